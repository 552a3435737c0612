"""Bezier joint trajectories, eq. 11.

    y_i(tau) = sum_k alpha_i[k] * C(M, k) * tau^k * (1 - tau)^(M - k),   tau in [0, 1]

Coefficient arrays have the order on the last axis, `[..., M + 1]`, so one call evaluates
every joint (and, under `vmap`, every environment).
"""

from __future__ import annotations

import math

import jax.numpy as jnp
import numpy as np
from jax import Array


def bernstein(tau: Array, order: int) -> Array:
    """The Bernstein basis of degree `order` at `tau`: `[..., order + 1]`."""
    k = np.arange(order + 1)
    binom = np.array([math.comb(order, i) for i in range(order + 1)], dtype=np.float32)
    tau = jnp.asarray(tau)[..., None]
    return binom * tau**k * (1.0 - tau) ** (order - k)


def value(alpha: Array, tau: Array) -> Array:
    """y(tau) for coefficients `alpha [..., M + 1]`; `tau` broadcasts against `alpha[..., 0]`."""
    order = alpha.shape[-1] - 1
    return jnp.sum(alpha * bernstein(tau, order), axis=-1)


def derivative(alpha: Array, tau: Array) -> Array:
    """dy/dtau: a Bezier curve of order M - 1 with coefficients M (alpha[k+1] - alpha[k])."""
    order = alpha.shape[-1] - 1
    return value(order * jnp.diff(alpha, axis=-1), tau)


def evaluate(alpha: Array, tau: Array, step_time: float | Array) -> tuple[Array, Array]:
    """Desired position and time derivative at phase `tau` of a step lasting `step_time`.

    The phase is clipped to [0, 1]: after a late touchdown the trajectory holds its end
    point with zero velocity instead of extrapolating the polynomial.
    """
    clipped = jnp.clip(tau, 0.0, 1.0)
    inside = (tau >= 0.0) & (tau <= 1.0)
    return value(alpha, clipped), jnp.where(inside, derivative(alpha, clipped) / step_time, 0.0)
