"""Combinatorics of 3-D zonohedra: reduced generators, facets, vertices, surface mesh.

Private engine behind :class:`zonotope.Zonotope` (the public façade in :mod:`zonotope.geometry.solid`).
Every function works on the *reduced* generators ``H`` (zero ones dropped, all oriented into one
half-space, parallel ones merged) and the offset ``off`` with ``Z = off + {xᵀH : x ∈ [0, 1]ᵖ}``.
Vertices carry random 64-bit keys ``Σ r_k`` over their generator set, so that the same vertex
reached along different facets is recognised without comparing floats.

References
----------
.. [1] McMullen, P. (1971). On zonotopes. Trans. AMS 159.
"""

from __future__ import annotations

from dataclasses import dataclass
from itertools import combinations

import numpy as np

from .._tol import ANGLE_ROUNDING, PARALLEL_PREFILTER, SWEEP_GENERIC, ZONOGON_HALFTURN, Tolerances


@dataclass(frozen=True)
class Facets3:
    """Facets of the + side of each ± pair (the − side is the point reflection through c)."""

    pairs: np.ndarray  # (P, 2) reduced-generator indices of parallelogram facets
    normals: np.ndarray  # (P, 3) h_i × h_j (not normalised)
    bases: np.ndarray  # (P, 3) lowest corner of the + facet
    keys: np.ndarray  # (P,) int64 hash of the lowest corner's generator set
    zonogons: list  # [(normal (3,), vertices (M, 3) CCW about normal, keys (M,))]
    members: list  # [reduced generator indices (r,) of each zonogon]
    volume: float


