"""zonotope.spectra.estimate: sensitivities from DNG matrices and chart photographs.

Independent truths: closed forms (a Luther camera's matrices; curves inside the basis span), the
least-squares matrices of :func:`synthesise_dng_matrices` recomputed from the estimate, isp's own DNG
tag reader, and measured cameras held out of the basis (shared data).
"""

from __future__ import annotations

import dataclasses
import json

import colour
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import zonotope
from zonotope import SpectralDataError
from zonotope._tol import SSF_CHART_CLIP, SSF_FIT_SIGMA_SCALE, SSF_PRIOR
from zonotope.spectra import builtin as spectra
from zonotope.spectra.estimate import (
    SSF_SHAPE,
    Chart,
    DNGMatrices,
    SSFBasis,
    SSFCalibration,
    estimate_ssf,
    learn_ssf_basis,
    read_dng_matrices,
    ssf_basis,
    synthesise_dng_matrices,
    write_ssf_json,
)

W = np.asarray(SSF_SHAPE.wavelengths)

#: Adobe DNG Converter's Canon EOS 5D Mark II matrices (ColorMatrix1 under A, ColorMatrix2 under
#: D65), as colour-hdri's documentation prints them.
CM_5D2_A = [[0.5309, -0.0229, -0.0336], [-0.6241, 1.3265, 0.3337], [-0.0817, 0.1215, 0.6664]]
CM_5D2_D65 = [[0.4716, 0.0603, -0.0830], [-0.7798, 1.5474, 0.2480], [-0.1496, 0.1937, 0.6651]]


def _peak1(v):
    return v / v.max(axis=0)


def _nikon():
    return spectra.resample(zonotope.camera("Nikon 5100 (NPL)"), W)


def _chart_rgb(values, reflectances="ColorChecker N Ohta", light="D65", top=0.8):
    R = spectra.resample(zonotope.reflectances(reflectances), W).T
    E = spectra.resample(zonotope.illuminant(light), W)[:, 0]
    C = (R * E) @ values
    return top * C / C.max()


# --- DNG matrices --------------------------------------------------------------------------------


def test_synthesised_matrices_of_a_luther_camera_are_the_closed_form():
    """A camera S = x̄·Bᵀ sees camera = B·XYZ exactly: ColorMatrix = B scaled so the white's max is 1."""
    B = np.array([[0.9, 0.3, 0.05], [0.2, 1.1, 0.1], [0.05, 0.1, 1.2]])
    cmfs = spectra.resample(zonotope.observer("CIE 1931 2°"), W)
    S = colour.MultiSpectralDistributions(cmfs @ B.T, W, name="luther")
    dng = synthesise_dng_matrices(S)
    for cm, light in zip(dng.color_matrices, ("A", "D65"), strict=True):
        E = spectra.resample(zonotope.illuminant(light), W)[:, 0]
        white = cmfs.T @ E
        expected = B / (B @ (white / white[1])).max()
        np.testing.assert_allclose(cm, expected, atol=1e-9)
    for fm in dng.forward_matrices:  # white-balanced white → D50 exactly
        D50 = colour.xy_to_XYZ(colour.CCS_ILLUMINANTS["CIE 1931 2 Degree Standard Observer"]["D50"])
        np.testing.assert_allclose(fm @ np.ones(3), D50, atol=1e-12)


def test_estimate_reproduces_the_matrices_it_was_given():
    """Matrices synthesised again from the estimate (on the estimate's own training reflectances)
    agree with the input to 0.03 per entry (the fit is XYZ → camera, a DNG converter's camera → XYZ:
    the two regressions differ by about that); a Canon's matrices differ from them by ≥ 0.1."""
    dng = synthesise_dng_matrices("Nikon 5100 (NPL)", reflectances="rawtoaces 190")
    est = estimate_ssf(dng, prior=SSF_PRIOR)  # exact matrices: the weight chosen on exact matrices
    again = synthesise_dng_matrices(est.sensitivities, reflectances="rawtoaces 190")
    other = synthesise_dng_matrices("Canon EOS 5D Mark II", reflectances="rawtoaces 190")
    for a, b, c in zip(dng.color_matrices, again.color_matrices, other.color_matrices, strict=True):
        assert np.abs(a - b).max() < 0.03, (a, b)
        assert np.abs(a - c).max() > 0.1
    assert est.values.min() >= 0 and est.values.max() == pytest.approx(1.0)
    assert est.sources == ("dng",) and est.residual < 0.05


