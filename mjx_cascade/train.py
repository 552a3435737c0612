"""Training: ES over MJX episodes, several generations per jitted call, checkpointed and resumable.

One generation (sample the antithetic population, run every member's episode in one
vmapped call, rank, optax step, decays) is a pure function of the ES state. `lax.scan` runs
up to `generations_per_call` of them per call, the last ones skipped by `lax.cond` when
fewer are due, so every call reuses one compiled program. The population axis is sharded
over every local device. The host only writes metrics and checkpoints between calls.
"""

from __future__ import annotations

import dataclasses
import json
import sys
import time
from pathlib import Path
from typing import Any, Callable

import jax
import jax.numpy as jnp
import numpy as np
from jax.sharding import NamedSharding, PartitionSpec

from mjx_cascade import checkpoint, es, plots
from mjx_cascade.config import Config, ConfigError, to_dict
from mjx_cascade.env import Env, make_env
from mjx_cascade.rollout import run_episodes

METRICS = "metrics.jsonl"


@dataclasses.dataclass
class Trainer:
    cfg: Config
    env: Env
    run: Callable  # (ESState, n_active) -> (ESState, metrics [L])
    state: es.ESState
    devices: int
    init: dict | None = None  # the warm start's policy: `params_sha256`, `generation`, `source`

    @property
    def num_params(self) -> int:
        return int(self.state.mean.shape[0])


def population_sharding() -> tuple[NamedSharding, int]:
    devices = jax.devices()
    mesh = jax.make_mesh((len(devices),), ("pop",), axis_types=(jax.sharding.AxisType.Auto,))
    return NamedSharding(mesh, PartitionSpec("pop")), len(devices)


