import jax
import jax.numpy as jnp
import numpy as np
import pytest

from mjx_cascade import features, policy


def test_heading_frame_rotation():
    v = jnp.array([1.0, 0.0])
    np.testing.assert_allclose(features.to_heading_frame(v, jnp.pi / 2), [0.0, -1.0], atol=1e-6)
    np.testing.assert_allclose(features.to_heading_frame(jnp.array([0.0, 2.0]), jnp.pi / 2), [2.0, 0.0], atol=1e-6)


def test_features_layout():
    s = features.features(jnp.array([0.5, -0.1]), jnp.array([0.3, 0.2]))
    np.testing.assert_allclose(s, [0.5, -0.1, 0.3, 0.2, -0.2, 0.3], atol=1e-6)
    assert s.shape == (features.STATE_DIM,)


@pytest.mark.parametrize("learned, params", [(6, 4184), (7, 4316)])
def test_table_1_parameter_counts(learned, params):
    actions = policy.action_dim(learned, 5)
    assert actions == learned * 4
    assert policy.param_count(actions, 4, 32) == params
    net = policy.make(actions, 4, 32, jax.random.PRNGKey(0))
    assert net.init_params.shape == (params,) == (net.num_params,)  # the flax module itself has exactly that many
    assert sum(x.size for x in jax.tree.leaves(net.unravel(net.init_params))) == params


def test_policy_outputs_are_sigmoids_and_depend_on_parameters():
    net = policy.make(24, 4, 32, jax.random.PRNGKey(0))
    s = jnp.array([0.5, 0.0, 0.1, 0.0, -0.4, 0.0])
    a = net.apply(net.init_params, s)
    assert a.shape == (24,) and np.all((a > 0) & (a < 1))
    b = net.apply(net.init_params + 0.1, s)
    assert not np.allclose(a, b)


def test_flat_bytes_are_fixed_order_float32():
    flat = jnp.arange(3, dtype=jnp.float32)
    assert policy.flat_bytes(flat) == np.arange(3, dtype="<f4").tobytes()
