"""The cost of one control tick of the single-robot runtime (MuJoCo C, `runtime.Runtime`).

    python benchmarks/runtime_tick.py --robot cassie --out benchmarks/results/cpu1core_runtime_tick_cassie.json
        [--model PATH] [--seconds 10] [--cores 1]

Pins the process to `--cores` CPU cores before JAX starts, walks the shipped policy through the
speed profile (`configs/scenarios/speed_profile.json`, its first `--seconds`) at dt = 0.5 ms, and
times every tick: `control` (measure the state, run the compiled controller, write `ctrl`) and
`mj_step` separately. The robot's loop is 2 kHz, so a tick has 500 us. Writes

    {"robot", "date", "code_version", "cpu", "cores", "ticks", "dt",
     "control_us": {"median", "p99", "max", "mean"}, "physics_us": {...}, "walked_m", "fell"}
"""

from __future__ import annotations

import argparse
import datetime
import json
import os
import sys
import time
from pathlib import Path

import numpy as np

import mjx_cascade  # noqa: F401  (sets the XLA CPU flag before JAX starts)


def stats(ns: np.ndarray) -> dict:
    us = ns / 1e3
    return {"median": float(np.median(us)), "p99": float(np.percentile(us, 99)), "max": float(us.max()),
            "mean": float(us.mean())}


def measure(rt, seconds: float) -> dict:
    """Tick timings of runtime `rt` on the speed profile's first `seconds`."""
    import mujoco

    from mjx_cascade import judge, scenario

    s = scenario.load("speed_profile")
    steps = int(round(seconds / rt.dt))
    cmd = s.command_schedule(np.arange(steps) * rt.dt)
    m, d = rt.robot.model, mujoco.MjData(rt.robot.model)
    rt.reset(d, cmd[0])
    control, physics = np.empty(steps, np.int64), np.empty(steps, np.int64)
    clock = time.perf_counter_ns
    for n in range(steps):
        t0 = clock()
        rt.control(d, cmd[n])
        t1 = clock()
        mujoco.mj_step(m, d)
        control[n], physics[n] = t1 - t0, clock() - t1
    return {"ticks": steps, "dt": rt.dt, "control_us": stats(control), "physics_us": stats(physics),
            "walked_m": float(d.qpos[0]), "fell": bool(judge.fallen(d.qpos[None], np.zeros(1))[0])}


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--robot", required=True, choices=("cassie", "digit"))
    ap.add_argument("--out", required=True)
    ap.add_argument("--model", metavar="PATH")
    ap.add_argument("--seconds", type=float, default=10.0)
    ap.add_argument("--cores", type=int, default=1, help="CPU cores the process may use (default 1)")
    args = ap.parse_args(argv)
    cores = sorted(os.sched_getaffinity(0))[:args.cores]
    os.sched_setaffinity(0, cores)  # before JAX's CPU backend starts its threads

    from mjx_cascade import config, evaluate, robots, runtime
    from mjx_cascade.benchmark import code_version
    from mjx_cascade._xla import cpu_model

    version = code_version()  # the code this process runs: imported at its start
    cfg, found = evaluate.load_policy(args.robot, None, config.PAPER_DT)
    model = robots.model_path(robots.get(args.robot), args.model)
    rt = runtime.Runtime(robots.build(robots.get(args.robot), cfg.physics, str(model) if model else None), cfg,
                         found.params)
    result = {"robot": args.robot, "date": datetime.date.today().isoformat(), "code_version": version,
              "cpu": cpu_model(), "cores": len(cores), **measure(rt, args.seconds)}
    Path(args.out).parent.mkdir(parents=True, exist_ok=True)
    Path(args.out).write_text(json.dumps(result, indent=1) + "\n")
    c = result["control_us"]
    print(f"{args.robot}: control median {c['median']:.0f} us, p99 {c['p99']:.0f} us", file=sys.stderr)
    return 0


if __name__ == "__main__":
    sys.exit(main())
