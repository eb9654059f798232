"""One tolerance module: each object honours its own tolerances, and the named values are used."""

from __future__ import annotations

import numpy as np
import pytest

from zonotope import Polytope, Tolerances, Zonotope, _tol


@pytest.mark.parametrize("k", [3, 4])
def test_contains_uses_the_solids_own_tolerances(k):
    """Regression: ``contains`` used the global TOL instead of the solid's ``tol``."""
    point = np.full(k, 0.5)
    point[0] = 1.05  # 0.05 outside the unit cube
    loose = Zonotope(np.eye(k), tol=Tolerances(contains=0.1))  # slack 0.1 × scale (scale = 1)
    strict = Zonotope(np.eye(k))
    assert loose.scale == 1.0
    assert bool(loose.contains(point)) and not bool(strict.contains(point))
    if k == 3:
        assert bool(loose.contains_reference(point)) and not bool(strict.contains_reference(point))
    # just inside the loose slack / just outside it
    point[0] = 1.0 + 0.1 * 0.999
    assert bool(loose.contains(point))
    point[0] = 1.0 + 0.1 * 1.001
    assert not bool(loose.contains(point))


def test_polytope_flatness_threshold_is_AFFINE():
    """Points off a plane by less than AFFINE × diameter are flat; 100 × more is a solid."""
    square = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [1, 1, 0]], dtype=float)
    diameter = np.sqrt(2.0)
    for height, dim in [(0.01 * _tol.AFFINE * diameter, 2), (100 * _tol.AFFINE * diameter, 3)]:
        P = Polytope(np.vstack([square, [0.5, 0.5, height]]))
        assert P.affine_dim == dim


def test_tolerance_values_are_documented():
    """Every named tolerance has a reason next to it (a comment block or the class notes)."""
    source = open(_tol.__file__, encoding="utf-8").read()
    names = [n for n in _tol.__all__ if n.isupper() and n != "TOL"]
    assert {"AFFINE", "ANGLE", "CERTIFY", "COLLINEAR", "FEASIBLE_REL", "FEASIBLE_ABS", "SINGULAR"} <= set(
        names
    )
    for name in names:
        assert "#: " in source.split(f"\n{name} = ")[0].rsplit("\n\n", 1)[-1], name
    for field in ("zero", "parallel", "coplanar", "rank", "contains"):
        assert f"``{field} = " in Tolerances.__doc__, field


def test_oracle_names_are_case_insensitive_and_unknown_ones_are_project_errors():
    import zonotope
    from zonotope.mismatch import metamer_mismatch

    rng = np.random.default_rng(3)
    Phi, Psi = rng.random((12, 2)), rng.random((12, 3))
    c = np.full(12, 0.5) @ Phi
    a = metamer_mismatch(Phi, Psi, c, oracle="HiGHS")
    b = metamer_mismatch(Phi, Psi, c, oracle="fast")
    np.testing.assert_allclose(a.volume, b.volume, rtol=1e-7)
    with pytest.raises(zonotope.UnknownMethodError, match=r"oracle='cdd' is not a support oracle method"):
        metamer_mismatch(Phi, Psi, c, oracle="cdd")


@pytest.mark.parametrize(("bump", "n_vertices"), [(0.0, 4), (1e-17, 4), (1e-9, 5)])
def test_polygon_collinear_threshold_is_COLLINEAR(bump, n_vertices):
    """A point on a square's edge is dropped when it is off the edge by rounding only (COLLINEAR)."""
    pts = np.array([[0, 0], [1, 0], [1, 1], [0, 1], [0.5, -bump]], dtype=float)
    assert len(Polytope(pts).vertices) == n_vertices


def test_flat_halfspace_vertices_skip_singular_subsets():
    """A flat triangle as half-spaces (two opposite planes z ≤ 0, −z ≤ 0 plus 3 sides): the parallel
    pair's |det| is 0 ≤ SINGULAR, skipped; the vertices come from the well-conditioned subsets."""
    A = np.array([[0, 0, 1], [0, 0, -1], [-1, 0, 0], [0, -1, 0], [1, 1, 0]], dtype=float)
    b = np.array([0, 0, 0, 0, 1], dtype=float)
    P = Polytope.from_halfspaces(A, b)
    assert P.affine_dim == 2
    np.testing.assert_allclose(sorted(map(tuple, P.vertices)), [(0, 0, 0), (0, 1, 0), (1, 0, 0)], atol=1e-12)
