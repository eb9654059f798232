"""The registry owns each method's noise facts: ``noise_options`` turns σ into options, and every
zonotope consumer (evaluation, the batch command, saved corrections) asks it, so that a newly
registered estimator gets its noise everywhere."""

from __future__ import annotations

import numpy as np
import pytest

from zonotope.correct import CORRECTION_METHODS, DELTA_SIGMAS, fit_Cheung2004, noise_options
from zonotope.utilities import MethodRegistry

GRID = np.arange(400.0, 701.0, 10.0)


@pytest.fixture
def dummy(monkeypatch):
    """A dummy estimator (a least-squares matrix that records its options) registered for this
    test only, with ``noise_option="noise"``; yields the list of option dicts it was fitted with."""
    calls: list[dict] = []

    def fit_Dummy(problem, **options):
        calls.append(dict(options))
        fitted = fit_Cheung2004(problem, noise=options.get("noise", 0.0))
        return type(fitted)("Dummy", problem, fitted.predict, {**fitted.params, **options})

    monkeypatch.setattr(CORRECTION_METHODS, "_methods", dict(CORRECTION_METHODS._methods))
    monkeypatch.setattr(CORRECTION_METHODS, "_keys", dict(CORRECTION_METHODS._keys))
    CORRECTION_METHODS.register(
        "Dummy", fit_Dummy, closed_form=True, needs_mmv=False, centroid=False, noise_option="noise"
    )
    return calls


def test_noise_options_follow_the_registry_entry():
    assert DELTA_SIGMAS == 3.0
    assert noise_options("least squares", 0.02) == {"noise": 0.02}
    assert noise_options("Centroid", 0.02) == {"delta": pytest.approx(DELTA_SIGMAS * 0.02)}
    assert noise_options("idt", 0.02) == {}
    assert noise_options("Prior", 0.0) == noise_options("Prior", None) == {}
    per_channel = noise_options("Centroid", [0.01, 0.02, 0.0])["delta"]
    np.testing.assert_allclose(per_channel, DELTA_SIGMAS * np.array([0.01, 0.02, 0.0]))
    for name in CORRECTION_METHODS:
        assert CORRECTION_METHODS.properties(name)["noise_option"] in ("noise", "delta", None)


@pytest.mark.parametrize("name", list(CORRECTION_METHODS))
def test_every_method_takes_one_sigma_per_channel(name):
    """σ per channel (a capture camera with estimated curves adds its band to the sensor noise) fits
    every registered estimator: "noise" estimators get it as a constant NoiseModel, the same fit as
    that model given directly; "delta" ones a tolerance per channel. Regressions, Guarded, Projection,
    MAP and Prior raised on the plain array before."""
    from zonotope.correct import NoiseModel, correction_problem, fit_correction

    problem = correction_problem(["Nikon 5100 (NPL)"], training="ColorChecker N Ohta", shape=GRID)
    sigma = np.array([0.012, 0.006, 0.009])
    opts = noise_options(name, sigma)
    extra = {"mix": 1.0} if name == "Prior" else {}
    c = np.array([[0.3, 0.4, 0.2], [0.05, 0.1, 0.6]])
    got = fit_correction(problem, method=name, **opts, **extra)(c)
    assert np.all(np.isfinite(got))
    if CORRECTION_METHODS.properties(name)["noise_option"] == "noise":
        model = NoiseModel.constant(sigma, 3)
        np.testing.assert_array_equal(got, fit_correction(problem, method=name, noise=model, **extra)(c))


def test_noise_options_reads_any_registry():
    registry = MethodRegistry("test")
    registry.register("a", lambda p: p, noise_option="delta")
    registry.register("b", lambda p: p, noise_option="sigma")
    assert noise_options("a", 0.1, registry=registry) == {"delta": pytest.approx(0.3)}
    with pytest.raises(ValueError, match="noise_option"):
        noise_options("b", 0.1, registry=registry)


def test_evaluate_passes_a_new_estimator_its_noise(dummy):
    from zonotope.evaluate import TestSet, evaluate, natural_test_sets

    sets = [TestSet("cc", natural_test_sets(GRID)[0].reflectances[:5])]
    evaluate(["Nikon 5100 (NPL)"], methods=["Dummy"], shape=GRID, test_sets=sets, noise=0.004)
    assert dummy and all(call.get("noise") == 0.004 for call in dummy)


def test_batch_command_passes_a_new_estimator_its_noise(dummy, tmp_path):
    import tifffile

    from zonotope.cli import main

    images = tmp_path / "in"
    images.mkdir()
    tifffile.imwrite(images / "a.tif", np.full((3, 4, 3), 0.3, np.float32), photometric="rgb")
    argv = ["correct", str(images), "-o", str(tmp_path / "out"), "--camera", "Nikon 5100 (NPL)"]
    argv += ["--method", "Dummy", "--noise", "0.004", "--scheduler", "serial", "--quiet"]
    assert main(argv) == 0
    assert dummy and all(call.get("noise") == 0.004 for call in dummy)


def test_saved_correction_refits_a_new_estimator_with_its_noise(dummy, tmp_path):
    from zonotope.correct import correction_problem, fit_correction, load_correction, save_correction

    problem = correction_problem("Nikon 5100 (NPL)", shape=GRID)
    fitted = fit_correction(problem, method="Dummy", **noise_options("Dummy", 0.004))
    path = save_correction(tmp_path / "dummy.npz", fitted)
    dummy.clear()
    again = load_correction(path)
    assert dummy == [{"noise": 0.004}]
    c = np.array([[0.2, 0.3, 0.25]])
    np.testing.assert_allclose(again(c), fitted(c))
