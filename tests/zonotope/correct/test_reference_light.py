"""Correction to a reference light: ``correction_problem(illuminant=scene, reference=light)``.

Truth: colour-science's own tristimulus integration (``colour.msds_to_XYZ``) for the targets, a
least-squares theorem against matrix + von Kries / CAT pipelines, and the illuminant-induced MMV for
the MMV-based estimators."""

from __future__ import annotations

import colour
import numpy as np
import pytest

from zonotope import spectra
from zonotope.correct import CORRECTION_METHODS, correction_problem, fit_correction
from zonotope.mismatch import MetamerMismatch

G20 = np.arange(400.0, 701.0, 20.0)
CAM = "Nikon 5100 (NPL)"


@pytest.fixture(scope="module")
def tungsten_to_daylight():
    return correction_problem(CAM, illuminant="A", reference="D65", shape=G20)


@pytest.fixture(scope="module")
def checker():
    return np.clip(spectra.resample(spectra.reflectances("ColorChecker N Ohta"), G20).T, 0, 1)


def _colour_XYZ(R, light):
    """XYZ (Y_white = 1) of reflectances under ``light`` by colour-science's integration."""
    shape = colour.SpectralShape(G20[0], G20[-1], G20[1] - G20[0])
    cmfs = colour.MSDS_CMFS["CIE 2015 2 Degree Standard Observer"].copy().align(shape)
    sd = colour.SDS_ILLUMINANTS[light].copy().align(shape)
    msds = colour.MultiSpectralDistributions(R.T, G20, labels=[str(i) for i in range(len(R))])
    white = colour.sd_to_XYZ(
        colour.SpectralDistribution(np.ones(G20.size), G20), cmfs, sd, method="Integration"
    )
    return colour.msds_to_XYZ(msds, cmfs, sd, method="Integration", shape=shape) / white[1]


def test_targets_are_the_observer_under_the_reference(tungsten_to_daylight, checker):
    p = tungsten_to_daylight
    np.testing.assert_allclose(p.target_of(checker), _colour_XYZ(checker, "D65"), rtol=2e-3, atol=2e-4)
    np.testing.assert_allclose(p.Phi, spectra.generators(CAM, "A", G20).values, atol=1e-15)
    assert p.illuminant == "A" and p.target_illuminant == "D65"
    # Lab is relative to the reference white: the white itself is L* = 100, a* = b* = 0
    np.testing.assert_allclose(p.to_Lab(p.Psi.sum(axis=0)), [100, 0, 0], atol=1e-9)


def test_no_reference_is_the_scene_light():
    a = correction_problem(CAM, illuminant="FL11", shape=G20)
    b = correction_problem(CAM, illuminant="FL11", reference="FL11", shape=G20)
    np.testing.assert_array_equal(a.Psi, b.Psi)
    np.testing.assert_array_equal(a.Phi, b.Phi)
    assert a.target_illuminant == "" and b.target_illuminant == "FL11"


@pytest.mark.parametrize("cat", ["Von Kries", "CAT02", "CAT16"])
def test_least_squares_matrix_beats_matrix_then_cat(tungsten_to_daylight, cat):
    """Theorem: a per-light 3×3 matrix followed by a 3×3 von Kries/CAT is itself a 3×3 matrix, so
    the least-squares matrix fitted straight to the reference light has no larger XYZ residual on
    its training set."""
    p = tungsten_to_daylight
    direct = fit_correction(p, method="Cheung 2004")
    under_a = correction_problem(CAM, illuminant="A", shape=G20)
    per_light = fit_correction(under_a, method="Cheung 2004")
    C, truth = p.source_of(p.training), p.target_of(p.training)
    adapted = colour.chromatic_adaptation(
        per_light(C), under_a.white_XYZ, p.white_XYZ, method="Von Kries", transform=cat
    )
    rss_direct = float(np.sum((direct(C) - truth) ** 2))
    rss_cat = float(np.sum((adapted - truth) ** 2))
    assert rss_direct <= rss_cat * (1 + 1e-12)
    assert rss_direct < 0.9 * rss_cat  # and by a margin: the A → D65 change is not a diagonal one


def test_reference_ignored_would_be_far_off(tungsten_to_daylight, checker):
    """The fitted map lands on the reference light's colours, not on the scene light's."""
    p = tungsten_to_daylight
    est = fit_correction(p, method="Finlayson 2015")(p.source_of(checker))
    dE_ref = p.delta_E(est, p.target_of(checker))
    dE_scene = p.delta_E(est, checker @ correction_problem(CAM, illuminant="A", shape=G20).Psi)
    assert np.median(dE_ref) < 3.0 and np.median(dE_scene) > 15.0


def test_every_estimator_fits_scene_to_reference(tungsten_to_daylight, checker):
    p = tungsten_to_daylight
    C = p.source_of(checker[:8])
    for method in CORRECTION_METHODS:
        options = {"eps": 0.0} if method == "Centroid" else {}
        est = fit_correction(p, method=method, **options)(C)
        assert est.shape == (8, 3) and np.all(np.isfinite(est)), method
        # the MMV centroid ignores priors and the A → D65 MMVs are large: a loose common bound, far
        # below the ΔE of the scene light's colours (median ≈ 20, the test above)
        assert np.median(p.delta_E(est, p.target_of(checker[:8]))) < 12.0, method


def test_centroid_is_the_illuminant_induced_mmv_centroid(tungsten_to_daylight, checker):
    p = tungsten_to_daylight
    mm = MetamerMismatch(CAM, "CIE 2015 2°", "A", G20, target_illuminant="D65")
    mm_xyz = MetamerMismatch(p)
    c = p.source_of(checker[5])
    mmv = mm_xyz(c)
    assert mmv.contains(p.target_of(checker[5]), atol=1e-9)
    # the problem's Ψ is the observer under D65 with Y_white = 1: a fixed scaling of mm's per channel
    scale = p.Psi.sum(axis=0) / mm.Psi.sum(axis=0)
    np.testing.assert_allclose(mm(c).centroid * scale, mmv.centroid, rtol=1e-7)
    est = fit_correction(p, method="Centroid", eps=0.0)(c)
    np.testing.assert_allclose(est, mmv.centroid, atol=1e-9)


def test_fit_correction_and_saved_corrections_keep_the_reference(tmp_path, tungsten_to_daylight, checker):
    """``fit_correction(cams, reference=...)`` builds the same problem, and a saved correction keeps
    the light its target sees (a reload that dropped it would still hold the right Ψ but say D65 = A)."""
    from zonotope.correct import load_correction, save_correction

    direct = fit_correction(tungsten_to_daylight, method="Cheung 2004")
    by_name = fit_correction(CAM, method="Cheung 2004", illuminant="A", reference="D65", shape=G20)
    assert by_name.problem.target_illuminant == tungsten_to_daylight.target_illuminant
    responses = checker @ tungsten_to_daylight.Phi
    np.testing.assert_allclose(by_name(responses), direct(responses), rtol=1e-12, atol=1e-14)
    with pytest.raises(Exception, match="reference"):
        fit_correction(tungsten_to_daylight, method="Cheung 2004", reference="D65")
    path = save_correction(tmp_path / "a_to_d65.npz", direct)
    loaded = load_correction(path)
    assert loaded.problem.target_illuminant == tungsten_to_daylight.target_illuminant != ""
    np.testing.assert_allclose(loaded(responses), direct(responses), rtol=1e-12, atol=1e-14)
