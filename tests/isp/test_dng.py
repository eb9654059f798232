"""isp.dng: DNG colour maths against colour-hdri (an independent implementation), DNG writing against
rawpy (LibRaw) reading it back."""

from __future__ import annotations

import colour
import colour_hdri
import numpy as np
import pytest
import rawpy

from isp import (
    DNGProfile,
    PipelineError,
    RawFormatError,
    camera_neutral_to_xy,
    matrix_interpolated,
    read_dng_tags,
    read_raw,
    write_dng,
)

# Canon EOS 5D Mark II matrices of colour-hdri's documentation (ColorMatrix1 under A, 2 under D65).
CM_A = np.array([[0.5309, -0.0229, -0.0336], [-0.6241, 1.3265, 0.3337], [-0.0817, 0.1215, 0.6664]])
CM_D65 = np.array([[0.4716, 0.0603, -0.0830], [-0.7798, 1.5474, 0.2480], [-0.1496, 0.1937, 0.6651]])
FM = np.array([[0.8924, -0.1041, 0.1760], [0.4351, 0.6621, -0.0972], [0.0505, -0.1562, 0.9308]])
I3 = np.eye(3)


def test_matrix_interpolated_documented_value():
    M = matrix_interpolated(5000, 2850, 6500, CM_A, CM_D65)
    np.testing.assert_allclose(M[0], [0.4854908, 0.0408106, -0.0714282], atol=1e-7)  # doc truncates
    np.testing.assert_allclose(M, colour_hdri.models.dng.matrix_interpolated(5000, 2850, 6500, CM_A, CM_D65))
    # order of the two illuminants does not matter; clamped outside
    np.testing.assert_allclose(matrix_interpolated(5000, 6500, 2850, CM_D65, CM_A), M)
    np.testing.assert_array_equal(matrix_interpolated(2000, 2850, 6500, CM_A, CM_D65), CM_A)
    np.testing.assert_array_equal(matrix_interpolated(9000, 2850, 6500, CM_A, CM_D65), CM_D65)


@pytest.mark.parametrize("neutral", [[0.413070, 1.0, 0.646465], [0.6, 1.0, 0.45], [0.35, 1.0, 0.8]])
def test_camera_to_XYZ_matches_colour_hdri(neutral):
    p = DNGProfile(
        color_matrix_1=CM_A, color_matrix_2=CM_D65, calibration_illuminant_1=17, calibration_illuminant_2=21
    )
    hdri_args = (2850, 6500, CM_A, CM_D65, I3, I3, np.ones(3))
    xy_ref = colour_hdri.camera_neutral_to_xy(np.array(neutral), *hdri_args, epsilon=1e-12)
    xy = camera_neutral_to_xy(neutral, p)
    np.testing.assert_allclose(xy, xy_ref, atol=1e-9)
    ref = colour_hdri.matrix_camera_space_to_XYZ(xy_ref, *hdri_args, I3, I3)
    M = p.camera_to_XYZ_D50(neutral)
    # colour-hdri does not normalise the exposure; we scale so the neutral (max 1) has Y = 1
    np.testing.assert_allclose(M / M[1].sum(), ref / ref[1].sum(), atol=1e-9)
    n = np.asarray(neutral) / max(neutral)
    np.testing.assert_allclose(colour.XYZ_to_xy(M @ n), colour_hdri.models.CCS_ILLUMINANT_ADOBEDNG, atol=1e-9)
    assert (M @ n)[1] == pytest.approx(1.0)


def test_forward_matrix_path_matches_colour_hdri():
    neutral = np.array([0.413070, 1.0, 0.646465])
    p = DNGProfile(
        color_matrix_1=CM_A,
        color_matrix_2=CM_D65,
        calibration_illuminant_1=17,
        calibration_illuminant_2=21,
        forward_matrix_1=FM,
        forward_matrix_2=FM,
    )
    xy = camera_neutral_to_xy(neutral, p)
    ref = colour_hdri.matrix_camera_space_to_XYZ(xy, 2850, 6500, CM_A, CM_D65, I3, I3, np.ones(3), FM, FM)
    M = p.camera_to_XYZ_D50(neutral)
    np.testing.assert_allclose(M / M[1, 1], ref / ref[1, 1], atol=1e-9)


