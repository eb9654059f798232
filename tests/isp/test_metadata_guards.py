"""Damaged RAW metadata that LibRaw accepts: each case is one RawFormatError naming the file and the
tag (AsShotNeutral, image dimensions, BitsPerSample, ActiveArea, a singular ColorMatrix), not a
colourless or garbage development."""

from __future__ import annotations

import shutil
from pathlib import Path

import numpy as np
import pytest
import tifffile

from isp import RawFormatError, read_raw
from isp.dng import DNGProfile, write_dng

CM = np.array([[0.8, -0.2, -0.05], [-0.3, 1.1, 0.2], [-0.05, 0.15, 0.6]])
MOSAIC = np.random.default_rng(0).integers(200, 3900, (48, 64)).astype(np.uint16)


def _dng(path: Path, monkeypatch=None, extra=()) -> Path:
    """A small uncompressed DNG written by isp, with ``extra`` tags added to its raw IFD."""
    if extra:
        write = tifffile.imwrite

        def with_extra(*args, extratags=(), **kwargs):
            return write(*args, extratags=[*extratags, *extra], **kwargs)

        monkeypatch.setattr(tifffile, "imwrite", with_extra)
    return write_dng(
        path,
        MOSAIC,
        cfa="RGGB",
        black_level=128,
        white_level=4000,
        color_matrix_1=CM,
        as_shot_neutral=[0.5, 1, 0.7],
    )


@pytest.fixture(scope="module")
def good(tmp_path_factory) -> Path:
    return _dng(tmp_path_factory.mktemp("dng") / "good.dng")


def _patched(good: Path, dst: Path, code: int, value) -> Path:
    """A copy of ``good`` with tag ``code`` of IFD 0 overwritten in place."""
    shutil.copyfile(good, dst)
    with tifffile.TiffFile(dst, mode="r+b") as tif:
        tif.pages[0].tags[code].overwrite(value)
    return dst


def _rationals(values) -> tuple[int, ...]:
    return tuple(v for x in values for v in x)


@pytest.mark.parametrize(
    ("name", "code", "value", "message"),
    [
        (
            "neutral_tiny",
            50728,
            _rationals([(1, 4_000_000_000)] * 2 + [(1, 1)]),
            r"AsShotNeutral = \(2\.5e-10, ",
        ),
        (
            "neutral_zero",
            50728,
            _rationals([(0, 1), (1, 1), (1, 1)]),
            r"AsShotNeutral = \(0, 1, 1\): expected 3 pos",
        ),
        (
            "neutral_no_denominator",
            50728,
            _rationals([(1, 0), (1, 1), (1, 1)]),
            r"AsShotNeutral = .*expected 3 pos",
        ),
        ("width_1", 256, 1, r"ImageWidth × ImageLength = 1 × 48: a CFA mosaic needs at least 2 × 2"),
        ("height_1", 257, 1, r"ImageWidth × ImageLength = 64 × 1"),
        ("bits_0", 258, 0, r"BitsPerSample = 0: raw samples have 1 to 32 bits"),
        (
            "singular_cm",
            50721,
            _rationals((x, 1) for x in [1, 2, 3, 2, 4, 6, 1, 0, 1]),
            r"ColorMatrix1 .* singular",
        ),
        (
            "zero_cm",
            50721,
            _rationals((x, 0) for x in [1, 2, 3, 2, 4, 6, 1, 0, 1]),
            r"ColorMatrix1 .* singular",
        ),
    ],
)
def test_damaged_tag_is_one_error_naming_file_and_tag(good, tmp_path, name, code, value, message):
    bad = _patched(good, tmp_path / f"{name}.dng", code, value)
    with pytest.raises(RawFormatError, match=rf"^{tmp_path}/{name}\.dng: {message}") as info:
        read_raw(bad)
    assert "\n" not in str(info.value)


@pytest.mark.parametrize(
    ("area", "ok"),
    [
        ((0, 0, 0, 0), False),
        ((10, 10, 4, 4), False),
        ((0, 0, 480, 640), False),
        ((4, 4, 5, 40), False),
        ((2, 2, 46, 62), True),
    ],
)
def test_active_area_must_be_a_non_empty_area_inside_the_image(tmp_path, monkeypatch, area, ok):
    path = _dng(tmp_path / "area.dng", monkeypatch, [(50829, "I", 4, area, True)])
    if ok:
        assert read_raw(path).mosaic.shape == (44, 60)
        return
    with pytest.raises(
        RawFormatError,
        match=rf"area\.dng: ActiveArea = \({', '.join(map(str, area))}\): .*inside the 64 × 48",
    ):
        read_raw(path)


def test_neutral_at_the_bound_is_accepted_and_a_good_file_reads(good, tmp_path):
    raw = read_raw(good)
    np.testing.assert_allclose(raw.as_shot_neutral, [0.5, 1, 0.7])
    edge = _patched(good, tmp_path / "edge.dng", 50728, _rationals([(1, 500), (1, 1), (1, 1)]))  # gain 500
    np.testing.assert_allclose(read_raw(edge).as_shot_neutral, [0.002, 1, 1])


def test_profile_refuses_a_singular_matrix_by_its_tag_name():
    with pytest.raises(RawFormatError, match=r"ForwardMatrix2 \(forward_matrix_2\) is singular"):
        DNGProfile(color_matrix_1=CM, forward_matrix_2=np.ones((3, 3)))
