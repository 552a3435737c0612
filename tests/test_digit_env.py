"""Digit's environment: the untrained policy's episodes (compiles MJX on the CPU)."""

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from mjx_cascade import config, rollout
from mjx_cascade.env import make_env
from conftest import DIGIT_MODEL

pytestmark = pytest.mark.slow


def test_an_untrained_digit_policy_steps_in_place():
    """Digit's range middles (what an untrained network outputs) and the regulators step in place
    from the balanced pool on the nominal model for 2 s, within eq. 27's bounds as configured:
    the starting point the ES improves on, as Cassie's (test_env)."""
    cfg = config.robot_config("digit").override(**{
        "episode.pool_size": 4, "episode.seconds": 2.0, "episode.vx": [0.0, 0.0], "episode.vy": [0.0, 0.0],
        "episode.yaw": [0.0, 0.0], "randomization.enabled": False})
    env = make_env(cfg, batch=4, model_path=str(DIGIT_MODEL))
    params = jnp.stack([env.init_params] * 4)
    keys = jax.random.split(jax.random.PRNGKey(1), 4)
    episodes = jax.jit(lambda p, k: rollout.run_episodes(env, p, k))(params, keys)
    assert np.all(np.isfinite(np.asarray(episodes.fitness)))
    assert not np.any(np.asarray(episodes.terminated)) and not np.any(np.asarray(episodes.diverged))
    np.testing.assert_array_equal(np.asarray(episodes.steps), env.episode_steps)
    # 2 s of steps of at most step_time each (a step ends at touchdown or by time-out)
    assert np.all(np.asarray(episodes.walking_steps) >= int(0.75 * 2.0 / cfg.gait.step_time))
