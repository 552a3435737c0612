"""Training: ES over MJX episodes, several generations per jitted call, checkpointed and resumable.

One generation (draw the antithetic population, run every member's episode in one vmapped call,
rank, optax step) is a pure function of the ES state. `lax.scan` runs up to
`generations_per_call` of them per call, the last ones skipped by `lax.cond` when fewer are due,
so every call reuses one compiled program. The population axis is sharded over every local
device. `drive` is the one host loop: it calls the program and hands each call's metrics to a
callback (the command line's writes metrics, checkpoints and the loggers' records, and every
`train.eval_every` generations judges the ES mean on the validation profiles; the time-to-walk
benchmark checks the walking bar).
"""

from __future__ import annotations

import dataclasses
import json
import math
import shutil
import sys
import time
from pathlib import Path
from typing import Any, Callable, Sequence

import jax
import jax.numpy as jnp
import numpy as np
from jax.sharding import NamedSharding, PartitionSpec

from mjx_cascade import _xla, checkpoint, episodes, es, evaluate, loggers, plots, policies, policy, profiles, rewards, robots
from mjx_cascade.config import PAPER_DT, Config, ConfigError, differences, from_dict, get, to_dict
from mjx_cascade.env import Env, make_env
from mjx_cascade.scenario import Scenario

METRICS, CONFIG, CURVE, BEST, BEST_RECORD = "metrics.jsonl", "config.yaml", "learning_curve.png", "best", "best.json"
# What a resumed run may change without --accept-changes: how far and in what calls it goes, and
# how often it is checked, not what it trains (each generation's keys come from its index alone).
RESUMABLE = ("train.generations", "train.checkpoint_every", "train.generations_per_call", "train.eval_every")
WORST = ("vx", "vy", "yaw")  # the walking bar's errors: m/s, m/s, rad


@dataclasses.dataclass
class Trainer:
    cfg: Config
    env: Env
    network: policy.Network
    run: Callable  # (ESState, n_active) -> (ESState, metrics [L])
    state: es.ESState
    devices: int
    init: dict | None = None  # the warm start's policy: `params_sha256`, `generation`, `source`

    @property
    def num_params(self) -> int:
        return self.network.num_params


def population_sharding() -> tuple[NamedSharding, int]:
    devices = jax.devices()
    mesh = jax.make_mesh((len(devices),), ("pop",), axis_types=(jax.sharding.AxisType.Auto,))
    return NamedSharding(mesh, PartitionSpec("pop")), len(devices)


def generation_metrics(res: episodes.EpisodeResult, state: es.ESState, strategy: es.Strategy, env: Env) -> dict:
    """One generation's figures; `reward/<term>` is each reward term's mean over the live time."""
    chunk = env.cfg.episode.steps_per_check
    live_seconds = jnp.sum(res.steps.astype(jnp.float32)) * env.dt
    terms = jnp.sum(res.terms, axis=0) / jnp.maximum(live_seconds, env.dt)
    return {
        "fitness_mean": jnp.mean(res.fitness),
        "fitness_max": jnp.max(res.fitness),
        "fitness_min": jnp.min(res.fitness),
        "sigma": strategy.sigma(state.generation),
        "learning_rate": strategy.learning_rate(state.generation),
        "physics_steps": jnp.sum(res.steps.astype(jnp.float32)),
        "simulated_steps": jnp.ceil(jnp.max(res.steps) / chunk) * chunk * strategy.population,
        "episode_seconds_mean": jnp.mean(res.steps) * env.dt,
        "walking_steps_mean": jnp.mean(res.walking_steps),
        "terminated_fraction": jnp.mean(res.terminated),
        "diverged": jnp.sum(res.diverged),
        **{f"reward/{name}": terms[i] for i, name in enumerate(rewards.TERMS)},
    }


