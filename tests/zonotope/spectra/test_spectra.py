"""Spectral data layer: grid policy, built-ins, loaders (real data), generators, bad input."""

from __future__ import annotations

import colour
import numpy as np
import pytest

import zonotope
from zonotope import SpectralDataError


def test_list_builtin_names_resolve():
    names = zonotope.list_builtin()
    assert set(names) == {"cameras", "observers", "illuminants", "reflectances"}
    for name in names["cameras"]:
        assert zonotope.camera(name).values.shape[1] == 3
    for name in names["observers"]:
        assert zonotope.observer(name).values.shape[1] == 3
    for name in names["reflectances"]:
        r = zonotope.reflectances(name).values
        assert r.min() >= 0 and r.max() <= 1.5
    assert len(names["illuminants"]) == len(colour.SDS_ILLUMINANTS)
    assert zonotope.illuminant("d65").name == colour.SDS_ILLUMINANTS["D65"].name


def test_names_are_case_and_punctuation_insensitive():
    assert zonotope.camera("nikon 5100").name == "Nikon 5100 (NPL)"
    assert zonotope.camera("Sigma SD Merrill").name == "Sigma SDMerill (NPL)"
    np.testing.assert_array_equal(
        zonotope.observer("lms").values,
        colour.MSDS_CMFS["Stockman & Sharpe 2 Degree Cone Fundamentals"].values,
    )


def test_unknown_name_lists_the_valid_ones():
    with pytest.raises(SpectralDataError, match="Nikon 5100"):
        zonotope.camera("Leica M11")


def test_common_shape_is_intersection_at_coarsest_step():
    shape = zonotope.common_shape(zonotope.camera("sigma sd merrill"), zonotope.observer("lms"))
    assert (shape.start, shape.end, shape.interval) == (400, 680, 10)
    shape = zonotope.common_shape(zonotope.camera("nikon 5100"), zonotope.observer("lms"), interval=1)
    assert (shape.start, shape.end) == (390, 780)


def test_disjoint_ranges_raise():
    a = colour.SpectralDistribution(np.ones(5), np.arange(400, 450, 10), name="a")
    b = colour.SpectralDistribution(np.ones(5), np.arange(600, 650, 10), name="b")
    with pytest.raises(SpectralDataError, match="no common wavelength range"):
        zonotope.common_shape(a, b)


def test_resample_never_extrapolates_and_is_exact_on_subgrids():
    cam = zonotope.camera("nikon 5100")
    v = zonotope.resample(cam, np.arange(400.0, 701.0, 10.0))
    np.testing.assert_array_equal(v, cam.values[(cam.wavelengths >= 400) & (cam.wavelengths <= 700)][::2])
    with pytest.raises(SpectralDataError, match="extrapolated"):
        zonotope.resample(zonotope.camera("sigma sd merrill"), np.arange(400.0, 701.0, 10.0))


def test_generators_white_is_one_per_channel_and_stacking():
    G = zonotope.generators(["nikon 5100", "canon 5d mark ii"], "D65")
    assert G.values.shape[1] == 6
    np.testing.assert_allclose(G.values.sum(axis=0), 1.0, rtol=1e-14)
    assert G.labels[0].startswith("Nikon 5100")


def test_generators_common_factor_keeps_white_point():
    G = zonotope.generators("CIE 1931 2°", "D65", colour.SpectralShape(380, 780, 5), normalise=1)
    white = G.values.sum(axis=0)
    assert white[1] == pytest.approx(1.0)
    xy = colour.XYZ_to_xy(white)
    np.testing.assert_allclose(
        xy, colour.CCS_ILLUMINANTS["CIE 1931 2 Degree Standard Observer"]["D65"], atol=2e-4
    )


def test_generators_match_colour_sd_to_xyz_integration():
    """x @ G equals colour's plain integration of the same reflectance (Y_white = 1)."""
    shape = colour.SpectralShape(380, 780, 5)
    G = zonotope.generators("CIE 1931 2°", "D65", shape, normalise=1).values
    cc = zonotope.reflectances("ColorChecker N Ohta")
    x = zonotope.resample(cc, shape)
    ours = x.T @ G
    cmfs = colour.MSDS_CMFS["CIE 1931 2 Degree Standard Observer"].copy().align(shape)
    ref = (
        colour.msds_to_XYZ(
            cc, cmfs, colour.SDS_ILLUMINANTS["D65"].copy().align(shape), method="Integration", shape=shape
        )
        / 100
    )
    np.testing.assert_allclose(ours, ref, rtol=1e-10, atol=1e-12)


