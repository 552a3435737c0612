"""The benchmark scripts, run tiny on the CPU: what they report is what they measured."""

import json

import jax
import numpy as np
import pytest

from conftest import DATA, ROOT, benchmark_script
from mjx_cascade import benchmark, checkpoint, cli, config, evaluate, policies, policy, profiles, scenario, train

pytestmark = pytest.mark.slow


# the CLI smoke run's settings and its batched eval (test_cli.py), so training and the checks
# compile once for both
SMOKE = {"es.population": 4, "episode.seconds": 0.5}
EVAL_DT = 0.0005


def _short_scenarios():
    return [scenario.load(DATA / "short.json"), scenario.load(DATA / "other.json")]


def test_time_to_walk_checks_the_bar_on_the_trained_mean(cassie_cfg, monkeypatch, tmp_path):
    ttw = benchmark_script("time_to_walk")
    cfg = cassie_cfg.override(**SMOKE)
    assert cfg.physics.dt > EVAL_DT  # so each check screens at the training step first
    stages, check = [], evaluate.check

    def recorded(runners, params, stop_at_miss=False):
        results = check(runners, params, stop_at_miss)
        stages.append((runners[0].env.dt, all(r["passed"] is True for r in results.values())))
        return results

    monkeypatch.setattr(evaluate, "check", recorded)
    result = ttw.time_to_walk(cfg, _short_scenarios(), dt=EVAL_DT, check_every=2, max_generations=3,
                              max_seconds=600.0, log=lambda m: None)
    # each check screens at the training step, and runs the bar's step only after a screen passed all
    assert result["screen_dt"] == cfg.physics.dt and stages[0][0] == cfg.physics.dt
    for (dt, passed), after in zip(stages, stages[1:]):
        assert after[0] == (EVAL_DT if dt == cfg.physics.dt and passed else cfg.physics.dt)
    deciding = ["bar" if dt == EVAL_DT else "screen" for dt, passed in stages if dt == EVAL_DT or not passed]
    assert [c["stage"] for c in result["checks"]] == deciding
    # 0.3 s from a balanced stand: the untrained mean stays up, so the bar ran and decided the run
    assert result["checks"][-1]["stage"] == "bar" and stages[-1][0] == EVAL_DT
    # checks at generation 2 and at the limit (3); stops early only on a pass
    assert [c["generation"] for c in result["checks"]] in ([2], [2, 3])
    assert result["generations"] == result["checks"][-1]["generation"]
    assert result["passed"] == result["checks"][-1]["passed"]
    assert result["physics_steps"] > 0 and min(result[k] for k in ("compile_s", "training_s", "check_s")) > 0
    # the wall-clock counts everything: compiling, training and the checks
    parts = result["compile_s"] + result["training_s"] + result["check_s"]
    assert result["wall_clock_s"] == pytest.approx(parts) and result["checks"][-1]["wall_clock_s"] <= result["wall_clock_s"]
    # the check's verdict is the evaluator's, from the trajectory alone: scenarios under 4 s have
    # no segment long enough to judge, so each passes exactly when the robot stays up
    checks = result["checks"][-1]["scenarios"]
    assert set(checks) == {"short", "other"}
    for check in checks.values():  # a check stops at a miss: the scenarios undecided by then are unjudged
        assert check["segments"] == [] and check["passed"] in ((not check["fell"]), None)
    assert result["cpu"] and result["cores"] >= 1  # which machine the wall-clock is of
    json.dumps(result)  # what the script writes


