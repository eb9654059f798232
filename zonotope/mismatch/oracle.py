"""Support-function oracles of metamer mismatch volumes.

For source generators Φ (n, k), target generators Ψ (n, m), a response c (k,) and a per-channel
tolerance δ (k,), the MMV support function is

    h(u) = max (Ψu)ᵀx  s.t.  c − δ ≤ Φᵀx ≤ c + δ,  0 ≤ x ≤ 1.

Two oracles answer it for a batch of directions U (q, m), same interface:

- :class:`HighsOracle`, the reference twin: one ``scipy.optimize.linprog(method="highs")`` call per
  direction, with tightened feasibility tolerances (1e-10).
- :class:`SimplexOracle`, the fast one: a bounded-variable primal simplex with k basic variables,
  run on a whole batch of directions at once in numpy. The constraints do not depend on u, so a
  basis optimal for one direction stays primal feasible for any other: each LP starts from the
  optimal basis of a nearby direction (the support point of a vertex of the facet being
  certified) and usually needs a handful of pivots. One phase-1 solve per response finds the first
  feasible basis (or proves the response infeasible).
"""

from __future__ import annotations

import numpy as np

from .._errors import GeometryError
from .._tol import HIGHS_FEASIBILITY, PHASE1, RATIO_PIVOT, REDUCED_COST

__all__ = ["HighsOracle", "Infeasible", "SimplexOracle"]


class Infeasible(Exception):
    """Raised by an oracle when no reflectance in [0, 1] meets the response constraints."""


def _as_delta(delta, k: int) -> np.ndarray:
    d = np.broadcast_to(np.asarray(delta, dtype=np.float64), (k,)).copy()
    if not np.all(np.isfinite(d)) or np.any(d < 0):
        raise GeometryError(f"delta must be finite and ≥ 0 (scalar or shape ({k},)); got {delta!r}.")
    return d


class HighsOracle:
    """Reference support oracle: one scipy HiGHS LP per direction.

    Parameters
    ----------
    Phi : ndarray of shape (n, k)
    Psi : ndarray of shape (n, m)
    c : ndarray of shape (k,)
    delta : float or ndarray of shape (k,)

    Raises
    ------
    Infeasible
        When the constraint set is empty (checked with the first LP).
    """

    def __init__(self, Phi, Psi, c, delta=0.0) -> None:
        self.Phi, self.Psi, self.c = Phi, Psi, np.asarray(c, dtype=np.float64)
        k = Phi.shape[1]
        self.delta = _as_delta(delta, k)
        self.n_calls = 0
        from scipy.sparse import csr_matrix

        if np.any(self.delta > 0):
            self._kw = dict(
                A_ub=csr_matrix(np.vstack([Phi.T, -Phi.T])),
                b_ub=np.concatenate([self.c + self.delta, -(self.c - self.delta)]),
            )
        else:
            self._kw = dict(A_eq=csr_matrix(Phi.T), b_eq=self.c)
        self.support(np.eye(Psi.shape[1])[:1])  # feasibility check

    def support(self, U, warm=None):
        """Support values (q,), points (q, m) and warm-start ids (q,) (unused) for U (q, m)."""
        from scipy.optimize import linprog

        U = np.atleast_2d(U)
        n = self.Phi.shape[0]
        vals, pts = np.empty(len(U)), np.empty((len(U), self.Psi.shape[1]))
        for i, u in enumerate(U):
            res = linprog(
                -(self.Psi @ u),
                bounds=(0, 1),
                method="highs",
                **self._kw,
                options=dict(
                    primal_feasibility_tolerance=HIGHS_FEASIBILITY,
                    dual_feasibility_tolerance=HIGHS_FEASIBILITY,
                ),
            )
            self.n_calls += 1
            if res.status == 2:
                raise Infeasible
            if res.status != 0:  # pragma: no cover
                raise GeometryError(f"HiGHS failed on a support LP: {res.message}")
            x = res.x[:n]
            pts[i] = x @ self.Psi
            vals[i] = u @ pts[i]
        return vals, pts, np.zeros(len(U), dtype=np.int64)


