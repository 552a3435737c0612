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


CASSIE = RobotDefinition(
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
    # Ranges of the free Bezier coefficients (left-leg convention, rad); their middles
    # make an untrained policy step in place with the swing knee bent.
    ranges=(
        (-0.3, 0.3),
        (-1.8, -0.8),
        (-0.2, 0.3),
        (-0.3, 0.3),
        (0.0, 1.1),
        (-2.2, -0.8),
    ),
    kp=(400.0, 200.0, 200.0, 500.0, 50.0),
    kd=(4.0, 4.0, 10.0, 20.0, 2.0),
    pelvis="cassie-pelvis",
    feet=("left-foot", "right-foot"),
    load_spec=load_spec,
    nominal=nominal,
    model_hint="MuJoCo Menagerie's agility_cassie (pip install mujoco-menagerie; offline: MENAGERIE_ROOT)",
)
