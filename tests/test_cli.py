"""The command line as users and outside checks drive it, in subprocesses."""

import json
import os
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from mjx_cascade import config, rewards

from conftest import DATA, ROOT, benchmark_script, model_for

SMOKE = ["--population", "4", "--episode-seconds", "0.5", "--set", "episode.pool_size=4"]


def cli(*args, timeout=600, env=None):
    return subprocess.run([sys.executable, "-m", "mjx_cascade.cli", *map(str, args)], capture_output=True,
                          text=True, timeout=timeout, env={**os.environ, **(env or {})}, cwd=ROOT)


def start_cli(log, *args):
    """`cli(*args)` in the background, its output in `log.out` and `log.err` (a pipe left unread
    could fill): the running process."""
    with open(f"{log}.out", "w") as out, open(f"{log}.err", "w") as err:
        return subprocess.Popen([sys.executable, "-m", "mjx_cascade.cli", *map(str, args)], stdout=out, stderr=err,
                                cwd=ROOT)


def finished(proc, log):
    """The completed process of `start_cli(log, ...)`, once it is done."""
    proc.wait(timeout=600)
    return subprocess.CompletedProcess(proc.args, proc.returncode, Path(f"{log}.out").read_text(),
                                       Path(f"{log}.err").read_text())


@pytest.mark.parametrize("robot, expect", [("cassie", (4184, 24, 6)), ("digit", (4316, 28, 6))])
def test_info_reports_table_1(robot, expect, request):
    model = model_for(request, robot)
    args = ["info", "--robot", robot, "--json"] + (["--model", model] if model else [])
    out = cli(*args)
    assert out.returncode == 0, out.stderr
    info = json.loads(out.stdout)
    assert (info["policy_params"], info["action_dim"], info["state_dim"]) == expect
    assert info["robot"] == robot and info["dt"] == config.robot_config(robot).physics.dt and len(info["learned_joints"]) == expect[1] // 4


def test_info_names_the_model_from_the_environment_and_none_when_a_required_one_is_missing(digit_model):
    given = cli("info", "--robot", "digit", "--json", env={"DIGIT_MODEL_PATH": str(digit_model)})
    assert given.returncode == 0, given.stderr
    assert json.loads(given.stdout)["model"] == str(digit_model)
    missing = {k: v for k, v in os.environ.items() if k != "DIGIT_MODEL_PATH"}
    none = subprocess.run([sys.executable, "-m", "mjx_cascade.cli", "info", "--robot", "digit", "--json"],
                          capture_output=True, text=True, timeout=600, env=missing, cwd=ROOT)
    assert none.returncode == 0, none.stderr
    assert json.loads(none.stdout)["model"] is None  # Digit has no default model to name
    assert json.loads(cli("info", "--robot", "cassie", "--json").stdout)["model"] == "default"


@pytest.fixture(scope="module")
def smoke(tmp_path_factory):
    """Two generations, then a rerun of the same command with --generations 3 (a resume); both log
    to TensorBoard."""
    out = tmp_path_factory.mktemp("runs") / "smoke"
    first = cli("train", "--robot", "cassie", "--out", out, "--generations", 2, *SMOKE, "--logger", "tensorboard")
    assert first.returncode == 0, first.stderr[-3000:]
    lines_after_first = (out / "metrics.jsonl").read_text().splitlines()
    second = cli("train", "--robot", "cassie", "--out", out, "--generations", 3, *SMOKE, "--logger", "tensorboard")
    assert second.returncode == 0, second.stderr[-3000:]
    return out, lines_after_first, first, second


