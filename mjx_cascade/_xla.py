"""Process-wide JAX/XLA settings the project needs on every machine.

On small CPU machines a jitted `jax.vmap(mjx.step)` over 64 or more environments hangs for
ever inside `block_until_ready` unless XLA's concurrency-optimised CPU scheduler is off.
The flag is read when JAX creates its CPU backend, so it is appended to `XLA_FLAGS` at
import time; it has no effect on GPU backends.
"""

from __future__ import annotations

import os
import sys
from pathlib import Path

CPU_SCHEDULER_FLAG = "--xla_cpu_enable_concurrency_optimized_scheduler=false"


def configure() -> None:
    """Add the CPU scheduler flag to `XLA_FLAGS` unless the user set that option already."""
    flags = os.environ.get("XLA_FLAGS", "")
    if "xla_cpu_enable_concurrency_optimized_scheduler" not in flags:
        os.environ["XLA_FLAGS"] = f"{flags} {CPU_SCHEDULER_FLAG}".strip()
    if cpu_backend_started():
        print(
            "mjx_cascade: JAX's CPU backend started before mjx_cascade was imported; "
            f"if batched CPU runs hang, set XLA_FLAGS={CPU_SCHEDULER_FLAG}",
            file=sys.stderr,
        )


def cpu_model() -> str:
    """The host CPU's model name: XLA's CPU code, and so the last bits of training, depend on it,
    as a CPU run's wall-clock does."""
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                return line.split(":", 1)[1].strip()
    except OSError:
        pass
    import platform

    return platform.processor() or platform.machine()


DEVICE_COUNT_FLAG = "--xla_force_host_platform_device_count"


def cores() -> int:
    """The CPU cores this process may use (all of them where the OS cannot say, as on macOS)."""
    return len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else (os.cpu_count() or 1)


def cpu_devices(value: str, population: int | None = None, limit: int | None = None) -> int:
    """`--cpu-devices`: a positive count, or `auto`: one device per core this process may use, as
    many as share `population` evenly and the robot allows (`limit`, its `max_cpu_devices`)."""
    if value == "auto":
        cap = min(cores(), limit or cores())
        return max(n for n in range(1, cap + 1) if population is None or population % n == 0)
    try:
        n = int(value)
    except ValueError:
        n = 0
    if n < 1:
        raise ValueError(f"--cpu-devices takes a positive count or auto, got {value!r}")
    return n


def cpu_split_given() -> bool:
    """Whether `XLA_FLAGS` already names a host device count (the user's own split)."""
    return DEVICE_COUNT_FLAG in os.environ.get("XLA_FLAGS", "")


def split_cpu(devices: int) -> None:
    """Split the CPU into `devices` JAX devices (the population is sharded over them). XLA reads
    the flag when JAX creates its CPU backend, so this must come before any JAX work; a count
    given in `XLA_FLAGS` already is replaced."""
    if cpu_backend_started():
        raise RuntimeError("JAX's CPU backend has started: split the CPU before any JAX work")
    kept = [f for f in os.environ.get("XLA_FLAGS", "").split() if not f.startswith(DEVICE_COUNT_FLAG)]
    os.environ["XLA_FLAGS"] = " ".join(kept + [f"{DEVICE_COUNT_FLAG}={devices}"])


def cpu_backend_started() -> bool:
    """Whether JAX's CPU backend exists in this process (a split would then come too late)."""
    xb = sys.modules.get("jax._src.xla_bridge")
    return bool(xb is not None and getattr(xb, "_backends", None))


def enable_compilation_cache(path: str | None = None) -> None:
    """Keep compiled XLA programs on disk so a rerun of the same command starts in seconds.

    Uses `JAX_COMPILATION_CACHE_DIR` when set, else `path`, else `~/.cache/mjx_cascade/xla`.
    """
    import jax

    target = os.environ.get("JAX_COMPILATION_CACHE_DIR") or path
    target = target or os.path.join(os.path.expanduser("~"), ".cache", "mjx_cascade", "xla")
    jax.config.update("jax_compilation_cache_dir", target)
    jax.config.update("jax_persistent_cache_min_compile_time_secs", 1.0)
