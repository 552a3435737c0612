"""Episode schedules: the command (one, or a second from a random time on) and the push force."""

import types

import jax
import jax.numpy as jnp
import numpy as np

from mjx_cascade import config, rollout

B = 256


def _schedules(generation=0, **over):
    """Cassie's schedules, pushes off unless `over` sets them (its config holds them off for 250 generations)."""
    over = {"randomization.push_force": [0.0, 0.0], "randomization.push_warmup_generations": 0, **over}
    cfg = config.robot_config("cassie").override(**over)
    env = types.SimpleNamespace(cfg=cfg, dt=cfg.physics.dt)
    keys = jax.random.split(jax.random.PRNGKey(0), B)
    cmd = jax.vmap(lambda k: rollout.sample_command(k, cfg.episode))(keys)
    return env, keys, cmd, *rollout.schedules(env, keys, cmd, generation)


def test_without_a_command_change_one_command_and_no_push():
    _, _, cmd, command, force = _schedules(**{"episode.command_change": [0.0, 0.0]})
    t = jnp.arange(B)
    assert command(t) is cmd and force(t) is None


def test_a_second_command_takes_over_at_its_own_time_in_the_window():
    env, keys, cmd, command, force = _schedules(**{"episode.command_change": [1.0, 3.0]})
    later, at = jax.vmap(lambda k: rollout.second_command(jax.random.fold_in(k, rollout.COMMAND_STREAM),
                                                          env.cfg.episode, env.dt))(keys)
    at = np.asarray(at)
    assert np.all((at >= 1000) & (at <= 3000)) and np.std(at) > 400  # dt 1 ms
    np.testing.assert_array_equal(command(jnp.asarray(at - 1)), cmd)
    np.testing.assert_array_equal(command(jnp.asarray(at)), later)
    e = env.cfg.episode
    lo, hi = np.array([e.vx[0], e.vy[0], e.yaw[0]]), np.array([e.vx[1], e.vy[1], e.yaw[1]])
    assert np.all((np.asarray(later) >= lo) & (np.asarray(later) <= hi))
    assert np.mean(np.abs(np.asarray(later) - np.asarray(cmd))[:, 0]) > 0.2  # drawn afresh
    assert force(jnp.asarray(at)) is None


def test_pushes_act_only_inside_their_window():
    _, _, _, _, force = _schedules(**{"randomization.push_force": [50.0, 50.0], "randomization.push_after": [1.0, 1.0]})
    for t, expect in ((999, 0.0), (1000, 50.0), (1199, 50.0), (1200, 0.0)):
        np.testing.assert_allclose(np.linalg.norm(np.asarray(force(jnp.full(B, t))), axis=1), expect, rtol=1e-5)


def test_pushes_start_after_their_warmup_generations_as_drawn_without_one():
    push = {"randomization.push_force": [10.0, 80.0], "randomization.push_after": [1.0, 1.0]}
    t = jnp.full(B, 1100)
    *_, plain = _schedules(**push)
    expected = np.asarray(plain(t))
    assert np.all(np.linalg.norm(expected, axis=1) >= 10.0 - 1e-4)
    for generation, scale in ((0, 0.0), (4, 0.0), (5, 1.0), (9, 1.0)):
        *_, force = _schedules(jnp.int32(generation), **push, **{"randomization.push_warmup_generations": 5})
        np.testing.assert_array_equal(np.asarray(force(t)), scale * expected)