def test_estimate_is_close_to_the_measured_curves_and_beats_the_mean_camera():
    """Nikon D5100 (NPL) from its synthesised matrices (exact fits of its curves, so the prior weight
    chosen on exact matrices): closer to the measurement than the basis's first component (the
    plausible camera with no data) in every channel."""
    truth = _peak1(_nikon())
    est = _peak1(estimate_ssf(synthesise_dng_matrices("Nikon 5100 (NPL)"), prior=SSF_PRIOR).values)
    prior = _peak1(np.abs(ssf_basis().components[:, :, 0].T))
    err = np.sqrt(np.mean((est - truth) ** 2, axis=0))
    assert np.all(err < 0.06), err
    assert np.all(err < np.sqrt(np.mean((prior - truth) ** 2, axis=0))), err


def test_real_adobe_matrices_of_a_held_out_camera(shared_data):
    """Canon 5D Mark II from Adobe's real ColorMatrix1/2, the basis learned without any 5D Mark II:
    within 0.08 RMSE (peak 1) of the rawtoaces measurement in every channel."""
    folder = shared_data / "ssf_rawtoaces" / "data" / "camera"
    cams = {
        f.stem: zonotope.load_camera(f) for f in sorted(folder.glob("*.json")) if "5D_Mark_II_" not in f.name
    }
    basis = learn_ssf_basis(cams, spread=np.full((W.size, 3), 0.05))
    assert not any("5D_Mark_II_" in s for s in basis.sources)
    est = estimate_ssf(DNGMatrices((CM_5D2_A, CM_5D2_D65), ("A", "D65")), basis=basis)
    truth = _peak1(spectra.resample(zonotope.camera("Canon EOS 5D Mark II"), W))
    err = np.sqrt(np.mean((_peak1(est.values) - truth) ** 2, axis=0))
    assert np.all(err < 0.08), err


@settings(max_examples=8, deadline=None)
@given(st.floats(-0.05, 0.05), st.integers(0, 8), st.booleans())
def test_any_plausible_matrices_give_smooth_non_negative_curves(delta, entry, forward):
    """Perturbed matrices (with or without ForwardMatrices): finite, ≥ 0, peak 1, band ≥ 0."""
    dng = synthesise_dng_matrices("Canon EOS 5D Mark II")
    cms = [cm.copy() for cm in dng.color_matrices]
    cms[0].flat[entry] += delta
    fms = dng.forward_matrices if forward else ()
    est = estimate_ssf(DNGMatrices(tuple(cms), dng.illuminants, fms))
    v = est.values
    assert np.all(np.isfinite(v)) and v.min() >= 0 and v.max() == pytest.approx(1.0)
    assert np.all(est.uncertainty >= 0) and est.uncertainty.shape == v.shape
    lower, upper = est.band()
    assert np.all(lower <= v) and np.all(v <= upper) and lower.min() >= 0
    # smooth: no channel's second difference exceeds a quarter of its peak
    assert np.abs(np.diff(v, 2, axis=0)).max() < 0.25


def test_read_dng_matrices_agrees_with_isp(shared_data):
    """The tifffile reader here and isp's DNG tag reader give the same matrices and illuminants."""
    isp_dng = pytest.importorskip("isp.dng")
    path = shared_data / "raw_samples" / "exiftool_DNG_Canon_EOS_350D_metadata_only.dng"
    ours = read_dng_matrices(path)
    theirs = read_dng_matrices(isp_dng.read_dng_tags(path))
    assert ours.illuminants == theirs.illuminants == ("A", "D65")
    for a, b in zip(ours.color_matrices, theirs.color_matrices, strict=True):
        np.testing.assert_allclose(a, b, atol=1e-12)
    assert "350D" in ours.name


# --- chart ---------------------------------------------------------------------------------------


def test_chart_estimate_reproduces_the_patch_responses():
    """Curves from a noise-free chart photograph predict the chart's responses within 2 % of white."""
    truth = _nikon()
    C = _chart_rgb(truth)
    est = estimate_ssf(chart=Chart(C))
    pred = _chart_rgb(est.values)  # same exposure rule: brightest value 0.8
    assert np.abs(pred - C).max() < 0.02 * C.max() / 0.8
    assert est.sources == ("chart",)


