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
from typing import Callable, NamedTuple, Sequence

import jax
import jax.numpy as jnp
import mujoco
import numpy as np
from mujoco import rollout

with contextlib.redirect_stdout(io.StringIO()):  # mjx prints "Failed to import warp" to stdout
    from mujoco import mjx

from mjx_cascade import _xla
from mjx_cascade.config import ConfigError, PhysicsConfig

__all__ = ["mjx", "resolve_impl", "put_model", "make_data", "stepper", "add_engine_sensors", "CEngine"]


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


Step = Callable[..., mjx.Data]


def stepper(model: mujoco.MjModel, impl: str) -> Step:
    """One physics step of `impl` (resolved), `(model, data, live=None) -> data`, pure and
    vmappable. `live` false says nothing reads the environment's next state (its episode is
    done): the C engine then leaves it as it was, where MJX, vectorized, steps it anyway."""
    if impl == "mujoco":
        return CEngine(model).step
    return lambda m, d, live=None: mjx.step(m, d)


# the model fields an environment may hold its own value of (`randomization`)
PER_ENVIRONMENT = ("body_mass", "body_ipos")
_STATE = mujoco.mjtState.mjSTATE_FULLPHYSICS
_CONTROL = mujoco.mjtState.mjSTATE_CTRL | mujoco.mjtState.mjSTATE_XFRC_APPLIED

# The sensors through which the C engine reports the kinematics the observation reads: for each
# body given to `add_engine_sensors`, (name, sensor type, object type), 3 numbers each.
_S, _O = mujoco.mjtSensor, mujoco.mjtObj
ENGINE_SENSORS = (
    ("xpos", _S.mjSENS_FRAMEPOS, _O.mjOBJ_XBODY),
    ("xaxis", _S.mjSENS_FRAMEXAXIS, _O.mjOBJ_XBODY),  # the columns of xmat
    ("yaxis", _S.mjSENS_FRAMEYAXIS, _O.mjOBJ_XBODY),
    ("zaxis", _S.mjSENS_FRAMEZAXIS, _O.mjOBJ_XBODY),
    ("subtree_com", _S.mjSENS_SUBTREECOM, _O.mjOBJ_BODY),
    ("angvel", _S.mjSENS_FRAMEANGVEL, _O.mjOBJ_XBODY),  # world frame, as cvel's rotational part
    ("linvel", _S.mjSENS_FRAMELINVEL, _O.mjOBJ_XBODY),  # of the body frame's origin, world frame
)
_ENGINE_PREFIX = "engine:"


def add_engine_sensors(spec: mujoco.MjSpec, bodies: Sequence[str]) -> None:
    """Sensors (`ENGINE_SENSORS`) reporting, from the C engine's step, the kinematics that the
    observation reads of `bodies` (their positions, orientations, subtree centres of mass and
    velocities), so that JAX need not recompute them; `bodies` holds the root of each one's tree.
    They read the state before the step, as `mjx.step` leaves these fields, and alter no physics."""
    for body in bodies:
        for name, kind, objtype in ENGINE_SENSORS:
            spec.add_sensor(name=f"{_ENGINE_PREFIX}{name}:{body}", type=kind, objtype=objtype, objname=body)


class _Kinematics(NamedTuple):
    """Where a model's engine sensors sit in its sensordata: `bodies` [K] ids, and per
    `ENGINE_SENSORS` name the sensordata indices [K, 3]; `root` [K] each body's root's row in `bodies`."""

    bodies: np.ndarray
    root: np.ndarray
    at: dict


def _engine_kinematics(model: mujoco.MjModel) -> _Kinematics:
    found: dict[int, dict[str, np.ndarray]] = {}
    for i in range(model.nsensor):
        name = model.sensor(i).name
        if name.startswith(_ENGINE_PREFIX):
            field = name[len(_ENGINE_PREFIX):].split(":")[0]
            adr = model.sensor_adr[i]
            found.setdefault(int(model.sensor_objid[i]), {})[field] = np.arange(adr, adr + 3)
    bodies = np.array(sorted(found), dtype=np.int64)
    if not len(bodies) or any(len(found[b]) != len(ENGINE_SENSORS) for b in bodies):
        raise ValueError("impl mujoco needs the model's engine sensors (physics.add_engine_sensors; "
                         "robots.build adds them when the physics config says impl mujoco)")
    row = {int(b): k for k, b in enumerate(bodies)}
    roots = [int(model.body_rootid[b]) for b in bodies]
    if any(r not in row for r in roots):
        raise ValueError("the engine sensors must cover the root of every body they cover (its cvel is about "
                         "the root's subtree centre of mass)")
    return _Kinematics(bodies, np.array([row[r] for r in roots]),
                       {name: np.stack([found[int(b)][name] for b in bodies]) for name, *_ in ENGINE_SENSORS})