@pytest.fixture(scope="module")
def after_smoke(smoke, tmp_path_factory):
    """The runs that need only the smoke run start at once, each mostly on one core: `eval` on
    `short.json` alone and batched with `other.json`, and a warm start from the smoke run's
    exported policy. `{name: (out, process)}` (`finished(process, out)` waits for it), and
    `"exported"`: the exported policy."""
    from mjx_cascade import policies

    tmp = tmp_path_factory.mktemp("after_smoke")
    exported = policies.export(smoke[0], tmp / "policy")
    ev = ["eval", "--robot", "cassie", "--checkpoint", smoke[0], "--dt", 0.0005, "--json"]
    runs = {"short": [*ev, "--scenario", DATA / "short.json", "--set", "regulators.k_phr=0.3"],  # the config's own value
            "both": [*ev, "--scenario", DATA / "short.json", DATA / "other.json", "--no-video"],
            "warm": ["train", "--robot", "cassie", "--init", exported, "--generations", 4, *SMOKE],
            # the smoke run's command again, in one go: the same parameters bit for bit
            "again": ["train", "--robot", "cassie", "--generations", 3, *SMOKE],
            # a changed reward setting, accepted: the run goes on with it and records the change
            "changed": ["train", "--robot", "cassie", "--generations", 4, *SMOKE, "--set",
                        "rewards.termination_penalty=10", "--accept-changes"],
            # MJX for the physics, the accelerators' engine, on the CPU's devices
            "mjx": ["train", "--robot", "cassie", "--generations", 2, *SMOKE, "--impl", "jax"]}
    shutil.copytree(smoke[0], tmp / "changed")
    jobs = {name: (tmp / name, start_cli(tmp / name, *args, "--out", tmp / name)) for name, args in runs.items()}
    return {**jobs, "exported": exported}


@pytest.mark.slow
def test_train_writes_checkpoints_and_metrics_then_resumes(smoke):
    out, first_lines, _, second = smoke
    assert len(first_lines) == 2
    lines = [json.loads(line) for line in (out / "metrics.jsonl").read_text().splitlines()]
    assert [r["generation"] for r in lines] == [1, 2, 3]
    for key in ("fitness_mean", "fitness_max", "sigma", "learning_rate", "physics_steps_total", "wall_clock_s",
                "samples_per_s", "diverged", *(f"reward/{term}" for term in rewards.TERMS)):
        assert all(np.isfinite(r[key]) for r in lines), key
    assert any(r["reward/orientation"] < 0 for r in lines)  # the terms are measured, not placeholders
    assert lines[2]["physics_steps_total"] > lines[1]["physics_steps_total"]
    assert "resuming" in second.stderr
    assert "generation 3/3: fitness" in second.stderr  # off a terminal, a line per call
    smoke_cfg = {"train.generations": 3, "es.population": 4, "episode.seconds": 0.5, "episode.pool_size": 4}
    assert config.load(out / "config.yaml") == config.robot_config("cassie").override(**smoke_cfg)
    # every 10 generations by default, and always where a run stops
    assert sorted(p.name for p in (out / "checkpoints").iterdir() if p.name.isdigit()) == ["2", "3"]
    assert (out / "learning_curve.png").stat().st_size > 10_000
    from mjx_cascade import policies

    # Cassie's config steps MuJoCo's C engine, which threads each step over the cores from one device
    assert config.robot_config("cassie").physics.impl == "mujoco" and policies.read(out)[0]["devices"] == 1


@pytest.mark.slow
def test_tensorboard_reads_every_metrics_row_of_a_run_and_its_resume(smoke):
    from tensorboard.backend.event_processing.event_accumulator import EventAccumulator

    out = smoke[0]
    rows = [json.loads(line) for line in (out / "metrics.jsonl").read_text().splitlines()]
    board = EventAccumulator(str(out / "tensorboard"))
    board.Reload()
    assert {"fitness_mean", "sigma", "samples_per_s", *(f"reward/{term}" for term in rewards.TERMS)} <= \
        set(board.Tags()["scalars"])
    for tag in ("fitness_mean", "reward/vx"):
        events = board.Scalars(tag)
        assert [e.step for e in events] == [1, 2, 3]  # one per generation, the resume's included
        np.testing.assert_allclose([e.value for e in events], [r[tag] for r in rows], rtol=1e-6)


