"""MJX behind one door: backend choice, model upload, per-batch data templates.

`impl` follows MuJoCo Playground's convention: `jax` (pure JAX, any device) or `warp`
(MuJoCo Warp kernels, NVIDIA GPUs, several times faster there). `auto` picks `warp` when
JAX runs on a CUDA GPU and `mujoco-warp` is installed, else `jax`.
"""

from __future__ import annotations

import contextlib
import functools
import importlib.util
import io
import sys

import jax
import mujoco

with contextlib.redirect_stdout(io.StringIO()):  # mjx prints "Failed to import warp" to stdout
    from mujoco import mjx

from mjx_cascade.config import ConfigError, PhysicsConfig

__all__ = ["mjx", "resolve_impl", "put_model", "make_data"]


def warp_available() -> bool:
    return jax.default_backend() == "gpu" and importlib.util.find_spec("mujoco_warp") is not None


def resolve_impl(impl: str) -> str:
    """`auto` -> `warp` or `jax`; an explicit `warp` where it cannot run is a ConfigError. With
    MuJoCo Warp installed but JAX on the CPU (a CPU-only jaxlib), `auto` says so once on stderr
    rather than fall back quietly."""
    if impl == "auto":
        if warp_available():
            return "warp"
        if jax.default_backend() == "cpu" and importlib.util.find_spec("mujoco_warp") is not None:
            _say_once("mjx_cascade: mujoco-warp is installed but JAX runs on the CPU, so MJX runs impl=jax; "
                      "for an NVIDIA GPU install JAX's CUDA build: pip install 'mjx-cascade[gpu]'")
        return "jax"
    if impl == "warp" and not warp_available():
        raise ConfigError("--impl warp needs an NVIDIA GPU and mujoco-warp (pip install 'mjx-cascade[warp]')")
    return impl


@functools.cache
def _say_once(message: str) -> None:
    print(message, file=sys.stderr)


def put_model(model: mujoco.MjModel, impl: str) -> mjx.Model:
    return mjx.put_model(model, impl=impl)


def make_data(model: mujoco.MjModel, impl: str, physics: PhysicsConfig, batch: int) -> mjx.Data:
    """An unbatched data template; warp sizes its contact buffer for `batch` environments."""
    if impl == "warp":
        return mjx.make_data(
            model,
            impl="warp",
            naconmax=physics.contacts_per_env * batch,
            njmax=physics.constraints_per_env,
        )
    return mjx.make_data(model, impl=impl)
