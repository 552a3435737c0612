import jax.numpy as jnp
import numpy as np
import pytest

from mjx_cascade.rotations import quat_to_rpy, tilt


@pytest.mark.parametrize("axis", [0, 1, 2])
@pytest.mark.parametrize("xp", [np, jnp])
def test_single_axis_rotations(axis, xp):
    a = 0.3
    q = np.zeros(4)
    q[0], q[1 + axis] = np.cos(a / 2), np.sin(a / 2)
    expect = np.zeros(3)
    expect[axis] = a
    np.testing.assert_allclose(np.asarray(quat_to_rpy(xp.asarray(q), xp)), expect, atol=1e-6)
    np.testing.assert_allclose(float(tilt(xp.asarray(q), xp)), 0.0 if axis == 2 else a, atol=1e-6)


def test_batched():
    q = np.array([[1.0, 0, 0, 0], [np.cos(0.5), 0, 0, np.sin(0.5)]])
    np.testing.assert_allclose(quat_to_rpy(q)[:, 2], [0.0, 1.0], atol=1e-9)
