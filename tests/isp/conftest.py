"""Fixtures of the isp tests: the real RAW samples of ../shared/data/raw_samples."""

from __future__ import annotations

import sys
from pathlib import Path

import pytest

# pytest's "prepend" import mode puts tests/ on sys.path, where this folder would shadow the real
# ``isp`` package as a namespace package (the editable install's finder comes after PathFinder);
# a regular package anywhere on sys.path wins over namespace portions, so put the root there.
_ROOT = str(Path(__file__).resolve().parents[2])
if _ROOT not in sys.path:
    sys.path.append(_ROOT)


@pytest.fixture(scope="package")
def raw_dir(shared_data):
    d = shared_data / "raw_samples"
    if not d.is_dir():
        pytest.skip(f"{d} not present")
    return d


@pytest.fixture(scope="package")
def dng_550d(raw_dir):
    return raw_dir / "tinydng_colorchart_Canon_EOS_Kiss_X4_MagicLantern.dng"


@pytest.fixture(scope="package")
def crw_d30(raw_dir):
    return raw_dir / "rawsamples_RAW_CANON_D30_SRGB.CRW"


@pytest.fixture(scope="package")
def dng_350d(raw_dir):
    return raw_dir / "exiftool_DNG_Canon_EOS_350D_metadata_only.dng"


@pytest.fixture(scope="package")
def raw_550d(dng_550d):
    from isp import read_raw

    return read_raw(dng_550d)