def test_350d_profile_interpolates_with_calibration(dng_350d):
    raw = read_raw(dng_350d, metadata_only=True)
    p = raw.profile
    ref = colour_hdri.matrix_camera_space_to_XYZ(
        camera_neutral_to_xy(raw.as_shot_neutral, p),
        2850,
        6500,
        p.color_matrix_1,
        p.color_matrix_2,
        p.camera_calibration_1,
        p.camera_calibration_2,
        np.ones(3),
        I3,
        I3,
    )
    M = p.camera_to_XYZ_D50(raw.as_shot_neutral)
    np.testing.assert_allclose(M / M[1].sum(), ref / ref[1].sum(), atol=1e-9)


def test_profile_errors():
    with pytest.raises(RawFormatError, match="no ColorMatrix"):
        DNGProfile(color_matrix_1=None)
    with pytest.raises(RawFormatError, match="9 finite"):
        DNGProfile(color_matrix_1=np.ones(8))
    p = DNGProfile(color_matrix_1=CM_D65)
    with pytest.raises(RawFormatError, match="positive"):
        p.camera_to_XYZ_D50([0.5, -1.0, 0.5])


def test_write_dng_read_back_by_rawpy(tmp_path):
    rng = np.random.default_rng(1)
    m = rng.integers(300, 3900, size=(32, 48)).astype(np.uint16)
    black = np.array([[256, 257], [258, 259]])
    path = write_dng(
        tmp_path / "sim.dng",
        m,
        cfa="GRBG",
        black_level=black,
        white_level=4000,
        color_matrix_1=CM_D65,
        as_shot_neutral=[0.5, 1.0, 0.7],
        make="Sim",
        model="Cam",
    )
    with rawpy.imread(str(path)) as r:
        np.testing.assert_array_equal(r.raw_image_visible, m)
        assert r.white_level == 4000
        np.testing.assert_allclose(r.camera_whitebalance[:3], [2.0, 1.0, 1 / 0.7], rtol=1e-5)
    raw = read_raw(path)
    assert raw.cfa == "GRBG"
    np.testing.assert_array_equal(raw.black_level, black)
    np.testing.assert_allclose(raw.profile.color_matrix_1, CM_D65, atol=5e-5)
    assert raw.profile.calibration_illuminant_1 == 21
    assert (raw.make, raw.model) == ("Sim", "Cam")
    tags = read_dng_tags(path)
    np.testing.assert_array_equal(tags["CFAPattern"], [1, 0, 2, 1])
    with pytest.raises(PipelineError, match="exists"):
        write_dng(
            path,
            m,
            cfa="GRBG",
            black_level=0,
            white_level=4000,
            color_matrix_1=CM_D65,
            as_shot_neutral=[1, 1, 1],
        )
    assert sorted(p.name for p in tmp_path.iterdir()) == ["sim.dng"]  # no temp files left


def test_write_dng_rejects_bad_mosaic(tmp_path):
    with pytest.raises(RawFormatError, match="white_level"):
        write_dng(
            tmp_path / "a.dng",
            np.full((4, 4), 5000),
            cfa="RGGB",
            black_level=0,
            white_level=4095,
            color_matrix_1=CM_D65,
            as_shot_neutral=[1, 1, 1],
        )
    with pytest.raises(RawFormatError, match="even"):
        write_dng(
            tmp_path / "a.dng",
            np.zeros((3, 4)),
            cfa="RGGB",
            black_level=0,
            white_level=4095,
            color_matrix_1=CM_D65,
            as_shot_neutral=[1, 1, 1],
        )