def make_generation(env: Env) -> Callable:
    """`generation(state) -> (state, metrics)`: one full ES generation, jittable."""
    cfg = env.cfg
    sharding, _ = population_sharding()

    def generation(state: es.ESState):
        state, noise, members = es.ask(state, cfg.es)
        pair_keys = jax.random.split(jax.random.fold_in(state.key, 1), cfg.es.population // 2)
        keys = jnp.concatenate([pair_keys, pair_keys])  # both members of a pair face the same episode
        members = jax.lax.with_sharding_constraint(members, sharding)
        keys = jax.lax.with_sharding_constraint(keys, sharding)
        res = run_episodes(env, members, keys, state.generation)
        new = es.tell(state, noise, res.fitness, cfg.es)
        chunk = cfg.episode.steps_per_check
        iterations = jnp.ceil(jnp.max(res.steps) / chunk)
        metrics = {
            "fitness_mean": jnp.mean(res.fitness),
            "fitness_max": jnp.max(res.fitness),
            "fitness_min": jnp.min(res.fitness),
            "sigma": state.sigma,
            "learning_rate": state.lr,
            "physics_steps": jnp.sum(res.steps.astype(jnp.float32)),
            "simulated_steps": iterations * chunk * cfg.es.population,
            "episode_seconds_mean": jnp.mean(res.steps) * env.dt,
            "walking_steps_mean": jnp.mean(res.walking_steps),
            "terminated_fraction": jnp.mean(res.terminated),
            "diverged": jnp.sum(res.diverged),
        }
        return new, metrics

    return generation


def make_run(env: Env, per_call: int) -> Callable:
    # jitted so that `skip`'s shape query and `lax.cond` share one trace of the generation
    generation = jax.jit(make_generation(env))

    def skip(state):
        _, metrics = jax.eval_shape(generation, state)
        return state, jax.tree.map(lambda s: jnp.zeros(s.shape, s.dtype), metrics)

    def run(state: es.ESState, n_active: jax.Array):
        def body(state, i):
            return jax.lax.cond(i < n_active, generation, skip, state)

        return jax.lax.scan(body, state, jnp.arange(per_call))

    return jax.jit(run)


def setup(cfg: Config, model_path: str | None = None, init: str | Path | None = None) -> Trainer:
    """The trainer at generation 0, or warm-started from the policy at `init` (a checkpoint
    directory or an exported `.npz`), counting on from that policy's generation."""
    sharding, devices = population_sharding()
    if cfg.es.population % devices:
        raise ConfigError(f"es.population ({cfg.es.population}) must be a multiple of the {devices} devices")
    if init is not None:  # read before the (slow) environment is built, so a bad `init` fails at once
        meta, params = checkpoint.read(init)
        generation = int(meta["generation"])
        if generation >= cfg.train.generations:
            raise ConfigError(f"--init is at generation {generation}; train.generations "
                              f"({cfg.train.generations}) leaves nothing to train")
    env = make_env(cfg, batch=cfg.es.population, model_path=model_path)
    key = jax.random.PRNGKey(cfg.seed)
    if init is None:
        state, record = es.init(env.init_params, key, cfg.es), None
    else:
        checkpoint.check_compatible(meta, cfg.robot, int(env.init_params.shape[0]), env.action_dim)
        # its own noise stream: the generation-0 key would replay the first run's perturbations
        state = es.init(jnp.asarray(params), jax.random.fold_in(key, generation), cfg.es, generation)
        record = {"params_sha256": checkpoint.params_sha256(params), "generation": generation,
                  "source": str(init)}
    return Trainer(cfg, env, make_run(env, cfg.train.generations_per_call), replicate(state), devices, record)


def replicate(state: es.ESState) -> es.ESState:
    """The ES state on every device. Fresh, restored and notebook states all get this one
    placement, so they all hit the same compiled program (and the same on-disk cache entry)."""
    return jax.device_put(state, NamedSharding(population_sharding()[0].mesh, PartitionSpec()))


def metadata(trainer: Trainer, generation: int, physics_steps: float, wall_clock: float) -> dict:
    env = trainer.env
    return {
        "robot": trainer.cfg.robot,
        "generation": generation,
        "policy_params": trainer.num_params,
        "action_dim": env.action_dim,
        "state_dim": 6,
        "learned_joints": env.robot.learned_names,
        "physics_steps": physics_steps,
        "wall_clock_s": wall_clock,
        "devices": trainer.devices,
        "device_kind": jax.devices()[0].device_kind,
        "backend": jax.default_backend(),
        "impl": env.impl,
        "jax_version": jax.__version__,
        "reproducibility": "bitwise on the same devices and backend; on another device count or kind "
                           "within floating-point tolerance",
        "config": to_dict(trainer.cfg),
        **({"init": trainer.init} if trainer.init else {}),
    }


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


def train(cfg: Config, out: str | Path, model_path: str | None = None, progress: bool | None = None,
          log: Callable[[str], None] | None = None, init: str | Path | None = None) -> dict:
    """Train (or resume) into `out`: `out/checkpoints/`, `out/metrics.jsonl` and `out/learning_curve.png`.

    `init` warm-starts a new run from another run's policy (`setup`); a run that has a checkpoint
    resumes from it instead, keeping the warm start it began with. Physics steps and wall-clock
    count this run's only. Everything that can refuse the run (config, model, devices, `init`) is
    checked before `out` is created.
    """
    out = Path(out)
    log = log or (lambda msg: print(msg, file=sys.stderr))
    resuming = checkpoint.is_checkpoint_dir(out / "checkpoints")
    trainer = setup(cfg, model_path, None if resuming else init)
    mngr = checkpoint.manager(out / "checkpoints")
    state, physics_steps, wall_clock = trainer.state, 0.0, 0.0
    if resuming:
        state, meta = checkpoint.restore(mngr, state)
        checkpoint.check_compatible(meta, cfg.robot, trainer.num_params, trainer.env.action_dim)
        physics_steps, wall_clock = float(meta["physics_steps"]), float(meta["wall_clock_s"])
        trainer.init = meta.get("init")
        log(f"resuming {out} at generation {int(state.generation)}")
        state = replicate(state)
    elif trainer.init:
        log(f"warm start from {init} (generation {trainer.init['generation']})")
    generation = int(state.generation)
    metrics_path = out / METRICS
    _truncate_metrics(metrics_path, generation)

    target, every, per_call = cfg.train.generations, cfg.train.checkpoint_every, cfg.train.generations_per_call
    t0 = time.perf_counter()
    compiled = trainer.run.lower(state, jnp.int32(per_call)).compile()
    compile_s = time.perf_counter() - t0
    log(f"compiled one call of {per_call} generations in {compile_s:.1f} s "
        f"({trainer.env.impl}, {trainer.devices} {jax.default_backend()} device(s), population {cfg.es.population})")
    bar = _progress(progress, target, generation)
    start = time.perf_counter()
    with metrics_path.open("a") as f:
        while generation < target:
            n = min(per_call, target - generation, (generation // every + 1) * every - generation)
            t_call = time.perf_counter()
            state, metrics = compiled(state, jnp.int32(n))
            metrics = jax.device_get(metrics)
            seconds = time.perf_counter() - t_call
            steps = float(np.sum(metrics["physics_steps"][:n]))
            for i in range(n):
                physics_steps += float(metrics["physics_steps"][i])
                row = {"generation": generation + i + 1, **{k: float(v[i]) for k, v in metrics.items()}}
                row.update(physics_steps_total=physics_steps, wall_clock_s=wall_clock + time.perf_counter() - start,
                           samples_per_s=steps / seconds)
                f.write(json.dumps(row) + "\n")
            f.flush()
            generation += n
            if generation % every == 0 or generation == target:
                checkpoint.save(mngr, generation, state,
                                metadata(trainer, generation, physics_steps, wall_clock + time.perf_counter() - start))
            if bar:
                bar.update(n)
                bar.set_postfix(fitness=f"{float(metrics['fitness_mean'][n - 1]):.3f}")
    if bar:
        bar.close()
    if mngr.latest_step() != generation:  # nothing was due (already trained that far): still leave a checkpoint
        checkpoint.save(mngr, generation, state, metadata(trainer, generation, physics_steps, wall_clock))
    plots.learning_curve(metrics_path, out / "learning_curve.png", title=f"{cfg.robot}: fitness (Fig. 6)")
    return {
        "generation": generation,
        "physics_steps": physics_steps,
        "wall_clock_s": wall_clock + time.perf_counter() - start,
        "compile_s": compile_s,
        "params_sha256": checkpoint.params_sha256(state.mean),
        "devices": trainer.devices,
        "impl": trainer.env.impl,
    }


def _progress(enabled: bool | None, total: int, initial: int) -> Any:
    if enabled is None:
        enabled = sys.stderr.isatty()
    if not enabled:
        return None
    from tqdm import tqdm

    return tqdm(total=total, initial=initial, unit="gen", file=sys.stderr)
