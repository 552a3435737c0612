"""The walking bar's verdict on part of a trajectory: what a check that stops early may decide."""

import numpy as np

from mjx_cascade import evaluate


def _walk(vx_cmd: list[tuple[float, float]], duration: float, vx: float = 0.3, period: float = 0.01) -> dict:
    """A robot standing tall at heading 0 that walks at `vx` throughout, under forward commands
    `[(from t, vx), ...]`, recorded every `period` s."""
    t = (np.arange(int(round(duration / period))) + 1) * period
    qpos = np.zeros((len(t), 7))
    qpos[:, 2], qpos[:, 3] = 1.0, 1.0
    qvel = np.zeros((len(t), 6))
    qvel[:, 0] = vx
    cmd = np.zeros((len(t), 3))
    for start, value in vx_cmd:
        cmd[t - period >= start - 1e-9, 0] = value
    return {"t": t, "qpos": qpos, "qvel": qvel, "cmd": cmd, "ground": np.zeros(len(t))}


def _first(traj: dict, seconds: float) -> dict:
    n = int(round(seconds / (traj["t"][1] - traj["t"][0])))
    return {k: v[:n] for k, v in traj.items()}


def test_a_finished_segment_out_of_bounds_decides_the_part():
    """0.6 m/s commanded for 5 s of 0.3 m/s walking: once the next command starts, the first segment
    is finished and missed, with the same errors as in the whole trajectory."""
    whole = _walk([(0.0, 0.6), (5.0, 0.3)], 10.0)
    full = evaluate.verdict_so_far(whole, whole=True)
    assert full["passed"] is False and len(full["segments"]) == 2
    part = evaluate.verdict_so_far(_first(whole, 5.5), whole=False)
    assert part["passed"] is False and not part["fell"]
    assert part["segments"] == full["segments"][:1]
    assert part["segments"][0]["vx_mae"] == full["segments"][0]["vx_mae"] > 0.1


def test_an_unfinished_segment_leaves_the_part_undecided():
    """The same miss before its command ends is not judged: the part might be cut short of a
    segment that the whole trajectory judges, or judge one the whole does not (under 4 s)."""
    whole = _walk([(0.0, 0.6), (5.0, 0.3)], 10.0)
    assert evaluate.verdict_so_far(_first(whole, 4.5), whole=False) == {
        "passed": None, "fell": False, "fall_time": None, "segments": []}
    on_command = _walk([(0.0, 0.3), (5.0, 0.3001)], 10.0)  # two segments within bounds
    part = evaluate.verdict_so_far(_first(on_command, 7.0), whole=False)
    assert part["passed"] is None and [s["within_bounds"] for s in part["segments"]] == [True]
    assert evaluate.verdict_so_far(on_command, whole=True)["passed"] is True


def test_a_fall_decides_the_part_at_once():
    traj = _walk([(0.0, 0.3)], 3.0)
    traj["qpos"][250:, 2] = 0.2  # the pelvis on the ground from 2.51 s
    part = evaluate.verdict_so_far(_first(traj, 2.6), whole=False)
    assert part["passed"] is False and part["fell"] and part["fall_time"] == traj["t"][250]
