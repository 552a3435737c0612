"""Evolution strategies (Sec. V-C, Table 3) as init / ask / tell, evosax's shape.

OpenAI-style ES: antithetic pairs theta +- sigma eps, centred-rank fitness shaping, the gradient
estimate turned into a step by an optax optimiser (Adam by default). Sigma and the learning rate
are optax schedules of the generation counter (Table 3: geometric decays to their floors), so a
warm start only sets the counter. The strategy (`make`) is built once and holds no state; the
state holds the run's key, from which each generation draws (`generation_keys`).
"""

from __future__ import annotations

import dataclasses

import jax
import jax.numpy as jnp
import optax
from flax import struct
from jax import Array

from mjx_cascade.config import ESConfig

NOISE, EPISODES = 0, 1  # a generation's draws, in `generation_keys` order


class ESState(struct.PyTreeNode):
    mean: Array  # [D] the policy parameters
    opt_state: optax.OptState
    generation: Array  # generations completed
    key: Array  # uint32 [2] the run's raw PRNG key; generation g draws from fold_in(key, g)


@dataclasses.dataclass(frozen=True, eq=False)
class Strategy:
    population: int  # antithetic pairs: even
    sigma: optax.Schedule  # of the generation counter
    learning_rate: optax.Schedule
    optimizer: optax.GradientTransformation  # the ascent direction from the gradient estimate
    weight_decay: float


def decay(init: float, rate: float, floor: float) -> optax.Schedule:
    """init x rate^g, never below `floor` (Table 3's decays)."""
    if rate == 1.0:
        return optax.constant_schedule(init)
    return optax.exponential_decay(init, transition_steps=1, decay_rate=rate, end_value=floor)


def make(cfg: ESConfig) -> Strategy:
    direction = optax.scale_by_adam() if cfg.optimizer == "adam" else optax.identity()
    return Strategy(cfg.population, decay(cfg.sigma, cfg.sigma_decay, cfg.sigma_min),
                    decay(cfg.learning_rate, cfg.lr_decay, cfg.lr_min), direction, cfg.weight_decay)


def init(strategy: Strategy, params: Array, key: Array, generation: int = 0) -> ESState:
    """A fresh state at `params`, `generation` generations in (a warm start: the schedules take their
    values there; the optimiser's moments start at zero, since a policy file holds the parameters only)."""
    return ESState(mean=params, opt_state=strategy.optimizer.init(params),
                   generation=jnp.asarray(generation, jnp.int32), key=key)


def generation_keys(state: ESState) -> Array:
    """`[2, key]`: the keys of the noise (`NOISE`) and of the episodes (`EPISODES`) of the generation
    `state` is about to run; each generation's stream is its own, whatever came before."""
    return jax.random.split(jax.random.fold_in(state.key, state.generation))


def ask(strategy: Strategy, state: ESState, key: Array) -> tuple[Array, Array]:
    """`(noise [P/2, D], members [P, D])`: members are mean + sigma noise, then mean - sigma noise."""
    noise = jax.random.normal(key, (strategy.population // 2, state.mean.shape[0]))
    sigma = strategy.sigma(state.generation)
    return noise, jnp.concatenate([state.mean + sigma * noise, state.mean - sigma * noise])


def centered_ranks(x: Array) -> Array:
    """Ranks mapped linearly onto [-0.5, 0.5]; ties broken by position. Non-finite counts as worst."""
    x = jnp.where(jnp.isfinite(x), x, -jnp.inf)
    ranks = jnp.argsort(jnp.argsort(x)).astype(jnp.float32)
    return ranks / (x.shape[0] - 1) - 0.5


def gradient(noise: Array, fitness: Array, sigma: Array) -> Array:
    """ES ascent direction from antithetic fitness `[P]` (the first half belongs to +noise)."""
    shaped = centered_ranks(fitness)
    half = noise.shape[0]
    return (shaped[:half] - shaped[half:]) @ noise / (2 * half * sigma)


def tell(strategy: Strategy, state: ESState, noise: Array, fitness: Array) -> ESState:
    """One optimiser step up the estimated gradient at the generation's learning rate."""
    g = state.generation
    grad = gradient(noise, fitness, strategy.sigma(g)) - strategy.weight_decay * state.mean
    direction, opt_state = strategy.optimizer.update(grad, state.opt_state, state.mean)
    mean = state.mean + strategy.learning_rate(g) * direction
    return state.replace(mean=mean, opt_state=opt_state, generation=g + 1)
