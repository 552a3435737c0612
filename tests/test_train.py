"""Training's checks on the validation profiles (`train.eval_every`) and the best policy they keep."""

import json

import numpy as np
import orbax.checkpoint as ocp
import pytest

from conftest import DATA
from mjx_cascade import checkpoint, config, policies, profiles, scenario, train


def _results(*profiles_):
    """`evaluate.check`'s shape: `(passed, fell, [(vx, vy, yaw) per judged segment])` per profile."""
    return {f"p{i}": {"passed": p, "fell": f, "fall_time": None,
                      "segments": [{"vx_mae": a, "vy_mae": b, "yaw_mae": c, "within_bounds": p} for a, b, c in segs]}
            for i, (p, f, segs) in enumerate(profiles_)}


def test_a_check_counts_profiles_and_takes_the_worst_judged_errors():
    row = train.validation_row(_results((True, False, [(0.05, 0.02, 0.1), (0.08, 0.01, 0.02)]),
                                        (False, True, [(0.3, 0.04, 0.01)]), (True, False, [])))
    assert row == {"val/passed": 2, "val/count": 3, "val/fell": 1, "val/worst_vx": 0.3, "val/worst_vy": 0.04,
                   "val/worst_yaw": 0.1}
    assert "val/worst_vx" not in train.validation_row(_results((True, False, [])))  # nothing long enough to judge


def test_the_best_check_passes_most_profiles_then_has_the_smallest_worst_errors():
    fewer = train.validation_row(_results((True, False, [(0.01, 0.01, 0.01)]), (False, False, [(0.2, 0.0, 0.0)])))
    more = train.validation_row(_results((True, False, [(0.09, 0.09, 0.1)]), (True, False, [(0.0, 0.0, 0.0)])))
    closer = train.validation_row(_results((True, False, [(0.05, 0.09, 0.1)]), (True, False, [(0.0, 0.0, 0.0)])))
    assert train.validation_score(fewer) < train.validation_score(more) < train.validation_score(closer)


@pytest.mark.slow
def test_eval_every_checks_the_mean_and_keeps_the_best_as_a_loadable_policy(tmp_path):
    """The CLI smoke run's training program and the time-to-walk test's checks (one compile each,
    shared through the cache), four generations checked every two on two short profiles."""
    cfg = config.robot_config("cassie").override(**{
        "es.population": 4, "episode.seconds": 0.5, "episode.pool_size": 4,
        "train.generations": 4, "train.checkpoint_every": 2, "train.eval_every": 2})
    short = [scenario.load(DATA / "short.json"), scenario.load(DATA / "other.json")]
    out, logged = tmp_path / "run", []
    train.train(cfg, out, log=logged.append, log_to=("tensorboard",), validation=short)  # off a terminal: lines

    rows = [json.loads(line) for line in (out / "metrics.jsonl").read_text().splitlines()]
    checked = [r for r in rows if "val/passed" in r]
    assert [r["generation"] for r in checked] == [2, 4] and all(r["val/count"] == 2 for r in checked)
    assert [m.split(":")[0] for m in logged if f"val passed {checked[0]['val/passed']}/2" in m][0] == "generation 2/4"
    assert not any(k.startswith("val/") for r in rows if r not in checked for k in r)
    best_row = max(checked, key=train.validation_score)  # the first of equals
    best = json.loads((out / "best" / "best.json").read_text())
    assert best["generation"] == best_row["generation"] and set(best["profiles"]) == {"short", "other"}
    assert best["validation"] == {k: v for k, v in best_row.items() if k.startswith("val/")}
    assert train._best_score(out) == train.validation_score(best_row)  # what a resumed run compares against

    # the ES mean at that generation, with the record its checkpoint holds
    found = policies.load(out / "best")
    meta = checkpoint.manager(out / "checkpoints").restore(
        best["generation"], args=ocp.args.Composite(meta=ocp.args.JsonRestore())).meta
    assert found.record == meta and found.generation == best["generation"]
    assert checkpoint.params_sha256(found.params) == meta["params_sha256"]
    assert found.config == cfg
    assert [r["generation"] for r in map(json.loads, (out / "best" / "metrics.jsonl").read_text().splitlines())] == \
        list(range(1, best["generation"] + 1))

    # any saved generation, not only the latest, is a policy source: checkpoints/<generation>
    for generation in (2, 4):
        saved = checkpoint.manager(out / "checkpoints").restore(
            generation, args=ocp.args.Composite(meta=ocp.args.JsonRestore())).meta
        assert policies.load(out / "checkpoints" / str(generation)).record == saved
        exported = policies.read(policies.export(out / "checkpoints" / str(generation), tmp_path / f"g{generation}"))
        assert exported[0] == saved and checkpoint.params_sha256(exported[1]) == saved["params_sha256"]
        assert len((tmp_path / f"g{generation}" / "metrics.jsonl").read_text().splitlines()) == generation
    assert policies.load(out).generation == 4

    from tensorboard.backend.event_processing.event_accumulator import EventAccumulator

    board = EventAccumulator(str(out / "tensorboard"))
    board.Reload()
    assert [(e.step, e.value) for e in board.Scalars("val/passed")] == [(r["generation"], r["val/passed"])
                                                                        for r in checked]


@pytest.mark.slow
def test_the_checks_default_to_the_robots_val_profiles_at_the_papers_step(cassie_cfg):
    runners = train.validation_runners(cassie_cfg)
    assert [s.name for r in runners for s in r.scenarios] == [s.name for s in profiles.draw_set("cassie", "val")]
    assert all(r.env.dt == config.PAPER_DT for r in runners)
    assert np.isclose(max(r.times[-1] for r in runners), 20.0)
