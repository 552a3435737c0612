"""Checkpoints with orbax: the ES state (parameters, optimiser, generation, the run's key) plus a
JSON record of what produced it.

Orbax writes each step to a temporary directory and renames it when complete, so a process
killed mid-write leaves the previous checkpoint as the latest one.
"""

from __future__ import annotations

import hashlib
import logging
from pathlib import Path
from typing import Any

import jax
import numpy as np
import orbax.checkpoint as ocp

from mjx_cascade.config import ConfigError
from mjx_cascade.policy import flat_bytes

logging.getLogger("absl").setLevel(logging.WARNING)
FORMAT = "mjx_cascade-checkpoint-2"
READABLE = ("mjx_cascade-checkpoint-1", FORMAT)  # format 1 held sigma and the learning rate in the state


def params_sha256(flat: Any) -> str:
    """sha256 of the policy parameters as float32 little-endian bytes in their flat order."""
    return hashlib.sha256(flat_bytes(flat)).hexdigest()


def manager(directory: Path, keep: int = 3) -> ocp.CheckpointManager:
    options = ocp.CheckpointManagerOptions(max_to_keep=keep, create=True, enable_async_checkpointing=False)
    return ocp.CheckpointManager(directory.absolute(), options=options, item_names=("state", "meta"))


def record(meta: dict, step: int, params: Any) -> dict:
    """What a checkpoint (or a policy directory) of `params` at generation `step` records."""
    return {**meta, "format": FORMAT, "generation": int(step), "params_sha256": params_sha256(params)}


def save(mngr: ocp.CheckpointManager, step: int, state: Any, meta: dict) -> None:
    meta = record(meta, step, state.mean)
    mngr.save(step, args=ocp.args.Composite(state=ocp.args.StandardSave(state), meta=ocp.args.JsonSave(meta)))
    mngr.wait_until_finished()


def restore(mngr: ocp.CheckpointManager, template: Any, step: int | None = None) -> tuple[Any, dict]:
    step = mngr.latest_step() if step is None else step
    out = mngr.restore(step, args=ocp.args.Composite(state=ocp.args.StandardRestore(template),
                                                     meta=ocp.args.JsonRestore()))
    return out.state, out.meta


def is_checkpoint_dir(path: Path) -> bool:
    return path.is_dir() and any(p.is_dir() and p.name.isdigit() for p in path.iterdir())


def run_dir(path: str | Path) -> Path:
    """The run's `--out` of a checkpoint source: the run itself, its `checkpoints/`, or one saved
    generation in it (`checkpoints/<generation>`)."""
    path = Path(path).absolute()
    return path.parent.parent if _is_generation(path) else path.parent if path.name == "checkpoints" else path


def read(path: str | Path) -> tuple[dict, np.ndarray]:
    """`(meta, params)` of the latest checkpoint in `path` (a run's `--out` or its `checkpoints/`),
    or of the generation `path` names (`checkpoints/<generation>`: choosing among saved ones)."""
    path = Path(path).absolute()  # orbax finds no array metadata under a relative path
    step = int(path.name) if _is_generation(path) else None
    path = path.parent if step is not None else path
    if (path / "checkpoints").is_dir():
        path = path / "checkpoints"
    if not is_checkpoint_dir(path):
        raise ConfigError(f"{path} is not a checkpoint directory (no saved generations in it)")
    mngr = manager(path)
    step = mngr.latest_step() if step is None else step
    try:
        meta = mngr.restore(step, args=ocp.args.Composite(meta=ocp.args.JsonRestore())).meta
        state = _read_numpy(path / str(step) / "state")
    except Exception as e:  # orbax raises many kinds for a damaged or foreign directory
        raise ConfigError(f"{path} holds no readable checkpoint ({type(e).__name__})") from None
    if not isinstance(meta, dict) or meta.get("format") not in READABLE:
        raise ConfigError(f"{path} is not an mjx_cascade checkpoint")
    return meta, np.asarray(state["mean"], dtype=np.float32)


def _is_generation(path: Path) -> bool:
    return path.name.isdigit() and path.parent.name == "checkpoints" and path.is_dir()


def _read_numpy(path: Path) -> dict:
    """A saved state as host numpy arrays, whatever devices saved it (a restore that keeps the
    saved sharding refuses a checkpoint written on another device count)."""
    absl = logging.getLogger("absl")
    level = absl.level
    absl.setLevel(logging.ERROR)  # the step's metadata file is one level up, and orbax warns of it
    try:
        with ocp.PyTreeCheckpointer() as c:
            tree = c.metadata(path).item_metadata.tree
            args = jax.tree.map(lambda _: ocp.RestoreArgs(restore_type=np.ndarray), tree)
            return c.restore(path, args=ocp.args.PyTreeRestore(restore_args=args))
    finally:
        absl.setLevel(level)


def check_robot(meta: dict, robot: str) -> None:
    if meta.get("robot") != robot:
        raise ConfigError(f"the checkpoint is for robot {meta.get('robot')!r}, not {robot!r}")


def check_compatible(meta: dict, robot: str, num_params: int) -> None:
    """A policy for another robot or network shape cannot be trained on here."""
    check_robot(meta, robot)
    if meta.get("policy_params") != num_params:
        raise ConfigError(f"the checkpoint's policy has {meta.get('policy_params')} parameters; "
                          f"this config needs {num_params}")


def check_resumable(meta: dict, robot: str, num_params: int) -> None:
    """Only a checkpoint of this version, robot and network shape resumes."""
    check_compatible(meta, robot, num_params)
    if meta.get("format") != FORMAT:
        raise ConfigError("the checkpoint was written by an earlier mjx_cascade and cannot be resumed; "
                          "warm-start a new run from it with --init")