def test_chart_and_dng_together_are_no_worse_than_the_dng_alone():
    truth = _peak1(_nikon())
    dng = synthesise_dng_matrices("Nikon 5100 (NPL)")
    alone = _peak1(estimate_ssf(dng).values)
    both = estimate_ssf(dng, chart=Chart(_chart_rgb(_nikon())))
    assert both.sources == ("dng", "chart")
    e_alone = np.sqrt(np.mean((alone - truth) ** 2))
    e_both = np.sqrt(np.mean((_peak1(both.values) - truth) ** 2))
    assert e_both <= e_alone * 1.05


def test_a_chart_with_a_dng_is_an_exposure_of_its_own():
    """DNG + chart: the chart's exposure is an unknown, so scaling its means changes nothing, and the
    noise-free data of one camera are fitted as closely as by either source alone (before, the chart
    fixed the curves' scale against the matrices' and the fit shrank the curves: misfit 0.31)."""
    dng = synthesise_dng_matrices("Nikon 5100 (NPL)")
    C = _chart_rgb(_nikon())
    plain = dataclasses.replace(ssf_basis(), real_dng=None)  # matrices weighted as exact fits
    for basis in (ssf_basis(), plain):
        both = estimate_ssf(dng, chart=Chart(C), basis=basis)
        darker = estimate_ssf(dng, chart=Chart(0.25 * C), basis=basis)
        np.testing.assert_allclose(darker.values, both.values, atol=1e-6)
        assert both.residual < 0.01
    alone = [estimate_ssf(dng, basis=plain).residual, estimate_ssf(chart=Chart(C), basis=plain).residual]
    assert both.residual < 2 * max(alone)


def test_several_chart_photographs_fit_each_light_and_each_exposure():
    """A chart under D65 and under A, exposed differently: the estimate predicts both photographs up
    to each one's exposure (within 2 % of white), and neither exposure changes it."""
    truth = _nikon()
    photos = [_chart_rgb(truth, light="D65"), _chart_rgb(truth, light="A", top=0.5)]
    est = estimate_ssf(chart=[Chart(photos[0]), Chart(photos[1], illuminant="A")])
    assert est.sources == ("chart",)
    for C, light in zip(photos, ("D65", "A"), strict=True):
        pred = _chart_rgb(est.values, light=light, top=C.max())
        assert np.abs(pred - C).max() < 0.02 * C.max()
    brighter = estimate_ssf(chart=[Chart(photos[0]), Chart(1.5 * photos[1], illuminant="A")])
    np.testing.assert_allclose(brighter.values, est.values, atol=1e-6)


def test_a_chart_list_holding_something_else_is_one_line():
    with pytest.raises(SpectralDataError, match="sequence of Charts"):
        estimate_ssf(chart=[Chart(_chart_rgb(_nikon())), np.ones((24, 3))])


# --- basis ---------------------------------------------------------------------------------------


def test_basis_spans_its_cameras_and_round_trips_through_json():
    """With as many components as cameras, every training curve lies in the span (closed form)."""
    rng = np.random.default_rng(1)
    cams = {f"c{i}": np.abs(rng.normal(size=(W.size, 3))) + 0.1 for i in range(4)}  # 4 cameras, 4 components
    basis = learn_ssf_basis(cams, n_components=4, spread=np.zeros((W.size, 3)))
    for v in cams.values():
        for c in range(3):
            V = basis.components[c]
            s = v[:, c] / v[:, c].max()
            np.testing.assert_allclose(V @ (V.T @ s), s, atol=1e-10)
    again = SSFBasis.from_json(json.loads(json.dumps(basis.to_json())))
    np.testing.assert_allclose(again.components, basis.components, atol=1e-8)
    assert again.sources == basis.sources
    shipped = ssf_basis()
    assert shipped.components.shape[:2] == (3, W.size) and "Apache-2.0" in shipped.licence


def _calibrated(basis, prior=1.0):
    """``basis`` with a real-DNG calibration unlike its own (wider, other k and scale)."""
    cal = SSFCalibration(
        prior, 2.5 * basis.spread, 3.0, np.array([0.5, 0.6, 0.7]), None, np.array([[1.0] * 3, [0.0] * 3]), 9
    )
    return dataclasses.replace(basis, real_dng=cal)