@pytest.mark.parametrize(
    ("wavelengths", "values", "match"),
    [
        ([400, 410, 420], [[0.1, 0.2, np.nan]] * 3, "NaN or inf"),
        ([400, 410, 420], [[0.1, 0.2, np.inf]] * 3, "NaN or inf"),
        ([400, 420, 410], [[0.1, 0.2, 0.3]] * 3, "increase strictly"),
        ([400, 410, 420], [[0.1, -0.2, 0.3]] * 3, "negative"),
        ([400, 410, 420], [[0.1, 0.2]] * 2, "do not match"),
    ],
)
def test_bad_curves_raise(wavelengths, values, match):
    with pytest.raises(SpectralDataError, match=match):
        zonotope.generators(
            (np.array(wavelengths, float), np.array(values, float)),
            None,
            np.array(wavelengths[:1] + sorted(wavelengths[1:]), float),
        )


def test_negative_sensitivities_opt_in():
    w = np.arange(400.0, 701.0, 10.0)
    v = np.stack([np.sin(w / 40), np.ones_like(w), np.cos(w / 50) + 2], axis=1)
    with pytest.raises(SpectralDataError, match="negative"):
        zonotope.generators((w, v), None, w)
    G = zonotope.generators((w, v), None, w, normalise=None, allow_negative=True)
    assert G.values.min() < 0


def test_all_zero_channel_raises():
    w = np.arange(400.0, 701.0, 10.0)
    v = np.stack([np.ones_like(w), np.zeros_like(w), np.ones_like(w)], axis=1)
    with pytest.raises(SpectralDataError, match="zero on"):
        zonotope.generators((w, v), "D65", w)


def test_read_camera_layouts(tmp_path):
    path = tmp_path / "cam.csv"
    path.write_text("wavelength,R,G,B\n400,0.1,0.2,0.3\n410,0.2,0.3,0.4\n420,0.3,0.4,0.5\n")
    cam = zonotope.load_camera(path)
    assert cam.labels == ("R", "G", "B") or list(cam.labels) == ["R", "G", "B"]
    np.testing.assert_array_equal(cam.wavelengths, [400, 410, 420])
    bad = tmp_path / "bad.csv"
    bad.write_text("hello\nworld\n")
    with pytest.raises(SpectralDataError, match="no table of numbers"):
        zonotope.load_camera(bad)


# ---- real data in ../shared/data ---------------------------------------------------------------


def test_all_shared_cameras_load(shared_data):
    paths = sorted((shared_data / "ssf_rawtoaces" / "data" / "camera").glob("*.json"))
    paths += sorted((shared_data / "ssf_jiang2013_camspec").glob("*/*.csv"))
    paths += sorted((shared_data / "ssf_butcher_spectroscope").glob("*/*_ssf.csv"))
    paths += sorted((shared_data / "ssf_darrodi2015_npl").glob("*.csv"))
    assert len(paths) == 52 + 28 + 4 + 2
    for path in paths:
        cam = zonotope.load_camera(path)
        assert cam.values.shape[1] == 3, path
        G = zonotope.generators(cam, "D65")
        np.testing.assert_allclose(G.values.sum(axis=0), 1.0, rtol=1e-12)
    # camspec JSON (dcamprof) agrees with its CSV
    a = zonotope.load_camera(shared_data / "ssf_jiang2013_camspec/Canon_40D/Canon_40D.json")
    b = zonotope.load_camera(shared_data / "ssf_jiang2013_camspec/Canon_40D/Canon_40D.csv")
    np.testing.assert_allclose(a.values, b.values, atol=1e-5)
    # the NPL export equals colour's built-in
    npl = zonotope.load_camera(shared_data / "ssf_darrodi2015_npl/Nikon_5100_NPL.csv")
    np.testing.assert_allclose(npl.values, zonotope.camera("nikon 5100").values, rtol=1e-9)


def test_shared_reflectance_sets_load(shared_data):
    sets = {
        "reflectance_munsell_matte_joensuu_5nm/munsell_matte_1269_380_780_5nm.csv": (1269, 81),
        "reflectance_munsell_glossy_centore2012/SpectralReflectancesOf2007MunsellBookOfColorGlossy.txt": (
            1485,
            36,
        ),
        "reflectance_colorchecker/BabelColor_Average.csv": (24, 36),
        "reflectance_colorchecker/ColorChecker_N_Ohta.csv": (24, 81),
        "reflectance_cie_test_colour_samples/CIE_224_2017_CES99_5nm.csv": (99, 81),
        "reflectance_cie_test_colour_samples/TCS_CIE_1995.csv": (14, 95),
        "reflectance_sfu1995/reflect_db.reflect": (1995, 101),
    }
    for rel, (samples, n) in sets.items():
        r = zonotope.load_reflectances(shared_data / rel)
        assert r.values.shape == (n, samples), rel
        assert r.values.min() >= 0.0
    munsell = zonotope.load_reflectances(sets_path := shared_data / next(iter(sets)))
    assert munsell.labels[0] == "2.5R9/2", sets_path
    ohta = zonotope.load_reflectances(shared_data / "reflectance_colorchecker/ColorChecker_N_Ohta.csv")
    np.testing.assert_allclose(ohta.values, zonotope.reflectances("ColorChecker N Ohta").values, rtol=1e-9)
