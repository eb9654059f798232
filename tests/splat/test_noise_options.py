"""The capture asks the correction registry how to tell an estimator its noise: a newly registered
estimator gets σ = δ / DELTA_SIGMAS from the plain and the fused correction alike."""

from __future__ import annotations

import numpy as np
import pytest

from zonotope.correct import CORRECTION_METHODS, DELTA_SIGMAS, fit_Cheung2004

from .capture_helpers import write_capture


@pytest.fixture
def dummy(monkeypatch):
    """A dummy estimator (a least-squares matrix that records its options), registered for this test
    only with ``noise_option="noise"``; yields the list of option dicts it was fitted with."""
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


def test_the_capture_passes_a_new_estimator_its_noise(dummy, tmp_path):
    from splat.capture import (
        WHITE_POINT,
        PipelineConfig,
        check_run,
        fit_corrector,
        fused_fitter,
        read_capture,
    )

    write_capture(tmp_path / "cap", views=1, holdout=0, colmap=False)
    spec = read_capture(tmp_path / "cap")
    check_run(spec, PipelineConfig(method="dummy"))  # a registered name is a valid --method
    fit_corrector(spec, [0, 1, 2], "Dummy", 0.03)
    assert dummy[-1] == {"noise": pytest.approx(0.03 / DELTA_SIGMAS), "white_point": WHITE_POINT}
    fit = fused_fitter(spec, [0, 1, 2], "Dummy")
    _, scale = fit(np.array([0.01, 0.02, 0.04, 0.01, 0.01, 0.02, 0.03, 0.05, 0.01]))
    assert dummy[-1] == {
        "noise": pytest.approx(0.02),
        "white_point": WHITE_POINT,
    }  # σ_ref: the median channel, the others whitened
    assert scale == pytest.approx(0.02 / np.array([0.01, 0.02, 0.04, 0.01, 0.01, 0.02, 0.03, 0.05, 0.01]))


def test_published_curves_of_stacked_cameras_carry_the_spread_between_units(dummy, tmp_path):
    """Without ``ssf_exact``, each camera's measured curves are taken as another unit's: the fit of the
    stack is told SSF_UNIT_SIGMA per channel in quadrature with the sensor noise; one camera alone is not."""
    from splat.capture import fit_corrector, read_capture
    from zonotope._tol import SSF_UNIT_SIGMA

    write_capture(tmp_path / "cap", views=1, holdout=0, colmap=False, ssf_exact=False)
    spec = read_capture(tmp_path / "cap")
    assert not any(c.ssf_exact for c in spec.cameras)
    fit_corrector(spec, [0, 1, 2], "Dummy", 0.03)
    told = dummy[-1]["noise"]
    want = np.hypot(0.03 / DELTA_SIGMAS, np.tile(SSF_UNIT_SIGMA, 3))
    np.testing.assert_allclose(np.sqrt(told.read), want)
    fit_corrector(spec, [1], "Dummy", 0.03)
    assert dummy[-1]["noise"] == pytest.approx(0.03 / DELTA_SIGMAS)


@pytest.mark.parametrize(
    ("line", "ssf", "message"),
    [
        ('ssf_exact = "yes"', None, r"ssf_exact = 'yes' must be true or false"),
        ("ssf_exact = true", "estimate", r'not for ssf = "estimate"'),
    ],
)
def test_ssf_exact_is_checked_when_the_capture_is_read(tmp_path, line, ssf, message):
    from splat.capture import CaptureError, read_capture

    write_capture(tmp_path / "cap", views=1, holdout=0, colmap=False, ssf_exact=False)
    toml = tmp_path / "cap" / "capture.toml"
    text = toml.read_text().replace('ssf = "Nikon 5100 (NPL)"', f'ssf = "Nikon 5100 (NPL)"\n{line}')
    if ssf is not None:
        text = text.replace('ssf = "Nikon 5100 (NPL)"', f'ssf = "{ssf}"')
    toml.write_text(text)
    with pytest.raises(CaptureError, match=message):
        read_capture(tmp_path / "cap")
