"""Held-out error draws of estimated sensitivities and the errors-in-variables regression."""

from __future__ import annotations

import dataclasses

import colour
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from zonotope._errors import OptionError, SpectralDataError
from zonotope._tol import SSF_ERROR_WEIGHT_FLOOR, SSF_PRIOR
from zonotope.correct import NoiseModel, correction_problem, fit_correction, noise_options
from zonotope.correct.eiv import fit_errors_in_variables
from zonotope.correct.regressions import root_polynomial_terms
from zonotope.spectra.estimate import (
    SSF_SHAPE,
    SSFBasis,
    estimate_ssf,
    held_out_error_model,
    ssf_basis,
    synthesise_dng_matrices,
)
from zonotope.ssf_band import ssf_response_errors

W = np.asarray(SSF_SHAPE.wavelengths)


def smooth_errors(m: int, seed: int, size: float = 0.03) -> np.ndarray:
    """``m`` smooth curve errors (n, 3) of about ``size`` (peak 1)."""
    rng = np.random.default_rng(seed)
    x = (W - W[0]) / (W[-1] - W[0])
    basis = np.stack([np.sin(np.pi * (j + 1) * x) for j in range(4)], axis=1)
    return size * np.einsum("nj,mjc->mnc", basis, rng.standard_normal((m, 4, 3)))


def msds(values, name):
    return colour.MultiSpectralDistributions(values, W, labels=["r", "g", "b"], name=name)


@pytest.fixture(scope="module")
def ests():
    """Two estimates (the built-in Nikon's, and one of a camera with its curves shifted by 20 nm),
    each with six smooth held-out errors."""
    first = estimate_ssf(synthesise_dng_matrices("Nikon 5100 (NPL)"), prior=SSF_PRIOR)
    second = estimate_ssf(
        synthesise_dng_matrices(msds(np.roll(first.values, 2, axis=0), "shifted")), prior=SSF_PRIOR
    )
    weight = np.array([[1.0] * 3, [0.0] * 3])
    return [
        dataclasses.replace(e, errors=smooth_errors(6, i), error_weight=weight)
        for i, e in enumerate((first, second))
    ]


@settings(max_examples=10, deadline=None)
@given(scale=st.floats(0.1, 2.0), m=st.integers(0, 5))
def test_response_errors_are_the_responses_of_the_perturbed_curves(ests, scale, m):
    """Independent path: the correction problem's white-balanced responses of the drawn curves."""
    e = ests[0]
    R = correction_problem(e.sensitivities, shape=SSF_SHAPE).training
    drawn = np.maximum(e.values + scale * e.values.max(axis=0) * e.errors[m], 0.0)
    want = correction_problem(msds(drawn, "drawn"), shape=SSF_SHAPE).source_of(R)
    want = want - correction_problem(e.sensitivities, shape=SSF_SHAPE).source_of(R)
    np.testing.assert_allclose(e.response_errors(R, scale=scale)[m], want, atol=1e-12)


def test_response_errors_weight_by_misfit_with_a_floor(ests):
    e = ests[0]
    R = np.eye(W.size)[::3]
    one = e.response_errors(R, scale=0.01)
    # weight a + b·r = 2 exactly: the same draws as twice the scale
    two = dataclasses.replace(e, error_weight=np.array([[1.0] * 3, [1.0 / e.residual] * 3]))
    np.testing.assert_allclose(
        two.response_errors(R, scale=0.01), e.response_errors(R, scale=0.02), atol=1e-15
    )
    low = dataclasses.replace(e, error_weight=np.array([[-5.0] * 3, [0.0] * 3]))
    np.testing.assert_allclose(
        low.response_errors(R, scale=0.01),
        e.response_errors(R, scale=0.01 * SSF_ERROR_WEIGHT_FLOOR),
        atol=1e-15,
    )
    assert np.abs(one).max() > 0
    assert np.all(e.response_errors(R, scale=0.0) == 0)


def test_response_errors_need_the_errors_and_the_grid(ests):
    with pytest.raises(SpectralDataError, match="no held-out errors"):
        dataclasses.replace(ests[0], errors=None).response_errors()
    with pytest.raises(SpectralDataError, match="shape"):
        ests[0].response_errors(np.ones((4, W.size - 1)))


def test_stacked_draws_shuffle_each_camera(ests):
    pb = correction_problem([e.sensitivities for e in ests], shape=SSF_SHAPE)
    d = ssf_response_errors(ests, pb, seed=3)
    assert d.shape == (6, pb.training.shape[0], 6)
    for i, e in enumerate(ests):
        own = e.response_errors(pb.training)
        # every draw of camera i is one of its own draws, each used once
        match = [int(np.argmin(np.abs(own - x).max(axis=(1, 2)))) for x in d[:, :, 3 * i : 3 * i + 3]]
        assert sorted(match) == list(range(6))
        np.testing.assert_allclose(d[:, :, 3 * i : 3 * i + 3], own[match], atol=1e-15)
    with pytest.raises(SpectralDataError, match="not the responses"):
        ssf_response_errors(ests[::-1], pb)
    with pytest.raises(SpectralDataError, match="not the responses"):
        ssf_response_errors(ests, pb, illuminant="A")


def problem_and_draws(ests):
    pb = correction_problem([e.sensitivities for e in ests], shape=SSF_SHAPE)
    return pb, ssf_response_errors(ests, pb)