@pytest.mark.slow
def test_a_checkpoint_reads_from_a_path_relative_to_the_working_directory(smoke, monkeypatch):
    """As `eval --checkpoint runs/cassie` gives it; orbax's metadata lookup fails on relative paths."""
    from mjx_cascade import checkpoint

    meta, params = checkpoint.read(smoke[0])
    monkeypatch.chdir(smoke[0].parent)
    relative_meta, relative_params = checkpoint.read(smoke[0].name)
    assert relative_meta["generation"] == meta["generation"] == 3
    np.testing.assert_array_equal(relative_params, params)


@pytest.mark.slow
def test_export_writes_a_run_as_a_policy_directory(smoke, tmp_path):
    from mjx_cascade import checkpoint, policies

    dest = policies.export(smoke[0], tmp_path / "policy")
    record = json.loads((dest / "record.json").read_text())
    params = np.load(dest / "params.npz")["params"]
    assert record["generation"] == 3 and record["config"]["robot"] == "cassie"
    assert record["params_sha256"] == checkpoint.params_sha256(params) == checkpoint.params_sha256(checkpoint.read(smoke[0])[1])
    assert len((dest / "metrics.jsonl").read_text().splitlines()) == 3
    assert (dest / "learning_curve.png").stat().st_size > 10_000
    found = policies.load(dest)
    assert found.revisions == [] and found.config == config.from_dict(record["config"])


@pytest.mark.slow
def test_train_warm_starts_from_an_exported_policy_and_counts_on_from_its_generation(after_smoke, tmp_path, capsys):
    from mjx_cascade import checkpoint

    (out, proc), exported = after_smoke["warm"], after_smoke["exported"]  # train --init EXPORTED --generations 4
    res = finished(proc, out)
    assert res.returncode == 0, res.stderr[-3000:]
    assert "warm start" in res.stderr
    lines = [json.loads(line) for line in (out / "metrics.jsonl").read_text().splitlines()]
    assert [r["generation"] for r in lines] == [4]
    assert lines[0]["physics_steps_total"] == lines[0]["physics_steps"]  # this run's steps only
    meta, params = checkpoint.read(out)
    assert meta["init"]["params_sha256"] == checkpoint.params_sha256(np.load(exported / "params.npz")["params"])
    assert meta["init"]["generation"] == 3
    start = np.load(exported / "params.npz")["params"]
    assert 0 < np.max(np.abs(params - start)) < 0.1  # one step from the exported policy, not from scratch
    # a rerun resumes its own checkpoint and keeps the record of where it started
    res = cli("train", "--robot", "cassie", "--out", out, "--init", exported, "--generations", 5, *SMOKE)
    assert res.returncode == 0 and "resuming" in res.stderr, res.stderr[-3000:]
    assert checkpoint.read(out)[0]["init"] == meta["init"]
    # nothing left to train is refused before anything is written (in this process: no interpreter start)
    code, err = _main(["train", "--robot", "cassie", "--out", tmp_path / "none", "--init", exported,
                       "--generations", 3, *SMOKE], capsys)
    assert code == 2 and "nothing to train" in err and not (tmp_path / "none").exists()


@pytest.mark.slow
def test_training_in_mjx_shares_the_population_over_one_device_per_core(after_smoke):
    """`--impl jax` without `--cpu-devices`: one JAX device per core (two on a 2-core CPU), recorded
    with the run, and the generations score real episodes."""
    from mjx_cascade import _xla, policies

    out, proc = after_smoke["mjx"]
    res = finished(proc, out)
    assert res.returncode == 0, res.stderr[-3000:]
    assert policies.read(out)[0]["devices"] == _xla.cpu_devices("auto", population=4)
    assert config.load(out / "config.yaml").physics.impl == "jax"
    rows = [json.loads(line) for line in (out / "metrics.jsonl").read_text().splitlines()]
    assert [r["generation"] for r in rows] == [1, 2]
    assert all(np.isfinite(r["fitness_mean"]) and r["physics_steps"] > 0 for r in rows)
    assert any(r["reward/orientation"] < 0 for r in rows)


