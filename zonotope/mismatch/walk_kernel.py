"""numba kernels of :mod:`zonotope.mismatch.walk` (imported on first use: numba costs ~1 s to import).

Conventions: variables j = 0..N−1 with constraint columns F[j] (k,), target columns G[j] (3,),
bounds lo[j] ≤ x_j ≤ hi[j]; constraints Σ_j x_j F[j] = c. A basis is k variable indices B; every
other variable sits at its lower (``up[j]`` False) or upper bound.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from .._tol import (
    CONE_INTERIOR,
    CONE_STEPS,
    DEGENERATE,
    EDGE_ZERO,
    HULL2_COLLINEAR,
    PARALLEL_EDGES,
    PHASE1,
    PIVOT,
    REDUCED_COST,
)

# status codes (see zonotope.mismatch.walk.STATUS)
_OK, _INFEASIBLE, _ART, _LIMIT, _DEGEN, _FLAT, _COLLIDE, _VLIMIT, _ADJ = 0, 1, 2, 3, 4, 5, 7, 8, 9


@njit(cache=True, error_model="numpy")
def _inverse(F, B, Minv):
    """Minv ← inverse of the k×k matrix whose column i is F[B[i]]; False when singular."""
    k = B.shape[0]
    return _inverse_ws(F, B, Minv, np.empty((k, 2 * k)))


@njit(cache=True, error_model="numpy")
def _inverse_ws(F, B, Minv, M):
    """:func:`_inverse` with the k × 2k work array ``M`` given (no allocation in the walk's loop)."""
    k = B.shape[0]
    for r in range(k):
        for i in range(k):
            M[r, i] = F[B[i], r]
            M[r, k + i] = 1.0 if r == i else 0.0
    big = 0.0
    for r in range(k):
        for i in range(k):
            big = max(big, abs(M[r, i]))
    if big == 0.0:
        return False
    for col in range(k):
        p = col
        for r in range(col + 1, k):
            if abs(M[r, col]) > abs(M[p, col]):
                p = r
        if abs(M[p, col]) <= PIVOT * big:
            return False
        if p != col:
            for q in range(2 * k):
                tmp = M[col, q]
                M[col, q] = M[p, q]
                M[p, q] = tmp
        piv = M[col, col]
        for q in range(2 * k):
            M[col, q] /= piv
        for r in range(k):
            if r != col:
                f = M[r, col]
                if f != 0.0:
                    for q in range(2 * k):
                        M[r, q] -= f * M[col, q]
    for r in range(k):
        for q in range(k):
            Minv[r, q] = M[r, k + q]
    return True


@njit(cache=True, error_model="numpy")
def _basic_values(F, lo, hi, c, B, up, isb, Minv, xB):
    """Set xB to the values of the basic variables (nonbasic ones at their bounds)."""
    _basic_values_ws(F, lo, hi, c, B, up, isb, Minv, xB, np.empty(c.shape[0]))


@njit(cache=True, error_model="numpy")
def _basic_values_ws(F, lo, hi, c, B, up, isb, Minv, xB, rhs):
    """:func:`_basic_values` with the work array ``rhs`` (k,) given."""
    N, k = F.shape
    rhs[:] = c
    for j in range(N):
        if not isb[j]:
            v = hi[j] if up[j] else lo[j]
            if v != 0.0:
                for r in range(k):
                    rhs[r] -= v * F[j, r]
    for i in range(k):
        s = 0.0
        for r in range(k):
            s += Minv[i, r] * rhs[r]
        xB[i] = s


@njit(cache=True, error_model="numpy")
def _primal(F, lo, hi, c, w, B, up, isb, max_iter):
    """Bounded-variable primal simplex maximising w·x from the feasible basis (B, up).

    Returns (status, pivots). Dantzig pricing, Bland's rule after half the iteration limit.
    """
    N, k = F.shape
    Minv = np.empty((k, k))
    xB = np.empty(k)
    alpha = np.empty(k)
    pi = np.empty(k)
    wmax = 0.0
    for j in range(N):
        wmax = max(wmax, abs(w[j]))
    dtol = REDUCED_COST * max(wmax, 1e-300)
    for it in range(max_iter):
        if not _inverse(F, B, Minv):
            return _DEGEN, it
        for r in range(k):
            s = 0.0
            for i in range(k):
                s += w[B[i]] * Minv[i, r]
            pi[r] = s
        best = -1
        bestv = 0.0
        bland = it > max_iter // 2
        for j in range(N):
            if isb[j] or not (hi[j] > lo[j]):
                continue
            d = w[j]
            for r in range(k):
                d -= pi[r] * F[j, r]
            score = -d if up[j] else d
            if score > dtol and (score > bestv or best < 0):
                best = j
                bestv = score
                if bland:
                    break
        if best < 0:
            return _OK, it
        _basic_values(F, lo, hi, c, B, up, isb, Minv, xB)
        j = best
        for i in range(k):
            s = 0.0
            for r in range(k):
                s += Minv[i, r] * F[j, r]
            alpha[i] = s
        sgn = -1.0 if up[j] else 1.0
        tmax = np.inf
        rr = -1
        for i in range(k):
            rate = sgn * alpha[i]
            b = B[i]
            if rate > 0.0:
                lim = (xB[i] - lo[b]) / rate
            elif rate < 0.0:
                lim = (xB[i] - hi[b]) / rate
            else:
                continue
            lim = max(lim, 0.0)
            if lim < tmax:
                tmax = lim
                rr = i
        flip_len = hi[j] - lo[j]
        if flip_len <= tmax:
            if not np.isfinite(flip_len):
                return _LIMIT, it  # unbounded: cannot happen on a bounded problem
            up[j] = not up[j]
        else:
            leave = B[rr]
            up[leave] = sgn * alpha[rr] < 0.0  # increasing basic variable leaves at its upper bound
            isb[leave] = False
            B[rr] = j
            isb[j] = True
            up[j] = False
    return _LIMIT, max_iter


@njit("void(i8[::1])", cache=True, error_model="numpy")
def _isort(a):
    """In-place insertion sort (k is small)."""
    for i in range(1, a.shape[0]):
        x = a[i]
        j = i - 1
        while j >= 0 and a[j] > x:
            a[j + 1] = a[j]
            j -= 1
        a[j + 1] = x


@njit(cache=True, error_model="numpy")
def _cross(a, b, out):
    out[0] = a[1] * b[2] - a[2] * b[1]
    out[1] = a[2] * b[0] - a[0] * b[2]
    out[2] = a[0] * b[1] - a[1] * b[0]


@njit("i8(f8[::1], f8[::1], i8, i8[::1], i8[::1])", cache=True, error_model="numpy")
def _hull2(px, py, n, hull, tmp):
    """CCW convex hull of points 0..n−1 by gift wrapping (O(n·h), h hull points, usually 3–5).

    Nearly collinear points (cross product within HULL2_COLLINEAR of the squared span) keep only the
    farthest. Returns the hull size, or 0 when the wrap does not close (numerical trouble).
    """
    span = 0.0
    start = 0
    for i in range(n):
        span = max(span, abs(px[i]), abs(py[i]))
        if px[i] < px[start] or (px[i] == px[start] and py[i] < py[start]):
            start = i
    eps = HULL2_COLLINEAR * span * span
    h = 0
    p = start
    while True:
        if h > n:
            return 0
        hull[h] = p
        h += 1
        q = 0 if p != 0 else 1
        xp = px[p]
        yp = py[p]
        qx = px[q] - xp
        qy = py[q] - yp
        for r in range(n):
            if r == p or r == q:
                continue
            rx = px[r] - xp
            ry = py[r] - yp
            cr = qx * ry - qy * rx
            if cr < -eps:
                q = r
                qx = rx
                qy = ry
            elif cr <= eps:
                dq = qx**2 + qy**2
                dr = rx**2 + ry**2
                if dr > dq:
                    q = r
                    qx = rx
                    qy = ry
        p = q
        if p == start:
            return h


@njit("b1(f8[:, ::1], f8[::1], i8, f8[::1], f8[::1], b1, f8[::1])", cache=True, error_model="numpy")
def _interior(A, na, cnt, w0, d0, has_d, w):
    """Set w to a direction with a·w > 0 for every row of A[:cnt] (True): w0 + η d0, else a perceptron."""
    for e in CONE_STEPS:
        if e > 0.0 and not has_d:
            break
        if e == 0.0 and has_d:
            continue
        for q in range(3):
            w[q] = w0[q] + e * d0[q]
        nw = np.sqrt(w[0] * w[0] + w[1] * w[1] + w[2] * w[2])
        ok = nw > 0.0
        for t in range(cnt):
            if not ok:
                break
            if (A[t, 0] * w[0] + A[t, 1] * w[1] + A[t, 2] * w[2]) <= CONE_INTERIOR * na[t] * nw:
                ok = False
        if ok:
            return True
    for q in range(3):
        w[q] = w0[q]
    for _ in range(5000):
        nw = np.sqrt(w[0] * w[0] + w[1] * w[1] + w[2] * w[2])
        worst = -1
        wv = np.inf
        for t in range(cnt):
            v = (A[t, 0] * w[0] + A[t, 1] * w[1] + A[t, 2] * w[2]) / na[t]
            if v < wv:
                wv = v
                worst = t
        if worst < 0 or wv > CONE_INTERIOR * nw:
            return nw > 0.0
        for q in range(3):
            w[q] += A[worst, q] / na[worst]
    return False


@njit("i8(i8[::1], i8[::1], i8)", cache=True, error_model="numpy")
def _tget(tkeys, tvals, key):
    """Value stored under ``key`` in the open-addressing table, or −1."""
    mask = tkeys.shape[0] - 1
    i = (key ^ (key >> 29)) & mask
    while tvals[i] >= 0:
        if tkeys[i] == key:
            return tvals[i]
        i = (i + 1) & mask
    return -1


@njit("void(i8[::1], i8[::1], i8, i8)", cache=True, error_model="numpy")
def _tput(tkeys, tvals, key, val):
    mask = tkeys.shape[0] - 1
    i = (key ^ (key >> 29)) & mask
    while tvals[i] >= 0 and tkeys[i] != key:
        i = (i + 1) & mask
    tkeys[i] = key
    tvals[i] = val


@njit(cache=True, error_model="numpy")
def _same_state(Bs, Ups, v, B, up, j, upj, leave, upl):
    """Is stored state v the basis B with ``up`` changed at j (to upj) and at ``leave`` (to upl, if ≥ 0)?"""
    k = B.shape[0]
    for i in range(k):
        if Bs[v, i] != B[i]:
            return False
    for t in range(up.shape[0]):
        x = upj if t == j else (upl if t == leave else up[t])
        if Ups[v, t] != x:
            return False
    return True


@njit(cache=True, error_model="numpy", nogil=True)
def walk(F, G, lo, hi, c, max_vertices, zb, zu):
    """Vertices (V, 3), status and number of moves of the MMV {Σ x_j G[j] : Σ x_j F[j] = c, lo ≤ x ≤ hi}."""
    N, k = F.shape
    empty = np.zeros((0, 3))
    zc = np.zeros(3)
    notri = np.zeros((0, 4), dtype=np.int64)
    # ---- phase 1: artificial variables ±e_i, minimise their sum
    Nx = N + k
    Fx = np.zeros((Nx, k))
    Fx[:N] = F
    lox = np.zeros(Nx)
    hix = np.empty(Nx)
    lox[:N] = lo
    hix[:N] = hi
    r0 = c.copy()
    for j in range(N):
        for r in range(k):
            r0[r] -= lo[j] * F[j, r]
    for i in range(k):
        Fx[N + i, i] = 1.0 if r0[i] >= 0.0 else -1.0
        hix[N + i] = np.inf
    w1 = np.zeros(Nx)
    w1[N:] = -1.0
    Bx = np.arange(N, Nx).astype(np.int64)
    upx = np.zeros(Nx, dtype=np.bool_)
    isbx = np.zeros(Nx, dtype=np.bool_)
    isbx[N:] = True
    limit = 50 * (Nx + k)
    st, piv1 = _primal(Fx, lox, hix, c, w1, Bx, upx, isbx, limit)
    if st != _OK:
        return empty, 0.0, zc, st, piv1, notri
    Minv = np.empty((k, k))
    xB = np.empty(k)
    if not _inverse(Fx, Bx, Minv):
        return empty, 0.0, zc, _DEGEN, piv1, notri
    _basic_values(Fx, lox, hix, c, Bx, upx, isbx, Minv, xB)
    scale = 0.0
    for r in range(k):
        s = 0.0
        for j in range(N):
            s += abs(F[j, r]) * max(abs(lo[j]), abs(hi[j]))
        scale = max(scale, s)
    infeas = 0.0
    for i in range(k):
        if Bx[i] >= N:
            infeas += xB[i]
    if infeas > PHASE1 * max(scale, 1.0):
        return empty, 0.0, zc, _INFEASIBLE, piv1, notri
    for i in range(k):
        if Bx[i] >= N:
            return empty, 0.0, zc, _ART, piv1, notri
    # ---- phase 2 for a generic direction u0
    B = Bx.copy()
    up = upx[:N].copy()
    isb = isbx[:N].copy()
    u0 = np.array([0.5773502691896258, -0.3015113445777636, 0.7587869930745341])
    u0 /= np.sqrt((u0 * u0).sum())
    w2 = np.empty(N)
    for j in range(N):
        w2[j] = G[j, 0] * u0[0] + G[j, 1] * u0[1] + G[j, 2] * u0[2]
    st, piv2 = _primal(F, lo, hi, c, w2, B, up, isb, limit)
    moves = piv1 + piv2
    if st != _OK:
        return empty, 0.0, zc, st, moves, notri
    # ---- the walk
    cap = 1024
    Bs = np.empty((cap, k), dtype=np.int64)
    Ups = np.empty((cap, N), dtype=np.bool_)
    Ms = np.empty((cap, 3))
    Ds = np.zeros((cap, 3))
    Y = np.empty((cap, 3))
    _isort(B)
    Bs[0] = B
    Ups[0] = up
    Ms[0] = u0
    has_dir = np.zeros(cap, dtype=np.bool_)
    key = np.int64(0)
    for i in range(k):
        key ^= zb[B[i]]
    for j in range(N):
        if up[j] and not isb[j]:
            key ^= zu[j]
    tsize = 4096
    tkeys = np.zeros(tsize, dtype=np.int64)  # open addressing, occupied where tvals ≥ 0
    tvals = np.full(tsize, -1, dtype=np.int64)
    _tput(tkeys, tvals, key, 0)
    keys = np.empty(cap, dtype=np.int64)
    keys[0] = key
    nv = 1
    gscale = 0.0
    for q in range(3):
        s = 0.0
        for j in range(N):
            s += abs(G[j, q]) * max(abs(lo[j]), abs(hi[j]))
        gscale = max(gscale, s)
    zeta = EDGE_ZERO * max(gscale, 1e-300)
    A = np.empty((N, 3))
    na = np.empty(N)
    var = np.empty(N, dtype=np.int64)
    alphas = np.empty((N, k))
    M2 = np.empty((3, k))
    px = np.empty(N)
    py = np.empty(N)
    hull = np.empty(2 * N + 2, dtype=np.int64)
    tmp = np.empty(2 * N + 2, dtype=np.int64)
    w = np.empty(3)
    e = np.empty(3)
    b1 = np.empty(3)
    b2 = np.empty(3)
    rp = np.empty(3)
    rn = np.empty(3)
    nB = np.empty(k, dtype=np.int64)
    Mw = np.empty((k, 2 * k))
    rhs = np.empty(k)
    nbr = np.empty((cap, N), dtype=np.int64)
    deg = np.zeros(cap, dtype=np.int64)
    v = 0
    while v < nv:
        B[:] = Bs[v]
        up[:] = Ups[v]
        isb[:] = False
        for i in range(k):
            isb[B[i]] = True
        if not _inverse_ws(F, B, Minv, Mw):
            return empty, 0.0, zc, _DEGEN, moves, notri
        # basic values (as _basic_values) and the non-basic part of the vertex in one pass
        rhs[:] = c
        y0 = 0.0
        y1 = 0.0
        y2 = 0.0
        for j in range(N):
            if isb[j]:
                continue
            x = hi[j] if up[j] else lo[j]
            if x != 0.0:
                for r in range(k):
                    rhs[r] -= x * F[j, r]
            y0 += x * G[j, 0]
            y1 += x * G[j, 1]
            y2 += x * G[j, 2]
        for i in range(k):
            s = 0.0
            for r in range(k):
                s += Minv[i, r] * rhs[r]
            xB[i] = s
        for i in range(k):
            b = B[i]
            eta = DEGENERATE * (hi[b] - lo[b])
            if not (xB[i] > lo[b] + eta and xB[i] < hi[b] - eta):
                return empty, 0.0, zc, _DEGEN, moves, notri
        for i in range(k):
            y0 += xB[i] * G[B[i], 0]
            y1 += xB[i] * G[B[i], 1]
            y2 += xB[i] * G[B[i], 2]
        Y[v, 0] = y0
        Y[v, 1] = y1
        Y[v, 2] = y2
        # edge vectors of the non-basic variables, signed so that the cone is {u : a·u ≥ 0}
        # M2 = G_Bᵀ B⁻¹ (3 × k): edge vector e_j = G[j] − M2 F[j]; the basic-variable rates
        # alphas = B⁻¹ F[j] are needed only for the hull's edges (computed there)
        for q in range(3):
            for r in range(k):
                s = 0.0
                for i in range(k):
                    s += G[B[i], q] * Minv[i, r]
                M2[q, r] = s
        cnt = 0
        m00, m01, m02 = M2[0, 0], M2[0, min(1, k - 1)], M2[0, min(2, k - 1)]
        m10, m11, m12 = M2[1, 0], M2[1, min(1, k - 1)], M2[1, min(2, k - 1)]
        m20, m21, m22 = M2[2, 0], M2[2, min(1, k - 1)], M2[2, min(2, k - 1)]
        for j in range(N):
            if isb[j] or not (hi[j] > lo[j]):
                continue
            if k == 3:  # unrolled, the same operations in the same order as the general loop
                f0, f1, f2 = F[j, 0], F[j, 1], F[j, 2]
                e[0] = G[j, 0] - m00 * f0 - m01 * f1 - m02 * f2
                e[1] = G[j, 1] - m10 * f0 - m11 * f1 - m12 * f2
                e[2] = G[j, 2] - m20 * f0 - m21 * f1 - m22 * f2
            else:
                for q in range(3):
                    s = G[j, q]
                    for r in range(k):
                        s -= M2[q, r] * F[j, r]
                    e[q] = s
            ne = np.sqrt(e[0] * e[0] + e[1] * e[1] + e[2] * e[2])
            if ne <= zeta:
                continue
            sg = 1.0 if up[j] else -1.0
            for q in range(3):
                A[cnt, q] = sg * e[q]
            na[cnt] = ne
            var[cnt] = j
            cnt += 1
        if cnt < 3:
            return empty, 0.0, zc, _FLAT, moves, notri
        if not _interior(A, na, cnt, Ms[v], Ds[v], has_dir[v], w):
            return empty, 0.0, zc, _FLAT, moves, notri
        nw = np.sqrt(w[0] * w[0] + w[1] * w[1] + w[2] * w[2])
        for q in range(3):
            w[q] /= nw
        # orthonormal b1, b2 ⊥ w with (b1, b2, w) right-handed
        t = 0 if abs(w[0]) <= abs(w[1]) and abs(w[0]) <= abs(w[2]) else (1 if abs(w[1]) <= abs(w[2]) else 2)
        e[:] = 0.0
        e[t] = 1.0
        _cross(w, e, b1)
        n1 = np.sqrt(b1[0] * b1[0] + b1[1] * b1[1] + b1[2] * b1[2])
        for q in range(3):
            b1[q] /= n1
        _cross(w, b1, b2)
        for t in range(cnt):
            s = 1.0 / (A[t, 0] * w[0] + A[t, 1] * w[1] + A[t, 2] * w[2])
            px[t] = (A[t, 0] * b1[0] + A[t, 1] * b1[1] + A[t, 2] * b1[2]) * s
            py[t] = (A[t, 0] * b2[0] + A[t, 1] * b2[1] + A[t, 2] * b2[2]) * s
        h = _hull2(px, py, cnt, hull, tmp)
        if h < 3:
            return empty, 0.0, zc, _FLAT, moves, notri
        deg[v] = h
        # parallel edge vectors (a point repeated at a hull vertex) are not handled by single moves
        span = 0.0
        for t in range(cnt):
            span = max(span, abs(px[t]), abs(py[t]))
        tie = PARALLEL_EDGES * span
        close = 0
        for g in range(h):
            a = hull[g]
            xa = px[a]
            ya = py[a]
            for t in range(cnt):  # branch-free count (vectorises); a itself is always close
                close += (abs(px[t] - xa) <= tie) & (abs(py[t] - ya) <= tie)
        if close != h:
            return empty, 0.0, zc, _FLAT, moves, notri
        for g in range(h):
            a = hull[g]
            ap = hull[(g - 1) % h]
            an = hull[(g + 1) % h]
            _cross(A[ap], A[a], rp)
            if rp[0] * A[an, 0] + rp[1] * A[an, 1] + rp[2] * A[an, 2] < 0.0:
                for q in range(3):
                    rp[q] = -rp[q]
            _cross(A[a], A[an], rn)
            if rn[0] * A[ap, 0] + rn[1] * A[ap, 1] + rn[2] * A[ap, 2] < 0.0:
                for q in range(3):
                    rn[q] = -rn[q]
            nrp = np.sqrt(rp[0] * rp[0] + rp[1] * rp[1] + rp[2] * rp[2])
            nrn = np.sqrt(rn[0] * rn[0] + rn[1] * rn[1] + rn[2] * rn[2])
            # move variable j off its bound: x_B(t) = x_B − t·sgn·alpha
            j = var[a]
            for i in range(k):
                s = 0.0
                for r in range(k):
                    s += Minv[i, r] * F[j, r]
                alphas[a, i] = s
            sgn = -1.0 if up[j] else 1.0
            tmax = np.inf
            rr = -1
            for i in range(k):
                rate = sgn * alphas[a, i]
                b = B[i]
                if rate > 0.0:
                    lim = (xB[i] - lo[b]) / rate
                elif rate < 0.0:
                    lim = (xB[i] - hi[b]) / rate
                else:
                    continue
                if lim < tmax:
                    tmax = lim
                    rr = i
            moves += 1
            key_of = keys[v]
            nB[:] = B
            # the new state is ``up`` changed at j (to upj) and at ``leave`` (to upl, when ≥ 0);
            # it is written out only for a new vertex
            flip_len = hi[j] - lo[j]
            leave = -1
            upl = False
            if flip_len < tmax:
                upj = not up[j]
                key_of ^= zu[j]
            else:
                leave = B[rr]
                to_up = sgn * alphas[a, rr] < 0.0
                upl = to_up
                if to_up:
                    key_of ^= zu[leave]
                key_of ^= zb[leave] ^ zb[j]
                if up[j]:
                    key_of ^= zu[j]
                upj = False
                nB[rr] = j
                _isort(nB)
            nkey = key_of
            u = _tget(tkeys, tvals, nkey)
            if u >= 0:
                if not _same_state(Bs, Ups, u, nB, up, j, upj, leave, upl):
                    return empty, 0.0, zc, _COLLIDE, moves, notri
                nbr[v, g] = u
                continue
            if nv >= max_vertices:
                return empty, 0.0, zc, _VLIMIT, moves, notri
            if nv == cap:
                cap *= 2
                Bs2 = np.empty((cap, k), dtype=np.int64)
                Bs2[:nv] = Bs[:nv]
                Bs = Bs2
                Ups2 = np.empty((cap, N), dtype=np.bool_)
                Ups2[:nv] = Ups[:nv]
                Ups = Ups2
                Ms2 = np.empty((cap, 3))
                Ms2[:nv] = Ms[:nv]
                Ms = Ms2
                Ds2 = np.zeros((cap, 3))
                Ds2[:nv] = Ds[:nv]
                Ds = Ds2
                Y2 = np.empty((cap, 3))
                Y2[:nv] = Y[:nv]
                Y = Y2
                h2 = np.zeros(cap, dtype=np.bool_)
                h2[:nv] = has_dir[:nv]
                has_dir = h2
                k2 = np.empty(cap, dtype=np.int64)
                k2[:nv] = keys[:nv]
                keys = k2
                nb2 = np.empty((cap, N), dtype=np.int64)
                nb2[:nv] = nbr[:nv]
                nbr = nb2
                dg2 = np.zeros(cap, dtype=np.int64)
                dg2[:nv] = deg[:nv]
                deg = dg2
            Bs[nv] = nB
            Ups[nv] = up
            Ups[nv, j] = upj
            if leave >= 0:
                Ups[nv, leave] = upl
            for q in range(3):
                Ms[nv, q] = rp[q] / nrp + rn[q] / nrn
                Ds[nv, q] = -A[a, q] / na[a]
            has_dir[nv] = True
            keys[nv] = nkey
            if 2 * (nv + 1) > tsize:
                tsize *= 4
                tk2 = np.zeros(tsize, dtype=np.int64)
                tv2 = np.full(tsize, -1, dtype=np.int64)
                for t in range(tkeys.shape[0]):
                    if tvals[t] >= 0:
                        _tput(tk2, tv2, tkeys[t], tvals[t])
                tkeys = tk2
                tvals = tv2
            _tput(tkeys, tvals, nkey, nv)
            nbr[v, g] = nv
            nv += 1
        v += 1
    tris = np.empty((2 * nv + 8, 4), dtype=np.int64)
    vol, cen, st, nt = _faces(Y, nbr, deg, nv, tris)
    if st != _OK:
        return empty, 0.0, zc, st, moves, notri
    return Y[:nv].copy(), vol, cen, _OK, moves, tris[:nt].copy()


@njit(cache=True, error_model="numpy", nogil=True)
def walk_batch(F, G, lo, hi, C, max_vertices, zb, zu):
    """:func:`walk` for each row of C (P, k) in one call: volumes (P,), centroids (P, 3), statuses and
    moves (P,) (what a batch of centroids needs; the vertex lists and triangles are dropped)."""
    P = C.shape[0]
    vols = np.zeros(P)
    cens = np.zeros((P, 3))
    status = np.empty(P, dtype=np.int64)
    moves = np.empty(P, dtype=np.int64)
    for p in range(P):
        _, vol, cen, st, mv, _ = walk(F, G, lo, hi, C[p], max_vertices, zb, zu)
        vols[p] = vol
        cens[p] = cen
        status[p] = st
        moves[p] = mv
    return vols, cens, status, moves


@njit(
    "Tuple((f8, f8[::1], i8, i8))(f8[:, ::1], i8[:, ::1], i8[::1], i8, i8[:, ::1])",
    cache=True,
    error_model="numpy",
)
def _faces(Y, nbr, deg, nv, tris):
    """Volume and centroid from the vertex graph: every face traced once by its directed edges.

    The edges of each vertex are in counter-clockwise order seen from outside, so the face to the
    left of the directed edge v → u continues at u with the edge just before u → v. The fan
    triangles (outward, counter-clockwise) go to ``tris`` as (a, b, c, face); returns (volume,
    centroid, status, number of triangles).
    """
    nt = 0
    face = 0
    o = np.zeros(3)
    for v in range(nv):
        for q in range(3):
            o[q] += Y[v, q]
    for q in range(3):
        o[q] /= nv
    used = np.zeros((nv, nbr.shape[1]), dtype=np.bool_)
    vol = 0.0
    cen = np.zeros(3)
    a = np.empty(3)
    b = np.empty(3)
    d = np.empty(3)
    for v0 in range(nv):
        for g0 in range(deg[v0]):
            if used[v0, g0]:
                continue
            cur = v0
            g = g0
            steps = 0
            while True:
                used[cur, g] = True
                u = nbr[cur, g]
                if cur != v0 and u != v0:
                    if nt >= tris.shape[0]:
                        return 0.0, cen, _ADJ, 0
                    tris[nt, 0] = v0
                    tris[nt, 1] = cur
                    tris[nt, 2] = u
                    tris[nt, 3] = face
                    nt += 1
                    for q in range(3):
                        a[q] = Y[v0, q] - o[q]
                        b[q] = Y[cur, q] - o[q]
                        d[q] = Y[u, q] - o[q]
                    t = (
                        a[0] * (b[1] * d[2] - b[2] * d[1])
                        - a[1] * (b[0] * d[2] - b[2] * d[0])
                        + a[2] * (b[0] * d[1] - b[1] * d[0])
                    ) / 6.0
                    vol += t
                    for q in range(3):
                        cen[q] += t * (a[q] + b[q] + d[q]) / 4.0
                gg = -1
                for x in range(deg[u]):
                    if nbr[u, x] == cur:
                        gg = x
                        break
                if gg < 0:
                    return 0.0, cen, _ADJ, 0
                g = (gg - 1) % deg[u]
                cur = u
                if cur == v0 and g == g0:
                    face += 1
                    break
                steps += 1
                if steps > nv + 2 or used[cur, g]:
                    return 0.0, cen, _ADJ, 0
    if not vol > 0.0:
        return 0.0, cen, _ADJ, 0
    for q in range(3):
        cen[q] = o[q] + cen[q] / vol
    return vol, cen, _OK, nt


@njit(cache=True, error_model="numpy", nogil=True)
def l1_distances(Phi, Psi, C, Y, feas_tol):
    """L1 distance from each target response Y[p] to the MMV of the source response C[p].

    One bounded-variable simplex per pair: min Σ_i (p_i + q_i) s.t. Φᵀx = c, Ψᵀx − p + q = y,
    0 ≤ x ≤ 1, p, q ≥ 0 (phase 1 on artificial variables for the source rows first). Returns the
    distances (NaN where c itself is infeasible, i.e. its phase 1 leaves more than ``feas_tol``)
    and a status per pair (0 ok, 3 pivot limit).
    """
    n, k = Phi.shape
    m = Psi.shape[1]
    R = k + m
    N = n + 2 * m + k
    F = np.zeros((N, R))
    F[:n, :k] = Phi
    F[:n, k:] = Psi
    for i in range(m):
        F[n + i, k + i] = -1.0  # p_i: Ψᵀx above y
        F[n + m + i, k + i] = 1.0  # q_i: Ψᵀx below y
    lo = np.zeros(N)
    hi = np.empty(N)
    hi[:n] = 1.0
    hi[n:] = np.inf
    w1 = np.zeros(N)
    w1[n + 2 * m :] = -1.0
    w2 = np.zeros(N)
    w2[n : n + 2 * m] = -1.0
    P = C.shape[0]
    out = np.empty(P)
    status = np.zeros(P, dtype=np.int64)
    rhs = np.empty(R)
    B = np.empty(R, dtype=np.int64)
    up = np.zeros(N, dtype=np.bool_)
    isb = np.zeros(N, dtype=np.bool_)
    Minv = np.empty((R, R))
    xB = np.empty(R)
    limit = 50 * (N + R)
    for p in range(P):
        for r in range(k):
            rhs[r] = C[p, r]
            F[n + 2 * m + r, :] = 0.0
            F[n + 2 * m + r, r] = 1.0 if C[p, r] >= 0.0 else -1.0
            B[r] = n + 2 * m + r
        for i in range(m):
            rhs[k + i] = Y[p, i]
            B[k + i] = n + m + i if Y[p, i] >= 0.0 else n + i
        hi[n + 2 * m :] = np.inf
        up[:] = False
        isb[:] = False
        for r in range(R):
            isb[B[r]] = True
        st, _ = _primal(F, lo, hi, rhs, w1, B, up, isb, limit)
        if st != _OK:
            out[p] = np.nan
            status[p] = st
            continue
        _inverse(F, B, Minv)
        _basic_values(F, lo, hi, rhs, B, up, isb, Minv, xB)
        infeas = 0.0
        for r in range(R):
            if B[r] >= n + 2 * m:
                infeas += abs(xB[r])
        if infeas > feas_tol:
            out[p] = np.nan
            continue
        hi[n + 2 * m :] = 0.0  # artificials fixed at zero (a basic one leaves at the first move)
        st, _ = _primal(F, lo, hi, rhs, w2, B, up, isb, limit)
        if st != _OK:
            out[p] = np.nan
            status[p] = st
            continue
        _inverse(F, B, Minv)
        _basic_values(F, lo, hi, rhs, B, up, isb, Minv, xB)
        d = 0.0
        for r in range(R):
            if n <= B[r] < n + 2 * m:
                d += max(xB[r], 0.0)
        out[p] = d
    return out, status
