"""Batched exact membership in a metamer mismatch volume, without one LP per pair.

"Can the target respond ``y`` when the source recorded ``c``?" is ``y ∈ MMV(c)``, and
``MMV(c) = {Ψᵀx : Φᵀx = c, 0 ≤ x ≤ 1}``, so it holds exactly when ``(c, y)`` lies in the joint
zonotope of the stacked generators ``[Φ Ψ]`` (k + m channels). A d-zonotope's facets are parallel
to d − 1 independent generators, so its H-representation is ``u · z ≤ h(u)`` over the unit
normals u of all (d − 1)-subsets of generators that span a hyperplane, with the support function
``h(u) = Σ_λ max(0, u · g_λ)``. These rows are shared by every (c, y) pair: one matrix product
decides a whole batch.

Cost: 2·C(n, d − 1) rows, built once; then one (pairs × rows) product. Measured
(benchmarks/bench_membership.py, Nikon 5100 → LMS, 10 nm, 2026-11-23, shared 2-core machine):
339,822 half-spaces built in 2.7 s, then 7.1 ms per pair against 2.0 ms per pair for one HiGHS
feasibility LP — exact and in agreement with the LP, but *slower* at 6 joint channels on 31
wavelengths: every row is a true facet, so a dense test cannot beat the LP there. It pays off only
with few wavelengths or channels (C(n, d − 1) small); a pruned search over the normal fan is the
way to make it fast (not done).
"""

from __future__ import annotations

import math
from itertools import combinations

import numpy as np

from ._errors import GeometryError
from ._tol import TOL

__all__ = ["joint_halfspaces", "mmv_contains"]


def joint_halfspaces(generators, *, max_terms: int = 2_000_000) -> tuple[np.ndarray, np.ndarray]:
    """Exact H-representation ``A z ≤ b`` of the zonotope ``{xᵀG : x ∈ [0, 1]ⁿ}`` in any dimension.

    Parameters
    ----------
    generators : array_like of shape (n, d)
    max_terms : int
        Refuse when C(n, d − 1) exceeds it.

    Returns
    -------
    A : ndarray of shape (m, d)
        Unit normals, both signs (rows may repeat when generators are degenerate).
    b : ndarray of shape (m,)
    """
    G = np.asarray(generators, dtype=np.float64)
    if G.ndim != 2 or not np.all(np.isfinite(G)):
        raise GeometryError(f"generators must be a finite (n, d) array; got shape {G.shape}.")
    n, d = G.shape
    if d < 2:
        raise GeometryError(f"need at least 2 channels; got {d}.")
    terms = math.comb(n, d - 1)
    if terms > max_terms:
        raise GeometryError(
            f"C({n}, {d - 1}) = {terms:.3g} facet directions exceed "
            f"max_terms={max_terms:.3g}; "
            "use a coarser wavelength grid or raise max_terms."
        )
    idx = np.fromiter(combinations(range(n), d - 1), dtype=(np.intp, d - 1), count=terms)
    _, s, Vt = np.linalg.svd(G[idx], full_matrices=True)
    scale = np.abs(G).max()
    ok = s[:, -1] > 1e-10 * max(scale, 1e-300)  # the subset spans a hyperplane
    U = Vt[ok, -1, :]
    U = np.concatenate([U, -U])
    h = np.clip(U @ G.T, 0.0, None).sum(axis=1)
    return U, h


def mmv_contains(
    Phi,
    Psi,
    responses,
    targets,
    *,
    atol: float | None = None,
    halfspaces: tuple[np.ndarray, np.ndarray] | None = None,
) -> np.ndarray:
    """Whether each target response lies in the MMV of its source response, exactly.

    Parameters
    ----------
    Phi : array_like of shape (n, k)
        Source generators.
    Psi : array_like of shape (n, m)
        Target generators.
    responses : array_like of shape (..., k)
    targets : array_like of shape (..., m)
    atol : float, optional
        Absolute slack (response units); default ``TOL.contains`` × the joint solid's largest extent.
    halfspaces : (A, b), optional
        :func:`joint_halfspaces` of ``[Phi Psi]``, to reuse across calls.

    Returns
    -------
    ndarray of bool, shape (...)

    Notes
    -----
    Equivalent to "the LP max 0 s.t. Φᵀx = c, Ψᵀx = y, 0 ≤ x ≤ 1 is feasible" (the HiGHS twin in
    the tests), for all pairs at once.
    """
    Phi = np.asarray(Phi, dtype=np.float64)
    Psi = np.asarray(Psi, dtype=np.float64)
    if Phi.ndim != 2 or Psi.ndim != 2 or Phi.shape[0] != Psi.shape[0]:
        raise GeometryError(f"Phi (n, k) and Psi (n, m) need the same n; got {Phi.shape} and {Psi.shape}.")
    c = np.asarray(responses, dtype=np.float64)
    y = np.asarray(targets, dtype=np.float64)
    if c.shape[-1:] != (Phi.shape[1],) or y.shape[-1:] != (Psi.shape[1],) or c.shape[:-1] != y.shape[:-1]:
        raise GeometryError(
            f"responses (..., {Phi.shape[1]}) and targets (..., {Psi.shape[1]}) must share "
            f"their leading shape; got {c.shape} and {y.shape}."
        )
    if not (np.all(np.isfinite(c)) and np.all(np.isfinite(y))):
        raise GeometryError("responses or targets contain NaN or inf.")
    J = np.concatenate([Phi, Psi], axis=1)
    A, b = halfspaces if halfspaces is not None else joint_halfspaces(J)
    z = np.concatenate([c, y], axis=-1).reshape(-1, J.shape[1])
    slack = TOL.contains * float(np.abs(J).sum(axis=0).max()) if atol is None else float(atol)
    out = np.empty(z.shape[0], dtype=bool)
    step = max(1, 4_000_000 // max(A.shape[0], 1))
    for s in range(0, z.shape[0], step):
        out[s : s + step] = (z[s : s + step] @ A.T - b).max(axis=1) <= slack
    return out.reshape(c.shape[:-1])
