"""The README's picture: the shipped Cassie policy on the speed profile, four moments side by side.

    python docs/make_figure.py   # writes docs/media/cassie_walk.png

Runs `speed_profile` at the paper's 0.5 ms as `eval` does and renders the moments through
`video.frames` (headless through EGL where there is no display): the command as a green arrow.
"""

from __future__ import annotations

import os
import sys
from pathlib import Path

if "MUJOCO_GL" not in os.environ and not os.environ.get("DISPLAY"):
    os.environ["MUJOCO_GL"] = "egl"  # before MuJoCo is first imported

import numpy as np  # noqa: E402

from mjx_cascade import config, evaluate, scenario, video  # noqa: E402

MOMENTS = (4.0, 8.0, 12.0, 17.0)  # s: forward, diagonal, backward, turning (the profile's segments)
SIZE = (300, 400)  # height, width of each moment
OUT = Path(__file__).resolve().parent / "media" / "cassie_walk.png"


def main() -> int:
    cfg, found = evaluate.load_policy("cassie", None, dt=config.PAPER_DT)
    runner = evaluate.Runner(cfg, [scenario.load("speed_profile")])
    traj = runner(found.params)[0]
    picks = [int(np.searchsorted(traj["t"], m)) for m in MOMENTS]
    picks.append(picks[-1])  # `frames` renders up to, not including, the last record
    moments = {k: np.asarray(traj[k])[picks] for k in ("qpos", "cmd", "force")}
    moments["t"] = np.arange(len(picks), dtype=float)  # one frame per pick at 1 fps
    clip = video.frames(moments, runner.env.robot.model, runner.env.robot.pelvis_body, fps=1, size=SIZE)
    from PIL import Image

    OUT.parent.mkdir(parents=True, exist_ok=True)
    Image.fromarray(np.concatenate(list(clip), axis=1)).save(OUT, optimize=True)
    print(f"wrote {OUT}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
