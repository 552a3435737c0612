"""The walking benchmark: the walking bar and the response to command steps on a set of profiles,
in one compact result file that the README's results table is built from.

`walking` runs a policy through the scenarios in the evaluation's batches (MJX, `evaluate.runners`)
or one after another in MuJoCo's C engine (`sim2sim.trajectories`), judges each trajectory with
the walking bar (`judge.walking`) and gathers, for every command change, how long the 1-s average
velocity (the heading itself) took to settle within the bar's bound (`judge`'s `settle`). It writes

    {"robot", "set", "date", "code_version", "simulator", "device", "backend", "dt", "policy",
     "wall_clock_s", "passed", "fell", "count", "response", "scenarios": [{"scenario", "passed",
     "fell", "fall_time", "worst", "changes": [{"t", "axis", "from", "to", "settle"}]}]}

`response` holds, per axis, the number of command changes larger than the bar, the median and
worst settling times of those that settled, and how many had not settled when their segment ended.
"""

from __future__ import annotations

import datetime
import subprocess
import time
from pathlib import Path
from typing import Iterator, Sequence

import jax
import numpy as np

from mjx_cascade import evaluate, judge, physics, sim2sim
from mjx_cascade.config import Config
from mjx_cascade.progress import Batches
from mjx_cascade.scenario import Scenario

CHECKOUT = Path(__file__).resolve().parents[1]
AXES = {"vx": 0, "vy": 1, "yaw": 2}


def code_version() -> str:
    """`git describe` of the checkout the package runs from, `-dirty` with uncommitted changes,
    or the package version where it is not a checkout."""
    import mjx_cascade

    try:
        return subprocess.run(["git", "describe", "--always", "--dirty"], cwd=CHECKOUT, capture_output=True,
                              text=True, check=True).stdout.strip()
    except (OSError, subprocess.CalledProcessError):
        return f"mjx-cascade {mjx_cascade.__version__}"


def trajectories(cfg: Config, params: np.ndarray, scenarios: Sequence[Scenario], model_path: str | None,
                 simulator: str, progress: Batches | None = None) -> Iterator[tuple[Scenario, dict]]:
    """`(scenario, trajectory)` pairs from MJX in the evaluation's batches, or from MuJoCo C;
    `progress` hears of each batch (each scenario in MuJoCo C) and its simulated seconds."""
    if simulator == "mujoco":
        for s, traj, _ in sim2sim.trajectories(cfg, params, scenarios, model_path, progress):
            yield s, traj
        return
    batches = evaluate.runners(cfg, scenarios, model_path)
    for i, runner in enumerate(batches):
        title = f"batch {i + 1}/{len(batches)}: {evaluate.describe(runner.scenarios)}"
        yield from zip(runner.scenarios, runner(params, progress(title, runner.seconds) if progress else None))


def changes(segments: list[dict], bar: judge.WalkingBar = judge.WALKING) -> list[dict]:
    """Every command change larger than the bar's bound on its axis, with its settling time (s, or
    None where the segment ended first)."""
    bound = {"vx": bar.vx, "vy": bar.vy, "yaw": bar.yaw}
    out = []
    for before, seg in zip(segments, segments[1:]):
        for axis, i in AXES.items():
            if abs(seg["cmd"][i] - before["cmd"][i]) > bound[axis]:
                out.append({"t": seg["t_start"], "axis": axis, "from": before["cmd"][i], "to": seg["cmd"][i],
                            "settle": seg["settle"][axis]})
    return out


def response(rows: list[dict]) -> dict:
    """Per axis: `{changes, median_s, worst_s, unsettled}` over every row's changes."""
    out = {}
    for axis in AXES:
        times = [c["settle"] for r in rows for c in r["changes"] if c["axis"] == axis]
        settled = [t for t in times if t is not None]
        out[axis] = {"changes": len(times), "median_s": float(np.median(settled)) if settled else None,
                     "worst_s": max(settled, default=None), "unsettled": len(times) - len(settled)}
    return out


def walking(robot: str, scenarios: Sequence[Scenario], set_name: str, checkpoint: str | None = None,
            model_path: str | None = None, dt: float | None = None, simulator: str = "mjx",
            progress: Batches | None = None) -> dict:
    """Judge the policy (the shipped one unless `checkpoint`) on `scenarios`, the set `set_name`;
    `progress` hears of each batch as it runs."""
    version = code_version()  # the code this process runs: imported at its start
    cfg, found = evaluate.load_policy(robot, checkpoint, dt)
    start = time.perf_counter()
    rows = {}
    for s, traj in trajectories(cfg, found.params, scenarios, model_path, simulator, progress):
        m = judge.walking(traj)
        rows[s.name] = {**evaluate.verdict({"scenario": {"name": s.name}, **m}), "changes": changes(m["segments"])}
    rows = [rows[s.name] for s in scenarios]
    simulated = sim2sim.SIMULATOR if simulator == "mujoco" else f"MJX ({physics.resolve_impl(cfg.physics.impl)})"
    return {"robot": robot, "set": set_name, "date": datetime.date.today().isoformat(), "code_version": version,
            "simulator": simulated, "device": jax.devices()[0].device_kind, "backend": jax.default_backend(),
            "dt": cfg.physics.dt, "policy": evaluate.policy_record(found), "wall_clock_s": time.perf_counter() - start,
            "passed": sum(r["passed"] for r in rows), "fell": sum(r["fell"] for r in rows), "count": len(rows),
            "response": response(rows), "scenarios": rows}