@pytest.mark.slow
def test_a_second_run_of_the_same_command_reproduces_the_exported_policy_bit_for_bit(after_smoke, tmp_path):
    """What `benchmarks/reproduce.py` checks for the shipped policies, on the smoke run: every metrics
    row but the timing, and the final parameters, though the smoke run stopped and resumed."""
    (out, proc), exported = after_smoke["again"], after_smoke["exported"]
    res = finished(proc, out)
    assert res.returncode == 0, res.stderr[-3000:]
    reproduce = benchmark_script("reproduce")
    same = reproduce.compare(out, exported)
    assert same["identical"] and same["generations_compared"] == 3 and same["params"]["equal"], same
    # one changed bit in a logged figure is found, and named
    rows = [json.loads(line) for line in (out / "metrics.jsonl").read_text().splitlines()]
    rows[1]["fitness_mean"] = float(np.nextafter(np.float32(rows[1]["fitness_mean"]), np.float32(np.inf)))
    changed = tmp_path / "changed"
    shutil.copytree(out, changed)
    (changed / "metrics.jsonl").write_text("".join(json.dumps(r) + "\n" for r in rows))
    differs = reproduce.compare(changed, exported)
    assert not differs["identical"] and differs["first_difference"]["generation"] == 2
    assert differs["first_difference"]["field"] == "fitness_mean"
    assert reproduce.main([str(changed), "--policy", str(exported), "--out", str(tmp_path / "r.json")]) == 1
    assert json.loads((tmp_path / "r.json").read_text())["first_difference"]["generation"] == 2


@pytest.fixture(scope="module")
def short_eval(after_smoke):
    """`eval` of the smoke run on `short.json`: `(out, completed process)`."""
    out, proc = after_smoke["short"]
    res = finished(proc, out)
    assert res.returncode == 0, res.stderr[-3000:]
    return out, res


@pytest.mark.slow
def test_eval_writes_trajectory_metrics_and_plots(short_eval):
    out, res = short_eval
    traj = np.load(out / "trajectory.npz")
    t = traj["t"]
    assert np.max(np.diff(t)) <= 0.01 + 1e-9 and t[-1] == pytest.approx(0.3, abs=0.011)
    assert traj["qpos"].shape == (len(t), 35) and traj["qvel"].shape == (len(t), 32)
    assert traj["cmd"].shape == (len(t), 3)
    np.testing.assert_allclose(traj["cmd"][t < 0.14][:, 0], 0.2)
    np.testing.assert_allclose(traj["cmd"][t > 0.16][:, 1:], [[0.1, 0.1]] * int(np.sum(t > 0.16)))
    metrics = json.loads((out / "metrics.json").read_text())
    assert set(metrics) >= {"fell", "segments", "passed", "policy"}
    assert json.loads(res.stdout)["policy"]["generation"] == 3
    assert metrics["policy"]["settings"] == {"regulators.k_phr": "0.3"}  # what --set changed, as given
    assert metrics["policy"]["revisions"] == []  # a run's checkpoint runs as it trained
    progress = [line for line in res.stderr.splitlines() if line.startswith("eval: ")]
    assert progress[0] == "eval: batch 1/1: 1 scenario on the plane (short)"
    assert len(progress) == 11 and progress[-1] == "eval: 100% (0.3 of 0.3 s simulated)"  # a line per tenth
    for png in ("tracking.png", "limit_cycles.png"):
        assert (out / png).stat().st_size > 10_000


