"""Shared fixtures. Importing mjx_cascade first sets the XLA CPU flag before JAX starts."""

from __future__ import annotations

import importlib.util
import os
from pathlib import Path

import mjx_cascade  # noqa: F401  (must precede any JAX work)
import pytest

ROOT = Path(__file__).resolve().parents[1]
SHARED = ROOT.parent / "shared"
DATA = Path(__file__).parent / "data"
DIGIT_MISSING = "Digit's model is not redistributable: set DIGIT_MODEL_PATH to digit-v3.xml"

# Offline: mujoco-menagerie reads Cassie from the shared copy instead of downloading it. A relative
# MENAGERIE_ROOT (the README's test command) is made absolute for subprocesses with other cwds.
if (SHARED / "menagerie").is_dir():
    os.environ.setdefault("MENAGERIE_ROOT", str(SHARED / "menagerie"))
if os.environ.get("MENAGERIE_ROOT"):
    os.environ["MENAGERIE_ROOT"] = str(Path(os.environ["MENAGERIE_ROOT"]).resolve())


# Files that compile a whole controller (20 to 60 s each) run first, so that under `pytest -n 2`
# the two workers share them and then finish the quick files together (pyproject.toml keeps this
# order with --no-loadscope-reorder). The shipped policy's walk comes early too: the walking
# benchmark's test (test_benchmarks.py) runs the same program and then finds it in the cache.
LONG_FIRST = ("test_smoke.py", "test_cli.py", "test_controller.py", "test_shipped_policy.py")


def pytest_collection_modifyitems(items):
    rank = {name: i for i, name in enumerate(LONG_FIRST)}
    items.sort(key=lambda item: rank.get(item.path.name, len(rank)))  # stable: file order otherwise


def benchmark_script(name: str):
    """`benchmarks/<name>.py` as a module (the scripts are not a package)."""
    spec = importlib.util.spec_from_file_location(name, ROOT / "benchmarks" / f"{name}.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


@pytest.fixture(scope="session", autouse=True)
def compilation_cache(tmp_path_factory):
    """One XLA cache for the whole session, shared with the CLI subprocesses and, under
    `pytest -n`, by every worker (their temporary directories sit side by side)."""
    base = tmp_path_factory.getbasetemp()
    shared = base.parent if os.environ.get("PYTEST_XDIST_WORKER") else base
    path = os.environ.get("JAX_COMPILATION_CACHE_DIR") or str(shared / "xla")
    Path(path).mkdir(parents=True, exist_ok=True)
    os.environ["JAX_COMPILATION_CACHE_DIR"] = path
    from mjx_cascade import _xla

    _xla.enable_compilation_cache(path)
    return path


def digit_model_path() -> Path | None:
    """Digit's model: `DIGIT_MODEL_PATH` where set, else the copy in ../shared; None where that is no file."""
    path = Path(os.environ.get("DIGIT_MODEL_PATH") or SHARED / "models" / "digit" / "digit-v3.xml")
    return path if path.is_file() else None


@pytest.fixture(scope="session")
def digit_model() -> Path:
    """Digit's model file. Without one a test that needs it is skipped, since Agility's model cannot
    ship with the code; where `MJX_CASCADE_REQUIRE_DIGIT=1` (CI, which has the model) it fails, so a
    lost model cannot pass unnoticed as skips."""
    path = digit_model_path()
    if path is None and os.environ.get("MJX_CASCADE_REQUIRE_DIGIT") == "1":
        pytest.fail(DIGIT_MISSING, pytrace=False)
    if path is None:
        pytest.skip(DIGIT_MISSING)
    return path


def model_for(request: pytest.FixtureRequest, robot: str) -> Path | None:
    """The model file a test of `robot` passes: Digit's (`digit_model`), else None for the default."""
    return request.getfixturevalue("digit_model") if robot == "digit" else None


@pytest.fixture(scope="session")
def cassie_cfg():
    from mjx_cascade import config

    # MJX at 1 ms: the accelerators' engine, at the step these tests' tolerances were measured at.
    # Cassie's config trains in MuJoCo's C engine at 2 ms; tests that name `impl` mujoco cover it.
    return config.robot_config("cassie").override(**{"episode.pool_size": 4, "episode.seconds": 0.25,
                                                      "physics.impl": "jax", "physics.dt": 0.001})


@pytest.fixture(scope="session")
def cassie(cassie_cfg):
    from mjx_cascade import robots

    return robots.build(robots.get("cassie"), cassie_cfg.physics)


@pytest.fixture(scope="session")
def cassie_network(cassie_cfg):
    """Cassie's motion policy network with its initial parameters (`cassie_network.init_params`)."""
    import jax

    from mjx_cascade import policy

    return policy.for_controller(cassie_cfg, 6, jax.random.PRNGKey(cassie_cfg.seed))


@pytest.fixture(scope="session")
def cassie_pool(cassie, cassie_cfg):
    from mjx_cascade import standing

    return standing.balanced_pool(cassie, cassie_cfg)


@pytest.fixture(scope="session")
def cassie_env(cassie, cassie_cfg, cassie_pool, cassie_network):
    from mjx_cascade.env import Env

    return Env(cassie, cassie_cfg, cassie_pool, cassie_network.apply)
