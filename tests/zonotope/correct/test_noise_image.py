"""correct_image with a noise model: which noise is used, where it came from, and chunked correctors."""

from __future__ import annotations

import numpy as np
import pytest

from zonotope.correct import IMAGE_METHOD, NoiseModel, NoiseModelError, correction_problem, fit_correction
from zonotope.correct.image import correct_image

W = np.arange(400, 701, 10)
TWO = ["Nikon 5100 (NPL)", "Canon EOS 5D Mark II"]


@pytest.fixture(scope="module")
def problem2():
    return correction_problem(TWO, shape=W)


def _patch_image(problem, n=6, size=40, seed=0):
    """Flat patches of natural reflectances with smooth shading: responses and true targets."""
    from zonotope.evaluate import natural_test_sets

    X = np.concatenate([t.reflectances for t in natural_test_sets(W)])
    X = X[np.random.default_rng(seed).choice(X.shape[0], n * n, replace=False)]
    C, T = problem.source_of(X), problem.target_of(X)
    idx = np.repeat(np.repeat(np.arange(n * n).reshape(n, n), size, 0), size, 1)
    _, xx = np.mgrid[0 : n * size, 0 : n * size] / (n * size)
    shade = (0.75 + 0.25 * xx)[..., None]
    return C[idx] * shade, T[idx] * shade


def test_auto_noise_is_estimated_reported_and_used(problem2):
    img, T = _patch_image(problem2)
    truth = NoiseModel.shot_limited(0.005, problem2.k)
    noisy = truth.sample(img, np.random.default_rng(1))
    out, info = correct_image(noisy, problem2, method="root-polynomial", return_info=True)
    assert info["noise_source"] == "estimated from image" and info["noise_note"] == ""
    np.testing.assert_allclose(info["noise"].sigma(np.full(6, 0.5)), truth.sigma(np.full(6, 0.5)), rtol=0.15)
    naive = correct_image(noisy, problem2, method="root-polynomial", noise=None)
    told = correct_image(noisy, problem2, method="root-polynomial", noise=truth)
    dE = {
        name: problem2.delta_E(x, T).mean() for name, x in (("auto", out), ("naive", naive), ("told", told))
    }
    assert dE["auto"] < 0.8 * dE["naive"]
    assert abs(dE["auto"] - dE["told"]) < 0.05


def test_noise_free_when_the_image_cannot_say(problem2):
    out, info = correct_image(np.full((5, 6), 0.3), problem2, method="Cheung 2004", return_info=True)
    assert info["noise"] is None and info["noise_source"] == "none"
    assert "not estimated" in info["noise_note"]
    np.testing.assert_allclose(out, fit_correction(problem2, method="Cheung 2004")(np.full((5, 6), 0.3)))


def test_given_noise_and_bad_noise(problem2):
    img = np.full((4, 4, 6), 0.2)
    _, info = correct_image(img, problem2, method="Cheung 2004", noise=0.004, return_info=True)
    assert info["noise_source"] == "constant σ"
    np.testing.assert_allclose(info["noise"].sigma_white, 0.004)
    for bad in (-0.01, np.nan, [0.01, 0.01]):
        with pytest.raises(NoiseModelError):
            correct_image(img, problem2, method="Cheung 2004", noise=bad)


def test_a_corrector_reports_its_own_noise(problem2):
    m = NoiseModel.shot_limited(0.003, problem2.k)
    cor = fit_correction(problem2, method="root-polynomial", noise=m)
    _, info = correct_image(np.full((4, 4, 6), 0.2), cor, return_info=True)
    assert info["noise"] is m and info["noise_source"] == "corrector"


@pytest.mark.parametrize("method", ["Cheung 2004", "Finlayson 2015", "MAP"])
def test_chunked_correction_is_identical(problem2, method):
    """Batches of 17 rows give the batch-free answer to the last bits: a row's result must not depend on
    its batch, but BLAS may round a product of a 17-row block and a 301-row one differently (1 ulp seen
    for MAP on a 2-core runner), so the bound is a few ulps, not bit equality."""
    rng = np.random.default_rng(2)
    C = rng.uniform(0.02, 0.9, (301, 6))
    C[5] = np.nan
    cor = fit_correction(problem2, method=method)
    small = type(cor)(
        cor.method, cor.problem, cor.predict, cor.params, cor.predict_with_radius, batch_size=17
    )
    np.testing.assert_allclose(small(C), cor(C), rtol=4 * np.finfo(float).eps, atol=0)
    assert np.isnan(small(C)[5]).all()


