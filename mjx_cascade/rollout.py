"""Episodes: sample a command, a model and (if configured) a push and a later second command,
start standing, run the controller, score it.

Episodes run in chunks of `steps_per_check` physics steps inside a `lax.while_loop` that
stops when every episode of the batch is done, so generations whose members all fall early
cost only as long as their longest survivor.
"""

from __future__ import annotations

from typing import Callable, NamedTuple

import jax
import jax.numpy as jnp
from jax import Array

from mjx_cascade import randomization
from mjx_cascade.config import EpisodeConfig
from mjx_cascade.env import Env, EnvState


PUSH_STREAM, COMMAND_STREAM = 3, 4  # fold_in indices of the episode key's push and second-command draws


class EpisodeResult(NamedTuple):
    fitness: Array  # normalised return (env.fitness)
    steps: Array  # physics steps survived
    walking_steps: Array  # stance switches while the episode ran
    terminated: Array
    diverged: Array
    terms: Array  # [9] unweighted reward terms integrated over the episode


def sample_command(key: Array, cfg: EpisodeConfig) -> Array:
    """[vx, vy, yaw]: velocities in the heading frame, heading relative to the start (uniform)."""
    lo = jnp.array([cfg.vx[0], cfg.vy[0], cfg.yaw[0]])
    hi = jnp.array([cfg.vx[1], cfg.vy[1], cfg.yaw[1]])
    return jax.random.uniform(key, (3,), minval=lo, maxval=hi)


def command_changes(cfg: EpisodeConfig) -> bool:
    return cfg.command_change[1] > 0.0


def second_command(key: Array, cfg: EpisodeConfig, dt: float) -> tuple[Array, Array]:
    """`(command [3], first step it applies to)`: drawn like the first, at U(command_change) s."""
    k_cmd, k_at = jax.random.split(key)
    return sample_command(k_cmd, cfg), randomization.random_step(k_at, cfg.command_change, dt)


def schedules(env: Env, keys: Array, cmd: Array, generation: Array | int = 0) -> tuple[Callable, Callable]:
    """Functions of the episodes' step counters `t [B]`: the command `[B, 3]` (`cmd`, then a second
    one if `episode.command_change` asks) and the push force `[B, 3]` (None without pushes, which
    leaves the compiled step as it was; zero while `generation`, the generations trained so far,
    is below `randomization.push_warmup_generations`). Each draw has a key of its own, so
    enabling one leaves every other draw as it was."""
    cfg = env.cfg
    command, force = (lambda t: cmd), (lambda t: None)
    if command_changes(cfg.episode):
        k_second = jax.vmap(lambda k: jax.random.fold_in(k, COMMAND_STREAM))(keys)
        later, change_at = jax.vmap(lambda k: second_command(k, cfg.episode, env.dt))(k_second)
        command = lambda t: jnp.where((t >= change_at)[:, None], later, cmd)  # noqa: E731
    if randomization.pushes_enabled(cfg.randomization):
        k_push = jax.vmap(lambda k: jax.random.fold_in(k, PUSH_STREAM))(keys)
        pushes = jax.vmap(lambda k: randomization.push(k, cfg.randomization, env.dt))(k_push)
        force = lambda t: jax.vmap(randomization.push_force)(pushes, t)  # noqa: E731
        warmup = cfg.randomization.push_warmup_generations
        if warmup > 0:
            pushed = force
            force = lambda t: jnp.where(generation >= warmup, pushed(t), 0.0)  # noqa: E731
    return command, force


def run_episodes(env: Env, params: Array, keys: Array, generation: Array | int = 0) -> EpisodeResult:
    """Training episodes of a batch of flat policy vectors `params [B, D]`, one key each, in
    generation `generation` (counted from 0; it only matters for `push_warmup_generations`).

    The loop over time is written at the batch level (a `while_loop` around vmapped chunks)
    rather than as a vmapped per-episode loop: JAX's batching of a `while_loop` selects the
    whole carry element by element, which MJX's warp data (contact buffers shared by all
    environments) does not allow.
    """
    cfg = env.cfg
    k_model, k_cmd, k_reset = jax.vmap(lambda k: jax.random.split(k, 3))(keys).transpose(1, 0, 2)
    if cfg.randomization.enabled:
        model = randomization.randomize(env.model, k_model, cfg.randomization)
        model_axes = randomization.in_axes(env.model)
    else:
        model, model_axes = env.model, None
    cmd = jax.vmap(lambda k: sample_command(k, cfg.episode))(k_cmd)
    state = jax.vmap(env.reset, in_axes=(0, 0, 0, model_axes))(params, k_reset, cmd, model)
    command, force = schedules(env, keys, cmd, generation)
    step = jax.vmap(lambda p, s, c, f, m: env.step(p, s, c, f, model=m), in_axes=(0, 0, 0, 0, model_axes))

    def chunk(s: EnvState) -> EnvState:
        def body(s, _):
            return step(params, s, command(s.t), force(s.t), model), None

        return jax.lax.scan(body, s, None, length=cfg.episode.steps_per_check)[0]

    state = jax.lax.while_loop(lambda s: ~jnp.all(s.done), chunk, state)
    return EpisodeResult(
        fitness=jax.vmap(env.fitness)(state),
        steps=state.t,
        walking_steps=state.ctrl.steps,
        terminated=state.terminated,
        diverged=state.diverged,
        terms=state.terms,
    )
