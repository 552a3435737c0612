import json

import numpy as np
import pytest

from mjx_cascade import judge, scenario
from mjx_cascade.config import ConfigError
from conftest import DATA, ROOT

GOOD = {
    "name": "s",
    "duration": 10,
    "commands": [{"t": 0, "vx": 0.2, "vy": 0, "yaw": 0}, {"t": 4, "vx": 0.5, "vy": 0.1, "yaw": 0.3}],
    "pushes": [{"t": 5, "duration": 0.2, "force": [60, 0, 0]}],
    "terrain": {"type": "slope", "degrees": 8},
}


def test_parse_and_schedules():
    s = scenario.parse(GOOD)
    times = np.array([0.0, 3.99, 4.0, 5.1, 5.3])
    np.testing.assert_allclose(s.command_schedule(times)[:, 0], [0.2, 0.2, 0.5, 0.5, 0.5])
    np.testing.assert_allclose(s.force_schedule(times)[:, 0], [0, 0, 0, 60, 0])
    assert s.terrain == {"type": "slope", "degrees": 8.0}


def test_shipped_scenarios_parse():
    for path in sorted((ROOT / "configs" / "scenarios").glob("*.json")) + [DATA / "short.json"]:
        assert scenario.load(path).duration > 0


def bad(**change):
    data = json.loads(json.dumps(GOOD))
    for key, value in change.items():
        data[key] = value
    return data


@pytest.mark.parametrize("data, message", [
    (bad(speed=1), "unknown key 'speed'"),
    (bad(duration=0), "duration must be positive"),
    (bad(duration=-3), "duration must be positive"),
    (bad(commands=[{"t": 1, "vx": 0, "vy": 0, "yaw": 0}]), "first command must be at t = 0"),
    (bad(commands=[{"t": 0, "vx": 0, "vy": 0, "yaw": 0}, {"t": 0, "vx": 1, "vy": 0, "yaw": 0}]), "must increase"),
    (bad(commands=[{"t": 0, "vx": 0, "vy": 0}]), "missing 'yaw'"),
    (bad(commands=[{"t": 0, "vx": "fast", "vy": 0, "yaw": 0}]), "must be a finite number"),
    (bad(commands=[]), "at least one command"),
    (bad(terrain={"type": "lava"}), "unknown terrain type 'lava'"),
    (bad(terrain={"type": "rough", "amplitude": 0.02}), "missing 'seed'"),
    (bad(pushes=[{"t": 1, "duration": -0.2, "force": [1, 0, 0]}]), "duration must be >= 0"),
    (bad(pushes=[{"t": 1, "duration": 0.2, "force": [1, 0]}]), "force must be"),
])
def test_invalid_scenarios_are_refused(data, message):
    with pytest.raises(ConfigError, match=message):
        scenario.parse(data)


def test_invalid_json(tmp_path):
    path = tmp_path / "s.json"
    path.write_text("{not json")
    with pytest.raises(ConfigError, match="not valid JSON"):
        scenario.load(path)


def _tracking_trajectory(cmd_at, duration=12.0, period=0.01, error=(0.0, 0.0), height=0.9):
    """A recorded trajectory (the evaluator's format) that follows `cmd_at(t)` plus `error`."""
    t = np.arange(1, int(round(duration / period)) + 1) * period
    cmd = np.array([cmd_at(x - period / 2) for x in t])
    yaw = cmd[:, 2]
    v = cmd[:, :2] + np.asarray(error)
    qpos = np.zeros((len(t), 7))
    qpos[:, 2] = height
    qpos[:, 3], qpos[:, 6] = np.cos(yaw / 2), np.sin(yaw / 2)
    qvel = np.zeros((len(t), 6))
    qvel[:, 0] = np.cos(yaw) * v[:, 0] - np.sin(yaw) * v[:, 1]
    qvel[:, 1] = np.sin(yaw) * v[:, 0] + np.cos(yaw) * v[:, 1]
    return {"t": t, "qpos": qpos, "qvel": qvel, "cmd": cmd}


def _profile(x):
    return (0.0, 0.0, 0.0) if x < 2.0 else (0.4, 0.1, 0.0) if x < 6.0 else (0.2, -0.2, 0.3)


def test_tracking_judges_every_segment_of_four_seconds_or_more():
    m = judge.walking(_tracking_trajectory(_profile))
    judged = [s for s in m["segments"] if "within_bounds" in s]
    # [0, 2) is too short; [2, 6) is exactly 4 s and [6, 12) longer: both judged, from 2 s after their start
    assert [(round(s["t_start"], 6), s["t_end"]) for s in judged] == [(2.0, 6.0), (6.0, 12.0)]
    assert not m["fell"] and m["passed"]
    assert all(s["vx_mae"] < 0.01 and s["vy_mae"] < 0.01 and s["yaw_mae"] < 0.01 for s in judged)


def test_tracking_fails_on_velocity_error_and_on_a_fall():
    slow = judge.walking(_tracking_trajectory(_profile, error=(-0.15, 0.0)))
    assert not slow["fell"] and not slow["passed"]
    assert all(abs(s["vx_mae"] - 0.15) < 0.02 for s in slow["segments"] if "vx_mae" in s)
    fallen = judge.walking(_tracking_trajectory(_profile, height=0.5))
    assert fallen["fell"] and fallen["fall_time"] == pytest.approx(0.01) and not fallen["passed"]


def test_each_segment_says_how_long_each_error_took_to_settle():
    """A robot that follows each command at once still settles late by the 1-s average's lag:
    a 0.4 m/s step leaves the average 0.1 off after 0.75 s, a 0.3 m/s step after 2/3 s."""
    first, second, third = judge.walking(_tracking_trajectory(_profile))["segments"]
    assert second["settle"]["vx"] == pytest.approx(0.75, abs=0.02)
    assert third["settle"]["vy"] == pytest.approx(2 / 3, abs=0.02)
    assert third["settle"]["vx"] == pytest.approx(0.5, abs=0.02)  # 0.2 m/s: half a second
    assert second["settle"]["yaw"] == third["settle"]["yaw"] == 0.0  # the heading itself is never off
    assert first["settle"] == {"vx": 0.0, "vy": 0.0, "yaw": 0.0}
    off = judge.walking(_tracking_trajectory(_profile, error=(0.15, 0.0)))["segments"]
    assert off[2]["settle"]["vx"] is None  # still outside at the segment's end


def test_a_summary_line_gives_the_worst_judged_errors():
    from mjx_cascade import evaluate

    m = judge.walking(_tracking_trajectory(_profile, error=(0.05, -0.02)))
    m["scenario"] = {"name": "s"}
    line = evaluate.verdict(m)
    judged = [s for s in m["segments"] if "within_bounds" in s]
    assert line["worst"]["vx"] == max(s["vx_mae"] for s in judged) and 0.04 < line["worst"]["vx"] < 0.06
    assert line["worst"]["vy"] == max(s["vy_mae"] for s in judged) and line["passed"]
