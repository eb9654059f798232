"""The guarded regression (default of correct_image): the criterion it was chosen by, on spectra it
was never fitted on, and its contract."""

from __future__ import annotations

import inspect

import numpy as np
import pytest

from zonotope import OptionError
from zonotope.correct import (
    CORRECTION_METHODS,
    IMAGE_METHOD,
    NoiseModel,
    correct_image,
    correction_problem,
    fit_correction,
)
from zonotope.evaluate import atypical_test_sets, natural_test_sets, source_split

W = np.arange(400, 701, 10)
ONE = ["Nikon 5100 (NPL)"]
TWO = ["Nikon 5100 (NPL)", "Canon EOS 5D Mark II"]


@pytest.fixture(scope="module")
def problem2():
    return correction_problem(TWO, shape=W)


def _held_out(problem, kind, data_dir=None):
    sets = natural_test_sets(W, data_dir=data_dir) if kind == "natural" else atypical_test_sets(W, 100)
    sets = source_split(sets, problem.training)[0]
    return np.concatenate([t.reflectances for t in sets])


@pytest.mark.parametrize("sigma", [0.0, 0.005])
def test_two_cameras_beat_every_regression_on_atypical_and_tie_root_poly_on_natural(
    problem2, sigma, shared_data
):
    """The selection criterion on the held-out sets of ``zonotope evaluate`` (natural: built-ins and
    subsets of the shared data; atypical: generators A and B), none of them fitted on."""
    model = NoiseModel.shot_limited(sigma, problem2.k)
    rng = np.random.default_rng(5)
    guarded = fit_correction(problem2, method="Guarded", noise=model)
    assert guarded.params["guard"]
    regs = {
        name: fit_correction(problem2, method=name, **opts)
        for name, opts in [
            ("Cheung 2004", {}),
            ("Finlayson 2015", {}),
            ("Cheung 2004", {"noise": model}),
            ("Finlayson 2015", {"noise": model}),
        ]
    }
    for kind in ("atypical", "natural"):
        X = _held_out(problem2, kind, shared_data)
        C, T = model.sample(problem2.source_of(X), rng), problem2.target_of(X)
        mean = {name: float(np.mean(problem2.delta_E(est(C), T))) for name, est in regs.items()}
        ours = float(np.mean(problem2.delta_E(guarded(C), T)))
        if kind == "atypical":
            assert ours < min(mean.values()), (ours, mean)
        else:
            assert ours <= mean["Finlayson 2015"] + 0.03, (ours, mean)


def test_one_camera_is_the_noise_aware_root_polynomial():
    problem = correction_problem(ONE, shape=W)
    model = NoiseModel.shot_limited(0.005, problem.k)
    guarded = fit_correction(problem, method="Guarded", noise=model)
    root = fit_correction(problem, method="Finlayson 2015", noise=model)
    C = problem.source_of(_held_out(problem, "atypical"))
    assert not guarded.params["guard"]
    np.testing.assert_array_equal(guarded(C), root(C))


def test_fallback_rows_are_the_widened_matrix_and_the_others_the_root_polynomial(problem2):
    guarded = fit_correction(problem2, method="Guarded")
    C = problem2.source_of(_held_out(problem2, "atypical"))
    out = guarded(C)
    root, wide = guarded.params["root"](C), C @ guarded.params["fallback"].params["M"]
    is_root = np.all(np.isclose(out, root, rtol=0, atol=1e-12), axis=1)
    is_wide = np.all(np.isclose(out, wide, rtol=0, atol=1e-12), axis=1)
    assert np.all(is_root | is_wide)
    assert 0 < np.count_nonzero(is_wide & ~is_root) < C.shape[0]
    # at most about 1 − quantile of the (noise-free) training responses leave the root-polynomial
    Ct = problem2.source_of(problem2.training)
    moved = ~np.all(np.isclose(guarded(Ct), guarded.params["root"](Ct), rtol=0, atol=1e-12), axis=1)
    assert np.mean(moved) <= 0.06


def test_float32_photos_stay_float32_within_a_hundredth(problem2):
    guarded = fit_correction(problem2, method="Guarded", noise=0.005)
    C = problem2.source_of(_held_out(problem2, "natural"))
    out32 = guarded.predict(C.astype(np.float32))  # a chunk as Corrector hands it over
    assert out32.dtype == np.float32
    dE = problem2.delta_E(out32.astype(np.float64), guarded(C))
    assert np.percentile(dE, 99) <= 0.01


def test_the_image_default_is_read_from_the_registry():
    assert CORRECTION_METHODS.names(image_default=True) == (IMAGE_METHOD,) == ("Guarded",)
    assert inspect.signature(correct_image).parameters["method"].default == IMAGE_METHOD
    img = np.full((2, 3, 6), 0.3)
    _, info = correct_image(img, TWO, shape=W, noise=0.002, return_info=True)
    assert info["method"] == IMAGE_METHOD


@pytest.mark.parametrize(
    "options", [{"quantile": 0.0}, {"quantile": 1.5}, {"augment": 0}, {"replicas": 2.5}, {"guard": "yes"}]
)
def test_bad_options_are_one_line_errors(problem2, options):
    with pytest.raises(OptionError) as e:
        fit_correction(problem2, method="Guarded", **options)
    assert "\n" not in str(e.value) and next(iter(options)) in str(e.value)
