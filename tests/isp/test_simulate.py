"""isp.simulate: the spectral forward model, a real DNG written and read back through rawpy, and the
pipeline's colour accuracy against the true colours of a simulated ColorChecker."""

from __future__ import annotations

import colour
import numpy as np
import pytest
import rawpy

import isp
import zonotope
from isp import PipelineError
from isp.simulate import (
    SpectralSetup,
    chart_image,
    fit_color_matrix,
    simulate_capture,
    simulate_dng,
    spectral_setup,
    true_XYZ,
)

D65_xy = colour.CCS_ILLUMINANTS["CIE 1931 2 Degree Standard Observer"]["D65"]


@pytest.fixture(scope="module")
def setup():
    return spectral_setup("Nikon 5100 (NPL)", illuminant="D65")


@pytest.fixture(scope="module")
def checker(setup):
    R = zonotope.resample(zonotope.reflectances("ColorChecker N Ohta"), setup.wavelengths).T
    return R, *chart_image(R, rows=4, cols=6, patch=16, gap=4)


def _patch_means(image, labels, n, margin=3):
    out = []
    for k in range(n):
        ys, xs = np.nonzero(labels == k)
        out.append(
            image[ys.min() + margin : ys.max() + 1 - margin, xs.min() + margin : xs.max() + 1 - margin]
            .reshape(-1, image.shape[-1])
            .mean(0)
        )
    return np.array(out)


def _delta_E_D65(XYZ_est, XYZ_true, white_true):
    """ΔE00 in CIELAB (D65) after adapting the truth from the illuminant's white (Bradford)."""
    D65 = colour.xy_to_XYZ(D65_xy)
    truth = colour.chromatic_adaptation(XYZ_true, white_true, D65, method="Von Kries", transform="Bradford")
    return colour.delta_E(
        colour.XYZ_to_Lab(XYZ_est, D65_xy), colour.XYZ_to_Lab(truth, D65_xy), method="CIE 2000"
    )


def test_setup_normalisation(setup):
    np.testing.assert_allclose(setup.observer.sum(0)[1], 1.0)
    np.testing.assert_allclose(setup.camera.sum(0), setup.neutral)
    assert setup.neutral.max() == pytest.approx(1.0)
    # the observer is CIE 1931 2° under D65: the white's chromaticity is D65's (to the grid's accuracy)
    np.testing.assert_allclose(colour.XYZ_to_xy(setup.observer.sum(0)), D65_xy, atol=2e-4)


def test_setup_generators_are_the_projects_generator_pair(setup):
    """One concept, one normalisation: the simulator's generators are the GeneratorPair that
    correction_problem and MetamerMismatch build for the same camera, illuminant and grid."""
    g = setup.generators
    assert isinstance(g, zonotope.GeneratorPair)
    p = zonotope.correction_problem(
        ["Nikon 5100 (NPL)"], target="CIE 1931 2°", illuminant="D65", shape=setup.wavelengths
    )
    np.testing.assert_array_equal(g.Phi, p.Phi)
    np.testing.assert_array_equal(g.Psi, p.Psi)
    np.testing.assert_array_equal(g.wavelengths, p.wavelengths)
    mm = zonotope.MetamerMismatch("Nikon 5100 (NPL)", "CIE 1931 2°", "D65", setup.wavelengths)
    np.testing.assert_array_equal(g.Phi, mm.Phi)
    np.testing.assert_allclose(mm.Psi, g.Psi / g.Psi.sum(0), rtol=1e-12)  # MMVs: white → 1 per channel
    np.testing.assert_allclose(g.Phi.sum(0), 1.0, rtol=1e-14)  # balanced: white → 1
    np.testing.assert_allclose(setup.camera, g.Phi * setup.neutral, rtol=0)  # RAW = balanced · neutral
    assert (g.target, g.illuminant) == ("CIE 1931 2°", "D65")
    for bad in ([1.0, 1.0], [1.0, 0.0, 0.5], [1.0, np.nan, 0.5]):
        with pytest.raises(PipelineError, match="neutral"):
            SpectralSetup(generators=g, neutral=bad)


