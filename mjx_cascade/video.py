"""A recorded trajectory as a video: an mp4 through mediapy where mediapy and an ffmpeg are installed
(`pip install -e ".[video]"` brings both), else an animated GIF through Pillow.

The camera follows the pelvis over a checkered floor, so walking shows as motion against the
ground. A green arrow above the pelvis is the commanded velocity (1 m per m/s, so a floor square
is 1 m/s; in the pelvis's heading frame, as the controller reads it); a red arrow ends at the
pelvis while a push acts, pointing along the force (1 m per 100 N).

MuJoCo chooses its OpenGL backend from `MUJOCO_GL` when it is first imported; without a display
`mjx-cascade eval` sets `MUJOCO_GL=egl` where an EGL library exists, which renders headless on
most Linux machines. Where no backend works, `render` says why in one line and writes nothing;
the plots do not depend on it.
"""

from __future__ import annotations

import copy
import shutil
from pathlib import Path
from types import ModuleType

import mujoco
import numpy as np

FPS = 25  # every 4th record of a trajectory (one per 10 ms): frames evenly spaced in time
SIZE = (480, 640)  # height, width of the mp4
GIF_FPS = 20  # every 5th record
GIF_SIZE = (240, 320)  # a GIF stores every frame whole: a 20-s scenario at this size is a few MB
CMD_SCALE = 1.0  # m of arrow per m/s commanded
CMD_LIFT = 0.3  # m above the pelvis: clear of the robot, where a slow command's short arrow still shows
FORCE_SCALE = 0.01  # m of arrow per N pushed
CMD_RGBA = np.array([0.1, 0.8, 0.2, 1.0], np.float32)
FORCE_RGBA = np.array([0.9, 0.1, 0.1, 1.0], np.float32)
GROUND = (int(mujoco.mjtGeom.mjGEOM_PLANE), int(mujoco.mjtGeom.mjGEOM_HFIELD))  # what gets the checker texture


class NoVideo(RuntimeError):
    """Why no frames can be rendered, in one line."""


def render(traj: dict, model: mujoco.MjModel, out: str | Path, pelvis: int) -> str:
    """Write `out/video.mp4`, or `out/video.gif` without mediapy or an ffmpeg, from the trajectory's
    `t, qpos, cmd, force`; returns the file's name, or why nothing was written."""
    media = load_mediapy()
    name, fps, size = ("video.mp4", FPS, SIZE) if media else ("video.gif", GIF_FPS, GIF_SIZE)
    try:
        clip = frames(traj, model, pelvis, fps, size)
    except NoVideo as e:
        return str(e)
    if not len(clip):
        return "no video: the trajectory is shorter than one frame"
    if media:
        media.write_video(Path(out) / name, clip, fps=fps)
    else:
        _write_gif(Path(out) / name, clip, fps)
    return name


def load_mediapy() -> ModuleType | None:
    """mediapy, pointed at an ffmpeg (the one on PATH, else imageio-ffmpeg's); None where either is missing."""
    try:
        import mediapy
    except ImportError:
        return None
    if shutil.which("ffmpeg") is None:
        try:
            import imageio_ffmpeg

            mediapy.set_ffmpeg(imageio_ffmpeg.get_ffmpeg_exe())
        except (ImportError, RuntimeError):  # RuntimeError: no binary was shipped for this platform
            return None
    return mediapy


def _write_gif(path: Path, clip: np.ndarray, fps: int) -> None:
    from PIL import Image

    images = [Image.fromarray(f) for f in clip]
    images[0].save(path, save_all=True, append_images=images[1:], duration=int(1000 / fps), loop=0)


def frames(traj: dict, model: mujoco.MjModel, pelvis: int, fps: int = FPS,
           size: tuple[int, int] = SIZE) -> np.ndarray:
    """`[F, H, W, 3]` uint8 frames of the trajectory (`t, qpos, cmd, force`) at `fps`, `size` =
    (height, width); raises `NoVideo` where MuJoCo cannot open an OpenGL context."""
    model = _lit(model, pelvis)
    context = _context_model(model, size)
    try:
        renderer = mujoco.Renderer(context, *size)
    except Exception as e:  # no OpenGL backend: every platform raises its own error type
        raise NoVideo("no video: MuJoCo could not open an OpenGL context "
                      f"({type(e).__name__}: {str(e).splitlines()[0]})") from None
    data = mujoco.MjData(model)
    option = mujoco.MjvOption()
    option.geomgroup[:] = 1  # collision geoms too: the visual meshes were dropped (robots/scene.py)
    camera = _tracking_camera(pelvis)
    t = np.asarray(traj["t"])
    index = np.searchsorted(t, np.arange(t[0], t[-1], 1.0 / fps))
    clip = np.empty((len(index), *size, 3), np.uint8)
    with renderer:
        for k, i in enumerate(index):
            data.qpos[:] = traj["qpos"][i]
            mujoco.mj_forward(model, data)
            # the scene from the robot's model, drawn by the context's (see `_context_model`)
            mujoco.mjv_updateScene(model, data, option, None, camera, mujoco.mjtCatBit.mjCAT_ALL, renderer.scene)
            _checker_ground(renderer.scene)
            _arrows(renderer.scene, data.xpos[pelvis], data.xmat[pelvis], traj["cmd"][i], traj["force"][i])
            renderer.render(out=clip[k])
    return clip


