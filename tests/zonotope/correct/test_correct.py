"""zonotope.correct (methods, prior, image): estimators against independent implementations."""

from __future__ import annotations

import colour
import numpy as np
import pytest
from scipy.optimize import minimize

from zonotope._errors import OptionError, SpectralDataError
from zonotope.correct import (
    CORRECTION_METHODS,
    correct,
    correction_problem,
    fit_correction,
    mmv_centroids,
    root_polynomial_terms,
)
from zonotope.correct.image import correct_image
from zonotope.correct.mmv import MIX_GRID, PriorConfig
from zonotope.correct.prior import (
    ReflectancePrior,
    fiber_lsq,
    interior_solution,
    map_reflectance,
    project_to_mmv,
)
from zonotope.geometry.lp import distance_to_zonotope
from zonotope.spectra.atypical import atypical_reflectances

GRID = np.arange(400.0, 701.0, 10.0)


@pytest.fixture(scope="module")
def problem():
    return correction_problem("Nikon 5100 (NPL)", shape=GRID)


@pytest.fixture(scope="module")
def problem2():
    return correction_problem(["Nikon 5100 (NPL)", "Canon EOS 5D Mark II"], shape=GRID)


@pytest.fixture(scope="module")
def checker(problem):
    from zonotope import spectra

    return np.clip(spectra.resample(spectra.reflectances("ColorChecker N Ohta"), GRID).T, 0, 1)


def in_mmv(problem, c, t, tol=1e-5):
    """Reference containment: (c, t) in the joint zonotope of [Φ Ψ] (one HiGHS LP)."""
    G = np.hstack([problem.Phi, problem.Psi])
    return distance_to_zonotope(G, np.zeros(G.shape[1]), np.concatenate([c, t]))[0] <= tol


# -- regressions against colour-science ---------------------------------------------------------


@pytest.mark.parametrize("degree", [1, 2, 3])
def test_root_polynomial_terms_match_colour(degree):
    rgb = np.random.default_rng(1).uniform(0.01, 1, (7, 3))
    ours = root_polynomial_terms(rgb, degree=degree)
    ref = colour.characterisation.polynomial_expansion_Finlayson2015(rgb, degree)
    assert ours.shape == ref.shape
    # same set of columns (order may differ)
    assert np.allclose(np.sort(ours, axis=1), np.sort(ref, axis=1))


def test_root_polynomial_general_k_counts_and_exposure():
    c = np.random.default_rng(2).uniform(0.01, 1, (5, 6))
    assert root_polynomial_terms(c, degree=2).shape == (5, 6 + 15)
    assert np.allclose(root_polynomial_terms(3 * c, degree=3), 3 * root_polynomial_terms(c, degree=3))


def test_finlayson2015_matches_colour_fit(problem, checker):
    est = fit_correction(problem, method="root-polynomial")
    C, T = problem.source_of(problem.training), problem.target_of(problem.training)
    M = colour.characterisation.matrix_colour_correction_Finlayson2015(C, T, degree=2)
    test = problem.source_of(checker)
    ref = colour.characterisation.colour_correction(test, C, T, method="Finlayson 2015", degree=2)
    assert M.shape == (3, 6)
    assert np.allclose(est(test), ref, atol=1e-6)


def test_cheung2004_is_least_squares(problem2):
    est = fit_correction(problem2, method="least squares")
    C, T = problem2.source_of(problem2.training), problem2.target_of(problem2.training)
    M = np.linalg.lstsq(C, T, rcond=None)[0]
    # the tiny ridge moves the coefficients of the near-collinear 6-channel stack, not the fit
    assert np.allclose(est(C), C @ M, atol=1e-4)


def test_idt_single_camera_only(problem, problem2, checker):
    est = fit_correction(problem, method="idt")
    dE = problem.delta_E(est(problem.source_of(checker)), problem.target_of(checker))
    assert dE.mean() < 3.0
    with pytest.raises(SpectralDataError, match="one RGB camera"):
        fit_correction(problem2, method="idt")


