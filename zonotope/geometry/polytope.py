"""Convex polytopes in V- and H-representation, of any affine dimension.

A :class:`Polytope` is built from points (its convex hull) or from half-spaces ``A y ≤ b``.
The affine hull is found first (SVD of the centred points), and the hull is computed inside it,
so a point, a segment or a polygon in 3-D space is an honest lower-dimensional polytope
(``affine_dim`` 0, 1 or 2, ``volume`` 0) instead of a Qhull precision error.

What is exact
-------------
- ``volume``: sum of the signed volumes of the tetrahedra (interior point, boundary triangle);
  0 when ``affine_dim`` < ``ambient_dim``.
- ``centroid``: the volume centroid by the same tetrahedral decomposition (3-D), the area centroid
  of a polygon, the midpoint of a segment, the point itself (never the mean of the vertices).
- ``halfspaces``: unit normals with coplanar triangles merged into one facet; lower-dimensional
  polytopes also get the ± rows of their affine hull's equations.
- ``project``: nearest point in the Euclidean metric or in ``(y − p)ᵀ W (y − p)``, by the
  closest point over a triangulation of the boundary (inside points are returned unchanged).

Ambient dimension 3 is complete; other dimensions support everything that does not need a
boundary triangulation (``project`` and the mesh conversions need ``affine_dim`` ≤ 3).
"""

from __future__ import annotations

from functools import cached_property

import numpy as np

from .._errors import GeometryError, float_array
from .._tol import AFFINE, ANGLE, COLLINEAR, SINGULAR

__all__ = ["Polytope"]


def _affine_hull(P: np.ndarray, atol: float) -> tuple[np.ndarray, np.ndarray]:
    """Origin (m,) and orthonormal basis (m, d) of the affine hull of points P (N, m)."""
    o = P.mean(axis=0)
    Q = P - o
    if P.shape[0] < 2:
        return o, np.zeros((P.shape[1], 0))
    _, _, Vt = np.linalg.svd(Q, full_matrices=False)
    dev = np.abs(Q @ Vt.T).max(axis=0) if Vt.size else np.zeros(0)
    d = int(np.sum(dev > atol))
    return o, Vt[:d].T.copy()


def _hull_2d(Z: np.ndarray) -> np.ndarray:
    """Indices of the CCW convex hull of 2-D points (Andrew's monotone chain, collinear dropped)."""
    order = np.lexsort((Z[:, 1], Z[:, 0]))
    pts = Z[order]

    def half(seq):
        out: list[int] = []
        for i in seq:
            while len(out) >= 2:
                a, b = pts[out[-2]], pts[out[-1]]
                cross = (b[0] - a[0]) * (pts[i][1] - a[1]) - (b[1] - a[1]) * (pts[i][0] - a[0])
                if cross <= COLLINEAR * (np.abs(b - a).max() * np.abs(pts[i] - a).max()):
                    out.pop()
                else:
                    break
            out.append(i)
        return out

    lower = half(range(len(pts)))
    upper = half(range(len(pts) - 1, -1, -1))
    return order[np.array(lower[:-1] + upper[:-1], dtype=int)]


def _det3(E: np.ndarray) -> np.ndarray:
    """Determinants (T,) of a stack of 3×3 matrices (T, 3, 3) by the triple product (LAPACK's
    batched LU costs ~1 µs per matrix; this is ~20× faster and equally exact: a few roundings)."""
    a, b, c = E[:, 0], E[:, 1], E[:, 2]
    return (
        a[:, 0] * (b[:, 1] * c[:, 2] - b[:, 2] * c[:, 1])
        - a[:, 1] * (b[:, 0] * c[:, 2] - b[:, 2] * c[:, 0])
        + a[:, 2] * (b[:, 0] * c[:, 1] - b[:, 1] * c[:, 0])
    )


