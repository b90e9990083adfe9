"""Shared fixtures. Real-data tests use the ``real_data_dir`` fixture: they skip
when MOCOMP_DATA_DIR is unset, except under CI (CI=true), where that is a failure."""
from __future__ import annotations

import os
from pathlib import Path

import pytest
from hypothesis import settings as hypothesis_settings

from mocomp.datasets import data_dir

IN_CI = os.environ.get("CI", "").lower() in ("1", "true", "yes")

# Property tests (hypothesis): under CI the examples are derived from each test's
# source (derandomize) and no example database is kept, so a CI run is
# reproducible and cannot flake; locally they explore new random examples on
# every run (HYPOTHESIS_PROFILE=ci reproduces CI).
hypothesis_settings.register_profile("ci", derandomize=True, database=None, print_blob=True)
hypothesis_settings.register_profile("dev", print_blob=True)
hypothesis_settings.load_profile(os.environ.get("HYPOTHESIS_PROFILE", "ci" if IN_CI else "dev"))


@pytest.fixture(scope="session")
def real_data_dir() -> Path:
    d = data_dir()
    if d is None:
        if IN_CI:
            pytest.fail("CI=true but MOCOMP_DATA_DIR is not set: real-data tests must run in CI")
        pytest.skip("MOCOMP_DATA_DIR not set (real capture clips unavailable)")
    return d


def real_files(pattern: str) -> list[Path]:
    """Real clips matching a glob below the data directory, for parametrization.

    Under CI a missing data directory or an empty match fails at collection time.
    """
    d = data_dir()
    if d is None:
        if IN_CI:
            raise RuntimeError("CI=true but MOCOMP_DATA_DIR is not set")
        return []
    files = sorted(d.glob(pattern))
    if not files and IN_CI:
        raise RuntimeError(f"no real clips match {pattern!r} under {d}")
    return files
