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
from typing import Iterator, Sequence

import mujoco
import numpy as np

from mjx_cascade import bundle, evaluate, robots
from mjx_cascade.config import Config
from mjx_cascade.progress import Batches, Tick
from mjx_cascade.robots import scene
from mjx_cascade.robots.base import Robot
from mjx_cascade.runtime import Runtime
from mjx_cascade.scenario import Scenario

SIMULATOR = f"MuJoCo {mujoco.__version__} (C)"


def steps_of(scenario: Scenario, dt: float) -> tuple[int, int]:
    """`(physics steps per record, physics steps)` of `scenario`: `evaluate.Runner`'s, in whole records."""
    every = max(1, int(evaluate.RECORD_PERIOD / dt + 1e-9))
    return every, int(math.ceil(scenario.duration / (every * dt))) * every


def trajectory(rt: Runtime, scenario: Scenario, progress: Tick | None = None) -> dict:
    """Simulate `scenario` once with the runtime `rt` (whose model holds the scenario's terrain),
    telling `progress` the seconds simulated every tenth of the way."""
    m, dt = rt.robot.model, rt.dt
    every, steps = steps_of(scenario, dt)
    tenth = -(-steps // 10)
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
        if progress and ((n + 1) % tenth == 0 or n + 1 == steps):
            progress((n + 1) * dt)
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
                 progress: Batches | None = None) -> Iterator[tuple[Scenario, dict, Robot]]:
    """`(scenario, trajectory, the simulated robot)` for each of `scenarios`, in order; `progress`
    hears of each scenario as it starts and of its simulated seconds."""
    rts = runtimes(cfg, params, scenarios, model_path)
    for i, s in enumerate(scenarios):
        rt = rts[scene.terrain_key(s.terrain)]
        title = f"scenario {i + 1}/{len(scenarios)}: {s.name}"
        tick = progress(title, steps_of(s, rt.dt)[1] * rt.dt) if progress else None
        yield s, trajectory(rt, s, tick), rt.robot


def sim2sim(robot: str, scenarios: Sequence[Scenario], out: str | Path, checkpoint_dir: str | None = None,
            model_path: str | None = None, dt: float | None = None, video: bool = True,
            settings: dict | None = None, progress: Batches | None = None) -> list[dict]:
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
