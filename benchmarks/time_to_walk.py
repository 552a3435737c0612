"""Time from scratch to a policy that passes the walking bar, on whatever device JAX has.

    python benchmarks/time_to_walk.py (--robot cassie | --config FILE) --out FILE.json [--check-every G]
        [--max-generations N] [--max-minutes M] [--scenario FILE ...] [--dt DT] [--set KEY=VALUE ...]

Trains with the robot's shipped config, or a config file (`robot` plus overrides, as
`mjx-cascade train --config`; `configs/cassie_cpu.yaml` is the CPU recipe), plus `--set`
overrides, exactly as `mjx-cascade train` does (`train.drive`), and every `--check-every`
generations runs the ES mean through each scenario (default: the robot's `val` profiles,
`configs/sets.yaml`) on the same device (`evaluate.Runner`: the scenarios in one batch through
the same simulator, compiled once, at the bar's time step `--dt`), judging it with `evaluate.check` (the walking bar, `judge.walking`)
from the recorded trajectory alone, as `train.eval_every` does, except that a check stops at the
first tenth of its simulation in which a scenario fell or finished a command out of bounds
(`stop_at_miss`: the scenarios undecided then count as not passed, and the verdict "not every
scenario passed" is the same).
Where the training time step is longer than the bar's, each check first screens the policy at
the training step (a quarter of the simulation at 2 ms against 0.5 ms), and runs the bar only
for a policy that passes every scenario there: the verdict that stops the run is always the
bar's. It stops at the first check that passes every scenario, or at the limits, and writes

    {"device", "backend", "impl", "devices", "robot", "wall_clock_s", "compile_s", "training_s",
     "check_s", "physics_steps", "generations", "passed", "screen_dt", "checks": [...], "config": {...},
     "date", "code_version", "versions", "cpu", "cores", "command"}

each check holding the stage that decided it (`screen` or `bar`) and that stage's verdicts.

`wall_clock_s` is everything from the start to the passing check: compiling the checks and the
training, training, and the checks; `compile_s`, `training_s` and `check_s` split it. Nothing
is checkpointed.
"""

from __future__ import annotations

import argparse
import datetime
import json
import sys
import time
from pathlib import Path

import mjx_cascade  # noqa: F401  (sets the XLA CPU flag before JAX starts)
import jax
import jax.numpy as jnp
import numpy as np

from mjx_cascade import _xla, benchmark, config, evaluate, profiles, scenario, train


