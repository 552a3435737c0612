"""Interactive play: the policy walking in MuJoCo's viewer in real time, steered from the keyboard.

`Play` holds one robot's runtime (`runtime.Runtime`, MuJoCo's C engine), its `MjData` and the
command. The viewer calls `Play.key` from its own thread; the keys wait in a queue until the
loop applies them between frames, so the command never changes inside a physics step. `run`
advances the physics in real time and syncs the viewer; `play` opens MuJoCo's passive viewer,
and tests hand `run` a stand-in with the viewer's methods. The viewer's own mouse perturbation
(Ctrl + right drag) writes `xfrc_applied`, which the loop leaves alone: it pushes the robot.
"""

from __future__ import annotations

import os
import queue
import sys
import time
from typing import Any

import mujoco
import numpy as np

from mjx_cascade.config import Config, ConfigError
from mjx_cascade.regulators import wrap_angle
from mjx_cascade.runtime import Runtime

# GLFW key codes, as the viewer's key callback receives them
KEY_RIGHT, KEY_LEFT, KEY_DOWN, KEY_UP = 262, 263, 264, 265
KEY_PAGE_UP, KEY_PAGE_DOWN, KEY_HOME, KEY_DELETE = 266, 267, 268, 261
STEPS = {KEY_UP: (0, 0.1), KEY_DOWN: (0, -0.1), KEY_LEFT: (1, 0.05), KEY_RIGHT: (1, -0.05),
         KEY_PAGE_UP: (2, 0.1), KEY_PAGE_DOWN: (2, -0.1)}  # command index, change per press
FRAME = 1.0 / 60.0  # s of simulated time between viewer syncs


class Play:
    """The robot, its command and its key handling; velocities stay within the ranges the policy
    trained on (`episode.vx`, `episode.vy`), the heading is any angle."""

    def __init__(self, rt: Runtime, cfg: Config):
        self.rt = rt
        self.d = mujoco.MjData(rt.robot.model)
        self.low = np.array([cfg.episode.vx[0], cfg.episode.vy[0], -np.inf])
        self.high = np.array([cfg.episode.vx[1], cfg.episode.vy[1], np.inf])
        self.cmd = np.zeros(3)
        self._keys: queue.SimpleQueue[int] = queue.SimpleQueue()
        self.reset()

    def key(self, code: int) -> None:
        """The viewer's key callback: any thread."""
        self._keys.put(code)

    def reset(self) -> None:
        """Stand the robot at the origin facing +x, with a zero command."""
        self.cmd = np.zeros(3)
        self.rt.reset(self.d, self.cmd)

    def apply_keys(self) -> None:
        while not self._keys.empty():
            code = self._keys.get()
            if code in STEPS:
                i, change = STEPS[code]
                self.cmd[i] = np.clip(self.cmd[i] + change, self.low[i], self.high[i])
                self.cmd[2] = float(wrap_angle(self.cmd[2]))
            elif code == KEY_HOME:
                self.cmd[:2] = 0.0
            elif code == KEY_DELETE:
                self.reset()

    def advance(self, seconds: float) -> None:
        """Apply the keys pressed since the last call, then simulate `seconds` under the command."""
        self.apply_keys()
        m = self.rt.robot.model
        for _ in range(max(1, int(round(seconds / self.rt.dt)))):
            self.rt.control(self.d, self.cmd)
            mujoco.mj_step(m, self.d)

    def text(self) -> tuple[str, str]:
        """The overlay: what is commanded, and the time."""
        vx, vy, heading = self.cmd
        return ("forward (Up/Down)\nsideways (Left/Right)\nheading (PgUp/PgDn)\nstop: Home, reset: Delete\ntime",
                f"{vx:+.2f} m/s\n{vy:+.2f} m/s\n{heading:+.2f} rad\n\n{self.d.time:.1f} s")


def run(p: Play, viewer: Any, seconds: float | None = None, realtime: bool = True) -> None:
    """Drive `viewer` (a `mujoco.viewer.Handle`, or anything with its `is_running`, `lock`,
    `set_texts` and `sync`) until it closes or `seconds` of simulated time have passed."""
    while viewer.is_running() and (seconds is None or p.d.time < seconds):
        start = time.perf_counter()
        with viewer.lock():
            p.advance(FRAME)
        if hasattr(viewer, "set_texts"):  # MuJoCo >= 3.3.3; older viewers show no overlay
            viewer.set_texts((None, None, *p.text()))
        viewer.sync()
        if realtime:
            time.sleep(max(0.0, FRAME - (time.perf_counter() - start)))


def check_display() -> None:
    """Refuse in one line where no window can open."""
    if sys.platform.startswith("linux") and not (os.environ.get("DISPLAY") or os.environ.get("WAYLAND_DISPLAY")):
        raise ConfigError("play needs a display and none is set (DISPLAY); sim2sim runs the same policy "
                          "headless and writes a video")


def play(robot: str, source: str | None, model_path: str | None, dt: float | None, seconds: float | None = None) -> None:
    """Open the viewer with `robot`'s policy (`source`: a policy or checkpoint directory or a
    bundle; default the shipped one) walking in real time."""
    import mujoco.viewer

    from mjx_cascade import bundle, evaluate, robots

    cfg, found = evaluate.load_policy(robot, source, dt)
    rt = Runtime(robots.build(robots.get(cfg.robot), cfg.physics, model_path), cfg, found.params)
    if source and bundle.is_bundle(source):
        bundle.check(source, rt.robot)
    p = Play(rt, cfg)
    try:
        viewer = mujoco.viewer.launch_passive(rt.robot.model, p.d, key_callback=p.key)
    except RuntimeError as e:  # macOS outside mjpython, no OpenGL, ...
        raise ConfigError(f"the viewer did not open: {e}") from None
    with viewer:
        run(p, viewer, seconds)