# -- shapes, NaN, errors ------------------------------------------------------------------------


def test_batch_shapes_and_nan(problem, checker):
    est = fit_correction(problem, method="Finlayson 2015")
    C = problem.source_of(checker[:6]).reshape(2, 3, 3)
    out = est(C)
    assert out.shape == (2, 3, 3)
    assert np.allclose(out.reshape(6, 3), est(C.reshape(6, 3)))
    C[0, 1, 2] = np.nan
    out = est(C)
    assert np.isnan(out[0, 1]).all() and np.isfinite(out[1]).all()
    with pytest.raises(SpectralDataError, match="3 source channels"):
        est(np.zeros((4, 6)))


def test_unknown_method_lists_valid_ones(problem):
    with pytest.raises(ValueError, match="Cheung 2004"):
        fit_correction(problem, method="neural net")
    assert set(CORRECTION_METHODS) >= {"Cheung 2004", "Finlayson 2015", "Centroid", "Prior"}


def test_reliability_messages():
    with pytest.raises(SpectralDataError, match="more than once"):
        correction_problem(["Nikon 5100 (NPL)", "nikon 5100"], shape=GRID)
    with pytest.raises(SpectralDataError, match="700"):  # Sigma data stop at 680 nm: grid outside
        correction_problem("Sigma SDMerill (NPL)", shape=GRID)
    with pytest.raises(SpectralDataError, match="no reflectances"):
        correction_problem("Nikon 5100 (NPL)", shape=GRID, training=np.zeros((0, GRID.size)))
    one = correction_problem("Nikon 5100 (NPL)", shape=GRID, training=np.full((1, GRID.size), 0.5))
    with pytest.raises(SpectralDataError, match="training set has 1 samples"):
        fit_correction(one, method="root-polynomial")


def test_lms_target_maps_to_xyz():
    lms = correction_problem("Nikon 5100 (NPL)", shape=GRID, target="Stockman & Sharpe 2°")
    xyz = correction_problem("Nikon 5100 (NPL)", shape=GRID)
    assert np.allclose(lms.Psi @ lms.XYZ_from_target, xyz.Psi, atol=2e-3)
    assert np.allclose(lms.white_XYZ, xyz.white_XYZ, atol=2e-3)


# -- reflectance-space programs vs scipy SLSQP (reference twin) --------------------------------


def test_map_reflectance_matches_slsqp(problem, checker):
    prior = ReflectancePrior.fit(problem.training)
    X = np.vstack([checker[[1, 13]], atypical_reflectances(GRID, 1, seed=3)[0]])
    C = problem.source_of(X)
    x = map_reflectance(problem, C, prior)
    assert np.all((x >= 0) & (x <= 1))
    assert np.allclose(x @ problem.Phi, C, atol=1e-6)
    for i in range(len(C)):
        ref = minimize(
            lambda v: prior.energy(v),
            np.full(GRID.size, 0.5),
            method="SLSQP",
            jac=lambda v: prior.precision @ (v - prior.mean),
            bounds=[(0, 1)] * GRID.size,
            options={"ftol": 1e-12, "maxiter": 500},
            constraints=[{"type": "eq", "fun": lambda v, c=C[i]: v @ problem.Phi - c}],
        )
        assert prior.energy(x[i]) <= ref.fun * (1 + 1e-4) + 1e-9


def test_fiber_lsq_noise_is_feasible_for_outside_response(problem):
    c = np.array([[1.2, 0.1, 0.1]])  # outside the object-colour solid
    x = fiber_lsq(problem.Phi, c, np.eye(GRID.size), np.full(GRID.size, 0.5), noise=0.01)
    assert np.all((x >= 0) & (x <= 1))


