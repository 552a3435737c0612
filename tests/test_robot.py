"""The robot definitions, the physics scene and the balanced initial states."""

import mujoco
import numpy as np
import pytest

from mjx_cascade import robots
from mjx_cascade.config import ConfigError
from mjx_cascade.robots import scene
from mjx_cascade.rotations import quat_to_rpy
from conftest import DIGIT_MODEL


def test_cassie_model_is_menageries_with_feet_only_contacts(cassie):
    m = cassie.model
    assert (m.nq, m.nv, m.nu, m.neq) == (35, 32, 10, 4)
    assert m.opt.timestep == pytest.approx(0.0005)
    colliding = [i for i in range(m.ngeom) if m.geom_contype[i] or m.geom_conaffinity[i]]
    bodies = {m.body(m.geom_bodyid[i]).name for i in colliding}
    assert bodies == {"left-foot", "right-foot", "world"}
    assert m.nmesh == 0 and m.nsensor == 2  # visuals dropped, one touch sensor per foot


def test_cassie_derived_signs(cassie):
    np.testing.assert_array_equal(cassie.mirror, [-1, -1, 1, 1, 1])  # roll and yaw mirror, pitch does not
    np.testing.assert_array_equal(cassie.lateral_sign, [1, -1])  # the feet move outward with +roll
    assert np.all(cassie.forward_sign == 1) and np.all(cassie.knee_extension == 1)
    assert cassie.torque_limit[0].tolist() == pytest.approx([112.5, 112.5, 195.2, 195.2, 45.0])


def test_touch_sensor_reads_the_ground_reaction_force(cassie, cassie_pool):
    m = cassie.model
    d = mujoco.MjData(m)
    d.qpos[:] = cassie_pool[0][0]
    mujoco.mj_forward(m, d)
    force = d.sensordata[cassie.foot_force_adr]
    weight = m.body_subtreemass[cassie.pelvis_body] * 9.81
    assert np.all(force > 0.2 * weight) and abs(force.sum() - weight) < 0.35 * weight


def test_pool_states_stand_balanced_and_differ(cassie, cassie_pool, cassie_cfg):
    qpos, qvel = cassie_pool
    assert qpos.shape == (cassie_cfg.episode.pool_size, cassie.model.nq)
    assert np.all(np.abs(qvel) < 0.5)
    assert np.all((qpos[:, 2] > 0.85) & (qpos[:, 2] < 1.05))
    assert np.ptp(qpos[:, 2]) > 1e-3  # not one hand-set pose
    rpy = quat_to_rpy(qpos[:, 3:7])
    assert np.all(np.abs(rpy[:, :2]) < 0.1)
    # and it stands on both feet
    m = cassie.model
    d = mujoco.MjData(m)
    d.qpos[:], d.qvel[:] = qpos[0], qvel[0]
    mujoco.mj_forward(m, d)
    assert np.all(d.sensordata[cassie.foot_force_adr] > 0)


@pytest.mark.parametrize("terrain", [{"type": "slope", "degrees": 8.0}, {"type": "rough", "amplitude": 0.02, "seed": 3}])
def test_terrains_are_level_at_the_start_and_match_the_height_field(terrain, cassie_cfg):
    robot = robots.build(robots.get("cassie"), cassie_cfg, terrain=terrain)
    m = robot.model
    assert m.nhfield == 1
    assert abs(scene.ground_height(terrain, 0.0, 0.0)) < 1e-9
    d = mujoco.MjData(m)
    mujoco.mj_forward(m, d)
    for x, y in ((3.0, 0.0), (5.0, 1.0), (8.0, -0.5)):  # a ray straight down hits the field at its height
        hit = mujoco.mj_ray(m, d, np.array([x, y, 5.0]), np.array([0, 0, -1.0]), None, 1, -1, np.zeros(1, np.int32))
        assert abs((5.0 - hit) - scene.ground_height(terrain, x, y)) < 5e-3
    if terrain["type"] == "slope":
        assert scene.ground_height(terrain, 3.0, 0.0) == pytest.approx(2.0 * np.tan(np.radians(8.0)))


def test_digit_definition_and_model_checks():
    digit = robots.get("digit")
    assert len(digit.learned) == 7
    assert robots.model_path(digit, str(DIGIT_MODEL)) == DIGIT_MODEL
    with pytest.raises(ConfigError, match="not found"):
        robots.model_path(digit, "/no/such/digit.xml")
    with pytest.raises(ConfigError, match="not a digit model"):
        robots.model_path(digit, str(DIGIT_MODEL.parents[2] / "menagerie" / "agility_cassie" / "cassie.xml"))
