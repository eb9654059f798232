"""ICC v4 input profiles: our writer read back by littleCMS (Pillow's ImageCms) and exiftool."""

from __future__ import annotations

import json
import shutil
import subprocess

import colour
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from isp.profiles.icc import ICC_D50, ICCError, icc_profile, read_icc_matrix, write_icc

ImageCms = pytest.importorskip("PIL.ImageCms")
from PIL import Image  # noqa: E402

FM = np.array([[0.7, 0.15, 0.1142], [0.28, 0.7, 0.02], [0.0, 0.05, 0.7749]])  # rows sum to D50
D65 = colour.xy_to_XYZ(colour.CCS_ILLUMINANTS["CIE 1931 2 Degree Standard Observer"]["D65"])


def test_littlecms_converts_like_the_matrix(tmp_path):
    path = write_icc(tmp_path / "cam.icc", icc_profile(FM, description="test cam", illuminant_XYZ=D65))
    prof = ImageCms.getOpenProfile(str(path))
    assert prof.profile.version == pytest.approx(4.4)
    assert prof.profile.device_class == "scnr" and prof.profile.xcolor_space == "RGB "
    assert prof.profile.connection_space == "XYZ " and prof.profile.profile_description == "test cam"
    lab = ImageCms.createProfile("LAB", 5000)  # littleCMS's Lab D50
    t = ImageCms.buildTransform(
        prof, lab, "RGB", "LAB", renderingIntent=ImageCms.Intent.RELATIVE_COLORIMETRIC
    )
    rng = np.random.default_rng(0)
    # channels ≥ 32: littleCMS's 8-bit path rounds a channel of a few codes coarsely (b* off by 3 for
    # RGB (235, 30, 2), whose Z is 1 % of the white's)
    rgb = rng.integers(32, 256, (8, 8, 3), dtype=np.uint8)
    out = np.asarray(ImageCms.applyTransform(Image.fromarray(rgb, "RGB"), t))
    got = np.stack([out[..., 0] / 2.55, out[..., 1].view(np.int8), out[..., 2].view(np.int8)], axis=-1)
    want = colour.XYZ_to_Lab((rgb / 255.0) @ FM.T, colour.XYZ_to_xy(ICC_D50))
    # Pillow's 8-bit Lab: L in steps of 100/255, a and b in steps of 1
    np.testing.assert_allclose(got[..., 0], want[..., 0], atol=0.5)
    np.testing.assert_allclose(got[..., 1:], want[..., 1:], atol=1.0)


@settings(max_examples=25, deadline=None)
@given(st.lists(st.floats(-0.3, 0.3), min_size=9, max_size=9))
def test_matrix_and_adaptation_read_back(tmp_path_factory, noise):
    M = FM + np.array(noise).reshape(3, 3) * 0.5
    if abs(np.linalg.det(M)) < 1e-3 or np.any(M @ np.ones(3) <= 0):
        return
    path = tmp_path_factory.mktemp("icc") / "m.icc"
    write_icc(path, icc_profile(M, description="m", illuminant_XYZ=D65))
    got, chad = read_icc_matrix(path)
    expected = np.diag(ICC_D50 / (M @ np.ones(3))) @ M  # the white is put on the PCS white exactly
    np.testing.assert_allclose(got, expected, atol=1.0 / 65536)
    cat = colour.adaptation.matrix_chromatic_adaptation_VonKries(D65 / D65[1], ICC_D50, transform="Bradford")
    np.testing.assert_allclose(chad, cat, atol=1.0 / 65536)


@pytest.mark.skipif(shutil.which("exiftool") is None, reason="exiftool not installed")
def test_exiftool_parses_the_tags(tmp_path):
    path = write_icc(
        tmp_path / "cam.icc", icc_profile(FM, description="desc", copyright="CC0", illuminant_XYZ=D65)
    )
    out = json.loads(
        subprocess.run(["exiftool", "-j", "-n", str(path)], capture_output=True, text=True).stdout
    )[0]
    assert out["ProfileClass"] == "scnr" and out["ColorSpaceData"] == "RGB "
    assert out["ProfileConnectionSpace"] == "XYZ " and out["ProfileVersion"] == 0x440
    assert out["ProfileDescription"] == "desc" and out["ProfileCopyright"] == "CC0"
    red = np.array(str(out["RedMatrixColumn"]).split(), float)
    np.testing.assert_allclose(red, FM[:, 0], atol=1e-4)
    assert len(str(out["ChromaticAdaptation"]).split()) == 9
    assert "Warning" not in out


def test_profile_id_is_the_md5_of_the_profile(tmp_path):
    import hashlib

    b = bytearray(icc_profile(FM, description="x"))
    pid = bytes(b[84:100])
    b[84:100] = bytes(16)  # flags and rendering intent are 0 in our profiles; the ID field zeroed
    assert hashlib.md5(bytes(b)).digest() == pid


@pytest.mark.parametrize(
    ("matrix", "message"),
    [(np.ones((3, 3)), "singular"), (np.full((3, 3), np.nan), "finite 3 × 3"), (np.eye(2), "finite 3 × 3")],
)
def test_bad_matrices_refused(matrix, message):
    with pytest.raises(ICCError, match=message):
        icc_profile(matrix, description="x")


def test_write_refuses_existing_and_non_profiles(tmp_path):
    p = tmp_path / "mine.icc"
    p.write_bytes(b"user data")
    with pytest.raises(ICCError, match="exists"):
        write_icc(p, icc_profile(FM, description="x"))
    with pytest.raises(ICCError, match="ICC profile"):
        write_icc(tmp_path / "new.icc", b"not a profile" * 10)
    assert p.read_bytes() == b"user data"
