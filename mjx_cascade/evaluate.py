"""Run a trained policy through scenarios and judge it from the recorded trajectory alone.

Scenarios run in batches through the one simulator (`rollout.simulate`): those on the plane in
one, those on height fields in another (each environment with its own row of height-field data),
all from the same standing start, with no domain randomization. Each records `t, qpos, qvel, cmd`
(plus the applied force, the ground height under the pelvis and the stance foot) every 10 ms;
`judge.walking` reads only such a trajectory.
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Callable, Sequence

import jax
import jax.numpy as jnp
import numpy as np

from mjx_cascade import bundle, checkpoint, judge, plots, policies, policy, robots, rollout, world
from mjx_cascade import video as video_lib
from mjx_cascade.config import Config, ConfigError, check_controller_settings
from mjx_cascade.env import make_env
from mjx_cascade.progress import Batches, Tick
from mjx_cascade.robots import scene
from mjx_cascade.robots.base import Robot
from mjx_cascade.scenario import Scenario

RECORD_PERIOD = 0.01  # s


def load_policy(robot: str, checkpoint_dir: str | None = None, dt: float | None = None, impl: str | None = None,
                settings: dict | None = None) -> tuple[Config, policies.Policy]:
    """`(the config to run, the policy)` from a checkpoint, policy directory or bundle, or the shipped one.

    `dt` and `impl`, where given, replace the physics time step and backend; `settings`
    (`{"regulators.k_phr": 0.4, ...}`, the command line's `--set`) change the controller the same
    parameters run in, to measure what a setting does without retraining.
    """
    settings = dict(settings or {})
    check_controller_settings(settings)
    found = bundle.load(checkpoint_dir) if checkpoint_dir and bundle.is_bundle(checkpoint_dir) else \
        policies.load(checkpoint_dir or robot)
    checkpoint.check_robot(found.record, robot)
    # the backend it trained on says nothing about where it runs now; --dt and --impl win over --set
    overrides = {"physics.impl": "auto", **settings}
    if impl:
        overrides["physics.impl"] = impl
    if dt is not None:
        overrides["physics.dt"] = dt
    return found.config.override(**overrides), found


def policy_record(found: policies.Policy, settings: dict | None = None) -> dict:
    """What an evaluation's results say about the policy it ran: generation, parameter hash, the
    revisions it runs with and the settings changed for this evaluation."""
    return {"generation": found.generation, "params_sha256": checkpoint.params_sha256(found.params),
            "revisions": [r["settings"] for r in found.revisions], "settings": dict(settings or {})}


class Runner:
    """`runner(params, progress) -> [trajectory, ...]` for a batch of scenarios, compiled once for any policy.

    Shorter scenarios hold their last command to the batch's longest duration and are cut back to
    their own. Each trajectory is a dict of NumPy arrays. `env.robot` is the simulated robot, its
    model holding the scenarios' terrains.
    """

    def __init__(self, cfg: Config, scenarios: Sequence[Scenario], model_path: str | None = None):
        self.scenarios = scenarios = list(scenarios)
        if not scenarios:
            raise ConfigError("no scenario to run")
        kinds = scene.distinct([s.terrain for s in scenarios])
        network = policy.for_controller(cfg, len(robots.get(cfg.robot).learned), jax.random.PRNGKey(0))
        self.env = env = make_env(cfg, network.apply, model_path, terrain=kinds[0] if len(kinds) == 1 else kinds)
        self.num_params = network.num_params
        self.every = every = max(1, int(RECORD_PERIOD / env.dt + 1e-9))
        self.records = [int(np.ceil(s.duration / (every * env.dt))) for s in scenarios]
        self.chunks = chunks = max(self.records)
        self.times = (np.arange(chunks * every) + 1) * env.dt  # the time at the end of each physics step
        shape = (len(scenarios), chunks, every, 3)
        self.cmd = np.stack([s.command_schedule(self.times - env.dt) for s in scenarios]).reshape(shape)
        self.force = np.stack([s.force_schedule(self.times - env.dt) for s in scenarios]).reshape(shape)
        schedule = world.schedule([np.array(s.commands) for s in scenarios],
                                  [[(p.t, p.duration, p.force) for p in s.pushes] for s in scenarios],
                                  env.dt, chunks * every)
        model, axes = world.terrains(env.robot.model, env.model, [s.terrain for s in scenarios])
        batch = world.World(model, axes, schedule)
        key = jax.random.PRNGKey(0)  # every scenario starts alike
        steps, per_call = chunks * every, rollout.per_call(chunks)
        self._start = jax.jit(lambda p: rollout.start(env, p, key, batch))
        self._advance = jax.jit(lambda p, carry, first: rollout.advance(
            env, p, carry, batch, steps, every, first, per_call, rollout.trajectory))

    @property
    def seconds(self) -> float:
        """The seconds the batch simulates: its longest scenario's, in whole records."""
        return self.chunks * self.every * self.env.dt

    def __call__(self, params: np.ndarray, progress: Tick | None = None, stop_at_miss: bool = False) -> list[dict]:
        """The batch's trajectories under `params`, telling `progress` the seconds simulated as they
        pass (`rollout.record_in_calls`: the same numbers with or without it). With `stop_at_miss`
        the simulation stops after the first tenth in which a scenario missed the bar
        (`verdict_so_far`), and the trajectories end there (shorter than their scenarios)."""
        env = self.env
        if params.shape[0] != self.num_params:
            raise ConfigError(f"the policy has {params.shape[0]} parameters; this robot's policy needs "
                              f"{self.num_params}")
        p = jnp.asarray(params)
        seconds = None if progress is None else lambda done, _: progress(done * self.every * env.dt)
        until = self._miss_watch() if stop_at_miss else None
        records = rollout.record_in_calls(lambda carry, first: self._advance(p, carry, first), self._start(p),
                                          self.chunks, seconds, until)
        return self._trajectories(records)

    def _trajectories(self, records: tuple) -> list[dict]:
        """Each scenario's trajectory from records `(qpos, qvel, ground, stance)` [records, B, ...],
        cut back to its own length."""
        qpos, qvel, ground, stance = (np.swapaxes(x, 0, 1) for x in records)
        t = self.times[self.every - 1::self.every]  # exact step counts x dt (MJX's float32 clock drifts)
        return [{
            "t": t[:n], "qpos": qpos[i, :n], "qvel": qvel[i, :n], "cmd": self.cmd[i, :n, -1],
            "force": self.force[i, :n, -1], "ground": ground[i, :n], "stance": stance[i, :n],
            "dt": np.float64(self.env.dt), **joint_layout(self.env.robot),
        } for i, n in enumerate(min(n, qpos.shape[1]) for n in self.records)]

    def _miss_watch(self) -> Callable[[tuple], bool]:
        """`until(records of a call)` for `rollout.record_in_calls`: whether a scenario has missed
        the bar in the records so far (`verdict_so_far`)."""
        parts = []

        def until(records: tuple) -> bool:
            parts.append(records)
            so_far = self._trajectories(tuple(np.concatenate(xs) for xs in zip(*parts)))
            return any(verdict_so_far(traj, len(traj["t"]) == n)["passed"] is False
                       for traj, n in zip(so_far, self.records))

        return until


def verdict_so_far(traj: dict, whole: bool) -> dict:
    """The walking bar's verdict `{passed, fell, fall_time, segments}` on a trajectory, or on the
    first part of one (`whole` false). A part has missed the bar (`passed` False) where it fell or
    where a segment it holds whole (one that a later command ended) is out of bounds; otherwise it
    is undecided (`passed` None). Its unfinished last segment is left unjudged: the 1-s average
    trails, so a finished segment's errors are the same in the part as in the whole trajectory.
    `segments` holds the judged segments only."""
    m = judge.walking(traj)
    segments = [seg for seg in (m["segments"] if whole else m["segments"][:-1]) if "within_bounds" in seg]
    if whole:
        passed = m["passed"]
    elif m["fell"] or not all(seg["within_bounds"] for seg in segments):
        passed = False
    else:
        passed = None
    return {"passed": passed, "fell": m["fell"], "fall_time": m["fall_time"], "segments": segments}


def joint_layout(robot: Robot) -> dict:
    """Names and qpos/qvel addresses of the actuated joints, for the trajectory's plots."""
    return {
        "joints": np.array([robot.model.actuator(int(a)).name for a in robot.actuator.ravel()]),
        "joint_qpos": robot.qpos_adr.ravel(),
        "joint_qvel": robot.dof_adr.ravel(),
    }


def runners(cfg: Config, scenarios: Sequence[Scenario], model_path: str | None = None) -> list[Runner]:
    """The batches of `scenarios`: one on the plane, one on height fields (each where there are any)."""
    plane = [s for s in scenarios if s.terrain["type"] == "flat"]
    fields = [s for s in scenarios if s.terrain["type"] != "flat"]
    return [Runner(cfg, batch, model_path) for batch in (plane, fields) if batch]


def check(batches: Sequence[Runner], params: np.ndarray, stop_at_miss: bool = False) -> dict[str, dict]:
    """The walking bar's verdict on one policy in every scenario of `batches` (`runners`), by name:
    `{passed, fell, fall_time, segments}`, the segments only those judged.

    With `stop_at_miss` a batch stops after the tenth of its simulation in which a scenario fell or
    finished a segment out of bounds, and every scenario is judged on what ran (`verdict_so_far`):
    the ones that missed fail, and the ones still undecided are left unjudged (`passed` None).
    Whether the policy passes them all is decided, at a fraction of the cost for one that misses."""
    results = {}
    for runner in batches:
        for s, traj, n in zip(runner.scenarios, runner(params, stop_at_miss=stop_at_miss), runner.records):
            results[s.name] = verdict_so_far(traj, len(traj["t"]) == n)
    return results


def run(cfg: Config, params: np.ndarray, scenario: Scenario, model_path: str | None = None) -> dict:
    """Simulate `scenario` once; returns the trajectory as a dict of NumPy arrays."""
    return Runner(cfg, [scenario], model_path)(np.asarray(params))[0]


def evaluate(robot: str, scenarios: Sequence[Scenario], out: str | Path, checkpoint_dir: str | None = None,
             model_path: str | None = None, dt: float | None = None, impl: str | None = None,
             video: bool = True, settings: dict | None = None, progress: Batches | None = None) -> list[dict]:
    """Run `scenarios` and write, for each, `trajectory.npz`, `metrics.json`, PNG plots and, where
    MuJoCo can render, `video.mp4` or `video.gif` (`metrics["video"]` names the file or says why
    there is none).

    One scenario writes into `out`; several write into `out/<name>/`, plus `out/summary.json`
    (each scenario's verdict). `settings` change the policy's controller (`load_policy`); each
    metrics file records them. `progress` hears of each batch and its simulated seconds.
    """
    scenarios = checked_names(scenarios)
    cfg, found = load_policy(robot, checkpoint_dir, dt, impl, settings)
    runs = {}
    batches = runners(cfg, scenarios, model_path)
    for i, runner in enumerate(batches):
        title = f"batch {i + 1}/{len(batches)}: {describe(runner.scenarios)}"
        tick = progress(title, runner.seconds) if progress else None
        for scenario, traj in zip(runner.scenarios, runner(found.params, tick)):
            runs[scenario.name] = (traj, runner.env.robot)
    return write(robot, scenarios, runs, policy_record(found, settings), Path(out), video)


def describe(scenarios: Sequence[Scenario]) -> str:
    """A batch in a few words: `3 scenarios on the plane (speed_profile, push, limit_cycle)`."""
    ground = "the plane" if scenarios[0].terrain["type"] == "flat" else "height fields"
    names = ", ".join(s.name for s in scenarios[:3]) + (", ..." if len(scenarios) > 3 else "")
    return f"{len(scenarios)} scenario{'s' * (len(scenarios) > 1)} on {ground} ({names})"


def checked_names(scenarios: Sequence[Scenario]) -> list[Scenario]:
    scenarios = list(scenarios)
    names = [s.name for s in scenarios]
    if len(set(names)) != len(names):
        raise ConfigError("scenario names must differ (each writes into out/<name>/)")
    return scenarios


def write(robot: str, scenarios: Sequence[Scenario], runs: dict[str, tuple[dict, Robot]], record: dict, out: Path,
          video: bool) -> list[dict]:
    """Each scenario's files from `runs` (its name -> (trajectory, the simulated robot)), in `out`
    for one scenario, else in `out/<name>/` with `out/summary.json`; returns the metrics."""
    metrics = [_write(robot, s, runs[s.name][0], record, out if len(scenarios) == 1 else out / s.name,
                      runs[s.name][1] if video else None) for s in scenarios]
    if len(scenarios) > 1:
        summary = {"policy": record, "dt": metrics[0]["dt"], "passed": sum(m["passed"] for m in metrics),
                   "fell": sum(m["fell"] for m in metrics), "scenarios": [verdict(m) for m in metrics]}
        (out / "summary.json").write_text(json.dumps(summary, indent=2) + "\n")
    return metrics


def verdict(m: dict) -> dict:
    """One scenario's line of `summary.json`: its verdict and worst judged errors."""
    judged = [s for s in m["segments"] if "within_bounds" in s]
    worst = {k: max((s[f"{k}_mae"] for s in judged), default=None) for k in ("vx", "vy", "yaw")}
    return {"scenario": m["scenario"]["name"], "passed": m["passed"], "fell": m["fell"], "fall_time": m["fall_time"],
            "worst": worst}


def _write(robot: str, scenario: Scenario, traj: dict, record: dict, out: Path, render: Robot | None) -> dict:
    """One scenario's files; `render` is the simulated robot when a video is wanted."""
    metrics = {"robot": robot, "scenario": scenario.to_dict(), "dt": float(traj["dt"]), "policy": record,
               **judge.walking(traj)}
    out.mkdir(parents=True, exist_ok=True)
    np.savez_compressed(out / "trajectory.npz", **traj)
    plots.tracking(traj, out / "tracking.png", title=f"{robot}: {scenario.name}")
    plots.limit_cycles(traj, out / "limit_cycles.png", title=f"{robot}: {scenario.name}")
    if render is not None:
        metrics["video"] = video_lib.render(traj, render.model, out, render.pelvis_body)
    (out / "metrics.json").write_text(json.dumps(metrics, indent=2) + "\n")
    return metrics