def test_fit_color_matrix_holds_the_white(setup, checker):
    R = checker[0]
    M = fit_color_matrix(setup, R)
    np.testing.assert_allclose(M @ setup.observer.sum(0), setup.neutral, atol=1e-12)
    # a camera that *is* the observer is fitted exactly
    from dataclasses import replace

    w = setup.observer.sum(0)
    obs_cam = SpectralSetup(generators=replace(setup.generators, Phi=setup.observer / w), neutral=w)
    np.testing.assert_allclose(fit_color_matrix(obs_cam, R), np.eye(3), atol=1e-10)


def test_chart_layout(checker):
    R, image, labels = checker
    assert image.shape == (4 * 20 + 4, 6 * 20 + 4, R.shape[1])
    assert np.all(np.bincount(labels[labels >= 0]) == 256)
    np.testing.assert_array_equal(image[labels == 5][0], R[5])


def test_noise_statistics(setup):
    flat = np.full((64, 64, setup.wavelengths.size), 0.5)
    cap = simulate_capture(flat, setup, full_well=10000.0, read_noise=3.0, seed=1)
    green = cap.mosaic[0::2, 1::2].astype(float)  # RGGB: G sites
    q = 0.8 * 0.5 * setup.neutral[1]
    scale = cap.white_level - cap.black_level
    assert green.mean() == pytest.approx(cap.black_level + q * scale, rel=2e-3)
    expected_var = q / 10000.0 * scale**2 + 3.0**2 + 1 / 12  # Poisson + read + rounding
    assert green.var() == pytest.approx(expected_var, rel=0.15)
    noiseless = simulate_capture(flat, setup, full_well=np.inf, read_noise=0.0)
    assert np.ptp(noiseless.mosaic[0::2, 1::2]) == 0


def test_simulated_dng_is_read_by_rawpy(setup, checker, tmp_path):
    cap = simulate_capture(checker[1], setup, cfa="BGGR")
    path = simulate_dng(tmp_path / "chart.dng", cap, model="Nikon 5100")
    with rawpy.imread(str(path)) as r:
        np.testing.assert_array_equal(r.raw_image_visible, cap.mosaic)
        assert r.raw_pattern.tolist() == [[2, 3], [1, 0]]  # B G / G R
        np.testing.assert_allclose(r.camera_whitebalance[:3], 1 / cap.neutral * cap.neutral[1], rtol=1e-5)
    raw = isp.read_raw(path)
    assert raw.cfa == "BGGR" and raw.profile.calibration_illuminant_1 == 21
    np.testing.assert_allclose(raw.profile.color_matrix_1, cap.color_matrix, atol=5e-5)


@pytest.mark.parametrize("method", ["bilinear", "Menon 2007"])
def test_colorchecker_delta_E_through_the_pipeline(setup, checker, tmp_path, method):
    R, image, labels = checker
    cap = simulate_capture(image, setup)
    raw = isp.read_raw(simulate_dng(tmp_path / f"cc_{method}.dng", cap))
    rgb = isp.develop(raw, demosaic=method, stop_after="XYZ_to_linear_sRGB").image
    XYZ = colour.RGB_to_XYZ(rgb, "sRGB", illuminant=D65_xy) / cap.exposure
    dE = _delta_E_D65(_patch_means(XYZ, labels, 24), true_XYZ(R, setup), setup.observer.sum(0))
    # the residual is the 3 × 3 matrix's (Luther-condition) error, measured ≈ 1.0 mean, 3.4 max
    assert np.mean(dE) < 1.5 and np.max(dE) < 4.5


def test_correction_callable_least_squares_from_ssf(setup, checker, tmp_path):
    """A 3 × 3 least-squares matrix fitted on training reflectances (rawtoaces 190) from the SSF,
    as a correction callable on white-balanced responses, replaces white balance + ColorMatrix."""
    R, image, labels = checker
    train = zonotope.resample(zonotope.reflectances("rawtoaces 190"), setup.wavelengths).T
    balanced = (train @ setup.camera) / setup.neutral  # white → (1, 1, 1)
    M = np.linalg.lstsq(balanced, train @ setup.observer, rcond=None)[0]  # (3, 3): XYZ = c @ M
    cap = simulate_capture(image, setup)
    raw = isp.read_raw(simulate_dng(tmp_path / "cc.dng", cap))
    pipe = isp.default_pipeline(demosaic="Menon 2007", correction=lambda c: c @ M)
    rgb = pipe(raw, stop_after="XYZ_to_linear_sRGB").image
    XYZ = colour.RGB_to_XYZ(rgb, "sRGB", illuminant=D65_xy) / cap.exposure
    # apply_correction normalises the callable's white to Y = 1; undo for absolute comparison
    XYZ = XYZ * (np.ones(3) @ M)[1]
    dE = _delta_E_D65(_patch_means(XYZ, labels, 24), true_XYZ(R, setup), setup.observer.sum(0))
    assert np.mean(dE) < 2.0 and np.max(dE) < 6.0


