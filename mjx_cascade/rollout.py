"""The one simulator: a batch of environments advanced together through a `world.World`, with the
episode books kept one layer above the environment (Brax's `EpisodeWrapper` idea).

`simulate` serves training (stopping once every episode is done), evaluation and the robustness
sweep (recording the trajectory every chunk of physics steps) alike, and builds the MJX data for
the batch it runs, so MuJoCo Warp's contact buffers hold every environment's contacts. Evaluation
and the sweep run its two halves, `start` and `advance`, through `record_in_calls`: a tenth of the
recording per call of one compiled program, so that they can say how far they are.

The loop over time is written at the batch level (chunks of vmapped steps inside a `scan` or a
`while_loop`) rather than as a vmapped per-episode loop: JAX's batching of a `while_loop`
selects the whole carry element by element, which MJX's warp data (contact buffers shared by all
environments) does not allow.
"""

from __future__ import annotations

from typing import Any, Callable

import jax
import jax.numpy as jnp
import numpy as np
from flax import struct
from jax import Array

from mjx_cascade import rewards
from mjx_cascade.env import Env, EnvState, StepReport
from mjx_cascade.world import World


class Books(struct.PyTreeNode):
    """One episode's accounts, per environment of the batch."""

    t: Array  # physics steps scored (taken before the episode was done)
    done: Array  # stopped scoring: terminated, diverged or out of time
    terminated: Array  # ended early by eq. 27
    diverged: Array  # ended by non-finite or impossible physics
    ret: Array  # weighted reward x seconds, less the termination penalty
    terms: Array  # [9] unweighted reward terms x seconds (`rewards.TERMS`)
    walking_steps: Array  # stance switches while the episode was live

    @classmethod
    def start(cls, batch: int) -> "Books":
        false, zero = jnp.zeros(batch, bool), jnp.zeros(batch)
        return cls(t=jnp.zeros(batch, jnp.int32), done=false, terminated=false, diverged=false, ret=zero,
                   terms=jnp.zeros((batch, len(rewards.TERMS))), walking_steps=jnp.zeros(batch, jnp.int32))


def keep_books(b: Books, report: StepReport, env: Env, episode_steps: int) -> Books:
    """The books after one step: only live episodes score; an early end pays the termination
    penalty for every second it leaves unplayed, so surviving longer always pays."""
    live, dt = ~b.done, env.dt
    counted = live & ~report.diverged
    reward = jnp.where(counted, report.terms @ env.weights * dt, 0.0)
    t = b.t + live.astype(jnp.int32)
    lost = (episode_steps - t) * dt
    penalty = jnp.where(live & report.terminated, env.cfg.rewards.termination_penalty * lost, 0.0)
    return Books(
        t=t,
        done=b.done | report.terminated | (t >= episode_steps),
        terminated=b.terminated | (live & report.terminated),
        diverged=b.diverged | (live & report.diverged),
        ret=b.ret + reward - penalty,
        terms=b.terms + jnp.where(counted[:, None], report.terms * dt, 0.0),
        walking_steps=b.walking_steps + (live & report.switched).astype(jnp.int32),
    )


def fitness(b: Books, episode_steps: int, dt: float) -> Array:
    """Episode return per second of the full episode: the normalised mean reward (Fig. 6)."""
    return b.ret / (episode_steps * dt)


Record = Callable[[Env, EnvState, World], Any]  # (env, batched state, world) -> what to keep of it


def trajectory(env: Env, state: EnvState, world: World) -> tuple[Array, Array, Array, Array]:
    """What evaluation keeps of each record: `(qpos, qvel, ground under the pelvis, stance)`."""
    ground = jax.vmap(env.ground, in_axes=(0, world.axes))(state.data, world.model)
    return state.data.qpos, state.data.qvel, ground, state.ctrl.stance


Carry = tuple[EnvState, Books]
Progress = Callable[[int, int], None]  # (records done, records in all)
CALLS = 10  # calls, and progress reports, of a simulation recorded from the host


def start(env: Env, params: Array, keys: Array, world: World) -> Carry:
    """A batch of environments reset under its first commands, with fresh books (`simulate`'s
    arguments)."""
    sched = world.schedule
    batch = sched.command.shape[0]
    reset = _over(env.reset, (0 if params.ndim == 2 else None, 0 if keys.ndim == 2 else None, 0, world.axes, None),
                  batch)
    return reset(params, keys, sched.command_at(0), world.model, env.data_template(batch)), Books.start(batch)