def test_projection_inside_unchanged_outside_lands_in_mmv(problem2, checker):
    X = checker[[2, 5]]
    C, T = problem2.source_of(X), problem2.target_of(X)
    y, inside = project_to_mmv(problem2, C, T)
    assert inside.all() and np.array_equal(y, T)
    far = T + np.array([0.05, -0.03, 0.04])
    y, inside = project_to_mmv(problem2, C, far)
    assert not inside.any()
    for c, t in zip(C, y):
        assert in_mmv(problem2, c, t)
    # the projection is closer (Lab metric) than the true colour, which is also in the MMV
    W = problem2.lab_metric(far)
    d_proj = np.einsum("ni,nij,nj->n", y - far, W, y - far)
    d_true = np.einsum("ni,nij,nj->n", T - far, W, T - far)
    assert np.all(d_proj <= d_true + 1e-9)


# -- prior-aware estimator -----------------------------------------------------------------------


def test_prior_estimator_natural_vs_atypical(problem2, checker):
    prior_est = fit_correction(problem2, method="Prior")
    rp = fit_correction(problem2, method="Finlayson 2015")
    C = problem2.source_of(checker)
    weights = prior_est.params["weights"]
    x = map_reflectance(problem2, C, prior_est.params["prior"])
    assert np.median(weights(C, x)) > 0.9  # natural → trust the regression
    dE = problem2.delta_E(prior_est(C), problem2.target_of(checker))
    dE_rp = problem2.delta_E(rp(C), problem2.target_of(checker))
    assert dE.mean() < dE_rp.mean() + 0.1
    A, _ = atypical_reflectances(GRID, 4, seed=5, kinds=["narrow-band"])
    CA = problem2.source_of(A)
    wA = weights(CA, map_reflectance(problem2, CA, prior_est.params["prior"]))
    assert np.median(wA) < 0.5
    est = prior_est(CA)
    for c, t in zip(CA, est):
        assert in_mmv(problem2, c, t, tol=1e-4)
    # improbable under the natural model → the atypical branch alone: λ · MAP + (1 − λ) · MMV centroid,
    # λ = b λ_in + (1 − b) λ_bd, b = exp(−(E(x̂) − E(x₀))) the prior density ratio of the bounded MAP
    # reflectance x̂ to the unbounded one x₀ (1 where x̂ is interior), (λ_in, λ_bd) learnt by
    # cross-validation on contrast-stretched training spectra
    low = wA <= 1e-4
    assert low.any()
    lam = prior_est.params["mix"]
    cv = prior_est.params["mix_cv"]
    scores = cv["scores"]
    assert set(scores) == {(a, b) for a in MIX_GRID for b in MIX_GRID}
    assert scores[cv["best"]] == min(scores.values()) and cv["one"][0] == cv["one"][1]
    assert scores[cv["one"]] == min(s for (a, b), s in scores.items() if a == b)
    assert lam == (cv["best"] if cv["gain"] > cv["se"] else cv["one"])  # one-standard-error rule
    assert prior_est.params["radius_scale"] == max(1.0, prior_est.params["mix_cv"]["radius_scale"]) >= 1.0
    prior = prior_est.params["prior"]
    x0, interior = interior_solution(prior, problem2.Phi, CA[low])
    x = map_reflectance(problem2, CA[low], prior)
    assert (prior.energy(x) >= prior.energy(x0) - 1e-9).all() and not interior.all()
    b = np.where(interior, 1.0, np.exp(-(prior.energy(x) - prior.energy(x0))))
    lam_rows = (b * lam[0] + (1 - b) * lam[1])[:, None]
    t_map = x @ problem2.Psi
    blend = lam_rows * t_map + (1 - lam_rows) * mmv_centroids(problem2, CA[low])
    expected = np.where(lam_rows < 0.99, blend, t_map)
    np.testing.assert_allclose(est[low], expected, atol=1e-12)


def test_prior_with_noise_runs(problem, checker):
    est = fit_correction(problem, method="Prior", noise=0.005)
    rng = np.random.default_rng(0)
    C = problem.source_of(checker[:4]) + rng.normal(0, 0.005, (4, 3))
    assert np.isfinite(est(C)).all()


