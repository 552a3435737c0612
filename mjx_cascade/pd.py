"""Joint PD control, eq. 21, and the map from joint torques to motor commands."""

from __future__ import annotations

import jax.numpy as jnp
from jax import Array


def pd_torque(q: Array, qd: Array, q_ref: Array, qd_ref: Array, kp: Array, kd: Array) -> Array:
    """u = -K_p (q - q^reg) - K_d (qdot - qdot^reg)."""
    return -kp * (q - q_ref) - kd * (qd - qd_ref)


def motor_command(u: Array, gear: Array, ctrl_low: Array, ctrl_high: Array) -> Array:
    """Joint torques -> MuJoCo `ctrl` of `motor` actuators, clipped to the actuator limits."""
    return jnp.clip(u / gear, ctrl_low, ctrl_high)
