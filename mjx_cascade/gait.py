"""The action map of Sec. III-C: policy outputs -> Bezier coefficients of the learned joints.

Joint values are handled in *role coordinates*: an array `[2, J]` whose row 0 is the stance
leg and row 1 the swing leg, each in the left leg's sign convention. The symmetry map T of
eq. 12 is then the change from role to absolute coordinates, which depends on which foot
is in stance: a leg's absolute angle is its role value times `mirror[j]` (+-1 per joint
type, derived from the model) if it is the right leg, and the role value itself if it is
the left. One set of learned coefficients therefore drives both stances.

Coefficients of each learned joint, `alpha [M + 1]` (eq. 11):
- alpha[0] = the joint's position at the step start (impact invariance);
- alpha[1] = alpha[0]: the desired velocity is zero at the switch, so the PD's derivative
  term does not kick at impact;
- alpha[2..M] = the policy's N x (M - 1) sigmoid outputs scaled into each joint's range.

The paper's continuity condition alpha_R[M] = alpha_L[0] holds by construction: the next
step's alpha[0] is the measured position where this step ended. Deviation: the paper fixes
its second coefficient by writing alpha_R[M] = (T alpha_R)[0] over the N learned joints,
which cannot be applied as printed because the mirror partners of the swing hip roll and
pitch (the stance hip roll and pitch) are torque-regulated, not learned; tying alpha[1]
keeps the paper's count of N (M - 1) outputs and leaves the step's end point to the policy.
"""

from __future__ import annotations

import jax.numpy as jnp
import numpy as np
from jax import Array

STANCE, SWING = 0, 1  # rows of role coordinates
LEFT, RIGHT = 0, 1  # rows of absolute per-leg coordinates; also the value of `stance`
LATERAL_MIRROR = np.array([1.0, -1.0], np.float32)  # a heading-frame [x, y] vector seen in a mirror


def role_to_absolute(role: Array, stance: Array, mirror: Array) -> Array:
    """Role coordinates `[2, J]` -> per-leg absolute angles `[2, J]` (row 0 left, row 1 right)."""
    right_stance = stance == RIGHT
    left = jnp.where(right_stance, role[SWING], role[STANCE])
    right = jnp.where(right_stance, role[STANCE], role[SWING]) * mirror
    return jnp.stack([left, right])


def absolute_to_role(absolute: Array, stance: Array, mirror: Array) -> Array:
    """Inverse of `role_to_absolute` (mirror signs are +-1, so the map is its own inverse)."""
    right_stance = stance == RIGHT
    left, right = absolute[LEFT], absolute[RIGHT] * mirror
    return jnp.stack([jnp.where(right_stance, right, left), jnp.where(right_stance, left, right)])


def velocity_to_role(v: Array, stance: Array) -> Array:
    """Heading-frame velocities `[..., 2]` as the left-stance gait sees them: the state's half of T.

    Role coordinates describe every walking step as a left-stance step (a right-stance step is
    its mirror image across the sagittal plane), so the policy that learns "the" step's
    coefficients must see the state in the same picture: in right stance the lateral
    components change sign. The controller applies it to the policy's features.
    Deviation (reading of eq. 12): the paper maps the coefficients, alpha^L = T alpha^R, and is
    silent on the state. Without the state's mirror the same features give the same role
    coefficients in both stances, so a sideways gait, which needs different swing hip rolls on
    the two sides, can come from the policy only through the sway of the step-averaged velocity
    (which alternates with the stance side) or from the regulators.
    """
    return jnp.where(stance == RIGHT, v * LATERAL_MIRROR, v)


def symmetry_matrix(roles: np.ndarray, types: np.ndarray, mirror: np.ndarray) -> np.ndarray:
    """T of eq. 12: right-stance absolute coefficients of the learned joints -> left-stance ones.

    Learned joint i is leg joint `types[i]` of the stance (role 0) or swing (role 1) leg. In
    right stance the stance leg is the right one, in left stance the left one; T is diagonal
    with the product of the two sign conventions, an involution (T @ T = I).
    """
    roles, types, mirror = map(np.asarray, (roles, types, mirror))
    sign_right_stance = np.where(roles == STANCE, mirror[types], 1.0)
    sign_left_stance = np.where(roles == STANCE, 1.0, mirror[types])
    return np.diag(sign_left_stance * sign_right_stance).astype(np.float32)


def coefficients(action: Array, q_start: Array, low: Array, high: Array) -> Array:
    """Bezier coefficients `[N, M + 1]` from sigmoid outputs `[N * (M - 1)]` in (0, 1).

    `q_start [N]`: the learned joints' role-coordinate positions at the step start.
    `low, high [N]` or `[N, M - 1]`: each learned joint's range, for all its free coefficients
    or for each one.
    """
    n = q_start.shape[0]
    low, high = low.reshape(n, -1), high.reshape(n, -1)
    free = low + (high - low) * action.reshape(n, -1)
    return jnp.concatenate([q_start[:, None], q_start[:, None], free], axis=1)


def step_ended(tau: Array, swing_force: Array, lifted: Array, min_phase: float, max_phase: float,
               threshold: float) -> Array:
    """Stance switch (Sec. III-C): swing-foot touchdown after `min_phase`, or a time-out.

    A touchdown is the swing foot's normal force rising above `threshold` after the foot
    has been unloaded (`lifted`) during this step: a foot that never left the ground has not
    landed, and its step ends only by time-out.
    """
    return ((tau >= min_phase) & lifted & (swing_force > threshold)) | (tau >= max_phase)
