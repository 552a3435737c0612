"""The physics scene around a robot's MJCF: ground or terrain, foot sensors, physics options.

- Visual-only geoms (no collision) are removed, and with them the meshes, textures and
  materials: they cost MJX time and their files may be absent. Bodies keep their explicit
  inertias, so the dynamics are unchanged.
- Only the feet collide, and only with the ground: early termination (eq. 27) ends an
  episode long before any other part could touch it, and fewer collision pairs make MJX
  faster.
- Each foot gets a touch sensor (its normal ground reaction force, Sec. III-C) on a box
  site enclosing the foot's collision geoms; the model's own sensors are dropped, since the
  controller reads the state directly (MuJoCo's C engine reports the feet's and the pelvis's
  kinematics through sensors of its own, `physics.add_engine_sensors`).
- Terrain: `flat` is a plane; `slope` and `rough` are height fields that are flat within
  1 m of the start, so every scenario begins standing on level ground. A list of terrains
  builds one height field whose vertical range holds them all; `hfield_data` gives each
  one's data for that model, so a batch can walk on different terrains in one compiled call.
"""

from __future__ import annotations

import json
import math
from typing import NamedTuple, Sequence

import mujoco
import numpy as np

from mjx_cascade.config import PhysicsConfig
from mjx_cascade.physics import add_engine_sensors

FLAT_RADIUS = 1.0  # m of level ground around the start
HFIELD_EXTENT = ((-5.0, 25.0), (-10.0, 10.0))  # x and y ranges covered by a height field, m
HFIELD_CELL = 0.04  # m


def compile_model(spec: mujoco.MjSpec, feet: tuple[str, str], physics: PhysicsConfig,
                  terrain: dict | Sequence[dict], pelvis: str) -> mujoco.MjModel:
    """The robot's MJCF `spec` with the ground (or terrains), foot sensors and physics options;
    `feet` names the foot bodies (left, right), `pelvis` the root body. For MuJoCo's C engine
    (`impl: mujoco`) the feet and pelvis also get the sensors through which it reports what the
    observation reads of them (`physics.add_engine_sensors`)."""
    _strip_visuals(spec)
    for sensor in list(spec.sensors):
        spec.delete(sensor)
    foot_geoms = _feet_only_collisions(spec, feet)
    for foot, geoms in zip(feet, foot_geoms):
        _add_touch_sensor(spec, foot, geoms)
    if physics.impl == "mujoco":
        add_engine_sensors(spec, (pelvis, *feet))
    _add_ground(spec, terrain)
    spec.option.timestep = physics.dt
    spec.option.iterations = physics.solver_iterations
    spec.option.ls_iterations = physics.ls_iterations
    model = spec.compile()
    if model.nhfield:  # MuJoCo rescales the data to [0, 1]; restore the first terrain's heights
        model.hfield_data[:] = hfield_data(model, terrain if isinstance(terrain, dict) else terrain[0])
    return model


def _strip_visuals(spec: mujoco.MjSpec) -> None:
    for geom in list(spec.geoms):
        if geom.contype == 0 and geom.conaffinity == 0:
            spec.delete(geom)
    for item in list(spec.meshes) + list(spec.textures) + list(spec.materials):
        spec.delete(item)


def _feet_only_collisions(spec: mujoco.MjSpec, feet: tuple[str, str]) -> list[list]:
    """Disable every collision except foot geoms against the ground; return the foot geoms."""
    foot_geoms = []
    for foot in feet:
        geoms = [g for g in spec.body(foot).geoms if g.contype or g.conaffinity]
        if not geoms:
            raise ValueError(f"foot body {foot!r} has no collision geom")
        foot_geoms.append(geoms)
    keep = {id(g) for geoms in foot_geoms for g in geoms}
    for geom in spec.geoms:
        if id(geom) in keep:
            geom.contype, geom.conaffinity = 1, 0
            geom.condim = 3
        else:
            geom.contype, geom.conaffinity = 0, 0
    return foot_geoms


def _add_touch_sensor(spec: mujoco.MjSpec, foot: str, geoms: list) -> None:
    body = spec.body(foot)
    lo, hi = _geoms_box(geoms)
    margin = 0.03
    body.add_site(
        name=f"{foot}-touch",
        type=mujoco.mjtGeom.mjGEOM_BOX,
        pos=(lo + hi) / 2,
        size=(hi - lo) / 2 + margin,
        group=5,
    )
    spec.add_sensor(
        name=f"{foot}-grf",
        type=mujoco.mjtSensor.mjSENS_TOUCH,
        objtype=mujoco.mjtObj.mjOBJ_SITE,
        objname=f"{foot}-touch",
    )


def _geoms_box(geoms: list) -> tuple[np.ndarray, np.ndarray]:
    """Axis-aligned box (body frame) around capsule/sphere/box geoms given by fromto or pos/size."""
    points = []
    for g in geoms:
        r = float(g.size[0])
        if not np.any(np.isnan(g.fromto)) and np.any(g.fromto != 0):
            ends = np.array(g.fromto).reshape(2, 3)
        else:
            ends = np.array([g.pos]) + np.zeros((1, 3))
            r = float(np.max(g.size))
        points.append(ends - r)
        points.append(ends + r)
    pts = np.concatenate(points)
    return pts.min(axis=0), pts.max(axis=0)


def terrain_key(terrain: dict) -> str:
    """A terrain's identity, for grouping scenarios that walk on the same one."""
    return json.dumps(terrain, sort_keys=True)


def distinct(terrains: Sequence[dict]) -> list[dict]:
    """The terrains of a batch, each once, in the order they first appear."""
    return list({terrain_key(t): t for t in terrains}.values())