def _with_kinematics(data: mjx.Data, sensordata: jax.Array, k: _Kinematics) -> mjx.Data:
    """`data` with the engine-sensed bodies' xpos, xmat, subtree_com and cvel read from `sensordata`."""
    read = {name: sensordata[idx] for name, idx in k.at.items()}
    xmat = jnp.stack([read["xaxis"], read["yaxis"], read["zaxis"]], axis=-1)
    w, origin = read["angvel"], read["xpos"]
    # cvel's linear part is the velocity at the root's subtree centre of mass, seen as moving with the body
    at_com = read["linvel"] - jnp.cross(w, origin - read["subtree_com"][k.root])
    b = k.bodies
    return data.replace(xpos=data.xpos.at[b].set(origin), xmat=data.xmat.at[b].set(xmat),
                        subtree_com=data.subtree_com.at[b].set(read["subtree_com"]),
                        cvel=data.cvel.at[b].set(jnp.concatenate([w, at_com], axis=-1)))


class CEngine:
    """Steps of MuJoCo's C engine for a batch of environments, as one JAX callback.

    `step` packs each environment's state, controls, pelvis forces, per-environment model fields
    (`PER_ENVIRONMENT`; one terrain for the whole batch, the model's) and whether it is live into
    one vector (a callback's cost grows with its number of arrays), steps every live environment
    of the vmapped batch once with `mujoco.rollout` on `threads` threads, and returns the new
    state and sensors as one vector. The fields the observation reads besides the state
    (positions, orientations, subtree centres of mass and velocities of the bodies it names)
    come from the model's engine sensors (`add_engine_sensors`), which the C step computes of
    the state before the step, as `mjx.step` leaves them; the other derived fields of the
    returned data are stale. The solver's warm start carries over as the step's mean
    acceleration. The C engine runs in float64 and MJX in float32, so the two agree to the
    physics' tolerance, not bit for bit (tests/test_physics.py).
    """

    def __init__(self, model: mujoco.MjModel, threads: int | None = None):
        self.model = model
        self.threads = threads or _xla.cores()
        self.models: list[mujoco.MjModel] = []
        self.written: np.ndarray | None = None  # the per-environment fields the models hold
        self.datas = [mujoco.MjData(model) for _ in range(self.threads)]
        self.pool = rollout.Rollout(nthread=self.threads)
        template = mujoco.MjData(model)
        self.template = np.empty(mujoco.mj_stateSize(model, _STATE))
        mujoco.mj_getState(model, template, self.template, _STATE)
        self.slices = _state_slices(model, _STATE)
        self.kinematics = _engine_kinematics(model)
        m = model
        self.inputs = _layout(time=1, qpos=m.nq, qvel=m.nv, act=m.na, warmstart=m.nv, control=m.nu + 6 * m.nbody,
                              sensordata=m.nsensordata, fields=sum(getattr(m, f).size for f in PER_ENVIRONMENT), live=1)
        self.outputs = _layout(qpos=m.nq, qvel=m.nv, act=m.na, sensordata=m.nsensordata)
        self.lock = threading.Lock()  # JAX devices split from the CPU may call at once: one batch at a time

    def step(self, model: mjx.Model, data: mjx.Data, live: jax.Array | None = None) -> mjx.Data:
        """`mjx.step` in the C engine: one step of `data` under `model` (its per-environment
        fields); an environment that is not `live` keeps its state and sensors."""
        live = jnp.ones((), bool) if live is None else live
        packed = jnp.concatenate([jnp.ravel(a).astype(jnp.float32) for a in (
            data.time, data.qpos, data.qvel, data.act, data.qacc_warmstart, data.ctrl, data.xfrc_applied,
            data.sensordata, *(getattr(model, f) for f in PER_ENVIRONMENT), live)])
        out = jax.ShapeDtypeStruct((self.outputs["size"],), jnp.float32)
        # the height field goes along only to refuse a batch of several (an array more costs ~20 us a step)
        terrain = (model.hfield_data[:1],) if self.model.nhfield else ()
        new = jax.pure_callback(self._host_step, out, packed, *terrain, vmap_method="expand_dims")
        o = self.outputs
        qpos, qvel, act, sensordata = (new[o[k]].astype(getattr(data, k).dtype)
                                       for k in ("qpos", "qvel", "act", "sensordata"))
        dt = jnp.asarray(model.opt.timestep, data.time.dtype)
        warmstart = jnp.where(live, (qvel - data.qvel) / dt, data.qacc_warmstart).astype(data.qacc_warmstart.dtype)
        data = data.replace(time=data.time + dt, qpos=qpos, qvel=qvel, act=act, sensordata=sensordata,
                            qacc_warmstart=warmstart)
        return _with_kinematics(data, sensordata, self.kinematics)

    def _host_step(self, packed: np.ndarray, terrain: np.ndarray | None = None) -> np.ndarray:
        with self.lock:
            return self._step_batch(packed, terrain)

    def _step_batch(self, packed: np.ndarray, terrain: np.ndarray | None) -> np.ndarray:
        single = np.ndim(packed) == 1  # called outside vmap
        packed = np.asarray(packed, np.float64).reshape(-1, self.inputs["size"])
        batch, i, o = packed.shape[0], self.inputs, self.outputs
        if terrain is not None and batch > 1 and np.shape(terrain)[0] == batch:  # a height field per environment
            raise ValueError("impl mujoco steps a batch on one terrain: a batch of several terrains (the robustness "
                             "sweep's rough ground) runs with impl jax")
        out = np.zeros((batch, o["size"]), np.float32)
        for k in ("qpos", "qvel", "act", "sensordata"):  # what environments that are not live keep
            out[:, o[k]] = packed[:, i[k]]
        live = np.nonzero(packed[:, i["live"]][:, 0] > 0.5)[0]
        if len(live):
            state, sensors = self._rollout(packed[live], self._models(batch, packed[:, i["fields"]]), live)
            for k in ("qpos", "qvel", "act"):
                out[live, o[k]] = state[:, self.slices[k]]
            out[live, o["sensordata"]] = sensors
        return out[0] if single else out

    def _rollout(self, packed: np.ndarray, models: list[mujoco.MjModel], which: np.ndarray):
        """`(new states, sensors)` of the environments `which` (their rows `packed`), one step each,
        in one chunk per thread: a one-step rollout is short enough that the pool's default of ten
        chunks per thread costs more in hand-offs than it gains in balance (benchmarks/README.md)."""
        n, i = packed.shape[0], self.inputs
        state = np.repeat(self.template[None], n, axis=0)
        for k in ("time", "qpos", "qvel", "act"):
            state[:, self.slices[k]] = packed[:, i[k]]
        new = np.empty((n, 1, state.shape[1]))
        sensors = np.empty((n, 1, self.model.nsensordata))
        self.pool.rollout([models[j] for j in which], self.datas, state,
                          np.ascontiguousarray(packed[:, None, i["control"]]), control_spec=_CONTROL, nstep=1,
                          skip_checks=True, initial_warmstart=np.ascontiguousarray(packed[:, i["warmstart"]]),
                          state=new, sensordata=sensors, chunk_size=-(-n // self.threads))
        return new[:, 0], sensors[:, 0]

    def _models(self, batch: int, fields: np.ndarray) -> list[mujoco.MjModel]:
        """One C model per environment holding its own `PER_ENVIRONMENT` values (written only when
        they change: within an episode they do not)."""
        while len(self.models) < batch:
            self.models.append(copy.deepcopy(self.model))
            self.written = None
        models = self.models[:batch]
        if self.written is not None and np.array_equal(self.written, fields):
            return models
        for m, row in zip(models, fields):
            at = 0
            for name in PER_ENVIRONMENT:
                target = getattr(m, name)
                target[:] = row[at:at + target.size].reshape(target.shape)
                at += target.size
            m.body_subtreemass[:] = subtree_masses(m.body_mass, m.body_parentid)
        self.written = fields.copy()
        return models


def subtree_masses(body_mass: np.ndarray, parent: np.ndarray) -> np.ndarray:
    """Each body's mass plus its descendants'. MuJoCo C's subtree centres of mass divide by the
    model's `body_subtreemass`, computed when the model compiles, while MJX sums the masses it is
    given at every step: a model whose `body_mass` changes (`randomization`, the mass sweep) needs
    these written too, or C reports the centre of mass at the scaled masses' share of its position."""
    total = np.array(body_mass, np.float64)
    for b in range(len(total) - 1, 0, -1):  # a body's parent comes before it
        total[parent[b]] += total[b]
    return total


def _layout(**sizes: int) -> dict:
    """Slices of consecutive parts of a packed vector, by name, and its `size`."""
    out, at = {}, 0
    for name, size in sizes.items():
        out[name], at = slice(at, at + size), at + size
    out["size"] = at
    return out


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
