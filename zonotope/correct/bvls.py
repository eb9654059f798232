"""Many small bounded-variable least-squares problems at once: ``min ‖M x − r‖²``, ``0 ≤ x ≤ 1``.

:func:`box_lsq` solves N problems that share one matrix ``M (p, n)`` (or have one each,
``(N, p, n)``) with all rows advancing together in numpy, on the normal equations ``H x = q``
(``H = MᵀM``, ``q = Mᵀr``). Every iteration takes, for each row still running, the Newton step onto
the minimiser over its *free* variables with the others held at their bounds: one batched
``np.linalg.solve`` of the ``n × n`` systems whose fixed rows and columns are replaced by the
identity. The gradient ``g = Mᵀ(M x − r)`` is always evaluated from the residual, never as
``H x − q``, so a repeated step is an iterative refinement of the normal-equations solve.

1. **Primal–dual active set** (Hintermüller, Ito & Kunisch 2002, SIAM J. Optim. 13: a semismooth
   Newton method), warm-started from the unconstrained minimiser ``H⁻¹q``: after each step the sets
   are predicted anew, all at once (a free variable outside [0, 1] is fixed at the bound it crossed; a
   fixed one whose multiplier has the wrong sign is freed). Few iterations, but it may cycle when
   ``H`` is not an M-matrix, so it runs at most :data:`PDAS_STEPS` iterations.
2. **Primal active set** (Nocedal & Wright, *Numerical Optimization*, §16.5) for the rows left, from
   the clipped unconstrained minimiser: feasible iterates, a step is cut at the first bound it meets
   (which is then fixed), and at a free minimiser the fixed variable whose multiplier is most wrong is
   freed: one change per step, the objective never increases, no cycling (barring degeneracy).

A row stops when its sets no longer change and it meets the KKT conditions of the bounded problem to
:data:`zonotope._tol.BVLS_KKT`: ``0 ≤ x ≤ 1``; ``g_i ≥ −τ_i`` where ``x_i = 0``, ``g_i ≤ τ_i`` where
``x_i = 1``, ``|g_i| ≤ τ_i`` elsewhere, ``τ = BVLS_KKT · |M|ᵀ(|M| |x| + |r|)`` (relative to the size of
the terms summed in ``g``, the scale of its rounding error). Those are the conditions of *the*
minimiser (the problem is convex), so a returned row is exact, not an approximation that stopped
early.

Rows not settled within ``max_iter`` iterations, and problems whose ``H`` has a condition number
above :data:`zonotope._tol.BVLS_CONDITION` (normal equations too inaccurate; rank-deficient ``M``,
whose minimiser is not unique, among them), are solved one by one by
``scipy.optimize.lsq_linear(method="bvls")`` (Stark & Parker 1995), the per-row solver this module
replaces, with its TRF fallback: the result is never worse than that solver's.

Measured (``benchmarks/bench_correct.py --bvls 2000``, 2 shared cores): 2000 rows of a noisy Prior
MAP (three cameras' 9 whitened channels, 29 bands, σ_ref 0.002–0.01, rows the closed form does not
cover) in 0.036–0.047 s against 1.06–1.32 s for scipy's BVLS row by row (25–32×), within 6e-15 of its
answers; every row settled by the first phase within 5 iterations.
"""

from __future__ import annotations

import numpy as np

from .._errors import GeometryError, float_array
from .._tol import BVLS_CONDITION, BVLS_FALLBACK, BVLS_KKT

__all__ = ["BLOCK", "FIBER_PDAS_STEPS", "MAX_ITER", "PDAS_STEPS", "box_lsq", "fiber_box_lsq"]

#: Iterations of the primal–dual phase of :func:`box_lsq` before a row that has not converged moves
#: to the primal phase. On the Prior MAP of ``benchmarks/bench_correct.py --bvls`` (three cameras,
#: 9 channels, 1500 rows the closed form does not cover, σ = 0.002–0.01) every row converged within 5;
#: rows still running after 10 are (nearly all) cycling.
PDAS_STEPS = 10

#: Default cap on the iterations of both phases of :func:`box_lsq` together, after which a row falls
#: back to scipy's per-row BVLS. The primal phase changes one variable per step, so a row that starts
#: far from its active set needs up to about ``2n`` of them (n = 31 bands).
MAX_ITER = 100

