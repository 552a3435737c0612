"""What a robot is to the controller: its definition, and the model facts derived from it.

A `RobotDefinition` holds the hand-written knowledge of one robot: joint names per leg,
which joints the policy learns, their ranges, PD gains, bodies, nominal pose, and how to
load the model. `build()` compiles the model for the physics settings of a config and
derives, numerically from the model at the nominal pose, every sign the regulators need:
the mirror convention of each joint (the symmetry map T, eq. 12), which way each hip joint
moves the foot, which way each stance hip joint torques the pelvis, and the Jacobian of the
foot's pitch and roll with respect to the toe motors. Every derivation moves one motor with
the closed chains' passive joints following it (`linkage`): Digit's toe motors reach the
foot only through rods. Shared code reads only these arrays.
"""

from __future__ import annotations

import dataclasses
import os
from pathlib import Path
from typing import Callable, Sequence

import mujoco
import numpy as np

from mjx_cascade import gait
from mjx_cascade.config import ConfigError, PhysicsConfig
from mjx_cascade.robots import linkage, scene

@dataclasses.dataclass(frozen=True)
class RobotDefinition:
    name: str
    joints: tuple[str, ...]  # leg joint types in order, e.g. ("hip_roll", ..., "toe_pitch")
    motors: tuple[tuple[str, ...], tuple[str, ...]]  # actuator names (left, right) in `joints` order
    toe_joints: tuple[str, ...]  # joints driving the foot's pitch (and roll)
    learned: tuple[tuple[str, str], ...]  # (role, joint): role is "stance" or "swing"
    # free-coefficient ranges of each learned joint (left convention): one (low, high) for all of
    # its free coefficients, or one pair per free coefficient (alpha[2], ..., alpha[M])
    ranges: tuple[tuple[float, float] | tuple[tuple[float, float], ...], ...]
    kp: tuple[float, ...]  # joint PD gains (eq. 21) per leg joint, N m / rad
    kd: tuple[float, ...]
    pelvis: str
    feet: tuple[str, str]  # foot bodies (left, right)
    load_spec: Callable[[Path | None], mujoco.MjSpec]  # the robot's MJCF from a checked path, or its default
    nominal: Callable[[mujoco.MjModel], np.ndarray]  # standing qpos of the compiled model
    # whether the stance foot's roll is the ground's (Sec. IV-A's slope estimate): False for a
    # line foot, which lies on the ground at any roll
    foot_senses_roll: bool = True
    model_env: str | None = None  # environment variable naming the model file
    model_required: bool = False  # no default model: the user must supply one
    model_hint: str = ""  # where users get the model, for error messages
    # the most CPU devices training may split a CPU into; None: any (docs/faq.md says why not)
    max_cpu_devices: int | None = None


