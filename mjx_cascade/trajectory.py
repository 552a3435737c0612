"""Quantities read off a recorded trajectory (`t`, `qpos`, `qvel` in MuJoCo's layout)."""

from __future__ import annotations

import numpy as np

from mjx_cascade.features import to_heading_frame
from mjx_cascade.rotations import quat_to_rpy


def heading_velocity(qpos: np.ndarray, qvel: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """`(v [T, 2] pelvis velocity in the heading frame, yaw [T])` from MuJoCo's free-joint state."""
    yaw = quat_to_rpy(qpos[:, 3:7])[:, 2]
    return to_heading_frame(qvel[:, :2], yaw, np), yaw


def moving_average(x: np.ndarray, t: np.ndarray, window: float) -> np.ndarray:
    """Trailing average over `window` seconds (shorter at the start)."""
    csum = np.concatenate([np.zeros((1,) + x.shape[1:]), np.cumsum(x, axis=0)])
    start = np.searchsorted(t, t - window + 1e-9)
    idx = np.arange(len(t)) + 1
    return (csum[idx] - csum[start]) / (idx - start)[:, None]
