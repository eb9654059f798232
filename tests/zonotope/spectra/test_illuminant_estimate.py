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
    grey_card,
    grey_edge,
    grey_world,
    white_angle,
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


def test_per_camera_exposure_is_needed_when_the_raw_gains_differ(candidates):
    """Two cameras at raw gains 1 : 3 (real cameras share no raw scale): one shared exposure reads the
    gain ratio as a colour of the light; an exposure per camera recovers the light and both gains."""
    R = _scene(CAMS, candidates["FL11"], 1) * np.repeat([1.0, 3.0], 3)
    per = estimate_illuminant(R, CAMS, candidates=candidates, shape=GRID, exposures="per camera")
    assert per.name == "FL11"
    np.testing.assert_allclose(per.exposures[3] / per.exposures[0], 3.0, rtol=0.1)
    shared = estimate_illuminant(R, CAMS, candidates=candidates, shape=GRID)
    assert shared.scores.max() < per.scores.max()  # a model that cannot fit the gains fits worse
    with pytest.raises(SpectralDataError, match="per camera"):
        estimate_illuminant(R, CAMS, candidates=candidates, shape=GRID, exposures="each")


def test_bootstrap_uncertainty_grows_with_fewer_surfaces(candidates):
    """Resampling 53 surfaces leaves the choice fixed; 8 surfaces let it move (a non-zero angle), and
    the angle is one between candidates' whites (closed form: ≤ the largest such angle)."""
    many = estimate_illuminant(
        _scene(CAMS, candidates["LED-B3"], 2), CAMS, candidates=candidates, shape=GRID, bootstrap=20
    )
    assert many.agreement == 1.0 and many.angular_uncertainty == 0.0
    few = estimate_illuminant(
        _scene(CAMS[:1], candidates["Planckian 6500 K"], 3, n=8)
        + 0.02 * np.random.default_rng(4).random((8, 3)),
        CAMS[0],
        candidates=candidates,
        shape=GRID,
        bootstrap=40,
    )
    whites = {
        n: np.asarray(zonotope.generators(CAMS[0], c, GRID, normalise=None).values).sum(0)
        for n, c in candidates.items()
    }
    widest = max(white_angle(whites[few.name], w) for w in whites.values())
    assert few.agreement < 1.0 and 0 < few.angular_uncertainty <= widest
    assert np.isnan(
        estimate_illuminant(
            _scene(CAMS, candidates["FL2"], 0), CAMS, candidates=candidates, shape=GRID
        ).agreement
    )


@pytest.mark.parametrize("truth", ["Planckian 3000 K", "FL2", "LED-V1"])
def test_grey_card_recovers_the_light_from_one_surface(candidates, truth):
    """A flat card's raw response is the light's white (closed form); per-camera gains do not matter."""
    G = np.asarray(zonotope.generators(CAMS, candidates[truth], GRID, normalise=None).values)
    card = 0.3 * G.sum(0) * np.repeat([2.0, 0.5], 3)
    est = grey_card(card, CAMS, candidates=candidates, shape=GRID)
    assert est.name == truth and est.angular_uncertainty < 1e-6
    assert est.scores[est.names.index(truth)] == est.scores.max()
    # a coloured card: its spectrum is used (the same card called flat fits worse)
    red = np.where(GRID > 580, 0.8, 0.1)
    card = red @ G
    coloured = grey_card(card, CAMS, reflectance=red, candidates=candidates, shape=GRID)
    assert coloured.name == truth and coloured.angular_uncertainty < 1e-6
    assert grey_card(card, CAMS, candidates=candidates, shape=GRID).angular_uncertainty > 1
    with pytest.raises(SpectralDataError, match="positive"):
        grey_card(np.zeros(6), CAMS, candidates=candidates, shape=GRID)


def test_grey_edge_of_grey_surfaces_is_the_white():
    """Closed form: an image of grey surfaces is a scalar field times the light's white, and so is every
    Gaussian derivative of it; its edges point along the white whatever σ and p."""
    G = np.asarray(zonotope.generators(CAMS[0], "A", GRID, normalise=None).values)
    w = G.sum(axis=0)
    rng = np.random.default_rng(0)
    grey = np.kron(rng.uniform(0.05, 0.9, (6, 6)), np.ones((5, 5)))
    img = grey[..., None] * w
    for sigma, p in ((1.0, 1.0), (2.0, 6.0)):
        e = grey_edge(img, sigma=sigma, p=p)
        assert white_angle(e, w) < 1e-9
    # a uniform offset (a constant surface everywhere) has no edges and does not move the estimate
    np.testing.assert_allclose(grey_edge(img + 0.3 * w), grey_edge(img), rtol=1e-9)
    # grey-world is biased by a dominant coloured surface; the edges of grey surfaces are not
    coloured = img.copy()
    coloured[:10, :10] = np.array([0.9, 0.2, 0.1]) * w  # flat inside, edges only along its border
    assert white_angle(grey_edge(coloured), w) < white_angle(grey_world(coloured.reshape(-1, 3)), w)
    with pytest.raises(SpectralDataError, match="no edges"):
        grey_edge(np.ones((8, 8, 3)))
    with pytest.raises(SpectralDataError, match="H, W"):
        grey_edge(np.ones((8, 3)))
