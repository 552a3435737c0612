"""The population axis is sharded over every local device: one generation on 1 and on 4
(simulated) CPU devices gives the same parameters within floating-point tolerance, and a
checkpoint saved on 4 devices reads on 1."""

import os
import subprocess
import sys

import numpy as np
import pytest

from conftest import ROOT
from mjx_cascade import checkpoint

pytestmark = pytest.mark.slow

SCRIPT = """
import sys
from pathlib import Path
import mjx_cascade, jax, jax.numpy as jnp, numpy as np
from mjx_cascade import checkpoint, config, train
assert len(jax.devices()) == int(sys.argv[2]), jax.devices()
# the CLI's MJX smoke run's settings: MJX shares the population over the devices (the C engine, Cassie's
# default, trains on one)
cfg = config.robot_config("cassie").override(**{"es.population": 4, "episode.seconds": 0.5,
    "episode.pool_size": 4, "physics.impl": "jax"})
trainer = train.setup(cfg)
state, metrics = trainer.run(trainer.state, jnp.int32(1))
np.save(sys.argv[1], np.stack([np.asarray(trainer.state.mean), np.asarray(state.mean)]))
checkpoint.save(checkpoint.manager(Path(sys.argv[1]).with_suffix("")), 1, state, {"robot": "cassie"})
"""


def start_generation(path, devices):
    """One generation on `devices` CPU devices, in a subprocess that writes `path`."""
    # one device is the default: no flag, so the cache key matches the CLI runs of test_cli.py
    flags = os.environ.get("XLA_FLAGS", "") + (f" --xla_force_host_platform_device_count={devices}" if devices > 1 else "")
    return subprocess.Popen([sys.executable, "-c", SCRIPT, str(path), str(devices)], stdout=subprocess.DEVNULL,
                            stderr=subprocess.PIPE, text=True, cwd=ROOT,
                            env={**os.environ, "XLA_FLAGS": flags, "JAX_PLATFORMS": "cpu"})


def finish(proc, path):
    """`[start, after]` means, once `proc` is done."""
    _, err = proc.communicate(timeout=600)
    assert proc.returncode == 0, err[-3000:]
    return np.load(path)


def test_one_and_four_devices_agree(tmp_path):
    # both at once: each compiles mostly on one core
    procs = start_generation(tmp_path / "one.npy", 1), start_generation(tmp_path / "four.npy", 4)
    start, one = finish(procs[0], tmp_path / "one.npy")
    _, four = finish(procs[1], tmp_path / "four.npy")
    assert np.all(np.isfinite(one)) and np.max(np.abs(one - start)) > 1e-4  # the generation moved them
    np.testing.assert_allclose(four, one, rtol=1e-5, atol=1e-6)
    meta, params = checkpoint.read(tmp_path / "four")  # this process has one device
    assert meta["generation"] == 1
    np.testing.assert_array_equal(params, four)
