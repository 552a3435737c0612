"""Domain randomization, Table 5: per-episode link masses and centre-of-mass positions.

Each episode scales every body's mass by U(mass) and its centre-of-mass offset by U(com),
body by body. Under `jax.vmap` the model becomes batched in exactly these two fields; MJX
recomputes the composite inertias from them at every step.
"""

from __future__ import annotations

import jax
import jax.numpy as jnp
from jax import Array

from mjx_cascade.config import RandomizationConfig
from mjx_cascade.physics import mjx

FIELDS = ("body_mass", "body_ipos")


def randomize(model: mjx.Model, keys: Array, cfg: RandomizationConfig) -> mjx.Model:
    """A batch of models, one per key; only `FIELDS` carry the batch axis (see `in_axes`).

    The world body (index 0) is left alone.
    """
    nbody = model.body_mass.shape[0]

    def scales(key):
        k_mass, k_com = jax.random.split(key)
        mass = jax.random.uniform(k_mass, (nbody,), minval=cfg.mass[0], maxval=cfg.mass[1])
        com = jax.random.uniform(k_com, (nbody, 1), minval=cfg.com[0], maxval=cfg.com[1])
        return mass.at[0].set(1.0), com.at[0].set(1.0)

    mass, com = jax.vmap(scales)(keys)
    return model.tree_replace({"body_mass": model.body_mass * mass, "body_ipos": model.body_ipos * com})


def in_axes(model: mjx.Model) -> mjx.Model:
    """`vmap` axes for a batch from `randomize`: 0 on its fields, None elsewhere."""
    axes = jax.tree.map(lambda _: None, model)
    return axes.tree_replace({name: 0 for name in FIELDS})
