"""The robot definitions, the physics scene and the balanced initial states."""

import copy
import time

import mujoco
import numpy as np
import pytest

from mjx_cascade import config, robots, standing
from mjx_cascade.config import ConfigError
from mjx_cascade.robots import digit as digit_lib
from mjx_cascade.robots import base, linkage, scene
from mjx_cascade.rotations import quat_to_rpy
from conftest import SHARED


def test_cassie_model_is_menageries_with_feet_only_contacts(cassie, cassie_cfg):
    m = cassie.model
    assert (m.nq, m.nv, m.nu, m.neq) == (35, 32, 10, 4)
    assert m.opt.timestep == pytest.approx(cassie_cfg.physics.dt)
    colliding = [i for i in range(m.ngeom) if m.geom_contype[i] or m.geom_conaffinity[i]]
    bodies = {m.body(m.geom_bodyid[i]).name for i in colliding}
    assert bodies == {"left-foot", "right-foot", "world"}
    assert m.nmesh == 0 and m.nsensor == 2  # visuals dropped, one touch sensor per foot


def test_cassie_derived_signs(cassie):
    np.testing.assert_array_equal(cassie.mirror, [-1, -1, 1, 1, 1])  # roll and yaw mirror, pitch does not
    np.testing.assert_array_equal(cassie.lateral_sign, [1, -1])  # the feet move outward with +roll
    assert np.all(cassie.forward_sign == 1) and np.all(cassie.knee_extension == 1)
    assert cassie.torque_limit[0].tolist() == pytest.approx([112.5, 112.5, 195.2, 195.2, 45.0])
    # the foot motor turns the foot directly, toe down when it turns negative (plantar rod following)
    np.testing.assert_allclose(cassie.toe_jac[..., 0], [[-1.0, 0.0], [-1.0, 0.0]], atol=1e-3)


def test_only_a_foot_with_width_reads_the_ground_roll(cassie, digit):
    """Cassie's foot touches the ground through one capsule along its length, so it lies flat at
    any ground roll and the slope estimate takes only its pitch; Digit's takes both."""
    m = cassie.model
    for foot in cassie.foot_body:
        geoms = [i for i in range(m.ngeom) if m.geom_bodyid[i] == foot and m.geom_contype[i]]
        assert [m.geom_type[i] for i in geoms] == [mujoco.mjtGeom.mjGEOM_CAPSULE]
    np.testing.assert_array_equal(cassie.slope_sensed, [1.0, 0.0])
    np.testing.assert_array_equal(digit.slope_sensed, [1.0, 1.0])


def test_ranges_are_per_joint_or_per_coefficient(cassie):
    assert cassie.learned_low.shape == (6, 4)  # the swing knee's range is given per coefficient
    np.testing.assert_allclose(cassie.learned_low[0], -0.3)  # a single pair applies to every coefficient
    assert np.all(cassie.learned_low < cassie.learned_high)
    with pytest.raises(ConfigError, match="pair"):
        base._ranges(((0.0, 1.0), ((0.0, 1.0), (0.0, 1.0))) + (((0.0, 1.0),) * 3,))


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
    robot = robots.build(robots.get("cassie"), cassie_cfg.physics, terrain=terrain)
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


def test_digit_definition_and_model_checks(digit_model):
    digit = robots.get("digit")
    assert len(digit.learned) == 7
    assert robots.model_path(digit, str(digit_model)) == digit_model
    with pytest.raises(ConfigError, match="not found"):
        robots.model_path(digit, "/no/such/digit.xml")
    with pytest.raises(ConfigError, match="not a digit model"):
        robots.model_path(digit, str(SHARED / "menagerie" / "agility_cassie" / "cassie.xml"))


@pytest.fixture(scope="module")
def digit_cfg():
    return config.robot_config("digit").override(**{"episode.pool_size": 4})


@pytest.fixture(scope="module")
def digit(digit_cfg, digit_model):
    return robots.build(robots.get("digit"), digit_cfg.physics, str(digit_model))