class Polytope:
    """A bounded convex polytope in R^m of any affine dimension.

    Parameters
    ----------
    points : array_like of shape (N, m), optional
        The polytope is their convex hull (V-representation).
    halfspaces : tuple (A (F, m), b (F,)), optional
        ``{y : A y ≤ b}``; with ``points`` too, the intersection of both.
    atol : float, optional
        Absolute tolerance (same units as the points) under which the points count as lying
        in a lower-dimensional affine subspace and coplanar facets are merged, and the default
        slack of :meth:`contains`; default ``AFFINE × span`` (``1e-9 ×`` the largest
        per-coordinate extent of the points, :data:`zonotope._tol.AFFINE`).

    Attributes
    ----------
    vertices : ndarray of shape (V, m)
    affine_dim : int
        Affine dimension: -1 empty, 0 point, 1 segment, 2 polygon, 3 solid.
    ambient_dim : int
        Dimension m of the space the points live in (number of coordinates).
    atol : float
        The absolute tolerance in use (see the parameter).

    Raises
    ------
    GeometryError
        NaN/inf coordinates, unbounded half-spaces, or hull dimension > 3 in ambient > 3 for the
        operations that need a boundary triangulation.

    Examples
    --------
    >>> import numpy as np
    >>> cube = Polytope(np.array([[x, y, z] for x in (0, 1) for y in (0, 1) for z in (0, 1)]))
    >>> cube.affine_dim, float(cube.volume), cube.centroid.tolist()
    (3, 1.0, [0.5, 0.5, 0.5])
    >>> Polytope(np.array([[0.0, 0, 0], [1, 1, 1]])).affine_dim
    1
    """

    def __init__(self, points=None, halfspaces=None, *, atol: float | None = None) -> None:
        if points is None and halfspaces is None:
            raise GeometryError("Polytope needs points (N, m) and/or halfspaces (A, b).")
        if halfspaces is not None:
            A, b = (float_array(a, "halfspaces", GeometryError) for a in halfspaces)
            if points is not None:
                other = Polytope(points, atol=atol)
                A2, b2 = other.halfspaces
                A, b = np.concatenate([A, A2]), np.concatenate([b, b2])
            points = _vertices_from_halfspaces(A, b, atol)
        P = float_array(points, "points", GeometryError, copy=True)
        if P.ndim != 2:
            raise GeometryError(f"points must have shape (N, m); got {P.shape}.")
        if not np.all(np.isfinite(P)):
            raise GeometryError("points contain NaN or inf.")
        self.ambient_dim = P.shape[1]
        span = float(np.ptp(P, axis=0).max()) if P.shape[0] else 0.0
        self.atol = float(atol) if atol is not None else AFFINE * max(span, 1e-300)
        if P.shape[0] == 0:
            self._o, self._B = np.zeros(self.ambient_dim), np.zeros((self.ambient_dim, 0))
            self.affine_dim = -1
            self._Z = np.zeros((0, 0))
            self.vertices = P
            self._simplices = np.zeros((0, 0), dtype=int)
            self._keep = np.zeros(0, dtype=int)
            return
        self._o, self._B = _affine_hull(P, self.atol)
        self.affine_dim = self._B.shape[1]
        Z = (P - self._o) @ self._B
        keep, simplices = self._hull(Z)
        self._keep = keep  # indices of the vertices among the input points
        self.vertices = P[keep]
        self.vertices.flags.writeable = False
        self._Z = Z[keep]
        self._simplices = simplices  # boundary simplices (affine_dim ≥ 2) as rows of vertex indices

    # -- construction helpers -------------------------------------------------------------------

    def _hull(self, Z: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        d = self.affine_dim
        if d == 0:
            return np.array([0]), np.zeros((0, 1), dtype=int)
        if d == 1:
            i, j = int(np.argmin(Z[:, 0])), int(np.argmax(Z[:, 0]))
            return np.array([i, j]), np.array([[0], [1]])
        if d == 2:
            idx = _hull_2d(Z)
            M = idx.size
            return idx, np.stack([np.arange(M), (np.arange(M) + 1) % M], axis=1)
        from scipy.spatial import ConvexHull

        hull = ConvexHull(Z, qhull_options="Qt")
        keep = hull.vertices
        remap = np.full(Z.shape[0], -1)
        remap[keep] = np.arange(keep.size)
        self._hull_equations = hull.equations
        self._hull_neighbors = hull.neighbors
        return keep, remap[hull.simplices]

    @classmethod
    def _from_triangulation(
        cls, points, triangles, faces, *, atol: float | None = None, volume=None, centroid=None
    ) -> Polytope | None:
        """A 3-D solid whose boundary is already known, without Qhull (the exact MMV walk).

        ``points (V, 3)`` are all vertices; ``triangles (T, 3)`` index them, counter-clockwise seen
        from outside, and tile the boundary; ``faces (T,)`` says which planar facet each belongs
        to. Each facet's plane comes from its summed triangle areas (Newell's normal), so the
        triangles of one facet share it exactly and merge as Qhull's coplanar ones do.
        ``volume`` and ``centroid``, when given, are the solid's (the walk sums the same
        tetrahedra of the same triangles) and are not summed again. Returns None when the points
        are not full-dimensional at ``atol`` (a sliver thinner than the tolerance).
        """
        P = float_array(points, "points", GeometryError, copy=True)
        S = np.asarray(triangles, dtype=np.intp)
        obj = _Triangulated.__new__(_Triangulated)
        obj.ambient_dim = P.shape[1]
        span = float(np.ptp(P, axis=0).max())
        obj.atol = float(atol) if atol is not None else AFFINE * max(span, 1e-300)
        obj._o, obj._B = _affine_hull(P, obj.atol)
        obj.affine_dim = obj._B.shape[1]
        if obj.affine_dim != 3 or obj.ambient_dim != 3:
            return None  # flat at atol: the caller builds it another way
        Z = (P - obj._o) @ obj._B
        if _det3(obj._B[None])[0] < 0:  # the SVD frame is a reflection: keep triangles outward
            S = S[:, ::-1]
        faces = np.asarray(faces)
        if faces.size > 1 and np.any(faces[1:] < faces[:-1]):  # the walk emits them in face order
            order = np.argsort(faces, kind="stable")
            S, faces = S[order], faces[order]
        obj._faces = faces
        obj._keep = np.arange(P.shape[0])
        obj.vertices = P
        obj.vertices.flags.writeable = False
        obj._Z = Z
        obj._simplices = S
        obj._volume = None if volume is None else float(volume)
        if centroid is not None:
            obj.__dict__["centroid"] = np.array(centroid, dtype=np.float64).reshape(3)
        return obj

    @classmethod
    def from_halfspaces(cls, A, b, *, atol: float | None = None) -> Polytope:
        """The polytope ``{y : A y ≤ b}`` (A of shape (F, m), b of shape (F,)); may be empty."""
        return cls(halfspaces=(A, b), atol=atol)

    def __repr__(self) -> str:
        return (
            f"Polytope(affine_dim={self.affine_dim}, ambient_dim={self.ambient_dim}, "
            f"n_vertices={len(self.vertices)})"
        )

    # -- facets ---------------------------------------------------------------------------------

    @cached_property
    def _facets_sub(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Merged facets inside the affine hull.

        Returns normals (F, d) (unit, outward), offsets (F,) and, for every boundary simplex
        (row of ``_simplices``), the index of the merged facet it belongs to (T,).
        """
        d, Z = self.affine_dim, self._Z
        if d <= 0:
            return np.zeros((0, max(d, 0))), np.zeros(0), np.zeros(0, dtype=int)
        if d == 1:
            return np.array([[-1.0], [1.0]]), np.array([-Z[0, 0], Z[1, 0]]), np.array([0, 1])
        S = self._simplices
        if d == 2:
            e = Z[S[:, 1]] - Z[S[:, 0]]
            n = np.stack([e[:, 1], -e[:, 0]], axis=1)  # outward for a CCW polygon
            n /= np.linalg.norm(n, axis=1, keepdims=True)
            return n, np.einsum("ij,ij->i", n, Z[S[:, 0]]), np.arange(S.shape[0])
        from scipy.sparse import coo_matrix
        from scipy.sparse.csgraph import connected_components

        eq = self._hull_equations
        n, off = eq[:, :-1], -eq[:, -1]
        T = n.shape[0]
        nb = self._hull_neighbors
        rows = np.repeat(np.arange(T), nb.shape[1])
        cols = nb.ravel()
        same = (np.einsum("ij,ij->i", n[rows], n[cols]) > 1.0 - ANGLE) & (
            np.abs(off[rows] - off[cols]) <= self.atol
        )
        if same.any():
            graph = coo_matrix((np.ones(int(same.sum())), (rows[same], cols[same])), shape=(T, T))
            ncomp, label = connected_components(graph, directed=False)
        else:  # nothing coplanar to merge: every simplex is its own facet
            ncomp, label = T, np.arange(T)
        normals = np.zeros((ncomp, d))
        np.add.at(normals, label, n)
        normals /= np.linalg.norm(normals, axis=1, keepdims=True)
        tri_max = np.einsum("tvd,td->tv", Z[S], normals[label]).max(axis=1)
        offsets = np.full(ncomp, -np.inf)
        np.maximum.at(offsets, label, tri_max)
        return normals, offsets, label

    @property
    def n_facets(self) -> int:
        """Number of merged facets (of the polytope inside its affine hull)."""
        return int(self._facets_sub[0].shape[0])

    @cached_property
    def halfspaces(self) -> tuple[np.ndarray, np.ndarray]:
        """H-representation ``A y ≤ b`` with unit rows and coplanar facets merged.

        Returns
        -------
        A : ndarray of shape (F, m)
        b : ndarray of shape (F,)
            For ``affine_dim`` < m the first rows are the facets inside the affine hull, followed by
            ± rows of the hull's equations (so ``A y ≤ b`` is exactly the polytope).
        """
        m = self.ambient_dim
        if self.affine_dim < 0:
            e = np.eye(m)[:1]
            return np.concatenate([e, -e]), np.array([-1.0, -1.0])  # y_0 ≤ -1 and y_0 ≥ 1
        ns, offs, _ = self._facets_sub
        A = ns @ self._B.T
        b = offs + A @ self._o
        if self.affine_dim < m:
            C = _complement(self._B)
            A = np.concatenate([A, C, -C])
            b = np.concatenate([b, C @ self._o, -(C @ self._o)])
        return A, b

    @property
    def affine_hull(self) -> tuple[np.ndarray, np.ndarray]:
        """``(origin (m,), basis (m, affine_dim))``: the affine hull is ``origin + basis @ z``."""
        return self._o.copy(), self._B.copy()

    # -- measures -------------------------------------------------------------------------------

    @cached_property
    def _simplex_measures(self) -> tuple[np.ndarray, np.ndarray]:
        """Measures (T,) and centroids (T, d) of a decomposition into d-simplices (in the hull)."""
        d, Z = self.affine_dim, self._Z
        if d < 1:
            return np.zeros(0), np.zeros((0, max(d, 0)))
        c = Z.mean(axis=0)
        S = self._simplices
        if d == 1:
            return np.array([abs(Z[1, 0] - Z[0, 0])]), np.array([0.5 * (Z[0] + Z[1])])
        ZS = Z.take(S.ravel(), axis=0).reshape(S.shape[0], d, d)  # (T, d, d): each boundary simplex
        E = ZS - c  # ... with the interior point c
        det = _det3(E) if d == 3 else np.linalg.det(E)
        meas = np.abs(det) / float(np.prod(np.arange(1, d + 1)))
        cents = (c + sum(ZS[:, i] for i in range(d))) / (d + 1)
        return meas, cents

    @property
    def volume(self) -> float:
        """Exact m-dimensional volume (0 when ``affine_dim`` < ``ambient_dim``)."""
        if self.affine_dim < self.ambient_dim:
            return 0.0
        return float(self._simplex_measures[0].sum())

    @property
    def measure(self) -> float:
        """Exact ``affine_dim``-dimensional measure: volume, area, length, or 1 for a point (0 if empty)."""
        if self.affine_dim < 0:
            return 0.0
        if self.affine_dim == 0:
            return 1.0
        return float(self._simplex_measures[0].sum())

    @cached_property
    def centroid(self) -> np.ndarray:
        """Exact centroid of the ``affine_dim``-dimensional measure, ndarray of shape (m,).

        Volume centroid for solids (tetrahedral decomposition), area centroid for polygons,
        midpoint for segments, the point itself for a point.
        """
        if self.affine_dim < 0:
            raise GeometryError("the polytope is empty; it has no centroid.")
        if self.affine_dim == 0:
            return self.vertices[0].copy()
        meas, cents = self._simplex_measures
        z = (meas[:, None] * cents).sum(axis=0) / meas.sum()
        return self._o + self._B @ z

    @property
    def diameter(self) -> float:
        """Largest distance between two vertices."""
        V = self.vertices
        if V.shape[0] < 2:
            return 0.0
        best = 0.0
        for s in range(0, V.shape[0], 512):
            D = np.linalg.norm(V[s : s + 512, None, :] - V[None], axis=-1)
            best = max(best, float(D.max()))
        return best

    def chebyshev_center(self, *, return_radius: bool = False):
        """Centre of the largest ball inside the polytope, within its affine hull.

        Parameters
        ----------
        return_radius : bool
            Also return the radius.

        Returns
        -------
        center : ndarray of shape (m,)
        radius : float
            Only with ``return_radius=True``; 0 for a point.
        """
        if self.affine_dim < 0:
            raise GeometryError("the polytope is empty; it has no Chebyshev centre.")
        if self.affine_dim == 0:
            out = self.vertices[0].copy(), 0.0
        else:
            from scipy.optimize import linprog

            ns, offs, _ = self._facets_sub
            d = self.affine_dim
            cost = np.zeros(d + 1)
            cost[-1] = -1.0
            res = linprog(
                cost,
                A_ub=np.hstack([ns, np.ones((ns.shape[0], 1))]),
                b_ub=offs,
                bounds=[(None, None)] * d + [(0, None)],
                method="highs",
            )
            if res.status != 0:  # pragma: no cover - bounded nonempty polytope
                raise GeometryError(f"Chebyshev-centre LP failed: {res.message}")
            out = self._o + self._B @ res.x[:d], float(res.x[-1])
        return out if return_radius else out[0]

    # -- queries --------------------------------------------------------------------------------

    def contains(self, points, atol: float | None = None) -> np.ndarray:
        """Whether each point lies in the polytope (within ``atol``), vectorised.

        Parameters
        ----------
        points : array_like of shape (..., m)
        atol : float, optional
            Absolute slack (the points' units); default the polytope's ``atol``.

        Returns
        -------
        ndarray of bool, shape (...)
        """
        P = self._check_points(points)
        atol = self.atol if atol is None else float(atol)
        A, b = self.halfspaces
        flat = P.reshape(-1, self.ambient_dim)
        out = np.empty(flat.shape[0], dtype=bool)
        for s in range(0, flat.shape[0], 4096):
            out[s : s + 4096] = (flat[s : s + 4096] @ A.T - b).max(axis=1, initial=-np.inf) <= atol
        return out.reshape(P.shape[:-1])

    def _check_points(self, points) -> np.ndarray:
        P = float_array(points, "points", GeometryError)
        if P.shape[-1:] != (self.ambient_dim,):
            raise GeometryError(f"points must have shape (..., {self.ambient_dim}); got {P.shape}.")
        if not np.all(np.isfinite(P)):
            raise GeometryError("points contain NaN or inf.")
        return P

    def project(self, points, metric=None) -> np.ndarray:
        """Nearest point of the polytope to each point.

        Parameters
        ----------
        points : array_like of shape (..., m)
        metric : array_like of shape (m, m), optional
            Symmetric positive-definite W: minimise ``(y − p)ᵀ W (y − p)``; default identity.

        Returns
        -------
        ndarray of shape (..., m)
            Points already inside are returned unchanged.

        Notes
        -----
        With W = L Lᵀ (Cholesky) the problem is Euclidean in ``z = Lᵀ y``; inside the affine
        hull (origin o, basis B) it is Euclidean for the metric ``M = Bᵀ W B``, so the point is
        first moved to its W-closest point of the hull, then projected onto the polytope by the
        closest point over the boundary simplices (triangles, edges or the segment).
        """
        P = self._check_points(points)
        if self.affine_dim < 0:
            raise GeometryError("cannot project onto an empty polytope.")
        m = self.ambient_dim
        W = np.eye(m) if metric is None else np.asarray(metric, dtype=np.float64)
        if W.shape != (m, m) or not np.allclose(W, W.T):
            raise GeometryError(f"metric must be a symmetric ({m}, {m}) matrix; got shape {W.shape}.")
        flat = P.reshape(-1, m)
        if self.affine_dim == 0:
            return np.broadcast_to(self.vertices[0], P.shape).copy()
        B, o = self._B, self._o
        M = B.T @ W @ B
        try:
            L = np.linalg.cholesky(M)  # M = L Lᵀ, coordinates s = Lᵀ z
            np.linalg.cholesky(W)
        except np.linalg.LinAlgError as error:
            raise GeometryError("metric must be positive definite.") from error
        # unconstrained minimiser in the hull: z* = M⁻¹ Bᵀ W (p − o)
        zstar = np.linalg.solve(M, B.T @ W @ (flat - o).T).T
        S = zstar @ L  # (N, d) Euclidean coordinates
        V = self._Z @ L
        if self.affine_dim == 1:
            lo, hi = np.sort(V[:, 0])
            out = np.clip(S, lo, hi)
        else:
            out = S.copy()
            if self.affine_dim == 2:
                simp = np.stack(
                    [np.zeros(len(V) - 2, int), np.arange(1, len(V) - 1), np.arange(2, len(V))], axis=1
                )
                out = _closest_on_triangles(S, V[simp])
            elif self.affine_dim == 3:
                inside = self.contains(flat) if self.affine_dim == m else np.zeros(len(flat), bool)
                if self.affine_dim < m:
                    ns, offs, _ = self._facets_sub
                    zin = np.linalg.solve(L.T, S.T).T
                    inside = (zin @ ns.T - offs).max(axis=1) <= self.atol
                out[~inside] = _closest_on_triangles(S[~inside], V[self._simplices])
            else:
                raise GeometryError(
                    f"project supports polytopes of dimension ≤ 3 (affine_dim={self.affine_dim})."
                )
        z = np.linalg.solve(L.T, out.T).T
        res = o + z @ B.T
        keep = self.contains(flat)
        res[keep] = flat[keep]  # inside: unchanged, bit for bit
        return res.reshape(P.shape)

    def intersect(self, other: Polytope, *, atol: float | None = None) -> Polytope:
        """Intersection with another polytope of the same ambient dimension (may be empty)."""
        if not isinstance(other, Polytope) or other.ambient_dim != self.ambient_dim:
            raise GeometryError("intersect needs a Polytope of the same ambient dimension.")
        A1, b1 = self.halfspaces
        A2, b2 = other.halfspaces
        t = atol if atol is not None else max(self.atol, other.atol)
        return Polytope(halfspaces=(np.concatenate([A1, A2]), np.concatenate([b1, b2])), atol=t)

    # -- conversions ----------------------------------------------------------------------------

    def triangles(self) -> tuple[np.ndarray, np.ndarray]:
        """Triangulated boundary (3-D) or polygon (2-D): ``(vertices (V, 3), faces (F, 3))``.

        For a solid the faces are outward CCW. Segments and points have no faces (F = 0).
        """
        if self.ambient_dim != 3:
            raise GeometryError("triangles are defined for polytopes in 3-D space.")
        V = self.vertices
        if self.affine_dim == 3:
            F = self._simplices.copy()
            P = V[F]
            nrm = np.cross(P[:, 1] - P[:, 0], P[:, 2] - P[:, 0])
            flip = np.einsum("ij,ij->i", nrm, P[:, 0] - self.centroid) < 0
            F[flip] = F[flip][:, ::-1]
            return V, F
        if self.affine_dim == 2:
            M = len(V)
            return V, np.stack([np.zeros(M - 2, int), np.arange(1, M - 1), np.arange(2, M)], axis=1)
        return V, np.zeros((0, 3), dtype=int)

    def to_trimesh(self):
        """:class:`trimesh.Trimesh` of the boundary (watertight for solids; faceless if affine_dim < 2)."""
        import trimesh

        V, F = self.triangles()
        return trimesh.Trimesh(vertices=V, faces=F, process=False)

    def to_pyvista(self):
        """:class:`pyvista.PolyData`: surface (3-D), polygon (2-D), line (1-D) or vertex (0-D)."""
        import pyvista as pv

        V, F = self.triangles()
        if self.affine_dim >= 2:
            return pv.PolyData(V, np.hstack([np.full((F.shape[0], 1), 3), F]).ravel())
        if self.affine_dim == 1:
            return pv.PolyData(V, lines=np.array([2, 0, 1]))
        return pv.PolyData(V)

    def to_manifold(self):
        """:class:`manifold3d.Manifold` of a 3-D solid (float64 mesh) for booleans."""
        if self.affine_dim != 3 or self.ambient_dim != 3:
            raise GeometryError(
                f"to_manifold needs a solid in 3-D space (affine_dim={self.affine_dim}); flat polytopes "
                "have no volume for booleans. Use Polytope.intersect instead."
            )
        import manifold3d as m3d

        V, F = self.triangles()
        mesh = m3d.Mesh64(
            vert_properties=np.array(V, dtype=np.float64, order="C"),
            tri_verts=np.array(F, dtype=np.uint64, order="C"),
        )
        return m3d.Manifold(mesh)

    @classmethod
    def from_manifold(cls, manifold, *, atol: float | None = None) -> Polytope:
        """Convex hull of the vertices of a :class:`manifold3d.Manifold`."""
        mesh = manifold.to_mesh64() if hasattr(manifold, "to_mesh64") else manifold.to_mesh()
        V = np.asarray(mesh.vert_properties, dtype=np.float64)[:, :3]
        return cls(V if V.size else np.zeros((0, 3)), atol=atol)


def _complement(B: np.ndarray) -> np.ndarray:
    """Orthonormal rows spanning the orthogonal complement of the columns of B (m, d)."""
    m, d = B.shape
    if d == 0:
        return np.eye(m)
    Q, _ = np.linalg.qr(np.hstack([B, np.eye(m)]))
    return Q[:, d:m].T.copy()


def _closest_on_triangles(S: np.ndarray, T: np.ndarray) -> np.ndarray:
    """Closest point to each S (N, d) over the triangles T (F, 3, d), any d ≥ 2.

    Candidates per triangle: the orthogonal projection onto its plane when it falls inside
    (barycentric test), and the clamped projections onto its three edges.
    """
    out = np.empty_like(S)
    a, b, c = T[:, 0], T[:, 1], T[:, 2]
    ab, ac = b - a, c - a
    g11, g12, g22 = (ab * ab).sum(-1), (ab * ac).sum(-1), (ac * ac).sum(-1)
    det = g11 * g22 - g12 * g12
    step = max(1, 1_000_000 // max(T.shape[0], 1))
    for s in range(0, S.shape[0], step):
        p = S[s : s + step][:, None, :]  # (n, 1, d)
        ap = p - a
        r1, r2 = (ap * ab).sum(-1), (ap * ac).sum(-1)
        with np.errstate(divide="ignore", invalid="ignore"):
            v = np.where(det > 0, (g22 * r1 - g12 * r2) / det, -1.0)
            w = np.where(det > 0, (g11 * r2 - g12 * r1) / det, -1.0)
        q = a + v[..., None] * ab + w[..., None] * ac
        inside = (v >= 0) & (w >= 0) & (v + w <= 1)
        cands = [q]
        dists = [np.where(inside, ((q - p) ** 2).sum(-1), np.inf)]
        for u0, u1 in ((a, b), (a, c), (b, c)):
            e = u1 - u0
            ee = (e * e).sum(-1)
            t = np.clip(((p - u0) * e).sum(-1) / np.where(ee > 0, ee, 1.0), 0.0, 1.0)
            cq = u0 + t[..., None] * e
            cands.append(cq)
            dists.append(((cq - p) ** 2).sum(-1))
        D = np.stack(dists, axis=1)  # (n, 4, F)
        best = np.argmin(D.reshape(D.shape[0], -1), axis=1)
        kind, tri = np.divmod(best, D.shape[2])
        C = np.stack(cands, axis=0)  # (4, n, F, d)
        out[s : s + p.shape[0]] = C[kind, np.arange(p.shape[0]), tri]
    return out


def _halfspace_intersection(A: np.ndarray, b: np.ndarray, centre: np.ndarray) -> np.ndarray:
    """Vertices of {y : A y ≤ b} (unit rows) around a strictly interior ``centre`` (Qhull).

    Qhull's precision is relative to its (dual) coordinates, so the problem is first moved to the
    centre and scaled to unit size: tiny polytopes (an MMV of a response on the solid's boundary
    is ~1e-8 across) would otherwise fail its "feasible point is clearly inside" check.
    """
    from scipy.spatial import HalfspaceIntersection, QhullError

    margin = b - A @ centre
    s = float(margin.max())
    try:
        V = HalfspaceIntersection(np.hstack([A, -(margin / s)[:, None]]), np.zeros(A.shape[1])).intersections
    except QhullError as error:
        first = str(error).splitlines()[0]
        raise GeometryError(f"half-space intersection failed (Qhull: {first}).") from error
    if not np.all(np.isfinite(V)):
        raise GeometryError("the half-spaces do not bound a polytope (unbounded region).")
    return centre + s * V


def _vertices_from_halfspaces(
    A: np.ndarray, b: np.ndarray, atol: float | None, interior: np.ndarray | None = None
) -> np.ndarray:
    """Vertices of the bounded polytope {y : A y ≤ b} (possibly empty or lower-dimensional).

    ``interior`` (m,), optional: a point known to be well inside (e.g. the centroid of an inner
    approximation); when every constraint holds there with margin, the Chebyshev LP is skipped.
    """
    if A.ndim != 2 or b.shape != (A.shape[0],):
        raise GeometryError(f"halfspaces must be A (F, m) and b (F,); got {A.shape} and {b.shape}.")
    if not (np.all(np.isfinite(A)) and np.all(np.isfinite(b))):
        raise GeometryError("halfspaces contain NaN or inf.")
    m = A.shape[1]
    norms = np.linalg.norm(A, axis=1)
    if np.any(norms == 0):
        if np.any(b[norms == 0] < 0):
            return np.zeros((0, m))
        A, b, norms = A[norms > 0], b[norms > 0], norms[norms > 0]
    A, b = A / norms[:, None], b / norms
    scale = max(float(np.abs(b).max()), 1.0)
    t = atol if atol is not None else AFFINE * scale
    if interior is not None and m >= 2 and float((b - A @ interior).min()) > 10 * t:
        return _halfspace_intersection(A, b, np.asarray(interior, dtype=np.float64))
    from scipy.optimize import linprog

    cost = np.zeros(m + 1)
    cost[-1] = -1.0
    res = linprog(
        cost,
        A_ub=np.hstack([A, np.ones((A.shape[0], 1))]),
        b_ub=b,
        bounds=[(None, None)] * m + [(0, None)],
        method="highs",
    )
    if res.status == 2:
        return np.zeros((0, m))
    if res.status == 3:
        raise GeometryError("the half-spaces do not bound a polytope (unbounded region).")
    if res.status != 0:  # pragma: no cover
        raise GeometryError(f"Chebyshev LP failed: {res.message}")
    centre, radius = res.x[:m], res.x[-1]
    if radius > 10 * t and m >= 2:
        return _halfspace_intersection(A, b, centre)
    # thin or lower-dimensional: enumerate the vertices (m-subsets of rows)
    from itertools import combinations

    if A.shape[0] > 400:
        raise GeometryError(f"a flat intersection of {A.shape[0]} half-spaces is too large to enumerate.")
    combos = np.array(list(combinations(range(A.shape[0]), m)), dtype=int)
    pts = []
    for s in range(0, len(combos), 200_000):
        cb = combos[s : s + 200_000]
        M = A[cb]
        ok = np.abs(np.linalg.det(M)) > SINGULAR
        y = np.linalg.solve(M[ok], b[cb[ok]][..., None])[..., 0]
        feas = (y @ A.T - b).max(axis=1) <= t
        pts.append(y[feas])
    V = np.concatenate(pts) if pts else np.zeros((0, m))
    if V.shape[0] == 0 and radius >= 0:
        # feasible but no vertex found numerically: fall back to the Chebyshev centre
        return centre[None]
    return V


class _Triangulated(Polytope):
    """A :class:`Polytope` built by :meth:`Polytope._from_triangulation` (the exact MMV walk).

    Its facet planes and triangle neighbours (what Qhull would give) are computed on first use:
    volume and centroid, all an MMV batch or Centroid estimate asks, need neither.
    """

    @cached_property
    def _tri_facets(self) -> tuple[np.ndarray, np.ndarray]:
        """(equations (T, 4), neighbours (T, 3)) in Qhull's conventions, from the triangulation.

        Each facet's plane comes from its summed triangle areas (Newell's normal), so the
        triangles of one facet share it exactly and merge as Qhull's coplanar ones do.
        """
        Z, S, faces = self._Z, self._simplices, self._faces
        area = np.cross(Z[S[:, 1]] - Z[S[:, 0]], Z[S[:, 2]] - Z[S[:, 0]])
        start = np.flatnonzero(np.r_[True, faces[1:] != faces[:-1]])
        label = np.cumsum(np.r_[False, faces[1:] != faces[:-1]])
        n = np.add.reduceat(area, start, axis=0)
        n /= np.linalg.norm(n, axis=1, keepdims=True)
        off = np.maximum.reduceat(np.einsum("tvd,td->tv", Z[S], n[label]).max(axis=1), start)
        # neighbours (Qhull's convention: row t, column j = the triangle across the edge opposite
        # vertex j), from the two directed copies of each edge
        T = S.shape[0]
        a, b = np.roll(S, -1, axis=1).ravel(), np.roll(S, -2, axis=1).ravel()  # edge opposite j
        V = Z.shape[0]
        fwd, back = a * V + b, b * V + a
        order = np.argsort(fwd)
        pos = np.searchsorted(fwd[order], back)
        neighbours = (order[np.minimum(pos, order.size - 1)] // 3).reshape(T, 3)
        return np.column_stack([n[label], -off[label]]), neighbours

    @property
    def volume(self) -> float:
        """Exact volume (see :attr:`Polytope.volume`)."""
        return self._volume if self._volume is not None else super().volume

    @property
    def measure(self) -> float:
        """Exact volume (the solid is full-dimensional)."""
        return self.volume

    @property
    def _hull_equations(self) -> np.ndarray:
        return self._tri_facets[0]

    @property
    def _hull_neighbors(self) -> np.ndarray:
        return self._tri_facets[1]
