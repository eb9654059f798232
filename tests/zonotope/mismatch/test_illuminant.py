"""Illuminant-induced metamer mismatch volumes against independent truth: the HiGHS twin, a closed
form (the 0.5 grey's MMV is centred on its own colour), the complement symmetry, and brute-force
metamers built in the null space of Φ."""

from __future__ import annotations

import colour
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import zonotope
from zonotope._errors import GeometryError
from zonotope.geometry.polytope import Polytope
from zonotope.mismatch import MetamerMismatch, metamer_mismatch
from zonotope.mismatch.illuminant import illuminant_mismatch, illuminant_pair, relative_volume
from zonotope.spectra.pair import GeneratorPair

G20 = np.arange(400.0, 701.0, 20.0)
G10 = np.arange(400.0, 701.0, 10.0)
LIGHTS = ["A", "FL2", "FL11", "LED-B3", "D50"]


def hausdorff(A, B):
    D = np.linalg.norm(A[:, None] - B[None], axis=2)
    return max(D.min(axis=1).max(), D.min(axis=0).max())


@pytest.fixture(scope="module")
def checker20():
    return zonotope.resample(zonotope.reflectances("ColorChecker N Ohta"), G20).T


@pytest.mark.parametrize("light", ["A", "FL11"])
def test_walk_matches_highs_twin(light, checker20):
    """The exact walk and facet refinement with scipy-HiGHS give one polytope (D65 → light)."""
    pair = illuminant_pair("D65", light, shape=G20)
    for i in (14,):
        c = pair.source_of(checker20[i])
        ours = metamer_mismatch(pair.Phi, pair.Psi, c)
        ref = metamer_mismatch(pair.Phi, pair.Psi, c, oracle="highs")
        assert ours.affine_dim == 3
        assert ours.volume == pytest.approx(ref.volume, rel=1e-6)
        np.testing.assert_allclose(ours.centroid, ref.centroid, atol=1e-7)
        assert hausdorff(ours.vertices, ref.vertices) < 1e-7


def test_camera_to_eye_under_another_light_matches_highs(checker20):
    """Observer- and illuminant-induced combined: a camera under A, the eye under D65."""
    mm = MetamerMismatch("Nikon 5100 (NPL)", "CIE 1931 2°", "A", G20, target_illuminant="D65")
    c = mm.source_of(checker20[6])
    ours = mm(c)
    ref = metamer_mismatch(mm.Phi, mm.Psi, c, oracle="highs")
    assert ours.volume == pytest.approx(ref.volume, rel=1e-6)
    np.testing.assert_allclose(ours.centroid, ref.centroid, atol=1e-7)
    # Ψ really is the observer under D65 and Φ the camera under A
    np.testing.assert_allclose(mm.Psi, zonotope.generators("CIE 1931 2°", "D65", G20).values)
    np.testing.assert_allclose(mm.Phi, zonotope.generators("Nikon 5100 (NPL)", "A", G20).values)
    assert mm.generators.illuminant == "A" and mm.generators.target_illuminant == "D65"


def test_same_light_is_the_observer_induced_mmv(checker20):
    """A target light equal to the source light (given as another object) changes nothing."""
    d65 = colour.SDS_ILLUMINANTS["D65"].copy()
    d65.name = "my daylight"
    same = MetamerMismatch("Nikon 5100 (NPL)", "CIE 1931 2°", "D65", G20, target_illuminant=d65)
    plain = MetamerMismatch("Nikon 5100 (NPL)", "CIE 1931 2°", "D65", G20)
    c = plain.source_of(checker20[9])
    assert same(c).volume == pytest.approx(plain(c).volume, rel=1e-12)
    np.testing.assert_allclose(same(c).centroid, plain(c).centroid, atol=1e-12)


def test_observer_under_one_light_is_a_point(checker20):
    """The observer seeing itself under the same light: no mismatch (a point at its colour)."""
    mm = illuminant_mismatch("D65", "D65", shape=G20)
    x = checker20[3]
    mmv = mm(mm.source_of(x))
    assert mmv.affine_dim == 0 and mmv.volume == 0.0
    np.testing.assert_allclose(mmv.centroid, mm.target_of(x), atol=1e-9)


@pytest.mark.parametrize("light", ["A", "FL2", "LED-B3"])
def test_half_grey_centroid_is_its_colour(light):
    """Closed form: x ↦ 1 − x maps the metamers of the 0.5 grey onto themselves, so the MMV is
    point-symmetric about the grey's own colour under light 2, which is then its centroid."""
    mm = illuminant_mismatch("D65", light, shape=G10)
    grey = np.full(G10.size, 0.5)
    mmv = mm(mm.source_of(grey))
    np.testing.assert_allclose(mmv.centroid, mm.target_of(grey), atol=1e-9)


