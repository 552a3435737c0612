"""Trained policies shipped with the package: `<robot>.npz` (flat parameters) and `<robot>.json`
(the checkpoint metadata: training config, seed, generations, physics steps, wall-clock)."""

from __future__ import annotations

import importlib.resources
import json

import numpy as np

from mjx_cascade.config import ConfigError


def load(robot: str) -> tuple[dict, np.ndarray]:
    """`(metadata, flat parameters)` of the shipped policy for `robot`."""
    root = importlib.resources.files(__name__)
    params, meta = root.joinpath(f"{robot}.npz"), root.joinpath(f"{robot}.json")
    if not (params.is_file() and meta.is_file()):
        raise ConfigError(f"no trained {robot} policy ships with this version; pass --checkpoint DIR")
    with params.open("rb") as f:
        flat = np.load(f)["params"].astype(np.float32)
    return json.loads(meta.read_text()), flat
