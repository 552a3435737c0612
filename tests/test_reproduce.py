"""`benchmarks/reproduce.py`'s comparison of a rerun's log with a policy's (the rerun itself is
test_cli.py's smoke run)."""

import json
import shutil

from conftest import ROOT, benchmark_script


def test_reproduce_compares_checks_only_where_both_runs_checked(tmp_path):
    """A rerun without `val` checks (`train.eval_every: 0`) compares every training figure; a
    check's figures count where both logs hold them, and their timing never."""
    reproduce = benchmark_script("reproduce")
    policy_dir = ROOT / "benchmarks" / "results" / "candidates" / "cassie_cpu_nvx08" / "policy"
    rows = [json.loads(line) for line in (policy_dir / "metrics.jsonl").read_text().splitlines()][:20]
    assert "val/passed" in rows[9] and "val/passed" not in rows[8]  # a check every 10 generations
    run = tmp_path / "run"
    run.mkdir()

    def write(rows):
        (run / "metrics.jsonl").write_text("".join(json.dumps(r) + "\n" for r in rows))
        return reproduce.compare(run, policy_dir)

    unchecked = [{k: v for k, v in r.items() if not k.startswith("val/")} | {"wall_clock_s": 1.0} for r in rows]
    same = write(unchecked)
    assert same["identical"] and same["generations_compared"] == 20 and same["params"] is None
    retimed = [r | ({"val/seconds": 1.0} if "val/seconds" in r else {}) for r in rows]
    assert write(retimed)["identical"]
    rows[19]["val/passed"] -= 1
    assert write(rows)["first_difference"] == {"generation": 20, "field": "val/passed", "run": rows[19]["val/passed"],
                                               "shipped": rows[19]["val/passed"] + 1}
    unchecked[4]["fitness_mean"] += 1e-6
    assert write(unchecked)["first_difference"]["generation"] == 5


def test_a_rerun_past_a_best_check_policy_is_compared_up_to_its_generation(tmp_path):
    """A policy that was its run's best check, not its last generation, logs up to its own
    generation: a rerun that trained on past it is compared up to there, with its `best/`'s
    parameters where that is the generation, and a `best/` of another generation matches nothing."""
    reproduce = benchmark_script("reproduce")
    policy_dir = ROOT / "mjx_cascade" / "policies" / "digit"
    record = json.loads((policy_dir / "record.json").read_text())
    rows = [json.loads(line) for line in (policy_dir / "metrics.jsonl").read_text().splitlines()]
    assert rows[-1]["generation"] == record["generation"] < record["config"]["train"]["generations"]
    run = tmp_path / "run"
    shutil.copytree(policy_dir, run / "best")
    later = [rows[-1] | {"generation": record["generation"] + k, "fitness_mean": 0.0} for k in (1, 2)]
    (run / "metrics.jsonl").write_text("".join(json.dumps(r) + "\n" for r in rows + later))
    same = reproduce.compare(run, policy_dir)
    assert same["identical"] and same["generations_compared"] == record["generation"] and same["params"]["equal"]
    (run / "best" / "record.json").write_text(json.dumps(record | {"generation": record["generation"] - 10}))
    other = reproduce.compare(run, policy_dir)
    assert not other["identical"] and other["params"] == {"run": None, "shipped": record["params_sha256"], "equal": False}