@dataclasses.dataclass(frozen=True, eq=False)
class Robot:
    """A definition compiled for one config: the MuJoCo model and derived index and sign arrays.

    Per-leg arrays are `[2, J]` with row 0 the left leg and row 1 the right leg.
    """

    definition: RobotDefinition
    model: mujoco.MjModel
    qpos_adr: np.ndarray  # [2, J] qpos address of each leg motor's joint
    dof_adr: np.ndarray  # [2, J]
    actuator: np.ndarray  # [2, J] actuator ids
    gear: np.ndarray  # [2, J]
    ctrl_low: np.ndarray  # [2, J]
    ctrl_high: np.ndarray  # [2, J]
    torque_limit: np.ndarray  # [2, J] N m
    mirror: np.ndarray  # [J] +-1: right-leg angle = mirror * left-leg angle in a mirrored pose
    learned_role: np.ndarray  # [N]
    learned_joint: np.ndarray  # [N]
    learned_low: np.ndarray  # [N, K] role coordinates, K = 1 (one range per joint) or M - 1
    learned_high: np.ndarray  # [N, K]
    kp: np.ndarray  # [J]
    kd: np.ndarray  # [J]
    nominal_qpos: np.ndarray  # [nq]
    nominal_role: np.ndarray  # [2, J] nominal leg angles in role coordinates
    pelvis_body: int
    foot_body: np.ndarray  # [2]
    foot_force_adr: np.ndarray  # [2] sensordata address of each foot's touch sensor
    hip_roll: int  # leg joint indices
    hip_pitch: int
    hip_yaw: int
    knee: int
    toe: np.ndarray  # [K] leg joint indices of the toe motors
    forward_sign: np.ndarray  # [2] d(foot x)/d(hip pitch), role coordinates
    lateral_sign: np.ndarray  # [2] d(foot y)/d(hip roll)
    yaw_sign: np.ndarray  # [2] d(pelvis yaw)/d(stance hip yaw), foot fixed
    torso_sign: np.ndarray  # [2, 2] stance hip (roll, pitch) torque per unit pelvis (x, y) torque
    toe_jac: np.ndarray  # [2, 2, K] d(foot pitch, roll)/d(toe motors), role coordinates, per leg
    toe_pinv: np.ndarray  # [2, K, 2] its pseudo-inverse
    knee_extension: np.ndarray  # [2] sign of d(hip-to-foot distance)/d(knee), role coordinates
    foot_flat: np.ndarray  # [2, 3, 3] foot orientations when standing flat, yaw removed

    @property
    def name(self) -> str:
        return self.definition.name

    @property
    def slope_sensed(self) -> np.ndarray:
        """[2] 1 for each terrain slope component (pitch, roll) the stance foot measures, else 0."""
        return np.array([1.0, float(self.definition.foot_senses_roll)], np.float32)

    @property
    def num_learned(self) -> int:
        return len(self.learned_role)

    @property
    def learned_names(self) -> list[str]:
        return [f"{role}_{joint}" for role, joint in self.definition.learned]


def requested_model(definition: RobotDefinition, path: str | None) -> str | None:
    """The model file asked for: `path`, else the robot's environment variable; None if neither."""
    return path or (os.environ.get(definition.model_env) if definition.model_env else None) or None


def model_path(definition: RobotDefinition, path: str | None) -> Path | None:
    """The model file to load (`requested_model`), checked to exist, to parse and to have the
    robot's motors; None means the robot's default model."""
    d = definition
    path = requested_model(d, path)
    if not path:
        if d.model_required:
            raise ConfigError(f"the {d.name} robot needs its model file: {d.model_hint}")
        return None
    p = Path(path)
    if not p.is_file():
        raise ConfigError(f"{d.name} model not found: {p}")
    try:
        spec = mujoco.MjSpec.from_file(str(p))
    except Exception as e:  # MuJoCo's parser raises a plain ValueError with a long message
        raise ConfigError(f"{p} is not a loadable MJCF: {str(e).splitlines()[0]}") from None
    names = {a.name for a in spec.actuators}
    missing = [m for side in d.motors for m in side if m not in names]
    if missing:
        raise ConfigError(f"{p} is not a {d.name} model (it has no actuator {missing[0]!r})")
    return p


def build(definition: RobotDefinition, physics: PhysicsConfig, model: str | None = None,
          terrain: dict | Sequence[dict] | None = None) -> Robot:
    """Compile the model for `physics` (and a scenario terrain, or several: `scene.compile_model`)
    and derive the controller's arrays."""
    spec = definition.load_spec(model_path(definition, model))
    model = scene.compile_model(spec, definition.feet, physics, terrain or {"type": "flat"}, definition.pelvis)
    return derive(definition, model)