def test_a_check_stopped_at_a_fall_gives_the_full_checks_verdict_for_a_fraction_of_the_simulation():
    """`stop_at_miss`: the simulation ends after the tenth in which a scenario fell (a miss; for a
    segment out of bounds, tests/test_evaluate.py); that fall is the full run's, the trajectories are
    its prefix, and scenarios still standing are left unjudged."""
    found = policies.load("cassie")
    # MuJoCo's C engine, the time-to-walk checks' simulator on a CPU, compiles in a fraction of MJX's time
    cfg = found.config.override(**{"physics.impl": "mujoco", "physics.dt": EVAL_DT, "episode.pool_size": 4})
    kick = scenario.parse({"name": "kick", "duration": 1.0, "commands": [{"t": 0.0, "vx": 0.3, "vy": 0.0, "yaw": 0.0}],
                                        "pushes": [{"t": 0.05, "duration": 0.1, "force": [0.0, 1500.0, 0.0]}]})
    calm = scenario.parse({"name": "calm", "duration": 1.0, "commands": [{"t": 0.0, "vx": 0.3, "vy": 0.0, "yaw": 0.0}]})
    runners = [evaluate.Runner(cfg, [kick, calm])]
    full = evaluate.check(runners, found.params)
    assert full["kick"]["fell"] and full["calm"]["passed"]
    stopped = evaluate.check(runners, found.params, stop_at_miss=True)
    assert stopped["kick"] == full["kick"]
    assert stopped["calm"] == {"passed": None, "fell": False, "fall_time": None, "segments": []}
    short, whole = runners[0](found.params, stop_at_miss=True), runners[0](found.params)
    n = len(short[0]["t"])
    assert n < len(whole[0]["t"]) and n >= full["kick"]["fall_time"] / evaluate.RECORD_PERIOD
    np.testing.assert_array_equal(short[1]["qpos"], whole[1]["qpos"][:n])
    # with no fall it runs to the end and judges everything, as the full check
    assert evaluate.check([evaluate.Runner(cfg, [calm])], found.params, stop_at_miss=True)["calm"] == full["calm"]


def test_runner_takes_the_policy_as_an_argument(cassie_cfg):
    """One compiled simulation serves every policy (the time-to-walk checks rely on it)."""
    cfg = cassie_cfg.override(**SMOKE, **{"physics.dt": EVAL_DT})  # the time-to-walk test's checks
    run = evaluate.Runner(cfg, _short_scenarios())
    params = policy.for_controller(cfg, 6, jax.random.PRNGKey(0)).init_params
    other = np.asarray(params) + np.random.default_rng(0).normal(0.0, 0.5, params.shape).astype(np.float32)
    a, b = run(np.asarray(params))[0], run(other)[0]
    assert a["qpos"].shape == b["qpos"].shape and not np.allclose(a["qpos"], b["qpos"])


def _stand_in_time_to_walk(monkeypatch, ttw) -> dict:
    """`ttw.main` with its training replaced: what it would train and check, and the CPU split it
    asks for as on a fresh process, go into the returned dict."""
    seen = {}

    def fake(cfg, scenarios, dt, *args, **kwargs):
        seen.update(cfg=cfg, names=[s.name for s in scenarios], dt=dt)
        return {k: 0 for k in ("device", "impl", "devices", "wall_clock_s", "compile_s", "training_s", "check_s",
                               "physics_steps", "generations", "passed")}

    monkeypatch.setattr(ttw, "time_to_walk", fake)
    monkeypatch.setattr(ttw._xla, "cpu_split_given", lambda: False)
    monkeypatch.setattr(ttw._xla, "cpu_backend_started", lambda: False)
    monkeypatch.setattr(ttw._xla, "split_cpu", lambda n: seen.setdefault("split", n))
    return seen


def test_time_to_walk_checks_the_robots_val_profiles_by_default(monkeypatch, tmp_path):
    """With no --scenario the stopping check is the val set that chooses checkpoints; the CPU is
    split as `mjx-cascade train` splits it."""
    ttw = benchmark_script("time_to_walk")
    seen = _stand_in_time_to_walk(monkeypatch, ttw)
    assert ttw.main(["--robot", "cassie", "--out", str(tmp_path / "t.json")]) == 0
    assert seen["names"] == [s.name for s in profiles.resolve("cassie", "val")] and len(seen["names"]) == 20
    assert seen["split"] == train.cpu_device_count(config.robot_config("cassie"))
    assert json.loads((tmp_path / "t.json").read_text())["command"].endswith("--robot cassie --out " + str(tmp_path / "t.json"))


