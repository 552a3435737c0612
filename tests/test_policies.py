"""Policy directories: what training wrote, plus revisions written by a function, never by hand."""

import json
import shutil

import numpy as np
import pytest

from mjx_cascade import checkpoint, config, policies
from mjx_cascade.config import ConfigError


@pytest.mark.parametrize("robot", list(config.ROBOTS))
def test_a_shipped_policy_is_its_training_record_and_its_revisions(robot):
    directory = policies.shipped(robot)
    found = policies.load(robot)
    assert found.record["params_sha256"] == checkpoint.params_sha256(found.params)
    assert found.params.shape == (found.record["policy_params"],)
    expected = config.from_dict(found.record["config"])  # the config it trained with
    for revision in found.revisions:
        assert revision["params_sha256"] == found.record["params_sha256"] and revision["reason"]
        expected = expected.override(**revision["settings"])
    assert found.config == expected
    lines = (directory / policies.METRICS).read_text().splitlines()
    assert json.loads(lines[-1])["generation"] == found.generation


@pytest.mark.parametrize("robot", list(config.ROBOTS))
def test_the_revisions_file_is_what_revise_writes(robot, tmp_path):
    """Replaying each recorded revision through `policies.revise` on a copy without the file writes
    it again byte for byte."""
    source = policies.shipped(robot)
    copy = tmp_path / robot
    shutil.copytree(source, copy)
    (copy / policies.REVISIONS).unlink(missing_ok=True)
    for revision in policies.load(robot).revisions:
        policies.revise(copy, revision["settings"], revision["reason"], revision["date"])
    assert _revisions(copy) == _revisions(source)  # None where nothing was changed after training


def _revisions(directory) -> bytes | None:
    path = directory / policies.REVISIONS
    return path.read_bytes() if path.exists() else None


def test_a_revision_changes_only_the_controller_and_needs_its_reason(tmp_path):
    copy = tmp_path / "cassie"
    shutil.copytree(policies.shipped("cassie"), copy)
    before = _revisions(copy)
    for settings, reason, message in (({"rewards.e_vy": 0.2}, "why", "can change only"),
                                      ({"policy.hidden_units": 16}, "why", "policy.hidden_units"),
                                      ({"regulators.k_height": -1.0}, "why", "regulators.k_height"),
                                      ({"regulators.k_height": 1.0}, " ", "reason")):
        with pytest.raises(ConfigError, match=message):
            policies.revise(copy, settings, reason)
        assert _revisions(copy) == before  # nothing written
    revision = policies.revise(copy, {"regulators.k_phr": "0.35"}, "a test", "2026-01-01")
    assert revision["settings"] == {"regulators.k_phr": 0.35}  # typed as the config holds it
    assert policies.load(copy).config.regulators.k_phr == 0.35
    np.testing.assert_array_equal(policies.load(copy).params, policies.load("cassie").params)
