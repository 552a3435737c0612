"""Trained policies as directories of what training wrote, and the revisions made after it.

A policy directory holds:
- `params.npz`: the flat parameters (`params`), exactly as the checkpoint held them;
- `record.json`: the checkpoint's record (the config it trained with, generations, physics
  steps, wall-clock, devices, versions), as training wrote it;
- `metrics.jsonl` and `learning_curve.png`: the run's per-generation metrics and Fig. 6;
- `revisions.json` (optional): controller settings changed after training, each with its reason
  and date, written by `revise` and never by hand.

`load` gives the parameters with the config they run with: the record's config (brought to the
current form by `config.migrate`) with the revisions applied in order. The policies that ship
with the package are the directories beside this file, one per robot.
"""

from __future__ import annotations

import datetime
import importlib.resources
import json
from pathlib import Path
from typing import Any, NamedTuple

import numpy as np

from mjx_cascade import checkpoint
from mjx_cascade.config import ROBOTS, Config, ConfigError, check_controller_settings, from_dict, get, need

PARAMS, RECORD, METRICS, CURVE, REVISIONS = "params.npz", "record.json", "metrics.jsonl", "learning_curve.png", "revisions.json"


class Policy(NamedTuple):
    params: np.ndarray  # [D] float32
    record: dict  # what training wrote
    revisions: list  # settings changed after training, oldest first
    config: Config  # the record's config with the revisions applied: what the policy runs with

    @property
    def generation(self) -> int:
        return int(self.record["generation"])


def shipped(robot: str) -> Path:
    """The directory of the policy that ships for `robot`."""
    need(robot in ROBOTS, f"unknown robot {robot!r}; choose from {', '.join(ROBOTS)}")
    return Path(str(importlib.resources.files(__name__).joinpath(robot)))


def is_policy_dir(path: Path) -> bool:
    return (path / PARAMS).is_file() and (path / RECORD).is_file()


def read(path: str | Path) -> tuple[dict, np.ndarray]:
    """`(record, params)` of a policy directory, or of a run's latest checkpoint."""
    path = Path(path)
    if not is_policy_dir(path):
        return checkpoint.read(path)
    try:
        record = json.loads((path / RECORD).read_text())
        with np.load(path / PARAMS) as f:
            params = np.asarray(f["params"], dtype=np.float32)
    except (OSError, ValueError, KeyError) as e:
        raise ConfigError(f"{path} holds no readable policy ({type(e).__name__})") from None
    need(isinstance(record, dict) and record.get("format") in checkpoint.READABLE, f"{path} is not an mjx_cascade policy")
    return record, params


def load(source: str | Path) -> Policy:
    """The policy a robot ships with (`source` a robot's name), in a policy directory, or at a run's
    latest checkpoint, with the config it runs with."""
    path = shipped(str(source)) if str(source) in ROBOTS else Path(source)
    if str(source) in ROBOTS and not is_policy_dir(path):
        raise ConfigError(f"no trained {source} policy ships with this version; pass --checkpoint DIR")
    record, params = read(path)
    revisions = json.loads((path / REVISIONS).read_text()) if (path / REVISIONS).is_file() else []
    config = from_dict(record["config"])
    for revision in revisions:
        config = config.override(**revision["settings"])
    return Policy(params, record, revisions, config)


def export(run: str | Path, dest: str | Path) -> Path:
    """Write the latest checkpoint of training run `run` (or the generation `run/checkpoints/<G>`)
    as a policy directory `dest`: its parameters and record, and the run's metrics up to that
    generation with their learning curve."""
    record, params = checkpoint.read(run)
    rows = [json.loads(line) for line in (checkpoint.run_dir(run) / METRICS).read_text().splitlines() if line]
    return write(dest, record, params, [r for r in rows if r["generation"] <= record["generation"]])


def write(dest: str | Path, record: dict, params: np.ndarray, metrics: list[dict]) -> Path:
    """`dest` as a policy directory: `params` with their `record` (a checkpoint's), and the
    run's `metrics` rows up to them with their learning curve."""
    from mjx_cascade import plots

    dest = Path(dest)
    dest.mkdir(parents=True, exist_ok=True)
    np.savez_compressed(dest / PARAMS, params=np.asarray(params, np.float32))
    (dest / RECORD).write_text(json.dumps(record, indent=1) + "\n")
    (dest / METRICS).write_text("".join(json.dumps(row) + "\n" for row in metrics))
    plots.learning_curve(dest / METRICS, dest / CURVE, title=f"{record['robot']}: {record['generation']} "
                         f"generations, {record['physics_steps']:.3g} physics steps")
    return dest


def revise(directory: str | Path, settings: dict[str, Any], reason: str, date: str | None = None) -> dict:
    """Record that the policy in `directory` runs with `settings` changed after training, and why.

    Only controller settings may change (`config.check_controller_settings`); the parameters do
    not. The revision is appended to `revisions.json` with the parameters' hash and the date.
    """
    directory = Path(directory)
    check_controller_settings(settings)
    need(bool(reason.strip()), "a revision needs its reason")
    policy = load(directory)
    revised = policy.config.override(**settings)  # refuses values out of range before anything is written
    revision = {"settings": {key: get(revised, key) for key in settings}, "reason": reason.strip(),
                "date": date or datetime.date.today().isoformat(),
                "params_sha256": checkpoint.params_sha256(policy.params)}
    (directory / REVISIONS).write_text(json.dumps(policy.revisions + [revision], indent=1) + "\n")
    return revision
