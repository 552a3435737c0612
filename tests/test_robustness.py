"""Robustness sweeps: the trial design, the verdict, and a small sweep with the shipped policy."""

from __future__ import annotations

import json

import numpy as np
import pytest

from mjx_cascade import judge, progress, robustness
from mjx_cascade.config import ConfigError
from mjx_cascade.robots import scene

STEP = 0.35


def test_every_cell_gets_its_trials_and_pushes_come_at_random_phases():
    sweep = robustness.Sweep(trials=3)
    t = robustness.trials(sweep, STEP)
    cells = {}
    for label in t.label:
        cells[label] = cells.get(label, 0) + 1
    assert set(cells.values()) == {3}
    assert len(cells) == 4 * len(sweep.push_forces) + len(sweep.slopes) + len(sweep.roughness) + len(sweep.mass_scales)
    push = np.array([lab[0] == "push" for lab in t.label])
    assert np.all((t.push_t[push] >= sweep.push_after) & (t.push_t[push] < sweep.push_after + 2 * STEP))
    assert np.ptp(t.push_t[push]) > STEP  # phases spread over the gait cycle
    assert np.all(np.isinf(t.push_t[~push]))
    for (axis, level, direction), f in zip(t.label, t.force):
        if axis == "push":
            assert np.linalg.norm(f) == pytest.approx(level)
            if level:
                assert np.dot(f[:2], robustness.DIRECTIONS[direction]) == pytest.approx(level)
    mass = [(lab[1], m) for lab, m in zip(t.label, t.mass) if lab[0] == "mass"]
    assert all(level == m for level, m in mass)
    seeds = {tr["seed"] for lab, tr in zip(t.label, t.terrain) if lab[0] == "rough"}
    assert seeds == {0, 1, 2}
    np.testing.assert_allclose(t.cmd, [[0.3, 0.0, 0.0]] * len(t.label))
    for bad, message in (({"axes": ("wind",)}, "unknown sweep axis"), ({"trials": 0}, "trials"),
                         ({"seconds": 2.0}, "seconds must exceed"), ({"push_directions": ("up",)}, "push direction 'up'"),
                         ({"push_directions": ()}, "push directions must be"),
                         ({"push_directions": ("left", "left")}, "push directions must be"),
                         ({"push_forces": ()}, "push forces must be"), ({"push_forces": (-50.0,)}, "push forces must be"),
                         ({"push_forces": (float("nan"),)}, "push forces must be"),
                         ({"push_forces": (125.0, 125.0)}, "push forces must be")):
        with pytest.raises(ConfigError, match=message):
            robustness.Sweep(**bad)


def test_a_push_scan_tries_only_the_forces_and_directions_it_names():
    """`push_forces` and `push_directions` narrow the push cells (a cheap scan of one weak cell);
    the trials' phases are drawn in the order the directions are named."""
    sweep = robustness.Sweep(axes=("push",), trials=2, push_forces=(125.0, 150.0), push_directions=("backward", "forward"))
    t = robustness.trials(sweep, STEP)
    assert t.label == [("push", f, d) for _ in range(2) for f in (125.0, 150.0) for d in ("backward", "forward")]
    np.testing.assert_allclose(t.force[:2], [[-125.0, 0.0, 0.0], [125.0, 0.0, 0.0]])
    rng = np.random.default_rng(sweep.seed)
    np.testing.assert_array_equal(t.push_t, sweep.push_after + rng.uniform(0.0, 2 * STEP, len(t.label)))


def _walk(v, seconds=10.0, fall_at=None):
    t = np.arange(1, int(seconds * 100) + 1) * 0.01
    qpos = np.zeros((len(t), 7))
    qpos[:, 2], qpos[:, 3] = 0.9, 1.0
    qvel = np.zeros((len(t), 6))
    qvel[:, :2] = v(t)
    if fall_at is not None:
        qpos[t >= fall_at, 2] = 0.3
    return t, qpos, qvel, np.zeros(len(t))


@pytest.mark.parametrize("v, fall_at, success", [
    (lambda t: np.stack([0.3 + 0 * t, 0 * t], 1), None, True),
    (lambda t: np.stack([0.3 + 0.5 * (t < 5), 0 * t], 1), None, True),  # off only before the last 3 s
    (lambda t: np.stack([0.3 + 0 * t, 0.2 + 0 * t], 1), None, False),  # sideways drift
    (lambda t: np.stack([0.1 + 0 * t, 0 * t], 1), None, False),  # too slow
    (lambda t: np.stack([0.3 + 0 * t, 0 * t], 1), 6.0, False),  # fell
])
def test_a_trial_succeeds_when_it_stands_and_tracks_over_the_last_seconds(v, fall_at, success):
    verdict = judge.robust(*_walk(v, fall_at=fall_at), np.array([0.3, 0.0, 0.0]), judge.ROBUSTNESS)
    assert verdict["success"] is success
    assert verdict["fell"] is (fall_at is not None)


def test_one_height_field_holds_a_list_of_terrains(cassie_cfg):
    from mjx_cascade import robots

    terrains = [{"type": "slope", "degrees": -11.0}, {"type": "slope", "degrees": 11.0},
                {"type": "rough", "amplitude": 0.04, "seed": 1}]
    model = robots.build(robots.get("cassie"), cassie_cfg.physics, terrain=terrains).model
    hf = scene.height_field(model)
    xs, ys = np.random.default_rng(0).uniform(-3, 20, 50), np.random.default_rng(1).uniform(-5, 5, 50)
    for terrain in terrains:
        data = scene.hfield_data(model, terrain)
        np.testing.assert_allclose(scene.height_at(hf, data, xs, ys), scene.ground_height(terrain, xs, ys), atol=1e-3)
    np.testing.assert_allclose(model.hfield_data, scene.hfield_data(model, terrains[0]))
    with pytest.raises(ValueError, match="does not fit"):
        scene.hfield_data(model, {"type": "slope", "degrees": 20.0})