def test_simulate_errors(setup):
    n = setup.wavelengths.size
    with pytest.raises(isp.PipelineError, match="even"):
        simulate_capture(np.full((3, 4, n), 0.5), setup)
    with pytest.raises(isp.PipelineError, match="wavelengths"):
        simulate_capture(np.full((4, 4, n + 1), 0.5), setup)
    with pytest.raises(isp.PipelineError, match=r"\[0, 1\]"):
        simulate_capture(np.full((4, 4, n), 50.0), setup)
    with pytest.raises(isp.PipelineError, match="exposure"):
        simulate_capture(np.full((4, 4, n), 0.5), setup, exposure=2.0)


@pytest.mark.parametrize(
    ("options", "match"),
    [
        ({"exposure": 0.0}, "exposure=0.0"),
        ({"exposure": float("nan")}, "exposure=nan"),
        ({"black_level": 20000, "white_level": 16383}, "black_level=20000"),
        ({"white_level": 70000}, "white_level=70000"),
        ({"white_level": 4095.0}, "white_level=4095.0"),
        ({"full_well": -1.0}, "full_well=-1.0"),
        ({"read_noise": float("inf")}, "read_noise=inf"),
        ({"read_noise": "2"}, "read_noise='2'"),
    ],
)
def test_sensor_config_refuses_bad_values(options, match):
    with pytest.raises(isp.PipelineError, match=match):
        isp.SensorConfig(**options)


def test_sensor_config_equals_keywords(setup):
    """A SensorConfig and the same keywords give the same mosaic; unknown options are refused."""
    img = np.full((8, 8, setup.wavelengths.size), 0.4)
    sensor = isp.SensorConfig(exposure=0.6, cfa="GRBG", read_noise=1.0)
    a = simulate_capture(img, setup, sensor, seed=3)
    b = simulate_capture(img, setup, exposure=0.6, cfa="GRBG", read_noise=1.0, seed=3)
    c = simulate_capture(
        img, setup, isp.SensorConfig(exposure=0.9, cfa="GRBG"), exposure=0.6, read_noise=1.0, seed=3
    )
    np.testing.assert_array_equal(a.mosaic, b.mosaic)
    np.testing.assert_array_equal(a.mosaic, c.mosaic)
    assert (a.cfa, a.exposure) == ("GRBG", 0.6)
    with pytest.raises(isp.PipelineError, match=r"unknown option.*read_nosie"):
        simulate_capture(img, setup, read_nosie=1.0)


def test_color_matrix_needs_three_dimensions_of_training_colours(setup):
    """One reflectance (or several of one chromaticity) cannot determine a 3 × 3 ColorMatrix: a clear
    error from fit_color_matrix, whatever LAPACK makes of the singular system; simulate_capture of a
    flat image fits on the ColorChecker instead (the same matrix as asking for it)."""
    from isp.simulate import default_training, fit_color_matrix

    grey = np.full((1, setup.wavelengths.size), 0.4)
    for training in (grey, np.vstack([grey, 0.5 * grey, 0.25 * grey])):
        with pytest.raises(isp.PipelineError, match="span only 1 of the 3"):
            fit_color_matrix(setup, training)
    img = np.full((8, 8, setup.wavelengths.size), 0.4)
    flat = simulate_capture(img, setup, seed=1)
    chart = simulate_capture(img, setup, seed=1, training=default_training(setup))
    np.testing.assert_array_equal(flat.color_matrix, chart.color_matrix)
    np.testing.assert_allclose(flat.color_matrix @ setup.observer.sum(0), setup.camera.sum(0), rtol=1e-10)
