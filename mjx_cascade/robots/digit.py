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

from mjx_cascade.robots.base import RobotDefinition

LEG = ("hip-roll", "hip-yaw", "hip-pitch", "knee", "toe-A", "toe-B")
ARM = ("shoulder-roll", "shoulder-pitch", "shoulder-yaw", "elbow")
HINT = "Agility Robotics' digit-v3.xml (see the README): pass --model PATH or set DIGIT_MODEL_PATH"


def load_spec(path: Path | None) -> mujoco.MjSpec:
    return mujoco.MjSpec.from_file(str(path))


def nominal(model: mujoco.MjModel) -> np.ndarray:
    raise NotImplementedError("Digit's standing pose and toe map are derived in the Digit robot issue")


DIGIT = RobotDefinition(
    name="digit",
    joints=("hip_roll", "hip_yaw", "hip_pitch", "knee", "toe_a", "toe_b",
            "shoulder_roll", "shoulder_pitch", "shoulder_yaw", "elbow"),
    motors=tuple(tuple(f"{side}-{j}" for j in LEG + ARM) for side in ("left", "right")),
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
    ranges=((-0.3, 0.3), (-0.6, 0.6), (-0.2, 0.3), (-0.3, 0.3), (-0.3, 0.8), (-0.8, 0.6), (-0.6, 0.6)),
    kp=(400.0, 200.0, 300.0, 400.0, 50.0, 50.0, 100.0, 100.0, 100.0, 100.0),
    kd=(4.0, 4.0, 10.0, 10.0, 2.0, 2.0, 5.0, 5.0, 5.0, 5.0),
    pelvis="base",
    feet=("left-foot", "right-foot"),
    load_spec=load_spec,
    nominal=nominal,
    model_env="DIGIT_MODEL_PATH",
    model_required=True,
    model_hint=HINT,
)
