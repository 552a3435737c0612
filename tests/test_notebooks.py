"""The notebooks run top to bottom (so they cannot rot)."""

import subprocess
import sys
from pathlib import Path

import pytest

from conftest import ROOT

# Each notebook compiles and runs MJX programs (02 trains a few generations): tens of seconds each.
pytestmark = pytest.mark.slow

NOTEBOOKS = sorted((ROOT / "notebooks").glob("*.ipynb"))

# Executes one notebook in its own kernel; prints the code cells' errors, if any.
RUN = """
import sys, nbformat
from nbclient import NotebookClient
nb = nbformat.read(sys.argv[1], as_version=4)
NotebookClient(nb, timeout=600, kernel_name="python3", resources={"metadata": {"path": sys.argv[2]}}).execute()
errors = [o for c in nb.cells if c.cell_type == "code" for o in c.get("outputs", []) if o.get("output_type") == "error"]
print(errors)
sys.exit(1 if errors else 0)
"""


@pytest.fixture(scope="module")
def executions():
    """Every notebook starts at once, each in a process of its own: each compiles mostly on one core."""
    procs = {path: subprocess.Popen([sys.executable, "-c", RUN, str(path), str(path.parent)], cwd=ROOT, text=True,
                                    stdout=subprocess.PIPE, stderr=subprocess.STDOUT) for path in NOTEBOOKS}
    yield procs
    for proc in procs.values():
        proc.kill()
        proc.wait()


@pytest.mark.parametrize("path", NOTEBOOKS, ids=[p.name for p in NOTEBOOKS])
def test_notebook_runs(path: Path, executions):
    out, _ = executions[path].communicate(timeout=900)
    assert executions[path].returncode == 0, out[-5000:]
