"""The cascade controller driving one robot in MuJoCo's C engine, tick by tick, as on a robot.

`Runtime` runs the controller's own code (`observe` -> `Controller.tick` -> `pd.motor_command`),
compiled once by JAX for one robot on the CPU, against a plain `mujoco.MjData`: there is no
second implementation of the regulators and no MJX in the loop. `observe` reads the fields it
needs from `Sensed`, the `MjData` arrays under `mjx.Data`'s names and shapes. The terrain height
under the pelvis is not a controller input (only training's rewards read it), so the runtime
leaves it out and `ground` computes it on the host for the records.

One control tick per physics step: the paper's 2 kHz loop at dt = 0.5 ms.
"""

from __future__ import annotations

from typing import NamedTuple

import jax
import jax.numpy as jnp
import mujoco
import numpy as np
from jax import Array
from jax.flatten_util import ravel_pytree

from mjx_cascade import pd, policy, standing
from mjx_cascade.config import Config
from mjx_cascade.controller import Controller, ControllerState
from mjx_cascade.env import foot_rest, start_draw
from mjx_cascade.observe import observe
from mjx_cascade.robots import scene
from mjx_cascade.robots.base import Robot


class Sensed(NamedTuple):
    """What `observe` reads of the simulator's state, in `mjx.Data`'s names and shapes."""

    qpos: Array
    qvel: Array
    subtree_com: Array  # [nbody, 3]
    cvel: Array  # [nbody, 6]
    xpos: Array  # [nbody, 3]
    xmat: Array  # [nbody, 3, 3]
    sensordata: Array


def _layout(m: mujoco.MjModel) -> list[tuple[int, ...]]:
    """The shapes of `Sensed`'s fields, then the time and the command, as `pack` lays them out."""
    return [(m.nq,), (m.nv,), (m.nbody, 3), (m.nbody, 6), (m.nbody, 3), (m.nbody, 3, 3), (m.nsensordata,), (), (3,)]


def pack(d: mujoco.MjData, cmd: np.ndarray) -> np.ndarray:
    """`d`'s measurements, its time and the command `cmd` in one float32 vector (MJX's precision):
    one transfer per tick instead of one per array."""
    return np.concatenate([d.qpos, d.qvel, d.subtree_com.ravel(), d.cvel.ravel(), d.xpos.ravel(),
                           d.xmat.ravel(), d.sensordata, [d.time], cmd]).astype(np.float32)


def unpack(v: Array, layout: list[tuple[int, ...]]) -> tuple[Sensed, Array, Array]:
    """`(sensed, time, cmd)` from `pack`'s vector."""
    sizes = [int(np.prod(shape)) for shape in layout]
    parts = jnp.split(v, np.cumsum(sizes)[:-1])
    fields = [p.reshape(shape) for p, shape in zip(parts, layout)]
    return Sensed(*fields[:7]), fields[7], fields[8]


class Runtime:
    """`robot`'s cascade controller under `cfg` with policy parameters `params`, for one `MjData`
    of `robot.model`; `pool` (default: `standing.balanced_pool` with the config's seed, as training
    and `eval` draw it) holds the standing states a reset starts from.

    The controller's state stays inside the runtime between ticks, as one flat host vector that
    the compiled tick reads and returns (`state` gives it as a `ControllerState`). `reset` and
    `control` are compiled ahead of time for this model, so a tick never waits for JAX to trace.
    Creating one turns JAX's asynchronous CPU dispatch off for the process: a tick then runs on
    the calling thread, which a host loop waits for anyway.
    """

    def __init__(self, robot: Robot, cfg: Config, params: np.ndarray,
                 pool: tuple[np.ndarray, np.ndarray] | None = None):
        # a tick's program is tiny: dispatched on the calling thread it costs half as much as handed
        # to JAX's CPU worker (measured: 54 against 129 us median on 2 cores, benchmarks/README.md)
        jax.config.update("jax_cpu_enable_async_dispatch", False)
        self.robot, self.cfg = robot, cfg
        self.pool = standing.balanced_pool(robot, cfg, seed=cfg.seed) if pool is None else pool
        network = policy.for_controller(cfg, robot.num_learned, jax.random.PRNGKey(0))
        self.dt = float(robot.model.opt.timestep)
        self.controller = Controller(robot, cfg, self.dt, network.apply, foot_rest(robot, self.pool[0]))
        self.params = jnp.asarray(params, jnp.float32)
        self.height_field = scene.height_field(robot.model)
        self.layout = _layout(robot.model)
        example = np.zeros(sum(int(np.prod(s)) for s in self.layout), np.float32)
        key = jax.random.PRNGKey(0)
        shapes = jax.eval_shape(self._start_fn, self.params, key, example)
        _, self._unravel = ravel_pytree(jax.tree.map(lambda s: np.zeros(s.shape, s.dtype), shapes))
        self._start = jax.jit(self._start_fn).lower(self.params, key, example).compile()
        flat = jax.ShapeDtypeStruct((sum(x.size for x in jax.tree.leaves(shapes)),), jnp.float32)
        self._tick = jax.jit(self._tick_fn).lower(self.params, flat, example).compile()
        self._flat: np.ndarray | None = None

    def _start_fn(self, params: Array, key: Array, v: Array) -> ControllerState:
        s, time, cmd = unpack(v, self.layout)
        return self.controller.reset(params, key, observe(self.robot, None, s, None), time, cmd)

    def _tick_fn(self, params: Array, flat: Array, v: Array) -> tuple[Array, Array]:
        r = self.robot
        s, time, cmd = unpack(v, self.layout)
        u, _, c = self.controller.tick(params, self._unravel(flat), observe(r, None, s, None), time, cmd)
        return pd.motor_command(u, r.gear, r.ctrl_low, r.ctrl_high), ravel_pytree(c)[0]

    @property
    def state(self) -> ControllerState:
        """The controller's state after the last tick (or reset)."""
        if self._flat is None:
            raise RuntimeError("reset the runtime before reading its state")
        return self._unravel(self._flat)

    def reset(self, d: mujoco.MjData, cmd: np.ndarray, key: Array | None = None) -> None:
        """Stand `d` in the pool state that `key` draws (default `PRNGKey(0)`, as `eval` starts
        every scenario), at time 0 and at rest, with the controller about to step under `cmd`."""
        key = jax.random.PRNGKey(0) if key is None else key
        i, k_side = start_draw(key, self.pool[0].shape[0])
        mujoco.mj_resetData(self.robot.model, d)
        d.qpos[:], d.qvel[:] = self.pool[0][int(i)], self.pool[1][int(i)]
        mujoco.mj_forward(self.robot.model, d)
        self._flat = np.asarray(ravel_pytree(self._start(self.params, k_side, pack(d, cmd)))[0])

    def control(self, d: mujoco.MjData, cmd: np.ndarray) -> None:
        """One control tick: write the motor commands for `d`'s state under command `cmd`
        [vx, vy, heading] into `d.ctrl`."""
        if self._flat is None:
            raise RuntimeError("reset the runtime before its first tick")
        ctrl, flat = self._tick(self.params, self._flat, pack(d, cmd))
        d.ctrl[self.robot.actuator] = np.asarray(ctrl)
        self._flat = np.asarray(flat)  # a host array: fed back as a device array, a tick costs twice as much

    def ground(self, d: mujoco.MjData) -> float:
        """The terrain height under the pelvis."""
        if self.height_field is None:
            return 0.0
        x, y = d.qpos[0], d.qpos[1]
        return float(scene.height_at(self.height_field, self.robot.model.hfield_data, x, y))
