"""Noise models and the noise-aware regressions, against independent truth (Monte Carlo, simulation)."""

from __future__ import annotations

import numpy as np
import pytest

from zonotope.correct import (
    NoiseModel,
    NoiseModelError,
    correction_problem,
    estimate_noise,
    expected_normal_equations,
    fit_correction,
    noise_model,
    root_polynomial_terms,
)

W = np.arange(400, 701, 10)
TWO = ["Nikon 5100 (NPL)", "Canon EOS 5D Mark II"]


@pytest.fixture(scope="module")
def problem2():
    return correction_problem(TWO, shape=W)


# --- the model -------------------------------------------------------------------------------------


def test_variance_is_shot_times_signal_plus_read():
    m = NoiseModel([1e-4, 2e-4, 3e-4], [1e-6, 0.0, 4e-6])
    c = np.array([[0.5, 0.2, 1.0], [-0.1, 0.0, 0.3]])
    np.testing.assert_allclose(
        m.variance(c), [[0.5e-4 + 1e-6, 0.4e-4, 3e-4 + 4e-6], [1e-6, 0.0, 0.9e-4 + 4e-6]]
    )
    np.testing.assert_allclose(m.sigma_white, np.sqrt([1e-4 + 1e-6, 2e-4, 3e-4 + 4e-6]))


def test_sample_has_the_model_variance():
    m = NoiseModel.shot_limited(0.01, 3, read=1e-6)
    c = np.tile([0.2, 0.5, 0.9], (200_000, 1))
    d = m.sample(c, np.random.default_rng(0)) - c
    np.testing.assert_allclose(d.var(axis=0), m.variance(c[0]), rtol=0.02)


@pytest.mark.parametrize(
    "shot, read",
    [
        ([-1e-4, 0, 0], [0, 0, 0]),
        ([np.nan, 0, 0], [0, 0, 0]),
        ([0, 0, 0], [0, np.inf, 0]),
        ([1, 2], [1, 2, 3]),
    ],
    ids=["negative", "nan", "inf", "channels"],
)
def test_bad_models_are_one_line_errors(shot, read):
    with pytest.raises(NoiseModelError) as e:
        NoiseModel(shot, read)
    assert "\n" not in str(e.value)


def test_wrong_channel_count_for_the_problem_is_an_error(problem2):
    with pytest.raises(NoiseModelError, match="3 channels; the responses have 6"):
        fit_correction(problem2, method="Cheung 2004", noise=NoiseModel.shot_limited(0.01, 3))
    with pytest.raises(NoiseModelError):
        noise_model([0.01] * 4, 6)
    with pytest.raises(NoiseModelError):
        noise_model(-0.01, 6)
    with pytest.raises(NoiseModelError):
        noise_model("loud", 6)


def test_coercion():
    assert noise_model(None, 3) is None and noise_model(0.0, 3) is None
    m = noise_model(0.01, 3)
    np.testing.assert_allclose(m.read, 1e-4) and np.testing.assert_allclose(m.shot, 0)
    m = noise_model({"shot": 1e-4, "read": 1e-6}, 3)
    assert m.k == 3 and m.source == "given"
    assert noise_model(NoiseModel([1e-4], [0.0]), 3).k == 3


def test_from_noise_profile_matches_simulated_raw_noise():
    """The DNG (S, O) model of the raw signal, carried through white balance, predicts the variance of
    white-balanced responses simulated from raw noise."""
    S, O = np.array([2e-4, 1e-4, 3e-4]), np.array([4e-6, 2e-6, 5e-6])
    white = np.array([0.45, 0.8, 0.6])  # raw level of the perfect white per channel
    m = NoiseModel.from_noise_profile(np.stack([S, O], axis=1), white=white)
    rng = np.random.default_rng(1)
    c = np.array([0.3, 0.6, 0.9])
    x = c * white
    raw = x + rng.standard_normal((200_000, 3)) * np.sqrt(S * x + O)
    np.testing.assert_allclose((raw / white).var(axis=0), m.variance(c), rtol=0.02)
    assert m.source == "DNG NoiseProfile"


def test_implausible_profile_is_an_error():
    with pytest.raises(NoiseModelError, match="not a plausible"):
        NoiseModel.from_noise_profile([0.5, 0.1], k=3)
    with pytest.raises(NoiseModelError):
        NoiseModel.from_noise_profile([[1e-4, 0], [1e-4, 0]], k=3)


def test_estimate_noise_recovers_a_simulated_model():
    """Flat patches with smooth shading and some texture, noise from a known shot + read model."""
    rng = np.random.default_rng(3)
    H, W_ = 256, 384
    yy, xx = np.mgrid[0:H, 0:W_] / max(H, W_)
    base = np.zeros((H, W_, 3))
    for i in range(0, H, 64):
        for j in range(0, W_, 64):
            base[i : i + 64, j : j + 64] = rng.uniform(0.05, 0.9, 3)
    img = base * (0.7 + 0.3 * xx[..., None]) * (0.9 + 0.1 * yy[..., None])  # smooth shading
    img[:64, :128] += 0.05 * np.sin(xx[:64, :128, None] * 300)  # a textured corner
    truth = NoiseModel([2e-5, 1e-5, 4e-5], [1e-6, 2e-6, 5e-7])
    noisy_img = truth.sample(img, rng)
    est = estimate_noise(noisy_img)
    assert est.source == "estimated from image"
    for c in (0.1, 0.5, 0.9):
        np.testing.assert_allclose(est.sigma(np.full(3, c)), truth.sigma(np.full(3, c)), rtol=0.12)


