"""Agility Robotics' Digit v3 (Sec. V): Cassie's legs with toe pitch and roll, plus arms.

Agility's MJCF (`digit-v3.xml`) cannot be redistributed: its path comes from `--model PATH`
or `DIGIT_MODEL_PATH`. Per leg: hip roll, yaw, pitch, knee and two toe motors (A, B) that
drive the toe pitch and roll through rods; per arm: shoulder roll, pitch, yaw and elbow.
The policy learns Cassie's six leg joints plus the swing-side shoulder pitch (the arm as a
pendulum, Sec. III-C): N = 7, 28 actions, 4316 parameters (Table 1).
"""

from __future__ import annotations

from pathlib import Path

import mujoco
import numpy as np

from mjx_cascade.robots import linkage
from mjx_cascade.robots.base import RobotDefinition

LEG = ("hip-roll", "hip-yaw", "hip-pitch", "knee", "toe-A", "toe-B")
ARM = ("shoulder-roll", "shoulder-pitch", "shoulder-yaw", "elbow")
SIDES = ("left", "right")
PELVIS = "base"
HINT = "Agility Robotics' digit-v3.xml (see the README): pass --model PATH or set DIGIT_MODEL_PATH"

# Standing motor angles of the left side, rad. Agility's model mirrors every right joint
# (right angle = -left angle). Knee 0.37 bends the leg to 86 % of its reach at the knee
# limit (1.02; larger angles extend it, and the achilles rod turns the tarsus by about
# minus the knee angle); the hips roll the feet out to about 0.33 m apart (the hip-roll
# housings are themselves tilted 21.5 deg); elbows slightly bent with the forearms forward,
# as Digit stands. The hip pitch is only a first guess: `nominal` solves it.
STAND = {"hip-roll": 0.30, "hip-yaw": 0.0, "hip-pitch": 0.33, "knee": 0.37,
         "shoulder-roll": -0.15, "shoulder-pitch": 1.1, "shoulder-yaw": 0.0, "elbow": -0.145}
SOLVED = ("hip-pitch", "toe-A", "toe-B")  # motors `nominal` solves for, per leg
FOOT = "{}-toe-roll"  # the body carrying the foot's collision box
SOLE = "{}-foot"  # a frame on the sole, z along its normal (the model's foot body, without geoms)


def load_spec(path: Path | None) -> mujoco.MjSpec:
    return mujoco.MjSpec.from_file(str(path))


def nominal(model: mujoco.MjModel) -> np.ndarray:
    """Standing qpos: pelvis upright, knees bent, soles level and flat on z = 0 under the CoM.

    The model has no keyframe, so the pose is derived. The motors are set to `STAND`, the
    springs (shin, heel) rest at zero, and Gauss-Newton (`linkage.close`) moves the passive
    joints (achilles and toe rods, tarsus, toe pitch and roll) together with each leg's hip
    pitch and toe A/B motors until the closed chains close, each sole's normal is vertical,
    and each sole frame lies under the centre of mass in x (static balance). The pelvis is
    then lowered until the lowest corner of the foot boxes is at z = 0.
    """
    qpos = model.qpos0.copy()  # pelvis upright at the origin, every loop closed at zero
    for side, sign in zip(SIDES, (1.0, -1.0)):
        for joint, angle in STAND.items():
            qpos[model.joint(f"{side}-{joint}").qposadr[0]] = sign * angle
    solved = [model.joint(f"{side}-{joint}").dofadr[0] for side in SIDES for joint in SOLVED]
    qpos = linkage.close(model, qpos, np.concatenate([linkage.passive_dofs(model), solved]), _soles_level_under_com)
    qpos[2] -= _lowest_foot_point(model, qpos)
    return qpos


def _soles_level_under_com(model: mujoco.MjModel, data: mujoco.MjData) -> tuple[np.ndarray, np.ndarray]:
    """Residuals (sole normal's world x and y, sole x - CoM x) per foot, with their qvel Jacobians."""
    com_jac = np.zeros((3, model.nv))
    pelvis = model.body(PELVIS).id  # its subtree is the whole robot
    mujoco.mj_jacSubtreeCom(model, data, com_jac, pelvis)
    com = data.subtree_com[pelvis]
    res, jac = [], []
    for side in SIDES:
        body = model.body(SOLE.format(side)).id
        jacp, jacr = np.zeros((3, model.nv)), np.zeros((3, model.nv))
        mujoco.mj_jacBody(model, data, jacp, jacr, body)
        z = data.xmat[body].reshape(3, 3)[:, 2]
        res += [z[0], z[1], data.xpos[body, 0] - com[0]]
        jac += [*(np.cross(jacr.T, z).T[:2]), jacp[0] - com_jac[0]]  # dz/dt = w x z
    return np.array(res), np.array(jac)