@pytest.mark.slow
def test_eval_runs_several_scenarios_in_one_batch_as_each_runs_alone(after_smoke, short_eval):
    """A scenario starts in a batch as it would alone, and a shorter one is cut to its own length.
    (The batch is test_benchmarks.py's: its program is already in the compilation cache.)"""
    both, proc = after_smoke["both"]  # eval --scenario short.json other.json --no-video
    res = finished(proc, both)
    assert res.returncode == 0, res.stderr[-3000:]
    names = [m["scenario"]["name"] for m in json.loads(res.stdout)]
    assert names == ["short", "other"]
    summary = json.loads((both / "summary.json").read_text())
    assert [s["scenario"] for s in summary["scenarios"]] == names
    assert summary["passed"] == sum(s["passed"] for s in summary["scenarios"]) and summary["dt"] == 0.0005
    assert all(s["worst"] == {"vx": None, "vy": None, "yaw": None} for s in summary["scenarios"])  # none judged
    batched, alone = np.load(both / "short" / "trajectory.npz"), np.load(short_eval[0] / "trajectory.npz")
    np.testing.assert_array_equal(batched["t"], alone["t"])
    np.testing.assert_array_equal(batched["cmd"], alone["cmd"])
    np.testing.assert_allclose(batched["qpos"], alone["qpos"], atol=1e-4)
    t = np.load(both / "other" / "trajectory.npz")["t"]
    assert t[-1] == pytest.approx(0.2, abs=0.011) and len(t) < len(alone["t"])


def _bad_scenario(tmp_path, text):
    path = tmp_path / f"scenario{len(list(tmp_path.glob('scenario*.json')))}.json"
    path.write_text(text if isinstance(text, str) else json.dumps(text))
    return path


GOOD = {"duration": 5, "commands": [{"t": 0, "vx": 0.2, "vy": 0, "yaw": 0}]}


def _with(**change):
    return {**GOOD, **change}


