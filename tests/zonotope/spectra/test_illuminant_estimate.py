"""Choosing the scene light among candidates: recovery of a known light from simulated responses,
closed forms for the baselines, and bad input."""

from __future__ import annotations

import numpy as np
import pytest

import zonotope
from zonotope._errors import SpectralDataError
from zonotope.spectra.illuminant_estimate import (
    candidate_illuminants,
    estimate_illuminant,
    grey_world,
    white_patch,
)

GRID = np.arange(400.0, 701.0, 20.0)
CAMS = ["Nikon 5100 (NPL)", "Canon EOS 5D Mark II"]


@pytest.fixture(scope="module")
def candidates():
    c = candidate_illuminants(["planckian", "fluorescent", "led"])
    return {k: c[k] for k in ("Planckian 3000 K", "Planckian 6500 K", "FL2", "FL11", "LED-B3", "LED-V1")}


def _scene(cams, light, seed, n=60):
    """Raw responses of natural surfaces (CIE TCS + ColorChecker, not the prior's training set)."""
    X = np.concatenate(
        [
            zonotope.resample(zonotope.reflectances(name), GRID).T
            for name in ("ColorChecker N Ohta", "CIE 1995 TCS", "NIST CQS 9.0")
        ]
    )
    X = np.clip(X, 0, 1)[np.random.default_rng(seed).choice(53, size=min(n, 53), replace=False)]
    G = np.asarray(zonotope.generators(cams, light, GRID, normalise=None).values)
    return 0.6 * X @ (G / G.sum(axis=0).mean())


@pytest.mark.parametrize("truth", ["Planckian 3000 K", "FL11", "LED-B3"])
def test_recovers_the_light_with_two_cameras(candidates, truth):
    est = estimate_illuminant(_scene(CAMS, candidates[truth], 0), CAMS, candidates=candidates, shape=GRID)
    assert est.name == truth
    assert est.scores[est.names.index(truth)] == est.scores.max()
    assert est.exposure == pytest.approx(0.6, rel=0.35)  # the exposure is found along with the light
    np.testing.assert_allclose(est.white.mean(), 1.0)


def test_grey_world_of_a_grey_scene_is_the_white():
    """Closed form: for grey surfaces every response is a multiple of the light's white."""
    G = np.asarray(zonotope.generators(CAMS[0], "A", GRID, normalise=None).values)
    R = np.linspace(0.1, 0.9, 7)[:, None] * G.sum(axis=0)
    w = G.sum(axis=0)
    np.testing.assert_allclose(grey_world(R) / w, np.full(3, 0.5), rtol=1e-12)
    np.testing.assert_allclose(white_patch(R) / w, np.full(3, 0.9), rtol=1e-12)


def test_candidate_families():
    every = candidate_illuminants()
    assert {"FL2", "FL11", "LED-B3", "daylight 6500 K", "Planckian 2500 K"} <= set(every)
    assert len(candidate_illuminants("led")) == 9
    with pytest.raises(SpectralDataError, match="daylight, planckian"):
        candidate_illuminants("sodium")


def test_bad_responses(candidates):
    with pytest.raises(SpectralDataError, match=r"\(N, 6\)"):
        estimate_illuminant(np.ones((20, 3)), CAMS, candidates=candidates, shape=GRID)
    with pytest.raises(SpectralDataError, match="more than 6"):
        estimate_illuminant(np.ones((4, 6)), CAMS, candidates=candidates, shape=GRID)
    R = np.ones((20, 6))
    R[3, 2] = np.nan
    with pytest.raises(SpectralDataError, match="finite"):
        estimate_illuminant(R, CAMS, candidates=candidates, shape=GRID)