def time_to_walk(cfg: config.Config, scenarios: list[scenario.Scenario], dt: float, check_every: int,
                 max_generations: int, max_seconds: float, log=print) -> dict:
    """Train `cfg` from scratch until a check passes every scenario or a limit is reached
    (`max_seconds` of wall-clock, checks included)."""
    version = benchmark.code_version()  # the code this process runs: imported at its start
    start = time.perf_counter()
    stages = [("bar", evaluate.runners(cfg.override(**{"physics.dt": dt}), scenarios))]
    if cfg.physics.dt > dt:
        stages.insert(0, ("screen", evaluate.runners(cfg, scenarios)))
    trainer = train.setup(cfg)
    trainer.run = trainer.run.lower(trainer.state, jnp.int32(cfg.train.generations_per_call)).compile()
    books = {"compile_s": time.perf_counter() - start, "check_s": 0.0, "physics_steps": 0.0, "checks": []}
    log(f"compiled in {books['compile_s']:.1f} s ({trainer.env.impl}, population {cfg.es.population})")

    def elapsed():
        return time.perf_counter() - start

    def on_call(state, rows, seconds):
        books["physics_steps"] += sum(r["physics_steps"] for r in rows)
        generation = rows[-1]["generation"]
        if generation % check_every and generation < max_generations and elapsed() < max_seconds:
            return False
        t_check = time.perf_counter()
        mean = np.asarray(jax.device_get(state.mean))
        for stage, runners in stages:
            results = evaluate.check(runners, mean, stop_at_miss=True)
            passed = all(r["passed"] is True for r in results.values())
            if not passed:
                break
        books["check_s"] += time.perf_counter() - t_check
        passed = passed and stage == "bar"
        books["checks"].append({"generation": generation, "wall_clock_s": elapsed(),
                                "physics_steps": books["physics_steps"], "fitness_mean": rows[-1]["fitness_mean"],
                                "stage": stage, "passed": passed,
                                "count": sum(r["passed"] is True for r in results.values()), "scenarios": results})
        log(f"generation {generation}: {elapsed():.0f} s, fitness {rows[-1]['fitness_mean']:.3f}, "
            f"{stage}: {books['checks'][-1]['count']} of {len(results)} passed, "
            f"{sum(r['fell'] for r in results.values())} fell, "
            f"{sum(r['passed'] is None for r in results.values())} stopped unjudged")
        return passed or elapsed() >= max_seconds

    state = train.drive(trainer, trainer.state, max_generations, check_every, on_call)
    wall = elapsed()
    checks = books["checks"]
    return {
        "device": jax.devices()[0].device_kind,
        "backend": jax.default_backend(),
        "impl": trainer.env.impl,
        "devices": jax.device_count(),
        "robot": cfg.robot,
        "wall_clock_s": wall,
        "compile_s": books["compile_s"],
        "training_s": wall - books["compile_s"] - books["check_s"],
        "check_s": books["check_s"],
        "physics_steps": books["physics_steps"],
        "generations": int(state.generation),
        "passed": bool(checks and checks[-1]["passed"]),
        "eval_dt": dt,
        "screen_dt": cfg.physics.dt if len(stages) > 1 else None,
        "checks": checks,
        "config": config.to_dict(cfg),
        "date": datetime.date.today().isoformat(),
        "code_version": version,
        "versions": train.software_versions(),
        "cpu": _xla.cpu_model(),  # the wall-clock on a CPU depends on which one, as much as on its cores
        "cores": _xla.cores(),
    }


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    src = ap.add_mutually_exclusive_group(required=True)
    src.add_argument("--robot", choices=list(config.ROBOTS), help="train with the robot's shipped config")
    src.add_argument("--config", metavar="FILE", help="YAML config: `robot` plus overrides of its settings")
    ap.add_argument("--out", required=True)
    ap.add_argument("--check-every", type=int, default=10, help="generations between checks of the bar")
    ap.add_argument("--max-generations", type=int, default=2000)
    ap.add_argument("--max-minutes", type=float, default=30.0, help="wall-clock limit, checks included")
    ap.add_argument("--scenario", action="append", default=None, metavar="FILE",
                    help="repeatable; default: the robot's val profiles (configs/sets.yaml)")
    ap.add_argument("--dt", type=float, default=0.0005, help="physics time step of the checks (the bar's)")
    ap.add_argument("--set", action="append", default=[], metavar="KEY=VALUE")
    args = ap.parse_args(argv)
    if args.check_every < 1 or args.max_generations < 1:
        raise SystemExit("--check-every and --max-generations must be positive")
    try:
        base = config.load(args.config) if args.config else config.robot_config(args.robot)
        cfg = base.override(**config.parse_assignments(args.set))
    except config.ConfigError as e:
        raise SystemExit(f"time_to_walk: {e}") from None
    if not _xla.cpu_split_given() and not _xla.cpu_backend_started():
        _xla.split_cpu(train.cpu_device_count(cfg))  # as `mjx-cascade train` does by default
    _xla.enable_compilation_cache()
    scenarios = [scenario.load(f) for f in args.scenario] if args.scenario else profiles.resolve(cfg.robot, "val")
    result = time_to_walk(cfg, scenarios, args.dt, args.check_every,
                          args.max_generations, 60.0 * args.max_minutes, log=lambda m: print(m, file=sys.stderr))
    result["command"] = " ".join(["python benchmarks/time_to_walk.py", *(argv if argv is not None else sys.argv[1:])])
    Path(args.out).parent.mkdir(parents=True, exist_ok=True)
    Path(args.out).write_text(json.dumps(result, indent=2) + "\n")
    print(json.dumps({k: result[k] for k in ("device", "impl", "devices", "wall_clock_s", "compile_s", "training_s",
                                             "check_s", "physics_steps", "generations", "passed")}))
    return 0


if __name__ == "__main__":
    sys.exit(main())
