"""The suite without Digit's model: its tests skip with the reason, and fail where CI requires them."""

import os
import subprocess
import sys
from pathlib import Path

from conftest import DIGIT_MISSING

NEEDS_DIGIT = "from conftest import digit_model  # noqa: F401\n\n\ndef test_needs_digit(digit_model):\n    pass\n"


def _pytest_without_digit(tmp_path: Path, **env: str) -> subprocess.CompletedProcess:
    """pytest on one test that needs Digit's model, with `DIGIT_MODEL_PATH` pointing nowhere."""
    (tmp_path / "test_needs_digit.py").write_text(NEEDS_DIGIT)
    base = {k: v for k, v in os.environ.items() if k != "MJX_CASCADE_REQUIRE_DIGIT"}
    return subprocess.run([sys.executable, "-m", "pytest", "-q", "-rs", "-p", "no:cacheprovider", tmp_path],
                          capture_output=True, text=True, timeout=120, cwd=tmp_path,
                          env={**base, "PYTHONPATH": str(Path(__file__).parent), **env,
                               "DIGIT_MODEL_PATH": str(tmp_path / "nowhere" / "digit-v3.xml")})


def test_a_missing_digit_model_skips_with_the_reason_and_fails_where_required(tmp_path):
    skipped = _pytest_without_digit(tmp_path)
    assert skipped.returncode == 0 and "1 skipped" in skipped.stdout, skipped.stdout
    assert DIGIT_MISSING in skipped.stdout
    required = _pytest_without_digit(tmp_path, MJX_CASCADE_REQUIRE_DIGIT="1")
    assert required.returncode == 1 and "1 error" in required.stdout and "skipped" not in required.stdout
    assert DIGIT_MISSING in required.stdout
