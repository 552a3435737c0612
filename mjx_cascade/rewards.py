"""Rewards, eq. 13-19 with Table 4's constants, and early termination, eq. 27.

Several printed formulas cannot be meant literally; each function's docstring gives the exact
form implemented (the evident intent) next to the printed one. Every term is non-increasing
in its error (tested), and every in-band reward is bounded so no single lucky step can
dominate an episode's return.
"""

from __future__ import annotations

from typing import NamedTuple

import jax.numpy as jnp
from jax import Array

from mjx_cascade.config import RewardConfig, TerminationConfig

TERMS = ("vx", "vy", "height", "torque", "com", "orientation", "angular_velocity", "feet_distance", "stance_foot")


def velocity(error: Array, band: float, cfg: RewardConfig) -> Array:
    """r_vx, r_vy (eq. 13). Printed: max(rho_v / (e + eps), 1) in band, -rho_v / e^2 outside.

    Implemented, with a = |e|:  min(max(rho_v / (a + eps), 1), cap)  if a <= band,
                                -(a - band)^2                         otherwise.
    The absolute value fixes the printed sign problem; the cap (`velocity_cap`) bounds the
    singular peak at zero error; the printed out-of-band -rho_v / e^2 shrinks as the error
    grows, so the penalty is made to grow with it instead.

    The error is the last walking step's average velocity minus the command, or with
    `velocity_steps: 2` the last stride's (two steps). Not in the paper: a step's sideways average
    alternates with the stance side (by about +-0.1 m/s for Cassie), so a band of 0.2 on it pays
    in full for a 0.1 m/s error in the mean; a stride's average holds the mean alone.
    """
    a = jnp.abs(error)
    inside = jnp.minimum(jnp.maximum(cfg.rho_v / (a + cfg.epsilon), 1.0), cfg.velocity_cap)
    return jnp.where(a <= band, inside, -((a - band) ** 2))


def height(z: Array, zd: float, cfg: RewardConfig) -> Array:
    """r_h for the desired height `zd` (q_z^d, `regulators.height`). Printed: max{(q_z / q_z^d)^2, 1}
    below and max{(q_z^d / q_z)^2, 1} above, both always 1.

    Implemented: min{(q_z / q_z^d)^2, (q_z^d / q_z)^2} within e_qz of q_z^d (1 at the target,
    smaller either side), -(q_z - q_z^d)^2 outside, as printed.
    """
    ratio = jnp.minimum((z / zd) ** 2, (zd / jnp.maximum(z, 1e-6)) ** 2)
    return jnp.where(jnp.abs(z - zd) <= cfg.e_height, ratio, -((z - zd) ** 2))


def torque(u_normalized: Array) -> Array:
    """r_u, eq. 14: -||u||^2, with each torque divided by its actuator limit and averaged.

    In newton-metres ||u||^2 reaches 1e4 and would drown every other term at Table 4's
    weights; normalised, the term lies in [-1, 0] for any robot.
    """
    return -jnp.mean(u_normalized**2)


def com(distance: Array, cfg: RewardConfig) -> Array:
    """r_CoM, eq. 15. Printed: rho_d / d inside P, -(d - 0.1)^2 / rho_d outside.

    Implemented: min(rho_d / d, 1) inside (the printed form is infinite at d = 0), the
    printed penalty outside; P has radius `com_radius` (Table 4's d = 0.1 m).
    """
    r = cfg.com_radius
    inside = cfg.rho_d / jnp.maximum(distance, cfg.rho_d)
    return jnp.where(distance <= r, inside, -((distance - r) ** 2) / cfg.rho_d)


def orientation(rpy_error: Array) -> Array:
    """r_ang, eq. 16: -(roll^2 + pitch^2 + yaw^2), the yaw taken relative to the desired heading."""
    return -jnp.sum(rpy_error**2)


def angular_velocity(omega: Array) -> Array:
    """r_angvel, eq. 17: -(|omega|^2) of the pelvis."""
    return -jnp.sum(omega**2)


def feet_distance(distance: Array, cfg: RewardConfig) -> Array:
    """r_fd, eq. 18, as printed; the distance is the feet's lateral separation (heading frame)."""
    below = -((distance - cfg.feet_min) ** 2)
    above = -((distance - cfg.feet_max) ** 2)
    return jnp.where(distance < cfg.feet_min, below, jnp.where(distance > cfg.feet_max, above, 0.0))


def stance_foot(v: Array, w: Array) -> Array:
    """r_stf, eq. 19: -||v_stf||^2 - ||w_stf||^2 of the stance foot."""
    return -jnp.sum(v**2) - jnp.sum(w**2)


class RewardInputs(NamedTuple):
    v_error: Array  # [2] step- or stride-averaged velocity minus command, heading frame
    height: Array  # pelvis height above the ground
    u_normalized: Array  # [nu] joint torques / actuator limits
    com_distance: Array  # horizontal distance of the CoM from the feet's midpoint
    rpy_error: Array  # [3] pelvis roll, pitch, yaw - desired yaw
    omega: Array  # [3] pelvis angular velocity
    feet_distance: Array  # lateral distance between the feet
    stance_v: Array  # [3] stance foot linear velocity
    stance_w: Array  # [3] stance foot angular velocity


def terms(x: RewardInputs, cfg: RewardConfig, height_des: float) -> Array:
    """The 9 rewards of eq. 13 in the paper's order (`TERMS`); `height_des` is q_z^d."""
    return jnp.stack([
        velocity(x.v_error[0], cfg.e_vx, cfg),
        velocity(x.v_error[1], cfg.e_vy, cfg),
        height(x.height, height_des, cfg),
        torque(x.u_normalized),
        com(x.com_distance, cfg),
        orientation(x.rpy_error),
        angular_velocity(x.omega),
        feet_distance(x.feet_distance, cfg),
        stance_foot(x.stance_v, x.stance_w),
    ])


def weights(cfg: RewardConfig) -> Array:
    """w of eq. 13 in `TERMS`' order."""
    w = cfg.weights
    return jnp.array([getattr(w, name) for name in TERMS], dtype=jnp.float32)


def terminated(x: RewardInputs, cfg: TerminationConfig) -> Array:
    """Eq. 27: the episode ends when any bound is violated."""
    tilt = jnp.abs(x.rpy_error)
    ok = (tilt[0] < cfg.max_tilt) & (tilt[1] < cfg.max_tilt) & (tilt[2] < cfg.max_yaw_error)
    ok &= jnp.all(jnp.abs(x.omega) < cfg.max_rate)
    ok &= (x.height > cfg.height[0]) & (x.height < cfg.height[1])
    ok &= (x.feet_distance > cfg.feet[0]) & (x.feet_distance < cfg.feet[1])
    return ~ok


def diverged(qpos: Array, qvel: Array, cfg: TerminationConfig) -> Array:
    """Physics blew up: NaN or inf anywhere, or a speed no robot reaches."""
    finite = jnp.all(jnp.isfinite(qpos)) & jnp.all(jnp.isfinite(qvel))
    return ~finite | jnp.any(jnp.abs(qvel) > cfg.max_speed)
