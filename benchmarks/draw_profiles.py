"""Draw random walking profiles: scenario files of piecewise-constant commands from standing.

    python benchmarks/draw_profiles.py --prefix rand --seed 901 --first 901 --count 10 \
        --vx -0.3 0.8 --vy -0.3 0.3 --heading-step 0.5 --out benchmarks/scenarios

Each profile lasts `--duration` seconds; its segments last 4, 5 or 6 s (drawn with equal
chances; the last one is cut at the end), each with vx and vy drawn uniformly from the ranges
and the desired heading moved by a uniform step of at most `--heading-step` rad. The same
arguments write the same files.
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

import numpy as np

SEGMENT_SECONDS = (4.0, 5.0, 6.0)


def draw(rng: np.random.Generator, name: str, duration: float, vx: tuple[float, float],
         vy: tuple[float, float], heading_step: float) -> dict:
    """One scenario as a dict (`scenario.parse` reads it)."""
    t, yaw, commands = 0.0, 0.0, []
    while t < duration:
        yaw += rng.uniform(-heading_step, heading_step)
        commands.append({"t": t, "vx": float(rng.uniform(*vx)), "vy": float(rng.uniform(*vy)), "yaw": float(yaw)})
        t += float(rng.choice(SEGMENT_SECONDS))
    return {"name": name, "duration": duration, "commands": commands}


def main(argv: list[str] | None = None) -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--prefix", required=True, help="file and scenario names: PREFIX<number>")
    p.add_argument("--seed", type=int, required=True)
    p.add_argument("--first", type=int, default=1, help="number of the first profile")
    p.add_argument("--count", type=int, default=10)
    p.add_argument("--duration", type=float, default=20.0)
    p.add_argument("--vx", type=float, nargs=2, required=True, metavar=("LOW", "HIGH"))
    p.add_argument("--vy", type=float, nargs=2, required=True, metavar=("LOW", "HIGH"))
    p.add_argument("--heading-step", type=float, required=True, help="largest heading change per segment, rad")
    p.add_argument("--out", required=True)
    a = p.parse_args(argv)
    rng = np.random.default_rng(a.seed)
    out = Path(a.out)
    out.mkdir(parents=True, exist_ok=True)
    for k in range(a.first, a.first + a.count):
        name = f"{a.prefix}{k:02d}"
        profile = draw(rng, name, a.duration, tuple(a.vx), tuple(a.vy), a.heading_step)
        (out / f"{name}.json").write_text(json.dumps(profile) + "\n")
        print(name, [(c["t"], round(c["vx"], 2), round(c["vy"], 2), round(c["yaw"], 2)) for c in profile["commands"]])


if __name__ == "__main__":
    main()
