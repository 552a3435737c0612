"""What a training episode faces, drawn from its key: one command or two, a push after its warm-up."""

import types

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from mjx_cascade import config, episodes

B = 256


def _draws(generation=0, **over):
    """Cassie's schedules for B episodes, pushes off unless `over` sets them (its config holds them off
    for its first generations), at a 1-ms step: the times below are in steps of 1 ms."""
    over = {"randomization.push_force": [0.0, 0.0], "randomization.push_warmup_generations": 0,
            "randomization.enabled": False, "physics.dt": 0.001, **over}
    cfg = config.robot_config("cassie").override(**over)
    env = types.SimpleNamespace(cfg=cfg, dt=cfg.physics.dt, model=None)
    keys = jax.random.split(jax.random.PRNGKey(0), B)
    return cfg, episodes.draw(env, keys, generation).schedule


def test_without_a_command_change_one_command_and_no_push():
    cfg, s = _draws(**{"episode.command_change": [0.0, 0.0]})
    assert s.command.shape == (B, 1, 3) and not s.pushes and s.force_at(jnp.int32(0)) is None
    np.testing.assert_array_equal(s.command_at(jnp.int32(5000)), s.command[:, 0])
    e = cfg.episode
    lo, hi = np.array([e.vx[0], e.vy[0], e.yaw[0]]), np.array([e.vx[1], e.vy[1], e.yaw[1]])
    assert np.all((np.asarray(s.command[:, 0]) >= lo) & (np.asarray(s.command[:, 0]) <= hi))


def test_a_second_command_takes_over_at_its_own_time_in_the_window():
    _, s = _draws(**{"episode.command_change": [1.0, 3.0]})
    at = np.asarray(s.command_start[:, 1])
    assert np.all((at >= 1000) & (at <= 3000)) and np.std(at) > 400  # dt 1 ms
    for i in (0, 1, 2):
        before, after = s.command_at(jnp.int32(at[i] - 1)), s.command_at(jnp.int32(at[i]))
        np.testing.assert_array_equal(before[i], s.command[i, 0])
        np.testing.assert_array_equal(after[i], s.command[i, 1])
    assert np.mean(np.abs(np.asarray(s.command[:, 1] - s.command[:, 0]))[:, 0]) > 0.2  # drawn afresh


def test_enabling_one_draw_leaves_the_others_as_they_were():
    _, plain = _draws()
    _, pushed = _draws(**{"randomization.push_force": [10.0, 80.0], "episode.command_change": [1.0, 3.0]})
    np.testing.assert_array_equal(plain.command[:, 0], pushed.command[:, 0])


def test_pushes_act_only_inside_their_window():
    _, s = _draws(**{"randomization.push_force": [50.0, 50.0], "randomization.push_after": [1.0, 1.0]})
    for t, expect in ((999, 0.0), (1000, 50.0), (1199, 50.0), (1200, 0.0)):
        np.testing.assert_allclose(np.linalg.norm(np.asarray(s.force_at(jnp.int32(t))), axis=1), expect, rtol=1e-5)


def test_pushes_draw_magnitude_direction_and_start_from_the_config():
    _, s = _draws(**{"randomization.push_force": [20.0, 80.0], "randomization.push_after": [1.0, 3.0]})
    force, start, stop = (np.asarray(x)[:, 0] for x in (s.push_force, s.push_start, s.push_stop))
    magnitude = np.linalg.norm(force, axis=1)
    assert np.all(force[:, 2] == 0) and np.all((magnitude > 20 - 1e-3) & (magnitude < 80 + 1e-3))
    angle = np.arctan2(force[:, 1], force[:, 0])
    assert np.histogram(angle, bins=4, range=(-np.pi, np.pi))[0].min() > 40  # every direction
    assert np.all((start >= 1000) & (start <= 3000)) and np.all(stop - start == 200)


@pytest.mark.parametrize("generation, scale", [(0, 0.0), (4, 0.0), (5, 1.0), (9, 1.0)])
def test_pushes_start_after_their_warmup_generations_as_drawn_without_one(generation, scale):
    push = {"randomization.push_force": [10.0, 80.0], "randomization.push_after": [1.0, 1.0]}
    t = jnp.int32(1100)
    _, plain = _draws(**push)
    expected = np.asarray(plain.force_at(t))
    assert np.all(np.linalg.norm(expected, axis=1) >= 10.0 - 1e-4)
    _, s = _draws(jnp.int32(generation), **push, **{"randomization.push_warmup_generations": 5})
    np.testing.assert_array_equal(np.asarray(s.force_at(t)), scale * expected)