def test_zero_draws_give_the_plain_and_the_noise_aware_regressions(ests):
    pb, d = problem_and_draws(ests)
    zero = np.zeros((2, *d.shape[1:]))
    for method in ("Finlayson 2015", "Cheung 2004"):
        plain = fit_correction(pb, method=method).params["M"]
        np.testing.assert_allclose(
            fit_errors_in_variables(pb, zero, method=method).params["M"], plain, rtol=1e-6
        )
        noise = NoiseModel(np.full(6, 1e-5), np.full(6, 1e-5))
        aware = fit_correction(pb, method=method, **noise_options(method, noise)).params["M"]
        got = fit_errors_in_variables(pb, zero, method=method, noise=noise).params["M"]
        np.testing.assert_allclose(got, aware, rtol=1e-6)


@settings(max_examples=10, deadline=None)
@given(size=st.floats(1e-4, 0.05), seed=st.integers(0, 100))
def test_linear_fit_on_opposite_draws_is_the_closed_form(ests, size, seed):
    """Draws ±d: the averaged normal equations are CᵀC + dᵀd, CᵀT (the cross terms cancel)."""
    pb = correction_problem([e.sensitivities for e in ests], shape=SSF_SHAPE)
    C, T = pb.source_of(pb.training), pb.target_of(pb.training)
    d = size * np.random.default_rng(seed).standard_normal(C.shape)
    M = fit_errors_in_variables(pb, np.stack([d, -d]), method="Cheung 2004", ridge=0.0).params["M"]
    np.testing.assert_allclose(M, np.linalg.solve(C.T @ C + d.T @ d, C.T @ T), rtol=1e-7, atol=1e-9)


def test_one_draw_is_the_least_squares_fit_of_the_moved_responses(ests):
    pb, d = problem_and_draws(ests)
    C, T = pb.source_of(pb.training), pb.target_of(pb.training)
    fit = fit_errors_in_variables(pb, d[:1], ridge=0.0)
    want = np.linalg.lstsq(root_polynomial_terms(C + d[0], degree=2), T, rcond=None)[0]
    # compared on the fitted colours (the coefficients of 45 collinear terms are ill-conditioned)
    for x in (C + d[0], C[:20] * 0.7):
        np.testing.assert_allclose(fit(x), root_polynomial_terms(x, degree=2) @ want, atol=1e-7)


def test_bad_options(ests):
    pb, d = problem_and_draws(ests)
    with pytest.raises(OptionError, match="choose"):
        fit_errors_in_variables(pb, d, method="Prior")
    with pytest.raises(OptionError, match="linear"):
        fit_errors_in_variables(pb, d, method="Cheung 2004", degree=2)
    with pytest.raises(SpectralDataError, match="shape"):
        fit_errors_in_variables(pb, d[:, :, :3])
    with pytest.raises(SpectralDataError, match="finite"):
        fit_errors_in_variables(pb, d * np.nan)


def test_basis_document_keeps_the_error_model():
    b = ssf_basis()
    doc = dataclasses.replace(
        b, errors=smooth_errors(5, 1), error_weight=np.array([[0.5] * 3, [2.0] * 3])
    ).to_json()
    back = SSFBasis.from_json(doc)
    np.testing.assert_allclose(back.errors, np.round(smooth_errors(5, 1), 6))
    np.testing.assert_allclose(back.error_weight, [[0.5] * 3, [2.0] * 3])
    doc["errors"] = np.zeros((5, 3, 3)).tolist()
    with pytest.raises(SpectralDataError, match="errors"):
        SSFBasis.from_json(doc)


def test_held_out_error_model_is_the_curve_errors_and_a_misfit_line(ests):
    pairs = []
    for i, r in enumerate((0.001, 0.002, 0.004, 0.008)):
        e = dataclasses.replace(ests[0], residual=r)
        truth = np.maximum(e.values + smooth_errors(1, 10 + i, 0.02)[0], 0.0)
        pairs.append((e, truth))
    errors, weight = held_out_error_model(pairs)
    for (e, t), got in zip(pairs, errors, strict=True):
        np.testing.assert_allclose(got, t / t.max(axis=0) - e.values / e.values.max(axis=0), atol=1e-15)
    # the line: least squares of each camera's RMS response error (through the correction problem's
    # own responses, rawtoaces 190 under D65) relative to their RMS, on the misfit
    rms = []
    for e, t in pairs:
        pe, pt = (correction_problem(msds(v, "c"), shape=SSF_SHAPE) for v in (e.values, t))
        rms.append(np.sqrt(np.mean(np.square(pt.source_of(pt.training) - pe.source_of(pe.training)), axis=0)))
    rms = np.array(rms)
    r = np.array([e.residual for e, _ in pairs])
    for c in range(3):
        slope, offset = np.polyfit(r, rms[:, c] / np.sqrt(np.mean(rms[:, c] ** 2)), 1)
        np.testing.assert_allclose(weight[:, c], [offset, slope], rtol=1e-8)
    with pytest.raises(SpectralDataError, match="at least 3"):
        held_out_error_model(pairs[:2])


def test_the_shipped_basis_carries_its_held_out_errors():
    est = estimate_ssf(synthesise_dng_matrices("Nikon 5100 (NPL)"))
    assert est.errors is not None and est.errors.shape[1:] == (W.size, 3) and len(est.errors) >= 3
    d = est.response_errors()
    assert d.shape == (len(est.errors), 190, 3) and np.all(np.isfinite(d)) and np.abs(d).max() > 0