def bad_inputs(tmp_path):
    ckpt_free = tmp_path / "not_a_checkpoint"
    ckpt_free.mkdir()
    (ckpt_free / "notes.txt").write_text("hello")
    cfg = tmp_path / "typo.yaml"
    cfg.write_text("robot: cassie\nes:\n  sigmma: 0.1\n")
    scen = lambda data: _bad_scenario(tmp_path, data)  # noqa: E731
    train = ["train", "--robot", "cassie", "--out"]
    ev = lambda path: ["eval", "--robot", "cassie", "--checkpoint", ckpt_free, "--scenario", path, "--out"]  # noqa: E731
    return [
        (["train", "--robot", "robo", "--out"], "invalid choice"),
        (["train", "--config", cfg, "--out"], "sigmma"),
        (train[:3] + ["--set", "es.sigmma=0.1", "--out"], "sigmma"),
        (train[:3] + ["--population", "5", "--out"], "es.population"),
        (train[:3] + ["--population", "0", "--out"], "es.population"),
        (train[:3] + ["--set", "es.sigma=0", "--out"], "es.sigma"),
        (train[:3] + ["--set", "es.learning_rate=-0.1", "--out"], "es.learning_rate"),
        (train[:3] + ["--set", "physics.dt=0", "--out"], "physics.dt"),
        (train[:3] + ["--episode-seconds", "0", "--out"], "episode.seconds"),
        (train[:3] + ["--eval-every", "-1", "--out"], "train.eval_every"),
        (train[:3] + ["--logger", "tensorboard,mlflow", "--out"], "unknown logger 'mlflow'"),
        (train[:3] + ["--cpu-devices", "0", "--out"], "--cpu-devices takes a positive count or auto"),
        (train[:3] + ["--cpu-devices", "3", "--population", "4", "--out"], "multiple of the 3 devices"),
        (["train", "--robot", "digit", "--cpu-devices", "2", "--out"], "at most 1 CPU device"),
        (["train", "--robot", "digit", "--model", tmp_path / "missing.xml", "--out"], "not found"),
        (["train", "--robot", "digit", "--model", ROOT.parent / "shared/menagerie/agility_cassie/cassie.xml", "--out"],
         "not a digit model"),
        (ev(scen("{oops")), "not valid JSON"),
        (ev(scen(_with(colour="red"))), "unknown key 'colour'"),
        (ev(scen(_with(duration=-1))), "duration must be positive"),
        (ev(scen(_with(commands=[{"t": 1, "vx": 0, "vy": 0, "yaw": 0}]))), "t = 0"),
        (ev(scen(_with(commands=[{"t": 0, "vx": 0, "vy": 0, "yaw": 0}, {"t": 0, "vx": 0, "vy": 0, "yaw": 0}]))),
         "increase"),
        (ev(scen(_with(terrain={"type": "ice"}))), "unknown terrain"),
        (ev(scen(_with(pushes=[{"t": 1, "duration": -1, "force": [1, 0, 0]}]))), "duration must be >= 0"),
        (ev(scen(GOOD)), "not a checkpoint"),
        (["eval", "--robot", "cassie", "--checkpoint", ckpt_free, "--scenario", scen(GOOD), "--dt", "0", "--out"],
         "--dt"),
        (["eval", "--robot", "cassie", "--scenario", scen(_with(name="same")), scen(_with(name="same")), "--out"],
         "names must differ"),
        (train[:3] + ["--init", tmp_path / "missing", "--out"], "not a checkpoint"),
        (train[:3] + ["--init", ckpt_free, "--out"], "not a checkpoint"),
        (["info", "--checkpoint", ckpt_free], "not a checkpoint"),
        (["robustness", "--robot", "cassie", "--axes", "push", "wind", "--out"], "unknown sweep axis 'wind'"),
        (["robustness", "--robot", "cassie", "--dt", "-1", "--out"], "--dt"),
        (["robustness", "--robot", "cassie", "--axes", "push", "--push-directions", "up", "--out"],
         "unknown push direction 'up'"),
        (["robustness", "--robot", "cassie", "--axes", "push", "--push-forces", "-50", "--out"], "push forces must be"),
        (["robustness", "--robot", "cassie", "--axes", "mass", "--push-directions", "left", "--out"], "need the push axis"),
        # an evaluation changes only the controller and physics the policy runs in
        (["eval", "--robot", "cassie", "--scenario", scen(GOOD), "--set", "rewards.e_vy=0.1", "--out"],
         "can change only"),
        (["eval", "--robot", "cassie", "--scenario", scen(GOOD), "--set", "gait.bezier_order=4", "--out"],
         "gait.bezier_order"),
        (["eval", "--robot", "cassie", "--scenario", scen(GOOD), "--set", "gait.first_swing=sideways", "--out"],
         "gait.first_swing"),
        (["eval", "--robot", "cassie", "--scenario", scen(GOOD), "--set", "regulators.k_phr", "--out"], "KEY=VALUE"),
        (["robustness", "--robot", "cassie", "--set", "policy.hidden_units=16", "--out"], "can change only"),
    ]


def test_eval_settings_change_the_controller_of_the_same_parameters():
    """`eval --set` measures a controller setting on a trained policy without retraining it."""
    from mjx_cascade import config, evaluate

    base, found = evaluate.load_policy("cassie", None, dt=0.0005)
    cfg, changed = evaluate.load_policy("cassie", None, dt=0.0005,
                                        settings={"regulators.k_phr": "0.45", "gait.first_swing": "command"})
    assert cfg.regulators.k_phr == 0.45 and cfg.gait.first_swing == "command" and cfg.physics.dt == 0.0005
    np.testing.assert_array_equal(changed.params, found.params)
    undone = cfg.override(**{"regulators.k_phr": base.regulators.k_phr, "gait.first_swing": base.gait.first_swing})
    assert config.to_dict(undone) == config.to_dict(base)  # nothing else moved
    # the physics flags win over --set, and --set alone reaches the physics
    flags, _ = evaluate.load_policy("cassie", None, dt=0.0005, impl="jax",
                                    settings={"physics.dt": "0.001", "physics.impl": "warp"})
    assert flags.physics.dt == 0.0005 and flags.physics.impl == "jax"
    alone, _ = evaluate.load_policy("cassie", None, settings={"physics.impl": "jax", "physics.dt": "0.002"})
    assert alone.physics.impl == "jax" and alone.physics.dt == 0.002


