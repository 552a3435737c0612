"""The walking bar on a set of profiles: one compact result file, no trajectories.

    python benchmarks/walking.py --robot cassie --scenario FILE [FILE ...] --out FILE.json
        [--checkpoint DIR] [--model PATH] [--dt 0.0005] [--simulator mjx|mujoco]

Runs the policy (the shipped one unless `--checkpoint`) through every scenario in the evaluation's
batches (`evaluate.runners`), or with `--simulator mujoco` in MuJoCo's C engine one scenario at a
time (`sim2sim.trajectories`), and judges each with the walking bar (`judge.walking`). Writes

    {"robot", "date", "code_version", "simulator", "device", "backend", "dt", "policy", "wall_clock_s",
     "passed", "fell", "count", "scenarios": [{"scenario", "passed", "fell", "fall_time", "worst"}]}

`worst` is the largest per-segment error in vx, vy (m/s) and heading (rad) over the judged segments.
"""

from __future__ import annotations

import argparse
import datetime
import json
import subprocess
import sys
import time
from pathlib import Path

import mjx_cascade  # noqa: F401  (sets the XLA CPU flag before JAX starts)
import jax

from mjx_cascade import _xla, config, evaluate, judge, physics, robots, scenario, sim2sim

ROOT = Path(__file__).resolve().parents[1]


def code_version() -> str:
    """`git describe` of the checkout, marked `-dirty` with uncommitted changes."""
    try:
        return subprocess.run(["git", "describe", "--always", "--dirty"], cwd=ROOT, capture_output=True,
                              text=True, check=True).stdout.strip()
    except (OSError, subprocess.CalledProcessError):
        return "unknown"


def trajectories(cfg: config.Config, params, scenarios: list[scenario.Scenario], model_path: str | None,
                 simulator: str):
    """`(scenario, trajectory)` pairs from MJX in the evaluation's batches, or from MuJoCo C."""
    if simulator == "mujoco":
        for s, traj, _ in sim2sim.trajectories(cfg, params, scenarios, model_path):
            yield s, traj
        return
    for runner in evaluate.runners(cfg, scenarios, model_path):
        yield from zip(runner.scenarios, runner(params))


def walking(robot: str, scenarios: list[scenario.Scenario], checkpoint: str | None, model_path: str | None,
            dt: float, simulator: str = "mjx") -> dict:
    version = code_version()  # the code this process runs: imported at its start
    cfg, found = evaluate.load_policy(robot, checkpoint, dt)
    start = time.perf_counter()
    lines = {s.name: evaluate.verdict({"scenario": {"name": s.name}, **judge.walking(traj)})
             for s, traj in trajectories(cfg, found.params, scenarios, model_path, simulator)}
    rows = [lines[s.name] for s in scenarios]
    simulated = sim2sim.SIMULATOR if simulator == "mujoco" else f"MJX ({physics.resolve_impl(cfg.physics.impl)})"
    return {"robot": robot, "date": datetime.date.today().isoformat(), "code_version": version,
            "simulator": simulated,
            "device": jax.devices()[0].device_kind, "backend": jax.default_backend(), "dt": cfg.physics.dt,
            "policy": evaluate.policy_record(found), "wall_clock_s": time.perf_counter() - start,
            "passed": sum(r["passed"] for r in rows), "fell": sum(r["fell"] for r in rows), "count": len(rows),
            "scenarios": rows}


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--robot", required=True, choices=list(config.ROBOTS))
    ap.add_argument("--scenario", required=True, nargs="+", metavar="FILE")
    ap.add_argument("--out", required=True)
    ap.add_argument("--checkpoint", metavar="DIR")
    ap.add_argument("--model", metavar="PATH")
    ap.add_argument("--dt", type=float, default=config.PAPER_DT, help="physics time step of the bar, s (default: the paper's)")
    ap.add_argument("--simulator", choices=("mjx", "mujoco"), default="mjx",
                    help="MJX in the evaluation's batches (eval), or MuJoCo's C engine one profile at a time (sim2sim)")
    args = ap.parse_args(argv)
    try:
        model = robots.model_path(robots.get(args.robot), args.model)
        scenarios = [scenario.load(f) for f in args.scenario]
    except config.ConfigError as e:
        raise SystemExit(f"walking: {e}") from None
    _xla.enable_compilation_cache()
    result = walking(args.robot, scenarios, args.checkpoint, str(model) if model else None, args.dt, args.simulator)
    Path(args.out).parent.mkdir(parents=True, exist_ok=True)
    Path(args.out).write_text(json.dumps(result, indent=1) + "\n")
    print(f"{args.robot}: passed {result['passed']} of {result['count']}, fell {result['fell']}", file=sys.stderr)
    return 0


if __name__ == "__main__":
    sys.exit(main())
