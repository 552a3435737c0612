"""Digit's environment: the untrained policy's episodes (compiles MJX on the CPU)."""

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from mjx_cascade import config, episodes, policy
from mjx_cascade.env import make_env
from test_env import timeouts_at_most

pytestmark = pytest.mark.slow


def test_an_untrained_digit_policy_steps_in_place(digit_model):
    """Digit's range middles (what an untrained network outputs) and the regulators step in place
    from the balanced pool on the nominal model for 2 s, within eq. 27's bounds as configured:
    the starting point the ES improves on, as Cassie's (test_env)."""
    cfg = config.robot_config("digit").override(**{
        "episode.pool_size": 4, "episode.seconds": 2.0, "episode.vx": [0.0, 0.0], "episode.vy": [0.0, 0.0],
        "episode.yaw": [0.0, 0.0], "randomization.enabled": False})
    network = policy.for_controller(cfg, 7, jax.random.PRNGKey(0))
    env = make_env(cfg, network.apply, model_path=str(digit_model))
    params = jnp.stack([network.init_params] * 4)
    keys = jax.random.split(jax.random.PRNGKey(1), 4)
    result = jax.tree.map(np.asarray, jax.jit(lambda p, k: episodes.run(env, p, k))(params, keys))
    assert np.all(np.isfinite(result.fitness))
    assert not np.any(result.terminated) and not np.any(result.diverged)
    np.testing.assert_array_equal(result.steps, round(2.0 / env.dt))
    # stepping, not standing: more steps than time-outs alone end in 2 s
    assert np.all(result.walking_steps >= timeouts_at_most(2.0, cfg.gait) + 1), result.walking_steps
