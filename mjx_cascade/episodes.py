"""Training episodes: what each one faces, drawn from its key, then run and scored.

An episode starts standing (a random member of the balanced pool) under a command drawn
uniformly from the config's ranges; a second command may take over at a random time
(`episode.command_change`) and a push may strike (`randomization.push_*`), and its model's
link masses and centres of mass are drawn per Table 5. Each draw has a key of its own, so
enabling one leaves every other as it was. The batch runs through `rollout.simulate`, stopping
once every episode is done, so generations whose members all fall early cost only as long as
their longest survivor.
"""

from __future__ import annotations

from typing import NamedTuple

import jax
import jax.numpy as jnp
from jax import Array

from mjx_cascade import randomization, rollout
from mjx_cascade.config import EpisodeConfig, RandomizationConfig
from mjx_cascade.env import Env
from mjx_cascade.world import Schedule, World

MODEL, COMMAND, RESET, PUSH, SECOND_COMMAND = range(5)  # the episode key's streams (`fold_in`)


class EpisodeResult(NamedTuple):
    fitness: Array  # normalised return (rollout.fitness)
    steps: Array  # physics steps survived
    walking_steps: Array  # stance switches while the episode ran
    terminated: Array
    diverged: Array
    terms: Array  # [9] unweighted reward terms integrated over the episode, x seconds


def sample_command(key: Array, cfg: EpisodeConfig) -> Array:
    """[vx, vy, yaw]: velocities in the heading frame, heading relative to the start (uniform)."""
    lo = jnp.array([cfg.vx[0], cfg.vy[0], cfg.yaw[0]])
    hi = jnp.array([cfg.vx[1], cfg.vy[1], cfg.yaw[1]])
    return jax.random.uniform(key, (3,), minval=lo, maxval=hi)


def random_step(key: Array, window: tuple[float, float], dt: float) -> Array:
    """The physics step nearest a time drawn uniformly from `window` (s)."""
    return jnp.round(jax.random.uniform(key, minval=window[0], maxval=window[1]) / dt).astype(jnp.int32)


def commands(key: Array, cfg: EpisodeConfig, dt: float) -> tuple[Array, Array]:
    """`(start steps [K], commands [K, 3])`: one command, and a second drawn like it from
    U(command_change) s on when the config asks for one (K = 2)."""
    first = sample_command(jax.random.fold_in(key, COMMAND), cfg)
    if cfg.command_change[1] <= 0.0:
        return jnp.zeros(1, jnp.int32), first[None]
    k_cmd, k_at = jax.random.split(jax.random.fold_in(key, SECOND_COMMAND))
    at = random_step(k_at, cfg.command_change, dt)
    return jnp.stack([jnp.int32(0), at]), jnp.stack([first, sample_command(k_cmd, cfg)])


def push(key: Array, cfg: RandomizationConfig, dt: float, generation: Array | int) -> tuple[Array, Array, Array]:
    """`(start [P], stop [P], force [P, 3])`: no push (P = 0) unless `push_force` allows one; then
    U(push_force) N in a uniform direction from U(push_after) s, for `push_seconds`, zero until
    `push_warmup_generations` generations have trained."""
    if cfg.push_force[1] <= 0.0:
        return jnp.zeros(0, jnp.int32), jnp.zeros(0, jnp.int32), jnp.zeros((0, 3))
    k_mag, k_dir, k_start = jax.random.split(jax.random.fold_in(key, PUSH), 3)
    magnitude = jax.random.uniform(k_mag, minval=cfg.push_force[0], maxval=cfg.push_force[1])
    angle = jax.random.uniform(k_dir, maxval=2.0 * jnp.pi)
    start = random_step(k_start, cfg.push_after, dt)
    force = magnitude * jnp.stack([jnp.cos(angle), jnp.sin(angle), 0.0])
    force = jnp.where(jnp.asarray(generation) >= cfg.push_warmup_generations, force, 0.0)
    return start[None], (start + round(cfg.push_seconds / dt))[None], force[None]


def draw(env: Env, keys: Array, generation: Array | int = 0) -> World:
    """Every episode's world: its model (Table 5), commands and push, from its key."""
    cfg = env.cfg
    command_start, command = jax.vmap(lambda k: commands(k, cfg.episode, env.dt))(keys)
    push_start, push_stop, force = jax.vmap(lambda k: push(k, cfg.randomization, env.dt, generation))(keys)
    schedule = Schedule(command_start, command, push_start, push_stop, force)
    if not cfg.randomization.enabled:
        return World(env.model, None, schedule)
    k_model = jax.vmap(lambda k: jax.random.fold_in(k, MODEL))(keys)
    model = randomization.randomize(env.model, k_model, cfg.randomization)
    return World(model, randomization.in_axes(env.model), schedule)


def run(env: Env, params: Array, keys: Array, generation: Array | int = 0) -> EpisodeResult:
    """Training episodes of a batch of flat policy vectors `params [B, D]`, one key each, in
    generation `generation` (counted from 0; it matters for `push_warmup_generations` only)."""
    e = env.cfg.episode
    steps = int(round(e.seconds / env.dt))
    world = draw(env, keys, generation)
    reset_keys = jax.vmap(lambda k: jax.random.fold_in(k, RESET))(keys)
    books, _ = rollout.simulate(env, params, reset_keys, world, steps, e.steps_per_check,
                                -(-steps // e.steps_per_check))
    return EpisodeResult(rollout.fitness(books, steps, env.dt), books.t, books.walking_steps,
                         books.terminated, books.diverged, books.terms)