def test_centroid_inside_mmv(problem, checker):
    est = fit_correction(problem, method="Centroid")
    C = problem.source_of(checker[:3])
    for c, t in zip(C, est(C)):
        assert in_mmv(problem, c, t, tol=1e-4)


# -- images ----------------------------------------------------------------------------------------


def test_correct_image_matches_per_pixel_and_caches(problem, checker, tmp_path):
    est = fit_correction(problem, method="MAP")
    img = problem.source_of(checker[np.random.default_rng(0).integers(0, 24, (6, 7))])
    img[0, 0] = np.nan
    exact = correct_image(img, est, quantum=0)
    ref = est(img)
    assert np.allclose(exact, ref, equal_nan=True)
    cached = correct_image(img, est, cache_dir=tmp_path)
    assert len(list(tmp_path.glob("*.npz"))) == 1
    again = correct_image(img, est, cache_dir=tmp_path)
    assert np.allclose(cached, again, equal_nan=True)
    assert np.nanmax(problem.delta_E(cached, exact)) < 0.05
    with pytest.raises(SpectralDataError, match="3 stacked channels"):
        correct_image(np.zeros((2, 2, 4)), est)


def test_correct_one_call():
    xyz = correct(np.array([1.0, 1.0, 1.0]), "Nikon 5100 (NPL)", method="root-polynomial", shape=GRID)
    assert abs(xyz[1] - 1.0) < 0.05


def test_correct_image_transfer_on_shaded_image(problem, checker):
    est = fit_correction(problem, method="Prior")
    shade = np.linspace(0.5, 1.0, 10)[:, None, None] * np.linspace(0.8, 1.0, 8)[None, :, None]
    img = problem.source_of(checker[[0, 11]])[np.arange(10) % 2][:, None, :] * shade  # (10, 8, 3)
    fast = correct_image(img, est, quantum=0.02)
    exact = est(img)
    assert problem.delta_E(fast, exact).max() < 0.5
    rp = fit_correction(problem, method="Finlayson 2015")
    assert np.array_equal(correct_image(img, rp), rp(img))  # regressions: per pixel, no grouping


def test_projection_matches_polytope_project(problem, checker):
    """Twin: Lab-metric projection in reflectance space vs Polytope.project on the exact MMV."""
    from zonotope import mismatch

    C = problem.source_of(checker[[3, 14]])
    far = problem.target_of(checker[[3, 14]]) + np.array([0.04, -0.02, 0.03])
    ours, inside = project_to_mmv(problem, C, far)
    assert not inside.any()
    W = problem.lab_metric(far)
    for i in range(len(C)):
        mmv = mismatch.metamer_mismatch(problem.Phi, problem.Psi, C[i])
        ref = mmv.project(far[i], metric=W[i])
        assert problem.delta_E(ours[i], ref) < 0.02


# -- issue 14: closed-form fast paths, cross-validated regression, uncertainty, executor -------------


def test_interior_solution_is_the_bounded_solution(problem, checker):
    """Where the unconstrained MAP lies in [0, 1]ⁿ it equals the BVLS solution (independent solver)."""

    prior = ReflectancePrior.fit(problem.training)
    A, _ = atypical_reflectances(GRID, 12, seed=3)
    C = problem.source_of(np.vstack([checker, A]))
    x, interior = interior_solution(prior, problem.Phi, C)
    assert 0 < interior.sum() < len(C)  # both paths are exercised
    ref = fiber_lsq(problem.Phi, C, prior.root, prior.root @ prior.mean)
    np.testing.assert_allclose(x[interior], ref[interior], atol=1e-6)
    np.testing.assert_allclose(x[interior] @ problem.Phi, C[interior], atol=1e-12)
    np.testing.assert_allclose(map_reflectance(problem, C, prior), ref, atol=1e-6)  # both paths
    xn, _ = interior_solution(prior, problem.Phi, C, noise=0.01)  # relaxed: the Gaussian posterior mode
    P = prior.precision
    grad = P @ (xn[0] - prior.mean) + problem.Phi @ (xn[0] @ problem.Phi - C[0]) / 0.01**2
    assert np.abs(grad).max() < 1e-6 * np.abs(P @ (xn[0] - prior.mean)).max()