def test_a_dng_alone_is_judged_by_the_real_dng_calibration():
    """DNG only: the calibration's prior, band, k and scale; with a chart: the basis' own band and
    prior (the chart's data are its own), the matrices weighted as the calibration judges them, so the
    estimate leans toward the chart's more than a basis without the calibration lets it."""
    plain = dataclasses.replace(ssf_basis(), real_dng=None)
    basis = _calibrated(plain)
    dng = synthesise_dng_matrices("Nikon 5100 (NPL)")
    alone = estimate_ssf(dng, basis=basis)
    np.testing.assert_allclose(alone.values, estimate_ssf(dng, basis=plain, prior=1.0).values)
    np.testing.assert_allclose(alone.uncertainty, 2.5 * plain.spread * alone.values.max(axis=0))
    assert alone.band_k == 3.0 and alone.response_scale.tolist() == [0.5, 0.6, 0.7]
    assert not np.allclose(alone.values, estimate_ssf(dng, basis=plain).values, atol=1e-3)  # prior matters
    chart = Chart(_chart_rgb(_nikon()))
    for kw in ({"chart": chart}, {"dng": dng, "chart": chart}):
        a, b = estimate_ssf(basis=basis, **kw), estimate_ssf(basis=plain, **kw)
        np.testing.assert_allclose(a.uncertainty / a.values.max(axis=0), b.uncertainty / b.values.max(axis=0))
        assert a.band_k == b.band_k
        if "dng" not in kw:
            np.testing.assert_allclose(a.values, b.values)
        else:
            only = _peak1(estimate_ssf(chart=chart, basis=plain).values)
            lean = [np.abs(_peak1(e.values) - only).max() for e in (a, b)]
            assert lean[0] < 0.5 * lean[1]
    np.testing.assert_allclose(
        estimate_ssf(dng, basis=basis, prior=SSF_PRIOR).values, estimate_ssf(dng, basis=plain).values
    )


def test_a_camera_unlike_the_calibration_cameras_is_estimated_as_from_exact_matrices():
    """A misfit above every calibration camera's (max_residual): the calibration does not apply; the
    estimate is the one the basis without it gives (prior SSF_PRIOR, the basis' own band)."""
    plain = dataclasses.replace(ssf_basis(), real_dng=None)
    strict = dataclasses.replace(
        _calibrated(plain), real_dng=dataclasses.replace(_calibrated(plain).real_dng, max_residual=1e-9)
    )
    dng = synthesise_dng_matrices("Nikon 5100 (NPL)")
    a, b = estimate_ssf(dng, basis=strict), estimate_ssf(dng, basis=plain)
    np.testing.assert_allclose(a.values, b.values)
    np.testing.assert_allclose(a.uncertainty, b.uncertainty)
    assert a.band_k == b.band_k == plain.band_k
    # the shipped calibration: a Foveon sensor (the Sigma) is unlike its Bayer cameras, the Nikon is not
    sigma = colour.MultiSpectralDistributions(
        zonotope.camera("Sigma SDMerill (NPL)").copy().align(SSF_SHAPE).values, W, name="sigma"
    )
    fell = estimate_ssf(synthesise_dng_matrices(sigma))
    assert fell.band_k == ssf_basis().band_k and fell.calibration.startswith("synthesised matrices (misfit")
    assert estimate_ssf(dng).band_k == ssf_basis().real_dng.band_k
    assert estimate_ssf(dng).calibration == "real DNG matrices"
    assert estimate_ssf(chart=Chart(_chart_rgb(_nikon()))).calibration == "synthesised matrices"


def test_real_dng_calibration_round_trips_and_bad_ones_are_refused():
    basis = _calibrated(learn_ssf_basis({f"c{i}": np.roll(_nikon(), i, axis=0) for i in range(6)}))
    again = SSFBasis.from_json(json.loads(json.dumps(basis.to_json())))
    assert again.real_dng.prior == 1.0 and again.real_dng.cameras == 9 and again.real_dng.band_k == 3.0
    np.testing.assert_allclose(again.real_dng.spread, basis.real_dng.spread, atol=1e-6)
    bad = (
        {"spread": [[0.1] * 3]},
        {"prior": -1},
        {"response_scale": [1, 1]},
        {"band_k": None},
        {"max_residual": 0},
    )
    for change in bad:
        doc = basis.to_json()
        doc["real_dng"] = doc["real_dng"] | change
        with pytest.raises(SpectralDataError, match="SSF basis"):
            SSFBasis.from_json(doc)


