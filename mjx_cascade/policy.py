"""The motion policy pi_y (Sec. V-B, Table 1): a small MLP from 6 features to N (M - 1) actions.

6 -> 4 hidden layers of 32 (ReLU) -> N (M - 1) with a sigmoid: 4184 parameters for Cassie
(N = 6, M = 5) and 4316 for Digit (N = 7). ES works on the flat parameter vector; `unravel`
turns it back into flax parameters inside the jitted rollout.
"""

from __future__ import annotations

from typing import Callable

import flax.linen as nn
import jax
import jax.numpy as jnp
from jax import Array
from jax.flatten_util import ravel_pytree

from mjx_cascade.features import STATE_DIM


class MotionPolicy(nn.Module):
    action_dim: int
    hidden_layers: int = 4
    hidden_units: int = 32

    @nn.compact
    def __call__(self, s: Array) -> Array:
        x = s
        for _ in range(self.hidden_layers):
            x = nn.relu(nn.Dense(self.hidden_units)(x))
        return nn.sigmoid(nn.Dense(self.action_dim)(x))


def action_dim(num_learned: int, bezier_order: int) -> int:
    """N (M - 1): the coefficients left free after impact invariance and continuity."""
    return num_learned * (bezier_order - 1)


def param_count(action_dim_: int, hidden_layers: int, hidden_units: int) -> int:
    sizes = [STATE_DIM] + [hidden_units] * hidden_layers + [action_dim_]
    return sum((a + 1) * b for a, b in zip(sizes[:-1], sizes[1:]))


def make(action_dim_: int, hidden_layers: int, hidden_units: int, key: Array) -> tuple[MotionPolicy, Array, Callable]:
    """The module, its initial flat parameter vector and the function that unflattens it."""
    module = MotionPolicy(action_dim_, hidden_layers, hidden_units)
    params = module.init(key, jnp.zeros((STATE_DIM,)))
    flat, unravel = ravel_pytree(params)
    return module, flat, unravel


def apply_flat(module: MotionPolicy, unravel: Callable, flat: Array, s: Array) -> Array:
    """Actions in (0, 1) for features `s` under flat parameters `flat`."""
    return module.apply(unravel(flat), s)


def flat_bytes(flat: Array) -> bytes:
    """The parameters' bytes in a fixed order (float32, little-endian): what `params_sha256` hashes."""
    import numpy as np

    return np.asarray(jax.device_get(flat), dtype="<f4").tobytes()