def test_time_to_walk_trains_the_cpu_recipe_from_its_config_file(monkeypatch, tmp_path):
    """`--config configs/cassie_cpu.yaml`: Cassie's config without the settings that hold strong
    pushes, in the C engine at a 2-ms step, judged on Cassie's val profiles at the bar's step, on one
    JAX device (the engine threads each step itself)."""
    ttw = benchmark_script("time_to_walk")
    seen = _stand_in_time_to_walk(monkeypatch, ttw)
    assert ttw.main(["--config", str(ROOT / "configs" / "cassie_cpu.yaml"), "--out", str(tmp_path / "t.json")]) == 0
    cfg = seen["cfg"]
    assert (cfg.robot, cfg.physics.impl, cfg.physics.dt, seen["dt"], seen["split"]) == ("cassie", "mujoco", 0.002, 0.0005, 1)
    # everything else is the shipped Cassie config
    shipped = config.to_dict(config.robot_config("cassie"))
    shipped["regulators"].update(backstep_limit=0.0, neutral_vx_max=0.0)
    shipped["randomization"].update(push_warmup_generations=220)
    assert config.to_dict(cfg) == shipped
    assert seen["names"] == [s.name for s in profiles.resolve("cassie", "val")]


def test_the_walking_benchmark_writes_the_bars_verdicts_with_their_provenance(tmp_path, capsys):
    """The shipped-policy test's walk (its program is in the compilation cache), through the command line."""
    out = tmp_path / "walking.json"
    assert cli.main(["benchmark", "walking", "--robot", "cassie", "--scenario", str(DATA / "walk_short.json"),
                     "--out", str(out)]) == 0
    result = json.loads(out.read_text())
    assert result["count"] == 1 and result["dt"] == EVAL_DT and result["code_version"] != ""
    assert result["set"] == "scenarios" and result["robot"] == "cassie"
    line = result["scenarios"][0]
    assert line["scenario"] == "walk_short" and result["passed"] == int(line["passed"])
    assert 0 < line["worst"]["vx"] < 0.1
    shipped = policies.load("cassie")
    assert result["policy"]["params_sha256"] == checkpoint.params_sha256(shipped.params)
    assert result["policy"]["revisions"] == [r["settings"] for r in shipped.revisions]
    assert result["response"] == benchmark.response(result["scenarios"])
    said = capsys.readouterr().err  # progress, as eval's: the batch, then each tenth simulated
    assert "benchmark: batch 1/1: 1 scenario on the plane (walk_short)" in said
    assert said.count("benchmark: ") == 11 and "100% (10 of 10 s simulated)" in said


def test_throughput_reports_each_rate_it_measured_with_its_provenance(tmp_path, monkeypatch):
    """Two environments for five steps: every rate is a measured positive number, and the file says
    what code and packages ran."""
    tp = benchmark_script("throughput")
    monkeypatch.setattr(tp.os, "cpu_count", lambda: 2)  # MuJoCo C on two threads, as on CI
    out = tmp_path / "tp.json"
    assert tp.main(["--robot", "cassie", "--out", str(out), "--batch", "2", "--steps", "5",
                    "--set", "episode.pool_size=4"]) == 0
    result = json.loads(out.read_text())
    assert result["backend"] == jax.default_backend() and result["steps"] == 5 and result["code_version"]
    assert result["versions"]["mujoco"] and result["date"]
    (row,) = result["rows"]
    assert row["impl"] == "jax" and row["batch"] == 2
    assert 0 < row["controller_steps_per_s"] and 0 < row["physics_steps_per_s"]
    assert result["cpu_mujoco_steps_per_s"] > 0 and result["cpu_cores"] == 2
    assert row["controller_vs_cpu_mujoco"] == row["controller_steps_per_s"] / result["cpu_mujoco_steps_per_s"]


def test_the_c_engines_host_rate_is_its_host_step_timed(cassie_cfg):
    """`engine_host_rate` steps the engine's host side from the standing pool, each output fed back:
    the state moves, and the rate is the batch's steps over the measured time."""
    import types

    from mjx_cascade import physics, robots

    tp = benchmark_script("throughput")
    robot = robots.build(robots.get("cassie"), cassie_cfg.override(**{"physics.impl": "mujoco"}).physics)
    engine = physics.CEngine(robot.model, threads=1)
    calls = []
    host_step = engine._host_step
    engine._host_step = lambda packed, terrain=None: calls.append(packed[:, engine.inputs["qpos"]].copy()) or host_step(packed, terrain)
    env = types.SimpleNamespace(pool_qpos=robot.model.qpos0[None], pool_qvel=np.zeros((1, robot.model.nv)))
    assert tp.engine_host_rate(engine, env, batch=2, steps=3) > 0
    assert len(calls) == 3 * 4  # a warm-up and three timed runs of three steps
    assert not np.array_equal(calls[0], calls[2])  # each step starts where the last one ended
