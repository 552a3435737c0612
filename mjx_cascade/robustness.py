"""Robustness sweeps (Sec. VI-B3, Fig. 11-14): success rate against pushes, slopes, rough
ground and whole-robot mass error, every trial of a sweep in one jitted, vmapped call.

A trial walks at `speed` from standing for `seconds`, with no early termination. Trials of
one cell differ in their Table 5 model perturbation (link masses and centres of mass, drawn
as in training), their start (pool member, first stance foot) and, for pushes, the push's
time within one gait cycle: a random gait phase. Rough-ground trials also differ in the
bumps' seed. Success is the robustness bar's (`judge.robust`).

Trials run through the one simulator (`rollout.simulate`): those on the plane (pushes, mass) in
one call, those on height fields (slopes, rough ground) in another, each environment with its
own row of height-field data (`world.terrains`).
"""

from __future__ import annotations

import dataclasses
import datetime
import json
import time
from collections import Counter
from pathlib import Path
from typing import NamedTuple

import jax
import jax.numpy as jnp
import numpy as np

from mjx_cascade import _xla, judge, plots, policy, randomization, robots, rollout, world
from mjx_cascade.benchmark import code_version
from mjx_cascade.config import Config, ConfigError
from mjx_cascade.env import Env, make_env
from mjx_cascade.evaluate import RECORD_PERIOD, joint_layout, load_policy, policy_record
from mjx_cascade.physics import resolve_impl
from mjx_cascade.progress import Batches, Tick
from mjx_cascade.robots import scene

AXES = ("push", "slope", "rough", "mass")
DIRECTIONS = {"forward": (1.0, 0.0), "backward": (-1.0, 0.0), "left": (0.0, 1.0), "right": (0.0, -1.0)}


@dataclasses.dataclass(frozen=True)
class Sweep:
    """What a sweep tries. Forces in N, slopes in degrees, roughness in m, mass as a scale."""

    axes: tuple[str, ...] = AXES
    trials: int = 10  # per cell
    speed: float = 0.3  # commanded forward velocity, m/s
    seconds: float = 10.0
    push_forces: tuple[float, ...] = (0.0, 25.0, 50.0, 75.0, 100.0, 125.0, 150.0)
    push_directions: tuple[str, ...] = tuple(DIRECTIONS)  # a subset scans one direction's cells cheaply
    push_duration: float = 0.2
    push_after: float = 4.0  # s: pushes start within the gait cycle that follows
    slopes: tuple[float, ...] = (-11.0, -8.0, -5.0, -2.0, 0.0, 2.0, 5.0, 8.0, 11.0)
    roughness: tuple[float, ...] = (0.0, 0.01, 0.02, 0.03, 0.04)
    mass_scales: tuple[float, ...] = (0.8, 0.85, 0.9, 0.95, 1.0, 1.05, 1.1, 1.15, 1.2)
    bar: judge.RobustnessBar = judge.ROBUSTNESS
    seed: int = 0

    def __post_init__(self):
        unknown = sorted(set(self.axes) - set(AXES))
        if unknown or not self.axes:
            raise ConfigError(f"unknown sweep axis {unknown[0] if unknown else None!r}; choose from {', '.join(AXES)}")
        odd = sorted(set(self.push_directions) - set(DIRECTIONS))
        if odd:
            raise ConfigError(f"unknown push direction {odd[0]!r}; choose from {', '.join(DIRECTIONS)}")
        # a repeated force or direction would fold two cells into one of twice the trials
        if not self.push_directions or len(set(self.push_directions)) < len(self.push_directions):
            raise ConfigError("push directions must be one or more distinct names")
        forces = np.asarray(self.push_forces, dtype=float)
        if forces.size == 0 or not np.all(np.isfinite(forces) & (forces >= 0)) or np.unique(forces).size < forces.size:
            raise ConfigError("push forces must be one or more distinct finite values of at least 0 N")
        if self.trials < 1:
            raise ConfigError("trials must be at least 1")
        if not self.bar.judge_seconds < self.seconds:
            raise ConfigError("seconds must exceed judge_seconds")


class Trials(NamedTuple):
    """One row per trial (NumPy); `label` is (axis, level, direction or '')."""

    label: list
    cmd: np.ndarray  # [B, 3] vx, vy, yaw
    push_t: np.ndarray  # [B] s
    force: np.ndarray  # [B, 3] N, world frame
    mass: np.ndarray  # [B] whole-robot mass scale
    terrain: list  # [B] terrain dicts


