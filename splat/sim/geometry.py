"""Geometry and textures of the simulated capture's scene (:mod:`splat.sim.capture`): exact ray casting of
a floor, a backdrop, boxes, spheres and capped cylinders, and procedural textures mixing measured
reflectances.

Everything here works on rays in bulk: an origin ``o`` (3,) and unit directions ``d`` (N, 3). A hit gives
up to three library indices and weights per ray (the spectrum is ``Σ w_k · library[i_k]``, shading
included), so a pixel's spectrum stays a convex mix of measured reflectances.
"""

from __future__ import annotations

from typing import Any, Protocol

import numpy as np

from .._tol import RAY_SURFACE, RAY_T_MIN, WARP_RADIUS_MIN

__all__ = ["CARD", "CHART", "SceneLike", "chart_in_view", "shade"]


class SceneLike(Protocol):
    """What shading reads of a scene (:class:`splat.sim.capture.SimScene` is one); declared here so
    that the geometry does not import the capture that uses it."""

    config: Any  # .texture ("fine" | "coarse"), .cell_size (m), .seed (int)
    palettes: dict  # palette name -> ndarray of library indices


_LIGHT = np.array([0.4, 0.3, 1.0]) / np.linalg.norm([0.4, 0.3, 1.0])
_WALL_R, _WALL_H = 6.0, 5.0
CHART = (-1.1, -1.5, 0.15, 0.025)  # x0, y0, patch side, gap (m); 6 × 4 patches on the floor
CARD = (0.3, -1.5, 0.3)  # x0, y0, side (m): the flat white reference card
# boxes: centre x, y, half sizes (hx, hy, hz), yaw (deg), palette, cell factor
_BOXES = [
    (0.75, 0.45, 0.32, 0.26, 0.30, 20.0, "chart", 0.8),
    (-0.85, 0.35, 0.22, 0.38, 0.45, -15.0, "natural", 0.7),
    (0.05, 1.05, 0.45, 0.18, 0.22, 5.0, "test", 0.9),
]
# spheres: centre, radius, palette, cell factor
_SPHERES = [((-0.15, 0.05, 0.32), 0.32, "natural", 0.6), ((0.75, 0.45, 0.78), 0.18, "chart", 0.5)]
# capped vertical cylinders: x, y, radius, height, palette, cell factor
_CYLINDERS = [(0.95, -0.55, 0.2, 0.75, "test", 0.6), (-1.2, -0.45, 0.14, 0.5, "chart", 0.6)]


def chart_in_view(view, width: int, height: int):
    """Where the ColorChecker's 24 patch centres fall in a pinhole ``view`` (``R``, ``t``, ``f``, principal
    point at the image centre) of ``width`` × ``height`` pixels, pixel ``j`` centred at ``j``.

    Returns ``(ij, corners, area)``: the rounded (row, column) of each patch centre (24, 2), patch
    ``k`` = row · 6 + column with row 0 (dark skin …) farthest along −y; the ``[chart] corners`` (centres
    of the top-left, top-right, bottom-right and bottom-left patches, 2 decimals); the chart's area in
    pixels. None where a centre lies behind the camera or outside the image. Whether the patches are
    seen (not occluded) is the caller's to test: each simulator knows what its pixels see.
    """
    x0, y0, side, gap = CHART
    k = np.arange(24)
    col, row = k % 6, k // 6
    centre = gap + side / 2
    X = np.stack([x0 + centre + col * (side + gap), y0 + centre + (3 - row) * (side + gap), np.zeros(24)], -1)
    p = X @ np.asarray(view.R).T + view.t  # camera coordinates
    if (p[:, 2] <= 0).any():
        return None
    u = view.f * p[:, 0] / p[:, 2] + width / 2 - 0.5
    v = view.f * p[:, 1] / p[:, 2] + height / 2 - 0.5
    j, i = np.rint(u).astype(int), np.rint(v).astype(int)
    if (j < 0).any() or (i < 0).any() or (j >= width).any() or (i >= height).any():
        return None
    corners = [[round(float(u[n]), 2), round(float(v[n]), 2)] for n in (0, 5, 23, 18)]
    a = np.array(corners)
    area = 0.5 * abs(np.dot(a[:, 0], np.roll(a[:, 1], -1)) - np.dot(a[:, 1], np.roll(a[:, 0], -1)))
    return np.stack([i, j], -1), corners, float(area)


