"""Shared fixtures: the real measured data in ../shared/data (tests skip cleanly without it)."""

from __future__ import annotations

import os
from pathlib import Path

import pytest
from hypothesis import settings

# CI runs one fixed set of hypothesis examples (HYPOTHESIS_PROFILE=ci in .ci/run), so a landing is
# judged on reproducible tests; local runs keep exploring new random examples. A failure found locally
# prints its reproduction blob.
settings.register_profile("ci", derandomize=True, print_blob=True)
settings.register_profile("default", print_blob=True)
settings.load_profile(os.environ.get("HYPOTHESIS_PROFILE", "default"))

os.environ.setdefault("VTK_DEFAULT_OPENGL_WINDOW", "vtkEGLRenderWindow")
os.environ.setdefault("JAX_PLATFORMS", "cpu")

#: ../shared/data relative to the repository root (override with ZONOTOPE_SHARED_DATA).
SHARED_DATA = Path(
    os.environ.get("ZONOTOPE_SHARED_DATA", Path(__file__).resolve().parents[1].parent / "shared" / "data")
)


@pytest.fixture(scope="package")
def shared_data() -> Path:
    """Path of ../shared/data; skips the test when the folder is absent."""
    if not SHARED_DATA.is_dir():
        pytest.skip(f"shared data folder {SHARED_DATA} not present")
    return SHARED_DATA


@pytest.fixture(scope="package")
def dask_cluster():
    """A real ``dask scheduler`` + 2 ``dask worker`` processes on localhost, shared by the batch tests
    (tests/_dask_cluster.py; a test that kills a worker gets a replacement started)."""
    from ._dask_cluster import LocalDaskCluster

    cluster = LocalDaskCluster(2)
    yield cluster
    cluster.close()


def pytest_terminal_summary(terminalreporter):
    """One line saying whether the measured data was there: a run without it skips every test of real
    cameras, files and reflectances and still ends green, so the summary says which run this was."""
    skipped = [
        r for r in terminalreporter.stats.get("skipped", ()) if "shared data folder" in str(r.longrepr)
    ]
    where = "present" if SHARED_DATA.is_dir() else "ABSENT"
    terminalreporter.write_line(
        f"shared data {SHARED_DATA}: {where}; {len(skipped)} tests skipped for want of it"
    )
