"""The DNG NoiseProfile tag (51041): :func:`isp.write_dng` writes it, :func:`isp.noise_profile` reads it.

Independent truths: exiftool (a second, widely used DNG reader) reads back the doubles written; the raw
IFD entry bytes (tag, type DOUBLE, count) and the IEEE doubles at its offset, decoded here with
``struct``; malformed tags made by patching those bytes of a file the real writer wrote.
"""

from __future__ import annotations

import json
import shutil
import struct
import subprocess

import numpy as np
import pytest

import isp
from isp import DNGMetadata, PipelineError, RawFormatError, noise_profile, read_dng_tags, write_dng

PAIRS3 = np.array([[1.6e-4, 3.3842184e-8], [9.0e-5, 1.25e-7], [2.5e-4, 0.0]])


def _write(path, profile, *, full_colour=False):
    shape = (24, 26, 3) if full_colour else (24, 26)  # LibRaw refuses sides < 22 px
    mosaic = np.full(shape, 1000, np.uint16)
    return write_dng(
        path,
        mosaic,
        cfa="RGGB",
        black_level=64,
        white_level=4095,
        color_matrix_1=np.eye(3),
        as_shot_neutral=[0.5, 1.0, 0.7],
        noise_profile=profile,
    )


def _entry(data: bytes):
    """Offset of the NoiseProfile IFD entry (little-endian TIFF: tag 51041, type 12 = DOUBLE)."""
    i = data.find(struct.pack("<HH", 51041, 12))
    assert i > 0 and data.count(struct.pack("<HH", 51041, 12)) == 1
    return i


@pytest.mark.parametrize("full_colour", [False, True])
@pytest.mark.parametrize("profile", [PAIRS3, PAIRS3[0], [[2e-4, 1e-7]]], ids=["three", "one", "one-row"])
def test_written_bytes_and_read_back(tmp_path, profile, full_colour):
    path = _write(tmp_path / "n.dng", profile, full_colour=full_colour)
    data = path.read_bytes()
    assert data[:2] == b"II"
    i = _entry(data)
    flat = np.asarray(profile, float).ravel()
    count, offset = struct.unpack("<II", data[i + 4 : i + 12])
    assert count == flat.size
    assert struct.unpack(f"<{count}d", data[offset : offset + 8 * count]) == tuple(flat)
    got = noise_profile(read_dng_tags(path), path)
    assert got.shape == (3, 2)
    np.testing.assert_array_equal(got, np.broadcast_to(flat.reshape(-1, 2), (3, 2)))
    # rawpy/LibRaw still decodes the file (Bayer) and the tags travel on RawImage.tags
    if not full_colour:
        raw = isp.read_raw(path)
        np.testing.assert_array_equal(noise_profile(raw.tags), got)


def test_no_tag_reads_as_none(tmp_path):
    path = _write(tmp_path / "n.dng", None)
    assert struct.pack("<HH", 51041, 12) not in path.read_bytes()
    tags = read_dng_tags(path)
    assert "NoiseProfile" not in tags and noise_profile(tags, path) is None


@pytest.mark.skipif(shutil.which("exiftool") is None, reason="exiftool not installed")
@pytest.mark.parametrize("profile", [PAIRS3, PAIRS3[1]], ids=["three", "one"])
def test_exiftool_reads_the_values_written(tmp_path, profile):
    path = _write(tmp_path / "n.dng", profile)
    out = subprocess.run(
        ["exiftool", "-j", "-n", "-NoiseProfile", str(path)], capture_output=True, text=True, check=True
    )
    value = json.loads(out.stdout)[0]["NoiseProfile"]
    got = np.array([float(x) for x in str(value).split()])
    # exiftool prints doubles with 15 significant digits
    np.testing.assert_allclose(got, np.asarray(profile, float).ravel(), rtol=1e-14, atol=0)


def _patched(tmp_path, *, count=None, values=None):
    path = _write(tmp_path / "bad.dng", PAIRS3)
    data = bytearray(path.read_bytes())
    i = _entry(bytes(data))
    offset = struct.unpack("<I", data[i + 8 : i + 12])[0]
    if count is not None:
        data[i + 4 : i + 8] = struct.pack("<I", count)
    if values is not None:
        data[offset : offset + 8 * len(values)] = struct.pack(f"<{len(values)}d", *values)
    path.write_bytes(bytes(data))
    return path


BAD = {
    "odd count": dict(count=3),
    "count 4": dict(count=4),
    "count 1": dict(count=1),
    "negative S": dict(values=[-1.6e-4]),
    "zero S": dict(values=[0.0]),
    "negative O": dict(values=[1.6e-4, -1e-8]),
    "nan": dict(values=[1.6e-4, 1e-8, float("nan")]),
    "inf": dict(values=[1.6e-4, 1e-8, 1e-4, float("inf")]),
}


@pytest.mark.parametrize("how", list(BAD))
def test_malformed_tag_is_refused_naming_file_and_tag(tmp_path, how):
    path = _patched(tmp_path, **BAD[how])
    tags = read_dng_tags(path)  # reading the tags alone still works
    with pytest.raises(RawFormatError) as e:
        noise_profile(tags, path)
    msg = str(e.value)
    assert str(path) in msg and "NoiseProfile (tag 51041)" in msg and "exiftool -NoiseProfile=" in msg


@pytest.mark.parametrize(
    "bad",
    [
        [1e-4],
        [1e-4, 1e-8, 1e-4],
        np.ones((2, 2)),
        np.ones((3, 3)),
        [0.0, 1e-8],
        [-1e-4, 1e-8],
        [1e-4, -1e-9],
        [float("nan"), 1e-8],
        [1e-4, float("inf")],
        "1e-4 1e-8",
        [[1e-4, 1e-8]] * 4,
    ],
)
def test_writer_refuses_a_bad_profile(tmp_path, bad):
    with pytest.raises(PipelineError, match=r"DNGMetadata\.noise_profile="):
        DNGMetadata(
            cfa="RGGB",
            black_level=0,
            white_level=4095,
            color_matrix_1=np.eye(3),
            as_shot_neutral=[1, 1, 1],
            noise_profile=bad,
        )
    assert not list(tmp_path.iterdir())