def _hash(a, b, salt: int) -> np.ndarray:
    h = (
        np.asarray(a).astype(np.int64).astype(np.uint64) * np.uint64(0x9E3779B97F4A7C15)
        ^ np.asarray(b).astype(np.int64).astype(np.uint64) * np.uint64(0xC2B2AE3D27D4EB4F)
        ^ np.uint64((salt * 0x165667B1 + 0x27D4EB2F) % 2**63)
    )
    h = (h ^ (h >> np.uint64(33))) * np.uint64(0xFF51AFD7ED558CCD)
    h = (h ^ (h >> np.uint64(33))) * np.uint64(0xC4CEB9FE1A85EC53)
    return h ^ (h >> np.uint64(33))


def _unit_float(h) -> np.ndarray:
    return (h >> np.uint64(11)).astype(np.float64) / 2.0**53


def _voronoi(uv: np.ndarray, size: float, salt: int):
    """Nearest feature point's hash and the distance (m) to the cell border, for points (N, 2)."""
    g = uv / size
    base = np.floor(g).astype(np.int64)
    d1 = np.full(len(g), np.inf)
    d2 = np.full(len(g), np.inf)
    h1 = np.zeros(len(g), np.uint64)
    for dx in (-1, 0, 1):
        for dy in (-1, 0, 1):
            cx, cy = base[:, 0] + dx, base[:, 1] + dy
            h = _hash(cx, cy, salt)
            fx = cx + 0.1 + 0.8 / 2.0**32 * (h & np.uint64(0xFFFFFFFF)).astype(np.float64)
            fy = cy + 0.1 + 0.8 / 2.0**32 * (h >> np.uint64(32)).astype(np.float64)
            d = np.hypot(g[:, 0] - fx, g[:, 1] - fy)
            closer = d < d1
            d2 = np.where(closer, d1, np.minimum(d2, d))
            h1 = np.where(closer, h, h1)
            d1 = np.where(closer, d, d1)
    return h1, 0.5 * (d2 - d1) * size


def _value_noise(uv: np.ndarray, size: float, salt: int) -> np.ndarray:
    g = uv / size
    b = np.floor(g).astype(np.int64)
    f = g - b
    f = f * f * (3 - 2 * f)

    def val(dx, dy):
        return _unit_float(_hash(b[:, 0] + dx, b[:, 1] + dy, salt))

    top = val(0, 0) * (1 - f[:, 0]) + val(1, 0) * f[:, 0]
    bot = val(0, 1) * (1 - f[:, 0]) + val(1, 1) * f[:, 0]
    return top * (1 - f[:, 1]) + bot * f[:, 1]