def derive(definition: RobotDefinition, model: mujoco.MjModel) -> Robot:
    """The controller's index and sign arrays, derived from `model` at the definition's nominal pose."""
    d = definition
    joint_index = {name: i for i, name in enumerate(d.joints)}
    nominal = d.nominal(model)
    data = mujoco.MjData(model)
    data.qpos[:] = nominal
    data.qpos[:2] = 0.0
    data.qpos[3:7] = (1, 0, 0, 0)
    mujoco.mj_kinematics(model, data)
    motors = _motors(model, d)
    mirror = _mirror_signs(data, motors["jnt"])
    qpos_adr, dof_adr = model.jnt_qposadr[motors["jnt"]], model.jnt_dofadr[motors["jnt"]]
    side_sign = np.stack([np.ones_like(mirror), mirror])  # role value * side_sign = absolute
    leg_nominal = nominal[qpos_adr]  # absolute [2, J]
    hips = {j: joint_index[j] for j in ("hip_roll", "hip_pitch", "hip_yaw", "knee")}
    toe = np.array([joint_index[j] for j in d.toe_joints])
    pelvis, feet = model.body(d.pelvis).id, np.array([model.body(f).id for f in d.feet])
    fd = _foot_kinematics(model, data, feet, pelvis, qpos_adr, dof_adr, side_sign, hips["hip_roll"],
                          hips["hip_pitch"], hips["hip_yaw"], hips["knee"], toe)
    return Robot(
        definition=d, model=model, qpos_adr=qpos_adr, dof_adr=dof_adr, actuator=motors["act"], gear=motors["gear"],
        ctrl_low=motors["low"], ctrl_high=motors["high"], torque_limit=motors["limit"], mirror=mirror,
        **_learned(d, joint_index),
        kp=np.array(d.kp, dtype=np.float64), kd=np.array(d.kd, dtype=np.float64),
        nominal_qpos=nominal, nominal_role=np.stack([leg_nominal[0], leg_nominal[0]]),  # left convention, both roles
        pelvis_body=pelvis, foot_body=feet,
        foot_force_adr=np.array([model.sensor_adr[model.sensor(f"{d.feet[leg]}-grf").id] for leg in range(2)]),
        **hips, toe=toe, **fd,
    )


def _motors(model: mujoco.MjModel, d: RobotDefinition) -> dict:
    """Per leg motor `[2, J]`: actuator ids, joints, gears, control ranges and torque limits."""
    act = np.array([[model.actuator(n).id for n in side] for side in d.motors])
    gear, ctrl = model.actuator_gear[act, 0], model.actuator_ctrlrange[act]
    return {"act": act, "jnt": model.actuator_trnid[act, 0], "gear": gear, "low": ctrl[..., 0], "high": ctrl[..., 1],
            "limit": gear * np.maximum(np.abs(ctrl[..., 0]), np.abs(ctrl[..., 1]))}


def _learned(d: RobotDefinition, joint_index: dict) -> dict:
    """The learned joints' roles, leg joints and coefficient ranges (role coordinates)."""
    roles = {"stance": gait.STANCE, "swing": gait.SWING}
    ranges = _ranges(d.ranges)
    return {"learned_role": np.array([roles[r] for r, _ in d.learned]),
            "learned_joint": np.array([joint_index[j] for _, j in d.learned]),
            "learned_low": ranges[..., 0], "learned_high": ranges[..., 1]}


def _ranges(ranges) -> np.ndarray:
    """`[N, K, 2]`: (low, high) of each learned joint's free coefficients, pairs broadcast to K."""
    per = [np.atleast_2d(np.asarray(r, dtype=np.float64)) for r in ranges]
    k = max(len(p) for p in per)
    if any(len(p) not in (1, k) or p.shape[1] != 2 for p in per):
        raise ConfigError(f"each range must be one (low, high) pair or {k} of them")
    return np.stack([np.broadcast_to(p, (k, 2)) for p in per])


def _mirror_signs(data: mujoco.MjData, jnt: np.ndarray) -> np.ndarray:
    """+1 where mirroring a pose across the sagittal plane keeps a joint's angle, -1 where it negates it.

    A joint axis is a pseudo-vector: its mirror image across the x-z plane is -M a with
    M = diag(1, -1, 1). The right joint's angle equals the left's in the mirrored pose when
    its axis is that image, and the negative when it is the opposite.
    """
    axes = data.xaxis[jnt]  # [2, J, 3]
    image = -axes[0] * np.array([1.0, -1.0, 1.0])
    return np.sign(np.sum(image * axes[1], axis=-1))


