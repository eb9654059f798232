"""Reference linear programs (scipy HiGHS): distance of a response to a zonotope.

These are the slow, trusted twins of the fast geometry; tests compare against them.
"""

from __future__ import annotations

import numpy as np
from scipy.optimize import linprog
from scipy.sparse import csr_matrix, hstack, vstack

from .._errors import GeometryError

__all__ = ["distance_to_zonotope"]


def distance_to_zonotope(G: np.ndarray, offset: np.ndarray, point: np.ndarray):
    """Chebyshev (∞-norm) distance from ``point`` to {offset + xᵀG : 0 ≤ x ≤ 1}, by HiGHS.

    Solves ``min t  s.t.  |Gᵀx + offset − point| ≤ t,  0 ≤ x ≤ 1`` (one LP).

    Parameters
    ----------
    G : ndarray of shape (n, d)
    offset, point : ndarray of shape (d,)

    Returns
    -------
    distance : float
        0 when the point is inside (up to HiGHS' feasibility tolerance, ~1e-9).
    x : ndarray of shape (n,)
        A reflectance reaching the nearest response.
    """
    n, d = G.shape
    A = csr_matrix(G.T)
    ones = csr_matrix(np.ones((d, 1)))
    A_ub = vstack([hstack([A, -ones]), hstack([-A, -ones])]).tocsr()
    r = np.asarray(point, dtype=np.float64) - offset
    b_ub = np.concatenate([r, -r])
    c = np.zeros(n + 1)
    c[-1] = 1.0
    res = linprog(c, A_ub=A_ub, b_ub=b_ub, bounds=[(0, 1)] * n + [(0, None)], method="highs")
    if res.status != 0:  # pragma: no cover - HiGHS failing on a bounded feasible LP
        raise GeometryError(f"HiGHS failed on the distance LP: {res.message}")
    return float(max(res.x[-1], 0.0)), res.x[:n]