def _texture(scene: SceneLike, uv: np.ndarray, palette: str, size: float, salt: int):
    """Library indices (N, 3) and weights (N, 3) of the procedural texture at surface coordinates uv.

    ``texture="fine"``: Voronoi cells mixed with a second reflectance in cells a third the size under a
    smooth noise, with dark borders. ``texture="coarse"``: each cell is one constant reflectance, with a
    thin dark border (corners for SIFT), so most pixels see a flat patch.
    """
    pal = scene.palettes[palette]
    n = np.uint64(len(pal))
    if scene.config.texture == "coarse":
        h, edge = _voronoi(uv, size, salt)
        i0 = pal[(h % n).astype(np.int64)]
        e = np.where(edge < 0.025 * size, 0.9, 0.0)
        idx = np.stack([i0, np.full_like(i0, 1), np.full_like(i0, 1)], axis=1)
        return idx, np.stack([1 - e, e, np.zeros_like(e)], axis=1)
    h, edge = _voronoi(uv, size, salt)  # cells of one reflectance each …
    h2, _ = _voronoi(uv, size / 3, salt + 5)  # … mixed with a second one in smaller cells
    i0 = pal[(h % n).astype(np.int64)]
    i1 = pal[((h >> np.uint64(24)) % n).astype(np.int64)]
    m = 0.75 * _unit_float(h2 >> np.uint64(7)) * (0.3 + 0.7 * _value_noise(uv, 0.7 * size, salt + 3))
    e = np.where(edge < 0.06 * size, 0.9, 0.0)  # dark cell borders
    idx = np.stack([i0, i1, np.full_like(i0, 1)], axis=1)
    wts = np.stack([(1 - m) * (1 - e), m * (1 - e), e], axis=1)
    return idx, wts


def _radial_warp(uv: np.ndarray, a: float) -> np.ndarray:
    """Floor coordinates warped by ``r → a·log(1 + r/a)``: a Voronoi cell of fixed size in the warped
    coordinates is ``1 + r/a`` times larger at the distance ``r`` (m) from the scene's centre, which keeps
    the far floor's cells (seen foreshortened at a grazing angle) several pixels wide."""
    r = np.hypot(uv[:, 0], uv[:, 1])
    with np.errstate(invalid="ignore", divide="ignore"):
        f = np.where(r > WARP_RADIUS_MIN, a * np.log1p(r / a) / r, 1.0)
    return uv * f[:, None]


def _primitives():
    """(surface id, kind, parameters): 0 floor, 1 wall, 10+ boxes, 20+ spheres, 30+ cylinders."""
    return (
        [(0, "floor", None), (1, "wall", None)]
        + [(10 + k, "box", q) for k, q in enumerate(_BOXES)]
        + [(20 + k, "sphere", q) for k, q in enumerate(_SPHERES)]
        + [(30 + k, "cylinder", q) for k, q in enumerate(_CYLINDERS)]
    )


def _yaw(deg: float) -> np.ndarray:
    cs, sn = np.cos(np.radians(deg)), np.sin(np.radians(deg))
    return np.array([[cs, sn, 0.0], [-sn, cs, 0.0], [0.0, 0.0, 1.0]])  # world → local


def _bounds(kind: str, q):
    """Centre and radius of a sphere enclosing a primitive (for culling rays)."""
    if kind == "box":
        return np.array([q[0], q[1], q[4]]), float(np.linalg.norm(q[2:5]))
    if kind == "sphere":
        return np.asarray(q[0], float), float(q[1])
    return np.array([q[0], q[1], q[3] / 2]), float(np.hypot(q[2], q[3] / 2))