def _main(args, capsys):
    """`mjx-cascade ARGS` in this process: (exit code, stderr)."""
    from mjx_cascade.cli import main

    try:
        code = main([str(a) for a in args])
    except SystemExit as e:  # argparse's own errors
        code = e.code
    return code, capsys.readouterr().err


def test_bad_input_is_one_line_exit_2_and_writes_nothing(tmp_path, capsys):
    cases = bad_inputs(tmp_path)
    # the first case through the installed entry point, the rest in-process (no interpreter start each)
    args, message = cases[0]
    res = cli(*args, tmp_path / "out0")
    assert res.returncode == 2 and len(res.stderr.strip().splitlines()) == 1 and message in res.stderr, res.stderr
    for i, (args, message) in enumerate(cases[1:], 1):
        out = tmp_path / f"out{i}"
        code, err = _main([*args, *([out] if args[-1] == "--out" else [])], capsys)
        lines = err.strip().splitlines()
        assert code == 2, (args, err[-2000:])
        assert len(lines) == 1 and message in lines[0], (args, err)
        assert not out.exists(), args


@pytest.mark.slow
def test_a_resume_with_a_changed_setting_is_refused_in_one_line_and_writes_nothing(smoke, capsys):
    out = smoke[0]
    before = {p.name: p.stat().st_mtime_ns for p in out.rglob("*")}
    code, err = _main(["train", "--robot", "cassie", "--out", out, "--generations", 5, *SMOKE,
                       "--set", "es.sigma=0.05", "--set", "gait.step_time=0.3",
                       "--set", "train.checkpoint_every=7"], capsys)
    assert code == 2 and len(err.strip().splitlines()) == 1, err
    assert "gait.step_time (0.35 -> 0.3), es.sigma (0.1 -> 0.05)" in err and "--accept-changes" in err
    assert "checkpoint_every" not in err  # how a run is checkpointed may change on resume
    assert {p.name: p.stat().st_mtime_ns for p in out.rglob("*")} == before


@pytest.mark.slow
def test_accept_changes_resumes_with_the_new_setting_and_records_it(after_smoke):
    from mjx_cascade import checkpoint

    out, proc = after_smoke["changed"]
    res = finished(proc, out)
    assert res.returncode == 0, res.stderr[-3000:]
    assert "changed settings: rewards.termination_penalty" in res.stderr
    meta, _ = checkpoint.read(out)
    assert meta["generation"] == 4 and meta["config"]["rewards"]["termination_penalty"] == 10.0
    assert meta["config_changes"] == [{"generation": 3, "changes": {"rewards.termination_penalty": [20.0, 10.0]}}]


@pytest.mark.slow
def test_checkpoints_for_another_robot_or_policy_are_refused(smoke, tmp_path, digit_model):
    out = smoke[0]
    before = sorted(p.name for p in (out / "checkpoints").iterdir())
    res = cli("train", "--robot", "cassie", "--out", out, "--generations", 4, *SMOKE, "--set", "policy.hidden_units=16")
    assert res.returncode == 2 and "parameters" in res.stderr and len(res.stderr.strip().splitlines()) == 1
    assert sorted(p.name for p in (out / "checkpoints").iterdir()) == before
    res = cli("eval", "--robot", "digit", "--model", digit_model, "--checkpoint", out,
              "--scenario", DATA / "short.json", "--out", tmp_path / "e")
    assert res.returncode == 2 and "for robot 'cassie'" in res.stderr and not (tmp_path / "e").exists()