def test_projection_witness_rows_are_inside(problem2, checker):
    """Rows certified by a witness reflectance are returned unchanged and are inside (HiGHS LP)."""
    C = problem2.source_of(checker)
    t = fit_correction(problem2, method="Finlayson 2015")(C)
    far = t.copy()
    far[:3] += np.array([0.05, -0.03, 0.04])
    out, inside = project_to_mmv(problem2, C, far)
    assert inside[3:].all() and not inside[:3].any()
    np.testing.assert_array_equal(out[3:], far[3:])
    for i in (3, 10, 20):
        assert in_mmv(problem2, C[i], far[i])
    for i in range(3):
        assert in_mmv(problem2, C[i], out[i], tol=1e-4)


def test_regression_chosen_by_cross_validation_on_training_only(problem):
    from dataclasses import replace

    from zonotope.correct import select_regression

    reg, cv = select_regression(problem)
    assert set(cv["scores"]) == {"Cheung 2004", "Finlayson 2015"}
    best = min(cv["scores"], key=cv["scores"].get)
    assert reg.method == best and cv["errors"].size == problem.training.shape[0]
    assert np.isclose(cv["errors"].mean(), cv["scores"][best])
    np.testing.assert_allclose(reg.params["M"], fit_correction(problem, method=best).params["M"])
    # 3 cameras (9 channels: 45 root-polynomial terms) trained on 40 samples: only the matrix can be
    # cross-validated (the root-polynomial has more terms than any training fold), so it is chosen
    three = correction_problem(
        ["Nikon 5100 (NPL)", "Canon EOS 5D Mark II", "Sigma SDMerill (NPL)"], shape=GRID[:-2]
    )
    small = replace(three, training=three.training[:40])
    reg, cv = select_regression(small)
    assert reg.method == "Cheung 2004" and list(cv["scores"]) == ["Cheung 2004"]


def test_prior_uncertainty_and_documented_centroid_fraction(problem, problem2):
    """The docstring's fractions of centroid blends hold on the built-in natural sets; radii are
    credible radii of the same estimates, larger where the natural model does not explain the response."""
    from zonotope.evaluate import natural_test_sets, source_split

    sets, _ = source_split(natural_test_sets(GRID), problem.training)
    X = np.vstack([s.reflectances for s in sets])  # 42 spectra not in the training set
    for pb, documented, centroids in ((problem, 0.10, 0.03), (problem2, 0.03, 0.03)):
        est = fit_correction(pb, method="Prior")
        C = pb.source_of(X)
        w = est.params["weights"](C, map_reflectance(pb, C, est.params["prior"]))
        assert np.mean(w < 0.99) <= documented  # the gate leaves the regression alone
        rows = est.params["centroid_rows"](C)  # the centroid enters with a weight ≥ 1 %
        assert np.mean(rows) <= centroids and not (rows & (w >= 0.99)).any()
    est = fit_correction(problem2, method="Prior")
    A, _ = atypical_reflectances(GRID, 6, seed=5, kinds=["narrow-band"])
    C = problem2.source_of(np.vstack([X[:10], A]))
    E, r = est.with_uncertainty(C)
    np.testing.assert_allclose(E, est(C), atol=1e-12)
    assert np.isfinite(r).all() and (r > 0).all()
    assert np.median(r[10:]) > np.median(r[:10])  # atypical: the MMV's spread, not the regression's
    w = est.params["weights"](C, map_reflectance(problem2, C, est.params["prior"]))
    sure = w >= 0.99  # no MMV computed: the regression's cross-validated radius, scaled by √w
    assert sure[:10].sum() >= 8
    np.testing.assert_allclose(r[sure], np.sqrt(w[sure]) * est.params["r_nat"], rtol=1e-12)
    E2, r2 = est.with_uncertainty(np.full((2, 2, 6), np.nan))
    assert E2.shape == (2, 2, 3) and np.isnan(r2).all()
    with pytest.raises(SpectralDataError, match="no uncertainty model"):
        fit_correction(problem2, method="Finlayson 2015").with_uncertainty(C)