#: Primal–dual iterations of :func:`fiber_box_lsq` before the primal phase takes the rows left, from
#: their last sets. On 600 exact-constraint Prior MAP rows (Nikon 5100, random responses up to 1.6× the
#: white that the closed form does not cover) 3 took 0.20 s, 5: 0.23 s, 10: 0.32 s (the rows left cycle).
FIBER_PDAS_STEPS = 3

#: Rows iterated together. Small blocks keep each matrix product (``BLOCK × p × n`` multiply-adds,
#: 1.6e5 for p = 40, n = 31) under OpenBLAS's threading threshold (2.6e5): on the shared 2-core
#: machine, a threaded product of 2000 such rows took 16 ms instead of 0.35 ms single-threaded, and
#: 8000 rows took 0.43 s in one block against 0.16 s in blocks of 128 (0.15–0.18 s for 64–256, and
#: the same 0.16 s with ``OPENBLAS_NUM_THREADS=1``).
BLOCK = 128


def box_lsq(M, r, *, max_iter: int = MAX_ITER) -> tuple[np.ndarray, np.ndarray]:
    """Solve ``min ‖M x − r_i‖²`` subject to ``0 ≤ x ≤ 1`` for every row ``r_i``, exactly.

    Parameters
    ----------
    M : ndarray of shape (p, n) or (N, p, n)
        One matrix shared by all problems, or one per problem.
    r : ndarray of shape (N, p)
    max_iter
        Iterations of the two batched phases together (the first takes at most :data:`PDAS_STEPS`)
        before a row that has not converged is handed to ``scipy.optimize.lsq_linear(method="bvls")``
        (0: every row is).

    Returns
    -------
    x : ndarray of shape (N, n)
        The minimisers, in [0, 1] (KKT conditions met to :data:`zonotope._tol.BVLS_KKT`, or scipy's
        answer for the rows in ``fallback``).
    fallback : ndarray of bool, shape (N,)
        Rows solved by scipy's per-row BVLS (iteration cap reached, or ``MᵀM`` ill-conditioned).

    Raises
    ------
    GeometryError
        ``M`` or ``r`` not of the shapes above, or not finite; ``max_iter`` negative.
    """
    M = float_array(M, "M", GeometryError)
    R = float_array(r, "r", GeometryError)
    if M.ndim not in (2, 3) or R.ndim != 2 or M.shape[-2] != R.shape[1] or (M.ndim == 3 and len(M) != len(R)):
        raise GeometryError(
            f"box_lsq: M must be (p, n) or (N, p, n) and r (N, p) with the same p (and N); got M {M.shape} "
            f"and r {R.shape}."
        )
    if not (np.all(np.isfinite(M)) and np.all(np.isfinite(R))):
        raise GeometryError("box_lsq: M or r contains NaN or inf; check the inputs.")
    if int(max_iter) != max_iter or max_iter < 0:
        raise GeometryError(f"box_lsq: max_iter={max_iter!r}; give an integer ≥ 0.")
    N, n = R.shape[0], M.shape[-1]
    x = np.zeros((N, n))
    fallback = np.ones(N, dtype=bool)
    if N == 0 or n == 0:
        return x, np.zeros(N, dtype=bool)
    H, rows = _gram_rows(M, N, max_iter)
    for i in range(0, rows.size, BLOCK):
        j = rows[i : i + BLOCK]
        if M.ndim == 2:
            x[j], ok = _solve_block(M, H, R[j], int(max_iter))
        else:
            x[j], ok = _solve_block(M[j], H[j], R[j], int(max_iter))
        fallback[j[ok]] = False
    for i in np.flatnonzero(fallback):
        x[i] = _scipy_bvls(M if M.ndim == 2 else M[i], R[i])
    return x, fallback


def _gram_rows(M: np.ndarray, N: int, max_iter: int) -> tuple[np.ndarray, np.ndarray]:
    """``MᵀM`` ((n, n) or (N, n, n)) and the rows the batched solvers take: those whose ``MᵀM`` is
    well conditioned (below :data:`BVLS_CONDITION`; a singular one never is), none when ``max_iter``
    is 0. The others go to scipy's per-row BVLS. Shared by :func:`box_lsq` and :func:`fiber_box_lsq`."""
    H = np.swapaxes(M, -1, -2) @ M
    ev = np.linalg.eigvalsh(H)  # ascending
    regular = ev[..., 0] * BVLS_CONDITION > ev[..., -1]  # also False for a singular H (λ_min ≤ 0)
    if M.ndim == 2:
        regular = np.broadcast_to(regular, (N,))
    return H, (np.flatnonzero(regular) if max_iter > 0 else np.zeros(0, dtype=np.intp))


