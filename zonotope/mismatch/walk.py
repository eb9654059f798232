"""Exact 3-D metamer mismatch volumes by walking the normal fan of optimal bases (output-sensitive).

The MMV ``{Ψᵀx : Φᵀx = c, 0 ≤ x ≤ 1}`` is a *constrained zonotope*: the zonotope of the
generators Ψ cut by the k linear constraints Φᵀx = c. Fix an optimal basis of the support LP,
i.e. k "basic" variables B solving the constraints while every other variable sits at a bound.
Moving a non-basic variable j changes the response by its *edge vector*

    e_j = ψ_j − Ψ_Bᵀ Φ_B⁻ᵀ φ_j                      (the basic variables compensate),

so near the vertex y of that basis the MMV is the zonotope ``y + Σ_j t_j e_j`` with the bound
pattern as its corner: the basis is optimal exactly for the directions u with σ_j u·e_j ≥ 0
(σ_j = +1 at the upper bound, −1 at the lower), the *normal cone* of y. Its facets are the edges
of the MMV at y: the e_j whose central projections are vertices of a 2-D convex hull. Crossing
one is one simplex move (a bound flip of j, or a pivot where j enters and the first basic
variable to reach a bound leaves), which lands on the neighbouring vertex. A breadth-first walk
from one optimal basis therefore visits every vertex once, at O(n·k·m + n log n) per vertex and
no hull rebuilds: the cost follows the number of vertices.

The walk is exact only for non-degenerate bases. It gives up (``status`` ≠ 0; the caller then
uses facet refinement, :mod:`zonotope.mismatch.refine`) when a basic variable lies within 1e-12 of
its range from a bound (degenerate vertex: black, white, boundary responses, Ψ = Φ), when a normal
cone is not full-dimensional (a flat MMV, parallel edge vectors), or when the pivot limit is hit.

The kernels are compiled with numba on first use (cached on disk when the package directory is
writable) and release the GIL, so threads run walks of different responses in parallel.

References
----------
.. [1] Avis, D., & Fukuda, K. (1992). A pivoting algorithm for convex hulls and vertex enumeration
   of arrangements and polyhedra. Discrete Comput. Geom. 8, 295–313 (vertex enumeration by pivots).
.. [2] Scott, J. K., Raimondo, D. M., Marseglia, G. R., & Braatz, R. D. (2016). Constrained
   zonotopes: a new tool for set-based estimation and fault detection. Automatica 69, 126–136.
"""

from __future__ import annotations

import numpy as np

__all__ = ["STATUS", "WalkOracle", "walk_mmv", "walk_mmv_batch"]

#: Meaning of the walk's status codes.
STATUS = {
    0: "ok",
    1: "infeasible response",
    2: "degenerate phase 1 (an artificial variable stays basic: dependent source channels)",
    3: "pivot limit reached",
    4: "degenerate vertex (a basic variable at a bound)",
    5: "normal cone not full-dimensional (flat MMV or parallel edge vectors)",
    6: "target dimension other than 3",
    7: "hash collision",
    8: "vertex limit reached",
    9: "inconsistent vertex adjacency (faces could not be traced)",
}

_KERNEL = None
#: Zobrist hash keys of the basis states: one random 62-bit number per (variable, basic) and per
#: (variable, at upper bound); a state's key is the XOR of its numbers (checked in full on a hit).
_ZOBRIST = [np.zeros(0, dtype=np.int64), np.zeros(0, dtype=np.int64)]


def _kernel(batch: bool = False):
    global _KERNEL
    if _KERNEL is None:
        from . import walk_kernel as _mmv_walk_kernel

        _KERNEL = _mmv_walk_kernel
    return _KERNEL.walk_batch if batch else _KERNEL.walk


def _inputs(Phi, Psi, delta):
    """Kernel inputs (F, G, lo, hi, zb, zu): the generators with one slack variable per δ > 0."""
    Phi = np.ascontiguousarray(Phi, dtype=np.float64)
    Psi = np.ascontiguousarray(Psi, dtype=np.float64)
    n, k = Phi.shape
    d = np.broadcast_to(np.asarray(delta, dtype=np.float64), (k,))
    slack = np.nonzero(d > 0)[0]
    F = np.concatenate([Phi, np.eye(k)[slack]]) if slack.size else Phi
    G = np.concatenate([Psi, np.zeros((slack.size, 3))]) if slack.size else Psi
    lo = np.concatenate([np.zeros(n), -d[slack]])
    hi = np.concatenate([np.ones(n), d[slack]])
    N = F.shape[0]
    if _ZOBRIST[0].size < N:
        rng = np.random.default_rng(20261123)
        _ZOBRIST[:] = [rng.integers(1, 2**62, size=2 * N, dtype=np.int64) for _ in range(2)]
    return np.ascontiguousarray(F), np.ascontiguousarray(G), lo, hi, _ZOBRIST[0][:N], _ZOBRIST[1][:N]