def trials(sweep: Sweep, step_time: float) -> Trials:
    """Every trial of `sweep`; a push comes at a uniformly random phase of one gait cycle (two steps)."""
    rng = np.random.default_rng(sweep.seed)
    flat = {"type": "flat"}
    rows = []  # (label, push_t, force, mass, terrain)
    for axis in sweep.axes:
        for i in range(sweep.trials):
            if axis == "push":
                for f in sweep.push_forces:
                    for name in sweep.push_directions:
                        dx, dy = DIRECTIONS[name]
                        t = sweep.push_after + rng.uniform(0.0, 2 * step_time)
                        rows.append(((axis, f, name), t, (f * dx, f * dy, 0.0), 1.0, flat))
            for level in {"slope": sweep.slopes, "rough": sweep.roughness, "mass": sweep.mass_scales}.get(axis, ()):
                terrain = {"slope": {"type": "slope", "degrees": level},
                           "rough": {"type": "rough", "amplitude": level, "seed": i}}.get(axis, flat)
                rows.append(((axis, level, ""), np.inf, (0.0, 0.0, 0.0), level if axis == "mass" else 1.0, terrain))
    label, push_t, force, mass, terrain = zip(*rows)
    n = len(rows)
    return Trials(list(label), np.tile([sweep.speed, 0.0, 0.0], (n, 1)), np.array(push_t),
                  np.array(force), np.array(mass), list(terrain))


def simulate(env: Env, params: np.ndarray, t: Trials, sweep: Sweep, progress: Tick | None = None) -> dict:
    """Run trials `t` as one compiled batch, each on its own terrain (the env's model holds them all),
    telling `progress` the seconds simulated as they pass (`rollout.record_in_calls`).

    Returns `qpos [B, R, nq]`, `qvel [B, R, nv]`, `ground [B, R]` recorded every 10 ms and the
    record times `t [R]`.
    """
    cfg, dt = env.cfg, env.dt
    every = max(1, int(RECORD_PERIOD / dt + 1e-9))
    records = int(np.ceil(sweep.seconds / (every * dt)))
    rand = cfg.randomization if cfg.randomization.enabled else dataclasses.replace(cfg.randomization, mass=(1.0, 1.0), com=(1.0, 1.0))
    pushes = [[] if not np.isfinite(pt) else [(pt, sweep.push_duration, f)] for pt, f in zip(t.push_t, t.force)]
    sched = world.schedule([np.concatenate([[0.0], c])[None] for c in t.cmd], pushes, dt, records * every)

    def trial_world(keys, mass):  # each call draws the same models from the same keys
        k_model, k_reset = jax.vmap(jax.random.split)(keys).transpose(1, 0, 2)
        model = randomization.randomize(env.model, k_model, rand)
        model = model.tree_replace({"body_mass": model.body_mass * mass[:, None]})
        model, axes = world.terrains(env.robot.model, model, t.terrain, randomization.in_axes(env.model))
        return world.World(model, axes, sched), k_reset

    @jax.jit
    def start(params, keys, mass):
        batch, k_reset = trial_world(keys, mass)
        return rollout.start(env, params, k_reset, batch)

    @jax.jit
    def advance(params, keys, mass, carry, first):
        batch, _ = trial_world(keys, mass)
        return rollout.advance(env, params, carry, batch, records * every, every, first, rollout.per_call(records),
                               rollout.trajectory)

    p, keys = jnp.asarray(params), jax.random.split(jax.random.PRNGKey(sweep.seed), len(t.label))
    mass = jnp.asarray(t.mass, jnp.float32)
    seconds = None if progress is None else lambda done, _: progress(done * every * dt)
    qpos, qvel, ground, _ = rollout.record_in_calls(lambda carry, first: advance(p, keys, mass, carry, first),
                                                    start(p, keys, mass), records, seconds)
    swap = lambda x: np.swapaxes(np.asarray(x), 0, 1)  # noqa: E731
    return {"t": (np.arange(records) + 1) * every * dt, "qpos": swap(qpos), "qvel": swap(qvel), "ground": swap(ground)}