def _ray_t(kind: str, q, o: np.ndarray, d: np.ndarray) -> np.ndarray:
    """Ray parameter of the first hit in front of the origin (inf: no hit); d (M, 3) unit vectors."""
    with np.errstate(divide="ignore", invalid="ignore"):
        if kind == "floor":
            t = np.where(d[:, 2] < 0, -o[2] / d[:, 2], np.inf)
            p = o + t[:, None] * d
            return np.where(np.hypot(p[:, 0], p[:, 1]) < _WALL_R, t, np.inf)
        if kind == "wall":
            a = d[:, 0] ** 2 + d[:, 1] ** 2
            b = o[0] * d[:, 0] + o[1] * d[:, 1]
            c = o[0] ** 2 + o[1] ** 2 - _WALL_R**2
            t = (-b + np.sqrt(b * b - a * c)) / a
            z = o[2] + t * d[:, 2]
            return np.where((z >= 0) & (z <= _WALL_H), t, np.inf)
        if kind == "box":
            cx, cy, hx, hy, hz, yaw = q[:6]
            Rz = _yaw(yaw)
            ol = Rz @ (o - np.array([cx, cy, hz]))
            dl = d @ Rz.T
            half = np.array([hx, hy, hz])
            t1, t2 = (-half - ol) / dl, (half - ol) / dl
            tn, tf = np.minimum(t1, t2).max(1), np.maximum(t1, t2).min(1)
            return np.where((tn <= tf) & (tn > 0), tn, np.inf)
        if kind == "sphere":
            oc = o - np.asarray(q[0], float)
            b = d @ oc
            return -b - np.sqrt(b * b - (oc @ oc - q[1] ** 2))
        cx, cy, r, hgt = q[:4]
        a = d[:, 0] ** 2 + d[:, 1] ** 2
        b = (o[0] - cx) * d[:, 0] + (o[1] - cy) * d[:, 1]
        c = (o[0] - cx) ** 2 + (o[1] - cy) ** 2 - r * r
        t = (-b - np.sqrt(b * b - a * c)) / a
        z = o[2] + t * d[:, 2]
        side = np.where((z >= 0) & (z <= hgt), t, np.inf)
        tc = np.where(d[:, 2] < 0, (hgt - o[2]) / d[:, 2], np.inf)
        pc = o + tc[:, None] * d
        cap = np.where(np.hypot(pc[:, 0] - cx, pc[:, 1] - cy) <= r, tc, np.inf)
        return np.minimum(side, cap)


def _surface(kind: str, q, p: np.ndarray):
    """Normals (M, 3) and texture coordinates (M, 2), in metres, at hit points p (M, 3)."""
    M = len(p)
    if kind == "floor":
        return np.broadcast_to([0.0, 0.0, 1.0], (M, 3)), p[:, :2]
    if kind == "wall":
        n = -np.stack([p[:, 0], p[:, 1], np.zeros(M)], 1) / np.hypot(p[:, 0], p[:, 1])[:, None]
        return n, np.stack([np.arctan2(p[:, 1], p[:, 0]) * _WALL_R, p[:, 2]], 1)
    if kind == "box":
        cx, cy, hx, hy, hz, yaw = q[:6]
        Rz = _yaw(yaw)
        pl = (p - np.array([cx, cy, hz])) @ Rz.T
        axis = np.argmax(np.abs(pl) / np.array([hx, hy, hz]), axis=1)
        sign = np.sign(pl[np.arange(M), axis])
        nl = np.zeros((M, 3))
        nl[np.arange(M), axis] = sign
        coords = np.where(
            axis[:, None] == 2, pl[:, :2], np.where(axis[:, None] == 0, pl[:, [1, 2]], pl[:, [0, 2]])
        )
        return nl @ Rz, coords + 3.7 * axis[:, None] + 1.3 * (sign[:, None] > 0)
    if kind == "sphere":
        n = (p - np.asarray(q[0], float)) / q[1]
        r = q[1]
        return n, np.stack([np.arctan2(n[:, 1], n[:, 0]) * r, np.arcsin(np.clip(n[:, 2], -1, 1)) * r], 1)
    cx, cy, r, hgt = q[:4]
    rad = np.hypot(p[:, 0] - cx, p[:, 1] - cy)
    cap = (p[:, 2] > hgt - RAY_SURFACE) & (rad < r * (1 - RAY_SURFACE))
    n = np.where(
        cap[:, None], [0.0, 0.0, 1.0], np.stack([(p[:, 0] - cx) / r, (p[:, 1] - cy) / r, np.zeros(M)], 1)
    )
    side_uv = np.stack([np.arctan2(p[:, 1] - cy, p[:, 0] - cx) * r, p[:, 2]], 1)
    uv = np.where(cap[:, None], p[:, :2] + 5.1, side_uv)
    return n, uv