def test_the_shipped_basis_trusts_real_dng_matrices_less():
    """Measured on real (Adobe) matrices: a stronger prior and a wider band than exact matrices get."""
    shipped = ssf_basis()
    cal = shipped.real_dng
    assert cal is not None and cal.prior > SSF_PRIOR and cal.cameras >= 20
    assert np.all(np.sqrt(np.mean(cal.spread**2, axis=0)) > np.sqrt(np.mean(shipped.spread**2, axis=0)))
    est = estimate_ssf(synthesise_dng_matrices("Nikon 5100 (NPL)"))
    np.testing.assert_allclose(est.uncertainty, cal.spread * est.values.max(axis=0))


def test_json_output_loads_back_with_load_camera(tmp_path):
    est = estimate_ssf(synthesise_dng_matrices("Nikon 5100 (NPL)"), name="Nikon D5100")
    path = write_ssf_json(est, tmp_path / "cam.json")
    back = zonotope.load_camera(path)
    np.testing.assert_allclose(back.values, est.values, atol=1e-6)
    assert back.name == "Nikon D5100" and list(back.wavelengths) == list(W)
    doc = json.loads(path.read_text())
    assert len(doc["spectral_data"]["data"]["uncertainty"]) == W.size
    with pytest.raises(zonotope.ZonotopeError, match="already exists"):
        write_ssf_json(est, path)
    write_ssf_json(est, path, overwrite=True)  # its own earlier output may be replaced
    foreign = tmp_path / "other.json"
    foreign.write_text('{"header": {}}\n')
    with pytest.raises(zonotope.ZonotopeError, match="never replaced"):
        write_ssf_json(est, foreign, overwrite=True)
    assert foreign.read_text() == '{"header": {}}\n'


def test_response_sigma_grows_with_the_band():
    est = estimate_ssf(synthesise_dng_matrices("Nikon 5100 (NPL)"))
    s = est.response_sigma()
    assert s.shape == (3,) and np.all(s > 0)
    wider = dataclasses.replace(est, uncertainty=2 * est.uncertainty)
    np.testing.assert_allclose(wider.response_sigma(), 2 * s, rtol=1e-12)


def test_response_sigma_is_the_bound_times_the_calibrated_scale():
    """The RMS σ is the fully correlated bound (recomputed here from its definition) times the
    shipped basis' leave-one-out scale for a DNG alone (its real-DNG calibration), which is below 1
    (the bound is an upper bound); the default, told to fits, is that times SSF_FIT_SIGMA_SCALE."""
    est = estimate_ssf(synthesise_dng_matrices("Nikon 5100 (NPL)"))
    R = spectra.resample(zonotope.load_reflectances("rawtoaces 190"), W).T
    E = spectra.resample(zonotope.illuminant("D65"), W)[:, 0]
    bound = np.sqrt(np.mean(np.square((R * E) @ est.uncertainty), axis=0)) / (E @ est.values)
    np.testing.assert_allclose(est.response_sigma(bound=True), bound, rtol=1e-10)
    scale = ssf_basis().real_dng.response_scale
    assert np.all((scale > 0) & (scale < 1))
    np.testing.assert_allclose(est.response_sigma(rms=True), bound * scale, rtol=1e-10)
    assert 0 < SSF_FIT_SIGMA_SCALE < 1
    np.testing.assert_allclose(est.response_sigma(), bound * scale * SSF_FIT_SIGMA_SCALE, rtol=1e-10)
    np.testing.assert_allclose(est.response_sigma(bound=True, rms=True), bound, rtol=1e-10)


def test_default_band_is_the_calibrated_multiple():
    est = estimate_ssf(synthesise_dng_matrices("Nikon 5100 (NPL)"))
    assert est.band_k == ssf_basis().real_dng.band_k > 0
    assert estimate_ssf(chart=Chart(_chart_rgb(_nikon()))).band_k == ssf_basis().band_k > 0
    lower, upper = est.band()
    np.testing.assert_allclose(upper - est.values, est.band_k * est.uncertainty, rtol=1e-12)
    np.testing.assert_array_equal(lower, np.maximum(est.values - est.band_k * est.uncertainty, 0.0))


