"""The policy that ships with the package, on the CPU at the paper's 2 kHz: it walks and tracks."""

import json

import numpy as np
import pytest

from conftest import DATA, DIGIT_MODEL
from mjx_cascade import evaluate, policies, scenario

pytestmark = pytest.mark.slow


@pytest.mark.parametrize("robot, num_params, model", [("cassie", 4184, None), ("digit", 4316, DIGIT_MODEL)])
def test_shipped_policy_walks_and_tracks(robot, num_params, model, tmp_path):
    """Two 5-s segments from standing (forward, then slower with a sideways component and a
    heading change), within both robots' command ranges: no fall, and the bar's errors after 2 s
    of settling in each."""
    meta, params = policies.load(robot)
    assert params.shape == (meta["policy_params"],) == (num_params,)
    (metrics,) = evaluate.evaluate(robot, [scenario.load(DATA / "walk_short.json")], tmp_path,
                                   model_path=model and str(model), dt=0.0005, video=False)
    traj = np.load(tmp_path / "trajectory.npz")
    again = evaluate.tracking_metrics(dict(traj))  # judged from trajectory.npz alone
    assert again["segments"] == json.loads((tmp_path / "metrics.json").read_text())["segments"] == metrics["segments"]
    assert not again["fell"] and again["passed"], again["segments"]
    judged = [s for s in again["segments"] if "within_bounds" in s]
    assert len(judged) == 2
    for s in judged:
        assert s["vx_mae"] <= 0.10 and s["vy_mae"] <= 0.10 and s["yaw_mae"] <= 0.15, s
    assert metrics["policy"]["params_sha256"] == meta["params_sha256"]
