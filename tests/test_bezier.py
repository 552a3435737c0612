import jax
import jax.numpy as jnp
import numpy as np
import pytest

from mjx_cascade import bezier


@pytest.fixture
def alpha():
    return jax.random.normal(jax.random.PRNGKey(0), (6, 6))  # 6 joints, M = 5


def test_endpoints_are_first_and_last_coefficients(alpha):
    np.testing.assert_allclose(bezier.value(alpha, 0.0), alpha[:, 0], atol=1e-6)
    np.testing.assert_allclose(bezier.value(alpha, 1.0), alpha[:, -1], atol=1e-6)


def test_basis_is_a_partition_of_unity():
    taus = jnp.linspace(0, 1, 11)
    np.testing.assert_allclose(bezier.bernstein(taus, 5).sum(-1), 1.0, atol=1e-6)


def test_derivative_matches_finite_differences(alpha):
    h = 1e-3
    for tau in (0.1, 0.37, 0.5, 0.9):
        fd = (bezier.value(alpha, tau + h) - bezier.value(alpha, tau - h)) / (2 * h)
        np.testing.assert_allclose(bezier.derivative(alpha, tau), fd, rtol=2e-3, atol=2e-3)


def test_endpoint_slopes_follow_the_control_polygon(alpha):
    m = alpha.shape[-1] - 1
    np.testing.assert_allclose(bezier.derivative(alpha, 0.0), m * (alpha[:, 1] - alpha[:, 0]), rtol=1e-5, atol=1e-5)
    np.testing.assert_allclose(bezier.derivative(alpha, 1.0), m * (alpha[:, -1] - alpha[:, -2]), rtol=1e-5, atol=1e-5)


def test_evaluate_scales_by_step_time_and_holds_after_the_step(alpha):
    y, yd = bezier.evaluate(alpha, 0.4, 0.5)
    np.testing.assert_allclose(yd, bezier.derivative(alpha, 0.4) / 0.5, rtol=1e-5)
    y_late, yd_late = bezier.evaluate(alpha, 1.2, 0.5)
    np.testing.assert_allclose(y_late, alpha[:, -1], atol=1e-6)
    np.testing.assert_allclose(yd_late, 0.0)


def test_vmaps_over_environments(alpha):
    batch = jnp.stack([alpha, 2 * alpha])
    y = jax.vmap(bezier.value, in_axes=(0, None))(batch, 0.3)
    np.testing.assert_allclose(y[1], 2 * y[0], rtol=1e-5, atol=1e-6)
