"""Regulator signs and limits, as pure functions (the whole controller on hand-built states is in
test_controller.py)."""

import dataclasses

import jax.numpy as jnp
import numpy as np
import pytest

from mjx_cascade import config, regulators

REG = config.robot_config("cassie").regulators


def test_swing_placement_follows_excess_velocity_and_ramps_in():
    zero = jnp.zeros(2)
    fast = regulators.swing_placement(jnp.array([0.5, 0.0]), jnp.array([0.2, 0.0]), zero, zero, 1.0, REG)
    assert fast[0] > 0 and fast[1] == 0
    left = regulators.swing_placement(jnp.array([0.0, 0.3]), zero, zero, zero, 1.0, REG)
    assert left[1] > 0
    np.testing.assert_allclose(regulators.swing_placement(jnp.array([0.5, 0.3]), zero, zero, zero, 0.0, REG), 0.0)
    # the drift terms add directly
    drift = regulators.swing_placement(zero, zero, zero, jnp.array([0.05, -0.02]), 1.0, REG)
    np.testing.assert_allclose(drift, [0.05, -0.02], atol=1e-7)


def test_backstep_limit_bounds_only_a_backward_placement():
    """The K_php term is bounded where it steps the foot back, not where it steps it forward, and
    a small error stays proportional; 0 bounds nothing."""
    zero = jnp.zeros(2)
    reg = dataclasses.replace(REG, k_php=0.3, k_dhp=0.0, backstep_limit=0.1)

    def forward(v: float, cfg: config.RegulatorConfig) -> float:
        return float(regulators.swing_placement(jnp.array([v, 0.0]), zero, zero, zero, 1.0, cfg)[0])

    assert forward(-0.65, reg) == pytest.approx(-0.1)  # a 100-N backward push: 0.3 x -0.65 = -0.195 unbounded
    assert forward(0.65, reg) == pytest.approx(0.195)  # forward: the whole gain
    assert forward(-0.2, reg) == pytest.approx(-0.06)  # under the bound: the whole gain
    assert forward(-0.65, dataclasses.replace(reg, backstep_limit=0.0)) == pytest.approx(-0.195)


def test_lip_prediction():
    """x'' = g/h x: at rest over the foot nothing moves; a CoM beside the foot falls away from it,
    faster the longer the wait; with the CoM over the foot the velocity grows by cosh(w t)."""
    h = 0.9
    w = np.sqrt(regulators.GRAVITY / h)
    zero = jnp.zeros(2)
    np.testing.assert_allclose(regulators.predicted_velocity(zero, zero, h, 0.3), 0.0)
    out = regulators.predicted_velocity(jnp.array([0.0, 0.1]), zero, h, 0.2)
    later = regulators.predicted_velocity(jnp.array([0.0, 0.1]), zero, h, 0.3)
    assert out[0] == 0 and 0 < out[1] < later[1]
    np.testing.assert_allclose(regulators.predicted_velocity(zero, jnp.array([0.3, -0.1]), h, 0.25),
                               np.array([0.3, -0.1]) * np.cosh(0.25 * w), rtol=1e-5)
    # no time left: the prediction is the measured velocity
    np.testing.assert_allclose(regulators.predicted_velocity(jnp.array([0.2, 0.1]), jnp.array([0.3, -0.1]), h, 0.0),
                               [0.3, -0.1], rtol=1e-6)


def test_neutral_point_is_half_a_step_of_travel_over_the_leg():
    v = jnp.array([0.4, 0.2])
    np_ = regulators.neutral_point(v, 0.8, 0.35, REG)
    np.testing.assert_allclose(np_, [REG.k_neutral_x * 0.4 * 0.35 / 1.6, REG.k_neutral_y * 0.2 * 0.35 / 1.6], rtol=1e-6)
    assert REG.k_neutral_x > 0  # Cassie lands the foot ahead when moving forward


def test_neutral_vx_max_holds_the_neutral_point_only_above_it():
    """Up to the bound the point grows with the forward velocity; beyond it, it holds, and the
    sideways and backward points are Raibert's; 0 bounds nothing."""
    reg = dataclasses.replace(REG, k_neutral_x=1.0, k_neutral_y=1.0, neutral_vx_max=0.8)

    def point(vx: float, vy: float, cfg: config.RegulatorConfig) -> np.ndarray:
        return np.asarray(regulators.neutral_point(jnp.array([vx, vy]), 0.8, 0.35, cfg))

    scale = 0.35 / 1.6
    np.testing.assert_allclose(point(1.2, 0.2, reg), [0.8 * scale, 0.2 * scale], rtol=1e-6)  # after a forward push
    np.testing.assert_allclose(point(0.5, 0.0, reg), [0.5 * scale, 0.0], rtol=1e-6)  # within the commanded range
    np.testing.assert_allclose(point(-0.7, 0.0, reg), [-0.7 * scale, 0.0], rtol=1e-6)  # backward: unbounded
    np.testing.assert_allclose(point(1.2, 0.0, dataclasses.replace(reg, neutral_vx_max=0.0)), [1.2 * scale, 0.0],
                               rtol=1e-6)