def _lit(model: mujoco.MjModel, pelvis: int) -> mujoco.MjModel:
    """A copy of `model` lit for the video: a brighter headlight than MuJoCo's default (the robots'
    models set none), and the model's lights moving with the pelvis, aimed at it, so a long walk
    stays lit."""
    model = copy.deepcopy(model)
    model.vis.headlight.ambient[:], model.vis.headlight.diffuse[:] = 0.45, 0.6
    model.light_mode[:] = mujoco.mjtCamLight.mjCAMLIGHT_TRACK
    model.light_bodyid[:] = pelvis
    model.light_pos0[:] = model.light_pos  # each light's position in the model becomes its offset from the pelvis
    model.light_dir0[:] = -model.light_pos / np.linalg.norm(model.light_pos, axis=1, keepdims=True)
    return model


def _context_model(model: mujoco.MjModel, size: tuple[int, int]) -> mujoco.MjModel:
    """What the renderer's OpenGL context is made from: a sky, a checker material (index 0),
    `model`'s ground geoms and height fields, and a framebuffer of `size`.

    The robot's model keeps no textures (robots/scene.py drops them) and a compiled model takes no
    new ones, so each frame's scene comes from the robot's model and is drawn by a context made
    from this one. The context draws a plane or height field from its own model, by the geom's
    and the height field's index, so those are copied to the same indices; other geoms only
    hold their places.
    """
    spec = mujoco.MjSpec()
    spec.visual.global_.offheight, spec.visual.global_.offwidth = size
    spec.visual.quality.shadowsize = 2048  # the light follows the robot: half the default is sharp, and cheaper
    spec.add_texture(name="sky", type=mujoco.mjtTexture.mjTEXTURE_SKYBOX, builtin=mujoco.mjtBuiltin.mjBUILTIN_GRADIENT,
                     rgb1=[0.55, 0.7, 0.85], rgb2=[0.95, 0.97, 1.0], width=256, height=1536)
    spec.add_texture(name="checker", type=mujoco.mjtTexture.mjTEXTURE_2D, builtin=mujoco.mjtBuiltin.mjBUILTIN_CHECKER,
                     rgb1=[0.62, 0.66, 0.70], rgb2=[0.38, 0.42, 0.46], width=64, height=64)
    material = spec.add_material(name="checker", texuniform=True, texrepeat=[0.5, 0.5])  # 1-m squares
    material.textures[mujoco.mjtTextureRole.mjTEXROLE_RGB] = "checker"
    for i in range(model.nhfield):
        adr, n = model.hfield_adr[i], model.hfield_nrow[i] * model.hfield_ncol[i]
        spec.add_hfield(name=f"h{i}", size=model.hfield_size[i], nrow=int(model.hfield_nrow[i]),
                        ncol=int(model.hfield_ncol[i]), userdata=model.hfield_data[adr:adr + n].tolist())
    for i in range(model.ngeom):
        if model.geom_type[i] in GROUND:
            hfield = f"h{model.geom_dataid[i]}" if model.geom_type[i] == mujoco.mjtGeom.mjGEOM_HFIELD else ""
            spec.worldbody.add_geom(type=mujoco.mjtGeom(model.geom_type[i]), size=model.geom_size[i], hfieldname=hfield)
        else:
            spec.worldbody.add_geom(type=mujoco.mjtGeom.mjGEOM_SPHERE, size=[0.1, 0, 0])
    context = spec.compile()
    context.hfield_data[:] = model.hfield_data  # the compiler rescales each to [0, 1]
    return context


def _checker_ground(scene: mujoco.MjvScene) -> None:
    """Lay the checker texture (1 m squares) on the ground's plane or height field."""
    for geom in scene.geoms[:scene.ngeom]:
        if geom.type in GROUND:
            geom.matid = 0
            geom.rgba[:] = 1.0


def _tracking_camera(pelvis: int) -> mujoco.MjvCamera:
    camera = mujoco.MjvCamera()
    camera.type = mujoco.mjtCamera.mjCAMERA_TRACKING
    camera.trackbodyid = pelvis
    camera.distance, camera.elevation, camera.azimuth = 3.0, -15.0, 120.0
    return camera


def _arrows(scene: mujoco.MjvScene, at: np.ndarray, xmat: np.ndarray, cmd: np.ndarray, force: np.ndarray) -> None:
    """The commanded velocity (`cmd` vx, vy in the heading frame of the pelvis at `at`, oriented
    `xmat`) above the pelvis, and the push `force` (world frame) ending at it while it acts."""
    yaw = np.arctan2(xmat[3], xmat[0])  # the pelvis's yaw (z-y-x), as `trajectory.heading_velocity` reads it
    c, s = np.cos(yaw), np.sin(yaw)
    velocity = np.array([c * cmd[0] - s * cmd[1], s * cmd[0] + c * cmd[1], 0.0])
    start = at + np.array([0.0, 0.0, CMD_LIFT])
    _arrow(scene, start, start + CMD_SCALE * velocity, CMD_RGBA)
    _arrow(scene, at - FORCE_SCALE * np.asarray(force, np.float64), at, FORCE_RGBA)


def _arrow(scene: mujoco.MjvScene, start: np.ndarray, end: np.ndarray, rgba: np.ndarray) -> None:
    """Add an arrow to the scene, unless it is shorter than 2 cm (no command, no push) or the scene is full."""
    if np.linalg.norm(end - start) < 0.02 or scene.ngeom >= scene.maxgeom:
        return
    geom = scene.geoms[scene.ngeom]
    mujoco.mjv_initGeom(geom, mujoco.mjtGeom.mjGEOM_ARROW, np.zeros(3), np.zeros(3), np.eye(3).ravel(), rgba)
    mujoco.mjv_connector(geom, mujoco.mjtGeom.mjGEOM_ARROW, 0.025, start, end)
    scene.ngeom += 1