class SimplexOracle:
    """Fast support oracle: batched, warm-started bounded-variable primal simplex.

    Parameters
    ----------
    Phi : ndarray of shape (n, k)
    Psi : ndarray of shape (n, m)
    c : ndarray of shape (k,) or (R, k)
        One response, or R responses solved side by side (``support(..., rows=...)`` says which
        response each direction belongs to); the constraint matrix is shared, only the right-hand
        side differs, so LPs of different responses share every numpy call.
    delta : float or ndarray of shape (k,)
    max_iter : int
        Pivot limit per LP (per batch member); LPs that hit it (cycling) are re-solved by HiGHS.

    Attributes
    ----------
    feasible : ndarray of bool, shape (R,)
        Whether each response can be met within δ (phase 1).

    Raises
    ------
    Infeasible
        From the constructor, for a single response (c of shape (k,)) that phase 1 proves
        infeasible. With several responses, see ``feasible`` instead.

    Notes
    -----
    Variables: the n reflectance values in [0, 1], k slacks s ∈ [−δ, δ] with Φᵀx + s = c (only when
    some δ > 0), and k artificial variables used by phase 1 and then fixed at 0 (their column is
    ± e_i, the sign per response making them start non-negative). A basis is k of them; the others
    sit at a bound. Dantzig pricing, Harris-free ratio test with bound flips, product-form updates
    of B⁻¹ and a fresh factorisation every 25 pivots and at the end.
    """

    def __init__(self, Phi, Psi, c, delta=0.0, *, max_iter: int | None = None) -> None:
        Phi = np.asarray(Phi, dtype=np.float64)
        Psi = np.asarray(Psi, dtype=np.float64)
        n, k = Phi.shape
        self.k, self.m = k, Psi.shape[1]
        C = np.asarray(c, dtype=np.float64)
        single = C.ndim == 1
        self.C = np.atleast_2d(C)
        R = self.C.shape[0]
        self.delta = _as_delta(delta, k)
        self.n_calls = 0
        self.n_fallback = 0
        self.n_pivots = 0
        use_slack = bool(np.any(self.delta > 0))
        cols = [Phi.T]
        lo, hi = [np.zeros(n)], [np.ones(n)]
        if use_slack:
            cols.append(np.eye(k))
            lo.append(-self.delta)
            hi.append(self.delta)
        n_main = n + (k if use_slack else 0)
        self.n_main = n_main
        # artificials: sign chosen per response so that they start non-negative
        x0 = np.concatenate(lo)
        r = self.C - x0 @ np.hstack(cols).T
        self.colscale = np.ones((R, n_main + k))
        self.colscale[:, n_main:] = np.where(r >= 0, 1.0, -1.0)
        cols.append(np.eye(k))
        lo.append(np.zeros(k))
        hi.append(np.full(k, np.inf))
        self.A = np.ascontiguousarray(np.hstack(cols))  # (k, N); artificial columns × colscale
        self.lo, self.hi = np.concatenate(lo), np.concatenate(hi)
        self.N = self.A.shape[1]
        self.PsiX = np.zeros((self.N, self.m))
        self.PsiX[:n] = Psi
        self._Phi, self._Psi = Phi, Psi
        self.max_iter = max_iter or 50 * (self.N + k)
        self.scale = float(np.abs(Phi).sum(axis=0).max()) or 1.0
        # phase 1, all responses at once
        rows = np.arange(R)
        basis = np.tile(np.arange(n_main, n_main + k), (R, 1))
        upper = np.zeros((R, self.N), dtype=bool)
        W1 = np.zeros((R, self.N))
        W1[:, n_main:] = -1.0
        basis, upper, xB, _ = self._solve(W1, basis, upper, rows)
        infeas = np.where(basis >= n_main, xB, 0.0).sum(axis=1)
        self.feasible = infeas <= PHASE1 * max(self.scale, 1.0)
        if single and not self.feasible[0]:
            raise Infeasible
        self.hi[n_main:] = 0.0  # artificials fixed at zero from now on
        self._bases = [basis]
        self._uppers = [upper]
        self._rows = [rows]
        self._count = R

    # -- public ---------------------------------------------------------------------------------

    def support(self, U, warm=None, rows=None):
        """Support of a batch of directions.

        Parameters
        ----------
        U : ndarray of shape (q, m)
        warm : ndarray of int, shape (q,), optional
            Ids (from earlier calls) of the solutions to start from; default the phase-1 basis of
            each direction's response.
        rows : ndarray of int, shape (q,), optional
            Response of each direction (index into ``c``); default 0.

        Returns
        -------
        values : ndarray of shape (q,)
        points : ndarray of shape (q, m)
        ids : ndarray of int, shape (q,)
            Ids of these solutions, to warm-start later calls.
        """
        U = np.atleast_2d(np.asarray(U, dtype=np.float64))
        q = U.shape[0]
        rows = np.zeros(q, dtype=np.int64) if rows is None else np.asarray(rows, dtype=np.int64)
        if len(self._bases) > 1:
            self._bases = [np.concatenate(self._bases)]
            self._uppers = [np.concatenate(self._uppers)]
            self._rows = [np.concatenate(self._rows)]
        bases, uppers, owner = self._bases[0], self._uppers[0], self._rows[0]
        w = rows.copy() if warm is None else np.asarray(warm, dtype=np.int64)
        if np.any(owner[w] != rows):
            raise GeometryError("warm-start ids belong to another response.")
        W = U @ self.PsiX.T  # (q, N)
        basis, upper, xB, failed = self._solve(W, bases[w].copy(), uppers[w].copy(), rows)
        x = np.where(upper, self.hi, self.lo)
        np.put_along_axis(x, basis, xB, axis=1)
        points = x @ self.PsiX
        if failed.any():
            self.n_fallback += int(failed.sum())
            for r in np.unique(rows[failed]):
                sel = failed & (rows == r)
                ref = HighsOracle(self._Phi, self._Psi, self.C[r], self.delta)
                _, points[sel], _ = ref.support(U[sel])
        self.n_calls += q
        ids = np.arange(self._count, self._count + q)
        self._count += q
        self._bases.append(basis)
        self._uppers.append(upper)
        self._rows.append(rows)
        return np.einsum("qm,qm->q", U, points), points, ids

    # -- the simplex ----------------------------------------------------------------------------

    def _refactor(self, basis, upper, cs, rhs):
        A, lo, hi = self.A, self.lo, self.hi
        Bmat = A[:, basis].transpose(1, 0, 2) * np.take_along_axis(cs, basis, axis=1)[:, None, :]
        Binv = np.linalg.inv(Bmat)  # (q, k, k): columns = basic variables
        xN = np.where(upper, hi, lo)
        np.put_along_axis(xN, basis, 0.0, axis=1)
        xN = np.where(np.isfinite(xN), xN, 0.0)
        xB = np.einsum("qij,qj->qi", Binv, rhs - (xN * cs) @ A.T)
        return Binv, xB

    def _solve(self, W, basis, upper, rows):
        """Run the primal simplex on every row of W (q, N) from the given feasible bases."""
        A, lo, hi = self.A, self.lo, self.hi
        q, N = W.shape
        cs = self.colscale[rows]  # (q, N) column signs (artificials)
        n_main = self.n_main
        art_free = bool(np.any(hi[n_main:] > lo[n_main:]))
        rhs = self.C[rows]
        Binv, xB = self._refactor(basis, upper, cs, rhs)
        isbasic = np.zeros((q, N), dtype=bool)
        np.put_along_axis(isbasic, basis, True, axis=1)
        dtol = REDUCED_COST * np.maximum(np.abs(W).max(axis=1), 1e-300)
        free = hi > lo
        iters = np.zeros(q, dtype=np.int64)
        since = 0
        active = np.arange(q)
        failed = np.zeros(q, dtype=bool)
        checked = False
        while True:
            if active.size == 0:
                if checked:
                    break
                # final refactorisation of everyone, then re-price once
                Binv, xB = self._refactor(basis, upper, cs, rhs)
                since = 0
                active = np.arange(q)[~failed]
                checked = True
            a = active
            Wa = W[a]
            wB = Wa[np.arange(a.size)[:, None], basis[a]]
            v = np.einsum("qi,qij->qj", wB, Binv[a])
            d = Wa - v @ A
            if art_free:  # phase 1: the artificial columns carry a per-response sign
                d[:, n_main:] = Wa[:, n_main:] - v * cs[a, n_main:]
            up = upper[a]
            dt = dtol[a, None]
            elig = ~isbasic[a] & free & np.where(up, d < -dt, d > dt)
            score = np.where(elig, np.abs(d), 0.0)
            bland = iters[a] > self.max_iter // 2
            j = np.argmax(score, axis=1)
            if bland.any():
                j[bland] = np.argmax(elig[bland], axis=1)
            has = elig[np.arange(a.size), j]
            over = iters[a] >= self.max_iter
            failed[a[over & has]] = True
            go = has & ~over
            if not go.any():
                active = a[:0]
                continue
            checked = False
            a, j = a[go], j[go]
            iters[a] += 1
            self.n_pivots += a.size
            Bi = Binv[a]
            alpha = np.einsum("qij,jq->qi", Bi, A[:, j] * cs[a, j])
            s = np.where(upper[a, j], -1.0, 1.0)
            rate = s[:, None] * alpha
            bB = basis[a]
            loB, hiB = lo[bB], hi[bB]
            xb = xB[a]
            ptol = RATIO_PIVOT
            lim = np.full(rate.shape, np.inf)  # step until each basic variable hits a bound
            np.divide(xb - loB, rate, out=lim, where=rate > ptol)
            np.divide(xb - hiB, rate, out=lim, where=rate < -ptol)
            np.maximum(lim, 0.0, out=lim)
            r = np.argmin(lim, axis=1)
            tmax = lim[np.arange(a.size), r]
            flip_len = hi[j] - lo[j]
            flip = flip_len <= tmax
            t = np.where(flip, flip_len, tmax)
            xb = xb - t[:, None] * rate
            # bound flips
            fa = a[flip]
            upper[fa, j[flip]] = ~upper[fa, j[flip]]
            # pivots
            pv = ~flip
            if pv.any():
                pa, pj, pr = a[pv], j[pv], r[pv]
                rows = np.arange(pa.size)
                leave = basis[pa, pr]
                upper[pa, leave] = rate[pv][rows, pr] < 0
                isbasic[pa, leave] = False
                enter_val = np.where(s[pv] > 0, lo[pj] + t[pv], hi[pj] - t[pv])
                xbp = xb[pv]
                xbp[rows, pr] = enter_val
                xb[pv] = xbp
                basis[pa, pr] = pj
                isbasic[pa, pj] = True
                upper[pa, pj] = False
                al = alpha[pv]
                Bp = Bi[pv]
                piv = al[rows, pr]
                row_r = Bp[rows, pr] / piv[:, None]
                Bp = Bp - al[:, :, None] * row_r[:, None, :]
                Bp[rows, pr] = row_r
                Bi[pv] = Bp
                Binv[a] = Bi
            xB[a] = xb
            active = a
            since += 1
            if since >= 25:
                Binv, xB = self._refactor(basis, upper, cs, rhs)
                since = 0
        return basis, upper, xB, failed
