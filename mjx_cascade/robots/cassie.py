"""Agility Robotics' Cassie (Sec. V): 10 motors, five per leg, no arms.

The model is MuJoCo Menagerie's `agility_cassie`, resolved by `mujoco-menagerie` (which
downloads it once, or reads it from `MENAGERIE_ROOT`), or any compatible MJCF given by path.
"""

from __future__ import annotations

from pathlib import Path

import mujoco
import numpy as np

from mjx_cascade.robots.base import RobotDefinition

LEG = ("hip-roll", "hip-yaw", "hip-pitch", "knee", "foot")


def load_spec(path: Path | None) -> mujoco.MjSpec:
    if path:
        return mujoco.MjSpec.from_file(str(path))
    import mujoco_menagerie

    robot = mujoco_menagerie.get("agility_cassie")
    root = robot.path(progress=mujoco_menagerie.print_progress)
    return mujoco.MjSpec.from_file(str(root / robot.entry("cassie").file))


def nominal(model: mujoco.MjModel) -> np.ndarray:
    """Menagerie's `home` keyframe: standing, feet flat."""
    return model.key("home").qpos.copy()


DEFINITION = RobotDefinition(
    name="cassie",
    joints=("hip_roll", "hip_yaw", "hip_pitch", "knee", "toe_pitch"),
    motors=(tuple(f"left-{j}" for j in LEG), tuple(f"right-{j}" for j in LEG)),
    toe_joints=("toe_pitch",),
    # Sec. III-C: the torso regulator owns the stance hip roll and pitch, the foot
    # orientation regulators own both toes; the policy learns the other six.
    learned=(
        ("stance", "hip_yaw"),
        ("stance", "knee"),
        ("swing", "hip_roll"),
        ("swing", "hip_yaw"),
        ("swing", "hip_pitch"),
        ("swing", "knee"),
    ),
    # Ranges of the free Bezier coefficients (left-leg convention, rad). Their middles, what
    # an untrained network outputs, step in place under the regulators: the swing knee bends
    # in the first half of the step and extends in the second (so its range is given per
    # coefficient), the swing hip pitch holds the foot a little forward. With one range per
    # joint the middles held the swing knee at a constant angle, which scuffed the foot and
    # fell within 0.7 s. The ranges bound what can be learned; nothing rewards the middles.
    ranges=(
        (-0.3, 0.3),  # stance hip yaw
        (-1.5, -0.5),  # stance knee
        (-0.25, 0.25),  # swing hip roll
        (-0.3, 0.3),  # swing hip yaw
        (0.0, 1.1),  # swing hip pitch
        ((-2.4, -1.4), (-2.4, -1.4), (-1.8, -0.8), (-1.7, -0.7)),  # swing knee: bend, then extend
    ),
    kp=(400.0, 200.0, 200.0, 500.0, 50.0),
    kd=(4.0, 4.0, 10.0, 20.0, 2.0),
    pelvis="cassie-pelvis",
    feet=("left-foot", "right-foot"),
    foot_senses_roll=False,  # the foot collides through one capsule along its length: a line foot
    load_spec=load_spec,
    nominal=nominal,
    model_hint="MuJoCo Menagerie's agility_cassie (pip install mujoco-menagerie; offline: MENAGERIE_ROOT)",
)
