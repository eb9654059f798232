"""Credible radii of "Prior" under a noise model: the noise reach against Monte Carlo, and coverage."""

from __future__ import annotations

import numpy as np
import pytest

from zonotope.correct import NoiseModel, correction_problem, fit_correction
from zonotope.evaluate import natural_test_sets, source_split

W = np.arange(400, 701, 10)
TWO = ["Nikon 5100 (NPL)", "Canon EOS 5D Mark II"]


@pytest.fixture(scope="module")
def problem2():
    return correction_problem(TWO, shape=W)


def test_noise_reach_matches_monte_carlo(problem2):
    """The 95 % ΔE00 reach of response noise through the regression, against sampled noise."""
    from zonotope.correct.mmv import _noise_radius

    model = NoiseModel.shot_limited(0.005, problem2.k)
    reg = fit_correction(problem2, method="root-polynomial", noise=model)
    X = np.concatenate([t.reflectances for t in natural_test_sets(W)])[::6]
    C = problem2.source_of(X)
    r = _noise_radius(problem2, reg, model, C)
    rng = np.random.default_rng(0)
    for c, ri in zip(C, r):
        cs = model.sample(np.tile(c, (4000, 1)), rng)
        mc = np.percentile(problem2.delta_E(reg(cs), reg(c[None])), 95)
        assert 0.7 * mc < ri < 1.4 * mc, (c, ri, mc)


def test_radii_with_noise_cover_noisy_natural_responses(problem2):
    model = NoiseModel.shot_limited(0.005, problem2.k)
    X = np.concatenate([t.reflectances for t in source_split(natural_test_sets(W), problem2.training)[0]])
    C = model.sample(problem2.source_of(X), np.random.default_rng(1))
    T = problem2.target_of(X)
    est = fit_correction(problem2, method="Prior", noise=model, mix=0.5)
    XYZ, radius = est.with_uncertainty(C)
    cover = np.mean(problem2.delta_E(XYZ, T) <= radius)
    assert 0.85 <= cover <= 1.0
    assert np.std(radius) > 0.05 * np.mean(radius)  # per response, not one constant
    dark = problem2.to_Lab(T)[:, 0] < 40
    assert np.median(radius[dark]) > np.median(radius[~dark])  # shot noise weighs more on dark colours


def test_noise_free_radius_is_the_cross_validation_percentile(problem2):
    est = fit_correction(problem2, method="Prior", mix=0.5)
    C = problem2.source_of(natural_test_sets(W)[0].reflectances)
    np.testing.assert_allclose(est.params["r_nat_of"](C), est.params["r_nat"])


# ------------------------------------------------------------------------------- posterior_radius


def test_posterior_radius_covers_draws_of_its_own_model(problem2):
    """Reflectances drawn from the Gaussian prior itself, seen with noise σ: the true colour lies within
    the closed-form radius around the posterior mean (``interior_solution``: the same model, solved
    another way) for about 95 % of the draws: a Monte Carlo check of the covariance and its ΔE00
    reach."""
    from zonotope.correct import ReflectancePrior, interior_solution, posterior_radius

    prior = ReflectancePrior.fit(problem2.training)
    rng = np.random.default_rng(4)
    X = rng.multivariate_normal(prior.mean, prior.cov, 6000)
    X = X[(problem2.target_of(X)[:, 1] > 0.05 * problem2.white_XYZ[1])]  # colours with a defined Lab
    sigma = np.array([0.004, 0.003, 0.005, 0.006, 0.004, 0.005])
    C = problem2.source_of(X) + sigma * rng.standard_normal((len(X), problem2.k))
    t = interior_solution(prior, problem2.Phi, C, noise=sigma)[0] @ problem2.Psi
    r = posterior_radius(problem2, t, sigma, prior=prior)
    cover = np.mean(problem2.delta_E(t, problem2.target_of(X)) <= r)
    # 0.92 for seeds 4–6: the radius is that of an isotropic ball with the spread's mean square, and the
    # spread is not isotropic in CIELAB
    assert 0.90 <= cover <= 0.97, cover


def test_posterior_radius_shrinks_with_cameras_and_grows_with_noise():
    """A second camera narrows what the surface could be (its metamer mismatch), more noise widens it;
    without noise one camera still leaves a radius (metamerism), and bad σ is refused."""
    from zonotope import SpectralDataError
    from zonotope.correct import posterior_radius

    one, two = correction_problem(TWO[:1], shape=W), correction_problem(TWO, shape=W)
    t = one.target_of(natural_test_sets(W)[0].reflectances)
    r1, r2 = posterior_radius(one, t, 0.0), posterior_radius(two, t, 0.0)
    assert (r1 > 0.2).all() and (r2 < r1).all()
    noisy = posterior_radius(two, t, 0.02)
    assert (noisy > r2).all()
    np.testing.assert_allclose(posterior_radius(two, t, np.zeros(6)), r2)
    with pytest.raises(SpectralDataError, match="noise"):
        posterior_radius(two, t, [0.01, np.nan, 0, 0, 0, 0])
