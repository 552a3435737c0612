"""What a batch of environments walks in: its models (terrain, perturbed bodies) and what happens
to each over time (the commands it is given and the pushes on its pelvis), by physics step.

Every way of running the controller describes its disturbances so: training draws them per
episode (`episodes`), evaluation builds them from scenario files and the robustness sweep from
its trials (`schedule`); `rollout.simulate` reads them.
"""

from __future__ import annotations

from typing import Any, NamedTuple, Sequence

import jax
import jax.numpy as jnp
import numpy as np
from flax import struct
from jax import Array

from mjx_cascade.physics import mjx
from mjx_cascade.robots import scene

NEVER = np.iinfo(np.int32).max  # the start step of a command slot that holds nothing


class Schedule(struct.PyTreeNode):
    """Commands and pushes of a batch of `B` environments, by physics step (0 is the first)."""

    command_start: Array  # [B, K] int32: the step from which each command holds, increasing (padding: NEVER)
    command: Array  # [B, K, 3] (vx, vy in the heading frame, m/s; desired heading, rad)
    push_start: Array  # [B, P] int32: the first step of each push
    push_stop: Array  # [B, P] int32: the first step after it
    push_force: Array  # [B, P, 3] N, world frame, on the pelvis

    @property
    def pushes(self) -> bool:
        return self.push_force.shape[1] > 0

    def command_at(self, n: Array) -> Array:
        """`[B, 3]`: the command each environment is given at step `n`."""
        k = jnp.sum(self.command_start <= n, axis=1) - 1
        return jnp.take_along_axis(self.command, k[:, None, None], axis=1)[:, 0]

    def force_at(self, n: Array) -> Array | None:
        """`[B, 3]`: the force on each pelvis at step `n`; None for a schedule without pushes."""
        if not self.pushes:  # the compiled step then writes no force at all
            return None
        on = (self.push_start <= n) & (n < self.push_stop)
        return jnp.sum(jnp.where(on[..., None], self.push_force, 0.0), axis=1)


class World(NamedTuple):
    """A batch's models (batched along `axes`, None where shared) and its schedule."""

    model: mjx.Model
    axes: Any
    schedule: Schedule


Push = tuple[float, float, Sequence[float]]  # (start, duration) in s, force [3] in N


def schedule(commands: Sequence[np.ndarray], pushes: Sequence[Sequence[Push]], dt: float, steps: int) -> Schedule:
    """A batch's schedule from timed commands (`[K_i, 4]` rows of t, vx, vy, yaw, t increasing from 0)
    and pushes, for `steps` physics steps of `dt`.

    A command or push given at time t acts from the first physics step that starts at or after t;
    a push lasts while the steps start before its end.
    """
    starts = (np.arange(steps) + 1) * dt - dt  # when each step starts (the time after it, less dt)
    on_steps = lambda t: np.searchsorted(starts, t, side="left")  # noqa: E731
    k = max(len(c) for c in commands)
    p = max((len(ps) for ps in pushes), default=0)
    command_start = np.full((len(commands), k), NEVER, np.int64)
    command = np.zeros((len(commands), k, 3))
    push = np.zeros((len(commands), p, 2), np.int64)
    force = np.zeros((len(commands), p, 3))
    for i, (c, ps) in enumerate(zip(commands, pushes)):
        c = np.asarray(c, np.float64)
        command_start[i, :len(c)] = on_steps(c[:, 0])
        command[i, :len(c)] = c[:, 1:]
        command[i, len(c):] = c[-1, 1:]
        for j, (t, duration, f) in enumerate(ps):
            push[i, j] = on_steps(t), on_steps(t + duration)
            force[i, j] = f
    return Schedule(jnp.asarray(command_start, jnp.int32), jnp.asarray(command, jnp.float32),
                    jnp.asarray(push[..., 0], jnp.int32), jnp.asarray(push[..., 1], jnp.int32),
                    jnp.asarray(force, jnp.float32))


def batched(model: mjx.Model, fields: dict[str, Array], axes: Any = None) -> tuple[mjx.Model, Any]:
    """`model` with `fields` replaced by per-environment values (leading batch axis), and the vmap
    axes of the result (`axes`, the model's so far, default: nothing batched)."""
    axes = jax.tree.map(lambda _: None, model) if axes is None else axes
    return model.tree_replace(fields), axes.tree_replace({name: 0 for name in fields})


def terrains(robot_model: Any, model: mjx.Model, kinds: Sequence[dict], axes: Any = None) -> tuple[mjx.Model, Any]:
    """`(model, axes)` of a batch whose environments walk on `kinds` (one terrain each), from the
    compiled robot model holding them all (`scene.compile_model` with the distinct ones) and the
    batch's models so far: unchanged when they share one terrain, else with one row of height-field
    data per environment."""
    distinct = scene.distinct(kinds)
    if len(distinct) == 1:
        return model, axes
    data = np.stack([scene.hfield_data(robot_model, k) for k in distinct])
    index = np.array([distinct.index(k) for k in kinds])
    return batched(model, {"hfield_data": jnp.asarray(data[index])}, axes)