def test_complement_symmetry():
    """MMV(white − c) = Ψ·1 − MMV(c): equal volumes for reflectance levels r and 1 − r."""
    mm = illuminant_mismatch("D65", "FL11", shape=G10)
    white = mm.Psi.sum(axis=0)
    low = mm(mm.source_of(np.full(G10.size, 0.2)))
    high = mm(mm.source_of(np.full(G10.size, 0.8)))
    assert low.volume == pytest.approx(high.volume, rel=1e-9)
    np.testing.assert_allclose(low.centroid, white - high.centroid, atol=1e-9)


def _metamers(Phi, x0, rng, count):
    """Reflectances in [0, 1] with exactly the response of ``x0``: x0 plus null-space steps of Φᵀ,
    each shrunk to stay in the box (independent of any LP)."""
    _, _, Vt = np.linalg.svd(Phi.T)
    N = Vt[Phi.shape[1] :].T
    out = []
    for _ in range(count):
        d = N @ rng.normal(size=N.shape[1])
        room = np.where(
            d > 0, (1 - x0) / np.maximum(d, 1e-300), np.where(d < 0, -x0 / np.minimum(d, -1e-300), np.inf)
        )
        out.append(x0 + d * min(1.0, float(room.min())) * rng.uniform(0.2, 1.0))
    return np.array(out)


@pytest.mark.parametrize("light", LIGHTS)
def test_every_metamer_lies_in_the_mmv(light, checker20):
    """Brute force: the colour under light 2 of every sampled metamer lies in the exact MMV, and
    the sampled colours spread over a sizeable part of it (the MMV is not simply too big)."""
    mm = illuminant_mismatch("D65", light, sources="Nikon 5100 (NPL)", shape=G20)
    rng = np.random.default_rng(1)
    x0 = 0.1 + 0.8 * checker20[11]  # away from the box faces, so the steps have room
    X = _metamers(mm.Phi, x0, rng, 400)
    C = mm.source_of(X)
    np.testing.assert_allclose(C, np.broadcast_to(mm.source_of(x0), C.shape), atol=1e-12)
    assert X.min() >= -1e-12 and X.max() <= 1 + 1e-12
    mmv = mm(mm.source_of(x0))
    assert mmv.contains(mm.target_of(X), atol=1e-9).all()
    sampled = Polytope(mm.target_of(X))
    assert 0.01 < sampled.volume / mmv.volume <= 1.0 + 1e-9


@settings(max_examples=15, deadline=None)
@given(
    st.lists(st.floats(0.0, 1.0), min_size=6, max_size=6),
    st.sampled_from(LIGHTS),
    st.sampled_from(["D65", "A"]),
)
def test_mmv_contains_the_true_colour(knots, light, source_light):
    """Any smooth reflectance's colour under light 2 lies in the MMV of its response under light 1."""
    x = np.interp(G20, np.linspace(400, 700, 6), knots)
    mm = illuminant_mismatch(source_light, light, sources="Nikon 5100 (NPL)", shape=G20)
    c = mm.source_of(x)
    mmv = mm(c)
    assert mmv.contains(mm.target_of(x), atol=1e-9)
    assert zonotope.Zonotope(mm.Psi).contains(mmv.vertices, atol=1e-9).all()


def test_relative_volume_is_scale_free():
    """Scaling the target's channels leaves the relative volume unchanged; batches work too."""
    g = np.full(G20.size, 0.5)
    a = illuminant_mismatch("D65", "A", shape=G20, normalise=1)
    b = illuminant_mismatch("D65", "A", shape=G20, normalise="channel")
    ra = relative_volume(a(a.source_of(g)), a)
    rb = relative_volume(b(b.source_of(g)), b)
    assert ra == pytest.approx(rb, rel=1e-8) and 0 < ra < 0.05
    batch = a.batch(a.source_of(np.stack([g, 0.3 * np.ones(G20.size)])), eps=0.0)
    np.testing.assert_allclose(relative_volume(batch, a)[0], ra, rtol=1e-8)


def test_relative_volume_needs_a_3d_target():
    pair = illuminant_pair("D65", "A", sources="Nikon 5100 (NPL)", shape=G20)
    mm = MetamerMismatch(GeneratorPair(Phi=pair.Phi, Psi=np.hstack([pair.Psi, pair.Phi]), wavelengths=G20))
    with pytest.raises(GeometryError, match="3-D"):
        relative_volume(1.0, mm)
