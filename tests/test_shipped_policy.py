"""The policy that ships with the package, on the CPU at the paper's 2 kHz: it walks and tracks."""

import json

import numpy as np
import pytest

from conftest import DATA, DIGIT_MODEL
from mjx_cascade import evaluate, judge, policies, scenario

pytestmark = pytest.mark.slow


# Digit also starts backwards and to the right with a heading change, as the two profiles did in
# which the policy shipped before `gait.first_swing: command` fell in its first second
@pytest.mark.parametrize("robot, num_params, model, names", [
    ("cassie", 4184, None, ["walk_short"]),
    ("digit", 4316, DIGIT_MODEL, ["walk_short", "backward_right_start"])])
def test_shipped_policy_walks_and_tracks(robot, num_params, model, names, tmp_path):
    """10-s scenarios of two 5-s segments from standing, within the robot's command ranges, in
    one batched call: no fall, and the bar's errors after 2 s of settling in each segment."""
    found = policies.load(robot)
    assert found.params.shape == (found.record["policy_params"],) == (num_params,)
    metrics = evaluate.evaluate(robot, [scenario.load(DATA / f"{n}.json") for n in names], tmp_path,
                                model_path=model and str(model), dt=0.0005, video=False)
    for name, m in zip(names, metrics):
        out = tmp_path / name if len(names) > 1 else tmp_path
        again = judge.walking(dict(np.load(out / "trajectory.npz")))  # judged from trajectory.npz alone
        assert again["segments"] == json.loads((out / "metrics.json").read_text())["segments"] == m["segments"]
        assert not again["fell"] and again["passed"], (name, again["segments"])
        judged = [s for s in again["segments"] if "within_bounds" in s]
        assert len(judged) == 2
        for s in judged:
            assert s["vx_mae"] <= 0.10 and s["vy_mae"] <= 0.10 and s["yaw_mae"] <= 0.15, (name, s)
        assert m["policy"]["params_sha256"] == found.record["params_sha256"]
        assert m["policy"]["revisions"] == [r["settings"] for r in found.revisions]
