"""Every reward term is non-increasing in its error (and bounded in band); eq. 27 terminates."""

import jax.numpy as jnp
import numpy as np
import pytest

from mjx_cascade import config, rewards

CFG = config.robot_config("cassie")
RW, TM = CFG.rewards, CFG.termination


def nonincreasing(values):
    v = np.asarray(values)
    return bool(np.all(np.diff(v) <= 1e-7))


ERRORS = np.linspace(0.0, 1.5, 301)


@pytest.mark.parametrize("band", [RW.e_vx, RW.e_vy])
def test_velocity_reward_is_nonincreasing_in_the_error_and_bounded(band):
    for sign in (1.0, -1.0):
        r = [float(rewards.velocity(jnp.float32(sign * e), band, RW)) for e in ERRORS]
        assert nonincreasing(r)
    assert float(rewards.velocity(jnp.float32(0.0), band, RW)) == pytest.approx(RW.velocity_cap)
    assert float(rewards.velocity(jnp.float32(band / 2), band, RW)) >= 1.0  # in band beats out of band
    assert float(rewards.velocity(jnp.float32(band + 0.5), band, RW)) < 0


def test_height_reward_peaks_at_the_target_and_falls_both_ways():
    zd = CFG.regulators.height
    above = [float(rewards.height(jnp.float32(zd + e), zd, RW)) for e in ERRORS * 0.3]
    below = [float(rewards.height(jnp.float32(zd - e), zd, RW)) for e in ERRORS * 0.3]
    assert nonincreasing(above) and nonincreasing(below)
    assert float(rewards.height(jnp.float32(zd), zd, RW)) == pytest.approx(1.0)
    assert float(rewards.height(jnp.float32(zd - 0.01), zd, RW)) < 1.0  # the printed max{., 1} would be 1


def test_torque_reward():
    assert nonincreasing([float(rewards.torque(jnp.full(10, e))) for e in ERRORS])
    assert float(rewards.torque(jnp.ones(10))) == pytest.approx(-1.0)


def test_com_reward_is_finite_at_zero_and_nonincreasing():
    r = [float(rewards.com(jnp.float32(d), RW)) for d in ERRORS * 0.5]
    assert nonincreasing(r) and np.isfinite(r[0]) and r[0] == pytest.approx(1.0)
    assert float(rewards.com(jnp.float32(RW.com_radius + 0.1), RW)) < 0


def test_orientation_and_angular_velocity_rewards():
    assert nonincreasing([float(rewards.orientation(jnp.array([e, 0.0, 0.0]))) for e in ERRORS])
    assert nonincreasing([float(rewards.orientation(jnp.array([0.0, 0.0, e]))) for e in ERRORS])
    assert nonincreasing([float(rewards.angular_velocity(jnp.array([0.0, e, 0.0]))) for e in ERRORS])


def test_feet_distance_reward_is_zero_in_range_and_falls_outside():
    mid = 0.5 * (RW.feet_min + RW.feet_max)
    assert float(rewards.feet_distance(jnp.float32(mid), RW)) == 0.0
    assert nonincreasing([float(rewards.feet_distance(jnp.float32(RW.feet_max + e), RW)) for e in ERRORS])
    assert nonincreasing([float(rewards.feet_distance(jnp.float32(RW.feet_min - e), RW)) for e in ERRORS * 0.1])


def test_stance_foot_reward():
    assert nonincreasing([float(rewards.stance_foot(jnp.array([e, 0, 0]), jnp.zeros(3))) for e in ERRORS])
    assert nonincreasing([float(rewards.stance_foot(jnp.zeros(3), jnp.array([0, e, 0]))) for e in ERRORS])


def _inputs(**kw):
    base = dict(v_error=jnp.zeros(2), height=jnp.float32(0.95), u_normalized=jnp.zeros(10),
                com_distance=jnp.float32(0.0), rpy_error=jnp.zeros(3), omega=jnp.zeros(3),
                feet_distance=jnp.float32(0.3), stance_v=jnp.zeros(3), stance_w=jnp.zeros(3))
    base.update(kw)
    return rewards.RewardInputs(**base)


def test_terms_order_and_weights():
    t = rewards.terms(_inputs(), RW, CFG.regulators.height)
    assert t.shape == (len(rewards.TERMS),)
    # Table 4's Cassie weights, except vy: 0.4 in configs/cassie.yaml (README, "How the policy was trained")
    np.testing.assert_allclose(rewards.weights(RW), [0.8, 0.4, 0.1, 0.01, 0.1, 0.5, 0.5, 5.0, 0.0])


@pytest.mark.parametrize("change, ends", [
    ({}, False),
    ({"rpy_error": jnp.array([0.6, 0.0, 0.0])}, True),
    ({"rpy_error": jnp.array([0.0, -0.6, 0.0])}, True),
    ({"rpy_error": jnp.array([0.0, 0.0, 1.1])}, True),  # yaw error bound widened to 1.0 (README)
    ({"omega": jnp.array([0.0, TM.max_rate + 0.5, 0.0])}, True),  # Cassie widens eq. 27's bounds (cassie.yaml)
    ({"omega": jnp.array([0.0, TM.max_rate - 0.5, 0.0])}, False),
    ({"height": jnp.float32(0.75)}, True),
    ({"height": jnp.float32(1.25)}, True),
    ({"feet_distance": jnp.float32(TM.feet[0] - 0.05)}, True),
    ({"feet_distance": jnp.float32(TM.feet[1] + 0.05)}, True),
])
def test_termination_eq_27(change, ends):
    assert bool(rewards.terminated(_inputs(**change), TM)) == ends


def test_diverged_physics_is_detected():
    ok = jnp.zeros(35), jnp.zeros(32)
    assert not bool(rewards.diverged(*ok, TM))
    assert bool(rewards.diverged(ok[0].at[3].set(jnp.nan), ok[1], TM))
    assert bool(rewards.diverged(ok[0], ok[1].at[0].set(jnp.inf), TM))
    assert bool(rewards.diverged(ok[0], ok[1].at[5].set(1e4), TM))
