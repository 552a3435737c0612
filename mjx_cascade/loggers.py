"""Where each generation's metrics row goes besides `metrics.jsonl`: TensorBoard or Weights & Biases.

A logger gets every row training writes (`log(row, step)`, the step being the row's generation)
and is closed when the run stops. Each numeric field but the generation becomes a scalar tagged
by its key (`fitness_mean`, `reward/vx`, `val/passed`). `make` builds the loggers a run asks for;
`check` refuses a missing package in one line before training starts.
"""

from __future__ import annotations

import importlib
import numbers
import os
import time
from pathlib import Path
from typing import Any, Iterable, Protocol, Sequence

from mjx_cascade.config import ConfigError

KINDS = ("tensorboard", "wandb")
TENSORBOARD = "tensorboard"  # the event files' folder in a run's directory


class Logger(Protocol):
    def log(self, row: dict, step: int) -> None: ...

    def close(self) -> None: ...


def parse(values: Iterable[str]) -> tuple[str, ...]:
    """The kinds named by `--logger` values (repeated or comma-separated; `none` names none), each once."""
    kinds = [k.strip() for v in values for k in v.split(",") if k.strip() and k.strip() != "none"]
    for kind in kinds:
        if kind not in KINDS:
            raise ConfigError(f"unknown logger {kind!r}; choose from none, {', '.join(KINDS)}")
    return tuple(dict.fromkeys(kinds))


def check(kinds: Sequence[str]) -> None:
    """Refuse a logger whose package is not installed, naming the extra that installs it."""
    for kind in kinds:
        try:
            importlib.import_module(kind)
        except ImportError:
            raise ConfigError(f"--logger {kind} needs the {kind} package: pip install -e \".[{kind}]\"") from None


def make(kinds: Sequence[str], out: str | Path, config: dict) -> list[Logger]:
    """The loggers of `kinds` for the run in `out` that trains with `config` (`config.to_dict`)."""
    check(kinds)
    return [TensorBoard(Path(out) / TENSORBOARD) if kind == "tensorboard" else WandB(Path(out), config)
            for kind in kinds]


def scalars(row: dict) -> dict[str, float]:
    """The row's numeric fields but the generation (the step itself), as floats."""
    return {k: float(v) for k, v in row.items() if k != "generation" and isinstance(v, numbers.Real)}


class TensorBoard:
    """Event files under `directory`, through TensorBoard's own writer (no TensorFlow or torch).

    A run's first event is a session start at its first step: where a resumed run goes back to
    its checkpoint, TensorBoard drops the later steps the interrupted run had logged, as
    `metrics.jsonl` drops their rows.
    """

    def __init__(self, directory: Path):
        from tensorboard.summary.writer.event_file_writer import EventFileWriter

        directory.mkdir(parents=True, exist_ok=True)
        self._writer = EventFileWriter(str(directory))
        self._started = False

    def log(self, row: dict, step: int) -> None:
        from tensorboard.compat.proto import event_pb2, summary_pb2

        if not self._started:
            self._writer.add_event(event_pb2.Event(wall_time=time.time(), step=step,
                                                   session_log=event_pb2.SessionLog(status=event_pb2.SessionLog.START)))
            self._started = True
        values = [summary_pb2.Summary.Value(tag=k, simple_value=v) for k, v in scalars(row).items()]
        self._writer.add_event(event_pb2.Event(wall_time=time.time(), step=step, summary=summary_pb2.Summary(value=values)))
        self._writer.flush()  # a row per generation at most: visible in TensorBoard at once

    def close(self) -> None:
        self._writer.close()


class WandB:
    """A Weights & Biases run in project `mjx_cascade`, its files in `out`; `WANDB_MODE` (e.g.
    `offline`) chooses where it goes."""

    def __init__(self, out: Path, config: dict):
        import wandb

        self._run: Any = wandb.init(project="mjx_cascade", dir=str(out), config=config,
                                    mode=os.environ.get("WANDB_MODE"))

    def log(self, row: dict, step: int) -> None:
        self._run.log(scalars(row), step=step)

    def close(self) -> None:
        self._run.finish()