def make_generation(env: Env, strategy: es.Strategy) -> Callable:
    """`generation(state) -> (state, metrics)`: one full ES generation, jittable."""
    sharding, _ = population_sharding()

    def generation(state: es.ESState):
        keys = es.generation_keys(state)
        noise, members = es.ask(strategy, state, keys[es.NOISE])
        pair_keys = jax.random.split(keys[es.EPISODES], strategy.population // 2)
        keys = jnp.concatenate([pair_keys, pair_keys])  # both members of a pair face the same episode
        members = jax.lax.with_sharding_constraint(members, sharding)
        keys = jax.lax.with_sharding_constraint(keys, sharding)
        res = episodes.run(env, members, keys, state.generation)
        return es.tell(strategy, state, noise, res.fitness), generation_metrics(res, state, strategy, env)

    return generation


def make_run(env: Env, strategy: es.Strategy, per_call: int) -> Callable:
    # jitted so that `skip`'s shape query and `lax.cond` share one trace of the generation
    generation = jax.jit(make_generation(env, strategy))

    def skip(state):
        _, metrics = jax.eval_shape(generation, state)
        return state, jax.tree.map(lambda s: jnp.zeros(s.shape, s.dtype), metrics)

    def run(state: es.ESState, n_active: jax.Array):
        def body(state, i):
            return jax.lax.cond(i < n_active, generation, skip, state)

        return jax.lax.scan(body, state, jnp.arange(per_call))

    return jax.jit(run)


def setup(cfg: Config, model_path: str | None = None, init: str | Path | None = None) -> Trainer:
    """The trainer at generation 0, or warm-started from the policy at `init` (a run, or a policy
    directory), counting on from that policy's generation."""
    sharding, devices = population_sharding()
    check_devices(cfg, devices, jax.default_backend())
    key = jax.random.PRNGKey(cfg.seed)
    network = policy.for_controller(cfg, len(robots.get(cfg.robot).learned), key)
    start = _warm_start(cfg, network, init) if init is not None else None  # before the (slow) environment
    env = make_env(cfg, network.apply, model_path=model_path)
    strategy = es.make(cfg.es)
    params, generation = (network.init_params, 0) if start is None else (jnp.asarray(start[1]), start[0]["generation"])
    state = es.init(strategy, params, key, generation)
    record = None if start is None else {"params_sha256": checkpoint.params_sha256(start[1]),
                                         "generation": generation, "source": str(init)}
    return Trainer(cfg, env, network, make_run(env, strategy, cfg.train.generations_per_call), replicate(state),
                   devices, record)


def cpu_device_count(cfg: Config, value: str = "auto") -> int:
    """`--cpu-devices` for `cfg`: a count, or `auto`, one JAX device per core, as many as divide the
    population and the robot allows; one with the C engine, which threads each step over every
    core itself (`physics.CEngine`)."""
    limit = 1 if cfg.physics.impl == "mujoco" else robots.get(cfg.robot).max_cpu_devices
    return _xla.cpu_devices(value, cfg.es.population, limit)


def check_devices(cfg: Config, devices: int, backend: str) -> None:
    """Refuse a population the devices cannot share, and CPU splits known to hang for the robot."""
    if cfg.es.population % devices:
        raise ConfigError(f"es.population ({cfg.es.population}) must be a multiple of the {devices} devices")
    limit = robots.get(cfg.robot).max_cpu_devices
    if backend == "cpu" and limit is not None and devices > limit:
        raise ConfigError(f"{cfg.robot} trains on at most {limit} CPU device(s): on more it hung inside "
                          f"LAPACK's Cholesky (docs/faq.md); use --cpu-devices {limit}")


def _warm_start(cfg: Config, network: policy.Network, init: str | Path) -> tuple[dict, np.ndarray]:
    record, params = policies.read(init)
    checkpoint.check_compatible(record, cfg.robot, network.num_params)
    if int(record["generation"]) >= cfg.train.generations:
        raise ConfigError(f"--init is at generation {record['generation']}; train.generations "
                          f"({cfg.train.generations}) leaves nothing to train")
    return record, params


def replicate(state: es.ESState) -> es.ESState:
    """The ES state on every device. Fresh, restored and notebook states all get this one
    placement, so they all hit the same compiled program (and the same on-disk cache entry)."""
    return jax.device_put(state, NamedSharding(population_sharding()[0].mesh, PartitionSpec()))


def check_resume(cfg: Config, out: str | Path, accept_changes: bool = False) -> dict | None:
    """The changes `cfg` makes to the run in `out` (`{key: [saved, new]}`), or None for a new run.

    A resumed run keeps its config: any difference but `RESUMABLE` is refused, naming the first
    keys, unless `accept_changes`; then the checkpoint records it.
    """
    if not checkpoint.is_checkpoint_dir(Path(out) / "checkpoints"):
        return None
    meta, _ = checkpoint.read(out)
    checkpoint.check_resumable(meta, cfg.robot, policy.size(cfg, len(robots.get(cfg.robot).learned))[1])
    saved = from_dict(meta["config"])
    changed = [k for k in differences(saved, cfg) if k not in RESUMABLE]
    if changed and not accept_changes:
        shown = ", ".join(f"{k} ({get(saved, k)!r} -> {get(cfg, k)!r})" for k in changed[:3])
        raise ConfigError(f"{out} trained with another config: {shown}{' ...' if len(changed) > 3 else ''}; "
                          "pass --accept-changes to resume with the new one, or choose another --out")
    return {k: [get(saved, k), get(cfg, k)] for k in changed}


def metadata(trainer: Trainer, generation: int, physics_steps: float, wall_clock: float, history: list) -> dict:
    """The checkpoint's record of what produced it."""
    env = trainer.env
    return {
        "robot": trainer.cfg.robot,
        "generation": generation,
        "policy_params": trainer.num_params,
        "action_dim": trainer.network.module.action_dim,
        "state_dim": 6,
        "learned_joints": env.robot.learned_names,
        "physics_steps": physics_steps,
        "wall_clock_s": wall_clock,
        "devices": trainer.devices,
        "device_kind": jax.devices()[0].device_kind,
        "backend": jax.default_backend(),
        "impl": env.impl,
        "jax_version": jax.__version__,
        "versions": software_versions(),
        "cpu": _xla.cpu_model(),
        "reproducibility": "bitwise on the same devices and backend; on another device count or kind "
                           "within floating-point tolerance",
        "config": to_dict(trainer.cfg),
        **({"init": trainer.init} if trainer.init else {}),
        **({"config_changes": history} if history else {}),
    }


def software_versions() -> dict[str, str]:
    """The installed versions of the packages whose arithmetic a trained policy depends on."""
    from importlib import metadata as md

    def version(name: str) -> str:
        try:
            return md.version(name)
        except md.PackageNotFoundError:
            return "not installed"

    return {name: version(name) for name in ("mjx-cascade", "jax", "jaxlib", "mujoco", "mujoco-mjx", "flax",
                                             "optax", "numpy")}


def drive(trainer: Trainer, state: es.ESState, target: int, every: int,
          on_call: Callable[[es.ESState, list[dict], float], bool | None]) -> es.ESState:
    """Run generations from `state` up to `target`, each call ending at a multiple of `every` at the
    latest; after each, `on_call(state, rows, seconds)` gets one metrics row per generation (with
    its `generation`) and the call's wall-clock, and may return True to stop."""
    per_call = trainer.cfg.train.generations_per_call
    generation = int(state.generation)
    while generation < target:
        n = min(per_call, target - generation, (generation // every + 1) * every - generation)
        t_call = time.perf_counter()
        state, metrics = trainer.run(state, jnp.int32(n))
        metrics = jax.device_get(metrics)
        rows = [{"generation": generation + i + 1, **{k: float(v[i]) for k, v in metrics.items()}} for i in range(n)]
        generation += n
        if on_call(state, rows, time.perf_counter() - t_call):
            break
    return state


def _truncate_metrics(path: Path, generation: int) -> None:
    """Keep the lines of generations up to the checkpoint being resumed: a killed run may have
    logged later generations, or left half a line."""
    if not path.exists():
        return
    keep = []
    for line in path.read_text().splitlines():
        try:
            if json.loads(line)["generation"] <= generation:
                keep.append(line)
        except (json.JSONDecodeError, KeyError, TypeError):
            continue
    path.write_text("".join(f"{line}\n" for line in keep))


@dataclasses.dataclass
class _Run:
    """The running totals of one `train` call, carried across resumes in the checkpoints."""

    physics_steps: float = 0.0
    wall_clock: float = 0.0
    history: list = dataclasses.field(default_factory=list)  # config changes accepted on resume


def train(cfg: Config, out: str | Path, model_path: str | None = None, progress: bool | None = None,
          log: Callable[[str], None] | None = None, init: str | Path | None = None,
          accept_changes: bool = False, log_to: Sequence[str] = (),
          validation: Sequence[Scenario] | None = None) -> dict:
    """Train (or resume) into `out`: `out/checkpoints/`, `out/metrics.jsonl`, `out/learning_curve.png`
    (redrawn at every checkpoint, and when the run stops or is interrupted) and `out/config.yaml`
    (the resolved config of the latest start; `train --config` reads it back). Off a terminal,
    each call logs one progress line. `log_to` names the loggers (`loggers.KINDS`) that receive
    every metrics row too.

    Every `train.eval_every` generations the ES mean runs through the `validation` profiles (the
    robot's val set unless given) at the paper's time step; the check's figures join that
    generation's metrics row (`validation_row`), and the best check so far (`validation_score`)
    is kept as a policy directory in `out/best/` with `best.json` (its generation and verdicts).

    `init` warm-starts a new run from another run's policy (`setup`); a run that has a checkpoint
    resumes from it instead, keeping the warm start it began with, and refuses a changed config
    (`check_resume`). Physics steps and wall-clock count this run's only. Everything that can
    refuse the run (config, model, devices, `init`, loggers, validation profiles) is checked
    before `out` is written.
    """
    out = Path(out)
    log = log or (lambda msg: print(msg, file=sys.stderr))
    loggers.check(log_to)
    changes = check_resume(cfg, out, accept_changes)
    trainer = setup(cfg, model_path, None if changes is not None else init)
    checks = _Validation(validation_runners(cfg, model_path, validation), _best_score(out)) \
        if cfg.train.eval_every else None
    mngr = checkpoint.manager(out / "checkpoints")
    state, totals = _start(trainer, mngr, changes, init, log, out)
    write_config(cfg, out / CONFIG)
    _truncate_metrics(out / METRICS, int(state.generation))
    compile_s = _compile(trainer, state, log)
    sinks = loggers.make(log_to, out, to_dict(cfg))
    try:
        state = _train_loop(trainer, state, totals, mngr, out, progress, log, sinks, checks)
    finally:  # an interrupted run still leaves its curve so far
        for sink in sinks:
            sink.close()
        _learning_curve(cfg, out)
    if mngr.latest_step() != int(state.generation):  # nothing was due (already trained that far): still leave one
        generation = int(state.generation)
        checkpoint.save(mngr, generation, state, metadata(trainer, generation, totals.physics_steps,
                                                          totals.wall_clock, totals.history))
    return {"generation": int(state.generation), "physics_steps": totals.physics_steps,
            "wall_clock_s": totals.wall_clock, "compile_s": compile_s,
            "params_sha256": checkpoint.params_sha256(state.mean), "devices": trainer.devices,
            "impl": trainer.env.impl}


def _compile(trainer: Trainer, state: es.ESState, log: Callable[[str], None]) -> float:
    """Compile the training call once, before any generation runs; its seconds."""
    cfg, t0 = trainer.cfg, time.perf_counter()
    trainer.run = trainer.run.lower(state, jnp.int32(cfg.train.generations_per_call)).compile()
    compile_s = time.perf_counter() - t0
    log(f"compiled one call of {cfg.train.generations_per_call} generations in {compile_s:.1f} s "
        f"({trainer.env.impl}, {trainer.devices} {jax.default_backend()} device(s), population {cfg.es.population})")
    return compile_s


def write_config(cfg: Config, path: Path) -> None:
    """The resolved config as YAML that `train --config` reads back to the same config."""
    import yaml

    data = {k: v for k, v in to_dict(cfg).items() if k != "version"}
    path.write_text(yaml.safe_dump(data, sort_keys=False))


def _learning_curve(cfg: Config, out: Path) -> None:
    if (out / METRICS).is_file() and (out / METRICS).stat().st_size:
        plots.learning_curve(out / METRICS, out / CURVE, title=f"{cfg.robot}: fitness (Fig. 6)")


def _start(trainer: Trainer, mngr: Any, changes: dict | None, init: Any, log: Callable, out: Path
           ) -> tuple[es.ESState, _Run]:
    """The state to train from and the totals so far: a resumed checkpoint's, or a fresh start's."""
    if changes is None:
        if trainer.init:
            log(f"warm start from {init} (generation {trainer.init['generation']})")
        return trainer.state, _Run()
    state, meta = checkpoint.restore(mngr, trainer.state)
    trainer.init = meta.get("init")
    history = list(meta.get("config_changes", []))
    if changes:
        history.append({"generation": int(state.generation), "changes": changes})
        log(f"resuming {out} with changed settings: {', '.join(changes)}")
    log(f"resuming {out} at generation {int(state.generation)}")
    return replicate(state), _Run(float(meta["physics_steps"]), float(meta["wall_clock_s"]), history)


def _train_loop(trainer: Trainer, state: es.ESState, totals: _Run, mngr: Any, out: Path,
                progress: bool | None, log: Callable[[str], None], sinks: list[loggers.Logger],
                checks: _Validation | None) -> es.ESState:
    cfg = trainer.cfg
    report = _Report(cfg.train.generations, int(state.generation), progress, log)
    start, wall0 = time.perf_counter(), totals.wall_clock

    with (out / METRICS).open("a") as f:
        def on_call(state, rows, seconds):
            generation, last = rows[-1]["generation"], rows[-1]
            params, results = _check(checks, cfg, state, last)
            totals.wall_clock = wall0 + time.perf_counter() - start
            _log_rows(f, sinks, rows, totals, seconds)
            best = results is not None and (checks.best is None or validation_score(last) > checks.best)
            due = generation % cfg.train.checkpoint_every == 0 or generation == cfg.train.generations
            if due or best:
                meta = metadata(trainer, generation, totals.physics_steps, totals.wall_clock, totals.history)
            if best:
                _keep_best(out, checkpoint.record(meta, generation, params), params, last, results)
                checks.best = validation_score(last)
            if due:
                checkpoint.save(mngr, generation, state, meta)
                _learning_curve(cfg, out)
            report(rows, seconds, best)

        # every call ends where a checkpoint or a check is due
        every = math.gcd(cfg.train.checkpoint_every, cfg.train.eval_every)
        state = drive(trainer, state, cfg.train.generations, every, on_call)
    report.close()
    return state


def _check(checks: _Validation | None, cfg: Config, state: es.ESState, last: dict
           ) -> tuple[np.ndarray | None, dict | None]:
    """Where a check is due, run the ES mean through the validation profiles and add the figures to
    the call's last metrics row; the parameters checked and the verdicts, or Nones."""
    if not checks or last["generation"] % cfg.train.eval_every:
        return None, None
    t_check = time.perf_counter()
    params = np.asarray(jax.device_get(state.mean))
    results = evaluate.check(checks.runners, params)
    last.update(validation_row(results), **{"val/seconds": time.perf_counter() - t_check})
    return params, results


def _log_rows(f: Any, sinks: list[loggers.Logger], rows: list[dict], totals: _Run, seconds: float) -> None:
    """One call's metrics rows, with the run's totals so far, to `metrics.jsonl` and every logger."""
    steps = sum(r["physics_steps"] for r in rows)
    for row in rows:
        totals.physics_steps += row["physics_steps"]
        row.update(physics_steps_total=totals.physics_steps, wall_clock_s=totals.wall_clock,
                   samples_per_s=steps / seconds)
        f.write(json.dumps(row) + "\n")
    f.flush()
    for sink in sinks:
        for row in rows:
            sink.log(row, row["generation"])


class _Report:
    """Progress: a bar on a terminal, one plain line per call off it (or nothing when turned off)."""

    def __init__(self, total: int, initial: int, progress: bool | None, log: Callable[[str], None]):
        self.total, self.log = total, log
        self.bar = _progress(progress, total, initial)
        self.lines = progress is None and self.bar is None
        self.postfix = {}  # the bar's: the latest fitness, and the latest check's verdict

    def __call__(self, rows: list[dict], seconds: float, best: bool) -> None:
        last = rows[-1]
        steps = sum(r["physics_steps"] for r in rows)
        val = f"val passed {last['val/passed']}/{last['val/count']}" if "val/passed" in last else ""
        if self.lines:
            self.log(f"generation {last['generation']}/{self.total}: fitness {last['fitness_mean']:.3f}, "
                     f"{seconds:.1f} s, {steps / seconds:,.0f} samples/s"
                     + (f", {val} in {last['val/seconds']:.1f} s{' (best so far)' if best else ''}" if val else ""))
        if self.bar:
            self.postfix.update(fitness=f"{last['fitness_mean']:.3f}",
                                **({"val": f"{last['val/passed']}/{last['val/count']}"} if val else {}))
            self.bar.update(len(rows))
            self.bar.set_postfix(self.postfix)

    def close(self) -> None:
        if self.bar:
            self.bar.close()


@dataclasses.dataclass
class _Validation:
    """`train.eval_every`'s checks: the validation profiles' compiled batches, and the score of the
    best check so far (in `out/best/`, kept across resumes)."""

    runners: list[evaluate.Runner]
    best: tuple[int, float] | None


def validation_runners(cfg: Config, model_path: str | None = None,
                       scenarios: Sequence[Scenario] | None = None) -> list[evaluate.Runner]:
    """The evaluation batches of `scenarios` (default: the robot's val set, `profiles.draw_set`) at
    the paper's time step, built once for every check of the run (each compiles at its first)."""
    scenarios = profiles.draw_set(cfg.robot, "val") if scenarios is None else scenarios
    return evaluate.runners(cfg.override(**{"physics.dt": PAPER_DT}), scenarios, model_path)


def validation_row(results: dict[str, dict]) -> dict:
    """A check's figures for its generation's metrics row (`evaluate.check`'s verdicts): profiles
    passed, run and fallen, and the worst judged error of each kind over every profile (where any
    segment was long enough to judge)."""
    judged = [seg for r in results.values() for seg in r["segments"]]
    worst = {f"val/worst_{k}": max(seg[f"{k}_mae"] for seg in judged) for k in WORST} if judged else {}
    return {"val/passed": sum(r["passed"] for r in results.values()), "val/count": len(results),
            "val/fell": sum(r["fell"] for r in results.values()), **worst}


def validation_score(row: dict) -> tuple[int, float]:
    """Higher is better: more profiles passed, then the smaller sum of the worst errors."""
    return row["val/passed"], -sum(row.get(f"val/worst_{k}", 0.0) for k in WORST)


def _best_score(out: Path) -> tuple[int, float] | None:
    path = out / BEST / BEST_RECORD
    return validation_score(json.loads(path.read_text())["validation"]) if path.is_file() else None


def _keep_best(out: Path, record: dict, params: np.ndarray, row: dict, results: dict) -> None:
    """`out/best/`: the policy directory of `params` (`policies.write`, with the run's metrics so far)
    and `best.json` (its generation, the check's figures and each profile's verdict). It is written
    beside and renamed into place, so an interrupted write leaves the previous best."""
    partial, old, best = out / f".{BEST}.partial", out / f".{BEST}.old", out / BEST
    for leftover in (partial, old):
        shutil.rmtree(leftover, ignore_errors=True)
    rows = [json.loads(line) for line in (out / METRICS).read_text().splitlines() if line]
    policies.write(partial, record, params, [r for r in rows if r["generation"] <= record["generation"]])
    figures = {k: v for k, v in row.items() if k.startswith("val/")}
    (partial / BEST_RECORD).write_text(json.dumps({"generation": record["generation"], "validation": figures,
                                                   "profiles": results}, indent=1) + "\n")
    if best.exists():
        best.rename(old)
    partial.rename(best)
    shutil.rmtree(old, ignore_errors=True)


def _progress(enabled: bool | None, total: int, initial: int) -> Any:
    if enabled is None:
        enabled = sys.stderr.isatty()
    if not enabled:
        return None
    from tqdm import tqdm

    return tqdm(total=total, initial=initial, unit="gen", file=sys.stderr)