def test_estimate_noise_needs_an_image():
    with pytest.raises(NoiseModelError):
        estimate_noise(np.zeros((10, 3)))
    with pytest.raises(NoiseModelError):
        estimate_noise(np.zeros((8, 8, 3)))


# --- noise-aware regressions ---------------------------------------------------------------------------


@pytest.mark.parametrize("degree", [1, 2])
def test_expected_normal_equations_are_the_limit_of_noisy_replicas(problem2, degree):
    """The closed form equals the normal equations of many noisy replicas (Monte Carlo) up to its error."""
    C, T = problem2.source_of(problem2.training), problem2.target_of(problem2.training)
    m = NoiseModel.shot_limited(0.01, problem2.k, read=1e-5)
    G, B = expected_normal_equations(C, T, m, degree=degree)
    rng = np.random.default_rng(0)
    reps = 400
    Cn = np.concatenate([m.sample(C, rng) for _ in range(reps)])
    A = Cn if degree == 1 else root_polynomial_terms(Cn, degree=degree)
    np.testing.assert_allclose(A.T @ A / reps, G, rtol=0.01, atol=1e-3 * np.abs(G).max())
    np.testing.assert_allclose(A.T @ np.tile(T, (reps, 1)) / reps, B, rtol=0.01, atol=1e-3 * np.abs(B).max())


def test_expected_normal_equations_without_noise_are_the_plain_ones(problem2):
    C, T = problem2.source_of(problem2.training), problem2.target_of(problem2.training)
    G, B = expected_normal_equations(C, T, NoiseModel(np.zeros(6), np.zeros(6)), degree=2)
    A = root_polynomial_terms(C)
    np.testing.assert_allclose(G, A.T @ A, rtol=1e-12)
    np.testing.assert_allclose(B, A.T @ T, rtol=1e-12)


@pytest.mark.parametrize("method", ["Cheung 2004", "Finlayson 2015"])
def test_noise_aware_regression_beats_the_naive_one_on_noisy_held_out_responses(problem2, method):
    """Two stacked cameras, shot noise σ = 0.005 at white, natural test spectra not in training."""
    from zonotope.evaluate import natural_test_sets, source_split

    X = np.concatenate([t.reflectances for t in source_split(natural_test_sets(W), problem2.training)[0]])
    m = NoiseModel.shot_limited(0.005, problem2.k)
    C = m.sample(problem2.source_of(X), np.random.default_rng(7))
    T = problem2.target_of(X)
    naive = problem2.delta_E(fit_correction(problem2, method=method)(C), T).mean()
    aware = problem2.delta_E(fit_correction(problem2, method=method, noise=m)(C), T).mean()
    assert aware < 0.8 * naive


def test_zero_noise_model_is_the_noise_free_fit(problem2):
    zero = NoiseModel(np.zeros(6), np.zeros(6))
    a = fit_correction(problem2, method="root-polynomial", noise=zero).params["M"]
    np.testing.assert_array_equal(a, fit_correction(problem2, method="root-polynomial").params["M"])


def test_two_unknown_nnls_matches_scipy():
    from scipy.optimize import nnls

    from zonotope.correct.noise import _nnls2

    rng = np.random.default_rng(4)
    for _ in range(200):
        A = np.abs(rng.normal(size=(8, 2)))
        b = rng.normal(size=8)
        np.testing.assert_allclose(_nnls2(A, b), nnls(A, b)[0], atol=1e-10)


def test_noise_options_take_a_noise_model():
    from zonotope.correct import DELTA_SIGMAS, noise_options

    m = NoiseModel([1e-4, 4e-4, 0.0], [0.0, 0.0, 1e-6])
    assert noise_options("Prior", m) == {"noise": m}
    assert noise_options("root-polynomial", m)["noise"] is m
    np.testing.assert_allclose(noise_options("Centroid", m)["delta"], DELTA_SIGMAS * m.sigma_white)
    assert noise_options("idt", m) == {}
    assert noise_options("Prior", NoiseModel(np.zeros(3), np.zeros(3))) == {}


def test_a_file_profile_that_cannot_be_used_is_reported_and_ignored():
    from zonotope.correct import noise_from_profile

    model, note = noise_from_profile([[2e-4, 1e-6]] * 3, white=[0.5, 0.8, 0.6], k=3)
    assert model is not None and note == "" and model.source == "DNG NoiseProfile"
    for bad, why in (
        (None, "no NoiseProfile"),
        ([0.9, 0.1], "not a plausible"),
        ([[1e-4, 0]] * 2, "pairs"),
        ([-1e-4, 0.0], "≥ 0"),
    ):
        model, note = noise_from_profile(bad, k=3)
        assert model is None and why in note and "\n" not in note