def shade(scene: SceneLike, o: np.ndarray, d: np.ndarray):
    """Nearest hit of every ray (origin o (3,), directions d (N, 3)) → library indices, weights, depth."""
    N = len(d)
    cell = scene.config.cell_size
    t_best = np.full(N, np.inf)
    surf = np.full(N, -1)
    prims = _primitives()
    for sid, kind, q in prims:
        if kind in ("floor", "wall"):
            sel = np.arange(N)
        else:
            c, rad = _bounds(kind, q)
            oc = o - c
            b = d @ oc
            disc = b * b - (oc @ oc - rad * rad)
            with np.errstate(invalid="ignore"):
                sel = np.nonzero((disc >= 0) & (-b + np.sqrt(np.maximum(disc, 0)) > 0))[0]
        if not len(sel):
            continue
        t = _ray_t(kind, q, o, d[sel])
        better = (t > RAY_T_MIN) & (t < t_best[sel])
        t_best[sel[better]] = t[better]
        surf[sel[better]] = sid
    hit_p = o + np.where(np.isfinite(t_best), t_best, 0.0)[:, None] * d
    normal = np.zeros((N, 3))
    uv = np.zeros((N, 2))
    for sid, kind, q in prims:
        m = surf == sid
        if m.any():
            normal[m], uv[m] = _surface(kind, q, hit_p[m])

    idx = np.zeros((N, 3), np.int64)
    wts = np.zeros((N, 3))
    groups = [(0, "natural", cell, 11), (1, "wall", 3 * cell, 12)]
    groups += [(10 + k, b[6], b[7] * cell, 13 + k) for k, b in enumerate(_BOXES)]
    groups += [(20 + k, s[2], s[3] * cell, 23 + k) for k, s in enumerate(_SPHERES)]
    groups += [(30 + k, c[4], c[5] * cell, 33 + k) for k, c in enumerate(_CYLINDERS)]
    coarse = scene.config.texture == "coarse"
    for sid, palette, size, salt in groups:
        sel = surf == sid
        if sel.any():
            u = uv[sel]
            if coarse and sid == 0:
                u = _radial_warp(u, 1.0)  # floor cells grow with the distance from the centre
            idx[sel], wts[sel] = _texture(scene, u, palette, size, salt + 100 * scene.config.seed)
    # the chart and the white card are flat patches on the floor (a texture override)
    fl = surf == 0
    x0, y0, side, gap = CHART
    px, py = hit_p[:, 0] - x0, hit_p[:, 1] - y0
    on_chart = fl & (px >= 0) & (px < 6 * (side + gap) + gap) & (py >= 0) & (py < 4 * (side + gap) + gap)
    ci, cj = np.floor((px - gap) / (side + gap)).astype(int), np.floor((py - gap) / (side + gap)).astype(int)
    inside = (
        on_chart
        & ((px - gap) - ci * (side + gap) < side)
        & ((py - gap) - cj * (side + gap) < side)
        & (px >= gap)
        & (py >= gap)
    )
    chart = scene.palettes["colorchecker"]
    idx[on_chart] = 1
    wts[on_chart] = (1.0, 0.0, 0.0)
    patch = np.clip((3 - cj) * 6 + ci, 0, 23)  # row 0 (dark skin …) farthest from the camera side
    idx[inside, 0] = chart[patch[inside]]
    cx0, cy0, cs = CARD
    card = (
        fl
        & (hit_p[:, 0] >= cx0)
        & (hit_p[:, 0] <= cx0 + cs)
        & (hit_p[:, 1] >= cy0)
        & (hit_p[:, 1] <= cy0 + cs)
    )
    idx[card] = 0
    wts[card] = (1.0, 0.0, 0.0)
    shading = np.clip(0.4 + 0.6 * np.maximum(normal @ _LIGHT, 0.0) / _LIGHT[2], 0.0, 1.0)
    wts *= np.where(surf >= 0, shading, 0.0)[:, None]
    return idx, wts, t_best
