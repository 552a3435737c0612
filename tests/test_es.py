import jax
import jax.numpy as jnp
import numpy as np
import pytest

from mjx_cascade import config, es


def es_cfg(**kw):
    over = {f"es.{k}": v for k, v in kw.items()}
    return config.robot_config("cassie").override(**over).es


def test_centered_ranks():
    r = es.centered_ranks(jnp.array([3.0, -1.0, 10.0, 0.0]))
    np.testing.assert_allclose(r, [1 / 6, -0.5, 0.5, -1 / 6], atol=1e-6)
    bad = es.centered_ranks(jnp.array([1.0, jnp.nan, 2.0]))
    assert float(bad[1]) == -0.5  # a NaN fitness ranks last, it never looks good


def test_antithetic_members():
    cfg = es_cfg(population=8)
    state = es.init(jnp.ones(5), jax.random.PRNGKey(0), cfg)
    _, noise, members = es.ask(state, cfg)
    assert noise.shape == (4, 5) and members.shape == (8, 5)
    np.testing.assert_allclose((members[:4] + members[4:]) / 2, 1.0, atol=1e-6)


def test_gradient_points_uphill_on_a_linear_objective():
    cfg = es_cfg(population=512)
    state = es.init(jnp.zeros(4), jax.random.PRNGKey(1), cfg)
    _, noise, members = es.ask(state, cfg)
    w = jnp.array([1.0, -2.0, 0.5, 0.0])
    g = es.gradient(noise, members @ w, state.sigma)
    assert float(jnp.dot(g, w)) > 0.8 * float(jnp.linalg.norm(g) * jnp.linalg.norm(w))


def _optimise(f, dim, generations, **kw):
    cfg = es_cfg(**kw)
    state = es.init(jnp.zeros(dim), jax.random.PRNGKey(0), cfg)

    @jax.jit
    def generation(state):
        state, noise, members = es.ask(state, cfg)
        return es.tell(state, noise, jax.vmap(f)(members), cfg)

    for _ in range(generations):
        state = generation(state)
    return state


def test_converges_on_a_quadratic():
    target = jnp.linspace(-1, 1, 10)
    state = _optimise(lambda x: -jnp.sum((x - target) ** 2), 10, 300, population=64, learning_rate=0.05)
    np.testing.assert_allclose(state.mean, target, atol=0.05)


def test_converges_on_rosenbrock():
    rosen = lambda x: -((1 - x[0]) ** 2 + 100 * (x[1] - x[0] ** 2) ** 2)
    state = _optimise(rosen, 2, 2000, population=64, learning_rate=0.05, sigma=0.02)
    np.testing.assert_allclose(state.mean, [1.0, 1.0], atol=0.1)


def test_sigma_and_learning_rate_decay_to_their_floors():
    cfg = es_cfg(sigma=0.1, sigma_decay=0.5, sigma_min=0.01, learning_rate=0.1, lr_decay=0.5, lr_min=0.02)
    state = es.init(jnp.zeros(3), jax.random.PRNGKey(0), cfg)
    for expect_sigma, expect_lr in ((0.05, 0.05), (0.025, 0.025), (0.0125, 0.02), (0.01, 0.02)):
        state, noise, _ = es.ask(state, cfg)
        state = es.tell(state, noise, jnp.arange(cfg.population, dtype=jnp.float32), cfg)
        assert float(state.sigma) == pytest.approx(expect_sigma)
        assert float(state.lr) == pytest.approx(expect_lr)
    assert int(state.generation) == 4


def test_a_warm_start_takes_the_decayed_sigma_and_learning_rate_of_its_generation():
    cfg = es_cfg(sigma=0.1, sigma_decay=0.5, sigma_min=0.01, learning_rate=0.1, lr_decay=0.5, lr_min=0.02)
    stepped = es.init(jnp.zeros(3), jax.random.PRNGKey(0), cfg)
    for _ in range(3):
        stepped, noise, _ = es.ask(stepped, cfg)
        stepped = es.tell(stepped, noise, jnp.arange(cfg.population, dtype=jnp.float32), cfg)
    warm = es.init(jnp.ones(3), jax.random.PRNGKey(1), cfg, generation=3)
    assert int(warm.generation) == 3
    assert float(warm.sigma) == pytest.approx(float(stepped.sigma)) and float(warm.lr) == pytest.approx(float(stepped.lr))
    np.testing.assert_array_equal(warm.mean, np.ones(3))
