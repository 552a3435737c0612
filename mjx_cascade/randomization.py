"""Domain randomization, Table 5: per-episode link masses and centre-of-mass positions; pushes.

Each episode scales every body's mass by U(mass) and its centre-of-mass offset by U(com),
body by body. Under `jax.vmap` the model becomes batched in exactly these two fields; MJX
recomputes the composite inertias from them at every step.

Pushes (`push`, `push_force`) are not in the paper: one horizontal force on the pelvis per
episode, of random magnitude, direction and start, when `push_force` allows a non-zero force.
"""

from __future__ import annotations

from typing import NamedTuple

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


class Push(NamedTuple):
    force: Array  # [3] N, horizontal
    start: Array  # first physics step it acts on
    stop: Array  # first step after it


def pushes_enabled(cfg: RandomizationConfig) -> bool:
    return cfg.push_force[1] > 0.0


def random_step(key: Array, window: tuple[float, float], dt: float) -> Array:
    """The physics step nearest a time drawn uniformly from `window` (s)."""
    return jnp.round(jax.random.uniform(key, minval=window[0], maxval=window[1]) / dt).astype(jnp.int32)


def push(key: Array, cfg: RandomizationConfig, dt: float) -> Push:
    """One episode's push: magnitude U(push_force), direction U(0, 2 pi), start U(push_after)."""
    k_mag, k_dir, k_start = jax.random.split(key, 3)
    magnitude = jax.random.uniform(k_mag, minval=cfg.push_force[0], maxval=cfg.push_force[1])
    angle = jax.random.uniform(k_dir, maxval=2.0 * jnp.pi)
    start = random_step(k_start, cfg.push_after, dt)
    force = magnitude * jnp.stack([jnp.cos(angle), jnp.sin(angle), 0.0])
    return Push(force, start, start + round(cfg.push_seconds / dt))


def push_force(p: Push, t: Array) -> Array:
    """The force [3] at episode step `t`."""
    return jnp.where((t >= p.start) & (t < p.stop), p.force, 0.0)
