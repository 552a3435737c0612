import json

import numpy as np
import pytest

from mjx_cascade import scenario
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
