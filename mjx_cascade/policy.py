"""The motion policy pi_y (Sec. V-B, Table 1): a small MLP from 6 features to N (M - 1) actions.

6 -> 4 hidden layers of 32 (ReLU) -> N (M - 1) with a sigmoid: 4184 parameters for Cassie
(N = 6, M = 5) and 4316 for Digit (N = 7). ES works on the flat parameter vector; `unravel`
turns it back into flax parameters inside the jitted rollout.
"""

from __future__ import annotations

from typing import Callable, NamedTuple

import flax.linen as nn
import jax
import jax.numpy as jnp
from jax import Array
from jax.flatten_util import ravel_pytree

from mjx_cascade.config import ControllerConfig
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


class Network(NamedTuple):
    """The motion policy as ES sees it: a flat parameter vector and a function of it."""

    module: MotionPolicy
    init_params: Array  # [D] flax's initialisation, flattened
    unravel: Callable[[Array], dict]

    def apply(self, flat: Array, s: Array) -> Array:
        """Actions in (0, 1) for features `s` under flat parameters `flat`."""
        return self.module.apply(self.unravel(flat), s)

    @property
    def num_params(self) -> int:
        return int(self.init_params.shape[0])


def make(action_dim_: int, hidden_layers: int, hidden_units: int, key: Array) -> Network:
    """The network with its initial parameters drawn from `key`."""
    module = MotionPolicy(action_dim_, hidden_layers, hidden_units)
    flat, unravel = ravel_pytree(module.init(key, jnp.zeros((STATE_DIM,))))
    return Network(module, flat, unravel)


def size(cfg: ControllerConfig, num_learned: int) -> tuple[int, int]:
    """`(actions, parameters)` of the network for `num_learned` learned joints under `cfg` (Table 1)."""
    actions = action_dim(num_learned, cfg.gait.bezier_order)
    return actions, param_count(actions, cfg.policy.hidden_layers, cfg.policy.hidden_units)


def for_controller(cfg: ControllerConfig, num_learned: int, key: Array) -> Network:
    """The network a controller of `num_learned` learned joints needs under `cfg`, drawn from `key`."""
    return make(size(cfg, num_learned)[0], cfg.policy.hidden_layers, cfg.policy.hidden_units, key)


def flat_bytes(flat: Array) -> bytes:
    """The parameters' bytes in a fixed order (float32, little-endian): what `params_sha256` hashes."""
    import numpy as np

    return np.asarray(jax.device_get(flat), dtype="<f4").tobytes()
