"""The physics behind one door: backend choice, model upload, per-batch data templates, the step.

`impl` follows MuJoCo Playground's convention: `jax` (pure JAX, any device) or `warp`
(MuJoCo Warp kernels, NVIDIA GPUs, several times faster there). `auto` picks `warp` when
JAX runs on a CUDA GPU and `mujoco-warp` is installed, else `jax`. `mujoco` (for CPUs, never
picked by `auto`) steps each batch in MuJoCo's C engine on a thread per core, called from the
jitted program (`CEngine`); everything else (controller, observation, rewards) stays in JAX.
"""

from __future__ import annotations

import contextlib
import copy
import functools
import importlib.util
import io
import sys
import threading
from typing import Callable

import jax
import jax.numpy as jnp
import mujoco
import numpy as np
from mujoco import rollout

with contextlib.redirect_stdout(io.StringIO()):  # mjx prints "Failed to import warp" to stdout
    from mujoco import mjx

from mjx_cascade import _xla
from mjx_cascade.config import ConfigError, PhysicsConfig

__all__ = ["mjx", "resolve_impl", "put_model", "make_data", "stepper", "CEngine"]


def warp_available() -> bool:
    return jax.default_backend() == "gpu" and importlib.util.find_spec("mujoco_warp") is not None


def resolve_impl(impl: str) -> str:
    """`auto` -> `warp` or `jax`; an explicit `warp` where it cannot run is a ConfigError. With
    MuJoCo Warp installed but JAX on the CPU (a CPU-only jaxlib), `auto` says so once on stderr
    rather than fall back quietly."""
    if impl == "auto":
        if warp_available():
            return "warp"
        if jax.default_backend() == "cpu" and importlib.util.find_spec("mujoco_warp") is not None:
            _say_once("mjx_cascade: mujoco-warp is installed but JAX runs on the CPU, so MJX runs impl=jax; "
                      "for an NVIDIA GPU install JAX's CUDA build: pip install 'mjx-cascade[gpu]'")
        return "jax"
    if impl == "warp" and not warp_available():
        raise ConfigError("--impl warp needs an NVIDIA GPU and mujoco-warp (pip install 'mjx-cascade[warp]')")
    return impl


@functools.cache
def _say_once(message: str) -> None:
    print(message, file=sys.stderr)


def put_model(model: mujoco.MjModel, impl: str) -> mjx.Model:
    return mjx.put_model(model, impl=_mjx_impl(impl))


def make_data(model: mujoco.MjModel, impl: str, physics: PhysicsConfig, batch: int) -> mjx.Data:
    """An unbatched data template; warp sizes its contact buffer for `batch` environments."""
    if impl == "warp":
        return mjx.make_data(
            model,
            impl="warp",
            naconmax=physics.contacts_per_env * batch,
            njmax=physics.constraints_per_env,
        )
    return mjx.make_data(model, impl=_mjx_impl(impl))


def _mjx_impl(impl: str) -> str:
    """The MJX backend that holds the arrays: the C engine's steps read and write JAX's."""
    return "jax" if impl == "mujoco" else impl


Step = Callable[[mjx.Model, mjx.Data], mjx.Data]


def stepper(model: mujoco.MjModel, impl: str) -> Step:
    """One physics step of `impl` (resolved), `(model, data) -> data`, pure and vmappable."""
    return CEngine(model).step if impl == "mujoco" else mjx.step


# the model fields an environment may hold its own value of (`randomization`)
PER_ENVIRONMENT = ("body_mass", "body_ipos")
_STATE = mujoco.mjtState.mjSTATE_FULLPHYSICS
_CONTROL = mujoco.mjtState.mjSTATE_CTRL | mujoco.mjtState.mjSTATE_XFRC_APPLIED


