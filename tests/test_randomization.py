"""Table 5 domain randomization: per-episode masses and centres of mass as batched model fields;
training pushes."""

import jax
import numpy as np
import pytest

from mjx_cascade import randomization


def test_masses_and_coms_scale_within_table_5_per_episode(cassie_env, cassie_cfg):
    model = cassie_env.model
    keys = jax.random.split(jax.random.PRNGKey(0), 64)
    batch = randomization.randomize(model, keys, cassie_cfg.randomization)
    np.testing.assert_allclose(np.asarray(batch.body_mass)[:, 0], np.asarray(model.body_mass)[0])  # the world
    mass = np.asarray(batch.body_mass)[:, 1:] / np.asarray(model.body_mass)[None, 1:]
    com = np.asarray(batch.body_ipos)[:, 1:] / np.where(np.asarray(model.body_ipos)[None, 1:] == 0, 1,
                                                          np.asarray(model.body_ipos)[None, 1:])
    assert mass.shape == (64, model.body_mass.shape[0] - 1)
    lo, hi = cassie_cfg.randomization.mass
    assert np.all((mass >= lo - 1e-6) & (mass <= hi + 1e-6)) and mass.std() > 0.05
    nonzero = np.asarray(model.body_ipos)[None, 1:] != 0
    lo, hi = cassie_cfg.randomization.com
    assert np.all((com[np.broadcast_to(nonzero, com.shape)] >= lo - 1e-6))
    assert np.all((com[np.broadcast_to(nonzero, com.shape)] <= hi + 1e-6))
    assert not np.allclose(mass[0], mass[1])  # every episode draws its own
    # only the randomized fields carry the batch axis
    axes = randomization.in_axes(model)
    assert axes.body_mass == 0 and axes.body_ipos == 0 and axes.body_inertia is None
    assert np.shape(batch.body_inertia) == np.shape(model.body_inertia)


def test_pushes_draw_magnitude_direction_and_start_from_the_config(cassie_cfg):
    cfg = cassie_cfg.override(**{"randomization.push_force": [20.0, 80.0], "randomization.push_seconds": 0.2,
                                 "randomization.push_after": [1.0, 3.0]}).randomization
    off = cassie_cfg.override(**{"randomization.push_force": [0.0, 0.0]}).randomization
    assert randomization.pushes_enabled(cfg) and not randomization.pushes_enabled(off)
    dt = 0.001
    p = jax.vmap(lambda k: randomization.push(k, cfg, dt))(jax.random.split(jax.random.PRNGKey(0), 512))
    force, start, stop = (np.asarray(x) for x in p)
    magnitude = np.linalg.norm(force, axis=1)
    assert np.all(force[:, 2] == 0) and np.all((magnitude > 20 - 1e-3) & (magnitude < 80 + 1e-3))
    angle = np.arctan2(force[:, 1], force[:, 0])
    assert np.histogram(angle, bins=4, range=(-np.pi, np.pi))[0].min() > 90  # every direction
    assert np.all((start >= 1000) & (start <= 3000)) and np.all(stop - start == 200)
    one = jax.tree.map(lambda x: x[0], p)
    on = [float(np.linalg.norm(randomization.push_force(one, t))) for t in (start[0] - 1, start[0], stop[0] - 1, stop[0])]
    assert on == pytest.approx([0.0, magnitude[0], magnitude[0], 0.0], rel=1e-6)