def test_centroids_with_an_executor_equal_serial(problem, checker):
    from concurrent.futures import ThreadPoolExecutor

    C = problem.source_of(checker[:6])
    serial = fit_correction(problem, method="Centroid")(C)
    with ThreadPoolExecutor(2) as pool:
        par = fit_correction(problem, method="Centroid", executor=pool)(C)
        par_prior = fit_correction(problem, method="Prior", executor=pool)(C)
    np.testing.assert_array_equal(par, serial)
    np.testing.assert_array_equal(par_prior, fit_correction(problem, method="Prior")(C))


def test_correct_image_noisy_closed_form_pixels_exact(problem2):
    """Noisy image: every pixel outside ``needs_solver`` is the exact per-pixel estimate; the grouped
    rest stays close to it."""
    from zonotope import spectra

    est = fit_correction(problem2, method="Prior", noise=0.003)
    pool = np.clip(spectra.resample(spectra.reflectances("BabelColor Average"), GRID).T, 0, 1)
    rng = np.random.default_rng(1)
    tiles = pool[rng.integers(0, len(pool), (4, 4))]
    img = np.repeat(np.repeat(tiles, 6, 0), 6, 1) @ problem2.Phi + rng.normal(0, 0.003, (24, 24, 6))
    out = correct_image(img, est, quantum=0.01)
    exact = est(img)
    slow = est.params["needs_solver"](img.reshape(-1, 6)).reshape(24, 24)
    assert 0 < slow.mean() < 0.5
    np.testing.assert_allclose(out[~slow], exact[~slow], atol=1e-9)
    assert problem2.delta_E(out[slow], exact[slow]).max() < 0.5


def test_leader_groups_against_brute_force():
    from zonotope.correct.image import _leader_groups

    rng = np.random.default_rng(4)
    P = np.vstack([rng.normal(c, 0.004, (60, 6)) for c in rng.uniform(0.1, 0.9, (5, 6))])
    first, label = _leader_groups(P, 0.01)
    assert (
        label.min() == 0
        and label.max() == first.size - 1
        and np.array_equal(label[first], np.arange(first.size))
    )
    assert np.all(np.abs(P - P[first][label]).max(axis=1) <= 0.01)  # every member near its leader
    lead = P[first]
    gap = np.abs(lead[:, None] - lead[None]).max(-1) + np.eye(first.size)
    assert gap.min() > 0.01  # no leader lies within the radius of another (it would have been taken)
    assert first.size < P.shape[0] / 4  # noise clouds are not cut into grid cells
    again, label2 = _leader_groups(P.copy(), 0.01)
    assert np.array_equal(again, first) and np.array_equal(label2, label)


def test_prior_config_checked_and_equal_to_keywords(problem, checker):
    """PriorConfig is checked when made; a config and the same keywords give the same estimator."""
    C = problem.source_of(checker)
    by_config = fit_correction(problem, method="Prior", config=PriorConfig(mix=0.5, odds=10.0))
    by_keywords = fit_correction(problem, method="Prior", mix=0.5, odds=10.0)
    np.testing.assert_array_equal(by_config(C), by_keywords(C))
    assert isinstance(by_keywords.params["config"], PriorConfig)
    assert by_keywords.params["mix"] == (0.5, 0.5) and by_keywords.params["mix_cv"] is None
    assert by_keywords.params["radius_scale"] == 1.0  # calibrated only together with λ
    assert fit_correction(problem, method="Prior", mix=(1.0, 0.25)).params["mix"] == (1.0, 0.25)
    for bad, match in (
        ({"odds": 0}, "odds"),
        ({"mix": 1.5}, "mix"),
        ({"mix": "sometimes"}, "mix"),
        ({"mix": (0.5, 1.2)}, "mix"),
        ({"mix": (0.5, 0.5, 0.5)}, "mix"),
        ({"folds": 1}, "folds"),
        ({"shrinkage": -0.1}, "shrinkage"),
        ({"noise": float("nan")}, "noise"),
    ):
        with pytest.raises(OptionError, match=match):
            PriorConfig(**bad)
    with pytest.raises(OptionError, match="unknown option"):
        fit_correction(problem, method="Prior", odd=10.0)


