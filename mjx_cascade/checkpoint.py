"""Checkpoints with orbax: the ES state (parameters, optimiser, sigma, learning rate, RNG key,
generation) plus a JSON record of what produced it.

Orbax writes each step to a temporary directory and renames it when complete, so a process
killed mid-write leaves the previous checkpoint as the latest one.
"""

from __future__ import annotations

import hashlib
import json
import logging
from pathlib import Path
from typing import Any

import jax
import numpy as np
import orbax.checkpoint as ocp

from mjx_cascade.config import ConfigError
from mjx_cascade.policy import flat_bytes

logging.getLogger("absl").setLevel(logging.WARNING)
FORMAT = "mjx_cascade-checkpoint-1"


def params_sha256(flat: Any) -> str:
    """sha256 of the policy parameters as float32 little-endian bytes in their flat order."""
    return hashlib.sha256(flat_bytes(flat)).hexdigest()


def manager(directory: Path, keep: int = 3) -> ocp.CheckpointManager:
    options = ocp.CheckpointManagerOptions(max_to_keep=keep, create=True, enable_async_checkpointing=False)
    return ocp.CheckpointManager(directory.absolute(), options=options, item_names=("state", "meta"))


def save(mngr: ocp.CheckpointManager, step: int, state: Any, meta: dict) -> None:
    meta = {**meta, "format": FORMAT, "generation": int(step), "params_sha256": params_sha256(state.mean)}
    mngr.save(step, args=ocp.args.Composite(state=ocp.args.StandardSave(state), meta=ocp.args.JsonSave(meta)))
    mngr.wait_until_finished()


def restore(mngr: ocp.CheckpointManager, template: Any, step: int | None = None) -> tuple[Any, dict]:
    step = mngr.latest_step() if step is None else step
    out = mngr.restore(step, args=ocp.args.Composite(state=ocp.args.StandardRestore(template),
                                                     meta=ocp.args.JsonRestore()))
    return out.state, out.meta


def is_checkpoint_dir(path: Path) -> bool:
    return path.is_dir() and any(p.is_dir() and p.name.isdigit() for p in path.iterdir())


def read(path: str | Path) -> tuple[dict, np.ndarray]:
    """`(meta, params)` of the latest checkpoint in `path` (a run's `--out` or its `checkpoints/`),
    or of an exported policy `NAME.npz` with its `NAME.json` beside it (the shipped format)."""
    path = Path(path).absolute()  # orbax finds no array metadata under a relative path
    if path.suffix == ".npz":
        return _read_exported(path)
    if (path / "checkpoints").is_dir():
        path = path / "checkpoints"
    if not is_checkpoint_dir(path):
        raise ConfigError(f"{path} is not a checkpoint directory (no saved generations in it)")
    mngr = manager(path)
    step = mngr.latest_step()
    try:
        meta = mngr.restore(step, args=ocp.args.Composite(meta=ocp.args.JsonRestore())).meta
        state = _read_numpy(path / str(step) / "state")
    except Exception as e:  # orbax raises many kinds for a damaged or foreign directory
        raise ConfigError(f"{path} holds no readable checkpoint ({type(e).__name__})") from None
    if not isinstance(meta, dict) or meta.get("format") != FORMAT:
        raise ConfigError(f"{path} is not an mjx_cascade checkpoint")
    return meta, np.asarray(state["mean"], dtype=np.float32)


def _read_exported(path: Path) -> tuple[dict, np.ndarray]:
    meta_path = path.with_suffix(".json")
    if not (path.is_file() and meta_path.is_file()):
        raise ConfigError(f"{path} needs {meta_path.name} beside it (an exported policy is a .npz and a .json)")
    try:
        meta = json.loads(meta_path.read_text())
        with np.load(path) as f:
            params = np.asarray(f["params"], dtype=np.float32)
    except (OSError, ValueError, KeyError) as e:
        raise ConfigError(f"{path} holds no readable policy ({type(e).__name__})") from None
    if not isinstance(meta, dict) or meta.get("format") != FORMAT:
        raise ConfigError(f"{meta_path} is not an mjx_cascade policy")
    return meta, params


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


def check_compatible(meta: dict, robot: str, num_params: int, action_dim: int) -> None:
    """A checkpoint for another robot or policy shape cannot be resumed here."""
    check_robot(meta, robot)
    if meta.get("policy_params") != num_params or meta.get("action_dim") != action_dim:
        raise ConfigError(
            f"the checkpoint's policy has {meta.get('policy_params')} parameters and {meta.get('action_dim')} "
            f"actions; this config needs {num_params} and {action_dim}")
