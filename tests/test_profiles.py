"""Profile sets by role, and the walking benchmark's bookkeeping of command changes."""

import numpy as np
import pytest

from mjx_cascade import benchmark, config, profiles
from mjx_cascade.config import ConfigError


@pytest.mark.parametrize("robot", list(config.ROBOTS))
@pytest.mark.parametrize("role", ["dev", "val"])
def test_a_set_is_drawn_from_its_seed_over_the_robots_full_command_ranges(robot, role):
    first, again = profiles.draw_set(robot, role), profiles.draw_set(robot, role)
    assert first == again and len(first) == profiles.sets()[robot][role]["count"]
    assert [s.name for s in first] == [f"{robot}_{role}{k:02d}" for k in range(1, len(first) + 1)]
    e = config.robot_config(robot).episode
    c = np.concatenate([np.array(s.commands) for s in first])
    for column, (lo, hi) in zip((1, 2, 3), (e.vx, e.vy, e.yaw)):
        assert lo <= c[:, column].min() and c[:, column].max() <= hi
        # uniform over the full range: 80 or more draws reach both outer fifths
        assert c[:, column].min() < lo + 0.2 * (hi - lo) and c[:, column].max() > hi - 0.2 * (hi - lo)
    for s in first:
        starts = np.array(s.commands)[:, 0]
        assert s.duration == 20.0 and starts[0] == 0.0 and set(np.diff(starts)) <= {4.0, 5.0, 6.0}
        assert s.terrain == {"type": "flat"} and not s.pushes


def test_the_sets_of_one_robot_differ_and_test_waits_for_a_frozen_policy():
    dev, val = profiles.draw_set("cassie", "dev"), profiles.draw_set("cassie", "val")
    assert not {s.commands for s in dev} & {s.commands for s in val}
    entries = [e for roles in profiles.sets().values() for role, e in roles.items() if role != "tests"]
    entries += [e for roles in profiles.sets().values() for e in roles.get("tests", {}).values()]
    # one seed, one set: a test set keeps its candidate-time name once its policy ships
    draws = {(e["seed"], e.get("frozen")) for e in entries}
    assert len(draws) == len({seed for seed, _ in draws})
    for robot, roles in profiles.sets().items():
        if "test" in roles:  # written only with the hash of the policy it judges
            assert len(roles["test"]["frozen"]) == 64
        else:
            with pytest.raises(ConfigError, match="frozen"):
                profiles.draw_set(robot, "test")
    with pytest.raises(ConfigError, match="unknown set"):
        profiles.draw_set("cassie", "train")


def test_another_frozen_policys_test_set_is_its_own_draw(monkeypatch):
    """`test:NAME` draws the `tests` entry NAME, apart from the robot's `test`, and is offered to
    the command line; an unknown NAME waits for its policy to be frozen."""
    shipped = profiles.sets()
    other = {"seed": 12345, "count": 3, "frozen": "f" * 64}
    monkeypatch.setattr(profiles, "sets", lambda: {**shipped, "cassie": {**shipped["cassie"], "tests": {"cpu": other}}})
    drawn = profiles.draw_set("cassie", "test:cpu")
    assert [s.name for s in drawn] == ["cassie_test_cpu01", "cassie_test_cpu02", "cassie_test_cpu03"]
    assert drawn == profiles.resolve("cassie", "test:cpu")
    assert not {s.commands for s in drawn} & {s.commands for s in profiles.draw_set("cassie", "test")}
    assert "test:cpu" in profiles.test_sets()
    with pytest.raises(ConfigError, match="frozen"):
        profiles.draw_set("cassie", "test:other")
    with pytest.raises(ConfigError, match="unknown set"):
        profiles.draw_set("cassie", "val:cpu")


def test_steps_cross_each_range_end_to_end():
    e = config.robot_config("cassie").episode
    steps = {s.name: s for s in profiles.steps("cassie")}
    assert len(steps) == 6
    down = steps["cassie_step_vx_down"].commands
    assert down == ((0.0, e.vx[1], 0.0, 0.0), (profiles.STEP_AT, e.vx[0], 0.0, 0.0))
    vy_up = steps["cassie_step_vy_up"].commands
    assert [c[2] for c in vy_up] == list(e.vy) and vy_up[0][1] == profiles.STEP_CRUISE
    assert profiles.resolve("cassie", "steps") == list(steps.values())


@pytest.mark.parametrize("robot", ["cassie", "digit"])
def test_starts_go_from_standing_into_every_corner_and_middle_of_the_ranges(robot):
    e = config.robot_config(robot).episode
    starts = profiles.resolve(robot, "starts")
    assert len(starts) == 45 and len({s.name for s in starts}) == 45
    assert all(s.duration == profiles.START_DURATION and len(s.commands) == 1 and s.commands[0][0] == 0.0
               for s in starts)
    commands = {s.commands[0][1:] for s in starts}
    assert len(commands) == 45  # no start twice
    assert (e.vx[0], e.vy[1], e.yaw[1]) in commands and (e.vx[1], e.vy[0], e.yaw[0]) in commands
    assert (e.vx[0] / 2, 0.0, e.yaw[1]) in commands and (0.0, 0.0, 0.0) in commands
    for k, (lo, hi) in enumerate((e.vx, e.vy, e.yaw)):
        assert min(c[k] for c in commands) == lo and max(c[k] for c in commands) == hi


def _segment(t, cmd, settle):
    return {"t_start": t, "cmd": cmd, "settle": dict(zip(("vx", "vy", "yaw"), settle))}


def test_changes_larger_than_the_bar_are_timed_and_summed_up():
    segments = [_segment(0.0, [0.8, 0.0, 0.0], (1.0, 0.0, 0.0)),
                _segment(6.0, [-0.3, 0.05, 0.0], (1.7, 0.4, 0.0)),  # vy moves 0.05: within the bar, not a change
                _segment(12.0, [-0.3, 0.3, 0.5], (0.0, None, 0.9))]
    found = benchmark.changes(segments)
    assert [(c["t"], c["axis"], c["settle"]) for c in found] == [(6.0, "vx", 1.7), (12.0, "vy", None),
                                                                  (12.0, "yaw", 0.9)]
    rows = [{"changes": found}, {"changes": [{"axis": "vx", "settle": 0.9}, {"axis": "vx", "settle": 1.3}]}]
    r = benchmark.response(rows)
    assert r["vx"] == {"changes": 3, "median_s": 1.3, "worst_s": 1.7, "unsettled": 0}
    assert r["vy"] == {"changes": 1, "median_s": None, "worst_s": None, "unsettled": 1}
    assert r["yaw"]["worst_s"] == 0.9
