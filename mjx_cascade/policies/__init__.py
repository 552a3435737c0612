"""Trained policies shipped with the package: `<robot>.npz` (flat parameters), `<robot>.json`
(the checkpoint metadata: training config, seed, generations, physics steps, wall-clock), and the
run's learning curve (`<robot>_metrics.jsonl`, `<robot>_learning.png`, Fig. 6)."""

from __future__ import annotations

import importlib.resources
import json
from pathlib import Path

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


def export(run: str | Path, robot: str, dest: str | Path | None = None) -> Path:
    """Ship the latest checkpoint of training run `run` as `<robot>.npz`, `.json` and `_learning.png`.

    `dest` defaults to this package. The learning curve (Fig. 6) is drawn from the run's
    `metrics.jsonl` up to the checkpoint's generation.
    """
    from mjx_cascade import checkpoint, plots

    run = Path(run)
    meta, params = checkpoint.read(run)
    checkpoint.check_robot(meta, robot)
    dest = Path(dest) if dest else Path(str(importlib.resources.files(__name__)))
    dest.mkdir(parents=True, exist_ok=True)
    np.savez_compressed(dest / f"{robot}.npz", params=np.asarray(params, np.float32))
    meta = {**meta, "params_sha256": checkpoint.params_sha256(params)}
    (dest / f"{robot}.json").write_text(json.dumps(meta, indent=1) + "\n")
    rows = [line for line in (run / "metrics.jsonl").read_text().splitlines()
            if line and json.loads(line)["generation"] <= meta["generation"]]
    curve = dest / f"{robot}_metrics.jsonl"
    curve.write_text("".join(f"{line}\n" for line in rows))
    plots.learning_curve(curve, dest / f"{robot}_learning.png",
                         title=f"{robot}: {meta['generation']} generations, {meta['physics_steps']:.3g} physics steps")
    return dest