def test_read_dng_tags_rejects_plain_tiff(tmp_path):
    import tifffile

    tifffile.imwrite(tmp_path / "plain.tif", np.zeros((4, 4), np.uint16))
    with pytest.raises(RawFormatError, match="not a DNG"):
        read_dng_tags(tmp_path / "plain.tif")
    (tmp_path / "junk.dng").write_bytes(b"II*\x00garbage")
    with pytest.raises(RawFormatError):
        read_dng_tags(tmp_path / "junk.dng")


def _meta(**over):
    from isp import DNGMetadata

    base = dict(
        cfa="RGGB", black_level=64, white_level=4095, color_matrix_1=CM_D65, as_shot_neutral=[0.5, 1, 0.7]
    )
    return DNGMetadata(**{**base, **over})


def test_write_dng_metadata_object_equals_keywords(tmp_path):
    """A DNGMetadata (plus per-file overrides) writes the same bytes as the keyword call."""
    m = np.random.default_rng(2).integers(64, 4000, size=(8, 12)).astype(np.uint16)
    meta = _meta(make="Sim", model="Cam")
    a = write_dng(tmp_path / "a.dng", m, meta, iso=400, exposure_time=0.01)
    b = write_dng(
        tmp_path / "b.dng",
        m,
        cfa="RGGB",
        black_level=64,
        white_level=4095,
        color_matrix_1=CM_D65,
        as_shot_neutral=[0.5, 1, 0.7],
        make="Sim",
        model="Cam",
        iso=400,
        exposure_time=0.01,
    )
    assert a.read_bytes() == b.read_bytes()
    assert read_dng_tags(a)["ISOSpeedRatings"] == 400


@pytest.mark.parametrize(
    ("over", "match"),
    [
        ({"white_level": 0}, "white_level=0"),
        ({"white_level": 70000}, "white_level=70000"),
        ({"white_level": 4095.5}, "white_level=4095.5"),
        ({"black_level": 5000}, "black_level=5000"),
        ({"black_level": [1, 2]}, "black_level"),
        ({"black_level": "64"}, "black_level"),
        ({"color_matrix_1": np.eye(2)}, "color_matrix_1"),
        ({"color_matrix_1": [[1, 0, 0], [0, np.nan, 0], [0, 0, 1]]}, "color_matrix_1"),
        ({"forward_matrix_1": "identity"}, "forward_matrix_1"),
        ({"as_shot_neutral": [1, 0, 1]}, "as_shot_neutral"),
        ({"as_shot_neutral": [1, 1]}, "as_shot_neutral"),
        ({"iso": True}, "iso=True"),
        ({"iso": -1}, "iso=-1"),
        ({"exposure_time": -0.01}, "exposure_time"),
        ({"f_number": float("inf")}, "f_number"),
        ({"orientation": 9}, "orientation=9"),
        ({"color_matrix_2": CM_A}, "both or neither"),
        ({"make": 3}, "make=3"),
    ],
)
def test_dng_metadata_refuses_bad_values(over, match):
    with pytest.raises(PipelineError, match=match):
        _meta(**over)


def test_dng_metadata_refuses_bad_cfa():
    with pytest.raises(RawFormatError):
        _meta(cfa="RGBX")


def test_write_dng_option_errors(tmp_path):
    m = np.full((4, 4), 100, np.uint16)
    with pytest.raises(PipelineError, match=r"unknown option.*colour_matrix_1"):
        write_dng(tmp_path / "a.dng", m, _meta(), colour_matrix_1=CM_D65)
    with pytest.raises(PipelineError, match="missing cfa, as_shot_neutral"):
        write_dng(tmp_path / "a.dng", m, black_level=0, white_level=4095, color_matrix_1=CM_D65)
    with pytest.raises(PipelineError, match="expected a DNGMetadata"):
        write_dng(tmp_path / "a.dng", m, {"cfa": "RGGB"})
    with pytest.raises(RawFormatError, match="cfa"):
        write_dng(tmp_path / "a.dng", m, _meta(cfa=None))
    assert write_dng(tmp_path / "rgb.dng", np.full((4, 4, 3), 100, np.uint16), _meta(cfa=None)).exists()
    assert sorted(p.name for p in tmp_path.iterdir()) == ["rgb.dng"]