def test_heading_turns_back_and_wraps():
    assert regulators.heading(0.3, 0.0, 1.0, REG) < 0
    assert regulators.heading(-0.3, 0.0, 1.0, REG) > 0
    # 3.1 is 0.083 rad short of -3.1 going the short way round: turn on, not back
    np.testing.assert_allclose(regulators.heading(3.1, -3.1, 1.0, REG), (2 * np.pi - 6.2) * REG.k_heading, atol=1e-5)


def test_drift_integrates_the_step_error_within_bounds():
    both = dataclasses.replace(REG, k_i_drift=0.05, k_i_drift_y=0.05)
    beta = jnp.zeros(2)
    for _ in range(100):
        beta = regulators.drift_update(beta, jnp.array([0.5, -0.5]), jnp.zeros(2), both)
    np.testing.assert_allclose(beta, [both.drift_limit, -both.drift_limit], atol=1e-6)


def test_drift_gains_are_per_axis():
    reg = dataclasses.replace(REG, k_i_drift=0.05, k_i_drift_y=0.0)
    beta = regulators.drift_update(jnp.zeros(2), jnp.array([0.4, 0.3]), jnp.array([0.2, -0.1]), reg)
    np.testing.assert_allclose(beta, [0.05 * 0.2, 0.0], atol=1e-7)


def test_rate_limit_ramps_each_axis_and_wraps_the_heading():
    reg = dataclasses.replace(REG, command_rate=(1.0, 2.0))
    dt = 0.01
    followed = jnp.array([0.0, 0.0, 3.1])
    cmd = jnp.array([0.8, -0.005, -3.1])
    first = regulators.rate_limit(followed, cmd, dt, reg)
    # vx moves 1 m/s^2 x dt, vy reaches its close target, the heading turns on through pi
    np.testing.assert_allclose(first, [0.01, -0.005, 3.12], atol=1e-6)
    for _ in range(100):
        followed = regulators.rate_limit(followed, cmd, dt, reg)
    np.testing.assert_allclose(followed[:2], cmd[:2], atol=1e-6)
    np.testing.assert_allclose(regulators.wrap_angle(followed[2] - cmd[2]), 0.0, atol=1e-5)
    # a rate of 0 follows at once, bit for bit
    off = dataclasses.replace(REG, command_rate=(0.0, 0.0))
    np.testing.assert_array_equal(regulators.rate_limit(jnp.zeros(3), cmd, dt, off), cmd)


def test_height_fix_extends_only_for_a_sag_and_saturates():
    reg = dataclasses.replace(REG, k_height=2.0)
    assert float(regulators.height_fix(jnp.float32(0.86), 0.91, reg)) == pytest.approx(0.1)
    assert float(regulators.height_fix(jnp.float32(0.96), 0.91, reg)) == pytest.approx(-0.1)
    assert float(regulators.height_fix(jnp.float32(0.5), 0.91, reg)) == pytest.approx(2.0 * regulators.HEIGHT_ERROR_LIMIT)
    off = dataclasses.replace(REG, k_height=0.0)
    assert float(regulators.height_fix(jnp.float32(0.5), 0.91, off)) == 0.0


def test_ground_rise_follows_the_estimated_plane():
    """Ground falling forward by 0.1 rad is tan(0.1) per metre lower ahead and higher behind; a
    roll of 0.1 rad raises it to the left."""
    t = np.tan(0.1)
    np.testing.assert_allclose(regulators.ground_rise(jnp.array([0.1, 0.0]), jnp.array([1.0, 0.5])), -t, rtol=1e-6)
    np.testing.assert_allclose(regulators.ground_rise(jnp.array([0.1, 0.0]), jnp.array([-0.2, 0.0])), 0.2 * t, rtol=1e-6)
    np.testing.assert_allclose(regulators.ground_rise(jnp.array([0.0, 0.1]), jnp.array([0.3, 0.5])), 0.5 * t, rtol=1e-6)
    assert float(regulators.ground_rise(jnp.zeros(2), jnp.array([0.3, -0.2]))) == 0.0


def test_torso_torque_opposes_tilt():
    t = regulators.torso_torque(np.array([0.1, -0.2, 0.0]), np.zeros(3), REG)
    assert t[0] < 0 and t[1] > 0
    damp = regulators.torso_torque(np.zeros(3), np.array([0.5, 0.5, 0.0]), REG)
    assert damp[0] < 0 and damp[1] < 0
