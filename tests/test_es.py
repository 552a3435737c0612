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
    strategy = es.make(es_cfg(population=8))
    state = es.init(strategy, jnp.ones(5), jax.random.PRNGKey(0))
    noise, members = es.ask(strategy, state, es.generation_keys(state)[es.NOISE])
    assert noise.shape == (4, 5) and members.shape == (8, 5)
    np.testing.assert_allclose((members[:4] + members[4:]) / 2, 1.0, atol=1e-6)
    np.testing.assert_allclose(members[:4] - 1.0, strategy.sigma(0) * noise, atol=1e-6)


def test_gradient_points_uphill_on_a_linear_objective():
    strategy = es.make(es_cfg(population=512))
    state = es.init(strategy, jnp.zeros(4), jax.random.PRNGKey(1))
    noise, members = es.ask(strategy, state, jax.random.PRNGKey(2))
    w = jnp.array([1.0, -2.0, 0.5, 0.0])
    g = es.gradient(noise, members @ w, strategy.sigma(0))
    assert float(jnp.dot(g, w)) > 0.8 * float(jnp.linalg.norm(g) * jnp.linalg.norm(w))


def _optimise(f, dim, generations, **kw):
    strategy = es.make(es_cfg(**kw))
    state = es.init(strategy, jnp.zeros(dim), jax.random.PRNGKey(0))

    @jax.jit
    def generation(state):
        noise, members = es.ask(strategy, state, es.generation_keys(state)[es.NOISE])
        return es.tell(strategy, state, noise, jax.vmap(f)(members))

    for _ in range(generations):
        state = generation(state)
    return state


def test_converges_on_a_quadratic():
    target = jnp.linspace(-1, 1, 10)
    state = _optimise(lambda x: -jnp.sum((x - target) ** 2), 10, 300, population=64, learning_rate=0.05)
    np.testing.assert_allclose(state.mean, target, atol=0.05)
    assert int(state.generation) == 300


def test_converges_on_rosenbrock():
    rosen = lambda x: -((1 - x[0]) ** 2 + 100 * (x[1] - x[0] ** 2) ** 2)
    state = _optimise(rosen, 2, 2000, population=64, learning_rate=0.05, sigma=0.02)
    np.testing.assert_allclose(state.mean, [1.0, 1.0], atol=0.1)


def test_sigma_and_learning_rate_are_schedules_of_the_generation_down_to_their_floors():
    strategy = es.make(es_cfg(sigma=0.1, sigma_decay=0.5, sigma_min=0.01, learning_rate=0.1, lr_decay=0.5, lr_min=0.02))
    for g, sigma, lr in ((0, 0.1, 0.1), (1, 0.05, 0.05), (2, 0.025, 0.025), (3, 0.0125, 0.02), (4, 0.01, 0.02),
                         (40, 0.01, 0.02)):
        assert float(strategy.sigma(g)) == pytest.approx(sigma) and float(strategy.learning_rate(g)) == pytest.approx(lr)
    constant = es.make(es_cfg(sigma_decay=1.0))
    assert float(constant.sigma(1000)) == pytest.approx(0.1)


def test_a_step_moves_by_the_learning_rate_of_its_generation():
    """SGD shows the step size alone: the step is lr(g) times the gradient estimate, so a warm start
    at generation 3 steps as the run that reached it would."""
    strategy = es.make(es_cfg(optimizer="sgd", learning_rate=0.1, lr_decay=0.5, lr_min=0.001, population=8))
    for generation in (0, 3):
        state = es.init(strategy, jnp.zeros(3), jax.random.PRNGKey(0), generation)
        noise, _ = es.ask(strategy, state, jax.random.PRNGKey(1))
        fitness = jnp.arange(8.0)
        new = es.tell(strategy, state, noise, fitness)
        grad = es.gradient(noise, fitness, strategy.sigma(generation))
        np.testing.assert_allclose(new.mean, 0.1 * 0.5**generation * grad, rtol=1e-5)
        assert int(new.generation) == generation + 1


def test_each_generation_and_each_draw_has_its_own_key():
    strategy = es.make(es_cfg())
    state = es.init(strategy, jnp.zeros(3), jax.random.PRNGKey(0))
    keys = [es.generation_keys(state.replace(generation=jnp.int32(g))) for g in range(4)]
    flat = {tuple(np.asarray(k[i]).tolist()) for k in keys for i in (es.NOISE, es.EPISODES)}
    assert len(flat) == 8  # no generation's noise is another's, or any generation's episodes
    # the episode draws of a generation are not the next generation's noise
    assert not np.array_equal(keys[0][es.EPISODES], keys[1][es.NOISE])
