"""Walking profiles by role: the `dev`, `val` and `test` sets, and the command steps.

A set is drawn from a seed (`configs/sets.yaml`) over the robot's training command ranges
(`episode.vx`, `vy`, `yaw`): 20-s profiles from standing whose segments last 4, 5 or 6 s, each
segment's vx, vy and heading drawn uniformly over the full ranges, so reversals across the whole
range occur as a user makes them. The same seed draws the same profiles (NumPy's PCG64).

`steps` are the command steps a response time is measured on: each of vx, vy and the heading
held at one end of its range for `STEP_AT` s, then stepped to the other end. `starts` start from
standing into every corner and middle of the ranges at once (the first command a user gives).
"""

from __future__ import annotations

import importlib.resources
from typing import Any

import numpy as np
import yaml

from mjx_cascade.config import Config, ConfigError, robot_config
from mjx_cascade.scenario import Scenario, parse

ROLES = ("dev", "val", "test")
SEGMENT_SECONDS = (4.0, 5.0, 6.0)
DURATION = 20.0  # s
STEP_AT, STEP_DURATION = 6.0, 12.0  # s: the step, and the profile's end
STEP_CRUISE = 0.2  # m/s forward while vy or the heading steps: both are judged while walking
START_DURATION = 6.0  # s: 2 s to settle, then a 4-s segment the bar judges


def sets() -> dict[str, dict[str, dict[str, Any]]]:
    """`configs/sets.yaml`: robot -> role -> `{seed, count, ...}`."""
    text = importlib.resources.files("mjx_cascade.configs").joinpath("sets.yaml").read_text()
    return yaml.safe_load(text)


def draw(rng: np.random.Generator, name: str, ranges: dict[str, tuple[float, float]],
         duration: float = DURATION) -> dict:
    """One profile as scenario JSON: segments of 4 to 6 s (the last cut at `duration`), each
    with vx, vy and the heading (`yaw`, relative to the start) uniform over `ranges`."""
    t, commands = 0.0, []
    while t < duration:
        commands.append({"t": t, **{k: float(rng.uniform(*ranges[k])) for k in ("vx", "vy", "yaw")}})
        t += float(rng.choice(SEGMENT_SECONDS))
    return {"name": name, "duration": duration, "commands": commands}


def command_ranges(cfg: Config) -> dict[str, tuple[float, float]]:
    e = cfg.episode
    return {"vx": tuple(e.vx), "vy": tuple(e.vy), "yaw": tuple(e.yaw)}


def draw_set(robot: str, role: str) -> list[Scenario]:
    """The profiles of `robot`'s `role` set (`configs/sets.yaml`), named `<robot>_<role>NN`;
    `test:NAME` is the test set of another frozen policy of the robot (its `tests` entry NAME),
    named `<robot>_test_<NAME>NN`."""
    kind, _, policy = role.partition(":")
    if kind not in ROLES or (policy and kind != "test"):
        raise ConfigError(f"unknown set {role!r}; choose from {', '.join(ROLES + tuple(NAMED))} or test:NAME")
    entries = sets().get(robot, {})
    entry = entries.get("tests", {}).get(policy) if policy else entries.get(role)
    if entry is None:
        raise ConfigError(f"{robot} has no {role} set yet" + (
            ": it is drawn only after the policy it judges is frozen (configs/sets.yaml)" if kind == "test" else ""))
    rng = np.random.default_rng(entry["seed"])
    ranges = command_ranges(robot_config(robot))
    label = f"test_{policy}" if policy else role
    return [parse(draw(rng, f"{robot}_{label}{k:02d}", ranges)) for k in range(1, entry["count"] + 1)]


def test_sets() -> tuple[str, ...]:
    """`test:NAME` for every other frozen policy's test set in `configs/sets.yaml`."""
    return tuple(sorted({f"test:{name}" for entries in sets().values() for name in entries.get("tests", {})}))


def steps(robot: str) -> list[Scenario]:
    """Command steps across the full ranges: vx low <-> high, vy low <-> high (walking forward at
    `STEP_CRUISE`), and the heading low <-> high, each stepping at `STEP_AT` s."""
    ranges = command_ranges(robot_config(robot))
    cruise = float(np.clip(STEP_CRUISE, *ranges["vx"]))
    out = []
    for axis in ("vx", "vy", "yaw"):
        lo, hi = ranges[axis]
        for name, (a, b) in (("down", (hi, lo)), ("up", (lo, hi))):
            held = {"vx": cruise, "vy": 0.0, "yaw": 0.0}
            first, second = {**held, axis: a}, {**held, axis: b}
            out.append(parse({"name": f"{robot}_step_{axis}_{name}", "duration": STEP_DURATION,
                              "commands": [{"t": 0.0, **first}, {"t": STEP_AT, **second}]}))
    return out


def starts(robot: str) -> list[Scenario]:
    """From standing into one command held for `START_DURATION` s: vx at both ends of its range,
    their halves and 0, each with vy at either end or 0 and the heading at either end or 0 (45)."""
    ranges = command_ranges(robot_config(robot))
    lo, hi = ranges["vx"]
    grid = [(vx, vy, yaw) for vx in (lo, lo / 2, 0.0, hi / 2, hi)
            for vy in (ranges["vy"][0], 0.0, ranges["vy"][1]) for yaw in (ranges["yaw"][0], 0.0, ranges["yaw"][1])]
    return [parse({"name": f"{robot}_start{k:02d}", "duration": START_DURATION,
                   "commands": [{"t": 0.0, "vx": float(vx), "vy": float(vy), "yaw": float(yaw)}]})
            for k, (vx, vy, yaw) in enumerate(grid, 1)]


NAMED = {"steps": steps, "starts": starts}  # the sets that are not drawn, by name


def resolve(robot: str, name: str) -> list[Scenario]:
    """The scenarios of a named set: `dev`, `val`, `test` (or `test:NAME`), `steps` or `starts`."""
    return NAMED[name](robot) if name in NAMED else draw_set(robot, name)
