"""The README's results table, built from the walking benchmark's result files.

    python benchmarks/results_table.py [--write]

Prints one markdown row per file in `FILES` (written by `mjx-cascade benchmark walking ... --out
FILE`): the profile set and the role it has played, passes, falls, the worst per-segment errors
of the profiles that did not fall, how long the 1-s average velocity took to settle after command
changes (median and worst, vx and vy), the date and code version, and the passes and falls of the same profiles in MuJoCo's C engine
(the file `<name>_mujoco.json`, `--simulator mujoco`) where that file exists. Every file must
judge the policy that ships now: a file of another policy is refused, so the table cannot show a
stale figure. Then one row per robot in `ROBUSTNESS` (written by `mjx-cascade robustness`): the
successes of the pushes at 100 and 150 N in each direction and the worst cell of each other axis.
`--write` puts them into README.md in place of the old ones; `tests/test_readme.py` checks that
the README holds exactly these tables.
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
RESULTS = ROOT / "benchmarks" / "results"

# result file (under RESULTS) -> the role its profiles have played; the set's name comes from the file
CASSIE = "candidates/cassie_cpu_nvx08"  # the run that became Cassie v2: its files, chosen and judged as a candidate
DIGIT = "candidates/digit_turn"  # the run that became Digit v2, likewise
FILES = {
    f"{CASSIE}/walking/cassie_val.json": "chose the checkpoint (the best of 32 checks in training)",
    f"{CASSIE}/walking/cassie_test.json": "drawn after the policy was frozen; run once",
    f"{CASSIE}/walking/cassie_steps.json": "command steps across the full ranges",
    f"{CASSIE}/walking/cassie_starts.json": "starts from standing into the ranges' corners",
    f"{DIGIT}/walking/digit_val.json": "chose the checkpoint (the best of 12 checks in training)",
    f"{DIGIT}/walking/digit_test.json": "drawn after the policy was frozen; run once",
    f"{DIGIT}/walking/digit_steps.json": "command steps across the full ranges",
    f"{DIGIT}/walking/digit_starts.json": "starts from standing into the ranges' corners",
}
# robot -> its shipped policy's robustness sweep (under RESULTS), in one file or split by axis over several
ROBUSTNESS = {"cassie": (f"{CASSIE}/robustness_push/robustness.json", f"{CASSIE}/robustness_mass/robustness.json",
                         f"{CASSIE}/robustness_slope_rough/robustness.json")}
DIRECTIONS = ("forward", "backward", "left", "right")
IMPLS = {"mujoco": "MuJoCo C", "jax": "MJX"}  # the robustness files' `impl`, as the table names it
ROBUSTNESS_HEADER = ("| robot | push 100 N (forward, backward, left, right) | push 150 N | slopes, worst cell "
                     "| rough ground, worst cell | mass, worst cell | trials per cell, dt | engine and wall-clock |\n"
                     "| --- | --- | --- | --- | --- | --- | --- | --- |")
HEADER = ("| robot | profiles | role | passed | falls | worst errors without the falls (vx, vy m/s; heading rad) "
          "| settling after a change, median / worst (vx; vy s) | date, code | MuJoCo C: passed, falls |\n"
          "| --- | --- | --- | --- | --- | --- | --- | --- | --- |")


def _seconds(r: dict | None) -> str:
    if not r or not r["changes"]:
        return "-"
    text = f"{r['median_s']:.2f} / {r['worst_s']:.2f}" if r["median_s"] is not None else "none settled"
    return text + (f" ({r['unsettled']} unsettled)" if r["unsettled"] else "")


def row(name: str, result: dict, mujoco: dict | None) -> str:
    walked = [s for s in result["scenarios"] if not s["fell"]] or result["scenarios"]  # a fall's errors say only "fell"
    worst = {k: max(s["worst"][k] for s in walked) for k in ("vx", "vy", "yaw")}
    errors = f"{worst['vx']:.4f}, {worst['vy']:.4f}; {worst['yaw']:.4f}"
    response = result.get("response", {})
    settle = f"{_seconds(response.get('vx'))}; {_seconds(response.get('vy'))}" if response else "not measured"
    profiles = f"{result['set']} ({result['count']})"
    c = "not run" if mujoco is None else f"{mujoco['passed']} of {mujoco['count']}, {mujoco['fell']}"
    return (f"| {result['robot']} | {profiles} | {FILES[name]} | {result['passed']} of {result['count']} | "
            f"{result['fell']} | {errors} | {settle} | {result['date']}, `{result['code_version']}` | {c} |")


def _read(path: Path) -> dict | None:
    return json.loads(path.read_text()) if path.is_file() else None


def check_policy(name: str, result: dict) -> None:
    """Refuse a file that judged another policy than the one that ships for its robot."""
    from mjx_cascade import checkpoint, policies

    shipped = checkpoint.params_sha256(policies.load(result["robot"]).params)
    if result["policy"]["params_sha256"] != shipped:
        raise SystemExit(f"{name} judged the policy {result['policy']['params_sha256'][:12]}, not the shipped "
                         f"{result['robot']} policy {shipped[:12]}: rerun it")


def table(results: Path = RESULTS) -> str:
    rows = []
    for name in FILES:
        result = _read(results / name)
        if result is None:
            raise SystemExit(f"{results / name} is missing: run `mjx-cascade benchmark walking` (benchmarks/README.md)")
        mujoco = _read(results / name.replace(".json", "_mujoco.json"))
        for judged in filter(None, (result, mujoco)):
            check_policy(name, judged)
        rows.append(row(name, result, mujoco))
    return "\n".join([HEADER, *rows])


def robustness_row(robot: str, results: list[dict]) -> str:
    """One robot's row from its sweep's files: each axis from the file that ran it."""
    axes = [axis for result in results for axis in result["cells"]]
    if len(axes) > len(set(axes)):
        raise SystemExit(f"{robot}'s robustness files run an axis twice: {axes}")
    cells = {axis: c for result in results for axis, c in result["cells"].items()}
    pushes = {(c["level"], c["direction"]): c["successes"] for c in cells["push"]}

    def push(force: float) -> str:
        return ", ".join(str(pushes[(force, d)]) for d in DIRECTIONS)

    def worst(axis: str, unit: str) -> str:
        cell = min(cells[axis], key=lambda c: (c["successes"], c["level"]))
        levels = [c["level"] for c in cells[axis]]
        return f"{cell['successes']}/{cell['trials']} ({min(levels):g} to {max(levels):g} {unit})"

    trials = {(r["sweep"]["trials"], r["dt"]) for r in results}
    if len(trials) > 1:
        raise SystemExit(f"{robot}'s robustness files differ in trials per cell or dt: {sorted(trials)}")
    (count, dt), = trials
    engines = "; ".join(f"{', '.join(r['sweep']['axes'])}: {IMPLS.get(r['impl'], r['impl'])}, {r['wall_clock_s']:.0f} s"
                        for r in results)
    return (f"| {robot} | {push(100.0)} | {push(150.0)} | {worst('slope', 'degrees')} | "
            f"{worst('rough', 'm')} | {worst('mass', 'x')} | {count}, {dt} s | {engines} |")


def robustness_table(results: Path = RESULTS) -> str:
    rows = []
    for robot, names in ROBUSTNESS.items():
        sweeps = []
        for name in names:
            result = _read(results / name)
            if result is None:
                raise SystemExit(f"{results / name} is missing: run `mjx-cascade robustness` (benchmarks/README.md)")
            check_policy(name, {"robot": robot, **result})
            sweeps.append(result)
        rows.append(robustness_row(robot, sweeps))
    return "\n".join([ROBUSTNESS_HEADER, *rows])


def replace_table(text: str, new: str) -> str:
    """`text` with the markdown table that starts with `new`'s header line replaced by `new`."""
    lines, header = text.split("\n"), new.split("\n")[0]
    if header not in lines:
        raise SystemExit(f"no table headed {header[:60]!r}... in the README")
    start = lines.index(header)
    end = next((i for i in range(start, len(lines)) if not lines[i].startswith("|")), len(lines))
    return "\n".join(lines[:start] + new.split("\n") + lines[end:])


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--results", type=Path, default=RESULTS, help="directory of the result files")
    ap.add_argument("--write", action="store_true", help="put the tables into README.md in place of the old ones")
    args = ap.parse_args(argv)
    tables = (table(args.results), robustness_table(args.results))
    if args.write:
        readme = ROOT / "README.md"
        text = readme.read_text()
        for new in tables:
            text = replace_table(text, new)
        readme.write_text(text)
    print("\n\n".join(tables))
    return 0


if __name__ == "__main__":
    sys.exit(main())