def _scipy_bvls(M: np.ndarray, r: np.ndarray) -> np.ndarray:
    """One problem by scipy's BVLS (TRF when BVLS does not converge), clipped to [0, 1]."""
    from scipy.optimize import lsq_linear

    res = lsq_linear(M, r, bounds=(0.0, 1.0), method="bvls")
    if not res.success:  # pragma: no cover - BVLS failing to converge; TRF is slower but sure
        res = lsq_linear(M, r, bounds=(0.0, 1.0), method="trf", tol=BVLS_FALLBACK)
    return np.clip(res.x, 0.0, 1.0)


def _solve_block(M: np.ndarray, H: np.ndarray, R: np.ndarray, max_iter: int) -> tuple[np.ndarray, np.ndarray]:
    """Both phases on one block of rows; returns ``x (N, n)`` and which rows converged (their fixed
    entries exactly 0 or 1, free ones in [0, 1])."""
    shared = M.ndim == 2
    N, n = R.shape[0], M.shape[-1]
    A = np.abs(M)
    eye = np.eye(n, dtype=bool)

    def grad(idx, x):  # Mᵀ(Mx − r), from the residual
        if shared:
            return (x @ M.T - R[idx]) @ M
        m = M[idx]
        return np.einsum("npi,np->ni", m, np.einsum("npi,ni->np", m, x) - R[idx])

    def tol(idx, x):  # BVLS_KKT · |M|ᵀ(|M| |x| + |r|): relative to the size of the terms summed in g
        if shared:
            return BVLS_KKT * ((np.abs(x) @ A.T + np.abs(R[idx])) @ A)
        a = A[idx]
        return BVLS_KKT * np.einsum("npi,np->ni", a, np.einsum("npi,ni->np", a, np.abs(x)) + np.abs(R[idx]))

    def newton(idx, x, free, g):  # step onto the minimiser over the free variables, the others held
        K = np.where(free[:, :, None] & free[:, None, :], H if shared else H[idx], eye)
        return np.linalg.solve(K, np.where(free, -g, 0.0)[..., None])[..., 0]

    # warm start: the unconstrained minimiser, clipped; its bound-violating entries start fixed
    q = np.einsum("...pi,...p->...i", M, R)
    x_unc = np.linalg.solve(H, q.T).T if shared else np.linalg.solve(H, q[..., None])[..., 0]
    lower, upper = x_unc < 0.0, x_unc > 1.0
    x = x_unc.copy()
    converged = np.zeros(N, dtype=bool)
    idx = np.arange(N)

    # phase 1, primal–dual active set: all predicted set changes at once (fast, may cycle)
    steps = min(max_iter, PDAS_STEPS)
    for _ in range(steps):
        lo, up = lower[idx], upper[idx]
        free = ~(lo | up)
        xi = np.where(lo, 0.0, np.where(up, 1.0, x[idx]))
        xi = xi + newton(idx, xi, free, grad(idx, xi))
        g = grad(idx, xi)
        tau = tol(idx, xi)
        new_lo = (free & (xi < 0.0)) | (lo & (g >= -tau))
        new_up = (free & (xi > 1.0)) | (up & (g <= tau))
        stable = np.all((new_lo == lo) & (new_up == up), axis=1)
        done = stable & np.all(~free | (np.abs(g) <= tau), axis=1)
        x[idx] = xi
        lower[idx], upper[idx] = new_lo, new_up
        converged[idx[done]] = True
        idx = idx[~done]
        if idx.size == 0:
            return x, converged

    # phase 2, primal active set for the rest: feasible iterates, one set change per step (monotone)
    lower[idx], upper[idx] = x_unc[idx] < 0.0, x_unc[idx] > 1.0
    x[idx] = np.clip(x_unc[idx], 0.0, 1.0)
    for _ in range(max_iter - steps):
        lo, up = lower[idx], upper[idx]
        free = ~(lo | up)
        xi = x[idx]
        d = newton(idx, xi, free, grad(idx, xi))
        xi, blocked, rows = _bounded_step(xi, d, lo, up)
        # full steps: the free minimiser is feasible; free the fixed variable of most wrong multiplier
        g = grad(idx, xi)
        tau = tol(idx, xi)
        free = ~(lo | up)
        wrong = np.where(lo, -g - tau, np.where(up, g - tau, -np.inf))
        j = np.argmax(wrong, axis=1)
        settled = ~blocked & np.all(~free | (np.abs(g) <= tau), axis=1)  # else: refine (same sets)
        release = settled & (wrong[rows, j] > 0.0)
        lo[rows[release], j[release]] = False
        up[rows[release], j[release]] = False
        done = settled & ~release
        x[idx], lower[idx], upper[idx] = xi, lo, up
        converged[idx[done]] = True
        idx = idx[~done]
        if idx.size == 0:
            break
    return x, converged