def test_sharpened_reflectances_are_steeper_versions_of_the_training_set(problem):
    from zonotope.spectra.atypical import sharpened_reflectances

    R = problem.training
    X = sharpened_reflectances(R, 200, seed=3)
    assert X.shape == (200, R.shape[1]) and X.min() >= 0 and X.max() <= 1
    np.testing.assert_array_equal(X, sharpened_reflectances(R, 200, seed=3))  # seeded
    steep = np.abs(np.diff(X, axis=1)).max(axis=1)
    assert np.median(steep) > 2 * np.median(np.abs(np.diff(R, axis=1)).max(axis=1))
    # further from the natural prior than the training spectra themselves
    prior = ReflectancePrior.fit(R)
    assert np.median(prior.energy(X)) > 10 * np.median(prior.energy(R))
    with pytest.raises(SpectralDataError, match="n must be"):
        sharpened_reflectances(R, -1)
    with pytest.raises(SpectralDataError, match="reflectances"):
        sharpened_reflectances(np.empty((0, 31)), 3)


def test_prior_closed_form_rows_equal_the_solver_path_with_noise(problem2, checker):
    """``closed_form`` (one vectorised pass) gives, on every row it does not flag, the estimate of the
    full solver path (``with_uncertainty`` solves every row: MAP, projection, centroid where needed)."""
    rng = np.random.default_rng(2)
    A, _ = atypical_reflectances(GRID, 8, seed=9)
    X = np.vstack([checker, A])
    C = problem2.source_of(X) + rng.normal(0.0, 0.003, (X.shape[0], problem2.k))
    for lam in (0.5, 1.0, (1.0, 0.3)):  # λ = 1: no centroid, the gated MAP blend is a closed form too
        est = fit_correction(problem2, method="Prior", noise=0.003, mix=lam)
        w = est.params["weights"](C, map_reflectance(problem2, C, est.params["prior"], noise=0.003))
        fast_est, slow = est.params["closed_form"](C)
        assert 0 < slow.sum() < slow.size
        full, _ = est.with_uncertainty(C)
        np.testing.assert_allclose(fast_est[~slow], full[~slow], atol=1e-12)
        np.testing.assert_allclose(est(C), full, atol=1e-12)
        # centroids are computed only where their weight (1 − w)(1 − λ) reaches 1 %
        rows = est.params["centroid_rows"](C)
        prior = est.params["prior"]
        x0, interior = interior_solution(prior, problem2.Phi, C, noise=0.003)
        x = map_reflectance(problem2, C, prior, noise=0.003)
        # posterior energies (prior + noise likelihood) of the bounded and the unbounded mode
        U, U0 = (prior.energy(z) + 0.5 * np.sum((z @ problem2.Phi - C) ** 2, -1) / 0.003**2 for z in (x, x0))
        assert (U >= U0 - 1e-9).all()  # the bounded mode cannot beat the unbounded one
        b = np.where(interior, 1.0, np.exp(-np.maximum(U - U0, 0.0)))
        lam_in, lam_bd = np.broadcast_to(lam, 2)
        lam_rows = b * lam_in + (1 - b) * lam_bd  # 1: λ_in (interior MAP), → λ_bd as the bounds cost more
        np.testing.assert_array_equal(rows, (w < 0.99) & ((1 - w) * (1 - lam_rows) >= 0.01))
        if lam == 1.0:
            assert not rows.any() and (~slow & (w < 0.99)).any()  # blended rows without a solver