def run(cfg: Config, params: np.ndarray, sweep: Sweep, model_path: str | None = None,
        progress: Batches | None = None) -> tuple[dict, dict]:
    """`(results, trajectories)`: per-trial verdicts and success rates, and the recorded trials.
    `progress` hears of each batch (the trials on the plane, then those on height fields).

    `results["cells"]` maps each axis to rows `{level, direction, trials, successes, rate}`;
    `results["trials"]` lists every trial's label, push time and verdict.
    """
    t = trials(sweep, cfg.gait.step_time)
    network = policy.for_controller(cfg, len(robots.get(cfg.robot).learned), jax.random.PRNGKey(0))
    on_plane = np.array([tr["type"] == "flat" for tr in t.terrain])
    batches = [idx for idx in (np.nonzero(on_plane)[0], np.nonzero(~on_plane)[0]) if len(idx)]
    subs = [Trials([t.label[i] for i in idx], t.cmd[idx], t.push_t[idx], t.force[idx], t.mass[idx],
                   [t.terrain[i] for i in idx]) for idx in batches]
    kinds_of = [scene.distinct(sub.terrain) for sub in subs]
    # refused before any trial runs: the C engine finds out only at the height fields' first step
    if cfg.physics.impl == "mujoco" and any(len(kinds) > 1 for kinds in kinds_of):
        raise ConfigError("impl mujoco steps every trial of a batch on one terrain; slopes and rough "
                          "ground of several levels run with impl jax")
    traj = {}
    for b, (idx, sub, kinds) in enumerate(zip(batches, subs, kinds_of)):
        env = make_env(cfg, network.apply, model_path, terrain=kinds[0] if len(kinds) == 1 else kinds)
        title = f"batch {b + 1}/{len(batches)}: {describe(sub)}"
        out = simulate(env, params, sub, sweep, progress(title, sweep.seconds) if progress else None)
        for j, i in enumerate(idx):
            traj[i] = {k: out[k] if k == "t" else out[k][j] for k in out}
    verdicts = [judge.robust(traj[i]["t"], traj[i]["qpos"], traj[i]["qvel"], traj[i]["ground"], t.cmd[i], sweep.bar)
                for i in range(len(t.label))]
    return summarize(t, verdicts, sweep), {"trials": t, "traj": traj, **joint_layout(env.robot)}


def describe(t: Trials) -> str:
    """A batch in a few words: `370 trials on the plane: push 280, mass 90`."""
    ground = "the plane" if t.terrain[0]["type"] == "flat" else "height fields"
    axes = ", ".join(f"{axis} {count}" for axis, count in Counter(label[0] for label in t.label).items())
    return f"{len(t.label)} trials on {ground}: {axes}"


def summarize(t: Trials, verdicts: list[dict], sweep: Sweep) -> dict:
    cells: dict = {}
    for (axis, level, direction), v in zip(t.label, verdicts):
        row = cells.setdefault(axis, {}).setdefault((level, direction), [0, 0])
        row[0] += 1
        row[1] += int(v["success"])
    return {
        "sweep": dataclasses.asdict(sweep),
        "cells": {axis: [{"level": lv, "direction": d, "trials": n, "successes": s, "rate": s / n}
                         for (lv, d), (n, s) in rows.items()] for axis, rows in cells.items()},
        "trials": [{"axis": a, "level": lv, "direction": d,
                    "push_t": None if not np.isfinite(pt) else float(pt), **v}
                   for (a, lv, d), pt, v in zip(t.label, t.push_t, verdicts)],
    }


UNITS = {"push": ("push force", "N", 1.0), "slope": ("slope", "degrees", 1.0),
         "rough": ("rough-ground amplitude", "cm", 100.0), "mass": ("mass scale", "x", 1.0)}


def markdown(results: dict) -> str:
    """The success-rate tables, one per axis (pushes: one column per direction)."""
    out = []
    for axis, rows in results["cells"].items():
        name, unit, scale = UNITS[axis]
        dirs = list(dict.fromkeys(r["direction"] for r in rows))
        levels = list(dict.fromkeys(r["level"] for r in rows))
        cell = {(r["level"], r["direction"]): f"{r['successes']}/{r['trials']}" for r in rows}
        head = [f"{name} ({unit})"] + ([d for d in dirs] if dirs != [""] else ["success"])
        out += [f"| {' | '.join(head)} |", "|" + " --- |" * len(head)]
        out += [f"| {lv * scale:g} | " + " | ".join(cell[(lv, d)] for d in dirs) + " |" for lv in levels]
        out.append("")
    return "\n".join(out)


