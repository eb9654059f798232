"""Exact point-in-convex-polytope test accelerated by a cube map of candidate facets.

For a convex polytope ``{y : A y ≤ b}`` with an interior point c, the ray from c through a
point p leaves through the facet whose *radial shadow* (central projection onto the unit
sphere) contains the direction of p − c, and that facet attains the gauge
max_F (a_F·(p − c)) / (b_F − a_F·c). So testing only the facets whose shadow can meet the
direction decides "inside" exactly:

- max over candidates ≤ 0  ⇒ inside (the exit facet is among them, gauge ≤ 1);
- max over candidates > atol ⇒ outside (some facet is violated by more than atol);
- otherwise (within atol of the boundary) the point is re-tested against every facet.

Directions are bucketed on the six faces of a cube (K×K cells each). A facet is a candidate
for a cell when the angular caps around the facet's shadow and around the cell overlap.
"""

from __future__ import annotations

import numpy as np

from .._tol import CAP_HEMISPHERE, CAP_MARGIN

__all__ = ["CubeMap"]


def _cells(K: int) -> tuple[np.ndarray, np.ndarray]:
    """Unit centre directions (6K², 3) and angular radii (6K²,) of the cube-map cells."""
    edges = np.linspace(-1.0, 1.0, K + 1)
    mid = 0.5 * (edges[:-1] + edges[1:])
    uu, vv = np.meshgrid(mid, mid, indexing="ij")
    cu = np.stack([edges[:-1], edges[1:]])
    centres, radii = [], []
    for axis in range(3):
        for sign in (1.0, -1.0):
            o1, o2 = [a for a in range(3) if a != axis]
            d = np.zeros((K, K, 3))
            d[..., axis] = sign
            d[..., o1] = uu
            d[..., o2] = vv
            d /= np.linalg.norm(d, axis=-1, keepdims=True)
            cos_min = np.ones((K, K))
            for a in range(2):
                for b in range(2):
                    corner = np.zeros((K, K, 3))
                    corner[..., axis] = sign
                    corner[..., o1] = cu[a][:, None]
                    corner[..., o2] = cu[b][None, :]
                    corner /= np.linalg.norm(corner, axis=-1, keepdims=True)
                    cos_min = np.minimum(cos_min, np.einsum("ijk,ijk->ij", d, corner))
            centres.append(d.reshape(-1, 3))
            radii.append(np.arccos(np.clip(cos_min, -1, 1)).reshape(-1))
    return np.concatenate(centres), np.concatenate(radii)


def _cell_index(v: np.ndarray, K: int) -> np.ndarray:
    """Cube-map cell of each direction v (B, 3) (any length > 0)."""
    axis = np.argmax(np.abs(v), axis=1)
    rows = np.arange(v.shape[0])
    major = v[rows, axis]
    face = 2 * axis + (major < 0)
    o1 = np.where(axis == 0, 1, 0)
    o2 = np.where(axis == 2, 1, 2)
    scale = np.abs(major)
    u = v[rows, o1] / scale
    w = v[rows, o2] / scale
    iu = np.clip(((u + 1.0) * 0.5 * K).astype(np.int64), 0, K - 1)
    iw = np.clip(((w + 1.0) * 0.5 * K).astype(np.int64), 0, K - 1)
    return face * K * K + iu * K + iw


class CubeMap:
    """Candidate-facet lookup for exact inside tests of a convex polytope.

    Parameters
    ----------
    A : ndarray of shape (m, 3)
        Unit facet normals (first the + side facets, then their point reflections).
    b : ndarray of shape (m,)
    centre : ndarray of shape (3,)
        An interior point; the polytope is symmetric about it.
    corners : list of ndarray of shape (F_i, M_i, 3)
        Corners of the + side facets, in the order of ``A``'s first half.
    """

    def __init__(self, A, b, centre, corners, K: int | None = None) -> None:
        self.A, self.b, self.c = A, b, centre
        self.h = b - A @ centre
        m = A.shape[0]
        half = m // 2
        dirs, alpha = [], []
        for block in corners:
            rel = block - centre
            mean = rel.mean(axis=1)
            d = mean / np.linalg.norm(mean, axis=1, keepdims=True)
            unit = rel / np.linalg.norm(rel, axis=2, keepdims=True)
            cos = np.einsum("fk,fmk->fm", d, unit).min(axis=1)
            dirs.append(d)
            alpha.append(np.arccos(np.clip(cos, -1.0, 1.0)))
        d_plus = np.concatenate(dirs)
        a_plus = np.concatenate(alpha)
        assert d_plus.shape[0] == half
        fdir = np.concatenate([d_plus, -d_plus])  # point symmetry about the centre
        falpha = np.concatenate([a_plus, a_plus])
        # a cap wider than a hemisphere is not spherically convex, so it may not hold the
        # facet's shadow: such (huge, close) facets are candidates everywhere
        falpha = np.where(falpha >= 0.5 * np.pi - CAP_HEMISPHERE, 2.0 * np.pi, falpha)
        self.K = K or int(np.clip(np.sqrt(m / 12.0), 4, 48))
        cdir, crad = _cells(self.K)
        reach = falpha[None, :] + CAP_MARGIN
        cells, facets = [], []
        step = max(1, 4_000_000 // max(m, 1))
        for s in range(0, cdir.shape[0], step):
            ang = np.arccos(np.clip(cdir[s : s + step] @ fdir.T, -1.0, 1.0))
            ci, fi = np.nonzero(ang <= reach + crad[s : s + step, None])
            cells.append(ci + s)
            facets.append(fi)
        cells = np.concatenate(cells)
        facets = np.concatenate(facets)
        order = np.argsort(cells, kind="stable")
        self.cand = facets[order]
        self.start = np.searchsorted(cells[order], np.arange(cdir.shape[0] + 1))

    @property
    def mean_candidates(self) -> float:
        """Mean number of candidate facets per cube-map cell."""
        return float(np.mean(np.diff(self.start)))

    def contains(self, points: np.ndarray, atol: float) -> np.ndarray:
        """Exact inside test of points (B, 3) within absolute slack ``atol``."""
        v = points - self.c
        out = np.ones(v.shape[0], dtype=bool)
        nz = np.nonzero(np.any(v != 0.0, axis=1))[0]
        if nz.size == 0:
            return out
        cell = _cell_index(v[nz], self.K)
        order = np.argsort(cell, kind="stable")
        cs = cell[order]
        bounds = np.flatnonzero(np.diff(cs)) + 1
        starts = np.concatenate([[0], bounds])
        ends = np.concatenate([bounds, [cs.size]])
        worst = np.empty(nz.size)
        vs = v[nz][order]
        for s, e in zip(starts.tolist(), ends.tolist()):
            c = cs[s]
            F = self.cand[self.start[c] : self.start[c + 1]]
            if F.size == 0:  # pragma: no cover - every cell meets some facet's shadow
                F = np.arange(self.A.shape[0])
            worst[s:e] = (vs[s:e] @ self.A[F].T - self.h[F]).max(axis=1)
        unsure = np.nonzero((worst > 0.0) & (worst <= atol))[0]
        if unsure.size:
            full = (vs[unsure] @ self.A.T - self.h).max(axis=1)
            worst[unsure] = full
        res = np.empty(nz.size, dtype=bool)
        res[order] = worst <= atol
        out[nz] = res
        return out
