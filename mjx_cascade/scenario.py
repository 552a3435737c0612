"""Evaluation scenarios: a JSON file of piecewise-constant commands, pushes and a terrain.

    {"name": "walk", "duration": 20,
     "commands": [{"t": 0, "vx": 0.3, "vy": 0, "yaw": 0}, ...],
     "pushes": [{"t": 5, "duration": 0.2, "force": [60, 0, 0]}],
     "terrain": {"type": "flat"} | {"type": "slope", "degrees": 8} | {"type": "rough", "amplitude": 0.02, "seed": 0}}

Commands hold from their `t` until the next one (times increase from 0); velocities are in
the heading frame, `yaw` is the desired heading in the world. Forces are in the world frame
and act on the pelvis. The robot starts standing at the origin facing +x.
"""

from __future__ import annotations

import dataclasses
import importlib.resources
import json
import math
from pathlib import Path
from typing import Any

import numpy as np

from mjx_cascade.config import ConfigError

TERRAINS = {"flat": set(), "slope": {"degrees"}, "rough": {"amplitude", "seed"}}


@dataclasses.dataclass(frozen=True)
class Push:
    t: float
    duration: float
    force: tuple[float, float, float]


@dataclasses.dataclass(frozen=True)
class Scenario:
    name: str
    duration: float
    commands: tuple[tuple[float, float, float, float], ...]  # (t, vx, vy, yaw)
    pushes: tuple[Push, ...]
    terrain: dict

    def command_schedule(self, times: np.ndarray) -> np.ndarray:
        """[len(times), 3] commanded (vx, vy, yaw) at each time."""
        starts = np.array([c[0] for c in self.commands])
        values = np.array([c[1:] for c in self.commands], dtype=np.float64)
        return values[np.searchsorted(starts, times, side="right") - 1]

    def force_schedule(self, times: np.ndarray) -> np.ndarray:
        """[len(times), 3] external force on the pelvis at each time."""
        force = np.zeros((len(times), 3))
        for p in self.pushes:
            on = (times >= p.t) & (times < p.t + p.duration)
            force[on] += p.force
        return force

    def to_dict(self) -> dict:
        return {
            "name": self.name,
            "duration": self.duration,
            "commands": [dict(zip(("t", "vx", "vy", "yaw"), c)) for c in self.commands],
            "pushes": [{"t": p.t, "duration": p.duration, "force": list(p.force)} for p in self.pushes],
            "terrain": self.terrain,
        }


def shipped() -> list[str]:
    """The names of the scenarios that ship with the package (`configs/scenarios/`)."""
    return sorted(p.name[:-5] for p in _shipped_dir().iterdir() if p.name.endswith(".json"))


def _shipped_dir():
    return importlib.resources.files("mjx_cascade.configs").joinpath("scenarios")


def resolve(name: str | Path) -> Path:
    """A scenario file: `name` itself when it is a file, else the shipped scenario of that name
    (`speed_profile`), so the shipped ones work from any directory."""
    path = Path(name)
    if path.is_file():
        return path
    names = shipped()
    if str(name) in names:
        return Path(str(_shipped_dir().joinpath(f"{name}.json")))
    raise ConfigError(f"scenario file not found: {name} (shipped scenarios: {', '.join(names)})")


def load(path: str | Path) -> Scenario:
    path = resolve(path)
    try:
        data = json.loads(path.read_text())
    except (json.JSONDecodeError, UnicodeDecodeError) as e:
        raise ConfigError(f"scenario {path} is not valid JSON: {e}") from None
    return parse(data, default_name=path.stem)


