"""A recorded trajectory as an animated GIF, rendered by MuJoCo where an OpenGL backend exists.

MuJoCo chooses its OpenGL backend from `MUJOCO_GL` when it is first imported; without a display
`mjx-cascade eval` sets `MUJOCO_GL=egl` where an EGL library exists, which renders headless on
most Linux machines. Where no backend works, `render` says why in one line and writes nothing;
the plots do not depend on it.
"""

from __future__ import annotations

import copy
from pathlib import Path

import mujoco
import numpy as np

FPS = 20
SIZE = (240, 320)  # height, width: a 20-s scenario makes a GIF of a few MB


def render(traj: dict, model: mujoco.MjModel, path: Path, pelvis: int, fps: int = FPS) -> str | None:
    """Write `path` (GIF) from the trajectory's `t` and `qpos`; returns None, or why nothing was written."""
    try:
        renderer = mujoco.Renderer(model, *SIZE)
    except Exception as e:  # no OpenGL backend: every platform raises its own error type
        return f"no video: MuJoCo could not open an OpenGL context ({type(e).__name__}: {str(e).splitlines()[0]})"
    from PIL import Image

    model = copy.deepcopy(model)  # brighter lights for the video only: the models bring none
    model.vis.headlight.ambient[:], model.vis.headlight.diffuse[:] = 0.45, 0.6
    data = mujoco.MjData(model)
    option = mujoco.MjvOption()
    option.geomgroup[:] = 1  # collision geoms too: the visual meshes may have been dropped
    camera = mujoco.MjvCamera()
    camera.type = mujoco.mjtCamera.mjCAMERA_TRACKING
    camera.trackbodyid = pelvis
    camera.distance, camera.elevation, camera.azimuth = 3.0, -15.0, 120.0
    t = np.asarray(traj["t"])
    frames = []
    for i in np.searchsorted(t, np.arange(t[0], t[-1], 1.0 / fps)):
        data.qpos[:] = traj["qpos"][i]
        mujoco.mj_forward(model, data)
        renderer.update_scene(data, camera, option)
        frames.append(Image.fromarray(renderer.render()))
    renderer.close()
    if not frames:
        return "no video: the trajectory is shorter than one frame"
    frames[0].save(path, save_all=True, append_images=frames[1:], duration=int(1000 / fps), loop=0)
    return None