def _bounded_step(x, d, lo, up):
    """``x + α d`` with α ≤ 1 the largest step that keeps the free entries in [0, 1] (the ratio test),
    the entry that meets its bound first fixed there (``lo``/``up`` updated in place); returns the new
    point, which rows were blocked, and the row indices. Shared by both active-set solvers' phase 2."""
    free = ~(lo | up)
    with np.errstate(divide="ignore", invalid="ignore"):  # the first bound the step meets
        reach = np.where(free & (d < 0.0), -x / d, np.where(free & (d > 0.0), (1.0 - x) / d, np.inf))
    k = np.argmin(reach, axis=1)
    rows = np.arange(x.shape[0])
    alpha = reach[rows, k]
    blocked = alpha < 1.0
    x = np.clip(x + np.clip(np.where(blocked, alpha, 1.0), 0.0, 1.0)[:, None] * d, 0.0, 1.0)
    b, kb = rows[blocked], k[blocked]
    at_one = d[b, kb] > 0.0
    lo[b, kb], up[b, kb], x[b, kb] = ~at_one, at_one, at_one.astype(np.float64)
    return x, blocked, rows


def fiber_box_lsq(A, b, F, c, weight, *, max_iter: int = MAX_ITER) -> tuple[np.ndarray, np.ndarray]:
    """``min ‖A x − b_i‖² + w² ‖Fᵀx − c_i‖²`` subject to ``0 ≤ x ≤ 1`` for every row, exactly, for a
    large weight ``w`` (a soft equality constraint), batched.

    :func:`box_lsq` of the stacked rows ``[A; w Fᵀ]`` needs ``MᵀM``, whose condition number grows
    with ``w²`` (≈ 1e11 for the exact-constraint fiber problem, w ≈ 1e5 relative): it hands every
    row to scipy's per-row BVLS. Here the constraint residual enters as its own unknown,
    ``λ = w²(Fᵀx − c)`` (the multiplier of the constraint as ``w → ∞``), so each free subproblem is
    the quasi-definite system ``[[AᵀA, F], [Fᵀ, −I/w²]] [x; λ] = [Aᵀb; c]`` (fixed variables held at
    their bounds: their rows and columns replaced by the identity), whose conditioning does not
    depend on ``w``. The same active-set phases as :func:`box_lsq` run on it (primal–dual, at most
    :data:`PDAS_STEPS` iterations, then primal with one set change per step), the gradient
    ``g = Aᵀ(Ax − b) + Fλ`` from the residual and the solved λ. A row stops when its sets no longer
    change, its free variables lie in [0, 1] and each fixed variable's multiplier has its sign to
    :data:`zonotope._tol.BVLS_KKT` ``· (|A|ᵀ(|A||x| + |b|) + |F||λ|)``. Rows not settled within
    ``max_iter`` iterations, and ``AᵀA`` above :data:`zonotope._tol.BVLS_CONDITION`, are solved by
    scipy's BVLS on the stacked rows, as before.

    Parameters
    ----------
    A : ndarray of shape (p, n) or (N, p, n)
    b : ndarray of shape (N, p)
    F : ndarray of shape (n, k)
    c : ndarray of shape (N, k)
    weight : float or ndarray of shape (N,)
        ``w`` > 0, one for all rows or one per row.
    max_iter
        Iterations of both phases together before a row falls back to scipy (0: every row does).

    Returns
    -------
    x : ndarray of shape (N, n)
    fallback : ndarray of bool, shape (N,)
        Rows solved by scipy's per-row BVLS.

    Raises
    ------
    GeometryError
        Shapes that do not match, values not finite, ``weight`` not > 0, ``max_iter`` negative.
    """
    A = float_array(A, "A", GeometryError)
    B = float_array(b, "b", GeometryError)
    F = float_array(F, "F", GeometryError)
    C = float_array(c, "c", GeometryError)
    if (
        A.ndim not in (2, 3)
        or B.ndim != 2
        or F.ndim != 2
        or C.ndim != 2
        or A.shape[-2] != B.shape[1]
        or F.shape[0] != A.shape[-1]
        or C.shape != (B.shape[0], F.shape[1])
        or (A.ndim == 3 and len(A) != len(B))
    ):
        raise GeometryError(
            f"fiber_box_lsq: A (p, n) or (N, p, n), b (N, p), F (n, k) and c (N, k) must agree; got A "
            f"{A.shape}, b {B.shape}, F {F.shape}, c {C.shape}."
        )
    W = (
        np.broadcast_to(np.asarray(weight, dtype=np.float64), (B.shape[0],))
        if _weights_ok(weight, B)
        else None
    )
    if (
        W is None
        or not all(np.all(np.isfinite(v)) for v in (A, B, F, C))
        or not np.all(np.isfinite(W) & (W > 0))
    ):
        raise GeometryError("fiber_box_lsq: A, b, F, c must be finite and weight > 0; check the inputs.")
    if int(max_iter) != max_iter or max_iter < 0:
        raise GeometryError(f"fiber_box_lsq: max_iter={max_iter!r}; give an integer ≥ 0.")
    N, n = B.shape[0], A.shape[-1]
    x = np.zeros((N, n))
    fallback = np.ones(N, dtype=bool)
    if N == 0 or n == 0:
        return x, np.zeros(N, dtype=bool)
    H, rows = _gram_rows(A, N, max_iter)
    for i in range(0, rows.size, BLOCK):
        j = rows[i : i + BLOCK]
        Aj, Hj = (A, H) if A.ndim == 2 else (A[j], H[j])
        xj, ok = _fiber_block(Aj, Hj, B[j], F, C[j], W[j], int(max_iter))
        x[j] = _polish(Aj, B[j], F, C[j], W[j], xj)
        fallback[j[ok]] = False
    for i in np.flatnonzero(fallback):
        x[i] = _scipy_bvls(
            np.vstack([A if A.ndim == 2 else A[i], W[i] * F.T]), np.concatenate([B[i], W[i] * C[i]])
        )
    return x, fallback


