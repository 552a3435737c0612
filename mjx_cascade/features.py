"""The feature map G of eq. 8 and Sec. V-A: full state and command -> the policy's 6 inputs.

s = (v_x^d, v_y^d, vbar_x, vbar_y, vbar_x - v_x^d, vbar_y - v_y^d), with vbar the pelvis
velocity averaged over the last walking step, all in the heading frame (the world frame
rotated by the pelvis yaw). The controller hands them over in the
left-stance picture of the role coordinates (`gait.velocity_to_role`): in right stance their
lateral components are negated.
"""

from __future__ import annotations

import jax.numpy as jnp
from jax import Array

STATE_DIM = 6


def to_heading_frame(v_world_xy, yaw, xp=jnp):
    """Rotate world-frame horizontal vectors `[..., 2]` into the frame turned by `yaw` about z.

    `xp` is the array module: `jax.numpy` in the controller, NumPy for recorded trajectories.
    """
    c, s = xp.cos(yaw), xp.sin(yaw)
    x, y = v_world_xy[..., 0], v_world_xy[..., 1]
    return xp.stack([c * x + s * y, -s * x + c * y], axis=-1)


def features(v_desired: Array, v_average: Array) -> Array:
    """The 6 features from the commanded and step-averaged velocities `[..., 2]` (heading frame)."""
    return jnp.concatenate([v_desired, v_average, v_average - v_desired], axis=-1)
