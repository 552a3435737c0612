"""Sensing: what the cascade controller measures of the robot and the ground, from `mjx.Data`.

Everything the controller and the rewards read comes through `observe`: joint angles and rates
of the leg motors, the pelvis pose and velocity (horizontal velocity in the heading frame, the
frame of Sec. V-A's features), the feet (positions, orientation relative to flat, ground
reaction forces, velocities), the centre of mass, and the terrain height under the pelvis.
"""

from __future__ import annotations

from typing import NamedTuple

import jax
import jax.numpy as jnp
from jax import Array

from mjx_cascade.features import to_heading_frame
from mjx_cascade.physics import mjx
from mjx_cascade.robots import scene
from mjx_cascade.robots.base import Robot
from mjx_cascade.rotations import quat_to_rpy


class Obs(NamedTuple):
    q: Array  # [2, J] leg motor joint angles, absolute (row 0 left)
    qd: Array  # [2, J]
    pos: Array  # [3] pelvis position
    rpy: Array  # [3] pelvis roll, pitch, yaw
    omega: Array  # [3] pelvis angular velocity, pelvis frame
    v_heading: Array  # [2] pelvis horizontal velocity, heading frame
    feet: Array  # [2, 3] foot positions
    foot_angles: Array  # [2, 2] foot (pitch, roll) relative to flat, heading frame
    foot_force: Array  # [2] normal ground reaction forces
    foot_v: Array  # [2, 3] foot linear velocities
    foot_w: Array  # [2, 3] foot angular velocities
    com: Array  # [3] centre of mass
    ground: Array  # terrain height under the pelvis


def foot_angles(rot: Array, flat: Array, yaw: Array) -> Array:
    """(pitch, roll) of a foot relative to its flat standing orientation, in the heading frame."""
    e = rot @ flat.T  # rotation taking the flat foot to the current one
    hx = jnp.stack([jnp.cos(yaw), jnp.sin(yaw), 0.0])
    hy = jnp.stack([-jnp.sin(yaw), jnp.cos(yaw), 0.0])
    return jnp.stack([jnp.arcsin(jnp.clip(-e[2] @ hx, -1, 1)), jnp.arcsin(jnp.clip(e[2] @ hy, -1, 1))])


def ground_height(hf: scene.HeightField | None, model: mjx.Model, pos: Array) -> Array:
    """Terrain height under `pos`, read from the model's height field (its data may be batched)."""
    if hf is None:
        return jnp.zeros(())
    return scene.height_at(hf, model.hfield_data, pos[0], pos[1], xp=jnp)


def observe(robot: Robot, hf: scene.HeightField | None, data: mjx.Data, model: mjx.Model) -> Obs:
    """The controller's measurements of `data`; `model` holds the terrain `hf` describes."""
    r = robot
    rpy = quat_to_rpy(data.qpos[3:7], jnp)
    root_com = data.subtree_com[r.pelvis_body]
    cvel = data.cvel[r.foot_body]
    foot_v = cvel[:, 3:] + jnp.cross(cvel[:, :3], data.xpos[r.foot_body] - root_com)
    pos = data.qpos[:3]
    return Obs(
        q=data.qpos[r.qpos_adr],
        qd=data.qvel[r.dof_adr],
        pos=pos,
        rpy=rpy,
        omega=data.qvel[3:6],
        v_heading=to_heading_frame(data.qvel[:2], rpy[2]),
        feet=data.xpos[r.foot_body],
        foot_angles=jax.vmap(foot_angles, in_axes=(0, 0, None))(data.xmat[r.foot_body], r.foot_flat, rpy[2]),
        foot_force=data.sensordata[r.foot_force_adr],
        foot_v=foot_v,
        foot_w=cvel[:, :3],
        com=root_com,
        ground=ground_height(hf, model, pos),
    )
