"""Quaternion helpers shared by the JAX controller and the NumPy tools (`xp` picks the library)."""

from __future__ import annotations

import numpy as np


def quat_to_rpy(q, xp=np):
    """Roll, pitch, yaw `[..., 3]` (z-y-x intrinsic) of unit quaternions `[..., 4]` in MuJoCo's (w, x, y, z)."""
    w, x, y, z = q[..., 0], q[..., 1], q[..., 2], q[..., 3]
    roll = xp.arctan2(2 * (w * x + y * z), 1 - 2 * (x * x + y * y))
    pitch = xp.arcsin(xp.clip(2 * (w * y - z * x), -1.0, 1.0))
    yaw = xp.arctan2(2 * (w * z + x * y), 1 - 2 * (y * y + z * z))
    return xp.stack([roll, pitch, yaw], axis=-1)


def tilt(q, xp=np):
    """Angle between the body's z axis and the vertical, for unit quaternions `[..., 4]`."""
    x, y = q[..., 1], q[..., 2]
    return xp.arccos(xp.clip(1 - 2 * (x * x + y * y), -1.0, 1.0))
