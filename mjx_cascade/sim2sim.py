"""Scenarios in MuJoCo's C engine (sim-to-sim): the policy outside MJX, judged as `eval` judges it.

Each scenario runs one `runtime.Runtime` tick per physics step on a plain `mujoco.MjData`, from
the standing state `eval` starts from, and records what `evaluate.Runner` records, at the same
times: `t, qpos, qvel, cmd, force, ground, stance` every `evaluate.RECORD_PERIOD`. Each physics
step's command and push are the scenario's at the step's start time, the steps that
`world.schedule` selects for MJX. The files are `eval`'s (`evaluate.write`).
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Callable, Iterator, Sequence

import mujoco
import numpy as np

from mjx_cascade import bundle, evaluate, robots
from mjx_cascade.config import Config
from mjx_cascade.robots import scene
from mjx_cascade.robots.base import Robot
from mjx_cascade.runtime import Runtime
from mjx_cascade.scenario import Scenario

Progress = Callable[[str], None]
SIMULATOR = f"MuJoCo {mujoco.__version__} (C)"


def trajectory(rt: Runtime, scenario: Scenario) -> dict:
    """Simulate `scenario` once with the runtime `rt` (whose model holds the scenario's terrain)."""
    m, dt = rt.robot.model, rt.dt
    every = max(1, int(evaluate.RECORD_PERIOD / dt + 1e-9))
    records = int(math.ceil(scenario.duration / (every * dt)))
    steps = records * every
    starts = (np.arange(steps) + 1) * dt - dt
    cmd, force = scenario.command_schedule(starts), scenario.force_schedule(starts)
    d = mujoco.MjData(m)
    rt.reset(d, cmd[0])
    pelvis = rt.robot.pelvis_body
    kept = {"qpos": [], "qvel": [], "ground": [], "stance": []}
    for n in range(steps):
        rt.control(d, cmd[n])
        d.xfrc_applied[pelvis, :3] = force[n]
        mujoco.mj_step(m, d)
        if (n + 1) % every == 0:
            for name, value in (("qpos", d.qpos.copy()), ("qvel", d.qvel.copy()), ("ground", rt.ground(d)),
                                ("stance", int(rt.state.stance))):
                kept[name].append(value)
    last = slice(every - 1, None, every)
    return {"t": ((np.arange(steps) + 1) * dt)[last], **{k: np.asarray(v) for k, v in kept.items()},
            "cmd": cmd[last], "force": force[last], "dt": np.float64(dt), **evaluate.joint_layout(rt.robot)}


def runtimes(cfg: Config, params: np.ndarray, scenarios: Sequence[Scenario], model_path: str | None = None
             ) -> dict[str, Runtime]:
    """One runtime per distinct terrain of `scenarios`, by `scene.terrain_key`."""
    out = {}
    for terrain in scene.distinct([s.terrain for s in scenarios]):
        robot = robots.build(robots.get(cfg.robot), cfg.physics, model_path, terrain)
        out[scene.terrain_key(terrain)] = Runtime(robot, cfg, params)
    return out


def trajectories(cfg: Config, params: np.ndarray, scenarios: Sequence[Scenario], model_path: str | None = None,
                 progress: Progress | None = None) -> Iterator[tuple[Scenario, dict, Robot]]:
    """`(scenario, trajectory, the simulated robot)` for each of `scenarios`, in order."""
    rts = runtimes(cfg, params, scenarios, model_path)
    for i, s in enumerate(scenarios):
        rt = rts[scene.terrain_key(s.terrain)]
        yield s, trajectory(rt, s), rt.robot
        if progress:
            progress(f"{i + 1}/{len(scenarios)} {s.name}")


def sim2sim(robot: str, scenarios: Sequence[Scenario], out: str | Path, checkpoint_dir: str | None = None,
            model_path: str | None = None, dt: float | None = None, video: bool = True,
            settings: dict | None = None, progress: Progress | None = None) -> list[dict]:
    """`eval` in MuJoCo C: run `scenarios` with the policy (the shipped one, a policy or checkpoint
    directory, or a bundle) and write `eval`'s files for each; returns the metrics."""
    scenarios = evaluate.checked_names(scenarios)
    cfg, found = evaluate.load_policy(robot, checkpoint_dir, dt, None, settings)
    if checkpoint_dir and bundle.is_bundle(checkpoint_dir):  # before the runtimes compile
        bundle.check(checkpoint_dir, robots.build(robots.get(cfg.robot), cfg.physics, model_path))
    runs = {s.name: (traj, sim_robot)
            for s, traj, sim_robot in trajectories(cfg, found.params, scenarios, model_path, progress)}
    record = {**evaluate.policy_record(found, settings), "simulator": SIMULATOR}
    return evaluate.write(robot, scenarios, runs, record, Path(out), video)
