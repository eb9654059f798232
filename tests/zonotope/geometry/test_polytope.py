"""Polytope: exact measures against independent implementations, degenerate cases, conversions."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.optimize import minimize
from scipy.spatial import ConvexHull, Delaunay

from zonotope._errors import GeometryError
from zonotope.geometry.polytope import Polytope

CUBE = np.array([[x, y, z] for x in (0, 1) for y in (0, 1) for z in (0, 1)], dtype=float)

#: Shared catalogue of degenerate inputs: (name, points, dim, measure, centroid)
DEGENERATE = [
    ("point", np.tile([0.2, 0.3, 0.4], (5, 1)), 0, 1.0, [0.2, 0.3, 0.4]),
    (
        "segment",
        np.array([[0, 0, 0], [1, 2, 2], [0.5, 1, 1], [0.25, 0.5, 0.5]], float),
        1,
        3.0,
        [0.5, 1.0, 1.0],
    ),
    (
        "triangle+inner",
        np.array([[0, 0, 1], [3, 0, 1], [0, 3, 1], [1, 1, 1], [1.5, 0, 1]], float),
        2,
        4.5,
        [1.0, 1.0, 1.0],
    ),
    (
        "tilted square",
        np.array([[0, 0, 0], [1, 0, 1], [0, 1, 0], [1, 1, 1]], float),
        2,
        np.sqrt(2.0),
        [0.5, 0.5, 0.5],
    ),
]


def random_points(seed: int, n: int = 40) -> np.ndarray:
    return np.random.default_rng(seed).normal(size=(n, 3)) * [1.0, 0.5, 0.2] + [0.3, -0.1, 2.0]


def test_cube_exact():
    P = Polytope(CUBE)
    assert P.affine_dim == 3 and P.volume == pytest.approx(1.0, abs=1e-15)
    np.testing.assert_allclose(P.centroid, 0.5, atol=1e-15)
    A, _ = P.halfspaces
    assert A.shape == (6, 3)  # 12 hull triangles merged into 6 facets
    np.testing.assert_allclose(np.linalg.norm(A, axis=1), 1.0)
    c, r = P.chebyshev_center(return_radius=True)
    np.testing.assert_allclose(c, 0.5, atol=1e-9)
    assert r == pytest.approx(0.5)


@pytest.mark.parametrize("seed", range(5))
def test_volume_and_centroid_match_independent(seed):
    import trimesh

    pts = random_points(seed)
    P = Polytope(pts)
    hull = ConvexHull(pts)
    assert P.volume == pytest.approx(hull.volume, rel=1e-12)
    F = hull.simplices.copy()  # orient Qhull's triangles outward by its facet equations
    T = pts[F]
    flip = np.einsum("ij,ij->i", np.cross(T[:, 1] - T[:, 0], T[:, 2] - T[:, 0]), hull.equations[:, :3]) < 0
    F[flip] = F[flip][:, ::-1]
    mesh = trimesh.Trimesh(pts, F, process=False)
    np.testing.assert_allclose(P.centroid, mesh.center_mass, atol=1e-12)
    tm = P.to_trimesh()
    assert tm.is_watertight and tm.volume == pytest.approx(P.volume, rel=1e-12)
    assert P.to_manifold().volume() == pytest.approx(P.volume, rel=1e-9)


def test_centroid_is_not_vertex_mean():
    # a cone: many vertices on the base circle, one apex; volume centroid at h/4 above the base
    t = np.linspace(0, 2 * np.pi, 200, endpoint=False)
    base = np.stack([np.cos(t), np.sin(t), np.zeros_like(t)], axis=1)
    P = Polytope(np.vstack([base, [[0, 0, 4.0]]]))
    assert P.centroid[2] == pytest.approx(1.0, rel=1e-12)
    assert P.vertices.mean(axis=0)[2] < 0.1


@pytest.mark.parametrize("name, pts, dim, measure, centroid", DEGENERATE, ids=[d[0] for d in DEGENERATE])
def test_degenerate_catalogue(name, pts, dim, measure, centroid):
    P = Polytope(pts)
    assert P.affine_dim == dim
    assert P.volume == 0.0
    assert P.measure == pytest.approx(measure, rel=1e-12)
    np.testing.assert_allclose(P.centroid, centroid, atol=1e-12)
    assert P.contains(pts).all()
    off = np.asarray(centroid) + np.array([0.3, -0.2, 0.7]) * 1e-3
    A, b = P.halfspaces
    assert (A @ np.asarray(centroid) <= b + 1e-12).all()
    assert not P.contains(off if dim < 3 else off + 10)
    proj = P.project(np.asarray(centroid) + np.array([[0.0, 0.0, 5.0]]))
    assert P.contains(proj).all()
    P.to_pyvista()
    P.to_trimesh()
    with pytest.raises(GeometryError):
        P.to_manifold()


def test_flat_in_3d_no_qhull_crash():
    rng = np.random.default_rng(1)
    uv = rng.random((100, 2))
    pts = np.array([0.1, 0.2, 0.3]) + uv @ np.array([[1.0, 0.5, 0.2], [-0.3, 1.0, 0.4]])
    P = Polytope(pts + 1e-14 * rng.normal(size=pts.shape))
    assert P.affine_dim == 2
    area = ConvexHull(uv).volume * np.linalg.norm(np.cross([1.0, 0.5, 0.2], [-0.3, 1.0, 0.4]))
    assert P.measure == pytest.approx(area, rel=1e-9)


@pytest.mark.parametrize("seed", range(3))
def test_contains_matches_delaunay(seed):
    pts = random_points(seed)
    P = Polytope(pts)
    q = random_points(seed + 100, 2000) * 1.2
    expect = Delaunay(pts).find_simplex(q) >= 0
    np.testing.assert_array_equal(P.contains(q, atol=0.0), expect)


def _project_slsqp(P: Polytope, p: np.ndarray, W: np.ndarray) -> np.ndarray:
    A, b = P.halfspaces
    res = minimize(
        lambda y: (y - p) @ W @ (y - p),
        P.centroid,
        jac=lambda y: 2 * W @ (y - p),
        constraints=[{"type": "ineq", "fun": lambda y: b - A @ y, "jac": lambda y: -A}],
        method="SLSQP",
        options={"ftol": 1e-14, "maxiter": 500},
    )
    return res.x


@pytest.mark.parametrize("seed", range(3))
@pytest.mark.parametrize("metric", [False, True])
def test_project_matches_slsqp(seed, metric):
    rng = np.random.default_rng(seed)
    P = Polytope(random_points(seed, 25))
    M = rng.normal(size=(3, 3))
    W = M @ M.T + 0.5 * np.eye(3) if metric else np.eye(3)
    q = P.centroid + rng.normal(size=(20, 3)) * 2
    got = P.project(q, metric=W if metric else None)
    for p, y in zip(q, got, strict=True):
        ref = _project_slsqp(P, p, W)
        assert (y - p) @ W @ (y - p) <= (ref - p) @ W @ (ref - p) + 1e-9
        np.testing.assert_allclose(y, ref, atol=1e-5)
    inside = P.vertices.mean(axis=0)
    np.testing.assert_array_equal(P.project(inside), inside)


@settings(max_examples=30, deadline=None)
@given(st.integers(0, 10_000))
def test_project_invariants(seed):
    rng = np.random.default_rng(seed)
    P = Polytope(rng.random((12, 3)))
    q = rng.normal(size=(8, 3)) * 3
    y = P.project(q)
    assert P.contains(y, atol=1e-9).all()
    np.testing.assert_allclose(P.project(y), y, atol=1e-12)
    d = np.linalg.norm(y - q, axis=1)
    dv = np.linalg.norm(q[:, None] - P.vertices[None], axis=2).min(axis=1)
    assert (d <= dv + 1e-12).all()


def test_halfspace_round_trip_and_intersection():
    P = Polytope(random_points(0))
    Q = Polytope(halfspaces=P.halfspaces)
    assert Q.volume == pytest.approx(P.volume, rel=1e-10)
    d = np.linalg.norm(Q.vertices[:, None] - P.vertices[None], axis=2)
    assert d.min(axis=1).max() < 1e-9 and d.min(axis=0).max() < 1e-9
    R = Polytope(random_points(1) + np.array([0.2, 0.1, 0.0]))
    both = P.intersect(R)
    ref = (P.to_manifold() ^ R.to_manifold()).volume()
    assert both.volume == pytest.approx(ref, rel=1e-9)


def test_intersection_degenerate_and_empty():
    cube = Polytope(CUBE)
    touching = Polytope(CUBE + np.array([1.0, 0.0, 0.0]))
    face = cube.intersect(touching)
    assert face.affine_dim == 2 and face.measure == pytest.approx(1.0, rel=1e-9)
    np.testing.assert_allclose(face.centroid, [1.0, 0.5, 0.5], atol=1e-9)
    empty = cube.intersect(Polytope(CUBE + 3.0))
    assert empty.affine_dim == -1 and empty.volume == 0.0 and not empty.contains([0.5, 0.5, 0.5])
    with pytest.raises(GeometryError, match="empty"):
        empty.centroid  # noqa: B018


def test_errors():
    with pytest.raises(GeometryError, match="NaN"):
        Polytope(np.array([[0.0, 0, 0], [np.nan, 0, 0]]))
    with pytest.raises(GeometryError, match="unbounded"):
        Polytope(halfspaces=(np.array([[1.0, 0, 0]]), np.array([1.0])))
    with pytest.raises(GeometryError):
        Polytope(CUBE).contains(np.zeros(2))
    with pytest.raises(GeometryError, match=r"positive definite|symmetric"):
        Polytope(CUBE).project(np.zeros(3) + 2, metric=-np.eye(3))


def test_pyvista_surface_closed():
    P = Polytope(random_points(3))
    mesh = P.to_pyvista()
    assert mesh.n_points == len(P.vertices)
    assert mesh.volume == pytest.approx(P.volume, rel=1e-9)


def test_2d_ambient():
    sq = Polytope(np.array([[0, 0], [2, 0], [0, 1], [2, 1], [1, 0.5]], float))
    assert sq.affine_dim == 2 and sq.volume == pytest.approx(2.0) and sq.n_facets == 4
    np.testing.assert_allclose(sq.centroid, [1.0, 0.5])
    np.testing.assert_allclose(sq.project(np.array([[3.0, 3.0]])), [[2.0, 1.0]])
