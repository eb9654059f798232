"""zonotope.ssf_band and sample_ssfs: the SSF uncertainty band reaches the noise model and the MMVs."""

from __future__ import annotations

import subprocess
import sys

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import zonotope
from zonotope._errors import SpectralDataError
from zonotope._tol import SSF_SAMPLE_MEAN_ATOL, SSF_UNIT_SIGMA
from zonotope.correct import NoiseModel, NoiseModelError, fit_correction, noise_options
from zonotope.spectra.estimate import estimate_ssf, sample_ssfs, synthesise_dng_matrices
from zonotope.ssf_band import band_mmvs, curves_sigma, ssf_noise


@pytest.fixture(scope="module")
def est():
    return estimate_ssf(synthesise_dng_matrices("Nikon 5100 (NPL)"))


sigmas = st.lists(st.floats(0.0, 0.05), min_size=3, max_size=3)


@settings(max_examples=25, deadline=None)
@given(sigma=sigmas, shot=st.floats(0.0, 1e-3))
def test_widened_noise_adds_the_band_in_quadrature(est, sigma, shot):
    base = NoiseModel(np.full(3, shot), np.square(sigma))
    wide = ssf_noise(est, base)
    band = est.response_sigma()
    assert np.all(wide.sigma_white >= base.sigma_white)
    np.testing.assert_allclose(wide.sigma_white, np.hypot(base.sigma_white, band), rtol=1e-12)
    np.testing.assert_array_equal(wide.shot, base.shot)


def test_noise_free_and_plain_sigma(est):
    np.testing.assert_allclose(ssf_noise(est).sigma_white, est.response_sigma(), rtol=1e-12)
    np.testing.assert_allclose(
        ssf_noise(est, 0.01).sigma_white, np.hypot(0.01, est.response_sigma()), rtol=1e-12
    )
    with pytest.raises(NoiseModelError):
        ssf_noise(est, -0.01)


def test_a_registry_estimator_fits_with_the_widened_noise(est):
    """The widened model is what fit_correction takes, and it changes the fit: noise-free least squares
    is the best fit of the noise-free training colours, so the noise-aware one fits them worse."""
    plain = fit_correction(est.sensitivities, method="least squares")
    wide = fit_correction(
        est.sensitivities, method="least squares", **noise_options("least squares", ssf_noise(est))
    )
    pb = plain.problem
    c, t = pb.training @ pb.Phi, pb.training @ pb.Psi
    err = [np.square(f.predict(c) - t).sum() for f in (plain, wide)]
    assert err[1] > err[0] * (1 + 1e-6)  # strictly worse: the noise changed the fit


@settings(max_examples=15, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), k=st.floats(0.5, 3.0))
def test_samples_are_non_negative_and_inside_the_band(est, seed, k):
    draws = np.stack([s.values for s in sample_ssfs(est, 5, seed=seed, k=k)])
    lower, upper = est.band(k)
    assert draws.shape == (5, *est.values.shape)
    assert np.all(draws >= 0)
    assert np.all(draws >= lower - 1e-12) and np.all(draws <= upper + 1e-12)


def test_samples_centre_on_the_estimate_and_vary(est):
    draws = np.stack([s.values for s in sample_ssfs(est, 400, seed=1)])
    np.testing.assert_allclose(draws.mean(axis=0), est.values, atol=SSF_SAMPLE_MEAN_ATOL)
    assert draws.std(axis=0).max() > 0.2 * est.uncertainty.max()  # they do spread
    again = np.stack([s.values for s in sample_ssfs(est, 400, seed=1)])
    np.testing.assert_array_equal(draws, again)


@pytest.mark.parametrize("bad", [{"n": 0}, {"n": 2.5}, {"n": 2, "k": 0.0}, {"n": 2, "correlation": -1.0}])
def test_sample_bad_options(est, bad):
    with pytest.raises(SpectralDataError, match="sample_ssfs"):
        sample_ssfs(est, **bad)


def test_band_mmvs_contain_the_truth_and_collapse_with_the_band(est):
    grey = np.full(est.wavelengths.size, 0.4)
    band = band_mmvs(est, grey, n=3, seed=2)
    truth = grey @ band.problem.Psi
    assert len(band.sample_mmvs) == 3 and band.centroid_delta_e.shape == (3,)
    for m in [band.mmv, *band.sample_mmvs]:
        assert m.volume > 0
        assert np.linalg.norm(m.centroid - truth) < 0.2  # a metamer of grey stays near grey
    assert np.any(band.centroid_delta_e > 0.05)  # the band moves the MMV
    thin = band_mmvs(est, grey, n=2, seed=2, k=1e-9)
    np.testing.assert_allclose(thin.sample_volumes, thin.volume, rtol=1e-3)
    assert np.all(thin.centroid_delta_e < 1e-3)
    with pytest.raises(SpectralDataError, match="band_mmvs"):
        band_mmvs(est, grey[:-1])


@pytest.mark.slow
def test_plot_mmv_band_png(tmp_path):
    script = f"""
import os
import numpy as np
from zonotope import viz
from zonotope.spectra.estimate import estimate_ssf, synthesise_dng_matrices
from zonotope.ssf_band import band_mmvs
est = estimate_ssf(synthesise_dng_matrices("Nikon 5100 (NPL)"))
band = band_mmvs(est, np.full(31, 0.4), n=3)
viz.plot_mmv_band(band, filename={str(tmp_path / "band.png")!r}).close()
os._exit(0)
"""
    r = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True, timeout=600)
    assert r.returncode == 0, r.stderr[-3000:]
    import matplotlib.image as mpimg

    img = mpimg.imread(tmp_path / "band.png")[..., :3]
    assert img.std() > 0.01


def test_top_level_names():
    assert zonotope.ssf_noise is ssf_noise and zonotope.sample_ssfs is sample_ssfs


def test_band_mmvs_draws_with_the_given_correlation(est):
    """The draws of band_mmvs are sample_ssfs' with the same seed, k and correlation."""
    grey = np.full(est.wavelengths.size, 0.4)
    for corr in (10.0, 80.0):
        band = band_mmvs(est, grey, n=1, seed=3, k=2.0, correlation=corr)
        (draw,) = sample_ssfs(est, 1, seed=3, k=2.0, correlation=corr)
        expect = zonotope.correct.correction_problem(draw, shape=band.problem.wavelengths)
        np.testing.assert_allclose(band.samples[0].Phi, expect.Phi, rtol=1e-12)


def test_curves_sigma_is_each_estimates_band_and_the_units_spread_for_measured_curves():
    """An estimate carries its own band; measured curves the spread between units in a stack, nothing
    alone or where they are the very camera's (``exact``)."""
    est = estimate_ssf(synthesise_dng_matrices("Nikon 5100 (NPL)"))
    band = np.asarray(est.response_sigma("D65"))
    np.testing.assert_allclose(curves_sigma([None, est], "D65"), [*SSF_UNIT_SIGMA, *band])
    np.testing.assert_allclose(curves_sigma([None, est], "D65", exact=[0]), [0, 0, 0, *band])
    np.testing.assert_allclose(curves_sigma([None], "D65"), [0, 0, 0])