def parse(data: Any, default_name: str = "scenario") -> Scenario:
    _mapping(data, "scenario", required={"duration", "commands"},
             optional={"name", "pushes", "terrain"})
    duration = _number(data["duration"], "duration")
    if duration <= 0:
        raise ConfigError(f"scenario duration must be positive, got {duration}")
    name = data.get("name", default_name)
    if not isinstance(name, str):
        raise ConfigError("scenario name must be a string")
    return Scenario(
        name=name,
        duration=duration,
        commands=_commands(data["commands"], duration),
        pushes=tuple(_push(p, i) for i, p in enumerate(_list(data.get("pushes", []), "pushes"))),
        terrain=_terrain(data.get("terrain", {"type": "flat"})),
    )


def _commands(items: Any, duration: float) -> tuple:
    items = _list(items, "commands")
    if not items:
        raise ConfigError("scenario needs at least one command")
    out = []
    for i, c in enumerate(items):
        _mapping(c, f"commands[{i}]", required={"t", "vx", "vy", "yaw"})
        out.append(tuple(_number(c[k], f"commands[{i}].{k}") for k in ("t", "vx", "vy", "yaw")))
    if out[0][0] != 0:
        raise ConfigError(f"the first command must be at t = 0, got {out[0][0]}")
    for a, b in zip(out, out[1:]):
        if b[0] <= a[0]:
            raise ConfigError(f"command times must increase: {b[0]} follows {a[0]}")
    if out[-1][0] >= duration:
        raise ConfigError(f"command at t = {out[-1][0]} is not before the end of the scenario ({duration} s)")
    return tuple(out)


def _push(p: Any, i: int) -> Push:
    _mapping(p, f"pushes[{i}]", required={"t", "duration", "force"})
    t, dur = _number(p["t"], f"pushes[{i}].t"), _number(p["duration"], f"pushes[{i}].duration")
    if t < 0:
        raise ConfigError(f"pushes[{i}].t must be >= 0, got {t}")
    if dur < 0:
        raise ConfigError(f"pushes[{i}].duration must be >= 0, got {dur}")
    force = _list(p["force"], f"pushes[{i}].force")
    if len(force) != 3:
        raise ConfigError(f"pushes[{i}].force must be [fx, fy, fz]")
    return Push(t, dur, tuple(_number(f, f"pushes[{i}].force") for f in force))


def _terrain(t: Any) -> dict:
    if not isinstance(t, dict) or "type" not in t:
        raise ConfigError('terrain must be an object with a "type"')
    kind = t["type"]
    if kind not in TERRAINS:
        raise ConfigError(f"unknown terrain type {kind!r}; choose from {', '.join(TERRAINS)}")
    _mapping(t, "terrain", required={"type"} | TERRAINS[kind])
    out = {"type": kind}
    if kind == "slope":
        out["degrees"] = _number(t["degrees"], "terrain.degrees")
        if abs(out["degrees"]) >= 30:
            raise ConfigError("terrain.degrees must be within (-30, 30)")
    if kind == "rough":
        out["amplitude"] = _number(t["amplitude"], "terrain.amplitude")
        if not 0 <= out["amplitude"] <= 0.2:
            raise ConfigError("terrain.amplitude must be in [0, 0.2] m")
        if isinstance(t["seed"], bool) or not isinstance(t["seed"], int):
            raise ConfigError("terrain.seed must be an integer")
        out["seed"] = t["seed"]
    return out


def _mapping(x: Any, where: str, required: set, optional: set = frozenset()) -> None:
    if not isinstance(x, dict):
        raise ConfigError(f"{where} must be a JSON object")
    unknown = sorted(set(x) - required - set(optional))
    if unknown:
        raise ConfigError(f"unknown key {unknown[0]!r} in {where}")
    missing = sorted(required - set(x))
    if missing:
        raise ConfigError(f"{where} is missing {missing[0]!r}")


def _list(x: Any, where: str) -> list:
    if not isinstance(x, list):
        raise ConfigError(f"{where} must be a JSON list")
    return x


def _number(x: Any, where: str) -> float:
    if isinstance(x, bool) or not isinstance(x, (int, float)) or not math.isfinite(x):
        raise ConfigError(f"{where} must be a finite number")
    return float(x)