def _foot_kinematics(model, data, feet, pelvis, qpos_adr, dof_adr, side_sign, hip_roll, hip_pitch, hip_yaw, knee_joint,
                     toe) -> dict:
    """Signs and Jacobians at the nominal pose, the closed chains' passive joints following each motor."""
    base = data.qpos.copy()
    flat = np.stack([data.xmat[f].reshape(3, 3) for f in feet])
    h = 1e-4

    def perturbed(leg, joint):
        data.qpos[:] = base
        qvel = _motor_velocity(model, data, dof_adr[leg, [joint]], side_sign[leg, [joint]])
        mujoco.mj_integratePos(model, data.qpos, qvel, h)  # a step in role coordinates
        mujoco.mj_kinematics(model, data)
        pos = data.xpos[feet[leg]].copy()
        rot = data.xmat[feet[leg]].reshape(3, 3) @ flat[leg].T
        return pos, rot

    data.qpos[:] = base
    mujoco.mj_kinematics(model, data)
    foot0 = data.xpos[feet].copy()

    forward, lateral, yaw, torso, jacs, pinv, knee = [], [], [], [], [], [], []
    for leg in range(2):
        pos, _ = perturbed(leg, hip_pitch)
        forward.append(np.sign(pos[0] - foot0[leg, 0]))
        pos, _ = perturbed(leg, hip_roll)
        lateral.append(np.sign(pos[1] - foot0[leg, 1]))
        _, rot = perturbed(leg, hip_yaw)
        yaw.append(-np.sign(rot[1, 0]))  # the foot turns one way, so a planted foot turns the pelvis the other
        torso.append(_torso_signs(model, data, base, qpos_adr[leg], side_sign[leg], hip_roll, hip_pitch))
        data.qpos[:] = base
        jac = _toe_jacobian(model, data, feet[leg], dof_adr[leg, toe], side_sign[leg, toe])
        jacs.append(jac)
        pinv.append(np.linalg.pinv(jac, rcond=1e-3))
        pos, _ = perturbed(leg, knee_joint)
        knee.append(np.sign(foot0[leg, 2] - pos[2]))  # extension lowers the foot below the hip
    data.qpos[:] = base
    mujoco.mj_kinematics(model, data)
    return dict(
        forward_sign=np.array(forward),
        lateral_sign=np.array(lateral),
        yaw_sign=np.array(yaw),
        torso_sign=np.array(torso),
        toe_jac=np.array(jacs),
        toe_pinv=np.array(pinv),
        knee_extension=np.array(knee),
        foot_flat=flat,
    )


def _motor_velocity(model, data, dofs, rates) -> np.ndarray:
    """qvel moving motor `dofs` at `rates`, the other motors still and the closed chains following."""
    qvel = np.zeros(model.nv)
    qvel[dofs] = rates
    return linkage.follow(model, data, qvel)


def _toe_jacobian(model, data, foot, dofs, signs) -> np.ndarray:
    """d(foot pitch, roll)/d(toe motors) [2, K] in role coordinates, at the pose in `data`.

    Toe motors may drive the foot through rods (Digit's toe A and B move both pitch and roll),
    so the passive joints follow each motor (`linkage.follow`) before `mj_jacBody` maps the
    motion to the foot's world angular velocity w. At zero yaw, `env.foot_angles` changes by
    (pitch, roll) = (w_y, w_x): for a small rotation e = I + [w]x, -e[2] . x = w_y, e[2] . y = w_x.
    """
    jacr = np.zeros((3, model.nv))
    columns = []
    for dof, sign in zip(dofs, signs):
        qvel = _motor_velocity(model, data, [dof], [sign])  # runs mj_fwdPosition, which mj_jacBody needs
        mujoco.mj_jacBody(model, data, None, jacr, foot)
        w = jacr @ qvel
        columns.append([w[1], w[0]])
    return np.array(columns).reshape(-1, 2).T


def _torso_signs(model, data, base, qpos_adr_leg, side_sign_leg, hip_roll, hip_pitch) -> np.ndarray:
    """Stance hip (roll, pitch) joint torque, role coordinates, per unit corrective pelvis torque (x, y).

    A joint torque tau about world axis a pushes the pelvis (its parent) with -tau a; to put
    T_x on the pelvis through the hip roll joint, tau = -T_x (a . x) for a unit a along x.
    """
    data.qpos[:] = base
    mujoco.mj_kinematics(model, data)
    signs = []
    for joint, axis in ((hip_roll, 0), (hip_pitch, 1)):
        jnt_id = int(np.nonzero(model.jnt_qposadr == qpos_adr_leg[joint])[0][0])
        a = data.xaxis[jnt_id]
        signs.append(-np.sign(a[axis]) * side_sign_leg[joint])
    return np.array(signs)