def _weights_ok(weight, B) -> bool:
    """Whether ``weight`` is one number or one per row of ``B``."""
    return np.ndim(weight) == 0 or np.shape(weight) == (B.shape[0],)


def _polish(A, B, F, C, w, x) -> np.ndarray:
    """The minimiser over the free variables of ``x`` (entries not exactly 0 or 1), the others held:
    Householder QR of the stacked rows ``[w Fᵀ; A]`` (heavy rows first, as row-weighted least squares
    needs), as scipy's BVLS solves it. The λ system of :func:`fiber_box_lsq` finds the active set, but
    where fewer variables are free than there are constraint rows its λ grows with ``w²`` along the
    residual the free variables cannot reach, and its ``x`` is only good to ≈ 1e-7; this solve is to
    round-off (measured against exact rational arithmetic)."""
    N, n = x.shape
    free = (x != 0.0) & (x != 1.0)
    fixed = np.where(free, 0.0, x)
    M = np.concatenate([w[:, None, None] * F.T, np.broadcast_to(A, (N, *A.shape[-2:]))], axis=1)
    K = np.concatenate([M * free[:, None, :], np.eye(n) * (~free)[:, None, :]], axis=1)
    r = np.concatenate([w[:, None] * C, B], axis=1) - np.einsum("npi,ni->np", M, fixed)
    Q, T = np.linalg.qr(K)
    z = np.linalg.solve(T, np.einsum("npi,np->ni", Q[:, : r.shape[1]], r)[..., None])[..., 0]
    return np.where(free, np.clip(z, 0.0, 1.0), x)


