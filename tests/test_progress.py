"""Progress of the long commands: what it prints, and that it changes nothing that is simulated."""

import io
import json

import jax
import numpy as np
import pytest

from conftest import ROOT
from mjx_cascade import evaluate, progress, rollout, scenario, world


def test_off_a_terminal_a_batch_says_each_tenth_once():
    out = io.StringIO()
    tick = progress.Report("eval", out)("batch 1/1: 1 scenario on the plane (walk)", 20.0)
    for done in (0.5, 2.0, 2.5, 8.0, 8.5, 20.0, 20.0):
        tick(done)
    assert out.getvalue().splitlines() == [
        "eval: batch 1/1: 1 scenario on the plane (walk)",
        "eval: 10% (2 of 20 s simulated)",
        "eval: 40% (8 of 20 s simulated)",
        "eval: 100% (20 of 20 s simulated)",
    ]


def test_a_record_past_the_batchs_seconds_ends_its_bar():
    out = io.StringIO()
    tick = progress.Report("sim2sim", out, bar=True)("scenario 1/1: walk", 0.305)
    tick(0.31)
    assert "sim2sim: scenario 1/1: walk" in out.getvalue() and "100%" in out.getvalue()


def _speed_profile(seconds: float) -> scenario.Scenario:
    """The shipped speed profile, its commands pressed into `seconds`."""
    data = json.loads((ROOT / "configs" / "scenarios" / "speed_profile.json").read_text())
    for c in data["commands"]:
        c["t"] *= seconds / data["duration"]
    return scenario.parse({**data, "duration": seconds})


@pytest.mark.slow
def test_progress_changes_no_number_of_an_evaluation():
    """95 records at 1 kHz in ten calls of one compiled program, the last one past the end: with
    progress or without, the trajectory is bit for bit one `rollout.simulate` call's."""
    cfg, found = evaluate.load_policy("cassie", None, dt=0.001)
    runner = evaluate.Runner(cfg, [_speed_profile(0.95)])
    heard = []
    quiet, told = runner(found.params)[0], runner(found.params, heard.append)[0]
    np.testing.assert_allclose(heard, [0.1 * k for k in range(1, 10)] + [0.95], rtol=1e-12)
    assert runner._advance._cache_size() == 1  # compiled once for every call
    env, every, chunks = runner.env, runner.every, runner.chunks
    schedule = world.schedule([np.array(runner.scenarios[0].commands)], [[]], env.dt, chunks * every)
    _, (qpos, qvel, ground, stance) = jax.jit(lambda p: rollout.simulate(
        env, p, jax.random.PRNGKey(0), world.World(env.model, None, schedule), chunks * every, every, chunks,
        rollout.trajectory))(found.params)
    for key in quiet:
        np.testing.assert_array_equal(quiet[key], told[key], err_msg=key)
    for key, whole in (("qpos", qpos), ("qvel", qvel), ("ground", ground), ("stance", stance)):
        np.testing.assert_array_equal(told[key], np.asarray(whole)[:, 0], err_msg=key)
