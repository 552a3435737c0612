"""Faults survived: SIGKILL at any moment, or in the middle of a checkpoint write, and the rerun
of the same command ends with exactly the parameters of a run that was never interrupted."""

import functools
import json
import signal
import subprocess
import sys
import time

import pytest

from conftest import ROOT
from test_cli import SMOKE, cli, finished, start_cli

pytestmark = pytest.mark.slow

RUN = ["train", "--robot", "cassie", "--generations", "6", "--checkpoint-every", "2",
       "--set", "train.generations_per_call=2", *SMOKE]

# Runs the CLI but kills itself (SIGKILL) at the moment orbax commits checkpoint 4: the data is
# written to a temporary directory whose rename would make it the new checkpoint.
KILL_AT_COMMIT = """
import os, signal, sys
from orbax.checkpoint._src.path import async_path
rename = async_path.rename
async def dying_rename(src, dst):
    if str(dst).rstrip("/").endswith("/4"):
        os.kill(os.getpid(), signal.SIGKILL)
    return await rename(src, dst)
async_path.rename = dying_rename
from mjx_cascade.cli import main
sys.exit(main(sys.argv[1:]))
"""


def sha(out):
    res = cli("info", "--checkpoint", out, "--json")
    assert res.returncode == 0, res.stderr
    return json.loads(res.stdout)


def start(out):
    """`RUN` into `out` in the background."""
    return start_cli(out, *RUN[:3], "--out", out, *RUN[3:])


@pytest.fixture(scope="module")
def uninterrupted(tmp_path_factory):
    """`()` -> the info of the run never interrupted. It trains beside the first test's runs (each
    mostly on one core) and is waited for where it is first compared."""
    out = tmp_path_factory.mktemp("straight") / "run"
    proc = start(out)

    @functools.cache
    def info():
        res = finished(proc, out)
        assert res.returncode == 0, res.stderr[-3000:]
        return sha(out)

    yield info
    proc.kill()
    proc.wait()


def generations_logged(out):
    return [json.loads(line)["generation"] for line in (out / "metrics.jsonl").read_text().splitlines()]


def test_sigkill_then_rerun_gives_the_uninterrupted_parameters(uninterrupted, tmp_path):
    out = tmp_path / "run"
    proc = start(out)
    deadline = time.time() + 500
    while not (out / "checkpoints" / "2").is_dir() and proc.poll() is None and time.time() < deadline:
        time.sleep(0.02)
    proc.send_signal(signal.SIGKILL)  # somewhere in generations 3 to 6
    proc.wait()
    res = cli(*RUN[:3], "--out", out, *RUN[3:])
    assert res.returncode == 0, res.stderr[-3000:]
    assert sha(out)["params_sha256"] == uninterrupted()["params_sha256"]
    assert generations_logged(out) == [1, 2, 3, 4, 5, 6]  # no line lost, none repeated


def test_kill_during_a_checkpoint_write_leaves_the_previous_one(uninterrupted, tmp_path):
    out = tmp_path / "run"
    res = subprocess.run([sys.executable, "-c", KILL_AT_COMMIT, *RUN[:3], "--out", str(out), *RUN[3:]],
                         cwd=ROOT, capture_output=True, text=True, timeout=600)
    assert res.returncode == -signal.SIGKILL, res.stderr[-3000:]
    leftovers = [p.name for p in (out / "checkpoints").iterdir()]
    assert "2" in leftovers and "4" not in leftovers and any(name.startswith("4.") for name in leftovers)
    assert sha(out)["generation"] == 2  # the interrupted write is invisible
    res = cli(*RUN[:3], "--out", out, *RUN[3:])
    assert res.returncode == 0, res.stderr[-3000:]
    assert sha(out)["params_sha256"] == uninterrupted()["params_sha256"]
    assert generations_logged(out) == [1, 2, 3, 4, 5, 6]
