"""Does a new training run reproduce a shipped policy's run, generation by generation?

    mjx-cascade train --robot cassie --generations 20 --out runs/repro
    python benchmarks/reproduce.py runs/repro --policy mjx_cascade/policies/cassie --out FILE.json

Compares every generation the new run logged (its `metrics.jsonl`) with the shipped policy's log,
field by field and exactly: fitness, physics steps, sigma, learning rate, episode books. Only the
timing fields (`TIMING`) may differ. The `val` checks' figures (`CHECK`) are compared where both
logs hold them: how often a run is checked (`train.eval_every`, 0 for none) does not change what
it trains, so a rerun may skip the checks that took half of a CPU recipe's time (a rerun of a
320-generation C-engine run without them logged every generation identically:
benchmarks/results/candidates/cassie_cpu_nvx08/reproduce_no_checks.json). Where the run
reached the shipped generation, the parameters' sha256 must match the record's too. Training is
reproducible bit for bit on the same devices and backend (the record's `reproducibility`), so one
differing bit in any generation is a failure. A policy that was its run's best `val` check rather
than its last generation logs up to its own generation; a rerun that trained on past it is
compared up to there, and its parameters at that generation are its `best/` or a saved one.
Writes

    {"run", "policy", "generations_compared", "identical", "first_difference", "params",
     "shipped_devices", "code_version", "date"}

and exits 1 unless every compared generation is identical.
"""

from __future__ import annotations

import argparse
import datetime
import json
import sys
from pathlib import Path

import numpy as np

from mjx_cascade import benchmark, checkpoint, policies

TIMING = ("wall_clock_s", "samples_per_s", "val/seconds")  # the only fields a rerun may change
CHECK = "val/"  # a validation check's figures: compared where both runs checked that generation


def _rows(path: Path) -> dict[int, dict]:
    rows = (json.loads(line) for line in path.read_text().splitlines() if line.strip())
    return {row["generation"]: {k: v for k, v in row.items() if k not in TIMING} for row in rows}


def _differing(new: dict, shipped: dict) -> list[str]:
    """The fields of one generation's rows that differ, a check's only where both rows hold it."""
    checked = any(k.startswith(CHECK) for k in new) and any(k.startswith(CHECK) for k in shipped)
    keys = (k for k in new.keys() | shipped.keys() if checked or not k.startswith(CHECK))
    return sorted(k for k in keys if new.get(k) != shipped.get(k))


def _params_at(run: Path, generation: int) -> np.ndarray | None:
    """The run's parameters at `generation`: its saved generation, else its best check's where that
    is the generation; None where neither holds it."""
    saved = run / "checkpoints" / str(generation)
    if saved.is_dir():
        return policies.read(saved)[1]
    if policies.is_policy_dir(run / "best"):
        record, params = policies.read(run / "best")
        return params if record["generation"] == generation else None
    return None


def compare(run: Path, policy: Path) -> dict:
    """The generations the run logged up to the policy's, compared with the policy's log, and the
    parameters' hash where the run reached the policy's generation."""
    new, shipped = _rows(run / "metrics.jsonl"), _rows(policy / "metrics.jsonl")
    record = policies.read(policy)[0]
    new = {g: row for g, row in new.items() if g <= record["generation"]}  # the policy's log ends there
    first = None
    for generation in sorted(new):
        if generation not in shipped:
            first = {"generation": generation, "field": None, "why": "not in the shipped log"}
            break
        diff = _differing(new[generation], shipped[generation])
        if diff:
            first = {"generation": generation, "field": diff[0], "run": new[generation].get(diff[0]),
                     "shipped": shipped[generation].get(diff[0])}
            break
    result = {"run": str(run), "policy": str(policy), "generations_compared": len(new),
              "identical": first is None and bool(new), "first_difference": first,
              "shipped_devices": record.get("devices"), "params": None}
    if record["generation"] in new:
        params = _params_at(run, record["generation"])
        sha = None if params is None else checkpoint.params_sha256(params)
        result["params"] = {"run": sha, "shipped": record["params_sha256"], "equal": sha == record["params_sha256"]}
        result["identical"] = result["identical"] and result["params"]["equal"]
    return result


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("run", type=Path, help="the new run's --out")
    parser.add_argument("--policy", type=Path, required=True, help="the shipped policy directory")
    parser.add_argument("--out", type=Path, help="where to write the result (JSON)")
    args = parser.parse_args(argv)
    result = compare(args.run, args.policy)
    result.update(code_version=benchmark.code_version(), date=datetime.date.today().isoformat())
    text = json.dumps(result, indent=1)
    if args.out:
        args.out.parent.mkdir(parents=True, exist_ok=True)
        args.out.write_text(text + "\n")
    print(text)
    return 0 if result["identical"] else 1


if __name__ == "__main__":
    sys.exit(main())
