"""Exact MacAdam limits, object-colour membership and invert, against LPs, tables and re-integration."""

from __future__ import annotations

import colour
import numpy as np
import pytest
from scipy.optimize import linprog

from zonotope import GeometryError, Zonotope
from zonotope.geometry.lp import distance_to_zonotope
from zonotope.geometry.macadam import invert, is_object_colour, macadam_limits, object_colour_solid, section


@pytest.fixture(scope="module")
def solid_C():
    return object_colour_solid("CIE 1931 2°", "C")


def awkward_generators(seed=0):
    """Random generators plus the degenerate cases: a zero row, a parallel pair, an antiparallel
    one (flipped by the reduction) and an exactly coplanar triple (a zonogon facet)."""
    rng = np.random.default_rng(seed)
    G = rng.normal(size=(12, 3))
    G[3] = 0.0
    G[5] = 2.5 * G[4]
    G[7] = -0.7 * G[6]
    G[9] = 0.3 * G[8] + 0.6 * G[10]
    return G


def test_invert_reintegrates_inside_on_and_at_the_centre():
    G = awkward_generators()
    Z = Zonotope(G, offset=[0.1, -0.2, 0.3])
    assert len(Z._facets.zonogons) == 1
    rng = np.random.default_rng(1)
    X = rng.random((400, G.shape[0]))
    X[:100] = np.round(X[:100])  # vertices and edge points
    P = np.concatenate(
        [X @ G + Z.offset, Z.support(rng.normal(size=(300, 3))).point, Z.centroid[None], Z.vertices]
    )
    R = invert(P, solid=Z)
    assert R.shape == (P.shape[0], G.shape[0])
    assert R.min() >= 0.0 and R.max() <= 1.0
    np.testing.assert_allclose(R @ G + Z.offset, P, rtol=0, atol=1e-12 * Z.scale)
    # the zonogon facet: points on it come back too
    _, verts, _ = Z._facets.zonogons[0]
    w = rng.dirichlet(np.ones(verts.shape[0]), size=50)
    Q = np.concatenate([w @ verts, 2 * Z.centroid - w @ verts])
    np.testing.assert_allclose(invert(Q, solid=Z) @ G + Z.offset, Q, atol=1e-10 * Z.scale)


def test_invert_batches_and_refuses_outside_points(solid_C):
    Z = solid_C
    x = np.random.default_rng(2).random((2, 3, Z.n_generators))
    P = x @ Z.generators
    R = invert(P, solid=Z)
    assert R.shape == (2, 3, Z.n_generators)
    np.testing.assert_allclose(R @ Z.generators, P, atol=1e-13)
    with pytest.raises(GeometryError, match="outside the solid"):
        invert([[0.5, 1.2, 0.5]], solid=Z)
    with pytest.raises(GeometryError, match="NaN"):
        invert([[np.nan, 0.5, 0.5]], solid=Z)


@pytest.mark.parametrize("seed", [0, 1])
def test_section_matches_linear_programs(seed):
    """Support of the section polygon in in-plane directions = the LP max over reflectances."""
    G = awkward_generators(seed)
    Z = Zonotope(G)
    rng = np.random.default_rng(seed + 10)
    n = rng.normal(size=3)
    v = n @ Z.centroid + 0.3 * rng.standard_normal() * abs(n @ G.T).sum() / 2
    poly = section(Z, n, v)
    assert poly.shape[0] >= 3
    np.testing.assert_allclose(poly @ n, v, atol=1e-12 * Z.scale * np.linalg.norm(n))
    for _ in range(8):
        u = rng.normal(size=3)
        u -= n * (u @ n) / (n @ n)
        lp = linprog(-(G @ u), A_eq=(G @ n)[None], b_eq=[v], bounds=(0, 1), method="highs")
        assert lp.status == 0
        assert (poly @ u).max() == pytest.approx(-lp.fun, abs=1e-9 * Z.scale)


def test_section_misses_and_bad_input():
    Z = Zonotope(np.eye(3))
    assert section(Z, [0, 0, 1], 2.0).shape == (0, 3)
    sq = section(Z, [0, 0, 1], 0.5)
    assert sq.shape == (4, 3) and np.allclose(sq[:, 2], 0.5)
    with pytest.raises(GeometryError, match="normal"):
        section(Z, [0, 0, 0], 0.5)
    with pytest.raises(GeometryError, match="Y must lie"):
        macadam_limits(-0.1, solid=Zonotope(np.abs(np.random.default_rng(0).normal(size=(5, 3)))))


def test_macadam_limits_against_macadam_1935_tables(solid_C):
    """colour-science's optimal colour stimuli under C (MacAdam's tables, Y = 10 … 95) lie on
    the exact loci: median distance in xy below 0.002 at every luminance."""
    from colour.volume import OPTIMAL_COLOUR_STIMULI_ILLUMINANTS

    table = OPTIMAL_COLOUR_STIMULI_ILLUMINANTS["C"]
    for Y in np.unique(table[:, 2]):
        lim = macadam_limits(Y / 100, solid=solid_C)
        assert np.allclose(lim.XYZ[:, 1], Y / 100)
        s0, s1 = lim.xy, np.roll(lim.xy, -1, axis=0)
        d = []
        for q in table[table[:, 2] == Y, :2]:
            e, w = s1 - s0, q - s0
            t = np.clip(np.einsum("ij,ij->i", w, e) / np.einsum("ij,ij->i", e, e), 0, 1)
            d.append(np.linalg.norm(w - t[:, None] * e, axis=1).min())
        assert np.median(d) < 0.002, Y


def test_is_object_colour_matches_the_lp_twin():
    G = awkward_generators(3)
    Z = Zonotope(G)
    rng = np.random.default_rng(4)
    lo, hi = Z.vertices.min(0), Z.vertices.max(0)
    Q = lo + (hi - lo) * rng.random((60, 3))
    fast = is_object_colour(Q, solid=Z)
    ref = np.array([distance_to_zonotope(Z._reduced[0], Z._reduced[1], q)[0] <= 1e-7 for q in Q])
    A, b = Z.halfspaces
    clear = np.abs((Q @ A.T - b).max(axis=1)) > 1e-6
    np.testing.assert_array_equal(fast[clear], ref[clear])
    assert 0 < fast.sum() < fast.size


@pytest.mark.slow
def test_munsell_real_colours_issue_364(solid_C):
    """colour-science issue #364: its MacAdam test calls 829 of the 2,734 real Munsell colours
    (illuminant C) impossible. The exact solid (CIE 1931 2°, C, 360–780 nm at 1 nm) gives every
    colour it accepts a reflectance in [0, 1] that integrates back to it, and every colour it
    rejects is outside by the HiGHS LP distance."""
    from colour.notation.datasets.munsell import MUNSELL_COLOURS_REAL

    xyY = np.array([v for _, v in MUNSELL_COLOURS_REAL])
    xyY[:, 2] /= 100.0
    XYZ = colour.xyY_to_XYZ(xyY)
    cs = colour.is_within_macadam_limits(xyY, "C")
    assert xyY.shape[0] == 2734 and np.count_nonzero(~cs) == 829
    exact = is_object_colour(XYZ, solid=solid_C)
    R = invert(XYZ[exact], solid=solid_C)
    assert R.min() >= 0.0 and R.max() <= 1.0
    np.testing.assert_allclose(R @ solid_C.generators, XYZ[exact], atol=1e-12)
    H, off = solid_C._reduced
    for q in XYZ[~exact]:
        assert distance_to_zonotope(H, off, q)[0] > 1e-9
    assert np.count_nonzero(~exact) < 20 and np.count_nonzero(exact & ~cs) > 800
