"""Fuzzing RAW metadata: random hostile values in the tags the development trusts (hypothesis).

The corpus of ``test_metadata_guards.py`` holds one file per reported case; here every draw puts a
random value (zero, tiny, huge, negative, non-finite rationals, wrong counts) into one of those
tags of a small DNG. Each file either reads to a RawImage that develops to a finite image, or is
refused with one RawFormatError line naming the file: never another exception, a NaN image or a
traceback.
"""

from __future__ import annotations

import shutil
from pathlib import Path

import numpy as np
import pytest
import tifffile
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import isp
from isp import RawFormatError, read_raw
from isp.dng import write_dng

CM = np.array([[0.8, -0.2, -0.05], [-0.3, 1.1, 0.2], [-0.05, 0.15, 0.6]])
MOSAIC = np.random.default_rng(0).integers(200, 3900, (48, 64)).astype(np.uint16)

#: tag code → (name, count of values, kind): the tags a development reads from the raw IFD.
TAGS = {
    256: ("ImageWidth", 1, "int"),
    257: ("ImageLength", 1, "int"),
    258: ("BitsPerSample", 1, "int"),
    50714: ("BlackLevel", 1, "rational"),
    50717: ("WhiteLevel", 1, "int"),
    50721: ("ColorMatrix1", 9, "srational"),
    50728: ("AsShotNeutral", 3, "rational"),
}

COUNT = {"read": 0, "refused": 0}


@pytest.fixture(scope="module")
def good(tmp_path_factory) -> Path:
    return write_dng(
        tmp_path_factory.mktemp("fuzz") / "good.dng",
        MOSAIC,
        cfa="RGGB",
        black_level=128,
        white_level=4000,
        color_matrix_1=CM,
        as_shot_neutral=[0.5, 1, 0.7],
    )


_numerators = st.one_of(
    st.sampled_from([0, 1, 2, 3, 65535, 2**31 - 1]), st.integers(0, 2**31 - 1), st.integers(1, 10)
)
_denominators = st.one_of(st.sampled_from([0, 1, 2**31 - 1]), st.integers(1, 2**31 - 1))


def _value(data, kind: str, count: int):
    if kind == "int":
        return data.draw(st.one_of(st.sampled_from([0, 1, 2, 3, 65535]), st.integers(0, 65535)))
    values = []
    for _ in range(count):
        n = data.draw(_numerators)
        if kind == "srational" and data.draw(st.booleans()):
            n = -n
        values += [n, data.draw(_denominators)]
    return tuple(values)


@settings(max_examples=40, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(data=st.data())
def test_fuzz_metadata_flips(good, tmp_path, data):
    code = data.draw(st.sampled_from(sorted(TAGS)))
    name, count, kind = TAGS[code]
    path = tmp_path / "flip.dng"
    shutil.copyfile(good, path)
    value = _value(data, kind, count)
    with tifffile.TiffFile(path, mode="r+b") as tif:
        tags = tif.pages[0].tags
        if code not in tags:
            return
        try:
            tags[code].overwrite(value)
        except (ValueError, TypeError, struct_error()):  # a value the tag's type cannot hold
            return
    try:
        raw = read_raw(path)
    except RawFormatError as error:
        COUNT["refused"] += 1
        message = str(error)
        assert "\n" not in message and str(path) in message, message
        return
    COUNT["read"] += 1
    image = isp.default_pipeline(demosaic="bilinear")(raw, keep=False).image
    assert image.shape[-1] == 3 and np.all(np.isfinite(image)), f"{name} = {value}"
    assert 0 <= image.min() and image.max() <= 1


def struct_error():
    import struct

    return struct.error


def test_the_fuzz_reaches_both_outcomes():
    """The draws above both refused and accepted files (a fuzz that only ever refuses tests nothing)."""
    if COUNT["read"] + COUNT["refused"] < 20:
        pytest.skip("run with test_fuzz_metadata_flips")
    assert COUNT["read"] > 0 and COUNT["refused"] > 0
