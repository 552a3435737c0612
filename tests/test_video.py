"""The video: an mp4 through mediapy, a GIF without it, and what the frames show.

The encoder tests replace `video.frames` with a synthetic clip, so they need no OpenGL. Real
frames render in a child process, where `MUJOCO_GL` can still choose EGL before MuJoCo is first
imported (in this process another test file may have imported it already).
"""

from __future__ import annotations

import os
import subprocess
import sys

import mujoco
import numpy as np
import pytest
from PIL import Image

from conftest import ROOT
from mjx_cascade import video


def standing(model_qpos: np.ndarray, seconds: float, vx: float = 0.0, push: float = 0.0) -> dict:
    """A trajectory standing still at `model_qpos`, recorded every 10 ms, with a constant command
    `vx` and a sideways `push` (N) over its second half."""
    t = np.arange(0.0, seconds, 0.01)
    force = np.zeros((len(t), 3))
    force[len(t) // 2:, 1] = push
    return {"t": t, "qpos": np.tile(model_qpos, (len(t), 1)), "cmd": np.tile([vx, 0.0, 0.0], (len(t), 1)),
            "force": force}


def synthetic_frames(traj, model, pelvis, fps=video.FPS, size=video.SIZE):
    """What `video.frames` returns, without OpenGL: one frame per 1/fps s, a bar moving across."""
    t = traj["t"]
    n = len(np.arange(t[0], t[-1], 1.0 / fps))
    clip = np.zeros((n, *size, 3), np.uint8)
    for k in range(n):
        clip[k, :, k * size[1] // n:(k + 1) * size[1] // n] = 255
    return clip


def frame_count(seconds: float, fps: int) -> int:
    return len(np.arange(0.0, seconds - 0.01, 1.0 / fps))  # the last record is at seconds - 10 ms


def test_render_writes_an_mp4(cassie, tmp_path, monkeypatch):
    imageio_ffmpeg = pytest.importorskip("imageio_ffmpeg", reason="the video extra is not installed")
    if video.load_mediapy() is None:
        pytest.skip("mediapy or an ffmpeg is missing: pip install -e '.[video]'")
    monkeypatch.setattr(video, "frames", synthetic_frames)
    traj = standing(cassie.nominal_qpos, 1.0)
    assert video.render(traj, cassie.model, tmp_path, cassie.pelvis_body) == "video.mp4"
    # mediapy's reader passes ffmpeg 9 an option it removed (-vsync); imageio-ffmpeg's reads any
    reader = imageio_ffmpeg.read_frames(str(tmp_path / "video.mp4"))
    meta = next(reader)
    assert meta["size"] == video.SIZE[::-1] and meta["fps"] == video.FPS
    assert sum(1 for _ in reader) == frame_count(1.0, video.FPS)
    assert not (tmp_path / "video.gif").exists()


def test_render_falls_back_to_a_gif_without_mediapy(cassie, tmp_path, monkeypatch):
    monkeypatch.setitem(sys.modules, "mediapy", None)  # `import mediapy` raises ImportError
    assert video.load_mediapy() is None
    monkeypatch.setattr(video, "frames", synthetic_frames)
    traj = standing(cassie.nominal_qpos, 1.0)
    assert video.render(traj, cassie.model, tmp_path, cassie.pelvis_body) == "video.gif"
    with Image.open(tmp_path / "video.gif") as gif:
        assert gif.size == video.GIF_SIZE[::-1]
        assert gif.n_frames == frame_count(1.0, video.GIF_FPS)
    assert not (tmp_path / "video.mp4").exists()


def test_render_says_why_it_wrote_nothing(cassie, tmp_path, monkeypatch):
    def no_context(*args, **kwargs):
        raise video.NoVideo("no video: MuJoCo could not open an OpenGL context (test)")

    monkeypatch.setattr(video, "frames", no_context)
    note = video.render(standing(cassie.nominal_qpos, 1.0), cassie.model, tmp_path, cassie.pelvis_body)
    assert note.startswith("no video:")
    assert list(tmp_path.iterdir()) == []


# Renders Cassie standing (the model and trajectories from the parent, as files): `render`'s mp4,
# and small clips with and without a command and a push. Exits 3 with the reason where MuJoCo
# cannot render.
RENDER = """
import sys
import mujoco, numpy as np
from mjx_cascade import video
model = mujoco.MjModel.from_binary_path(sys.argv[1])
data = np.load(sys.argv[2], allow_pickle=True)
pelvis = int(data["pelvis"])
note = video.render(data["walk"].item(), model, sys.argv[3], pelvis)
if note.startswith("no video"):
    print(note)
    sys.exit(3)
clips = {k: video.frames(data[k].item(), model, pelvis, fps=10, size=(120, 160)) for k in ("still", "command", "push")}
np.savez(sys.argv[4], note=note, **clips)
"""


@pytest.fixture(scope="module")
def rendered(cassie, tmp_path_factory):
    """What the child process rendered: `render`'s note and its file's directory, and the clips."""
    out = tmp_path_factory.mktemp("rendered")
    mujoco.mj_saveModel(cassie.model, str(out / "cassie.mjb"), None)
    q = cassie.nominal_qpos
    np.savez(out / "in.npz", pelvis=cassie.pelvis_body, walk=standing(q, 0.5, vx=0.5, push=60.0),
             still=standing(q, 0.2), command=standing(q, 0.2, vx=0.8), push=standing(q, 0.2, push=60.0))
    env = dict(os.environ)
    if sys.platform.startswith("linux") and not env.get("DISPLAY"):
        env.setdefault("MUJOCO_GL", "egl")  # as `mjx-cascade eval` does without a display
    proc = subprocess.run([sys.executable, "-c", RENDER, out / "cassie.mjb", out / "in.npz", out, out / "clips.npz"],
                          cwd=ROOT, env=env, capture_output=True, text=True, timeout=300)
    if proc.returncode == 3:
        pytest.skip(f"MuJoCo cannot render on this machine: {proc.stdout.strip()}")
    assert proc.returncode == 0, proc.stderr[-3000:]
    return out, dict(np.load(out / "clips.npz"))


def test_rendered_video_decodes_at_its_size(rendered):
    out, clips = rendered
    name = str(clips["note"])
    if name == "video.mp4":
        import imageio_ffmpeg

        reader = imageio_ffmpeg.read_frames(str(out / name))
        assert next(reader)["size"] == video.SIZE[::-1]
        assert sum(1 for _ in reader) == frame_count(0.5, video.FPS)
    else:  # without mediapy or an ffmpeg
        assert name == "video.gif"
        with Image.open(out / name) as gif:
            assert gif.size == video.GIF_SIZE[::-1] and gif.n_frames == frame_count(0.5, video.GIF_FPS)


def colored(before: np.ndarray, after: np.ndarray, channel: int) -> int:
    """Pixels that changed from `before` to `after` and are now mostly `channel` (0 red, 1 green)."""
    changed = np.any(before != after, axis=-1)
    rgb = after.astype(int)
    dominant = np.all(rgb[..., channel:channel + 1] > np.delete(rgb, channel, axis=-1) + 60, axis=-1)
    return int(np.sum(changed & dominant))


def test_frames_draw_the_command_and_the_push(rendered):
    _, clips = rendered
    still, command, push = clips["still"], clips["command"], clips["push"]
    assert still.shape == command.shape == push.shape == (2, 120, 160, 3) and still.dtype == np.uint8
    assert colored(still, command, channel=1) > 20  # a green arrow for vx = 0.8 m/s
    assert colored(still[0], push[0], channel=0) == 0  # no push yet
    assert colored(still[1], push[1], channel=0) > 20  # a red arrow while it acts
