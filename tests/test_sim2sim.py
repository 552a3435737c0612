"""The policy outside the trainer: a bundle run by `sim2sim` in MuJoCo C, and `play`'s loop."""

import contextlib
import json

import numpy as np
import pytest

from conftest import DATA
from mjx_cascade import cli, evaluate, play, robots, runtime, scenario
from mjx_cascade.physics import mjx

# what eval's trajectory.npz holds (`evaluate.Runner`)
EVAL_KEYS = {"t", "qpos", "qvel", "cmd", "force", "ground", "stance", "dt", "joints", "joint_qpos", "joint_qvel"}


def _main(args, capsys):
    code = cli.main([str(a) for a in args])
    return code, capsys.readouterr()


def _no_mjx(monkeypatch):
    def refuse(*_, **__):
        raise AssertionError("MJX ran")

    for name in ("put_model", "make_data", "forward", "step"):
        monkeypatch.setattr(mjx, name, refuse)


@pytest.mark.slow
def test_sim2sim_runs_an_exported_bundle_in_mujoco_c_into_evals_files(tmp_path, capsys, monkeypatch):
    """export -> sim2sim with every MJX entry point disabled: eval's trajectory.npz, metrics.json
    and plots, the scenario's commands and push at their times, judged by the walking bar."""
    code, _ = _main(["export", "--robot", "cassie", "--out", tmp_path / "bundle"], capsys)
    assert code == 0
    _no_mjx(monkeypatch)
    code, out = _main(["sim2sim", "--bundle", tmp_path / "bundle", "--scenario", DATA / "short.json",
                       "--out", tmp_path / "run", "--dt", "0.0005", "--no-video"], capsys)
    assert code == 0, out.err
    assert "cassie / short: passed" in out.out and "sim2sim: scenario 1/1: short" in out.err
    assert "sim2sim: 50% (0.15 of 0.3 s simulated)" in out.err and "sim2sim: 100% (0.3 of 0.3 s simulated)" in out.err
    traj = dict(np.load(tmp_path / "run" / "trajectory.npz"))
    assert set(traj) == EVAL_KEYS
    s = scenario.load(DATA / "short.json")
    assert len(traj["t"]) == 30 and np.allclose(traj["t"], 0.01 * np.arange(1, 31)) and traj["dt"] == 0.0005
    assert np.array_equal(traj["cmd"], s.command_schedule(traj["t"] - 0.0005))
    pushed = traj["force"][:, 0] > 0
    # each record holds its last physics step's force: the steps starting in [0.1, 0.15) s
    assert np.array_equal(np.nonzero(pushed)[0], np.arange(10, 15))
    assert traj["qpos"].shape[0] == traj["qvel"].shape[0] == 30
    metrics = json.loads((tmp_path / "run" / "metrics.json").read_text())
    assert metrics["policy"]["simulator"].startswith("MuJoCo") and not metrics["fell"]
    assert (tmp_path / "run" / "tracking.png").stat().st_size > 10_000


class StandInViewer:
    """The methods `play.run` calls on `mujoco.viewer.Handle`."""

    def __init__(self):
        self.texts, self.syncs = [], 0

    def is_running(self):
        return True

    def lock(self):
        return contextlib.nullcontext()

    def set_texts(self, texts):
        self.texts.append(texts)

    def sync(self):
        self.syncs += 1


@pytest.mark.slow
def test_play_walks_where_the_keys_steer_and_resets():
    """`play.run` for 3 s of simulated time (no real-time waits) with a stand-in viewer: three
    presses of Up and one of Page Up command 0.3 m/s and 0.1 rad, the robot walks forward and
    turns, the overlay shows the command; Delete stands it back at the origin."""
    cfg, found = evaluate.load_policy("cassie", None, 0.0005)
    rt = runtime.Runtime(robots.build(robots.get("cassie"), cfg.physics), cfg, found.params)
    p, viewer = play.Play(rt, cfg), StandInViewer()
    start = p.d.qpos.copy()
    for key in [play.KEY_UP] * 3 + [play.KEY_PAGE_UP, play.KEY_LEFT, play.KEY_RIGHT]:
        p.key(key)
    play.run(p, viewer, seconds=3.0, realtime=False)
    assert np.allclose(p.cmd, [0.3, 0.0, 0.1])
    assert p.d.qpos[0] > 0.4 and p.d.qpos[2] > 0.8  # walked forward, upright
    yaw = 2 * np.arctan2(p.d.qpos[6], p.d.qpos[3])
    assert 0.03 < yaw < 0.2, yaw
    per_frame = round(play.FRAME / rt.dt)  # physics steps between syncs
    assert viewer.syncs == int(np.ceil(round(3.0 / rt.dt) / per_frame))
    assert "+0.30 m/s" in viewer.texts[-1][3] and "+0.10 rad" in viewer.texts[-1][3]
    for key in [play.KEY_DOWN] * 10:  # clipped to the trained range
        p.key(key)
    p.apply_keys()
    assert p.cmd[0] == cfg.episode.vx[0]
    p.key(play.KEY_DELETE)
    p.advance(play.FRAME)
    assert np.allclose(p.cmd, 0.0) and p.d.time < 2 * play.FRAME
    assert np.abs(p.d.qpos[:2] - start[:2]).max() < 0.01 and p.d.qpos[2] > 0.8


def test_play_without_a_display_says_so_in_one_line(capsys, monkeypatch):
    monkeypatch.delenv("DISPLAY", raising=False)
    monkeypatch.delenv("WAYLAND_DISPLAY", raising=False)
    monkeypatch.setattr("sys.platform", "linux")
    code, out = _main(["play", "--robot", "cassie"], capsys)
    assert code == 2 and "play needs a display" in out.err and len(out.err.strip().splitlines()) == 1


def test_play_help_documents_the_keys():
    parser = cli.build_parser()
    commands = next(a for a in parser._actions if a.dest == "command").choices
    text = commands["play"].format_help()
    for key in ("Up / Down", "Left / Right", "Page Up / Page Down", "Home", "Delete", "Ctrl + right drag"):
        assert key in text, key
