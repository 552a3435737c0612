"""The loggers a training run's metrics rows go to, fed rows as the training loop feeds them."""

import sys
import types

import pytest

from mjx_cascade import cli, loggers
from mjx_cascade.config import ConfigError


def _rows(generations, offset=0.0):
    return [{"generation": g, "fitness_mean": 0.1 * g + offset, "reward/vx": 0.5 + g + offset, "diverged": 0,
             "val/passed": g} for g in generations]


def _scalars(directory):
    from tensorboard.backend.event_processing.event_accumulator import EventAccumulator

    acc = EventAccumulator(str(directory))
    acc.Reload()
    return {tag: [(e.step, e.value) for e in acc.Scalars(tag)] for tag in acc.Tags()["scalars"]}


def test_tensorboard_reads_every_numeric_field_by_its_key_at_its_generation(tmp_path):
    (board,) = loggers.make(["tensorboard"], tmp_path, {})
    for row in _rows([1, 2, 3]):
        board.log({**row, "note": "skipped"}, row["generation"])
    board.close()
    scalars = _scalars(tmp_path / "tensorboard")
    assert set(scalars) == {"fitness_mean", "reward/vx", "diverged", "val/passed"}  # the generation is the step
    assert scalars["reward/vx"] == [(g, pytest.approx(0.5 + g)) for g in (1, 2, 3)]
    assert scalars["fitness_mean"] == [(g, pytest.approx(0.1 * g)) for g in (1, 2, 3)]


def test_a_resumed_run_replaces_the_generations_after_its_checkpoint(tmp_path):
    """As `metrics.jsonl` drops the rows an interrupted run logged after its last checkpoint."""
    (first,) = loggers.make(["tensorboard"], tmp_path, {})
    for row in _rows([1, 2, 3]):
        first.log(row, row["generation"])
    first.close()
    (resumed,) = loggers.make(["tensorboard"], tmp_path, {})  # from the checkpoint at generation 1
    for row in _rows([2, 3], offset=10.0):
        resumed.log(row, row["generation"])
    resumed.close()
    assert _scalars(tmp_path / "tensorboard")["reward/vx"] == [(1, pytest.approx(1.5)), (2, pytest.approx(12.5)),
                                                               (3, pytest.approx(13.5))]


def test_wandb_gets_the_run_config_and_every_row_at_its_step(tmp_path, monkeypatch):
    calls = []

    class Run:
        def log(self, data, step):
            calls.append(("log", data, step))

        def finish(self):
            calls.append(("finish",))

    def init(**kwargs):
        calls.append(("init", kwargs))
        return Run()

    monkeypatch.setitem(sys.modules, "wandb", types.SimpleNamespace(init=init))
    monkeypatch.setenv("WANDB_MODE", "offline")
    (run,) = loggers.make(["wandb"], tmp_path, {"robot": "cassie"})
    for row in _rows([4, 5]):
        run.log(row, row["generation"])
    run.close()
    assert calls[0] == ("init", {"project": "mjx_cascade", "dir": str(tmp_path), "config": {"robot": "cassie"},
                                 "mode": "offline"})
    assert [(c[2], c[1]["fitness_mean"], "generation" in c[1]) for c in calls[1:3]] == [
        (4, pytest.approx(0.4), False), (5, pytest.approx(0.5), False)]
    assert calls[3:] == [("finish",)]


def test_logger_names_parse_from_repeats_and_commas():
    assert loggers.parse(["tensorboard,wandb", "tensorboard"]) == ("tensorboard", "wandb")
    assert loggers.parse(["none"]) == loggers.parse([]) == ()
    with pytest.raises(ConfigError, match="unknown logger 'mlflow'"):
        loggers.parse(["mlflow"])


def test_a_missing_package_is_one_line_naming_its_extra_before_anything_is_written(tmp_path, monkeypatch, capsys):
    monkeypatch.setitem(sys.modules, "wandb", None)  # an import of it fails, as where it is not installed
    out = tmp_path / "run"
    code = cli.main(["train", "--robot", "cassie", "--out", str(out), "--logger", "tensorboard,wandb"])
    err = capsys.readouterr().err.strip()
    assert code == cli.EXIT_USAGE and len(err.splitlines()) == 1
    assert 'pip install -e ".[wandb]"' in err and not out.exists()