def test_chunked_uncertainty_is_identical(problem2):
    from zonotope.evaluate import natural_test_sets

    X = np.concatenate([t.reflectances for t in natural_test_sets(W)])[:40]
    C = problem2.source_of(X)
    cor = fit_correction(problem2, method="Prior", mix=0.5)
    small = type(cor)(cor.method, cor.problem, cor.predict, cor.params, cor.predict_with_radius, batch_size=7)
    a, ra = cor.with_uncertainty(C)
    b, rb = small.with_uncertainty(C)
    np.testing.assert_allclose(a, b, rtol=1e-10, atol=1e-12)
    np.testing.assert_allclose(ra, rb, rtol=1e-10, atol=1e-12)


def test_float32_input_is_accepted_chunk_by_chunk(problem2):
    cor = fit_correction(problem2, method="Finlayson 2015")
    C = np.random.default_rng(3).uniform(0.02, 0.9, (1000, 6)).astype(np.float32)
    a, b = cor(C), cor(C.astype(np.float64))
    assert problem2.delta_E(a, b).max() < 0.01  # the float32 budget (measured 1.2e-3 noise-free)


@pytest.mark.parametrize("method", ["Finlayson 2015", "Guarded", "MAP", "Projection"])
def test_working_memory_does_not_grow_with_the_number_of_responses(problem2, method):
    """Beyond its input and output, a corrector's peak memory is that of one chunk."""
    import tracemalloc

    cor = fit_correction(problem2, method=method)
    cor = type(cor)(cor.method, cor.problem, cor.predict, cor.params, cor.predict_with_radius, batch_size=128)
    rng = np.random.default_rng(5)
    base = problem2.source_of(rng.uniform(0.05, 0.95, (64, W.size)) ** 2)  # physically possible responses

    def extra(n):
        C = base[rng.integers(0, base.shape[0], n)] * rng.uniform(0.9, 1.0, (n, 1))
        tracemalloc.start()
        start = tracemalloc.get_traced_memory()[0]
        out = cor(C)
        peak = tracemalloc.get_traced_memory()[1] - start - out.nbytes
        tracemalloc.stop()
        return peak

    small, large = extra(512), extra(4096)
    assert large < 1.5 * small + 2**20, (small, large)


def test_the_photo_default_is_the_registry_default_fitted_for_the_estimated_noise(problem2):
    img, _ = _patch_image(problem2)
    noisy = NoiseModel.shot_limited(0.005, problem2.k).sample(img, np.random.default_rng(4))
    out, info = correct_image(noisy, problem2, return_info=True)
    assert info["method"] == IMAGE_METHOD and info["noise_source"] == "estimated from image"
    want = fit_correction(problem2, method=IMAGE_METHOD, noise=info["noise"])(noisy)
    np.testing.assert_array_equal(out, want)


def test_correct_image_in_chunks_computes_each_colour_once_with_bounded_memory(problem2, monkeypatch):
    """Images beyond one chunk: same result as one chunk, each distinct colour solved once over all
    chunks, and working memory (beyond input and output) that does not grow with the pixel count."""
    import dataclasses
    import tracemalloc

    from zonotope.correct import image

    rng = np.random.default_rng(8)
    colours = problem2.source_of(rng.uniform(0.05, 0.95, (20, W.size)) ** 2)
    fitted = fit_correction(problem2, method="MAP")
    seen = []
    est = dataclasses.replace(fitted, predict=lambda c: seen.append(len(c)) or fitted.predict(c))

    def image_of(n):
        return colours[rng.integers(0, colours.shape[0], n)][:, None, :]

    img = image_of(3000)
    whole = correct_image(img, est, quantum=0)
    monkeypatch.setattr(image, "_PIXEL_CHUNK", 256)
    seen.clear()
    np.testing.assert_array_equal(correct_image(img, est, quantum=0), whole)
    assert sum(seen) == colours.shape[0]

    def extra(n):
        pixels = image_of(n)
        tracemalloc.start()
        start = tracemalloc.get_traced_memory()[0]
        out = correct_image(pixels, est, quantum=0)
        peak = tracemalloc.get_traced_memory()[1] - start - out.nbytes
        tracemalloc.stop()
        return peak

    small, large = extra(2048), extra(16384)
    assert large < 1.5 * small + 2**18, (small, large)
