"""Quantities read off a recorded trajectory (`t`, `qpos`, `qvel` in MuJoCo's layout)."""

from __future__ import annotations

import numpy as np


def heading_velocity(qpos: np.ndarray, qvel: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """`(v [T, 2] pelvis velocity in the heading frame, yaw [T])` from MuJoCo's free-joint state."""
    w, x, y, z = qpos[:, 3], qpos[:, 4], qpos[:, 5], qpos[:, 6]
    yaw = np.arctan2(2 * (w * z + x * y), 1 - 2 * (y * y + z * z))
    c, s = np.cos(yaw), np.sin(yaw)
    vx, vy = qvel[:, 0], qvel[:, 1]
    return np.stack([c * vx + s * vy, -s * vx + c * vy], axis=1), yaw


def tilt(qpos: np.ndarray) -> np.ndarray:
    """Angle between the pelvis z axis and the vertical."""
    x, y = qpos[:, 4], qpos[:, 5]
    return np.arccos(np.clip(1 - 2 * (x * x + y * y), -1.0, 1.0))


def moving_average(x: np.ndarray, t: np.ndarray, window: float) -> np.ndarray:
    """Trailing average over `window` seconds (shorter at the start)."""
    csum = np.concatenate([np.zeros((1,) + x.shape[1:]), np.cumsum(x, axis=0)])
    start = np.searchsorted(t, t - window + 1e-9)
    idx = np.arange(len(t)) + 1
    return (csum[idx] - csum[start]) / (idx - start)[:, None]
