"""The physics scene around a robot's MJCF: ground or terrain, foot sensors, physics options.

- Visual-only geoms (no collision) are removed, and with them the meshes, textures and
  materials: they cost MJX time and their files may be absent. Bodies keep their explicit
  inertias, so the dynamics are unchanged.
- Only the feet collide, and only with the ground: early termination (eq. 27) ends an
  episode long before any other part could touch it, and fewer collision pairs make MJX
  faster.
- Each foot gets a touch sensor (its normal ground reaction force, Sec. III-C) on a box
  site enclosing the foot's collision geoms; the model's own sensors are dropped, since the
  controller reads the state directly.
- Terrain: `flat` is a plane; `slope` and `rough` are height fields that are flat within
  1 m of the start, so every scenario begins standing on level ground.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

import mujoco
import numpy as np

from mjx_cascade.config import PhysicsConfig

if TYPE_CHECKING:
    from mjx_cascade.robots.base import RobotDefinition

FLAT_RADIUS = 1.0  # m of level ground around the start
HFIELD_EXTENT = ((-5.0, 25.0), (-10.0, 10.0))  # x and y ranges covered by a height field, m
HFIELD_CELL = 0.04  # m


def compile_model(spec: mujoco.MjSpec, robot: "RobotDefinition", physics: PhysicsConfig, terrain: dict) -> mujoco.MjModel:
    _strip_visuals(spec)
    for sensor in list(spec.sensors):
        spec.delete(sensor)
    foot_geoms = _feet_only_collisions(spec, robot.feet)
    for foot, geoms in zip(robot.feet, foot_geoms):
        _add_touch_sensor(spec, foot, geoms)
    _add_ground(spec, terrain)
    spec.option.timestep = physics.dt
    spec.option.iterations = physics.solver_iterations
    spec.option.ls_iterations = physics.ls_iterations
    return spec.compile()


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


def _add_ground(spec: mujoco.MjSpec, terrain: dict) -> None:
    if terrain["type"] == "flat":
        spec.worldbody.add_geom(name="ground", type=mujoco.mjtGeom.mjGEOM_PLANE, size=[0, 0, 1],
                                contype=0, conaffinity=1, condim=3)
        return
    (x0, x1), (y0, y1) = HFIELD_EXTENT
    ncol = int(round((x1 - x0) / HFIELD_CELL)) + 1
    nrow = int(round((y1 - y0) / HFIELD_CELL)) + 1
    xs, ys = np.linspace(x0, x1, ncol), np.linspace(y0, y1, nrow)
    heights = ground_height(terrain, xs[None, :], ys[:, None])
    low, high = float(heights.min()), float(heights.max())
    span = max(high - low, 1e-3)
    spec.add_hfield(
        name="terrain",
        size=[(x1 - x0) / 2, (y1 - y0) / 2, span, 0.5],
        nrow=nrow,
        ncol=ncol,
        userdata=((heights - low) / span).astype(np.float32).ravel().tolist(),
    )
    spec.worldbody.add_geom(name="ground", type=mujoco.mjtGeom.mjGEOM_HFIELD, hfieldname="terrain",
                            pos=[(x0 + x1) / 2, (y0 + y1) / 2, low], contype=0, conaffinity=1, condim=3)