def _fiber_block(A, H, B, F, C, w: np.ndarray, max_iter: int) -> tuple[np.ndarray, np.ndarray]:
    """Both phases of :func:`fiber_box_lsq` on one block; ``x (N, n)`` and which rows converged."""
    shared = A.ndim == 2
    N, n = B.shape[0], A.shape[-1]
    k = F.shape[1]
    Aabs, Fabs = np.abs(A), np.abs(F)
    eye = np.eye(n, dtype=bool)
    q = np.einsum("...pi,...p->...i", A, B)  # Aᵀb

    def solve(idx, free, x):
        """The free subproblem's minimiser (fixed entries of ``x`` kept) and its λ."""
        m = idx.size
        Hi = H if shared else H[idx]
        fixed = np.where(free, 0.0, x)
        K = np.zeros((m, n + k, n + k))
        K[:, :n, :n] = np.where(free[:, :, None] & free[:, None, :], Hi, eye)
        Ff = np.where(free[:, :, None], F, 0.0)  # (m, n, k): fixed variables leave the constraint rows
        K[:, :n, n:] = Ff
        K[:, n:, :n] = np.swapaxes(Ff, 1, 2)
        K[:, n:, n:] = -np.eye(k) / w[idx, None, None] ** 2
        rhs = np.empty((m, n + k))
        rhs[:, :n] = np.where(free, q[idx] - np.einsum("...ij,...j->...i", Hi, fixed), fixed)
        rhs[:, n:] = C[idx] - fixed @ F
        z = np.linalg.solve(K, rhs[..., None])[..., 0]
        return np.where(free, z[:, :n], x), z[:, n:]

    def grad(idx, x, lam):  # Aᵀ(Ax − b) + Fλ, from the residual
        a = A if shared else A[idx]
        return np.einsum("...pi,...p->...i", a, np.einsum("...pi,...i->...p", a, x) - B[idx]) + lam @ F.T

    def tol(idx, x, lam):
        a = Aabs if shared else Aabs[idx]
        s = np.einsum("...pi,...p->...i", a, np.einsum("...pi,...i->...p", a, np.abs(x)) + np.abs(B[idx]))
        return BVLS_KKT * (s + np.abs(lam) @ Fabs.T)

    # warm start: the minimiser without the bounds; its bound-violating entries start fixed
    idx = np.arange(N)
    x_unc, _ = solve(idx, np.ones((N, n), dtype=bool), np.zeros((N, n)))
    lower, upper = x_unc < 0.0, x_unc > 1.0
    x = x_unc.copy()
    converged = np.zeros(N, dtype=bool)

    # phase 1, primal–dual active set: all predicted set changes at once (fast, may cycle)
    steps = min(max_iter, FIBER_PDAS_STEPS)
    for _ in range(steps):
        lo, up = lower[idx], upper[idx]
        free = ~(lo | up)
        xi, lam = solve(idx, free, np.where(lo, 0.0, np.where(up, 1.0, x[idx])))
        g, tau = grad(idx, xi, lam), tol(idx, xi, lam)
        new_lo = (free & (xi < 0.0)) | (lo & (g >= -tau))
        new_up = (free & (xi > 1.0)) | (up & (g <= tau))
        done = np.all((new_lo == lo) & (new_up == up), axis=1)
        x[idx] = xi
        lower[idx], upper[idx] = new_lo, new_up
        converged[idx[done]] = True
        idx = idx[~done]
        if idx.size == 0:
            return x, converged

    # phase 2, primal active set for the rest: feasible iterates, one set change per step (monotone)
    # from the last primal–dual sets, made feasible (fixed entries at their bounds, free ones clipped)
    x[idx] = np.clip(np.where(lower[idx], 0.0, np.where(upper[idx], 1.0, x[idx])), 0.0, 1.0)
    for _ in range(max_iter - steps):
        lo, up = lower[idx], upper[idx]
        free = ~(lo | up)
        xi = x[idx]
        z, lam = solve(idx, free, xi)
        xi, blocked, rows = _bounded_step(xi, z - xi, lo, up)
        # at the free minimiser (a full step): free the fixed variable whose multiplier is most wrong
        g, tau = grad(idx, xi, lam), tol(idx, xi, lam)
        wrong = np.where(lo, -g - tau, np.where(up, g - tau, -np.inf))
        j = np.argmax(wrong, axis=1)
        release = ~blocked & (wrong[rows, j] > 0.0)
        lo[rows[release], j[release]] = False
        up[rows[release], j[release]] = False
        done = ~blocked & ~release
        x[idx], lower[idx], upper[idx] = xi, lo, up
        converged[idx[done]] = True
        idx = idx[~done]
        if idx.size == 0:
            break
    return x, converged
