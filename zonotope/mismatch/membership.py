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
with few wavelengths or channels (C(n, d − 1) small).

The fast way is :func:`mmv_distance` / :func:`outside_mmv_fraction`: one small compiled
bounded-variable simplex per pair (k + m rows), which also says *how far* outside an estimate
lies: the L1 distance from y to MMV(c), min Σ_i |(Ψᵀx)_i − y_i| over Φᵀx = c, 0 ≤ x ≤ 1. Measured
(benchmarks/bench_membership.py, same setting, same process): ~40 µs per pair against ~3 ms per
pair for the HiGHS LP (about 80×), agreeing with it to 1e-15.
"""

from __future__ import annotations

import math
from itertools import combinations

import numpy as np

from .._errors import GeometryError, float_array
from .._tol import HYPERPLANE_RANK, PHASE1, TOL

__all__ = ["joint_halfspaces", "mmv_contains", "mmv_distance", "outside_mmv_fraction", "solid_distance"]


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
    G = float_array(generators, "generators", GeometryError)
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
    ok = s[:, -1] > HYPERPLANE_RANK * max(scale, 1e-300)  # the subset spans a hyperplane
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
    Phi = float_array(Phi, "Phi", GeometryError)
    Psi = float_array(Psi, "Psi", GeometryError)
    if Phi.ndim != 2 or Psi.ndim != 2 or Phi.shape[0] != Psi.shape[0]:
        raise GeometryError(f"Phi (n, k) and Psi (n, m) need the same n; got {Phi.shape} and {Psi.shape}.")
    c = float_array(responses, "responses", GeometryError)
    y = float_array(targets, "targets", GeometryError)
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


def _pairs(Phi, Psi, responses, targets):
    Phi = np.ascontiguousarray(getattr(Phi, "values", Phi), dtype=np.float64)
    Psi = np.ascontiguousarray(getattr(Psi, "values", Psi), dtype=np.float64)
    if Phi.ndim != 2 or Psi.ndim != 2 or Phi.shape[0] != Psi.shape[0]:
        raise GeometryError(f"Phi (n, k) and Psi (n, m) need the same n; got {Phi.shape} and {Psi.shape}.")
    if not (np.all(np.isfinite(Phi)) and np.all(np.isfinite(Psi))):
        raise GeometryError("Phi or Psi contains NaN or inf; check the spectral data.")
    c = float_array(responses, "responses", GeometryError)
    y = float_array(targets, "targets", GeometryError)
    k, m = Phi.shape[1], Psi.shape[1]
    if c.shape[-1:] != (k,) or y.shape[-1:] != (m,) or c.shape[:-1] != y.shape[:-1]:
        raise GeometryError(
            f"responses (..., {k}) and targets (..., {m}) must share their leading shape; "
            f"got {c.shape} and {y.shape}."
        )
    if not (np.all(np.isfinite(c)) and np.all(np.isfinite(y))):
        raise GeometryError("responses or targets contain NaN or inf.")
    return Phi, Psi, c, y


def mmv_distance(Phi, Psi, responses, targets) -> np.ndarray:
    """L1 distance from each target response to the metamer mismatch volume of its source response.

    ``d(c, y) = min Σ_i |(Ψᵀx)_i − y_i|`` over reflectances with ``Φᵀx = c``, ``0 ≤ x ≤ 1``: 0 when
    ``y ∈ MMV(c)`` (some reflectance gives both responses), else how far, in target units, ``y``
    lies outside. One compiled bounded-variable simplex per pair (k + m rows; numba, see
    :mod:`zonotope.mismatch.walk`), exact to round-off: the LP's optimum, which the tests check
    against scipy-HiGHS.

    Parameters
    ----------
    Phi : array_like of shape (n, k)
        Source generators.
    Psi : array_like of shape (n, m)
        Target generators.
    responses : array_like of shape (..., k)
    targets : array_like of shape (..., m)

    Returns
    -------
    ndarray of shape (...)
        Distances ≥ 0; NaN where the source response itself is not feasible (outside the source
        object-colour solid by more than 1e-9 of its scale: the MMV is empty).

    Raises
    ------
    GeometryError
        Shapes that do not match, NaN/inf input.

    Examples
    --------
    >>> import numpy as np, zonotope
    >>> grid = np.arange(400, 701, 10.0)
    >>> Phi = zonotope.generators("Nikon 5100 (NPL)", shape=grid).values
    >>> Psi = zonotope.generators("Stockman & Sharpe 2°", shape=grid).values
    >>> x = np.full(31, 0.5)
    >>> d = mmv_distance(Phi, Psi, [x @ Phi, x @ Phi], [x @ Psi, x @ Psi + 0.2])
    >>> float(d[0]), bool(d[1] > 0.1)
    (0.0, True)
    """
    from .walk_kernel import l1_distances

    Phi, Psi, c, y = _pairs(Phi, Psi, responses, targets)
    k, m = Phi.shape[1], Psi.shape[1]
    lead = c.shape[:-1]
    scale = max(float(np.abs(Phi).sum(axis=0).max()), 1.0)
    C, Y = np.ascontiguousarray(c.reshape(-1, k)), np.ascontiguousarray(y.reshape(-1, m))
    d, status = l1_distances(Phi, Psi, C, Y, PHASE1 * scale)
    if np.any(status != 0):  # pragma: no cover - pivot limit (cycling): the HiGHS twin answers
        from scipy.optimize import linprog

        n = Phi.shape[0]
        A = np.vstack([np.hstack([Phi.T, np.zeros((k, 2 * m))]), np.hstack([Psi.T, -np.eye(m), np.eye(m)])])
        for p in np.nonzero(status != 0)[0]:
            rhs = np.concatenate([c.reshape(-1, k)[p], y.reshape(-1, m)[p]])
            res = linprog(
                np.r_[np.zeros(n), np.ones(2 * m)],
                A_eq=A,
                b_eq=rhs,
                bounds=[(0, 1)] * n + [(0, None)] * (2 * m),
                method="highs",
            )
            d[p] = res.fun if res.status == 0 else np.nan
    return d.reshape(lead)


def solid_distance(Phi, responses) -> np.ndarray:
    """L1 distance from each response to the object-colour solid ``{Φᵀx : 0 ≤ x ≤ 1}``, exactly.

    ``min Σ_i |(Φᵀx)_i − c_i|`` over reflectances in [0, 1]: 0 when some reflectance gives ``c``,
    else how far outside it lies, in response units. For stacked cameras (``Φ = [Φ_A Φ_B]``) this
    says whether two cameras' responses can come from one surface: the joint solid holds every pair
    a reflectance can produce. It is :func:`mmv_distance` with an empty source (nothing fixed), one
    compiled bounded-variable simplex per response (k rows), so it works for any k and wavelength
    count, where the solid's facets (:func:`joint_halfspaces`) are too many to list.

    Parameters
    ----------
    Phi : array_like of shape (n, k)
    responses : array_like of shape (..., k)

    Returns
    -------
    ndarray of shape (...)
        Distances ≥ 0.

    Examples
    --------
    >>> import numpy as np, zonotope
    >>> grid = np.arange(400, 701, 10.0)
    >>> Phi = zonotope.generators("Nikon 5100 (NPL)", shape=grid).values
    >>> x = np.full(31, 0.5)
    >>> d = solid_distance(Phi, [x @ Phi, x @ Phi * [1.0, 1.0, 3.0]])
    >>> float(d[0]), bool(d[1] > 0.1)
    (0.0, True)
    """
    Phi = float_array(getattr(Phi, "values", Phi), "Phi", GeometryError)
    if Phi.ndim != 2:
        raise GeometryError(f"Phi must be (n, k); got shape {Phi.shape}.")
    c = float_array(responses, "responses", GeometryError)
    return mmv_distance(np.zeros((Phi.shape[0], 1)), Phi, np.zeros((*c.shape[:-1], 1)), c)


def outside_mmv_fraction(Phi, Psi, responses, estimates, *, atol: float | None = None) -> float:
    """Share of an estimator's outputs that no reflectance can produce together with its input.

    ``estimates[p]`` is physically impossible for ``responses[p]`` when it lies outside
    ``MMV(responses[p])``: no reflectance in [0, 1] gives both. This is the share of pairs whose
    :func:`mmv_distance` exceeds ``atol``.

    Parameters
    ----------
    Phi : array_like of shape (n, k)
    Psi : array_like of shape (n, m)
        Target generators, in the units of ``estimates`` (e.g. LMS or XYZ with the white at 1).
    responses : array_like of shape (..., k)
        Source responses the estimator was given.
    estimates : array_like of shape (..., m)
        Its answers.
    atol : float, optional
        L1 slack in target units; default :data:`zonotope._tol.TOL` ``.contains`` × the target
        scale (its largest white channel).

    Returns
    -------
    float
        Fraction in [0, 1] of the pairs with a feasible source response (NaN when there are
        none).

    Raises
    ------
    GeometryError
        Shapes that do not match, NaN/inf input.
    """
    Phi, Psi, c, y = _pairs(Phi, Psi, responses, estimates)
    slack = TOL.contains * float(np.abs(Psi).sum(axis=0).max()) if atol is None else float(atol)
    if not (np.isfinite(slack) and slack >= 0):
        raise GeometryError(f"atol must be a finite number ≥ 0; got {atol!r}.")
    d = mmv_distance(Phi, Psi, c, y).ravel()
    d = d[np.isfinite(d)]
    return float(np.mean(d > slack)) if d.size else float("nan")
