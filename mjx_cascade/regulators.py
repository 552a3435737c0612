"""The feedback regulator policy pi_m of Sec. IV: trajectory compensations and torso torques.

Every function works on small arrays and a `RegulatorConfig`; the robot supplies the
kinematic signs (derived from its model, `robots/base.py`) that turn "move the swing foot
forward / outward" or "pitch the pelvis back" into joint-space signs. This replaces the
paper's hand-set S_y and S_theta (eq. 24 and Sec. IV-B) for any leg geometry.

Velocities are in the heading frame: `v_bar` is the pelvis velocity that the linear inverted
pendulum (LIP) predicts for the end of the current step (`predicted_velocity`), `v_des` the
command and `v_ls` the average over the previous step (v^ls). Deviation: the paper's vbar is an
average velocity. Neither average worked for Cassie's first steps from standing:
- the previous step's average leaves the first step uncorrected, and the robot falls towards
  the swing side before any placement acts;
- the current step's running average starts each step with the velocity towards the new
  stance foot that an in-place gait always has, so it pulls the swing foot across.
With the LIP's end-of-step prediction a hand-set constant gait steps in place for 8 s; with
either average it fell within 0.9 s.
"""

from __future__ import annotations

import jax.numpy as jnp
import numpy as np
from jax import Array

from mjx_cascade.config import RegulatorConfig


def wrap_angle(a: Array) -> Array:
    """Angle in (-pi, pi]."""
    return jnp.arctan2(jnp.sin(a), jnp.cos(a))


def blend(tau: Array, cfg: RegulatorConfig) -> Array:
    """Phase smoothing of the swing compensations: 0 at the step start, 1 after `blend_phase`."""
    return jnp.clip(tau / cfg.blend_phase, 0.0, 1.0)


GRAVITY = 9.81  # m/s^2


def predicted_velocity(rel: Array, v: Array, height: Array, remaining: Array) -> Array:
    """LIP prediction (x'' = g/h x) of the pelvis velocity `remaining` seconds ahead.

    `rel [2]`: centre of mass minus stance foot, `v [2]`: pelvis velocity, both horizontal in the
    heading frame; `height`: centre of mass above the stance foot.
    """
    w = jnp.sqrt(GRAVITY / height)
    return rel * w * jnp.sinh(w * remaining) + v * jnp.cosh(w * remaining)


def neutral_point(v_bar: Array, height: Array, step_time: float, cfg: RegulatorConfig) -> Array:
    """Raibert's neutral point: swing hip offsets `[forward, leftward]` of v T / 2 over the leg height.

    A foot landing half a step's travel ahead of the hip keeps the speed it has; eq. 23 only
    moves the foot by the velocity *error*, so an untrained policy that lands the foot under
    the hip speeds up until the error alone places it far enough. Deviation: the paper leaves
    this offset to the learned trajectories. `k_neutral_x`, `k_neutral_y` scale it per direction.
    `neutral_vx_max` (0: none) bounds the forward velocity it grows with: up to the fastest command
    the point is Raibert's, beyond it (mostly after a forward push) it holds, and the velocity-error
    terms answer the excess. A shorter point at every speed (k_neutral_x 0.8) held more 125-N forward
    pushes but slowed a 0.8 -> -0.3 m/s reversal to 3.0 s (benchmarks/results/candidates/); bounding
    backward speeds too (at -0.3 m/s) lost backward pushes (benchmarks/results/push_scan/README.md).
    """
    k = jnp.array([cfg.k_neutral_x, cfg.k_neutral_y], dtype=jnp.float32)
    if cfg.neutral_vx_max > 0:
        v_bar = v_bar.at[0].set(jnp.minimum(v_bar[0], cfg.neutral_vx_max))
    return k * v_bar * step_time / (2.0 * height)


def swing_levelling(rpy: Array) -> Array:
    """Swing hip offsets `[forward, leftward]` that cancel the pelvis tilt (rad, as `swing_placement`).

    The swing leg hangs from the pelvis, so a pelvis rolled by phi carries the foot sideways by
    about phi times the leg length, as far as a hip roll of phi does. Deviation: the paper adds
    no such term. Without it, the pelvis tilting towards the swing side in Cassie's first step
    carried the swing foot inwards while the placement moved it out. It ramps in with `blend`
    like the other swing compensations, so the switch keeps impact invariance.
    """
    return jnp.stack([rpy[1], -rpy[0]])


def swing_placement(v_bar: Array, v_des: Array, v_ls: Array, beta: Array, tau: Array, cfg: RegulatorConfig) -> Array:
    """Eq. 23-26, rows 1-2: how far to move the swing foot `[forward, leftward]`, in hip radians.

    delta_hp = K_php (v_x - v_x^d) + K_dhp (v_x - v_x^ls) + beta_x
    delta_hr = K_phr (v_y - v_y^d) + K_dhr (v_y - v_y^ls) + beta_y
    Positive moves the foot in the direction of the excess velocity (Raibert's foot placement).
    The printed P matrix repeats K_dhr in row 2; K_dhp (Table 7) is the evident intent. The
    robot multiplies each component by the sign of d(foot position)/d(joint angle).
    Deviation: `backstep_limit` (0: none) bounds the K_php term where it moves the foot back. A
    backward push of 100 N takes about 0.65 m/s off Cassie, so the term asks for 0.2 rad; v1's
    parameters fell 0.6 to 0.9 s later in 6 of 10 trials, and with the term bounded at 0.1 rad in
    none (benchmarks/results/backstep_on_v1/). No shipped policy trained with a bound.
    """
    e_des = v_bar - v_des
    e_last = v_bar - v_ls
    p_x = cfg.k_php * e_des[0]
    if cfg.backstep_limit > 0:
        p_x = jnp.maximum(p_x, -cfg.backstep_limit)
    forward = p_x + cfg.k_dhp * e_last[0] + beta[0]
    lateral = cfg.k_phr * e_des[1] + cfg.k_dhr * e_last[1] + beta[1]
    return blend(tau, cfg) * jnp.stack([forward, lateral])


