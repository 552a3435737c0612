"""Evolution strategies (Sec. V-C, Table 3) as init / ask / tell on an explicit state.

OpenAI-style ES: antithetic pairs theta +- sigma eps, centred-rank fitness shaping, the
gradient estimate handed to an optax optimiser (Adam by default), and sigma and the learning
rate decaying geometrically to their floors once per generation.
"""

from __future__ import annotations

import jax
import jax.numpy as jnp
import optax
from flax import struct
from jax import Array

from mjx_cascade.config import ESConfig


class ESState(struct.PyTreeNode):
    mean: Array  # [D] the policy parameters
    opt_state: optax.OptState
    sigma: Array
    lr: Array
    generation: Array  # generations completed
    key: Array  # uint32 [2] raw PRNG key


def optimizer(cfg: ESConfig) -> optax.GradientTransformation:
    base = optax.adam if cfg.optimizer == "adam" else optax.sgd
    return optax.inject_hyperparams(base)(learning_rate=cfg.learning_rate)


def init(params: Array, key: Array, cfg: ESConfig, generation: int = 0) -> ESState:
    """A fresh state at `params`. `generation > 0` warm-starts another run's policy: sigma and the
    learning rate take their decayed values at that generation, the optimiser's moments start at
    zero (a policy file holds the parameters only)."""
    decayed = lambda x0, rate, floor: max(x0 * rate**generation, floor)  # noqa: E731
    return ESState(
        mean=params,
        opt_state=optimizer(cfg).init(params),
        sigma=jnp.asarray(decayed(cfg.sigma, cfg.sigma_decay, cfg.sigma_min), jnp.float32),
        lr=jnp.asarray(decayed(cfg.learning_rate, cfg.lr_decay, cfg.lr_min), jnp.float32),
        generation=jnp.asarray(generation, jnp.int32),
        key=key,
    )


def ask(state: ESState, cfg: ESConfig) -> tuple[ESState, Array, Array]:
    """`(state, noise [P/2, D], members [P, D])`: members are mean + sigma noise, then mean - sigma noise."""
    key, sub = jax.random.split(state.key)
    noise = jax.random.normal(sub, (cfg.population // 2, state.mean.shape[0]))
    members = jnp.concatenate([state.mean + state.sigma * noise, state.mean - state.sigma * noise])
    return state.replace(key=key), noise, members


def centered_ranks(x: Array) -> Array:
    """Ranks mapped linearly onto [-0.5, 0.5]; ties broken by position. Non-finite counts as worst."""
    x = jnp.where(jnp.isfinite(x), x, -jnp.inf)
    ranks = jnp.argsort(jnp.argsort(x)).astype(jnp.float32)
    return ranks / (x.shape[0] - 1) - 0.5


def gradient(noise: Array, fitness: Array, sigma: Array) -> Array:
    """ES ascent direction from antithetic fitness `[P]` (the first half belongs to +noise)."""
    shaped = centered_ranks(fitness)
    half = noise.shape[0]
    diff = shaped[:half] - shaped[half:]
    return diff @ noise / (2 * half * sigma)


def tell(state: ESState, noise: Array, fitness: Array, cfg: ESConfig) -> ESState:
    """One optimiser step up the estimated gradient, then the Table 3 decays."""
    grad = gradient(noise, fitness, state.sigma) - cfg.weight_decay * state.mean
    opt_state = state.opt_state._replace(hyperparams={**state.opt_state.hyperparams, "learning_rate": state.lr})
    updates, opt_state = optimizer(cfg).update(-grad, opt_state, state.mean)
    return state.replace(
        mean=optax.apply_updates(state.mean, updates),
        opt_state=opt_state,
        sigma=jnp.maximum(state.sigma * cfg.sigma_decay, cfg.sigma_min),
        lr=jnp.maximum(state.lr * cfg.lr_decay, cfg.lr_min),
        generation=state.generation + 1,
    )
