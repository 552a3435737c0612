"""Physics steps per second: the cascade controller in the loop, raw MJX, and CPU MuJoCo.

    python benchmarks/throughput.py --robot cassie --out FILE.json [--batch B ...] [--steps T]

For every physics backend available on JAX's default device (`jax` always, `warp` on NVIDIA GPUs
with mujoco-warp, `mujoco`, MuJoCo's C engine called from JAX, where `--impl` asks for it) and
every batch size:
- `controller_steps_per_s`: physics steps per second with the whole cascade controller, the
  policy, the rewards and termination in the loop, exactly as training runs them (`Env.step`),
  on JAX's default device alone (training on a CPU split into N devices runs N such batches);
- `physics_steps_per_s`: the backend's step alone (`Env.physics_step`: `mjx.step` or the C
  engine's) on the same model, time step, solver and batch, zero control;
- `peak_memory_bytes`: the device's peak allocation (where JAX reports it).
For the C engine also `engine_host_steps_per_s`: its host side alone (unpacking, the threaded C
steps, packing), called from Python on the same batch, so that `physics_steps_per_s` against it
is the cost of JAX calling back to the host.
Plus `cpu_mujoco_steps_per_s`: MuJoCo's C `rollout` with one environment per CPU core (the
paper's kind of setup), same model and time step, and per row `controller_vs_cpu_mujoco`, the
trainer's rate as a share of it. Each figure is the best of three timed runs after a compiling
warm-up.
"""

from __future__ import annotations

import argparse
import datetime
import json
import os
import sys
import time
from pathlib import Path

import mjx_cascade  # noqa: F401  (sets the XLA CPU flag before JAX starts)
import jax
import jax.numpy as jnp
import mujoco
import numpy as np
from mujoco import rollout as mj_rollout

from mjx_cascade import benchmark, config, physics, policy, robots, train
from mjx_cascade.env import make_env
from mjx_cascade.physics import mjx


def best_of(fn, repeats: int = 3) -> float:
    jax.block_until_ready(fn())  # compile and warm up
    times = []
    for _ in range(repeats):
        t = time.perf_counter()
        jax.block_until_ready(fn())
        times.append(time.perf_counter() - t)
    return min(times)


def controller_rate(env, init_params, batch: int, steps: int) -> float:
    params = jnp.broadcast_to(init_params, (batch,) + init_params.shape)
    keys = jax.random.split(jax.random.PRNGKey(0), batch)
    cmd = jnp.broadcast_to(jnp.array([0.3, 0.0, 0.0]), (batch, 3))
    data = env.data_template(batch)
    state = jax.jit(jax.vmap(lambda p, k, c: env.reset(p, k, c, data=data)))(params, keys, cmd)
    step = jax.vmap(lambda p, s, c: env.step(p, s, c)[0])

    @jax.jit
    def run(state):
        return jax.lax.scan(lambda s, _: (step(params, s, cmd), None), state, None, length=steps)[0]

    return batch * steps / best_of(lambda: run(state))


def physics_rate(env, batch: int, steps: int) -> float:
    data = env.data_template(batch).replace(qpos=jnp.asarray(env.pool_qpos[0]), qvel=jnp.asarray(env.pool_qvel[0]))
    data = jax.jit(jax.vmap(lambda _: mjx.forward(env.model, data)))(jnp.arange(batch))
    step = jax.vmap(lambda d: env.physics_step(env.model, d))

    @jax.jit
    def run(data):
        return jax.lax.scan(lambda d, _: (step(d), None), data, None, length=steps)[0]

    return batch * steps / best_of(lambda: run(data))


def engine_host_rate(engine: physics.CEngine, env, batch: int, steps: int) -> float:
    """The C engine's host step alone: `steps` steps of a batch standing from the balanced pool
    under zero control, each step's output fed back as the next one's input."""
    i, o, m = engine.inputs, engine.outputs, engine.model
    packed = np.zeros((batch, i["size"]), np.float32)
    packed[:, i["qpos"]], packed[:, i["qvel"]] = np.asarray(env.pool_qpos[0]), np.asarray(env.pool_qvel[0])
    packed[:, i["fields"]] = np.concatenate([getattr(m, f).ravel() for f in physics.PER_ENVIRONMENT])
    packed[:, i["live"]] = 1.0

    def run():
        x = packed.copy()
        for _ in range(steps):
            out = engine._host_step(x)  # flat ground: no height field goes along, as in training
            for k in ("qpos", "qvel", "act", "sensordata"):
                x[:, i[k]] = out[:, o[k]]
        return x

    return batch * steps / best_of(run)


