"""numba kernels of the ``"cpu"`` rendering back-end (:func:`splat.rendering.render_cpu`).

Front-to-back compositing of depth-sorted, tile-binned 2-D Gaussians and its exact backward pass, the
split that gsplat's CUDA rasteriser makes (projection differentiated by JAX, rasterisation by hand):

- :func:`bin_tiles` lists, for each 16-pixel tile, the valid Gaussians whose cut-off box overlaps it, in
  depth order — the same overlap test, in the same float32 arithmetic, as :func:`render_tiled`, but with
  no capacity: nothing is dropped;
- :func:`forward` composites each pixel (``C = Σ c_i α_i T_i``, ``T_{i+1} = T_i (1 − α_i)``) and keeps
  its final transmittance and the number of list entries it went through;
- :func:`backward` walks each tile's list back to front, recovering ``T_i = T_{i+1} / (1 − α_i)`` per
  pixel, and returns ∂L/∂(means2d, conics, opacities, colours) from ∂L/∂C and ∂L/∂T, and on request
  the sum over pixels of each pixel's |∂L/∂means2d| (AbsGS' densification statistic).

Both visit a tile Gaussian by Gaussian (in depth order, or its reverse) and each Gaussian only over the
pixels of its cut-off box: most Gaussians listed for a 16 × 16 tile cover a few of its pixels, so this
does a fraction of the pixel × list work of a pixel-by-pixel walk (3DGS' CUDA kernels, one thread per
pixel, test every listed Gaussian at every pixel).

Per-pixel termination follows the tiled back-end: a pixel stops at a chunk boundary of its tile's list
(every ``chunk`` entries) once ``T ≤ transmittance_min``. The tiles run in parallel (``prange``); the
backward pass accumulates each block of tiles into its own float64 buffer and sums the blocks in a fixed
order, so gradients are deterministic whatever the number of threads.

Imported on first use (numba costs ~1 s to import); compiled once and cached on disk where the package
directory is writable.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit, prange

#: Tiles are split into this many blocks for the backward pass (one float64 gradient buffer each).
N_BLOCKS = 16


@njit(inline="always")
def _floor(v):
    """floor(v) as an int, with v first clipped to ±1e9 (a huge box must not overflow the int)."""
    return math.floor(min(max(v, -1e9), 1e9))


@njit(inline="always")
def _visit_tiles(g, means2d, extents, s, nx, ny, counts, ids, fill, do_fill):
    """Count (``do_fill`` False) or list Gaussian g in every tile whose pixel centres its box overlaps."""
    half, last = np.float32(0.5), np.float32(s - 1)
    mx, my = means2d[g, 0], means2d[g, 1]
    ex, ey = extents[g, 0], extents[g, 1]
    # a range one tile wider than the exact one; the float32 test below decides, as render_tiled does
    tx0 = max(_floor((mx - ex - half - last) / s) - 1, 0)
    tx1 = min(_floor((mx + ex - half) / s) + 1, nx - 1)
    ty0 = max(_floor((my - ey - half - last) / s) - 1, 0)
    ty1 = min(_floor((my + ey - half) / s) + 1, ny - 1)
    for ty in range(ty0, ty1 + 1):
        y0 = np.float32(ty * s) + half
        if not (my + ey >= y0 and my - ey <= y0 + last):
            continue
        for tx in range(tx0, tx1 + 1):
            x0 = np.float32(tx * s) + half
            if mx + ex >= x0 and mx - ex <= x0 + last:
                t = ty * nx + tx
                if do_fill:
                    ids[fill[t]] = g
                    fill[t] += 1
                else:
                    counts[t + 1] += 1


@njit(cache=True)
def bin_tiles(means2d, extents, order, n_valid, H, W, s):
    """Tile lists: ``(offsets (n_tiles + 1,), ids (n_hits,), max_per_tile)``.

    ``order`` holds the valid Gaussians' indices in depth order (its first ``n_valid`` entries). A
    Gaussian hits tile ``(ty, tx)`` when its box ``means2d ± extents`` overlaps the tile's pixel
    centres ``[tx·s + 0.5, tx·s + s − 0.5]`` (and likewise in y), as in ``render_tiled``.
    """
    ny = (H + s - 1) // s
    nx = (W + s - 1) // s
    nt = ny * nx
    counts = np.zeros(nt + 1, np.int64)
    ids = np.empty(0, np.int32)
    for r in range(n_valid):
        _visit_tiles(order[r], means2d, extents, s, nx, ny, counts, ids, counts, False)
    max_per_tile = 0
    for t in range(nt):
        max_per_tile = max(max_per_tile, counts[t + 1])
        counts[t + 1] += counts[t]
    ids = np.empty(counts[nt], np.int32)
    fill = counts[:nt].copy()
    for r in range(n_valid):
        _visit_tiles(order[r], means2d, extents, s, nx, ny, counts, ids, fill, True)
    return counts, ids, max_per_tile


@njit(inline="always")
def _alpha(px, py, g, means2d, conics, opac, cut2, alpha_min, alpha_max):
    """(alpha, dx, dy, clipped, exp(−q/2)) of Gaussian g at pixel centre (px, py); alpha 0 outside the
    cut-off and below ``alpha_min``; ``clipped`` where ``alpha_max`` bounds it (no gradient there)."""
    dx = px - means2d[g, 0]
    dy = py - means2d[g, 1]
    a, b, c = conics[g, 0], conics[g, 1], conics[g, 2]
    q = a * dx * dx + 2 * b * dx * dy + c * dy * dy
    if q > cut2:
        return 0.0, dx, dy, False, 0.0
    gauss = math.exp(-0.5 * q)
    alpha = opac[g] * gauss
    clipped = False
    if alpha > alpha_max:
        alpha = alpha_max * 1.0
        clipped = True
    if alpha < alpha_min:
        return 0.0, dx, dy, False, gauss
    return alpha, dx, dy, clipped, gauss


@njit(inline="always")
def _box(g, means2d, extents, x0, y0, s, W, H):
    """Pixel offsets ``(ox0, ox1, oy0, oy1)`` (inclusive) of the tile at pixel ``(x0, y0)`` whose centres
    may lie in Gaussian g's cut-off ellipse: its bounding box ``means2d ± extents``, one pixel wider
    (rounding), clipped to the tile and the image. Outside it ``q > cut²`` and alpha is 0."""
    mx, my = means2d[g, 0], means2d[g, 1]
    ex, ey = extents[g, 0], extents[g, 1]
    ox0 = max(_floor(mx - ex - 0.5) - x0, 0)
    ox1 = min(_floor(mx + ex - 0.5) + 1 - x0, s - 1, W - 1 - x0)
    oy0 = max(_floor(my - ey - 0.5) - y0, 0)
    oy1 = min(_floor(my + ey - 0.5) + 1 - y0, s - 1, H - 1 - y0)
    return ox0, ox1, oy0, oy1


@njit(parallel=True, cache=True)
def forward(
    means2d, conics, opac, colours, extents, offsets, ids, H, W, s, cut2, alpha_min, alpha_max, tmin, chunk
):
    """Composite every pixel: colour ``C`` (H, W, k), final transmittance ``T`` (H, W) and the number
    of list entries each pixel went through, ``n_done`` (H, W).

    Gaussian by Gaussian in the tile's depth order, each over the pixels of its cut-off box only (each
    pixel still sees its Gaussians in depth order). At every ``chunk``-th entry, pixels whose
    transmittance has fallen to ``tmin`` stop (``tmin`` 0: none do)."""
    k = colours.shape[1]
    nx = (W + s - 1) // s
    nt = offsets.shape[0] - 1
    C = np.zeros((H, W, k), colours.dtype)
    T = np.ones((H, W), colours.dtype)
    n_done = np.zeros((H, W), np.int32)
    half = np.float32(0.5)
    for t in prange(nt):
        ty, tx = t // nx, t % nx
        x0, y0 = tx * s, ty * s
        lo, hi = offsets[t], offsets[t + 1]
        Tl = np.ones((s, s))
        Cl = np.zeros((s, s, k))
        nd = np.full((s, s), hi - lo, np.int32)
        live = np.zeros((s, s), np.bool_)
        live[: min(s, H - y0), : min(s, W - x0)] = True
        n_live = min(s, H - y0) * min(s, W - x0)
        qx = np.empty(s, colours.dtype)  # a·dx² per column of the box (float32 as in _alpha)
        bx = np.empty(s)  # 2b·dx per column (float64 as in _alpha)
        col = np.empty(k)
        for r in range(lo, hi):
            if tmin > 0 and (r - lo) % chunk == 0:
                for oy in range(s):
                    for ox in range(s):
                        if live[oy, ox] and Tl[oy, ox] <= tmin:
                            live[oy, ox] = False
                            nd[oy, ox] = r - lo
                            n_live -= 1
                if n_live == 0:
                    break
            g = ids[r]
            ox0, ox1, oy0, oy1 = _box(g, means2d, extents, x0, y0, s, W, H)
            # _alpha's q = a·dx·dx + 2·b·dx·dy + c·dy·dy with its column and row parts computed once per
            # Gaussian and tile, in the same order and types: the same numbers, fewer operations
            mx, my, op = means2d[g, 0], means2d[g, 1], opac[g]
            a, b, c = conics[g, 0], conics[g, 1], conics[g, 2]
            for ox in range(ox0, ox1 + 1):
                dx = (np.float32(x0 + ox) + half) - mx
                qx[ox] = a * dx * dx
                bx[ox] = 2 * b * dx
            for j in range(k):
                col[j] = colours[g, j]
            for oy in range(oy0, oy1 + 1):
                dy = (np.float32(y0 + oy) + half) - my
                qy = c * dy * dy
                for ox in range(ox0, ox1 + 1):
                    if not live[oy, ox]:
                        continue
                    q = qx[ox] + bx[ox] * dy + qy
                    if q > cut2:
                        continue
                    alpha = op * math.exp(-0.5 * q)
                    if alpha > alpha_max:
                        alpha = alpha_max * 1.0
                    if alpha < alpha_min:
                        continue
                    w = alpha * Tl[oy, ox]
                    for j in range(k):
                        Cl[oy, ox, j] += col[j] * w
                    Tl[oy, ox] *= 1 - alpha
        for oy in range(min(s, H - y0)):
            for ox in range(min(s, W - x0)):
                T[y0 + oy, x0 + ox] = Tl[oy, ox]
                n_done[y0 + oy, x0 + ox] = nd[oy, ox]
                for j in range(k):
                    C[y0 + oy, x0 + ox, j] = Cl[oy, ox, j]
    return C, T, n_done


@njit(parallel=True, cache=True)
def backward(
    means2d, conics, opac, colours, extents, offsets, ids, T, n_done, gC, gT, H, W, s, cut2, alpha_min,
    alpha_max, absgrad,
):  # fmt: skip
    """∂L/∂(means2d, conics, opacities, colours) from ∂L/∂C (H, W, k) and ∂L/∂T (H, W).

    Returns an array (G, 6 + k), or (G, 8 + k) when ``absgrad`` is true: columns 0–1 ∂L/∂means2d, 2–4
    ∂L/∂conics, 5 ∂L/∂opacity, then k columns ∂L/∂colours and, with ``absgrad``, two columns
    ``Σ_p |∂L_p/∂means2d|`` per axis (each pixel's contribution taken absolutely before the sum, so that
    contributions of opposite sign over a textured footprint do not cancel; Ye et al. 2024).

    For pixel p and its i-th Gaussian, with ``S_i = Σ_{j>i} c_j α_j T_j`` and ``T_f`` the final
    transmittance: ``∂C/∂c_i = α_i T_i``, ``∂C/∂α_i = c_i T_i − S_i / (1 − α_i)``,
    ``∂T_f/∂α_i = −T_f / (1 − α_i)``; ``α = min(α_max, o·exp(−q/2))`` with
    ``q = a dx² + 2b dx dy + c dy²`` and ``d = p − mean``. Each tile's list is walked back to front,
    ``T_i = T_{i+1} / (1 − α_i)`` recovered per pixel, each Gaussian over its cut-off box only.
    """
    G, k = colours.shape
    nx = (W + s - 1) // s
    nt = offsets.shape[0] - 1
    per = (nt + N_BLOCKS - 1) // N_BLOCKS
    ncol = 8 + k if absgrad else 6 + k
    buf = np.zeros((N_BLOCKS, G, ncol))  # dmx, dmy, da, db, dc, do, dcolours[, |dmx|, |dmy|]
    for blk in prange(N_BLOCKS):
        out = buf[blk]
        d = np.zeros(ncol)
        for t in range(blk * per, min(nt, (blk + 1) * per)):
            ty, tx = t // nx, t % nx
            x0, y0 = tx * s, ty * s
            lo = offsets[t]
            hy, wx = min(s, H - y0), min(s, W - x0)
            Tn = np.empty((s, s))  # T_{i+1} per pixel
            acc = np.zeros((s, s))  # g · S_i per pixel
            nd = np.zeros((s, s), np.int32)
            last = 0
            for oy in range(hy):
                for ox in range(wx):
                    Tn[oy, ox] = T[y0 + oy, x0 + ox]
                    nd[oy, ox] = n_done[y0 + oy, x0 + ox]
                    last = max(last, nd[oy, ox])
            for r in range(lo + last - 1, lo - 1, -1):
                g = ids[r]
                ox0, ox1, oy0, oy1 = _box(g, means2d, extents, x0, y0, s, W, H)
                d[:] = 0
                hit = False
                a, b, c = conics[g, 0], conics[g, 1], conics[g, 2]
                for oy in range(oy0, oy1 + 1):
                    y = y0 + oy
                    py = np.float32(y) + np.float32(0.5)
                    for ox in range(ox0, ox1 + 1):
                        if r - lo >= nd[oy, ox]:
                            continue
                        x = x0 + ox
                        px = np.float32(x) + np.float32(0.5)
                        alpha, dx, dy, clipped, gauss = _alpha(
                            px, py, g, means2d, conics, opac, cut2, alpha_min, alpha_max
                        )
                        if alpha == 0:
                            continue
                        hit = True
                        om = 1 - alpha
                        Ti = Tn[oy, ox] / om
                        gc_dot = 0.0
                        for j in range(k):
                            gc_dot += gC[y, x, j] * colours[g, j]
                            d[6 + j] += gC[y, x, j] * alpha * Ti
                        d_alpha = gc_dot * Ti - (acc[oy, ox] + gT[y, x] * T[y, x]) / om
                        acc[oy, ox] += gc_dot * alpha * Ti
                        Tn[oy, ox] = Ti
                        if clipped:
                            continue
                        d[5] += d_alpha * gauss
                        dq = -0.5 * alpha * d_alpha
                        gmx = dq * 2.0 * (a * dx + b * dy)
                        gmy = dq * 2.0 * (b * dx + c * dy)
                        d[0] -= gmx
                        d[1] -= gmy
                        if absgrad:
                            d[6 + k] += abs(gmx)
                            d[7 + k] += abs(gmy)
                        d[2] += dq * dx * dx
                        d[3] += dq * 2.0 * dx * dy
                        d[4] += dq * dy * dy
                if hit:
                    for j in range(ncol):
                        out[g, j] += d[j]
    total = np.zeros((G, ncol))
    for blk in range(N_BLOCKS):
        total += buf[blk]
    return total
