import jax
import jax.numpy as jnp
import mujoco
import numpy as np

from mjx_cascade import bezier, gait


def test_role_and_absolute_coordinates_round_trip():
    mirror = jnp.array([-1.0, -1.0, 1.0, 1.0, 1.0])
    role = jax.random.normal(jax.random.PRNGKey(1), (2, 5))
    for stance in (gait.LEFT, gait.RIGHT):
        absolute = gait.role_to_absolute(role, jnp.int32(stance), mirror)
        np.testing.assert_allclose(gait.absolute_to_role(absolute, jnp.int32(stance), mirror), role, atol=1e-6)


def test_stance_leg_row_goes_to_the_stance_side():
    mirror = jnp.array([-1.0, 1.0])
    role = jnp.array([[1.0, 2.0], [3.0, 4.0]])  # stance row, swing row
    right = gait.role_to_absolute(role, jnp.int32(gait.RIGHT), mirror)
    np.testing.assert_allclose(right, [[3.0, 4.0], [-1.0, 2.0]])  # left is swing; right is stance, mirrored
    left = gait.role_to_absolute(role, jnp.int32(gait.LEFT), mirror)
    np.testing.assert_allclose(left, [[1.0, 2.0], [-3.0, 4.0]])


def test_symmetry_matrix_is_an_involution_that_maps_right_to_left_stance(cassie):
    T = gait.symmetry_matrix(cassie.learned_role, cassie.learned_joint, cassie.mirror)
    np.testing.assert_allclose(T @ T, np.eye(len(T)))
    # T maps the absolute angles a set of role coefficients produces in right stance to those of left stance
    y = np.random.default_rng(0).normal(size=cassie.num_learned)
    role = np.zeros((2, len(cassie.mirror)))
    role[cassie.learned_role, cassie.learned_joint] = y
    legs = {s: np.asarray(gait.role_to_absolute(jnp.asarray(role), jnp.int32(s), cassie.mirror)) for s in (0, 1)}

    def learned_absolute(stance):  # stance leg for role 0, the other leg for role 1
        leg = np.where(cassie.learned_role == gait.STANCE, stance, 1 - stance)
        return legs[stance][leg, cassie.learned_joint]

    np.testing.assert_allclose(T @ learned_absolute(gait.RIGHT), learned_absolute(gait.LEFT), atol=1e-12)


def test_mirrored_role_pose_gives_mirrored_feet(cassie):
    """The derived mirror signs are right: the same role pose in either stance is a mirror image."""
    m, r = cassie.model, cassie
    rng = np.random.default_rng(3)
    role = r.nominal_role + rng.uniform(-0.15, 0.15, size=r.nominal_role.shape)
    feet = {}
    for stance in (gait.LEFT, gait.RIGHT):
        d = mujoco.MjData(m)
        d.qpos[:] = r.nominal_qpos
        d.qpos[r.qpos_adr] = np.asarray(gait.role_to_absolute(jnp.asarray(role), jnp.int32(stance), r.mirror))
        mujoco.mj_kinematics(m, d)
        feet[stance] = d.xpos[r.foot_body] - d.xpos[r.pelvis_body]
    # left-stance stance foot (left) mirrors right-stance stance foot (right), and so on
    np.testing.assert_allclose(feet[gait.LEFT][0] * [1, -1, 1], feet[gait.RIGHT][1], atol=2e-3)
    np.testing.assert_allclose(feet[gait.LEFT][1] * [1, -1, 1], feet[gait.RIGHT][0], atol=2e-3)


def test_coefficients_impact_invariance_and_ranges():
    q0 = jnp.array([0.1, -1.2, 0.3])
    low, high = jnp.array([-0.5, -2.0, 0.0]), jnp.array([0.5, -0.5, 1.0])
    action = jax.random.uniform(jax.random.PRNGKey(0), (3 * 4,))
    alpha = gait.coefficients(action, q0, low, high)
    assert alpha.shape == (3, 6)
    np.testing.assert_allclose(bezier.value(alpha, 0.0), q0, atol=1e-6)  # starts where the joint is
    np.testing.assert_allclose(bezier.derivative(alpha, 0.0), 0.0, atol=1e-5)  # with zero velocity
    free = alpha[:, 2:]
    assert np.all(free >= low[:, None] - 1e-6) and np.all(free <= high[:, None] + 1e-6)


def test_coefficients_take_a_range_per_coefficient():
    q0 = jnp.array([0.1, -1.2])
    low = jnp.array([[0.0, 0.0, 0.0, 0.0], [-2.4, -2.4, -1.8, -1.7]])
    high = jnp.array([[1.0, 1.0, 1.0, 1.0], [-1.4, -1.4, -0.8, -0.7]])
    alpha = gait.coefficients(jnp.full(8, 0.5), q0, low, high)
    np.testing.assert_allclose(alpha[:, 2:], (low + high) / 2, atol=1e-6)  # middles, coefficient by coefficient


def test_step_ends_on_touchdown_after_min_phase_or_on_time_out():
    def ended(tau, force, lifted=True):
        return bool(gait.step_ended(jnp.float32(tau), jnp.float32(force), jnp.bool_(lifted), 0.5, 1.3, 50.0))

    assert not ended(0.3, 500.0)  # too early: a touchdown right after lift-off is ignored
    assert ended(0.6, 80.0)
    assert not ended(0.9, 10.0)  # still in the air
    assert not ended(0.9, 300.0, lifted=False)  # the foot never left the ground: no touchdown
    assert ended(1.3, 0.0) and ended(1.3, 300.0, lifted=False)  # time-out


def test_a_right_stance_step_is_the_mirror_image_of_a_left_stance_step(cassie, cassie_cfg, cassie_pool, cassie_network):
    """The policy plans a right-stance step from the mirrored state (lateral velocities and heading
    negated, legs swapped) exactly as it plans the left-stance step: eq. 12 applied to the state as
    well as the coefficients. The same state in the other stance gives another step."""
    from mjx_cascade.env import Env

    r = cassie
    rng = np.random.default_rng(5)
    q = jnp.asarray(r.nominal_qpos[r.qpos_adr] + rng.uniform(-0.1, 0.1, size=r.qpos_adr.shape), jnp.float32)
    q_mirror = gait.role_to_absolute(gait.absolute_to_role(q, jnp.int32(gait.LEFT), r.mirror), jnp.int32(gait.RIGHT), r.mirror)
    cmd, v_avg = jnp.array([0.4, 0.25, 0.1]), jnp.array([0.3, 0.05])
    mirrored = jnp.array([1.0, -1.0, -1.0])

    ctl = Env(r, cassie_cfg, cassie_pool, cassie_network.apply).controller
    p0 = cassie_network.init_params
    params = p0 + 0.3 * jnp.asarray(rng.normal(size=p0.shape), jnp.float32)
    left = np.asarray(ctl.plan(params, q, jnp.int32(gait.LEFT), cmd, v_avg))
    right = np.asarray(ctl.plan(params, q_mirror, jnp.int32(gait.RIGHT), cmd * mirrored, v_avg * mirrored[:2]))
    np.testing.assert_allclose(right, left, atol=1e-6)
    # the unmirrored command and velocity in right stance: the policy sees other features
    unmirrored = np.asarray(ctl.plan(params, q_mirror, jnp.int32(gait.RIGHT), cmd, v_avg))
    np.testing.assert_allclose(unmirrored[:, :2], left[:, :2], atol=1e-6)  # impact invariance: the same start
    assert np.abs(unmirrored[:, 2:] - left[:, 2:]).max() > 1e-3
