"""Balanced initial states (Sec. V-C): a model-based standing controller settles varied poses.

Each pool member starts from the nominal pose with random crouch, hip and stance-width
offsets, and is balanced for `settle_seconds` by:
- joint PD (eq. 21) to the offset pose;
- the torso regulator (Sec. IV-B) on both hip pitch joints, half the torque each;
- centre-of-mass feedback through the feet: a foot pitch torque proportional to how far the
  CoM (from the model) is ahead of the feet's midpoint, and to its velocity;
- roll through leg length: the knee of the higher side bends, the lower side extends
  (with two narrow feet, hip roll alone cannot right the pelvis in double support).
States that end upright, at rest and on both feet form the pool. It runs MuJoCo's C
simulator once per process, before any JAX work, so it costs no compilation.
"""

from __future__ import annotations

import hashlib

import mujoco
import numpy as np

from mjx_cascade import regulators
from mjx_cascade.config import Config
from mjx_cascade.robots.base import Robot
from mjx_cascade.rotations import quat_to_rpy

COM_GAIN, COM_DAMPING = 300.0, 30.0  # foot pitch torque per m and per m/s of CoM offset
ROLL_GAIN, ROLL_DAMPING = 3.0, 0.3  # knee angle per rad and per rad/s of pelvis roll


def balanced_pool(robot: Robot, cfg: Config, seed: int = 0) -> tuple[np.ndarray, np.ndarray]:
    """`(qpos [P, nq], qvel [P, nv])` of `cfg.episode.pool_size` balanced states, feet centred on the origin.

    A pure function of the model, the settings it reads and the seed; a process computes each
    pool once (seconds of simulation), and every caller gets its own copy.
    """
    key = (robot.definition.name, _model_digest(robot.model), repr(cfg.episode), repr(cfg.termination),
           repr(cfg.regulators), seed)
    if key not in _POOLS:
        _POOLS[key] = _balanced_pool(robot, cfg, seed)
    return tuple(a.copy() for a in _POOLS[key])


_POOLS: dict[tuple, tuple[np.ndarray, np.ndarray]] = {}


def _model_digest(model: mujoco.MjModel) -> str:
    buffer = np.empty(mujoco.mj_sizeModel(model), np.uint8)
    mujoco.mj_saveModel(model, None, buffer)
    return hashlib.sha256(buffer.tobytes()).hexdigest()


def _balanced_pool(robot: Robot, cfg: Config, seed: int) -> tuple[np.ndarray, np.ndarray]:
    rng = np.random.default_rng(seed)
    size = cfg.episode.pool_size
    states = []
    for _ in range(4 * size):
        state = _settle(robot, cfg, _offsets(robot, rng))
        if state is not None:
            states.append(state)
        if len(states) == size:
            return np.stack([s[0] for s in states]), np.stack([s[1] for s in states])
    raise RuntimeError(f"the standing controller balanced only {len(states)} of {4 * size} poses")


def _offsets(robot: Robot, rng: np.random.Generator) -> np.ndarray:
    """Role-coordinate offsets [2, J] from the nominal pose: crouch, hip pitch, stance width."""
    off = np.zeros_like(robot.nominal_role)
    off[:, robot.knee] = -robot.knee_extension * rng.uniform(-0.05, 0.15)
    off[:, robot.hip_pitch] = rng.uniform(-0.05, 0.05)
    off[:, robot.hip_roll] = rng.uniform(-0.02, 0.04) * robot.lateral_sign * np.array([1.0, -1.0])  # outward
    return off


def _settle(robot: Robot, cfg: Config, offset: np.ndarray) -> tuple[np.ndarray, np.ndarray] | None:
    m = robot.model
    d = mujoco.MjData(m)
    d.qpos[:] = robot.nominal_qpos
    side = np.stack([np.ones_like(robot.mirror), robot.mirror])  # left, right legs
    target = (robot.nominal_role + offset) * side  # absolute [2, J]
    mujoco.mj_forward(m, d)
    for _ in range(int(round(cfg.episode.settle_seconds / m.opt.timestep))):
        d.ctrl[:] = _control(robot, cfg, d, target, side)
        mujoco.mj_step(m, d)
    if not _balanced(robot, cfg, d):
        return None
    qpos = d.qpos.copy()
    qpos[:2] -= d.xpos[robot.foot_body, :2].mean(axis=0)  # stand centred on the origin
    return qpos, d.qvel.copy()


def _control(robot: Robot, cfg: Config, d: mujoco.MjData, target: np.ndarray, side: np.ndarray) -> np.ndarray:
    rpy = quat_to_rpy(d.qpos[3:7])
    omega = d.qvel[3:6]
    target = target.copy()
    roll_fix = ROLL_GAIN * rpy[0] + ROLL_DAMPING * omega[0]
    # Higher side (left when rolled positive) shortens; knee_extension says which way is longer.
    target[0, robot.knee] -= roll_fix * robot.knee_extension[0] * side[0, robot.knee]
    target[1, robot.knee] += roll_fix * robot.knee_extension[1] * side[1, robot.knee]
    q, qd = d.qpos[robot.qpos_adr], d.qvel[robot.dof_adr]
    u = robot.kp * (target - q) - robot.kd * qd
    pelvis_torque = regulators.torso_torque(rpy, omega, cfg.regulators)
    feet = d.xpos[robot.foot_body]
    com = d.subtree_com[robot.pelvis_body]
    com_vel = d.qvel[0]
    # foot pitch torque that pushes the body back when the CoM is ahead (see module docstring)
    foot_pitch_torque = COM_GAIN * (com[0] - feet[:, 0].mean()) + COM_DAMPING * com_vel
    for leg in range(2):
        u[leg, robot.hip_pitch] += 0.5 * robot.torso_sign[leg, 1] * float(pelvis_torque[1]) * side[leg, robot.hip_pitch]
        u[leg, robot.toe] += (robot.toe_jac[leg].T @ np.array([foot_pitch_torque, 0.0])) * side[leg, robot.toe]
    ctrl = np.zeros(robot.model.nu)
    ctrl[robot.actuator] = np.clip(u / robot.gear, robot.ctrl_low, robot.ctrl_high)
    return ctrl


def _balanced(robot: Robot, cfg: Config, d: mujoco.MjData) -> bool:
    rpy = quat_to_rpy(d.qpos[3:7])
    force = d.sensordata[robot.foot_force_adr]
    lo, hi = cfg.termination.height
    return bool(
        np.all(np.isfinite(d.qpos))
        and np.all(np.abs(rpy[:2]) < 0.1)
        and lo < d.qpos[2] < hi
        and np.max(np.abs(d.qvel)) < 0.5
        and np.all(force > 0.0)
    )