@pytest.mark.slow
def test_a_small_sweep_with_the_shipped_policy(tmp_path, capsys):
    """Pushes of 0 and 400 N and slopes of +-11 degrees, one trial each, in two batches, each
    saying its progress."""
    sweep = robustness.Sweep(axes=("push", "slope"), trials=1, seconds=4.5, push_after=2.0,
                             bar=judge.RobustnessBar(judge_seconds=1.5), push_forces=(0.0, 400.0), slopes=(-11.0, 11.0))
    # the config's own k_phr, so the program is the same; the results must still record the change
    results, sim = robustness.sweep("cassie", tmp_path, sweep, dt=0.002, settings={"regulators.k_phr": "0.3"},
                                    progress=progress.Report("robustness", bar=False))
    said = [line for line in capsys.readouterr().err.splitlines() if line.startswith("robustness: ")]
    assert said[0] == "robustness: batch 1/2: 8 trials on the plane: push 8" and len(said) == 22
    assert said[11] == "robustness: batch 2/2: 2 trials on height fields: slope 2"
    assert said[10] == said[-1] == "robustness: 100% (4.5 of 4.5 s simulated)"
    rows = {(r["level"], r["direction"]): r for r in results["cells"]["push"]}
    assert all(rows[(0.0, d)]["rate"] == 1.0 for d in robustness.DIRECTIONS)  # it walks undisturbed
    assert all(rows[(400.0, d)]["rate"] == 0.0 for d in robustness.DIRECTIONS)  # and 400 N knocks it over
    fell = [tr for tr in results["trials"] if tr["level"] == 400.0]
    assert all(tr["fell"] and tr["fall_time"] > tr["push_t"] for tr in fell)
    assert {r["level"] for r in results["cells"]["slope"]} == {-11.0, 11.0}
    # each environment of the terrain batch walks on its own slope: the ground under its pelvis
    for i, (axis, level, _) in enumerate(sim["trials"].label):
        if axis == "slope":
            x = sim["traj"][i]["qpos"][:, 0]
            want = scene.ground_height({"type": "slope", "degrees": level}, x, 0.0 * x)
            assert abs(want[-1]) > 0.02  # it walked onto the slope
            np.testing.assert_allclose(sim["traj"][i]["ground"], want, atol=2e-3)
    saved = json.loads((tmp_path / "robustness.json").read_text())
    assert saved["cells"] == json.loads(json.dumps(results["cells"]))
    assert saved["policy"]["settings"] == {"regulators.k_phr": "0.3"}
    assert saved["code_version"] and saved["date"] and saved["cpu"]  # what ran it, and where
    table = (tmp_path / "robustness.md").read_text()
    assert "Controller settings changed from the policy's config: `regulators.k_phr=0.3`." in table
    assert "| 400 | 0/1 | 0/1 | 0/1 | 0/1 |" in table and "| -11 | " in table
    for png in ("robustness.png", "push_response.png", "push_limit_cycle.png", "terrain_tracking.png"):
        assert (tmp_path / png).stat().st_size > 10_000


def test_the_c_engine_refuses_several_terrains_before_any_trial_runs(tmp_path, monkeypatch):
    """MuJoCo's C engine steps a batch on one terrain: a sweep over several slopes says so at once,
    not at its height fields' first step after the trials on the plane."""
    def no_trials(*args, **kwargs):
        raise AssertionError("a trial ran")

    monkeypatch.setattr(robustness, "simulate", no_trials)
    sweep = robustness.Sweep(axes=("mass", "slope"), trials=1, slopes=(-5.0, 5.0))
    with pytest.raises(ConfigError, match="one terrain"):
        robustness.sweep("cassie", tmp_path, sweep, impl="mujoco")
    assert not (tmp_path / "robustness.json").exists()


def test_a_push_scan_from_the_command_line_writes_its_tables_without_figures(tmp_path, monkeypatch):
    """`--push-forces`, `--push-directions` and `--no-figures` reach the sweep: the trials are the
    named cells only, and the output is the two tables (the simulation is stood in for)."""
    from mjx_cascade import cli

    ran = []

    def stand_in(cfg, params, sweep, model_path=None, progress=None):
        t = robustness.trials(sweep, cfg.gait.step_time)
        ran.append(t.label)
        verdicts = [{"success": label[1] < 150.0, "fell": label[1] >= 150.0} for label in t.label]
        return robustness.summarize(t, verdicts, sweep), {}

    monkeypatch.setattr(robustness, "run", stand_in)
    out = tmp_path / "scan"
    assert cli.main(["robustness", "--robot", "cassie", "--axes", "push", "--trials", "2", "--push-forces", "125",
                     "150", "--push-directions", "backward", "--no-figures", "--out", str(out)]) == 0
    assert ran == [[("push", f, "backward") for _ in range(2) for f in (125.0, 150.0)]]
    assert sorted(p.name for p in out.iterdir()) == ["robustness.json", "robustness.md"]
    saved = json.loads((out / "robustness.json").read_text())
    assert saved["figures"] == [] and saved["sweep"]["push_directions"] == ["backward"]
    table = (out / "robustness.md").read_text()
    assert "| push force (N) | backward |" in table and "| 125 | 2/2 |" in table and "| 150 | 0/2 |" in table
