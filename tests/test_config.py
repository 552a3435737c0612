import dataclasses
import json

import pytest
import yaml

from mjx_cascade import config
from mjx_cascade.config import ConfigError

from conftest import ROOT


def test_robot_configs_carry_the_paper_tables():
    c, d = config.robot_config("cassie"), config.robot_config("digit")
    # Table 3
    assert (c.es.population, c.es.sigma, c.es.sigma_decay, c.es.sigma_min) == (24, 0.1, 0.9999, 1e-4)
    assert (c.es.learning_rate, c.es.lr_decay, c.es.lr_min) == (0.01, 0.9999, 1e-4)
    # Table 4 (q_z^d is the height regulation's target too)
    assert (c.regulators.height, d.regulators.height, c.rewards.e_height, d.rewards.e_height) == (0.91, 1.0, 0.05, 0.04)
    assert d.rewards.weights.stance_foot == 0.5 and c.rewards.weights.stance_foot == 0.0
    # Table 7 (Cassie's placement and torso gains are retuned; configs/base.yaml and cassie.yaml say why)
    assert (c.regulators.k_dhr, c.regulators.k_dhp, d.regulators.k_p_roll, d.regulators.k_ptp) == (0.05, 0.01, 3500.0, 0.1)
    # Sec. V-C episode lengths: Digit's 7.5 s; Cassie trains on 8 s (the paper's 5 s, lengthened)
    assert (c.episode.seconds, d.episode.seconds) == (8.0, 7.5)


def test_a_robot_file_states_only_its_differences_from_the_base():
    base = yaml.safe_load((ROOT / "configs" / "base.yaml").read_text())
    for robot in config.ROBOTS:
        own = yaml.safe_load((ROOT / "configs" / f"{robot}.yaml").read_text())
        for section, values in own.items():
            for key, value in values.items():
                assert base.get(section, {}).get(key) != value, f"{robot}.yaml repeats {section}.{key}"


def test_the_controller_half_is_what_a_policy_runs_with():
    cfg = config.robot_config("cassie")
    controller = cfg.controller
    assert type(controller) is config.ControllerConfig and isinstance(cfg, config.ControllerConfig)
    assert set(config.to_dict(controller)) == {"version", "robot", *config.CONTROLLER_SECTIONS}
    assert config.CONTROLLER_SECTIONS == ("physics", "gait", "policy", "regulators")
    assert controller.regulators is cfg.regulators and controller.override(**{"gait.step_time": 0.3}).gait.step_time == 0.3


def test_overrides_are_typed_and_checked_where_the_field_is():
    c = config.robot_config("cassie").override(**{"es.sigma": "0.05", "episode.vx": "[0, 1]"})
    assert c.es.sigma == 0.05 and c.episode.vx == (0.0, 1.0)
    with pytest.raises(ConfigError, match="es.population"):
        c.override(**{"es.population": 7})
    with pytest.raises(ConfigError, match="es.population"):
        c.override(**{"es.population": -4})
    with pytest.raises(ConfigError, match="unknown config key 'es.sigmaa'"):
        c.override(**{"es.sigmaa": 0.1})
    with pytest.raises(ConfigError, match="must be an integer"):
        c.override(**{"train.generations": 1.5})
    with pytest.raises(ConfigError, match="physics.dt"):  # the section checks itself, however it is built
        dataclasses.replace(c.physics, dt=0.0)


@pytest.mark.parametrize("key", ["es.sigma", "es.learning_rate", "physics.dt", "episode.seconds", "regulators.height"])
@pytest.mark.parametrize("value", [0, -1])
def test_non_positive_settings_are_refused(key, value):
    with pytest.raises(ConfigError, match=key):
        config.robot_config("cassie").override(**{key: value})


def test_user_config_file(tmp_path):
    path = tmp_path / "run.yaml"
    path.write_text(yaml.safe_dump({"robot": "cassie", "es": {"population": 64}, "gait": {"step_time": 0.35}}))
    cfg = config.load(path)
    assert cfg.es.population == 64 and cfg.gait.step_time == 0.35 and cfg.es.sigma == 0.1
    path.write_text(yaml.safe_dump({"robot": "cassie", "es": {"populaton": 64}}))
    with pytest.raises(ConfigError, match="populaton"):
        config.load(path)
    path.write_text(yaml.safe_dump({"robot": "bob"}))
    with pytest.raises(ConfigError, match="unknown robot"):
        config.load(path)
    path.write_text("es: [1, 2")
    with pytest.raises(ConfigError, match="not valid YAML"):
        config.load(path)


