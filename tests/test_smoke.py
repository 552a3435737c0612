"""Every registered robot builds, resets and steps with its untrained policy: no NaN anywhere.

The fast tier's guard for shared code: a change that breaks any robot fails here in seconds,
before the slow tests compile training and evaluation programs.
"""

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from mjx_cascade import config, policy, robots, rollout, world
from mjx_cascade.env import make_env
from conftest import model_for

STEPS = 20


@pytest.mark.parametrize("robot", list(config.ROBOTS))
def test_every_robot_builds_resets_and_steps(robot, request):
    cfg = config.robot_config(robot).override(**{"episode.pool_size": 2})
    network = policy.for_controller(cfg, len(robots.get(robot).learned), jax.random.PRNGKey(0))
    model = model_for(request, robot)
    env = make_env(cfg, network.apply, model_path=model and str(model))
    sched = world.schedule([np.array([[0.0, 0.3, 0.1, 0.2]])], [[(0.005, 0.01, (30.0, 0.0, 0.0))]], env.dt, STEPS)
    record = lambda env, s, w: (s.data.qpos, s.data.qvel, s.ctrl.alpha)  # noqa: E731
    books, (qpos, qvel, alpha) = jax.jit(lambda p: rollout.simulate(
        env, p, jax.random.PRNGKey(0), world.World(env.model, None, sched), STEPS, 1, STEPS, record))(
        network.init_params)
    for x in (qpos, qvel, alpha, books.terms, books.ret):
        assert np.all(np.isfinite(np.asarray(x)))
    assert not bool(books.diverged[0]) and int(books.t[0]) == STEPS
    assert np.max(np.abs(np.asarray(qpos[-1] - qpos[0]))) > 1e-4  # the physics moved
    assert alpha.shape[-2:] == (len(robots.get(robot).learned), cfg.gait.bezier_order + 1)
