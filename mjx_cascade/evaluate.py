"""Run a trained policy through a scenario and judge it from the recorded trajectory alone.

`run` simulates one robot (no domain randomization, no early termination) at the requested
physics time step and records `t, qpos, qvel, cmd` (plus the applied force and the ground
height under the pelvis) at least every 10 ms. `tracking_metrics` reads only such a
trajectory: a fall (pelvis below 0.6 m above the ground or tilted beyond 0.6 rad), and in
every command segment of 4 s or more, after 2 s of settling, the mean absolute error of the
1-second moving average of the heading-frame pelvis velocity, and of the heading.
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Sequence

import jax
import jax.numpy as jnp
import numpy as np

from mjx_cascade import checkpoint, plots, policies
from mjx_cascade import video as video_lib
from mjx_cascade.rotations import tilt
from mjx_cascade.trajectory import heading_velocity, moving_average
from mjx_cascade.config import Config, ConfigError, from_dict
from mjx_cascade.scenario import Scenario
from mjx_cascade.env import make_env
from mjx_cascade.robots.base import Robot

RECORD_PERIOD = 0.01  # s
FALL_HEIGHT, FALL_TILT = 0.6, 0.6
BOUNDS = {"vx": 0.10, "vy": 0.10, "yaw": 0.15}


# What an evaluation may change about the policy's own config: the controller and the physics it
# runs in. The policy's shape (`policy.*`, `gait.bezier_order`) is fixed by its parameters, and the
# training-only sections (rewards, episode, ES, ...) do not act in an evaluation.
CONTROLLER_SECTIONS = ("gait", "regulators", "physics")
SHAPE_SETTINGS = ("gait.bezier_order",)


def check_controller_settings(settings: dict) -> None:
    """Refuse evaluation overrides outside the controller and physics (`CONTROLLER_SECTIONS`)."""
    for key in settings:
        if key.split(".")[0] not in CONTROLLER_SECTIONS or key in SHAPE_SETTINGS:
            raise ConfigError(f"an evaluation can change only {', '.join(s + '.*' for s in CONTROLLER_SECTIONS)} "
                              f"settings (not {', '.join(SHAPE_SETTINGS)}), got {key!r}")


def load_policy(robot: str, checkpoint_dir: str | None, dt: float | None = None,
                impl: str | None = None, settings: dict | None = None) -> tuple[Config, np.ndarray, dict]:
    """`(training config, flat parameters, metadata)` from a checkpoint, or the shipped policy.

    `dt` and `impl`, where given, replace the config's physics time step and backend; `settings`
    (`{"regulators.k_phr": 0.4, ...}`, the command line's `--set`) change the controller the same
    parameters run in, to measure what a setting does without retraining.
    """
    settings = dict(settings or {})
    check_controller_settings(settings)
    if checkpoint_dir:
        meta, params = checkpoint.read(checkpoint_dir)
        checkpoint.check_robot(meta, robot)
    else:
        meta, params = policies.load(robot)
    # the backend it trained on says nothing about where it runs now; --dt and --impl win over --set
    overrides = {"physics.impl": "auto", **settings}
    if impl:
        overrides["physics.impl"] = impl
    if dt is not None:
        overrides["physics.dt"] = dt
    return from_dict(meta["config"]).override(**overrides), params, meta


def policy_record(meta: dict, params: np.ndarray, settings: dict | None = None) -> dict:
    """What an evaluation's results say about the policy it ran: generation, parameter hash and
    the controller settings changed from its config."""
    return {"generation": meta.get("generation"), "params_sha256": checkpoint.params_sha256(params),
            "settings": dict(settings or {})}


class Runner:
    """`runner(params) -> [trajectory, ...]` for a batch of scenarios, compiled once for any
    number of policies.

    Every scenario of the batch runs in one vmapped simulation (they must share a terrain: it is
    part of the model), each from the same start, so a scenario's trajectory does not depend on
    the others in its batch. Shorter scenarios hold their last command to the batch's longest
    duration and are cut back to their own. Each trajectory is a dict of NumPy arrays; the policy
    parameters are an argument of the jitted simulation, so checking many checkpoints
    (`benchmarks/time_to_walk.py`) compiles once. `robot` is the simulated robot, its model
    including the scenarios' terrain.
    """

    def __init__(self, cfg: Config, scenarios: Sequence[Scenario], model_path: str | None = None):
        scenarios = list(scenarios)
        if not scenarios:
            raise ConfigError("no scenario to run")
        if any(s.terrain != scenarios[0].terrain for s in scenarios):
            raise ConfigError("the scenarios of one batch must share a terrain")
        cfg = cfg.override(**{"randomization.enabled": False})
        self.env = env = make_env(cfg, batch=1, model_path=model_path, terrain=scenarios[0].terrain)
        self.robot = env.robot
        self.scenarios = scenarios
        self.every = every = max(1, int(RECORD_PERIOD / env.dt + 1e-9))
        self.records = [int(np.ceil(s.duration / (every * env.dt))) for s in scenarios]
        records = max(self.records)
        self.times = (np.arange(records * every) + 1) * env.dt  # the time at the end of each physics step
        self.cmd = np.stack([s.command_schedule(self.times - env.dt) for s in scenarios]).reshape(-1, records, every, 3)
        self.force = np.stack([s.force_schedule(self.times - env.dt) for s in scenarios]).reshape(-1, records, every, 3)

        def simulate(params, cmd, force):
            state = env.reset(params, jax.random.PRNGKey(0), cmd[0, 0])

            def record(state, inputs):
                def physics(state, x):
                    return env.step(params, state, x[0], x[1]), None

                state, _ = jax.lax.scan(physics, state, inputs)
                obs = env.observe(state.data)
                return state, (state.data.qpos, state.data.qvel, obs.ground, state.ctrl.stance)

            return jax.lax.scan(record, state, (cmd, force))[1]

        if len(scenarios) == 1:  # unbatched: on a 2-core CPU it compiled in 22 s, against 30 s vmapped
            one = jax.jit(simulate)
            self._simulate = lambda p, c, f: jax.tree.map(lambda x: x[None], one(p, c[0], f[0]))
        else:
            self._simulate = jax.jit(jax.vmap(simulate, in_axes=(None, 0, 0)))
        self._inputs = jnp.asarray(self.cmd, jnp.float32), jnp.asarray(self.force, jnp.float32)

    def __call__(self, params: np.ndarray) -> list[dict]:
        env, robot = self.env, self.robot
        if params.shape[0] != env.init_params.shape[0]:
            raise ConfigError(f"the policy has {params.shape[0]} parameters; this robot's policy needs "
                              f"{env.init_params.shape[0]}")
        qpos, qvel, ground, stance = jax.device_get(self._simulate(jnp.asarray(params), *self._inputs))
        t = self.times[self.every - 1::self.every]  # exact step counts x dt (MJX's float32 clock drifts)
        return [{
            "t": t[:n],
            "qpos": np.asarray(qpos[i, :n]),
            "qvel": np.asarray(qvel[i, :n]),
            "cmd": self.cmd[i, :n, -1],
            "force": self.force[i, :n, -1],
            "ground": np.asarray(ground[i, :n]),
            "stance": np.asarray(stance[i, :n]),
            "dt": np.float64(env.dt),
            **joint_layout(robot),
        } for i, n in enumerate(self.records)]


def joint_layout(robot: Robot) -> dict:
    """Names and qpos/qvel addresses of the actuated joints, for the trajectory's plots."""
    return {
        "joints": np.array([robot.model.actuator(int(a)).name for a in robot.actuator.ravel()]),
        "joint_qpos": robot.qpos_adr.ravel(),
        "joint_qvel": robot.dof_adr.ravel(),
    }


def runners(cfg: Config, scenarios: Sequence[Scenario], model_path: str | None = None) -> list[Runner]:
    """One `Runner` per terrain among `scenarios`, each batching every scenario on that terrain."""
    batches: dict[str, list[Scenario]] = {}
    for s in scenarios:
        batches.setdefault(json.dumps(s.terrain, sort_keys=True), []).append(s)
    return [Runner(cfg, batch, model_path) for batch in batches.values()]


def run(cfg: Config, params: np.ndarray, scenario: Scenario, model_path: str | None = None) -> dict:
    """Simulate `scenario` once; returns the trajectory as a dict of NumPy arrays."""
    return Runner(cfg, [scenario], model_path)(np.asarray(params))[0]


def fallen(qpos: np.ndarray, ground: np.ndarray) -> np.ndarray:
    """[T] bool: the pelvis below 0.6 m above the ground, tilted beyond 0.6 rad, or non-finite."""
    return (qpos[:, 2] - ground < FALL_HEIGHT) | (tilt(qpos[:, 3:7]) > FALL_TILT) | ~np.all(np.isfinite(qpos), axis=1)


def tracking_metrics(traj: dict, settle: float = 2.0, min_segment: float = 4.0, window: float = 1.0) -> dict:
    """Fall and per-segment tracking errors, from `t, qpos, qvel, cmd` (and `ground` if present)."""
    t, qpos, qvel, cmd = (np.asarray(traj[k]) for k in ("t", "qpos", "qvel", "cmd"))
    fell_at = fallen(qpos, np.asarray(traj["ground"]) if "ground" in traj else np.zeros_like(t))
    v, yaw = heading_velocity(qpos, qvel)
    v_avg = moving_average(v, t, window)
    change = np.nonzero(np.any(np.diff(cmd, axis=0) != 0, axis=1))[0] + 1
    bounds = np.concatenate([[0], change, [len(t)]])
    segments = []
    period = t[1] - t[0] if len(t) > 1 else 0.0
    for a, b in zip(bounds[:-1], bounds[1:]):
        t0 = t[a] - period  # each record ends a period that its command held throughout
        t1 = t[b - 1]
        seg = {"t_start": float(max(t0, 0.0)), "t_end": float(t1), "cmd": cmd[a].tolist()}
        judged = (t >= t0 + settle) & (np.arange(len(t)) >= a) & (np.arange(len(t)) < b)
        if t1 - t0 >= min_segment - 1e-6 and judged.any():
            err_yaw = np.angle(np.exp(1j * (yaw[judged] - cmd[judged, 2])))
            seg.update(
                vx_mae=float(np.mean(np.abs(v_avg[judged, 0] - cmd[judged, 0]))),
                vy_mae=float(np.mean(np.abs(v_avg[judged, 1] - cmd[judged, 1]))),
                yaw_mae=float(np.mean(np.abs(err_yaw))),
            )
            seg["within_bounds"] = bool(seg["vx_mae"] <= BOUNDS["vx"] and seg["vy_mae"] <= BOUNDS["vy"]
                                        and seg["yaw_mae"] <= BOUNDS["yaw"])
        segments.append(seg)
    judged_segments = [s for s in segments if "within_bounds" in s]
    fell = bool(fell_at.any())
    return {
        "fell": fell,
        "fall_time": float(t[np.argmax(fell_at)]) if fell else None,
        "segments": segments,
        "passed": (not fell) and all(s["within_bounds"] for s in judged_segments),
        "bounds": BOUNDS,
    }


def evaluate(robot: str, scenarios: Sequence[Scenario], out: str | Path, checkpoint_dir: str | None = None,
             model_path: str | None = None, dt: float | None = None, impl: str | None = None,
             video: bool = True, settings: dict | None = None) -> list[dict]:
    """Run `scenarios` and write, for each, `trajectory.npz`, `metrics.json`, PNG plots and, where
    MuJoCo can render, `video.gif` (`metrics["video"]` names the file or says why there is none).

    One scenario writes into `out`; several write into `out/<name>/`, plus `out/summary.json`
    (each scenario's verdict). Scenarios that share a terrain run in one vmapped call. `settings`
    change the policy's controller (`load_policy`); each metrics file records them.
    """
    scenarios = list(scenarios)
    names = [s.name for s in scenarios]
    if len(set(names)) != len(names):
        raise ConfigError("scenario names must differ (each writes into out/<name>/)")
    cfg, params, meta = load_policy(robot, checkpoint_dir, dt, impl, settings)
    out = Path(out)
    policy = policy_record(meta, params, settings)
    results = {}
    for runner in runners(cfg, scenarios, model_path):
        for scenario, traj in zip(runner.scenarios, runner(params)):
            where = out if len(scenarios) == 1 else out / scenario.name
            results[scenario.name] = _write(robot, scenario, traj, policy, where, runner.robot if video else None)
    metrics = [results[n] for n in names]
    if len(scenarios) > 1:
        summary = [{"scenario": m["scenario"]["name"], "passed": m["passed"], "fell": m["fell"],
                    "fall_time": m["fall_time"]} for m in metrics]
        (out / "summary.json").write_text(json.dumps({"policy": policy, "scenarios": summary}, indent=2) + "\n")
    return metrics


def _write(robot: str, scenario: Scenario, traj: dict, policy: dict, out: Path, render: Robot | None) -> dict:
    """One scenario's files; `render` is the simulated robot when a video is wanted."""
    metrics = {
        "robot": robot,
        "scenario": scenario.to_dict(),
        "dt": float(traj["dt"]),
        "policy": policy,
        **tracking_metrics(traj),
    }
    out.mkdir(parents=True, exist_ok=True)
    np.savez_compressed(out / "trajectory.npz", **traj)
    plots.tracking(traj, out / "tracking.png", title=f"{robot}: {scenario.name}")
    plots.limit_cycles(traj, out / "limit_cycles.png", title=f"{robot}: {scenario.name}")
    if render is not None:
        note = video_lib.render(traj, render.model, out / "video.gif", render.pelvis_body)
        metrics["video"] = note or "video.gif"
    (out / "metrics.json").write_text(json.dumps(metrics, indent=2) + "\n")
    return metrics