def test_a_saved_config_round_trips_and_must_be_complete():
    cfg = config.robot_config("cassie")
    saved = config.to_dict(cfg)
    assert saved["version"] == config.VERSION and config.from_dict(json.loads(json.dumps(saved))) == cfg
    del saved["gait"]["step_time"]
    with pytest.raises(ConfigError, match="gait.step_time"):
        config.from_dict(saved)
    with pytest.raises(ConfigError, match="newer"):
        config.from_dict({**config.to_dict(cfg), "version": config.VERSION + 1})


def _version_1(cfg: config.Config) -> dict:
    """`cfg` as version 1 saved it: no version, the desired height under rewards, slope estimation,
    the height over the slope and the mirrored state as settings."""
    data = config.to_dict(cfg)
    del data["version"]
    data["rewards"]["height"] = data["regulators"].pop("height")
    data["regulators"].update(slope_estimation=True, height_over_slope=True)
    data["policy"]["mirror_lateral"] = True
    return data


def test_migration_reads_a_version_1_config_as_it_meant():
    cfg = config.robot_config("cassie")
    assert config.from_dict(_version_1(cfg)) == cfg  # every setting saved: nothing to fill in
    old = _version_1(cfg)
    for section, keys in {"randomization": ("push_force", "push_seconds", "push_after", "push_warmup_generations"),
                          "episode": ("command_change",), "gait": ("first_swing",),
                          "rewards": ("velocity_steps",),
                          "regulators": ("k_height", "k_i_drift_y", "command_rate")}.items():
        for key in keys:
            del old[section][key]
    meant = config.from_dict(old)  # saved before those settings existed: what the code then did
    assert meant.gait.first_swing == "random" and meant.regulators.command_rate == (0.0, 0.0)
    assert meant.randomization.push_force == (0.0, 0.0) and meant.episode.command_change == (0.0, 0.0)
    assert meant.regulators.k_i_drift_y == 0.05 and meant.regulators.k_height == 0.0
    assert meant.rewards.velocity_steps == 1
    assert meant.regulators.height == 0.91
    off = _version_1(cfg)
    off["regulators"]["slope_estimation"] = False
    with pytest.raises(ConfigError, match="slope_estimation"):
        config.from_dict(off)
    unmirrored = _version_1(cfg)
    del unmirrored["policy"]["mirror_lateral"]  # saved before the setting: the state was not mirrored
    with pytest.raises(ConfigError, match="mirror_lateral"):
        config.from_dict(unmirrored)


def test_migration_reads_a_version_4_config_as_starting_at_the_first_command():
    cfg = config.robot_config("digit").override(**{"regulators.start_from_rest": True})
    old = {**config.to_dict(cfg), "version": 4}
    del old["regulators"]["start_from_rest"]  # saved before the setting: the first command at once
    assert config.from_dict(old) == cfg.override(**{"regulators.start_from_rest": False})


def test_migration_reads_a_version_5_config_as_an_unbounded_backward_placement():
    cfg = config.robot_config("cassie").override(**{"regulators.backstep_limit": 0.1})
    old = {**config.to_dict(cfg), "version": 5}
    del old["regulators"]["backstep_limit"]  # saved before the setting: no bound
    assert config.from_dict(old) == cfg.override(**{"regulators.backstep_limit": 0.0})


def test_migration_reads_a_version_6_config_as_a_neutral_point_unbounded_in_speed():
    cfg = config.robot_config("cassie").override(**{"regulators.neutral_vx_max": 0.8})
    old = {**config.to_dict(cfg), "version": 6}
    del old["regulators"]["neutral_vx_max"]  # saved before the setting: no bound
    assert config.from_dict(old) == cfg.override(**{"regulators.neutral_vx_max": 0.0})


def test_migration_reads_a_version_2_config_as_one_without_validation_checks():
    cfg = config.robot_config("cassie").override(**{"train.eval_every": 5})
    old = {**config.to_dict(cfg), "version": 2}
    del old["train"]["eval_every"]
    old["policy"] = {**old["policy"], "mirror_lateral": True}
    # the height regulation measures over the ground under the pelvis: saved as a setting until version 3
    old["regulators"]["height_over_slope"] = True
    assert config.from_dict(old) == cfg.override(**{"train.eval_every": 0})
    over_foot = {**old, "regulators": {**old["regulators"], "height_over_slope": False}}
    with pytest.raises(ConfigError, match="height_over_slope"):
        config.from_dict(over_foot)
    unregulated = {**old, "regulators": {**over_foot["regulators"], "k_height": 0.0}}
    assert config.from_dict(unregulated).regulators.k_height == 0.0  # nothing measured: nothing changes