class CEngine:
    """Steps of MuJoCo's C engine for a batch of environments, as one JAX callback.

    `step` reads the state, controls, pelvis forces and per-environment model fields
    (`PER_ENVIRONMENT`; one terrain for the whole batch, the model's) of the whole vmapped batch, steps every environment once with
    `mujoco.rollout` on `threads` threads, and returns the new state. The fields the observation
    reads besides the state (positions and orientations of the bodies, centre of mass and body
    velocities) are computed in JAX from the state before the step, as `mjx.step` leaves them;
    the sensors come from the C step, which computes them there too. The solver's warm start
    carries over as the step's mean acceleration. The C engine runs in float64 and MJX in
    float32, so the two agree to the physics' tolerance, not bit for bit (tests/test_physics.py).
    """

    def __init__(self, model: mujoco.MjModel, threads: int | None = None):
        self.model = model
        self.threads = threads or _xla.cores()
        self.models: list[mujoco.MjModel] = []
        self.written: list[np.ndarray] | None = None  # the per-environment fields the models hold
        self.datas = [mujoco.MjData(model) for _ in range(self.threads)]
        self.pool = rollout.Rollout(nthread=self.threads)
        template = mujoco.MjData(model)
        self.template = np.empty(mujoco.mj_stateSize(model, _STATE))
        mujoco.mj_getState(model, template, self.template, _STATE)
        self.slices = _state_slices(model, _STATE)
        self.lock = threading.Lock()  # JAX devices split from the CPU may call at once: one batch at a time

    def step(self, model: mjx.Model, data: mjx.Data) -> mjx.Data:
        """`mjx.step` in the C engine: one step of `data` under `model` (its per-environment fields)."""
        data = mjx.com_vel(model, mjx.com_pos(model, mjx.kinematics(model, data)))
        args = (data.time, data.qpos, data.qvel, data.act, data.qacc_warmstart, data.ctrl, data.xfrc_applied,
                model.hfield_data[:1], *(getattr(model, f) for f in PER_ENVIRONMENT))
        out = (jax.ShapeDtypeStruct(data.qpos.shape, data.qpos.dtype),
               jax.ShapeDtypeStruct(data.qvel.shape, data.qvel.dtype),
               jax.ShapeDtypeStruct(data.act.shape, data.act.dtype),
               jax.ShapeDtypeStruct(data.sensordata.shape, data.sensordata.dtype))
        qpos, qvel, act, sensordata = jax.pure_callback(self._host_step, out, *args, vmap_method="expand_dims")
        dt = jnp.asarray(model.opt.timestep, data.time.dtype)
        return data.replace(time=data.time + dt, qpos=qpos, qvel=qvel, act=act, sensordata=sensordata,
                            qacc_warmstart=((qvel - data.qvel) / dt).astype(data.qacc_warmstart.dtype))

    def _host_step(self, *args):
        with self.lock:
            return self._step_batch(*args)

    def _step_batch(self, time, qpos, qvel, act, warmstart, ctrl, xfrc, terrain, *fields):
        single = np.ndim(qpos) == 1  # called outside vmap
        if single:
            time, qpos, qvel, act, warmstart, ctrl, xfrc, terrain, *fields = (
                np.asarray(a)[None] for a in (time, qpos, qvel, act, warmstart, ctrl, xfrc, terrain, *fields))
        batch = qpos.shape[0]
        if batch > 1 and np.shape(terrain)[0] == batch:  # a row of the height field per environment
            raise ValueError("impl mujoco steps a batch on one terrain: a batch of several terrains (the robustness "
                             "sweep's rough ground) runs with impl jax")
        models = self._models(batch, fields)
        state = np.repeat(self.template[None], batch, axis=0)
        for name, value in (("time", time), ("qpos", qpos), ("qvel", qvel), ("act", act)):
            state[:, self.slices[name]] = np.asarray(value, np.float64).reshape(batch, -1)
        control = np.concatenate([np.asarray(ctrl, np.float64).reshape(batch, -1),
                                  np.asarray(xfrc, np.float64).reshape(batch, -1)], axis=1)[:, None]
        new = np.empty((batch, 1, state.shape[1]))
        sensors = np.empty((batch, 1, self.model.nsensordata))
        self.pool.rollout(models, self.datas, state, np.ascontiguousarray(control), control_spec=_CONTROL, nstep=1,
                          skip_checks=True, initial_warmstart=np.ascontiguousarray(warmstart, np.float64),
                          state=new, sensordata=sensors)
        new, sensors = new[:, 0], sensors[:, 0]
        result = tuple(np.asarray(new[:, self.slices[k]], np.asarray(v).dtype).reshape(np.shape(v))
                       for k, v in (("qpos", qpos), ("qvel", qvel), ("act", act)))
        result += (sensors.astype(np.asarray(qpos).dtype),)
        return tuple(r[0] for r in result) if single else result

    def _models(self, batch: int, fields: list[np.ndarray]) -> list[mujoco.MjModel]:
        """One C model per environment holding its own `PER_ENVIRONMENT` values (written only when
        they change: within an episode they do not)."""
        while len(self.models) < batch:
            self.models.append(copy.deepcopy(self.model))
            self.written = None
        models = self.models[:batch]
        values = [np.asarray(v, np.float64) for v in fields]
        if self.written is not None and all(w.shape == v.shape and np.array_equal(w, v)
                                            for w, v in zip(self.written, values)):
            return models
        for name, value in zip(PER_ENVIRONMENT, values):
            for i, m in enumerate(models):
                getattr(m, name)[:] = value[i if value.shape[0] == batch else 0].reshape(getattr(m, name).shape)
        self.written = values
        return models


def _state_slices(model: mujoco.MjModel, spec: int) -> dict[str, slice]:
    """Where time, qpos, qvel and act sit in a state vector of `spec` (components in bit order)."""
    names = {mujoco.mjtState.mjSTATE_TIME: "time", mujoco.mjtState.mjSTATE_QPOS: "qpos",
             mujoco.mjtState.mjSTATE_QVEL: "qvel", mujoco.mjtState.mjSTATE_ACT: "act"}
    slices, at = {}, 0
    for bit in range(int(mujoco.mjtState.mjNSTATE)):
        component = 1 << bit
        if not spec & component:
            continue
        size = mujoco.mj_stateSize(model, component)
        if component in names:
            slices[names[component]] = slice(at, at + size)
        at += size
    return slices