def cpu_mujoco_rate(env, steps: int) -> tuple[float, int]:
    model = env.robot.model
    cores = os.cpu_count() or 1
    datas = [mujoco.MjData(model) for _ in range(cores)]
    nstate = mujoco.mj_stateSize(model, mujoco.mjtState.mjSTATE_FULLPHYSICS)
    d = mujoco.MjData(model)
    d.qpos[:], d.qvel[:] = np.asarray(env.pool_qpos[0]), np.asarray(env.pool_qvel[0])
    state0 = np.empty(nstate)
    mujoco.mj_getState(model, d, state0, mujoco.mjtState.mjSTATE_FULLPHYSICS)
    initial = np.tile(state0, (cores, 1))
    control = np.zeros((cores, steps, model.nu))
    with mj_rollout.Rollout(nthread=cores) as pool:
        pool.rollout([model] * cores, datas, initial, control)  # warm-up
        best = min(_timed(lambda: pool.rollout([model] * cores, datas, initial, control)) for _ in range(3))
    return cores * steps / best, cores


def _timed(fn) -> float:
    t = time.perf_counter()
    fn()
    return time.perf_counter() - t


def peak_memory() -> int | None:
    stats = jax.devices()[0].memory_stats() or {}
    return stats.get("peak_bytes_in_use")


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--robot", default="cassie", choices=list(config.ROBOTS))
    p.add_argument("--out", required=True)
    p.add_argument("--batch", type=int, nargs="+", default=None)
    p.add_argument("--steps", type=int, default=200)
    p.add_argument("--impl", choices=("jax", "warp", "mujoco"), nargs="+", default=None)
    p.add_argument("--set", action="append", default=[], metavar="KEY=VALUE")
    args = p.parse_args(argv)

    gpu = jax.default_backend() == "gpu"
    batches = args.batch or ([256, 1024, 4096, 16384] if gpu else [16, 64, 128])
    impls = args.impl or (["jax", "warp"] if physics.warp_available() else ["jax"])
    cfg = config.robot_config(args.robot).override(**config.parse_assignments(args.set))
    network = policy.for_controller(cfg, len(robots.get(args.robot).learned), jax.random.PRNGKey(cfg.seed))
    result = {"device": jax.devices()[0].device_kind, "backend": jax.default_backend(), "robot": args.robot,
              "devices": 1,
              "dt": cfg.physics.dt, "steps": args.steps, "date": datetime.date.today().isoformat(),
              "code_version": benchmark.code_version(), "versions": train.software_versions(), "rows": []}
    for impl in impls:
        for batch in batches:
            env = make_env(cfg.override(**{"physics.impl": impl}), network.apply)
            row = {"impl": impl, "batch": batch,
                   "controller_steps_per_s": controller_rate(env, network.init_params, batch, args.steps),
                   "physics_steps_per_s": physics_rate(env, batch, args.steps),
                   "peak_memory_bytes": peak_memory()}
            engine = getattr(env.physics_step, "__self__", None)  # the C engine's, with its threads
            if engine is not None:
                row["engine_threads"] = engine.threads
                row["engine_host_steps_per_s"] = engine_host_rate(engine, env, batch, args.steps)
            result["rows"].append(row)
            print(json.dumps(row), file=sys.stderr, flush=True)
    result["cpu_mujoco_steps_per_s"], result["cpu_cores"] = cpu_mujoco_rate(env, max(args.steps, 1000))
    for r in result["rows"]:  # the trainer's rate as a share of MuJoCo C's on the same machine's cores
        r["controller_vs_cpu_mujoco"] = r["controller_steps_per_s"] / result["cpu_mujoco_steps_per_s"]
    Path(args.out).parent.mkdir(parents=True, exist_ok=True)
    Path(args.out).write_text(json.dumps(result, indent=2) + "\n")
    print(f"{'impl':6} {'batch':>7} {'controller/s':>14} {'physics/s':>12} {'ratio':>6} {'of C':>6}")
    for r in result["rows"]:
        ratio = r["controller_steps_per_s"] / r["physics_steps_per_s"]
        print(f"{r['impl']:6} {r['batch']:7d} {r['controller_steps_per_s']:14,.0f} {r['physics_steps_per_s']:12,.0f} "
              f"{ratio:6.2f} {r['controller_vs_cpu_mujoco']:6.2f}")
    print(f"CPU MuJoCo rollout, {result['cpu_cores']} cores: {result['cpu_mujoco_steps_per_s']:,.0f} steps/s")
    return 0


if __name__ == "__main__":
    sys.exit(main())