def test_migration_reads_a_version_3_config_that_mirrored_the_state_and_refuses_one_that_did_not():
    cfg = config.robot_config("cassie")
    old = {**config.to_dict(cfg), "version": 3}
    old["policy"] = {**old["policy"], "mirror_lateral": True}
    assert config.from_dict(old) == cfg
    old["policy"]["mirror_lateral"] = False
    with pytest.raises(ConfigError, match="mirror_lateral false"):
        config.from_dict(old)


def test_the_shipped_policies_records_load_through_the_migration():
    for robot in config.ROBOTS:
        record = json.loads((ROOT / "mjx_cascade" / "policies" / robot / "record.json").read_text())
        assert config.from_dict(record["config"]).robot == robot


@pytest.mark.parametrize("robot", list(config.ROBOTS))
def test_the_shipped_policy_trained_with_exactly_the_robots_config(robot):
    """`mjx-cascade train --robot R` trains what ships: nothing was changed after training."""
    policy_dir = ROOT / "mjx_cascade" / "policies" / robot
    record = json.loads((policy_dir / "record.json").read_text())
    assert config.from_dict(record["config"]) == config.robot_config(robot)
    assert not (policy_dir / "revisions.json").exists()


def test_differences_name_the_changed_keys_in_order():
    a = config.robot_config("cassie")
    b = a.override(**{"es.sigma": 0.05, "gait.step_time": 0.3})
    assert config.differences(a, b) == ["gait.step_time", "es.sigma"]
    assert config.differences(a, a) == []
    assert config.get(b, "es.sigma") == 0.05 and config.get(b, "episode.vx") == [-0.3, 0.8]


@pytest.mark.parametrize("key, value", [("randomization.push_force", [50, 10]), ("randomization.push_force", [-1, 10]),
                                        ("randomization.push_seconds", 0), ("randomization.push_after", [3, 1]),
                                        ("episode.command_change", [3, 1]), ("episode.command_change", [-1, 1]),
                                        ("regulators.command_rate", [-1, 1]), ("regulators.neutral_vx_max", -0.1),
                                        ("randomization.push_warmup_generations", -1),
                                        ("rewards.velocity_steps", 3), ("rewards.velocity_steps", 0),
                                        ("gait.first_swing", "left")])
def test_bad_values_are_refused(key, value):
    with pytest.raises(ConfigError, match=key):
        config.robot_config("cassie").override(**{key: value})


def test_a_trained_policy_may_change_only_its_controller():
    config.check_controller_settings({"regulators.k_phr": 0.4, "gait.first_swing": "command", "physics.dt": 0.0005})
    for key in ("rewards.e_vy", "es.sigma", "gait.bezier_order", "policy.hidden_units"):
        with pytest.raises(ConfigError, match="can change only"):
            config.check_controller_settings({key: 1})


def test_set_assignments_are_parsed_once_for_every_command_line():
    assert config.parse_assignments(["es.sigma=0.05", " episode.vx =[0, 1]"]) == {"es.sigma": "0.05", "episode.vx": "[0, 1]"}
    with pytest.raises(ConfigError, match="KEY=VALUE"):
        config.parse_assignments(["es.sigma"])


def test_auto_says_once_when_mujoco_warp_is_installed_but_jax_runs_on_the_cpu(capsys, monkeypatch):
    """A CPU-only jaxlib beside mujoco-warp (`pip install ".[warp]"` without CUDA JAX) runs
    impl=jax, and says so once on stderr instead of falling back quietly."""
    import importlib.util

    from mjx_cascade import physics

    real = importlib.util.find_spec
    monkeypatch.setattr(physics.importlib.util, "find_spec",
                        lambda name, *a: object() if name == "mujoco_warp" else real(name, *a))
    physics._say_once.cache_clear()
    assert physics.resolve_impl("auto") == "jax" and physics.resolve_impl("auto") == "jax"
    err = capsys.readouterr().err
    assert err.count("mujoco-warp is installed but JAX runs on the CPU") == 1 and "mjx-cascade[gpu]" in err
    with pytest.raises(config.ConfigError, match="needs an NVIDIA GPU"):
        physics.resolve_impl("warp")


def test_the_gpu_extra_brings_cuda_jax_and_mujoco_warp():
    text = (ROOT / "pyproject.toml").read_text()
    gpu = next(line for line in text.splitlines() if line.startswith("gpu = "))
    assert '"jax[cuda12]' in gpu and '"mujoco-warp' in gpu and '"warp-lang' in gpu
