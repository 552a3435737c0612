"""Table 5 domain randomization: per-episode masses and centres of mass as batched model fields."""

import jax
import numpy as np

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