def test_cpu_devices_split_the_cpu_before_jax_starts():
    """`--cpu-devices` sets XLA's host device count, replacing one given in XLA_FLAGS."""
    from mjx_cascade import _xla

    script = "from mjx_cascade import _xla; _xla.split_cpu(2); import jax; print(len(jax.devices()))"
    res = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True, timeout=120,
                         env={**os.environ, "XLA_FLAGS": "--xla_force_host_platform_device_count=4"})
    assert res.returncode == 0 and res.stdout.strip() == "2", res.stderr[-2000:]
    assert _xla.cpu_devices("auto") == len(os.sched_getaffinity(0)) and _xla.cpu_devices("3") == 3
    with pytest.raises(RuntimeError, match="before any JAX work"):  # this process has started JAX
        import jax

        jax.devices()
        _xla.split_cpu(2)


def test_auto_takes_the_most_cores_that_share_the_population_and_the_robot_allows(monkeypatch):
    from mjx_cascade import _xla

    monkeypatch.setattr(os, "sched_getaffinity", lambda pid: set(range(16)))
    assert _xla.cpu_devices("auto", population=24) == 12  # 16 cores, but 24 splits into 12
    assert _xla.cpu_devices("auto", population=24, limit=1) == 1  # Digit
    assert _xla.cpu_devices("auto", population=7) == 7 and _xla.cpu_devices("auto", population=17) == 1
    monkeypatch.setattr(os, "sched_getaffinity", lambda pid: {0, 1})
    assert _xla.cpu_devices("auto", population=24) == 2 and _xla.cpu_devices("auto", population=3) == 1
    assert _xla.cpu_devices("5", population=24) == 5  # a count given is the user's; check_devices refuses it
    from mjx_cascade import train

    cassie = config.robot_config("cassie")  # MuJoCo's C engine, which threads each step itself
    assert train.cpu_device_count(cassie) == 1 and train.cpu_device_count(config.robot_config("digit")) == 1
    assert train.cpu_device_count(cassie.override(**{"physics.impl": "jax"})) == 2


def test_version_and_help_for_every_option_with_examples_per_command():
    from mjx_cascade import cli as cli_lib

    res = cli("--version")
    assert res.returncode == 0 and res.stdout.strip() == f"mjx-cascade {__import__('mjx_cascade').__version__}"
    parser = cli_lib.build_parser()
    commands = next(a for a in parser._actions if a.dest == "command").choices
    assert set(commands) == {"info", "train", "eval", "robustness", "benchmark", "revise", "export", "sim2sim", "play"}
    for name, sub in commands.items():
        assert "examples:" in sub.epilog and f"mjx-cascade {name}" in sub.epilog, name
        for action in sub._actions:
            assert action.help, (name, action.dest)
    train_help = commands["train"].format_help()
    assert "(default cassie 320, digit 120)" in " ".join(train_help.split())  # defaults from the configs


def test_a_shipped_scenario_is_named_from_any_directory(tmp_path, monkeypatch):
    from mjx_cascade import scenario

    monkeypatch.chdir(tmp_path)
    assert scenario.load("speed_profile") == scenario.load(ROOT / "configs" / "scenarios" / "speed_profile.json")
    with pytest.raises(config.ConfigError, match="shipped scenarios: limit_cycle, push"):
        scenario.load("speed_profil")


def test_eval_takes_the_robot_from_the_checkpoint_and_runs_at_the_papers_step(tmp_path, digit_model):
    import argparse

    from mjx_cascade import cli as cli_lib, policies

    def resolved(**given):
        args = argparse.Namespace(**{"robot": None, "checkpoint": None, "dt": None, "set": [], "model": None,
                                     "out": tmp_path / "out", **given})
        cli_lib._simulation_args(args)
        return args

    args = resolved(checkpoint=str(policies.shipped("digit")), model=digit_model)
    assert args.robot == "digit" and args.dt == config.PAPER_DT == 0.0005
    assert resolved(robot="cassie", set=["physics.dt=0.002"]).dt is None  # --set decides it
    assert resolved(robot="cassie", dt=0.001).dt == 0.001
    with pytest.raises(config.ConfigError, match="--robot, or a --checkpoint"):
        resolved()
