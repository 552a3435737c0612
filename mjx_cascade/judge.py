"""The judges: the walking bar and the robustness bar as data, and their verdicts on a recorded
trajectory alone (`t`, `qpos`, `qvel`, `cmd` in MuJoCo's layout, and `ground` on a terrain).

Both read the same two things: a fall (the pelvis below `Fall.height` above the ground, tilted
beyond `Fall.tilt`, or non-finite), and the 1-second moving average of the heading-frame pelvis
velocity against the command.
- Walking: in every command segment of `min_segment` s or more, after `settle` s, the mean
  absolute error of that average in vx and vy, and of the heading, within bounds; no fall. Each
  segment also says how long each of them took to settle: the time from the segment's start
  after which the average (the heading itself) stays within the bound to the segment's end.
- Robustness: over the last `judge_seconds` of a trial with one command, the mean absolute error
  of that average in vx and in vy within `tolerance`; no fall.
"""

from __future__ import annotations

import dataclasses

import numpy as np

from mjx_cascade.rotations import tilt
from mjx_cascade.trajectory import heading_velocity, moving_average


@dataclasses.dataclass(frozen=True)
class Fall:
    height: float = 0.6  # m, pelvis above the ground
    tilt: float = 0.6  # rad, pelvis z axis from the vertical


@dataclasses.dataclass(frozen=True)
class WalkingBar:
    vx: float = 0.10  # m/s, mean absolute error of the 1-s average
    vy: float = 0.10
    yaw: float = 0.15  # rad
    settle: float = 2.0  # s after each command change that are not judged
    min_segment: float = 4.0  # s: shorter segments are not judged
    window: float = 1.0  # s, the moving average
    fall: Fall = Fall()


@dataclasses.dataclass(frozen=True)
class RobustnessBar:
    tolerance: float = 0.15  # m/s, mean absolute error of the 1-s average in vx and in vy
    judge_seconds: float = 3.0  # the last seconds of a trial that are judged
    window: float = 1.0
    fall: Fall = Fall()


WALKING, ROBUSTNESS = WalkingBar(), RobustnessBar()


def fallen(qpos: np.ndarray, ground: np.ndarray, fall: Fall = Fall()) -> np.ndarray:
    """[T] bool: the pelvis too low above the ground, tilted too far, or non-finite."""
    return (qpos[:, 2] - ground < fall.height) | (tilt(qpos[:, 3:7]) > fall.tilt) | ~np.all(np.isfinite(qpos), axis=1)


def _fall(t: np.ndarray, fell_at: np.ndarray) -> dict:
    fell = bool(fell_at.any())
    return {"fell": fell, "fall_time": float(t[np.argmax(fell_at)]) if fell else None}


def walking(traj: dict, bar: WalkingBar = WALKING) -> dict:
    """Fall and per-segment tracking errors: `{fell, fall_time, segments, passed, bounds}`."""
    t, qpos, qvel, cmd = (np.asarray(traj[k]) for k in ("t", "qpos", "qvel", "cmd"))
    fell = _fall(t, fallen(qpos, np.asarray(traj["ground"]) if "ground" in traj else np.zeros_like(t), bar.fall))
    v, yaw = heading_velocity(qpos, qvel)
    v_avg = moving_average(v, t, bar.window)
    change = np.nonzero(np.any(np.diff(cmd, axis=0) != 0, axis=1))[0] + 1
    bounds = np.concatenate([[0], change, [len(t)]])
    period = t[1] - t[0] if len(t) > 1 else 0.0
    segments = [_segment(t, cmd, v_avg, yaw, a, b, period, bar) for a, b in zip(bounds[:-1], bounds[1:])]
    judged = [s for s in segments if "within_bounds" in s]
    return {**fell, "segments": segments, "passed": (not fell["fell"]) and all(s["within_bounds"] for s in judged),
            "bounds": {"vx": bar.vx, "vy": bar.vy, "yaw": bar.yaw}}


def _segment(t, cmd, v_avg, yaw, a: int, b: int, period: float, bar: WalkingBar) -> dict:
    """Records `[a, b)` of one command: its errors after settling, if it lasts long enough."""
    t0 = t[a] - period  # each record ends a period that its command held throughout
    seg = {"t_start": float(max(t0, 0.0)), "t_end": float(t[b - 1]), "cmd": cmd[a].tolist(),
           "settle": _settle(t[a:b], t0, v_avg[a:b] - cmd[a:b, :2], _wrap(yaw[a:b] - cmd[a:b, 2]), bar)}
    index = np.arange(len(t))
    judged = (t >= t0 + bar.settle) & (index >= a) & (index < b)
    if t[b - 1] - t0 < bar.min_segment - 1e-6 or not judged.any():
        return seg
    err_yaw = _wrap(yaw[judged] - cmd[judged, 2])
    seg.update(vx_mae=float(np.mean(np.abs(v_avg[judged, 0] - cmd[judged, 0]))),
               vy_mae=float(np.mean(np.abs(v_avg[judged, 1] - cmd[judged, 1]))),
               yaw_mae=float(np.mean(np.abs(err_yaw))))
    seg["within_bounds"] = bool(seg["vx_mae"] <= bar.vx and seg["vy_mae"] <= bar.vy and seg["yaw_mae"] <= bar.yaw)
    return seg


def _wrap(angle: np.ndarray) -> np.ndarray:
    return np.angle(np.exp(1j * angle))


def _settle(t: np.ndarray, t0: float, err_v: np.ndarray, err_yaw: np.ndarray, bar: WalkingBar) -> dict:
    """Seconds from `t0` until each error (vx, vy of the average; the heading) stays within its
    bound through the last record; None where the last record is still outside."""
    out = {}
    for name, err, bound in (("vx", err_v[:, 0], bar.vx), ("vy", err_v[:, 1], bar.vy), ("yaw", err_yaw, bar.yaw)):
        outside = np.nonzero(np.abs(err) > bound)[0]
        if not len(outside):
            out[name] = 0.0
        elif outside[-1] == len(t) - 1:
            out[name] = None
        else:
            out[name] = round(float(t[outside[-1] + 1] - t0), 3)  # the first record that stays inside
    return out


def robust(t: np.ndarray, qpos: np.ndarray, qvel: np.ndarray, ground: np.ndarray, cmd: np.ndarray,
           bar: RobustnessBar = ROBUSTNESS) -> dict:
    """One trial's verdict (arrays over time, `cmd [3]` held throughout): `{success, fell, fall_time,
    vx_mae, vy_mae}`."""
    fell = _fall(t, fallen(qpos, ground, bar.fall))
    v, _ = heading_velocity(qpos, qvel)
    v_avg = moving_average(v, t, bar.window)
    mae = np.mean(np.abs(v_avg[t > t[-1] - bar.judge_seconds] - cmd[:2]), axis=0)
    return {"success": (not fell["fell"]) and bool(np.all(mae <= bar.tolerance)), **fell,
            "vx_mae": float(mae[0]), "vy_mae": float(mae[1])}