def test_digit_nominal_stands_flat_with_closed_chains(digit):
    m = digit.model
    start = time.perf_counter()
    qpos = digit.definition.nominal(m)
    assert time.perf_counter() - start < 1.0
    np.testing.assert_array_equal(qpos, digit.nominal_qpos)  # deterministic
    d = mujoco.MjData(m)
    d.qpos[:] = qpos
    mujoco.mj_fwdPosition(m, d)
    residual, _ = linkage.equality(m, d)
    assert len(residual) == 18 and np.abs(residual).max() < 1e-8  # six connect constraints closed
    for side in ("left", "right"):
        sole = m.body(f"{side}-foot").id
        np.testing.assert_allclose(d.xmat[sole].reshape(3, 3)[:, 2], [0, 0, 1], atol=1e-6)  # flat
        assert d.xpos[sole, 0] == pytest.approx(d.subtree_com[1, 0], abs=1e-6)  # under the CoM
        for spring in ("shin", "heel-spring"):
            assert qpos[m.joint(f"{side}-{spring}").qposadr[0]] == 0.0  # unloaded springs at rest
    assert digit_lib._lowest_foot_point(m, qpos) == pytest.approx(0.0, abs=1e-9)
    assert 0.95 < qpos[2] < 1.1 and 0.2 < digit.nominal_role[0, digit.knee] < 0.6  # knees bent
    np.testing.assert_array_equal(digit.mirror, -1)  # Agility mirrors every right joint
    np.testing.assert_allclose(qpos[digit.qpos_adr[1]], -qpos[digit.qpos_adr[0]])
    feet = d.xpos[digit.foot_body]
    assert 0.2 < feet[0, 1] - feet[1, 1] < 0.4  # inside the feet-distance band of eq. 27


def _toe_response(robot, leg: int, dq_role: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(measured toe motor change, foot (pitch, roll) change), role coordinates, when joint PD moves
    the toe motors of `leg` by `dq_role` with MuJoCo's constraint solver closing the rods: the
    robot floats without gravity or contacts, and the foot is measured relative to the pelvis."""
    m = copy.deepcopy(robot.model)
    m.opt.gravity[:] = 0.0
    m.opt.disableflags |= mujoco.mjtDisableBit.mjDSBL_CONTACT
    d = mujoco.MjData(m)
    d.qpos[:] = robot.nominal_qpos
    side = np.stack([np.ones_like(robot.mirror), robot.mirror])
    target = robot.nominal_role * side
    target[leg, robot.toe] += dq_role * side[leg, robot.toe]

    def foot():
        return d.xmat[robot.pelvis_body].reshape(3, 3).T @ d.xmat[robot.foot_body[leg]].reshape(3, 3)

    mujoco.mj_forward(m, d)
    rot0, q0 = foot(), d.qpos[robot.qpos_adr[leg, robot.toe]].copy()
    for _ in range(600):  # 0.3 s
        u = 500.0 * (target - d.qpos[robot.qpos_adr]) - 10.0 * d.qvel[robot.dof_adr]
        d.ctrl[robot.actuator] = np.clip(u / robot.gear, robot.ctrl_low, robot.ctrl_high)
        mujoco.mj_step(m, d)
    e = foot() @ rot0.T
    angles = np.array([np.arcsin(-e[2, 0]), np.arcsin(e[2, 1])])  # as env.foot_angles at zero yaw
    dq = (d.qpos[robot.qpos_adr[leg, robot.toe]] - q0) * side[leg, robot.toe]
    return dq, angles


@pytest.mark.parametrize("leg", [0, 1])
def test_digit_toe_map_matches_the_simulated_linkage(digit, leg):
    for dq_cmd in ([0.05, 0.0], [0.0, 0.05], [0.04, -0.03]):
        dq, angles = _toe_response(digit, leg, np.array(dq_cmd))
        predicted = digit.toe_jac[leg] @ dq
        assert np.linalg.norm(angles - predicted) < 0.2 * np.linalg.norm(predicted), (dq_cmd, angles, predicted)


@pytest.mark.parametrize("leg", [0, 1])
def test_digit_toe_pinv_gives_pitch_or_roll_alone(digit, leg):
    pitch = _toe_response(digit, leg, digit.toe_pinv[leg] @ np.array([0.05, 0.0]))[1]
    roll = _toe_response(digit, leg, digit.toe_pinv[leg] @ np.array([0.0, 0.05]))[1]
    assert pitch[0] == pytest.approx(0.05, rel=0.2) and abs(pitch[1]) < 0.2 * pitch[0]
    assert roll[1] == pytest.approx(0.05, rel=0.2) and abs(roll[0]) < 0.2 * roll[1]


def test_digit_pool_stands_balanced(digit, digit_cfg):
    qpos, qvel = standing.balanced_pool(digit, digit_cfg)
    assert qpos.shape == (4, digit.model.nq) and np.all(np.abs(qvel) < 0.5)
    assert np.all(np.abs(quat_to_rpy(qpos[:, 3:7])[:, :2]) < 0.1)