HEIGHT_ERROR_LIMIT = 0.1  # m: larger sags are falls, not errors to correct


def height_fix(height: Array, height_des: float, cfg: RegulatorConfig) -> Array:
    """Stance knee extension, rad (positive extends the leg), for the pelvis `height` above the
    ground under the stance foot.

    Not in the paper. After a forward push the swing foot lands early with its knee still bent
    and the pelvis sinks a little further each step (0.92 to 0.79 m in four steps, then a fall);
    nothing in eq. 20-26 acts on height, and the learned stance knee only sees the commanded and
    step-averaged velocities. The height is taken over the stance foot's ground, which the robot
    can measure through its leg, not over the terrain under the pelvis, which it cannot.
    """
    return cfg.k_height * jnp.clip(height_des - height, -HEIGHT_ERROR_LIMIT, HEIGHT_ERROR_LIMIT)


def ground_rise(slope: Array, offset: Array) -> Array:
    """Height of the estimated ground plane at `offset [2]` (forward, leftward, m, heading frame)
    from the stance foot, for the terrain `slope [2]` (pitch: positive where the ground falls
    forward; roll: positive where it rises to the left), rad.

    Lets `height_fix` measure the pelvis over the ground beneath it, not over the stance foot.
    """
    return -jnp.tan(slope[0]) * offset[0] + jnp.tan(slope[1]) * offset[1]


def heading(yaw: Array, yaw_des: Array, tau: Array, cfg: RegulatorConfig) -> Array:
    """Eq. 24 row 3: swing hip yaw offset, in the direction that turns the pelvis back to `yaw_des`.

    Returned as "pelvis yaw change over the next stance" (negative of the error); the robot
    converts it with the sign of d(pelvis yaw)/d(stance hip yaw).
    """
    return -cfg.k_heading * blend(tau, cfg) * wrap_angle(yaw - yaw_des)


def rate_limit(followed: Array, cmd: Array, dt: float, cfg: RegulatorConfig) -> Array:
    """Move the followed command `[vx, vy, yaw]` towards `cmd` by at most `command_rate` x `dt`.

    Not in the paper, whose episodes hold one command. A policy trained on command changes fell
    1 to 1.5 s after jumps of about 1 m/s (often with a heading change of 0.5 to 0.8 rad); fed the
    same commands through a ramp of 1 m/s^2 and 1 rad/s it did not. A rate of 0 follows at once.
    """
    rate_v, rate_yaw = cfg.command_rate
    limit = np.array([rate_v, rate_v, rate_yaw], np.float32) * dt
    delta = cmd - followed
    delta = delta.at[2].set(wrap_angle(delta[2]))
    return jnp.where(limit > 0, followed + jnp.clip(delta, -limit, limit), cmd)


def drift_update(beta: Array, v_step: Array, v_des: Array, cfg: RegulatorConfig) -> Array:
    """The PI terms beta_x, beta_y: integrate each step's average velocity error, bounded.

    Each axis has its own gain (`k_i_drift`, `k_i_drift_y`): the lateral integral can overshoot
    a change of vy command while the swing hip roll already tracks it, so it is tuned apart.
    """
    gain = jnp.array([cfg.k_i_drift, cfg.k_i_drift_y])
    return jnp.clip(beta + gain * (v_step - v_des), -cfg.drift_limit, cfg.drift_limit)


def stance_foot_tilt(v_bar: Array, v_des: Array, cfg: RegulatorConfig) -> Array:
    """Eq. 24 rows 6-7: stance foot `[pitch, roll]` offsets from the velocity error (Digit)."""
    e = v_bar - v_des
    return jnp.stack([cfg.k_ptp * e[0], cfg.k_ptr * e[1]])


def torso_torque(rpy: Array, rate: Array, cfg: RegulatorConfig) -> Array:
    """Sec. IV-B: the corrective torque `[about x, about y]` the stance hip must put on the pelvis.

    -[K_p_psi q_psi + K_d_psi dq_psi,  K_p_theta q_theta + K_d_theta dq_theta] for an
    upright torso (desired roll and pitch zero); the robot turns it into stance hip roll and
    pitch joint torques through the joint axes (the reaction of a joint torque on the pelvis).
    Works on NumPy arrays too (the standing controller runs it outside JAX).
    """
    kp = np.array([cfg.k_p_roll, cfg.k_p_pitch], dtype=np.float32)
    kd = np.array([cfg.k_d_roll, cfg.k_d_pitch], dtype=np.float32)
    return -(kp * rpy[:2] + kd * rate[:2])