def _is_closed_manifold(F: np.ndarray, n_vertices: int) -> bool:
    """Every edge is shared by exactly two triangles that traverse it in opposite directions."""
    a = F.reshape(-1).astype(np.int64)
    b = np.roll(F, -1, axis=1).reshape(-1).astype(np.int64)
    key = np.sort((np.minimum(a, b) * n_vertices + np.maximum(a, b)) * 2 + (a < b))
    if key.size % 2:
        return False
    first, second = key[0::2], key[1::2]
    same_edge = np.all(first // 2 == second // 2)
    opposite = np.all(first % 2 == 0) and np.all(second % 2 == 1)
    only_two = np.all(first[1:] // 2 != second[:-1] // 2)
    return bool(same_edge and opposite and only_two)


def _hull_mesh(points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Outward-oriented triangulated convex hull (Qhull) of points (N, 3)."""
    from scipy.spatial import ConvexHull

    hull = ConvexHull(points)
    keep = hull.vertices
    remap = np.full(points.shape[0], -1)
    remap[keep] = np.arange(keep.size)
    F = hull.simplices.copy()
    V = points[keep]
    P = points[F]
    normal = np.cross(P[:, 1] - P[:, 0], P[:, 2] - P[:, 0])
    flip = np.einsum("ij,ij->i", normal, hull.equations[:, :3]) < 0
    F[flip] = F[flip][:, ::-1]
    return V, _fix_winding(remap[F], normal)


def _fix_winding(F: np.ndarray, normal: np.ndarray) -> np.ndarray:
    """Make neighbouring triangles traverse shared edges in opposite directions (BFS).

    Sliver triangles have no reliable normal of their own, so orientation is propagated from the
    largest triangle across shared edges instead.
    """
    from collections import deque

    F = F.copy()
    edges: dict[tuple[int, int], list[int]] = {}
    for f, tri in enumerate(F.tolist()):
        for a, b in ((tri[0], tri[1]), (tri[1], tri[2]), (tri[2], tri[0])):
            edges.setdefault((min(a, b), max(a, b)), []).append(f)
    done = np.zeros(len(F), dtype=bool)
    for seed in np.argsort(-np.linalg.norm(normal, axis=1)):
        if done[seed]:
            continue
        done[seed] = True
        queue = deque([int(seed)])
        while queue:
            f = queue.popleft()
            tri = F[f].tolist()
            for a, b in ((tri[0], tri[1]), (tri[1], tri[2]), (tri[2], tri[0])):
                for g in edges[(min(a, b), max(a, b))]:
                    if done[g]:
                        continue
                    t = F[g].tolist()
                    if (a, b) in ((t[0], t[1]), (t[1], t[2]), (t[2], t[0])):
                        F[g] = F[g][::-1]
                    done[g] = True
                    queue.append(g)
    return F


def reduce_generators(G: np.ndarray, offset: np.ndarray, tol: Tolerances) -> tuple[np.ndarray, np.ndarray]:
    """(H, offset'): zero generators dropped, all oriented to one half-space, parallels merged.

    Z(G) = offset' + Z(H) exactly, since {t·g} = g + {t·(−g)} for t ∈ [0, 1].
    """
    H, off, _, _ = reduce_with_groups(G, offset, tol)
    return H, off


def reduce_with_groups(G: np.ndarray, offset: np.ndarray, tol: Tolerances):
    """:func:`reduce_generators` plus, per input generator, its reduced index (−1: dropped as
    zero) and whether it was flipped (x ↦ 1 − x) to orient it."""
    group = np.full(G.shape[0], -1, dtype=np.intp)
    flipped = np.zeros(G.shape[0], dtype=bool)
    norms = np.linalg.norm(G, axis=1)
    keep = norms > tol.zero * (norms.max() if norms.size else 0.0)
    H, off = G[keep].copy(), offset.copy()
    if H.shape[0] == 0:
        return H, off, group, flipped
    w = np.sin(1.2345 * np.arange(1, G.shape[1] + 1) + 0.5)  # fixed generic direction
    flip = H @ w < 0
    off += H[flip].sum(axis=0)
    H[flip] *= -1.0
    U = H / np.linalg.norm(H, axis=1, keepdims=True)
    # candidates by cosine (cheap), confirmed by |u_i − u_j|, which resolves tiny angles
    ci, cj = np.nonzero(U @ U.T >= 1.0 - max(PARALLEL_PREFILTER, tol.parallel**2))  # 1 − cos θ ≈ θ²/2
    d2 = np.einsum("ij,ij->i", U[ci] - U[cj], U[ci] - U[cj])
    close = np.zeros((U.shape[0], U.shape[0]), dtype=bool)
    close[ci, cj] = d2 <= tol.parallel**2
    label = np.argmax(close, axis=1)
    uniq, inverse = np.unique(label, return_inverse=True)
    merged = np.zeros((uniq.size, G.shape[1]))
    np.add.at(merged, inverse, H)
    group[keep] = inverse
    flipped[keep] = flip
    return merged, off, group, flipped


def facets(H: np.ndarray, off: np.ndarray, r: np.ndarray, coplanar: float) -> Facets3:
    """Angular sweep: for each generator h_i, sort the others by angle in the plane ⊥ h_i.

    For the pair (i, j) the facet normal is n = h_i × h_j and sign(n · h_k) is the side of
    the line through h_j's projection, so the positive set is a half-turn of the sorted
    angles: prefix sums give every facet's base point in O(p² log p) total. All p sweeps
    run at once on one (p, p) angle matrix; searches use per-row offsets. ``coplanar`` is the
    angle (rad, ``Tolerances.coplanar``) within which a generator lies in the plane of a pair.
    """
    p = H.shape[0]
    m = p - 1
    T = H.sum(axis=0)
    two_pi, big = 2.0 * np.pi, 16.0
    A = H / np.linalg.norm(H, axis=1, keepdims=True)
    E1 = np.zeros((p, 3))
    E1[np.arange(p), np.argmin(np.abs(A), axis=1)] = 1.0
    E1 -= A * np.einsum("ij,ij->i", A, E1)[:, None]
    E1 /= np.linalg.norm(E1, axis=1, keepdims=True)
    E2 = np.cross(A, E1)
    P1, P2 = E1 @ H.T, E2 @ H.T
    ang = np.arctan2(P2, P1)
    ang[np.arange(p), np.arange(p)] = np.inf  # self sorts last and is cut off
    # Rounding of the row angles: the projection of h_k onto h_i⊥ has length |h_k|·s_ik
    # (s_ik = sin of their angle) and an absolute error of a few ε·|h_k|, so θ_k in row i is
    # only good to ≈ ε / s_ik. For nearly parallel generators (s ≈ 1e-6) that exceeds ``coplanar``:
    # the old fixed window missed exactly coplanar triples (14 vertices instead of 12). A
    # generator counts as coplanar when its angle is within ``coplanar`` *or within rounding*.
    s = np.hypot(P1, P2) / np.linalg.norm(H, axis=1)[None, :]
    s[np.arange(p), np.arange(p)] = np.inf
    noise = ANGLE_ROUNDING / s  # (p, p): rounding of θ_k in row i
    row_noise = noise.max(axis=1, where=np.isfinite(noise), initial=0.0)
    order = np.argsort(ang, axis=1)[:, :m]
    a_s = np.take_along_axis(ang, order, axis=1)  # (p, m)
    rows = np.arange(p)[:, None]
    # row-offset sorted angles for searches; prefix sums along each row. A half-turn window
    # may wrap past the row's end: C(t) = cum[t] + cum[t − m] for t > m (cum[0] = 0).
    flat_as = (a_s + big * rows).ravel()
    cum = np.zeros((p, m + 1, 3))
    np.cumsum(H[order], axis=1, out=cum[:, 1:])
    cumr = np.zeros((p, m + 1), np.int64)
    np.cumsum(r[order], axis=1, out=cumr[:, 1:])
    ii, tt = np.nonzero(order > np.arange(p)[:, None])  # pairs (i, j) with j > i
    jj = order[ii, tt]
    th = a_s[ii, tt]
    base_row = ii * m
    # per-pair window: coplanar plus the rounding of θ_j and of the noisiest angle of the row
    win = coplanar + noise[ii, jj] + row_noise[ii]
    lo = np.searchsorted(flat_as, th + win + big * ii, "right") - base_row
    x = th + np.pi - win
    wrap = x > np.pi
    hi = np.searchsorted(flat_as, x - two_pi * wrap + big * ii, "left") - base_row + m * wrap
    hi1, hi2 = np.minimum(hi, m), np.maximum(hi - m, 0)
    Bp = cum[ii, hi1] + cum[ii, hi2] - cum[ii, lo]
    Kp = cumr[ii, hi1] + cumr[ii, hi2] - cumr[ii, lo]
    n = np.cross(H[ii], H[jj])
    volume = float(np.einsum("ij,ij->", n, 2.0 * Bp - T)) / 3.0
    # generators coplanar with (i, j): angle within coplanar of θ_j or θ_j + π (mod 2π). Cheap
    # test first (neighbours in sorted order), exact windows only for the flagged pairs.
    # Both neighbours wrap around the row: θ = π and θ' = −π are one direction (the last angle's
    # next neighbour is the first one + 2π; missing it dropped a zonogon, found by hypothesis).
    prev = np.where(tt > 0, a_s[ii, tt - 1], a_s[ii, m - 1] - two_pi)
    after = np.where(tt + 1 < m, a_s[ii, np.minimum(tt + 1, m - 1)], a_s[ii, 0] + two_pi)
    nxt = np.where(hi < 2 * m, a_s[ii, hi % m] + two_pi * (hi >= m), np.inf)
    flag = (lo > tt + 1) | (th - prev <= win) | (after - th <= win) | (nxt <= th + np.pi + win)
    th = th + big * ii
    zonogons, planes = [], []
    keep = np.ones(ii.size, dtype=bool)
    deg = np.nonzero(flag)[0]
    if deg.size:
        planes = _coplanar_classes(deg, ii, jj, th, flat_as, order.ravel(), win, coplanar, noise)
        if planes:
            pid = ii * p + jj
            inside = np.concatenate([np.array([a * p + b for a, b in combinations(S, 2)]) for S in planes])
            keep &= ~np.isin(pid, inside)
            for S in planes:
                zonogons.append(_zonogon_of(H, r, off, np.array(S)))
        # flagged pairs that are no zonogon's: parallelograms whose base is rebuilt from exact signs
        # (the windows above left the near-coplanar generators out of the prefix sums)
        redo = deg[keep[deg]]
        if redo.size:
            side = n[redo] @ H.T > 0.0
            side[np.arange(redo.size), ii[redo]] = False
            side[np.arange(redo.size), jj[redo]] = False
            Bp[redo] = side @ H
            Kp[redo] = side.astype(np.int64) @ r
    ii, jj, n, Bp, Kp = (a[keep] for a in (ii, jj, n, Bp, Kp))
    Bp += off
    return Facets3(
        pairs=np.stack([ii, jj], axis=1),
        normals=n,
        bases=Bp,
        keys=Kp,
        zonogons=zonogons,
        members=[np.array(S) for S in planes],
        volume=volume,
    )


def _coplanar_classes(deg, ii, jj, th, flat_as, g_flat, win, coplanar, noise) -> list[list[int]]:
    """Coplanar generator sets (≥ 3) from the flagged pairs, with one decision per triple.

    A plane's generator set is decided once, in the sweep of its smallest generator i: with j
    the smallest other member, S = {i} ∪ {k : angle of k within ``coplanar`` of θ_j modulo π, plus
    the rounding ``noise[i, j] + noise[i, k]`` of the two angles}. Candidates come from the
    per-pair windows ``win`` (≥ every such bound in the row). The
    sweeps of the other members are not asked: their angle tests can disagree with row i's near
    the tolerance (between 1e-12 and 1e-11 rad on near-coplanar data), which used to drop or
    double a facet. Every pair inside S belongs to the zonogon and to no parallelogram; a pair
    claimed by two sets (tolerances chaining through near-parallel generators) stays with the
    first, and the vertex sweep's pair count then hands over to key deduplication.
    """
    thd, wd = th[deg], win[deg]
    ti, tj = ii[deg], jj[deg]
    di, dk = [], []
    for c in (0.0, 2.0 * np.pi, -2.0 * np.pi, np.pi, -np.pi):
        a = np.searchsorted(flat_as, thd + c - wd, "left")
        b = np.searchsorted(flat_as, thd + c + wd, "right")
        cnt = np.maximum(b - a, 0)
        total = int(cnt.sum())
        if total == 0:
            continue
        pos = np.arange(total) - np.repeat(np.cumsum(cnt) - cnt, cnt) + np.repeat(a, cnt)
        e = np.repeat(np.arange(deg.size), cnt)
        k = g_flat[pos]
        # the decision for this triple: coplanar plus the rounding of both row angles
        ok = np.abs(flat_as[pos] - thd[e] - c) <= coplanar + noise[ti[e], tj[e]] + noise[ti[e], k]
        di.append(e[ok])
        dk.append(k[ok])
    if not di:
        return []
    di, tk = np.concatenate(di), np.concatenate(dk)
    low = np.full(deg.size, np.iinfo(np.int64).max)
    np.minimum.at(low, di, tk)
    # the plane's smallest generator i sweeps it; its second smallest j names the pair (i, j)
    planes, seen = [], set()
    for e in np.nonzero((low >= tj) & (ti < tj))[0].tolist():
        S = sorted({int(ti[e])} | set(tk[di == e].tolist()))
        if len(S) < 3:
            continue
        pairs = set(combinations(S, 2))
        if pairs & seen:  # tolerances chained two planes through a shared pair: keep the first
            continue
        seen |= pairs
        planes.append(S)
    return planes


def _zonogon_of(H, r, off, S):
    """Zonogon facet of the coplanar generators ``S``: normal from its widest pair, base from
    the exact sides of all other generators."""
    U = H[S] / np.linalg.norm(H[S], axis=1, keepdims=True)
    w = np.linalg.norm(np.cross(U[:, None], U[None]), axis=-1)
    a, b = np.unravel_index(np.argmax(w), w.shape)
    a, b = min(a, b), max(a, b)
    normal = np.cross(U[a], U[b])  # of unit vectors: no underflow for tiny generators
    side = H @ normal > 0.0
    side[S] = False
    return zonogon(H, r, normal, off + side @ H, side.astype(np.int64) @ r, S)


def zonogon(H, r, normal, base, key, zset):
    """Polygon (CCW about ``normal``) of a facet spanned by ≥ 3 coplanar generators."""
    nn = normal / np.linalg.norm(normal)
    e1 = H[zset[0]] / np.linalg.norm(H[zset[0]])
    e2 = np.cross(nn, e1)
    Z = H[zset].copy()
    rz = r[zset].copy()
    ang = np.arctan2(Z @ e2, Z @ e1)
    flip = (ang < -ZONOGON_HALFTURN) | (ang >= np.pi - ZONOGON_HALFTURN)
    base = base + Z[flip].sum(axis=0)
    key = np.array([key], dtype=np.int64) + rz[flip].sum(dtype=np.int64)
    Z[flip] *= -1.0
    rz[flip] = -rz[flip]
    ang = np.where(flip, np.arctan2(Z @ e2, Z @ e1), ang)
    order = np.argsort(ang)
    steps = np.concatenate([Z[order], -Z[order][:-1]])
    ksteps = np.concatenate([rz[order], -rz[order][:-1]])
    verts = base + np.vstack([np.zeros(3), np.cumsum(steps, axis=0)])
    vkeys = key + np.concatenate([np.zeros(1, np.int64), np.cumsum(ksteps)])
    return normal, verts, vkeys


def halfspaces(f: Facets3, c: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """H-representation ``A y ≤ b`` with unit rows, one row per facet (3-D only).

    Returns
    -------
    A : ndarray of shape (m, 3)
    b : ndarray of shape (m,)
    """
    N = [f.normals] + [z[0][None] for z in f.zonogons]
    B = [f.bases] + [z[1][:1] for z in f.zonogons]
    N = np.concatenate(N)
    N = N / np.linalg.norm(N, axis=1, keepdims=True)
    bplus = np.einsum("ij,ij->i", N, np.concatenate(B))
    A = np.concatenate([N, -N])
    b = np.concatenate([bplus, bplus - 2.0 * N @ c])
    return A, b


def mesh(f: Facets3, H: np.ndarray, r: np.ndarray, c: np.ndarray) -> tuple[np.ndarray, np.ndarray, str]:
    """Triangle mesh (vertices, faces, status) of the zonohedron with facets ``f``."""
    c2 = 2.0 * c
    K_all = r.sum(dtype=np.int64)
    hi, hj = H[f.pairs[:, 0]], H[f.pairs[:, 1]]
    rr = r
    ri, rj = rr[f.pairs[:, 0]], rr[f.pairs[:, 1]]
    quads = np.stack([f.bases, f.bases + hi, f.bases + hi + hj, f.bases + hj], axis=1)
    qkeys = np.stack([f.keys, f.keys + ri, f.keys + ri + rj, f.keys + rj], axis=1)
    polys = [(quads, qkeys, False), (c2 - quads, K_all - qkeys, True)]
    for _, verts, vkeys in f.zonogons:
        polys.append((verts[None], vkeys[None], False))
        polys.append(((c2 - verts)[None], (K_all - vkeys)[None], True))
    points, pkeys, faces = [], [], []
    offset = 0
    for verts, vkeys, reverse in polys:
        m, M = verts.shape[:2]
        ids = offset + np.arange(m * M).reshape(m, M)
        fan = np.stack([np.zeros(M - 2, int), np.arange(1, M - 1), np.arange(2, M)], axis=1)
        tri = ids[:, fan].reshape(-1, 3)
        faces.append(tri[:, ::-1] if reverse else tri)
        points.append(verts.reshape(-1, 3))
        pkeys.append(vkeys.reshape(-1))
        offset += m * M
    _, first, inverse = np.unique(np.concatenate(pkeys), return_index=True, return_inverse=True)
    V = np.concatenate(points)[first]
    F = inverse.reshape(-1)[np.concatenate(faces)]
    if _is_closed_manifold(F, V.shape[0]):
        return V, F, "facets"
    # Nearly coplanar generators (within TOL.coplanar, but not exactly) can make the
    # combinatorics of neighbouring facets disagree; the facet planes, the volume and the
    # vertices stay right, so the surface is rebuilt as the Qhull hull of the vertices.
    return (*_hull_mesh(V), "qhull")


def vertices_by_keys(f: Facets3, H: np.ndarray, r: np.ndarray, c: np.ndarray) -> np.ndarray:
    """Every vertex is the lowest or the highest corner of some facet (its upward edges form one
    contiguous arc around it): list those corners and their point reflections, drop repeats."""
    rr = r
    top = f.bases + H[f.pairs[:, 0]] + H[f.pairs[:, 1]]
    ktop = f.keys + rr[f.pairs[:, 0]] + rr[f.pairs[:, 1]]
    pts = np.concatenate([f.bases, top] + [z[1] for z in f.zonogons])
    keys = np.concatenate([f.keys, ktop] + [z[2] for z in f.zonogons])
    pts = np.concatenate([pts, 2.0 * c - pts])
    keys = np.concatenate([keys, rr.sum(dtype=np.int64) - keys])
    _, first = np.unique(keys, return_index=True)
    return pts[first]


def vertices_sweep(
    f: Facets3, H: np.ndarray, off: np.ndarray, r: np.ndarray, c: np.ndarray
) -> np.ndarray | None:
    """Each vertex exactly once, from the arrangement of great circles ``h⊥`` on the sphere.

    Vertices of the zonotope are the cells of that arrangement (the directions for which the
    vertex is the support point); facets are its crossing points ``±(h_i × h_j)``. Seen in the
    gnomonic chart of the hemisphere ``w · u > 0`` the circles are lines and every bounded cell
    has one lowest corner for a generic height ``e`` (e ⊥ w): at each crossing the corner
    whose two edges both climb. The cells that cross the equator ``w⊥`` are the 2p vertices
    of the zonotope's shadow along ``w`` (one angular sweep); the lower hemisphere holds the
    point reflections of the upper one. Returns None (the caller falls back to key
    deduplication) if the fixed generic ``w, e`` happen to be tied with the data or the count
    differs from Euler's ``V = 2 + E − F``.
    """
    p = H.shape[0]
    # Each pair of generator directions spans exactly one plane, hence one ± facet pair: if the
    # tolerant coplanarity tests of different sweeps disagreed, a facet is missing (or doubled)
    # and the arrangement below would miss vertices, so leave it to the key method.
    r_z = [z[1].shape[0] // 2 for z in f.zonogons]
    if f.pairs.shape[0] + sum(r * (r - 1) // 2 for r in r_z) != p * (p - 1) // 2:
        return None
    c2 = 2.0 * c
    key_all = r.sum(dtype=np.int64)
    w = np.array([0.5459694, 0.3173211, 0.7752803])
    w /= np.linalg.norm(w)
    e = np.cross(w, [0.8314159, -0.2718281, 0.4845213])
    e /= np.linalg.norm(e)
    eps = SWEEP_GENERIC
    # crossings in the upper hemisphere: the + facet (normal n) or its − twin (normal −n)
    i, j = f.pairs[:, 0], f.pairs[:, 1]
    n = f.normals
    nn2 = np.einsum("ij,ij->i", n, n)
    wn, en = n @ w, n @ e
    if np.any(wn * wn <= eps * eps * nn2):
        return None
    up = wn > 0
    # climbing direction γ = (w·N) e − (e·N) w at N = ±n, written γ_t = α h_i + β h_j; with
    # n = h_i × h_j, n·(e × h_j) = |h_j|² e·h_i − (h_i·h_j) e·h_j (and alike): scalars only
    gw, ge = np.abs(wn), np.where(up, en, -en)
    He, Hw, H2 = H @ e, H @ w, np.einsum("ij,ij->i", H, H)
    hij = np.einsum("ij,ij->i", H[i], H[j])
    alpha = (gw * (H2[j] * He[i] - hij * He[j]) - ge * (H2[j] * Hw[i] - hij * Hw[j])) / nn2
    beta = (gw * (H2[i] * He[j] - hij * He[i]) - ge * (H2[i] * Hw[j] - hij * Hw[i])) / nn2
    small = eps * np.hypot(gw, ge)
    if np.any(alpha * alpha * H2[i] <= small * small) or np.any(beta * beta * H2[j] <= small * small):
        return None
    # the chosen corner, mirrored through the centre on the − twins
    zero = np.concatenate([H, np.zeros((1, 3))])
    rz = np.concatenate([r, np.zeros(1, np.int64)])
    ci = np.where((alpha > 0) == up, i, p)
    cj = np.where((beta > 0) == up, j, p)
    sgn = np.where(up, 1.0, -1.0)[:, None]
    corner = sgn * (f.bases + zero[ci] + zero[cj]) + (~up)[:, None] * c2
    ckey = np.where(up, 1, -1) * (f.keys + rz[ci] + rz[cj]) + np.where(up, 0, key_all)
    pts, keys = [corner], [ckey]
    n_edges = 4 * i.size
    for normal, verts, vkeys in f.zonogons:
        M = verts.shape[0]
        n_edges += M
        wz = normal @ w
        if abs(wz) <= eps * np.linalg.norm(normal):
            return None
        if wz < 0:
            normal, verts, vkeys = -normal, (c2 - verts)[::-1], (key_all - vkeys)[::-1]
        g = -((normal @ w) * e - (normal @ e) * w)
        a = np.roll(verts, -1, axis=0) - verts
        b = np.roll(verts, 1, axis=0) - verts
        sa, sb = np.cross(a, g) @ normal, np.cross(g, b) @ normal
        pick = (sa > 0) & (sb > 0)
        if np.count_nonzero(pick) != M // 2 - 1:
            return None
        pts.append(verts[pick])
        keys.append(vkeys[pick])
    upper, ukeys = np.concatenate(pts), np.concatenate(keys)
    # the equator: vertices of the shadow along w, one per gap between the 2p events φ ± π/2
    a1 = np.cross(w, e)
    phi = np.arctan2(He, H @ a1)
    if np.any(np.hypot(He, H @ a1) <= eps * np.sqrt(H2)):
        return None
    events = np.sort(np.mod(np.concatenate([phi + np.pi / 2, phi - np.pi / 2]), 2.0 * np.pi))
    gaps = np.diff(np.concatenate([events, events[:1] + 2.0 * np.pi]))
    if gaps.min() <= eps:
        return None
    theta = events + 0.5 * gaps
    S = np.stack([np.cos(theta), np.sin(theta)], axis=1) @ np.stack([H @ a1, H @ e]) > 0
    equator = off + S @ H
    ekeys = S.astype(np.int64) @ r
    # cells that cross the equator but still have a lowest corner are in both lists
    # (a 2¹⁶-bucket table of their keys' low bits leaves ~1 % of candidates to search)
    bucket = np.zeros(1 << 16, dtype=bool)
    bucket[ekeys & 0xFFFF] = True
    cand = np.nonzero(bucket[ukeys & 0xFFFF])[0]
    es = np.sort(ekeys)
    hit = cand[es[np.minimum(np.searchsorted(es, ukeys[cand]), es.size - 1)] == ukeys[cand]]
    upper = np.delete(upper, hit, axis=0)
    n_facets = 2 * (i.size + len(f.zonogons))
    if 2 * upper.shape[0] + 2 * p != 2 + n_edges - n_facets:
        return None
    return np.concatenate([upper, c2 - upper, equator])


def circular_transitions(X: np.ndarray, a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Fewest 0↔1 transitions of circular sequences with two free entries.

    ``X`` (m, n) holds 0/1; entries ``a`` < ``b`` (m,) are free values in (0, 1) (the facet's two
    generators at ½). A free entry between equal neighbours costs two transitions, between
    different ones one; two adjacent free entries between different neighbours cost one and
    between equal ones two (zonohedra's ``transitioncount``, specialised to two free entries).
    """
    m, n = X.shape
    keep = np.ones((m, n), dtype=bool)
    rows = np.arange(m)
    keep[rows, a] = False
    keep[rows, b] = False
    y = X[keep].reshape(m, n - 2).astype(bool)
    d = y != np.roll(y, -1, axis=1)
    count = 2 + d.sum(axis=1)
    adjacent = (b == a + 1) | ((a == 0) & (b == n - 1))
    ka, kb = (a - 1) % (n - 2), (b - 2) % (n - 2)
    sep = ~adjacent
    count[sep] += (1 - 2 * d[rows[sep], ka[sep]]) + (1 - 2 * d[rows[sep], kb[sep]])
    return count


def pgram_transitions(
    G: np.ndarray, H: np.ndarray, group: np.ndarray, f: Facets3, chunk: int = 4096
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Transition counts of the boundary parallelograms of the standard tiling.

    One parallelogram per pair I < J of reduced generators (zonogon facets tiled), as in
    zonohedra's ``transitionsdf``. Its centre is the image of the cube point with x = ½ on I and
    J and x = [g·n > 0] on every other reduced generator g (n the facet normal); the other
    members of a zonogon facet get 1 between I and J and 0 outside (zonohedra's
    ``boundarypgramdata``). The count is circular, over the reduced generators in the order of
    their first input generator (a merged run of parallel generators is one entry, zero
    generators none). Returns ``pairs (P, 2)`` (reduced indices), ``reps (P, 2)`` (first input
    index of each) and ``transitions (P,)`` (even, ≥ 2).
    """
    p, n = H.shape[0], G.shape[0]
    I, J = np.triu_indices(p, 1)
    reps = np.full(p, n, dtype=np.intp)
    np.minimum.at(reps, group[group >= 0], np.nonzero(group >= 0)[0])
    normals = np.cross(H[I], H[J])
    plane = np.full(p * p, -1, dtype=np.intp)  # pair id → zonogon index
    members = []
    zid = np.zeros(I.size, dtype=np.intp) - 1
    for z, S in enumerate(f.members):
        members.append(S)
        for s, t in combinations(S.tolist(), 2):
            plane[s * p + t] = z
    if f.zonogons:
        zid = plane[I * p + J]
        has = zid >= 0
        # which side of a zonogon is "+" decides its tiles' counts (all 2 or all 4 for the
        # 50-generator zonogon of CIE 1931, area 0.1 of 34669); zonohedra's choice is not
        # documented, −n (n from the zonogon's widest pair) is ours
        normals[has] = -np.stack([f.zonogons[z][0] for z in zid[has]])
    # the sequence runs over the reduced generators in the order of their first wavelengths
    seq = np.argsort(reps, kind="stable")
    pos = np.empty(p, dtype=np.intp)
    pos[seq] = np.arange(p)
    Gs = G[reps[seq]]
    a, b = np.minimum(pos[I], pos[J]), np.maximum(pos[I], pos[J])
    out = np.empty(I.size, dtype=np.int64)
    for s in range(0, I.size, chunk):
        e = min(s + chunk, I.size)
        X = normals[s:e] @ Gs.T > 0.0
        for r in np.nonzero(zid[s:e] >= 0)[0]:
            free = pos[members[zid[s + r]]]
            X[r, free] = (free >= a[s + r]) & (free <= b[s + r])
        out[s:e] = circular_transitions(X, a[s:e], b[s:e])
    return np.stack([I, J], axis=1), np.stack([reps[I], reps[J]], axis=1), out