@pytest.mark.parametrize("change", [{"band_k": 0.0}, {"response_scale": [1.0, 1.0]}, {"band_k": "wide"}])
def test_a_basis_with_a_bad_calibration_is_refused(change):
    doc = {**ssf_basis().to_json(), **change}
    with pytest.raises(SpectralDataError, match="SSF basis"):
        SSFBasis.from_json(doc)


def test_calibrated_sigma_repairs_stacked_cameras_held_out_of_the_basis(shared_data):
    """Two camspec cameras (never in the shipped basis), estimated from synthesised matrices: the
    root-polynomial fitted on the estimates and applied to the measured cameras' responses is worse
    noise-free than told the calibrated σ (the measured camera is the independent truth)."""
    from zonotope.correct import NoiseModel, correction_problem, fit_correction, noise_options
    from zonotope.ssf_band import ssf_noise

    folder = shared_data / "ssf_jiang2013_camspec"
    measured = [zonotope.load_camera(folder / m / f"{m}.csv") for m in ("Canon_40D", "Nikon_D80")]
    est = [estimate_ssf(synthesise_dng_matrices(m)) for m in measured]
    truth = correction_problem(measured, shape=SSF_SHAPE)
    fitted = correction_problem([e.sensitivities for e in est], shape=SSF_SHAPE)
    sigma = np.concatenate([ssf_noise(e).sigma_white for e in est])
    R = spectra.resample(zonotope.load_reflectances("ColorChecker N Ohta"), W).T
    dE = []
    for opts in ({}, noise_options("Finlayson 2015", NoiseModel(np.zeros(6), sigma**2))):
        fit = fit_correction(fitted, method="Finlayson 2015", **opts)
        dE.append(float(np.mean(truth.delta_E(fit(truth.source_of(R)), truth.target_of(R)))))
    assert dE[1] < 0.7 * dE[0], dE


# --- errors --------------------------------------------------------------------------------------


@pytest.mark.parametrize(
    ("tags", "match"),
    [
        ({}, "no usable ColorMatrix1/ColorMatrix2"),
        ({"ColorMatrix1": np.zeros(9)}, "no usable ColorMatrix1/ColorMatrix2"),
        ({"ColorMatrix1": np.ones(9), "CalibrationIlluminant1": 21}, "singular"),
        (
            {
                "ColorMatrix1": np.eye(3).ravel(),
                "ColorMatrix2": np.eye(3).ravel(),
                "CalibrationIlluminant1": 255,
            },
            "CalibrationIlluminant1 = 255",
        ),
    ],
)
def test_dng_without_usable_matrices_is_a_one_line_error(tags, match):
    with pytest.raises(SpectralDataError, match=match) as info:
        estimate_ssf(tags)
    assert "\n" not in str(info.value)


def test_a_file_that_is_not_a_dng_is_refused(tmp_path):
    path = tmp_path / "x.dng"
    path.write_text("not a tiff")
    with pytest.raises(SpectralDataError, match="not a readable DNG"):
        read_dng_matrices(path)
    with pytest.raises(SpectralDataError, match="no such file"):
        read_dng_matrices(tmp_path / "missing.dng")
    with pytest.raises(SpectralDataError, match=r"a DNG .* a chart"):
        estimate_ssf()


@pytest.mark.parametrize(
    ("change", "match"),
    [
        (lambda C: np.where(np.arange(24)[:, None] == 18, SSF_CHART_CLIP, C), r"patches \[19\] are clipped"),
        (lambda C: C * 0.001, "too dark"),
        (lambda C: C * 4000, "fractions of saturation"),
        (lambda C: C[:20], "20 patch means for a chart of 24"),
        (lambda C: C[:, :2], r"expected \(patches, 3\)"),
        (lambda C: np.where(C > 0.5, np.nan, C), "NaN"),
    ],
)
def test_bad_charts_are_one_line_errors(change, match):
    C = change(_chart_rgb(_nikon()))
    with pytest.raises(SpectralDataError, match=match) as info:
        estimate_ssf(chart=Chart(C))
    assert "\n" not in str(info.value)
