"""The exported bundle: the shipped policy's parameters and controller, readable without this package."""

import json

import jax
import numpy as np
import pytest

from mjx_cascade import bundle, config, policies, policy, robots


@pytest.fixture(scope="module")
def cassie_bundle(tmp_path_factory):
    return bundle.export("cassie", tmp_path_factory.mktemp("bundle"))


def test_the_bundle_holds_the_shipped_parameters_and_the_config_they_run_with(cassie_bundle):
    found, read = policies.load("cassie"), bundle.load(cassie_bundle)
    assert read.params.dtype == np.float32 and np.array_equal(read.params, found.params)
    assert read.config == found.config  # the training config with its recorded revisions
    assert read.revisions == found.revisions and read.generation == found.generation


def test_the_layers_as_plain_arrays_give_the_packages_actions(cassie_bundle):
    """A NumPy MLP over weights.npz alone acts as the package's flax network: float32 against
    float64 arithmetic through 5 layers of at most 32 units differ by less than 1e-5."""
    found = policies.load("cassie")
    network = policy.for_controller(found.config, 6, jax.random.PRNGKey(0))
    features = np.random.default_rng(0).normal(0.0, 0.5, (256, 6)).astype(np.float32)
    expected = np.asarray(jax.vmap(network.apply, in_axes=(None, 0))(found.params, features))
    with np.load(cassie_bundle / bundle.WEIGHTS) as f:
        layers = [(f[f"layer{i}.kernel"], f[f"layer{i}.bias"]) for i in range(5)]
    assert [k.shape for k, _ in layers] == [(6, 32), (32, 32), (32, 32), (32, 32), (32, 24)]
    got = bundle.actions(layers, features)
    assert np.abs(got - expected).max() < 1e-5
    assert np.abs(expected - expected.mean(axis=0)).max() > 0.05  # the features matter: not a constant


def test_eval_reads_a_bundle_as_it_reads_the_policy(cassie_bundle):
    from mjx_cascade import evaluate

    cfg, found = evaluate.load_policy("cassie", str(cassie_bundle), 0.0005)
    shipped_cfg, shipped = evaluate.load_policy("cassie", None, 0.0005)
    assert cfg == shipped_cfg and np.array_equal(found.params, shipped.params)


def test_the_contract_states_what_the_controller_needs(cassie_bundle):
    contract = json.loads((cassie_bundle / bundle.CONTRACT).read_text())
    cfg = policies.load("cassie").config
    assert contract["format"] == bundle.FORMAT and contract["version"] == bundle.VERSION
    assert contract["robot"] == "cassie" and contract["model"]["nu"] == 10
    assert contract["policy"]["features"] == list(bundle.FEATURES) and contract["policy"]["params"] == 4184
    assert contract["gait"]["bezier_order"] == cfg.gait.bezier_order == 5
    assert contract["gait"]["step_time"] == cfg.gait.step_time
    assert contract["gait"]["grf_threshold"] == cfg.gait.grf_threshold
    assert np.array(contract["gait"]["learned_low"]).shape == (6, 4)
    assert contract["regulators"]["command_rate"] == list(cfg.regulators.command_rate)
    assert contract["timestep"] == {"trained": cfg.physics.dt, "runs": config.PAPER_DT}
    facts = contract["robot_facts"]
    assert facts["motors"][0][0] == "left-hip-roll" and len(facts["learned"]) == 6
    assert set(facts["derived"]) >= {"mirror", "kp", "kd", "forward_sign", "torso_sign", "toe_pinv", "foot_flat"}
    assert config.from_dict(contract["config"]) == cfg


def test_a_changed_bundle_or_another_model_is_refused(cassie_bundle, tmp_path):
    import shutil

    robot = robots.build(robots.get("cassie"), policies.load("cassie").config.physics)
    bundle.check(cassie_bundle, robot)  # the model it was exported from
    changed = shutil.copytree(cassie_bundle, tmp_path / "changed")
    contract = json.loads((changed / bundle.CONTRACT).read_text())
    contract["robot_facts"]["derived"]["kp"][0] += 1.0
    (changed / bundle.CONTRACT).write_text(json.dumps(contract))
    with pytest.raises(config.ConfigError, match="kp differ"):
        bundle.check(changed, robot)
    with np.load(cassie_bundle / bundle.WEIGHTS) as f:
        arrays = dict(f)
    arrays["params"] = arrays["params"] * np.float32(1.001)
    np.savez(changed / bundle.WEIGHTS, **arrays)
    with pytest.raises(config.ConfigError, match="does not hold the parameters"):
        bundle.load(changed)
