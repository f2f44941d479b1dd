"""Shared fixtures: paths to the repository's data and to the real third-party data."""

import os
from pathlib import Path

import pytest

# The suite runs on every core (pytest-xdist, pyproject.toml): one BLAS thread per worker,
# set here before the workers start, so that they do not oversubscribe the cores and the
# CPU times the tests read are the work's own.
for _var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

REPO = Path(__file__).resolve().parents[1]
SHARED_DATA = REPO.parent / "shared" / "data"


@pytest.fixture(scope="session")
def repo() -> Path:
    return REPO


@pytest.fixture(scope="session")
def shared_data() -> Path:
    """``../shared/data`` beside the repository; skip where it is absent."""
    if not SHARED_DATA.is_dir():
        pytest.skip(f"real third-party data not found at {SHARED_DATA} "
                    "(tests on real data need ../shared/data beside the repository)")
    return SHARED_DATA