def walk_mmv(Phi, Psi, c, delta=0.0, *, max_vertices: int = 200_000, triangles: bool = False):
    """Vertices of the 3-D MMV of one response by the normal-fan walk.

    Parameters
    ----------
    Phi : ndarray of shape (n, k)
    Psi : ndarray of shape (n, 3)
    c : ndarray of shape (k,)
    delta : float or ndarray of shape (k,)
        Per-channel tolerance |Φᵀx − c| ≤ δ (adds k slack variables with range [−δ, δ]).
    max_vertices : int
    triangles : bool
        Also return the boundary triangulation (see Returns).

    Returns
    -------
    vertices : ndarray of shape (V, 3)
        The MMV's vertices (every one once; empty when ``status`` ≠ 0).
    volume : float
        Volume, from the faces traced on the vertex graph (tetrahedra from the vertex mean).
    centroid : ndarray of shape (3,)
        Volume centroid.
    status : int
        0 on success, else a key of :data:`STATUS`.
    moves : int
        Simplex moves made (phase 1 and 2 pivots plus one per walked edge).
    tris : ndarray of int, shape (T, 4)
        Only with ``triangles=True``: the faces' fan triangles (vertex indices, counter-clockwise
        seen from outside) and the index of the face each belongs to.
    """
    c = np.ascontiguousarray(c, dtype=np.float64)
    if np.shape(Psi)[1] != 3:
        m = np.shape(Psi)[1]
        out = np.zeros((0, m)), 0.0, np.zeros(m), 6, 0
        return (*out, np.zeros((0, 4), dtype=np.int64)) if triangles else out
    F, G, lo, hi, zb, zu = _inputs(Phi, Psi, delta)
    Y, vol, cen, status, moves, tris = _kernel()(F, G, lo, hi, c, int(max_vertices), zb, zu)
    if triangles:
        return Y, float(vol), cen, int(status), int(moves), tris
    return Y, float(vol), cen, int(status), int(moves)


def walk_mmv_batch(Phi, Psi, C, delta=0.0, *, max_vertices: int = 200_000):
    """Volumes and centroids of the MMVs of many responses, one compiled call for all of them.

    The same walk as :func:`walk_mmv` (identical results), without the vertex lists and triangles and
    without the per-response Python overhead: what a batch of centroids needs.

    Parameters
    ----------
    Phi : ndarray of shape (n, k)
    Psi : ndarray of shape (n, 3)
    C : ndarray of shape (P, k)
    delta : float or ndarray of shape (k,)
    max_vertices : int

    Returns
    -------
    volumes : ndarray of shape (P,)
    centroids : ndarray of shape (P, 3)
    status : ndarray of int, shape (P,)
        0 where the walk succeeded, else a key of :data:`STATUS` (volume and centroid are then 0).
    moves : ndarray of int, shape (P,)
    """
    C = np.ascontiguousarray(C, dtype=np.float64).reshape(-1, np.shape(Phi)[1])
    P = C.shape[0]
    if np.shape(Psi)[1] != 3:
        m = np.shape(Psi)[1]
        return np.zeros(P), np.zeros((P, m)), np.full(P, 6, dtype=np.int64), np.zeros(P, dtype=np.int64)
    F, G, lo, hi, zb, zu = _inputs(Phi, Psi, delta)
    return _kernel(batch=True)(F, G, lo, hi, C, int(max_vertices), zb, zu)


class WalkOracle:
    """Support oracle of one MMV backed by its exact vertex list from :func:`walk_mmv`.

    The constructor walks the normal fan once; ``support`` is then the maximum over the vertices
    (exact). When the walk declines (``status`` not 0: degenerate or flat MMV, target not 3-D), a
    :class:`~zonotope.mismatch.oracle.SimplexOracle` answers instead, so the class is a full oracle
    either way.

    Parameters
    ----------
    Phi : ndarray of shape (n, k)
    Psi : ndarray of shape (n, m)
    c : ndarray of shape (k,)
    delta : float or ndarray of shape (k,)

    Attributes
    ----------
    vertices : ndarray of shape (V, m)
    volume : float
    centroid : ndarray of shape (m,)
    status : int
    moves : int
    triangles : ndarray of int, shape (T, 4)
        Boundary fan triangles and their face (see :func:`walk_mmv`).

    Raises
    ------
    Infeasible
        No reflectance meets the response within δ.
    """

    def __init__(self, Phi, Psi, c, delta=0.0) -> None:
        from .oracle import Infeasible, SimplexOracle, _as_delta

        d = _as_delta(delta, Phi.shape[1])
        out = walk_mmv(Phi, Psi, c, d, triangles=True)
        self.vertices, self.volume, self.centroid, self.status, self.moves, self.triangles = out
        if self.status == 1:
            raise Infeasible
        self.n_calls = 0
        self._fallback = None if self.status == 0 else SimplexOracle(Phi, Psi, c, d)

    def support(self, U, warm=None):
        """Support values (q,), points (q, m) and ids (q,) (vertex indices) for U (q, m)."""
        if self._fallback is not None:
            return self._fallback.support(U, warm)
        U = np.atleast_2d(np.asarray(U, dtype=np.float64))
        self.n_calls += len(U)
        H = U @ self.vertices.T
        ids = np.argmax(H, axis=1)
        return H[np.arange(len(U)), ids], self.vertices[ids], ids
