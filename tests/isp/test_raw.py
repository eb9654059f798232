"""isp.raw: RawImage from real files, checked against rawpy and the documented tag values."""

from __future__ import annotations

import numpy as np
import pytest
import rawpy

from isp import RawFormatError, read_raw


def test_550d_dng_layout_matches_rawpy(dng_550d, raw_550d):
    raw = raw_550d
    with rawpy.imread(str(dng_550d)) as ref:
        np.testing.assert_array_equal(raw.mosaic, ref.raw_image_visible)
        assert raw.white_level == ref.white_level == 15000
    assert raw.shape == (1156, 1734)  # ActiveArea (26, 152, 1182, 1886)
    assert raw.cfa == "RGGB"
    np.testing.assert_array_equal(raw.black_level, np.full((2, 2), 2056.0))
    assert (raw.make, raw.model) == ("Canon", "Canon EOS Kiss X4")
    assert raw.is_dng


def test_550d_dng_colour_tags(raw_550d):
    # values from PROVENANCE.md (decoded independently with exiftool/tifffile)
    p = raw_550d.profile
    np.testing.assert_allclose(
        p.color_matrix_1, [[0.6461, -0.1164, -0.0857], [-0.3825, 1.1597, 0.2534], [-0.0416, 0.1540, 0.6039]]
    )
    assert p.color_matrix_2 is None and p.forward_matrix_1 is None
    assert p.calibration_illuminant_1 == 0
    np.testing.assert_allclose(p.analog_balance, 1.0)
    # AsShotNeutral (1, 2.477, 1.462) normalised to max 1
    np.testing.assert_allclose(raw_550d.as_shot_neutral, np.array([1.0, 2.477, 1.462]) / 2.477)


def test_350d_metadata_only(dng_350d):
    with pytest.raises(RawFormatError, match="no pixel data"):
        read_raw(dng_350d)
    raw = read_raw(dng_350d, metadata_only=True)
    p = raw.profile
    assert (p.calibration_illuminant_1, p.calibration_illuminant_2) == (17, 21)
    np.testing.assert_allclose(p.color_matrix_2[0], [0.6018, -0.0617, -0.0965])
    np.testing.assert_allclose(p.color_matrix_1[1], [-0.6846, 1.3563, 0.3684])
    np.testing.assert_allclose(np.diag(p.camera_calibration_1), [1.0069, 1.0, 1.0027])
    np.testing.assert_allclose(raw.as_shot_neutral, [0.592408, 1.0, 0.501692])
    assert raw.baseline_exposure == pytest.approx(0.25)
    assert raw.model == "Canon EOS 350D DIGITAL"
    # rawpy decodes the pixels from the SubIFD; we agree with its layout
    assert raw.shape == (2314, 3474) and raw.cfa == "RGGB"
    assert not raw.mosaic.any()  # stale decoder memory is not handed out


def test_d30_crw_uses_libraw_matrix(crw_d30):
    raw = read_raw(crw_d30)
    with rawpy.imread(str(crw_d30)) as ref:
        np.testing.assert_allclose(raw.profile.color_matrix_1, ref.rgb_xyz_matrix[:3])
        np.testing.assert_array_equal(raw.mosaic, ref.raw_image_visible)
        assert ref.camera_whitebalance[0] == -1  # the D30's camera WB is not recorded
    assert raw.cfa == "RGGB" and raw.white_level == 4095
    np.testing.assert_array_equal(raw.black_level, np.full((2, 2), 126.0))
    assert raw.profile.calibration_illuminant_1 == 21
    from isp.raw import auto_white_balance  # LibRaw's automatic white, as rawpy's use_camera_wb

    assert raw.white_balance_source == "auto"
    np.testing.assert_allclose(raw.as_shot_neutral, auto_white_balance(raw.mosaic, "RGGB", 126.0, 4095.0))
    assert not raw.is_dng


@pytest.mark.parametrize("n_bytes", [0, 100, 5000, 2_000_000])
def test_truncated_dng_is_a_clear_error(dng_550d, tmp_path, n_bytes):
    bad = tmp_path / "cut.dng"
    bad.write_bytes(dng_550d.read_bytes()[:n_bytes])
    with pytest.raises(RawFormatError, match="not a readable RAW file"):
        read_raw(bad)


def test_not_raw(tmp_path):
    txt = tmp_path / "notes.txt"
    txt.write_text("hello " * 200)
    with pytest.raises(RawFormatError, match="not a readable RAW"):
        read_raw(txt)
    with pytest.raises(FileNotFoundError):
        read_raw(tmp_path / "missing.dng")


def test_crop_keeps_cfa_phase(raw_550d):
    c = raw_550d.crop(100, 200, 64, 48)
    assert c.shape == (64, 48) and c.cfa == raw_550d.cfa
    np.testing.assert_array_equal(c.mosaic, raw_550d.mosaic[100:164, 200:248])
    with pytest.raises(RawFormatError, match="even"):
        raw_550d.crop(101, 200, 64, 48)


def test_bad_cfa_and_levels(raw_550d):
    from dataclasses import replace

    with pytest.raises(RawFormatError, match="RGGB"):
        replace(raw_550d, cfa="RGBW")
    with pytest.raises(RawFormatError, match="white_level"):
        replace(raw_550d, white_level=100)
    with pytest.raises(RawFormatError, match="as_shot_neutral"):
        replace(raw_550d, as_shot_neutral=[1.0, np.nan, 1.0])
