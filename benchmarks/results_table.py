"""The README's results table, built from the walking-bar result files (`walking.py`).

    python benchmarks/results_table.py [--results benchmarks/results/walking_cpu]

Prints one markdown row per result file in `SETS`: what the profiles are, the role they have
played, passes, falls and the worst per-segment errors over the set in MJX (`eval`), and the
passes and falls of the same profiles in MuJoCo's C engine (`sim2sim`, the file `<name>_mujoco.json`
from `walking.py --simulator mujoco`) where that file exists. `tests/test_readme.py`
checks that the README holds exactly this table, so the two cannot drift apart.
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
RESULTS = ROOT / "benchmarks" / "results" / "walking_cpu"

# result file -> (the profiles, the role they have played so far)
SETS = {
    "cassie_screen": ("rand401-510 (20)", "chose the checkpoint"),
    "cassie_profiles": ("rand601-910 (40)", "drawn unseen; later chose `height_over_slope`"),
    "cassie_disturbances": ("shipped scenarios, pushes, rough (12)", "everyday checks"),
    "digit_profiles": ("digit_rand01-50, digit_screen01-10 (60)", "chose the checkpoint and `command_rate`"),
}
HEADER = ("| robot | profiles | role | passed | falls | worst errors (vx, vy m/s; heading rad) | date, code "
          "| MuJoCo C: passed, falls, code |\n"
          "| --- | --- | --- | --- | --- | --- | --- | --- |")


def row(name: str, result: dict, mujoco: dict | None) -> str:
    profiles, role = SETS[name]
    worst = {k: max(s["worst"][k] for s in result["scenarios"]) for k in ("vx", "vy", "yaw")}
    errors = f"{worst['vx']:.4f}, {worst['vy']:.4f}; {worst['yaw']:.4f}"
    c = "not run" if mujoco is None else \
        f"{mujoco['passed']} of {mujoco['count']}, {mujoco['fell']}, `{mujoco['code_version']}`"
    return (f"| {result['robot']} | {profiles} | {role} | {result['passed']} of {result['count']} | "
            f"{result['fell']} | {errors} | {result['date']}, `{result['code_version']}` | {c} |")


def _read(path: Path) -> dict | None:
    return json.loads(path.read_text()) if path.is_file() else None


def table(results: Path = RESULTS) -> str:
    rows = [row(name, _read(results / f"{name}.json"), _read(results / f"{name}_mujoco.json")) for name in SETS]
    return "\n".join([HEADER, *rows])


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--results", type=Path, default=RESULTS, help="directory of the walking result files")
    print(table(ap.parse_args(argv).results))
    return 0


if __name__ == "__main__":
    sys.exit(main())
