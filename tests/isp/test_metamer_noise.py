"""isp.metamer: the noise model of the metamer stage's responses, from a simulated DNG whose noise is known.

Independent truth: :class:`isp.simulate.SensorConfig` sets the shot and read noise of the raw signal,
``Capture.noise_profile`` states it as DNG ``(S, O)`` pairs, and the white-balanced, exposure-divided
response the stage sees has ``var = (S·x + O)·g²/w²`` with ``x = c·w/g`` (gains ``g = max(n)/n``).
"""

from __future__ import annotations

import inspect

import numpy as np
import pytest

import isp
import zonotope
from isp.metamer import MetamerConfig, metamer_noise, photograph_method
from isp.profiles.fitting import ProfileConfig
from isp.simulate import chart_image, simulate_capture, simulate_dng, spectral_setup
from zonotope.correct import NoiseModel, correct_image

CAMERA = "Nikon 5100 (NPL)"


@pytest.fixture(scope="module")
def capture():
    """A noisy 148 × 220 ColorChecker (enough flat 8 × 8 tiles in each 74 × 110 colour plane)."""
    setup = spectral_setup(CAMERA, illuminant="D65")
    R = zonotope.resample(zonotope.reflectances("ColorChecker N Ohta"), setup.wavelengths).T
    image, _ = chart_image(R, rows=4, cols=6, patch=32, gap=4)
    return simulate_capture(image, setup, full_well=3000.0, read_noise=4.0)


def _truth(cap, white_level: float) -> NoiseModel:
    g = cap.neutral.max() / cap.neutral
    S, O = cap.noise_profile[:, 0], cap.noise_profile[:, 1]
    return NoiseModel(S * g / white_level, O * g**2 / white_level**2)


@pytest.mark.parametrize("white_level", [1.0, 0.8])
def test_noise_profile_carried_through_white_balance(capture, tmp_path, white_level):
    path = simulate_dng(tmp_path / "np.dng", capture, noise_profile=capture.noise_profile)
    model, note = metamer_noise(isp.read_raw(path), white_level=white_level)
    assert note == "" and model.source == "DNG NoiseProfile"
    truth = _truth(capture, white_level)
    np.testing.assert_allclose(model.shot, truth.shot, rtol=1e-5)  # AsShotNeutral is stored as rationals
    np.testing.assert_allclose(model.read, truth.read, rtol=1e-5)


def test_without_profile_the_mosaic_estimate_is_near_the_truth(capture, tmp_path):
    path = simulate_dng(tmp_path / "plain.dng", capture)
    model, note = metamer_noise(isp.read_raw(path), white_level=capture.exposure)
    assert model.source == "estimated from image" and note == ""
    ratio = model.sigma_white / _truth(capture, capture.exposure).sigma_white
    assert np.all((ratio > 0.8) & (ratio < 1.35)), ratio  # chart edges add a little variance


def test_implausible_profile_reported_and_ignored(capture, tmp_path):
    path = simulate_dng(tmp_path / "bad.dng", capture, noise_profile=[1.0, 0.5])
    model, note = metamer_noise(isp.read_raw(path))
    assert "NoiseProfile ignored" in note and "not a plausible noise model" in note
    assert model is not None and model.source == "estimated from image"


def test_given_noise_is_used_as_it_is(capture, tmp_path):
    raw = isp.read_raw(simulate_dng(tmp_path / "np.dng", capture, noise_profile=capture.noise_profile))
    model, note = metamer_noise(raw, noise=0.01)
    np.testing.assert_allclose(model.sigma_white, 0.01)
    assert note == ""
    assert metamer_noise(raw, noise=0) == (None, "")
    with pytest.raises(zonotope.correct.NoiseModelError):
        metamer_noise(raw, noise=-1.0)


def test_the_fit_is_told_the_noise():
    model = NoiseModel([2e-5] * 3, [1e-7] * 3, "test")
    m = isp.metamer_correction(CAMERA, method="root-polynomial", noise=model)
    assert m.noise is model and m.corrector.params["noise"] is model
    assert "test" in m.describe_noise()
    free = isp.metamer_correction(CAMERA, method="root-polynomial")
    assert free.noise is None and not np.allclose(free.corrector.params["M"], m.corrector.params["M"])


def test_noise_belongs_in_the_config_not_in_estimator_options():
    with pytest.raises(isp.PipelineError, match=r"noise are fields of MetamerConfig.*MetamerConfig.noise"):
        MetamerConfig(estimator_options={"noise": 0.01})
    with pytest.raises(isp.PipelineError, match=r"MetamerConfig.noise"):
        MetamerConfig(noise=float("nan"))
    with pytest.raises(isp.PipelineError, match=r"ProfileConfig.noise"):
        ProfileConfig(noise=[0.1, 0.2])


def test_default_estimator_is_zonotopes_photograph_default():
    assert photograph_method() == inspect.signature(correct_image).parameters["method"].default
    assert MetamerConfig().method is None