def figures(results: dict, sim: dict, out: Path, title: str) -> list[str]:
    """Fig. 11, 12 and 14 from the sweep's own trials; returns the files written.

    Pushes: per direction, the first trial at the strongest force it recovered from (else the
    strongest force). Terrains: the first trial of every level.
    """
    t, traj, verdicts = sim["trials"], sim["traj"], results["trials"]
    written = []

    def record(i):
        return {**traj[i], "cmd": t.cmd[i], **{k: sim[k] for k in ("joints", "joint_qpos", "joint_qvel")}}

    pushes = []
    for d in DIRECTIONS:
        mine = [i for i, v in enumerate(verdicts) if v["axis"] == "push" and v["direction"] == d and v["level"] > 0]
        if mine:
            won = [i for i in mine if verdicts[i]["success"]] or mine
            i = max(won, key=lambda k: (verdicts[k]["level"], -k))
            pushes.append((f"{d}, {verdicts[i]['level']:g} N", i))
    if pushes:
        dur = results["sweep"]["push_duration"]
        plots.push_response([(label, record(i), t.push_t[i], dur) for label, i in pushes],
                            out / "push_response.png", title=f"{title}: pushes")
        label, i = pushes[0]
        plots.push_limit_cycle(record(i), t.push_t[i], dur, out / "push_limit_cycle.png", title=f"{title}: {label} push")
        written += ["push_response.png", "push_limit_cycle.png"]
    groups = {}
    for axis in ("slope", "rough"):
        name, unit, scale = UNITS[axis]
        firsts = {}
        for i, v in enumerate(verdicts):
            if v["axis"] == axis:
                firsts.setdefault(v["level"], i)
        if firsts:
            groups[name] = [(f"{lv * scale:g} {unit}", record(i)) for lv, i in sorted(firsts.items())]
    if groups:
        plots.terrain_tracking(groups, out / "terrain_tracking.png", title=f"{title}: terrains")
        written.append("terrain_tracking.png")
    return written


def sweep(robot: str, out: str | Path, sweep_cfg: Sweep, checkpoint_dir: str | None = None,
          model_path: str | None = None, dt: float | None = None, impl: str | None = None,
          settings: dict | None = None, progress: Batches | None = None,
          plot: bool = True) -> tuple[dict, dict]:
    """Run the sweep with a checkpoint or the shipped policy and write `robustness.json`,
    `robustness.md` and, with `plot`, `robustness.png` and the Fig. 11, 12 and 14 plots into `out`.
    `settings` change the policy's controller (`evaluate.load_policy`); the results record them.
    `progress` hears of each batch and its simulated seconds.

    Returns `(results, trajectories)` as `run` does, the results with the run's provenance.
    """
    version = code_version()  # the code this process runs: taken before the hour-long part
    cfg, found = load_policy(robot, checkpoint_dir, dt, impl, settings)
    start = time.perf_counter()
    results, sim = run(cfg, found.params, sweep_cfg, model_path, progress)
    results = {
        "robot": robot,
        "device": jax.devices()[0].device_kind,
        "backend": jax.default_backend(),
        "impl": resolve_impl(cfg.physics.impl),
        "dt": cfg.physics.dt,
        "policy": policy_record(found, settings),
        "wall_clock_s": time.perf_counter() - start,
        "date": datetime.date.today().isoformat(),
        "code_version": version,
        "cpu": _xla.cpu_model() if jax.default_backend() == "cpu" else None,
        **results,
    }
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    title = f"{robot} (generation {found.generation}, dt {cfg.physics.dt:g} s)"
    results["figures"] = []
    if plot:
        plots.robustness(results, UNITS, out / "robustness.png", title=title)
        results["figures"] = ["robustness.png"] + figures(results, sim, out, robot)
    (out / "robustness.json").write_text(json.dumps(results, indent=2) + "\n")
    (out / "robustness.md").write_text(report(results))
    return results, sim


def report(results: dict) -> str:
    """`robustness.md`: how the sweep ran, then its tables."""
    s = results["sweep"]
    head = (f"# Robustness of {results['robot']}: success rate (no fall, and vx, vy within "
            f"{s['bar']['tolerance']} m/s over the last {s['bar']['judge_seconds']:g} s)\n\n"
            f"Policy generation {results['policy']['generation']} (sha256 {results['policy']['params_sha256'][:12]}); "
            f"{s['trials']} trials per cell walking at {s['speed']} m/s for {s['seconds']:g} s; "
            f"pushes of {s['push_duration']} s on the pelvis at a random phase after {s['push_after']:g} s; "
            f"dt {results['dt']} s on {results['device']} ({results['impl']}), {results['wall_clock_s']:.0f} s wall-clock.\n\n")
    changed = results["policy"].get("settings")
    if changed:  # results of a controller the policy did not train with say so first
        head += "Controller settings changed from the policy's config: " + ", ".join(
            f"`{k}={v}`" for k, v in changed.items()) + ".\n\n"
    return head + markdown(results)