def _chunk(env: Env, params: Array, world: World, episode_steps: int, chunk: int,
           skip_done: bool = False) -> Callable[[Array, Carry], Carry]:
    """`run_chunk(i, carry)`: the batch advanced through physics steps `i * chunk` to `(i + 1) * chunk - 1`;
    with `skip_done`, environments whose episodes are done need not be stepped (`Env.step`'s `live`)."""
    sched = world.schedule
    step = _over(env.step, (0 if params.ndim == 2 else None, 0, 0, 0 if sched.pushes else None, world.axes, 0),
                 sched.command.shape[0])

    def run_chunk(i: Array, carry: Carry) -> Carry:
        def physics(carry, n):
            state, books = carry
            live = ~books.done if skip_done else jnp.ones_like(books.done)
            state, report = step(params, state, sched.command_at(n), sched.force_at(n), world.model, live)
            return (state, keep_books(books, report, env, episode_steps)), None

        return jax.lax.scan(physics, carry, i * chunk + jnp.arange(chunk))[0]

    return run_chunk


def advance(env: Env, params: Array, carry: Carry, world: World, episode_steps: int, chunk: int, first: Array | int,
            chunks: int, record: Record) -> tuple[Carry, Any]:
    """`carry` advanced through chunks `first` to `first + chunks - 1` of `chunk` physics steps,
    keeping `record(...)` after each: `(carry, records [chunks, ...])`."""
    run_chunk = _chunk(env, params, world, episode_steps, chunk)

    def recorded(carry, i):
        carry = run_chunk(i, carry)
        return carry, record(env, carry[0], world)

    return jax.lax.scan(recorded, carry, first + jnp.arange(chunks))


def simulate(env: Env, params: Array, keys: Array, world: World, episode_steps: int, chunk: int,
             chunks: int, record: Record | None = None) -> tuple[Books, Any]:
    """Reset a batch of environments and advance it `chunks` times by `chunk` physics steps, keeping
    `record(...)` after each chunk; without `record`, stop once every episode is done. Returns
    `(books, records [chunks, ...] or None)`.

    `params` is one flat policy vector `[D]` for the whole batch, or one per environment `[B, D]`;
    `keys` one reset key per environment `[B, 2]`, or one `[2]` that starts them all alike.
    Episodes last `episode_steps` physics steps; their robots simulate on with the batch after
    where a trajectory is recorded, and need not without one (the C engine leaves them be).
    """
    carry = start(env, params, keys, world)
    if record is not None:
        (_, books), records = advance(env, params, carry, world, episode_steps, chunk, 0, chunks, record)
        return books, records
    run_chunk = _chunk(env, params, world, episode_steps, chunk, skip_done=True)

    def more(c):
        return (c[0] < chunks) & ~jnp.all(c[2].done)

    _, _, books = jax.lax.while_loop(more, lambda c: (c[0] + 1, *run_chunk(c[0], c[1:])), (0, *carry))
    return books, None


def per_call(chunks: int) -> int:
    """Chunks per call of a recording of `chunks` made in `CALLS` calls (`record_in_calls`)."""
    return -(-chunks // CALLS)


def record_in_calls(advance_call: Callable[[Any, Array], tuple[Any, Any]], carry: Any, chunks: int,
                    progress: Progress | None = None, until: Callable[[Any], bool] | None = None) -> Any:
    """The records `[chunks, ...]` (NumPy) of a recorded simulation run from the host as calls of one
    compiled `advance_call(carry, first) -> (carry, records [per_call(chunks), ...])` from chunk 0,
    telling `progress(records done, chunks)` after each call. The last call runs past `chunks` and
    its extra records are dropped: one program serves every call. Progress comes from the host, not
    from a callback inside the program, because JAX keeps no program with a host callback in its
    persistent compilation cache. Where `until(records of a call)` is true the recording stops
    after that call, and holds fewer than `chunks` records."""
    n, parts = per_call(chunks), []
    for first in range(0, chunks, n):
        carry, records = advance_call(carry, jnp.int32(first))
        parts.append(jax.device_get(records))
        if progress:
            progress(min(first + n, chunks), chunks)
        if until is not None and first + n < chunks and until(parts[-1]):
            break
    return jax.tree.map(lambda *xs: np.concatenate(xs)[:chunks], *parts)


def _lone(x: Any, axes: Any) -> Any:
    """The one element of `x`, batched along `axes` (a pytree of axes, None where it is shared)."""
    return jax.tree.map(lambda ax, a: a if ax is None else jax.tree.map(lambda leaf: leaf[0], a), axes, x,
                        is_leaf=lambda ax: ax is None)


def _over(fn: Callable, in_axes: tuple, batch: int) -> Callable:
    """`jax.vmap(fn, in_axes)`; for a batch of one, `fn` itself on the lone element with the batch
    axis put back on its outputs: one environment's program compiles faster unbatched."""
    if batch > 1:
        return jax.vmap(fn, in_axes=in_axes)
    return lambda *args: jax.tree.map(lambda a: a[None], fn(*map(_lone, args, in_axes)))