def _lowest_foot_point(model: mujoco.MjModel, qpos: np.ndarray) -> float:
    """World z of the lowest corner of the feet's collision boxes."""
    data = mujoco.MjData(model)
    data.qpos[:] = qpos
    mujoco.mj_kinematics(model, data)
    corners = np.array(np.meshgrid([-1, 1], [-1, 1], [-1, 1])).reshape(3, -1)
    lowest = np.inf
    for side in SIDES:
        body = model.body(FOOT.format(side)).id
        for g in np.nonzero((model.geom_bodyid == body) & (model.geom_type == mujoco.mjtGeom.mjGEOM_BOX))[0]:
            points = data.geom_xpos[g][:, None] + data.geom_xmat[g].reshape(3, 3) @ (corners * model.geom_size[g][:, None])
            lowest = min(lowest, points[2].min())
    return float(lowest)


DEFINITION = RobotDefinition(
    name="digit",
    joints=("hip_roll", "hip_yaw", "hip_pitch", "knee", "toe_a", "toe_b",
            "shoulder_roll", "shoulder_pitch", "shoulder_yaw", "elbow"),
    motors=tuple(tuple(f"{side}-{j}" for j in LEG + ARM) for side in SIDES),
    toe_joints=("toe_a", "toe_b"),
    learned=(
        ("stance", "hip_yaw"),
        ("stance", "knee"),
        ("swing", "hip_roll"),
        ("swing", "hip_yaw"),
        ("swing", "hip_pitch"),
        ("swing", "knee"),
        ("swing", "shoulder_pitch"),
    ),
    # Ranges of the free Bezier coefficients (left-leg convention, rad). Their middles, what
    # an untrained network outputs, step in place under the regulators (about 3.6 steps a
    # second, pelvis between 0.91 and 0.98 m). On Digit's left leg a larger hip roll moves
    # the foot inward, a larger hip pitch moves it back, a larger knee angle extends the leg.
    # About the nominal pose (hip roll 0.30, hip pitch 0.32, knee 0.37, shoulder pitch 1.1):
    # - the stance knee's middle is the nominal angle: 0.07 more bent, the stance leg sagged
    #   under Digit's 48 kg (the pelvis sank from 0.96 to 0.80 m in 0.8 s);
    # - the swing hip roll's middle is 0.12 inward: at 0.05 outward the feet spread further
    #   each step (0.9 m apart after 0.5 s);
    # - the swing knee bends 0.65 in the first half of the step and extends past nominal in
    #   the second, one range per coefficient: bent to the end (one range), the swing foot
    #   stayed in the air until the time-out.
    # The middles came from batched searches of the untrained policy stepping in place (32
    # variants at a time, 3 to 6 s each); the ranges bound what can be learned.
    ranges=(
        (-0.3, 0.3),  # stance hip yaw
        (-0.13, 0.87),  # stance knee
        (0.17, 0.67),  # swing hip roll
        (-0.3, 0.3),  # swing hip yaw
        (-0.37, 0.73),  # swing hip pitch: middle 0.14 forward
        ((-0.78, 0.22), (-0.78, 0.22), (0.0, 1.0), (0.4, 1.0)),  # swing knee: bend, then extend
        (0.5, 1.7),  # swing shoulder pitch: nominal +- 0.6, the arm as a pendulum
    ),
    # Knee kp 1000 (not 400): at 400 the knees sag 0.18 rad under Digit's weight in double
    # support, the pelvis sinks 7 cm below the nominal pose and the standing controller's
    # states are still moving after 1 s (joint speeds up to 0.3 rad/s).
    kp=(400.0, 200.0, 300.0, 1000.0, 50.0, 50.0, 100.0, 100.0, 100.0, 100.0),
    kd=(4.0, 4.0, 10.0, 20.0, 2.0, 2.0, 5.0, 5.0, 5.0, 5.0),
    pelvis=PELVIS,
    feet=tuple(FOOT.format(side) for side in SIDES),
    load_spec=load_spec,
    nominal=nominal,
    model_env="DIGIT_MODEL_PATH",
    model_required=True,
    model_hint=HINT,
    # split into two CPU devices, the first training call hung in 2 of 2 tries inside MJX's batched
    # LAPACK Cholesky, every thread asleep (docs/faq.md)
    max_cpu_devices=1,
)
