"""The episode books the simulator keeps above the environment (pure functions, no physics)."""

import types

import jax.numpy as jnp
import numpy as np

from mjx_cascade import rewards, rollout
from mjx_cascade.env import StepReport

DT, STEPS, PENALTY = 0.01, 10, 20.0
ENV = types.SimpleNamespace(dt=DT, weights=jnp.ones(len(rewards.TERMS)),
                            cfg=types.SimpleNamespace(rewards=types.SimpleNamespace(termination_penalty=PENALTY)))


def _report(terminated=(False, False), diverged=(False, False), switched=(False, False), terms=1.0):
    return StepReport(jnp.full((2, len(rewards.TERMS)), terms), jnp.array(terminated), jnp.array(diverged),
                      jnp.array(switched))


def test_live_episodes_score_and_count_until_their_time_is_up():
    books = rollout.Books.start(2)
    for _ in range(STEPS + 3):  # the robots simulate on after the episode's end
        books = rollout.keep_books(books, _report(switched=(True, False)), ENV, STEPS)
    np.testing.assert_array_equal(books.t, [STEPS, STEPS])
    assert np.all(books.done) and not np.any(books.terminated)
    np.testing.assert_allclose(books.ret, STEPS * len(rewards.TERMS) * DT, rtol=1e-6)
    np.testing.assert_allclose(books.terms, STEPS * DT, rtol=1e-6)
    np.testing.assert_array_equal(books.walking_steps, [STEPS, 0])  # switches count only while live
    np.testing.assert_allclose(rollout.fitness(books, STEPS, DT), len(rewards.TERMS), rtol=1e-6)


def test_an_early_end_pays_for_every_second_it_leaves_unplayed():
    books = rollout.Books.start(2)
    for i in range(STEPS):
        books = rollout.keep_books(books, _report(terminated=(i == 3, False)), ENV, STEPS)
    assert list(np.asarray(books.terminated)) == [True, False] and int(books.t[0]) == 4
    played = 4 * len(rewards.TERMS) * DT
    np.testing.assert_allclose(books.ret[0], played - PENALTY * (STEPS - 4) * DT, rtol=1e-5)


def test_a_diverged_step_is_never_counted():
    books = rollout.Books.start(2)
    books = rollout.keep_books(books, _report(terminated=(True, False), diverged=(True, False), terms=jnp.nan), ENV, STEPS)
    assert bool(books.diverged[0]) and bool(books.done[0])
    assert np.all(np.isfinite(np.asarray(books.terms[0])))  # the NaN terms were not added
    np.testing.assert_allclose(books.ret[0], -PENALTY * (STEPS - 1) * DT, rtol=1e-6)