def ground_height(terrain: dict, x, y, xp=np):
    """Terrain height at world (x, y); zero on the level area around the start.

    `xp` is the array module (NumPy, or `jax.numpy` inside jitted code).
    """
    kind = terrain["type"]
    if kind == "flat":
        return xp.zeros(xp.broadcast_shapes(xp.shape(x), xp.shape(y)))
    if kind == "slope":
        grade = math.tan(math.radians(terrain["degrees"]))
        return grade * xp.maximum(x - FLAT_RADIUS, 0.0) + 0.0 * y
    if kind == "rough":
        return _rough(terrain["amplitude"], terrain["seed"], x, y, xp)
    raise ValueError(f"unknown terrain type {kind!r}")


def _rough(amplitude: float, seed: int, x, y, xp):
    """Smooth random bumps with heights in [0, amplitude], ramped in beyond the level start."""
    rng = np.random.default_rng(seed)
    k = rng.uniform(2.0, 8.0, size=(12, 2)) * rng.choice([-1.0, 1.0], size=(12, 2))
    phase = rng.uniform(0.0, 2 * np.pi, size=12)
    field = sum(xp.sin(k[i, 0] * x + k[i, 1] * y + phase[i]) for i in range(12)) / math.sqrt(6.0)
    field = xp.clip(0.5 + 0.25 * field, 0.0, 1.0)
    ramp = xp.clip(xp.hypot(x, y) - FLAT_RADIUS, 0.0, 0.5) / 0.5
    return amplitude * field * ramp


def _grid() -> tuple[np.ndarray, np.ndarray]:
    (x0, x1), (y0, y1) = HFIELD_EXTENT
    ncol = int(round((x1 - x0) / HFIELD_CELL)) + 1
    nrow = int(round((y1 - y0) / HFIELD_CELL)) + 1
    return np.linspace(x0, x1, ncol), np.linspace(y0, y1, nrow)


def _heights(terrain: dict) -> np.ndarray:
    """[nrow, ncol] terrain heights on the height field's grid (rows along y, as MuJoCo's)."""
    xs, ys = _grid()
    return ground_height(terrain, xs[None, :], ys[:, None])


def _add_ground(spec: mujoco.MjSpec, terrain: dict | Sequence[dict]) -> None:
    terrains = [terrain] if isinstance(terrain, dict) else list(terrain)
    if all(t["type"] == "flat" for t in terrains):
        spec.worldbody.add_geom(name="ground", type=mujoco.mjtGeom.mjGEOM_PLANE, size=[0, 0, 1],
                                contype=0, conaffinity=1, condim=3)
        return
    (x0, x1), (y0, y1) = HFIELD_EXTENT
    xs, ys = _grid()
    heights = [_heights(t) for t in terrains]
    low = min(float(h.min()) for h in heights)
    span = max(max(float(h.max()) for h in heights) - low, 1e-3)
    spec.add_hfield(
        name="terrain",
        size=[(x1 - x0) / 2, (y1 - y0) / 2, span, 0.5],
        nrow=len(ys),
        ncol=len(xs),
        userdata=((heights[0] - low) / span).astype(np.float32).ravel().tolist(),
    )
    spec.worldbody.add_geom(name="ground", type=mujoco.mjtGeom.mjGEOM_HFIELD, hfieldname="terrain",
                            pos=[(x0 + x1) / 2, (y0 + y1) / 2, low], contype=0, conaffinity=1, condim=3)


class HeightField(NamedTuple):
    """Where a model's height field lies: static numbers for looking heights up in its data."""

    x0: float
    y0: float
    cell_x: float
    cell_y: float
    nrow: int
    ncol: int
    low: float  # height of data 0
    span: float  # height of data 1 above `low`


def height_field(model: mujoco.MjModel) -> HeightField | None:
    """The ground's height field, or None when the ground is a plane."""
    if model.nhfield == 0:
        return None
    g = model.geom("ground")
    sx, sy, span, _ = model.hfield_size[0]
    nrow, ncol = int(model.hfield_nrow[0]), int(model.hfield_ncol[0])
    return HeightField(float(g.pos[0] - sx), float(g.pos[1] - sy), float(2 * sx / (ncol - 1)),
                       float(2 * sy / (nrow - 1)), nrow, ncol, float(g.pos[2]), float(span))


def hfield_data(model: mujoco.MjModel, terrain: dict) -> np.ndarray:
    """`terrain`'s data for `model`'s height field (built from a list of terrains that held it)."""
    hf = height_field(model)
    if hf is None:
        raise ValueError("the model's ground is a plane, not a height field")
    data = (_heights(terrain) - hf.low) / hf.span
    if data.shape != (hf.nrow, hf.ncol) or data.min() < -1e-6 or data.max() > 1 + 1e-6:
        raise ValueError(f"terrain {terrain} does not fit the model's height field")
    return np.clip(data, 0.0, 1.0).astype(np.float32).ravel()


def height_at(hf: HeightField, data, x, y, xp=np):
    """Ground height at world (x, y), bilinear in the height field's `data` (flat, row-major).

    `data` may be a traced array (one environment's row of a batch of terrains).
    """
    fx = xp.clip((x - hf.x0) / hf.cell_x, 0.0, hf.ncol - 1.001)
    fy = xp.clip((y - hf.y0) / hf.cell_y, 0.0, hf.nrow - 1.001)
    ix, iy = xp.floor(fx).astype(int), xp.floor(fy).astype(int)
    ax, ay = fx - ix, fy - iy
    z = data.reshape(hf.nrow, hf.ncol)
    top = (1 - ax) * z[iy, ix] + ax * z[iy, ix + 1]
    bottom = (1 - ax) * z[iy + 1, ix] + ax * z[iy + 1, ix + 1]
    return hf.low + hf.span * ((1 - ay) * top + ay * bottom)
