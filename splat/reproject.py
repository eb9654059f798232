"""Other photographs reprojected into a view through the splat's depth (image-based rendering).

The splat's colours are a fit that blurs: on the simulated capture its flat-pixel error in a camera's
channels is 0.013–0.021 (white = 1) at held-out views. Its *geometry* is good enough to carry the
photographs themselves from one view to another: each pixel of the target view is lifted to 3-D with the
splat's depth (:func:`depth_map`; moved along the pixel's ray to where the photographs agree,
:func:`consistent_depth`), projected into a source photograph, and the source's demosaiced value read
there (bilinear) when the source sees that point (its own splat depth agrees within :data:`DEPTH_RTOL`).
The photographs of a camera that see the point are combined into that camera's reprojected response
(:func:`reprojected`: their median, or with each one's noise variance, their inverse-variance mean
within :data:`TRIM_SIGMA` σ + :data:`TRIM_RTOL` of the median): 0.004–0.016 on the same pixels (the
median of Malvar-demosaiced sources), measured values rather than a model of them.
Pixels that no photograph of a camera sees keep the render for that camera (:mod:`splat.fusion`).

The scene must be Lambertian for this to hold (a glossy highlight moves with the view); the render's
view-independent colours assume the same.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import NamedTuple

import numpy as np

from ._errors import SplatError
from ._tol import SOURCE_BAND_ROWS

__all__ = [
    "DEPTH_RTOL",
    "MIN_ALPHA",
    "SWEEP_FLOOR",
    "SWEEP_PRIOR",
    "SWEEP_RANGE",
    "SWEEP_STEPS",
    "SWEEP_WINDOW",
    "TRIM_RTOL",
    "TRIM_SIGMA",
    "RowSource",
    "consistent_depth",
    "depth_map",
    "reproject",
    "reproject_rows",
    "reprojected",
    "visibility",
]

#: A source photograph sees a target pixel's 3-D point when the point's depth in the source and the
#: splat's depth at the projected pixel agree within this fraction: the splat's depth of one surface is
#: good to ~1 % at the simulated capture's 3–6 m (a 130-px image spans ~5 cm per pixel there), while an
#: occluder in front is ≥ 10 % nearer.
DEPTH_RTOL = 0.03

#: Pixels whose splat opacity is below this have no depth (background, holes): a target pixel below it
#: is not reprojected, and a source whose depth is given as 0 there (as the pipeline does,
#: ``np.where(alpha >= MIN_ALPHA, depth, 0)``) does not vouch for visibility. The depth is normalised by
#: the opacity, so a half-transparent surface still has one, and the 3 % depth test still rejects
#: occluded points. A trained splat is half-transparent over much of its surfaces, the more so when
#: trained on binned photographs (benchmark capture, 16,384 Gaussians: median Gaussian opacity 0.67 /
#: 0.54 / 0.26 at binning 1 / 2 / 4; at binning 4, 39 % of a held-out view's region pixels reach 0.5),
#: while its depth stays the surface's (0.2–0.4 % from the sources' at the median). 12 held-out views,
#: Prior on the fused responses (chart / uniform region means, flat pixels; ΔE00), 0.5 → 0.05 with the
#: own camera's reprojection tested against the measurement (3 σ): binning 1, 0.298 / 0.422, 0.522 → 0.294 /
#: 0.386, 0.508; binning 4 (uniform, flat, at working size) 0.668, 1.202 → 0.397, 0.563; 0.1 the same to
#: 0.01. The full-size output at binning 4 (with :func:`splat.resolution.working_footprint`), region
#: means 1.184 / 1.271 → 0.440 / 0.621; at its stage alone, 0.2 gave 0.539 / 0.885 and 0.02 0.448 /
#: 0.597, where a pixel that faint may be a floater's. Earlier, 0.9 → 0.5 on the CI coarse captures
#: (flat pixels 0.460 → 0.396 ΔE00). docs/notes/2026-11-30-low-opacity-depth.md
MIN_ALPHA = 0.05

#: With the sources' noise variances given, :func:`reprojected` averages (inverse-variance weights) the
#: sources within ``TRIM_SIGMA`` of their own σ plus ``TRIM_RTOL`` of the median from the median: the
#: mean of Gaussian noise is the efficient estimate (the median wastes a third of the samples' worth),
#: and the band drops what the median guarded against — a source read across an edge or a missed
#: occlusion, off by far more than its noise. Three cameras fused, CI coarse capture with shot and read
#: noise, flat held-out pixels: median 1.086 ΔE00, plain mean 1.191, inverse-variance mean 1.125, this
#: band 0.992 (2σ + 0.5 %: 1.011); noise-free, 0.339 either way.
TRIM_SIGMA = 3.0
TRIM_RTOL = 0.01

#: :func:`consistent_depth` tries the splat's depth times ``exp(u)`` for ``SWEEP_STEPS`` values of ``u``
#: evenly spaced in ±``ln(1 + SWEEP_RANGE)`` (a step of 1 %), averages each scale's cost over a
#: ``SWEEP_WINDOW`` × ``SWEEP_WINDOW`` neighbourhood, and adds ``SWEEP_PRIOR · |u|`` so that the splat's
#: own depth is kept where the photographs cannot tell (a textureless patch costs the same at every
#: scale) or hardly can (noise). The cost of a pixel is the sources' mean absolute deviation from their
#: median relative to ``|median| + SWEEP_FLOOR`` (exposure-1 units; a white patch reads 0.3–0.6). Why: a
#: trained splat's depth drifts with training — CI coarse capture, noise-free, held-out views, three
#: cameras fused, flat pixels: 0.341 ΔE00 after 1000 steps, 0.447 after 2000, and 0.354 / 0.365 with the
#: simulator's true depth substituted (an oracle only) — and a ½–2 px misregistration of the photographs
#: costs colour near every edge. ``SWEEP_PRIOR`` was chosen on three models (fused; 1000 steps / 2000
#: steps / 1000 steps with shot and read noise): none 0.341 / 0.447 / 0.966; 0.2: 0.340 / 0.375 /
#: 0.986; **1: 0.320 / 0.362 / 0.974**; 3: 0.335 / 0.398 / 0.970 (a sum of squares normalised by the number
#: of photographs instead of the absolute deviation, 0.2: 0.347 / 0.401 / 0.977), then checked on three
#: others (README).
SWEEP_RANGE = 0.06
SWEEP_STEPS = 13
SWEEP_WINDOW = 5
SWEEP_PRIOR = 1.0
SWEEP_FLOOR = 0.01


def depth_map(gaussians, camera, *, mask=None, colour: bool = False, config=None):
    """The splat's depth (expected camera-space ``z`` of the composited Gaussians, divided by their
    opacity) and accumulated opacity of a view, each (H, W); with ``colour``, also its render
    (H, W, k), from the same pass.

    Renders the Gaussians with two channels, ``z`` of each centre in the camera and 1 (after their
    ``k`` colour channels when ``colour``), through the same renderer as the colours (so depth and
    colour come from the same compositing weights), with ``config`` (:class:`splat.RenderConfig`,
    default the renderer's).
    """
    from .gaussians import Gaussians, inverse_softplus
    from .outputs import render_views

    means = np.asarray(gaussians.means, np.float64)
    z = means @ np.asarray(camera.R, np.float64)[2] + float(np.asarray(camera.t, np.float64)[2])
    params = inverse_softplus(np.stack([np.maximum(z, 1e-3), np.ones_like(z)], 1).astype(np.float32))
    k = 0
    if colour:
        own = np.asarray(gaussians.colour_params, np.float32)
        k = own.shape[1]
        params = np.concatenate([own, params], 1)
    g = Gaussians(gaussians.means, gaussians.quats, gaussians.log_scales, gaussians.opacity_logits, params)
    img = render_views(g, [camera], mask=mask, config=config)[0].astype(np.float64)
    alpha = img[..., k + 1]
    depth = img[..., k] / np.maximum(alpha, 1e-6)
    return (depth, alpha, img[..., :k]) if colour else (depth, alpha)


def _on_host(camera):
    """The camera with float64 NumPy arrays: each ``np.asarray`` of a JAX array is a device transfer
    (~0.4 ms), and a sweep reprojects hundreds of times per view."""
    import dataclasses

    return dataclasses.replace(
        camera,
        **{k: np.asarray(getattr(camera, k), np.float64) for k in ("R", "t", "focal", "principal")},
    )


def _nanmedian0(stack: np.ndarray) -> np.ndarray:
    """``np.nanmedian(stack, axis=0)`` (NaN where all are NaN), by one sort: NaNs sort last, so the
    median of a column's ``c`` finite values is the mean of its sorted entries ``(c − 1) // 2`` and
    ``c // 2`` (~10× faster than ``nanmedian`` on a few sources of many pixels)."""
    if len(stack) <= 2:  # one or two sources: the finite one, or their mean (no sort)
        a, b = stack[0], stack[-1]
        return np.where(np.isnan(a), b, np.where(np.isnan(b), a, (a + b) / 2))
    s = np.sort(stack, axis=0)
    c = np.isfinite(s).sum(0)
    lo = np.take_along_axis(s, np.maximum(c - 1, 0)[None] // 2, axis=0)[0]
    hi = np.take_along_axis(s, (c // 2)[None], axis=0)[0]
    return np.where(c > 0, (lo + hi) / 2, np.nan)


class RowSource(NamedTuple):
    """A source photograph read a band of rows at a time, at a resolution higher than its depth map's.

    Attributes
    ----------
    camera : splat.Camera
        The photograph's camera at the image's own resolution.
    depth : ndarray of shape (Hd, Wd)
        Its splat depth at ``1 / binning`` of that resolution (``Hd = H // binning``; 0 where the splat
        has no reliable depth), for the occlusion test.
    binning : int
        The image's pixels per depth pixel along each axis (depth pixel ``i`` covers image pixel edges
        ``[f i, f (i + 1))``: :func:`splat.resolution.scale_camera`).
    rows : callable
        ``rows(a, b) → (b − a, W, c)``: image rows ``a:b`` (e.g. demosaiced from the RAW file's samples).
    variance : callable or None
        ``variance(values (..., c)) → (..., c)``: the noise variance of a pixel of the given value (affine
        in the value, so that it commutes with bilinear interpolation); None: combine by the median.
    channels : int
        ``c``.
    """

    camera: object
    depth: np.ndarray
    binning: int
    rows: Callable
    variance: Callable | None = None
    channels: int = 3


def _project(target, target_depth, target_alpha, source, min_alpha: float = MIN_ALPHA):
    """Each target pixel lifted to 3-D with ``target_depth`` and projected into ``source``: its column
    ``u`` and row ``v`` there (pixel-centre coordinates, centre of pixel (0, 0) at (0, 0)), its depth
    ``zs`` in the source, and whether it can be read (opacity ≥ ``min_alpha``, in front, inside).

    The point in the source's frame is ``d · M (x, y, 1) + c`` with ``M = R_s R_tᵀ``, ``c = t_s − M t_t``
    (the same as lifting to world coordinates and projecting): ``M (x, y, 1)`` is separable in the
    pixel's column and row, a few operations a pixel in float64."""
    d = np.asarray(target_depth, np.float64)
    Rt, tt = np.asarray(target.R, np.float64), np.asarray(target.t, np.float64)
    Rs, ts = np.asarray(source.R, np.float64), np.asarray(source.t, np.float64)
    M = Rs @ Rt.T
    c = ts - M @ tt
    fx, fy = (float(x) for x in np.asarray(target.focal, np.float64))
    cx, cy = (float(x) for x in np.asarray(target.principal, np.float64))
    x = (np.arange(target.width) + 0.5 - cx) / fx
    y = (np.arange(target.height) + 0.5 - cy) / fy
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):  # inf depths: not valid below
        ps = [d * ((M[k, 0] * x)[None, :] + (M[k, 1] * y + M[k, 2])[:, None]) + c[k] for k in range(3)]
        zs = ps[2]
        fxs, fys = (float(v) for v in np.asarray(source.focal, np.float64))
        cxs, cys = (float(v) for v in np.asarray(source.principal, np.float64))
        u = fxs * ps[0] / zs + (cxs - 0.5)  # column coordinate of pixel centres
        v = fys * ps[1] / zs + (cys - 0.5)
    inside = (
        (np.asarray(target_alpha) >= min_alpha)
        & (zs > 0)
        & (u >= 0)
        & (u <= source.width - 1)
        & (v >= 0)
        & (v <= source.height - 1)
    )
    return np.where(inside, u, 0.0), np.where(inside, v, 0.0), zs, inside


def _visible(u, v, zs, inside, source_depth, binning: int = 1):
    """Where the source's depth (at ``1 / binning`` of the image's resolution) agrees with the point's
    within :data:`DEPTH_RTOL`: the source sees the point, nothing occludes it."""
    f = float(binning)
    sd = np.asarray(source_depth, np.float64)[..., None]
    idx = np.flatnonzero(inside)  # the source's depth read at the points that can be seen only
    seen = _sample(sd, (np.ravel(v)[idx] + 0.5) / f - 0.5, (np.ravel(u)[idx] + 0.5) / f - 0.5)[..., 0]
    z = np.ravel(zs)[idx]
    out = np.zeros(np.shape(inside), bool)
    out.ravel()[idx[np.abs(seen - z) <= DEPTH_RTOL * np.abs(z)]] = True
    return out


def _sample(image, v, u):
    """``image`` (h, w, c) read bilinearly at rows ``v`` and columns ``u`` (any shape, within
    ``[0, h − 1] × [0, w − 1]``, else clamped to it): (..., c), as ``scipy.ndimage.map_coordinates(order=1,
    mode="nearest")`` per channel, with the four taps and weights found once for all channels."""
    h, w = image.shape[:2]
    v, u = np.clip(v, 0, h - 1), np.clip(u, 0, w - 1)  # mode="nearest": the border value beyond it
    i0 = np.floor(v).astype(np.intp)
    j0 = np.floor(u).astype(np.intp)
    di = np.where(i0 < h - 1, w, 0)  # the next row's offset, 0 on the last row
    dj = (j0 < w - 1).astype(np.intp)
    flat = image.reshape(h * w, -1)
    k = i0 * w + j0
    ty = (v - i0)[..., None].astype(image.dtype)
    tx = (u - j0)[..., None].astype(image.dtype)
    a, b = np.take(flat, k, axis=0), np.take(flat, k + dj, axis=0)
    c, d = np.take(flat, k + di, axis=0), np.take(flat, k + di + dj, axis=0)
    top = a + (b - a) * tx
    return top + (c + (d - c) * tx - top) * ty


def visibility(
    target,
    target_depth,
    target_alpha,
    source,
    source_depth,
    *,
    binning: int = 1,
    min_alpha: float = MIN_ALPHA,
) -> np.ndarray:
    """Where a source sees each target pixel (:func:`reproject`'s ``valid``, with ``min_alpha``) without
    reading its image: (H, W) bool; ``source_depth`` at ``1 / binning`` of ``source``'s resolution."""
    _check_target(target, target_depth, target_alpha)
    target, source = _on_host(target), _on_host(source)
    u, v, zs, inside = _project(target, target_depth, target_alpha, source, min_alpha)
    return _visible(u, v, zs, inside, source_depth, binning)


def reproject(
    target, target_depth, target_alpha, source, source_depth, source_image, *, min_alpha: float = MIN_ALPHA
):
    """A source photograph's values at each pixel of a target view, and where they are valid.

    Parameters
    ----------
    target, source : splat.Camera
        The target may be a strip or any resolution of a view (its intrinsics say which pixels it has).
    target_depth, target_alpha : ndarray of shape (H, W)
        :func:`depth_map` of the target.
    source_depth : ndarray of shape (Hs, Ws)
        :func:`depth_map` of the source (its depth only).
    source_image : ndarray of shape (Hs, Ws, c)
        The source's values (e.g. its demosaiced RAW).

    Returns
    -------
    values : ndarray of shape (H, W, c)
    valid : ndarray of shape (H, W), bool
        The target pixel has a depth (opacity ≥ ``min_alpha``, default :data:`MIN_ALPHA`), projects
        inside the source, in front of it, and the source's depth there agrees within
        :data:`DEPTH_RTOL` (not occluded).
    """
    src = np.asarray(source_image, np.float64)
    sd = np.asarray(source_depth, np.float64)
    if src.ndim != 3:
        raise SplatError(f"reproject: the source image must be (Hs, Ws, c), got shape {src.shape}.")
    if src.shape[:2] != sd.shape or sd.shape != (source.height, source.width):
        raise SplatError(
            f"reproject: source image {src.shape[:2]} and depth {sd.shape} must both be the source "
            f"camera's size {(source.height, source.width)}."
        )
    _check_target(target, target_depth, target_alpha)
    u, v, zs, inside = _project(target, target_depth, target_alpha, source, min_alpha)
    valid = _visible(u, v, zs, inside, sd)
    return np.where(valid[..., None], _sample(src, v, u), 0.0), valid


def _check_target(target, target_depth, target_alpha):
    d = np.shape(target_depth)
    if d != (target.height, target.width):
        raise SplatError(f"reproject: target depth {d} is not the target's size.")
    if np.shape(target_alpha) != d:
        raise SplatError(f"reproject: target alpha {np.shape(target_alpha)} is not the target's size {d}.")


def reproject_rows(
    target,
    target_depth,
    target_alpha,
    source: RowSource,
    *,
    band: int = SOURCE_BAND_ROWS,
    min_alpha: float = MIN_ALPHA,
):
    """:func:`reproject` from a :class:`RowSource`, reading only the source rows the target's pixels
    land on, at most ``band`` (+ 1) rows at a time (``rows`` is asked for just the rows a band needs;
    a caching reader can keep more): the same values and validity as :func:`reproject`
    of the whole source image with its depth upsampled (bilinear reads need rows ``⌊v⌋`` and ``⌊v⌋ + 1``
    only), memory bounded by the band whatever the source's size.

    Returns
    -------
    values : ndarray of shape (H, W, c), float32
    valid : ndarray of shape (H, W), bool
    """
    cam, depth, f, rows = source.camera, source.depth, int(source.binning), source.rows
    if f < 1 or np.shape(depth) != (cam.height // f, cam.width // f):
        raise SplatError(
            f"reproject_rows: source depth {np.shape(depth)} is not 1/{f} of the source's size "
            f"{(cam.height, cam.width)}."
        )
    if band < 1:
        raise SplatError(f"reproject_rows: band={band} rows; give at least 1.")
    _check_target(target, target_depth, target_alpha)
    u, v, zs, inside = _project(target, target_depth, target_alpha, cam, min_alpha)
    valid = _visible(u, v, zs, inside, depth, f)
    out = np.zeros((*valid.shape, source.channels), np.float32)
    idx = np.flatnonzero(valid)
    if idx.size == 0:
        return out, valid
    vv, uu = v.ravel()[idx], u.ravel()[idx]
    r = np.floor(vv).astype(np.int64)
    order = np.argsort(r, kind="stable")
    idx, vv, uu, r = idx[order], vv[order], uu[order], r[order]
    flat = out.reshape(-1, source.channels)
    a = 0
    while a < idx.size:
        lo = int(r[a])
        b = int(np.searchsorted(r, lo + band, side="left"))
        img = np.asarray(rows(lo, min(int(r[b - 1]) + 2, cam.height)), np.float32)
        flat[idx[a:b]] = _sample(img, vv[a:b] - lo, uu[a:b])
        a = b
    return out, valid


#: Rows of the target that :func:`_combine` works through at a time, so that its elementwise passes run
#: in cache: a strip of 128 × 5632 px, two sources with variances, 50–53 ms against 119–121 ms for the
#: whole strip at once (16 rows: 73 ms) and 257 ms for the former NaN-marked stacks.
COMBINE_ROWS = 8


def _combine(values, ok, var=None, *, rows: int = COMBINE_ROWS) -> tuple[np.ndarray, np.ndarray]:
    """Several sources' values combined per pixel, and how many see each pixel.

    ``values``: n arrays (H, W, c), finite, 0 where the source does not see the pixel; ``ok`` (n, H, W)
    bool: where it does; ``var``: n arrays (H, W, c) of finite noise variances (any finite value where
    the source does not see the pixel), or None. With variances, the inverse-variance mean of the
    sources within ``TRIM_SIGMA`` σ + ``TRIM_RTOL`` × |median| of the median (the median where none
    is); without, the median; 0 where no source sees the pixel. Worked through ``rows`` rows at a time
    (the same numbers whatever ``rows``)."""
    n = len(values)
    H, W, c = np.shape(values[0])
    dtype = np.result_type(*values, *(var or ()))
    ok = np.asarray(ok, bool)
    count = ok.sum(0)
    out = np.empty((H, W, c), dtype)
    step = max(1, int(rows))
    for a in range(0, H, step):
        b = min(H, a + step)
        z = np.stack([np.asarray(x[a:b]) for x in values])
        seen, cnt = ok[:, a:b, :, None], count[a:b, :, None]
        if n <= 2:  # the one source that sees it, or the two's mean: (z₀ + z₁) / count, 0 + z = z
            med = z[0] + z[-1] if n == 2 else z[0].copy()
            med /= np.maximum(cnt, 1).astype(med.dtype)
        else:
            med = _nanmedian0(np.where(seen, z, np.nan))
            med[np.broadcast_to(cnt == 0, med.shape)] = 0
        res = out[a:b]
        res[...] = med
        if var is None:
            continue
        v = np.stack([np.asarray(x[a:b]) for x in var])
        thr = np.sqrt(v)
        thr *= TRIM_SIGMA
        thr += TRIM_RTOL * np.abs(med)
        d = np.abs(z - med)
        keep = d <= thr
        keep &= seen
        w = np.maximum(v, 1e-30)
        np.divide(1.0, w, out=w)
        w *= keep  # 1/σ² where kept, else 0 (σ² finite)
        wsum = w.sum(0)
        pos = wsum > 0
        mean = (z * w).sum(0)
        mean /= wsum + ~pos  # where none is kept: ÷ 1, then the median below
        np.copyto(res, mean, where=pos)
    return out, count


def reprojected(
    target, target_depth, target_alpha, sources, *, min_alpha: float = MIN_ALPHA
) -> tuple[np.ndarray, np.ndarray]:
    """Several source photographs reprojected into a target view and combined, and how many see each
    pixel.

    Parameters
    ----------
    target : splat.Camera
        A view, or a strip or any resolution of one (its intrinsics say which pixels it has).
    target_depth, target_alpha : ndarray of shape (H, W)
    sources : iterable of (Camera, depth (Hs, Ws), image (Hs, Ws, c)), (…, variance (Hs, Ws, c)) or RowSource
        With a per-pixel noise variance for every source, the sources that see a pixel are combined by
        their inverse-variance mean over those within ``TRIM_SIGMA`` σ + ``TRIM_RTOL`` × |median| of
        the median (the median where none is); without, by the median. A :class:`RowSource` is read a
        band of rows at a time (:func:`reproject_rows`).
    min_alpha : float
        A target pixel is lifted where the splat's opacity reaches this (default :data:`MIN_ALPHA`).

    Returns
    -------
    values : ndarray of shape (H, W, c)
        0 at pixels that no source sees.
    count : ndarray of shape (H, W), int
        Sources that see each pixel.
    """
    values, oks, var = [], [], []
    target = _on_host(target)
    for src in sources:
        if isinstance(src, RowSource):
            vals, ok = reproject_rows(
                target,
                target_depth,
                target_alpha,
                src._replace(camera=_on_host(src.camera)),
                min_alpha=min_alpha,
            )
            values.append(vals)
            oks.append(ok)
            if src.variance is not None:  # elementwise, finite at the zeros where the source does not see
                var.append(src.variance(vals))
            continue
        cam, depth, image, *rest = src
        cam = _on_host(cam)
        if len(rest) > 1:
            raise SplatError("reprojected: a source is (camera, depth, image[, variance]).")
        image = np.asarray(image, np.float64)
        c = image.shape[-1]
        if rest:  # reprojected together with the image: one interpolation, the same pixels
            v = np.asarray(rest[0], np.float64)
            if v.shape != image.shape or not np.all(np.isfinite(v)) or (v < 0).any():
                raise SplatError(
                    f"reprojected: a source's variance {v.shape} must be finite, ≥ 0 and the shape of its "
                    f"image {image.shape}."
                )
            image = np.concatenate([image, v], axis=-1)
        vals, ok = reproject(target, target_depth, target_alpha, cam, depth, image, min_alpha=min_alpha)
        values.append(vals[..., :c])
        oks.append(ok)
        if rest:
            var.append(vals[..., c:])
    if not values:
        raise SplatError("reprojected: no source photograph given.")
    if len({v.shape for v in values}) > 1:
        raise SplatError(
            "reprojected: the source images differ in size or channel count: "
            f"{[v.shape[-1] for v in values]} channels."
        )
    if var and len(var) != len(values):
        raise SplatError("reprojected: give a variance for every source or for none.")
    return _combine(values, np.stack(oks), var or None)


def consistent_depth(
    target,
    target_depth,
    target_alpha,
    groups,
    *,
    steps: int = SWEEP_STEPS,
    span: float = SWEEP_RANGE,
    window: int = SWEEP_WINDOW,
    prior: float = SWEEP_PRIOR,
) -> tuple[np.ndarray, np.ndarray]:
    """The splat's depth of a view rescaled, pixel by pixel, to where the photographs agree (a plane
    sweep along each pixel's ray).

    For each trial scale ``s`` (``steps`` values, an odd number, geometric in ``[1/(1 + span), 1 + span]``,
    1 among them) every source is reprojected through ``s · depth``; a pixel's cost is
    the mean, over the photographs of each group that see it (at least two), of their absolute
    deviation from the group's median relative to ``|median| +`` :data:`SWEEP_FLOOR`, averaged over
    channels and groups. Costs are averaged over a ``window`` × ``window`` neighbourhood (pixels with a
    cost only; at least half the window), ``prior · |ln s|`` is added, and each pixel takes the
    cheapest scale. Pixels without a cost at the splat's own depth (fewer than two photographs of any
    group see them there) keep it; so does a depth more than :data:`DEPTH_RTOL` off the sources' own
    (the photographs do not see the point lifted with it).

    Parameters
    ----------
    target : splat.Camera
    target_depth, target_alpha : ndarray of shape (H, W)
        :func:`depth_map` of the target.
    groups : sequence of sequences of (Camera, depth (Hs, Ws), image (Hs, Ws, c)[, variance])
        The photographs, grouped so that values within a group are comparable (one camera's photographs
        at one exposure); a variance, if given, is ignored.
    steps, span, window, prior
        The sweep (:data:`SWEEP_STEPS`, :data:`SWEEP_RANGE`, :data:`SWEEP_WINDOW`, :data:`SWEEP_PRIOR`).

    Returns
    -------
    depth : ndarray of shape (H, W)
    scale : ndarray of shape (H, W)
        The factor applied to each pixel's depth (1 where it was kept).
    """
    from scipy.ndimage import uniform_filter

    d = np.asarray(target_depth, np.float64)
    groups = [list(g) for g in groups]
    if not all(isinstance(s, (tuple, list)) and len(s) in (3, 4) for g in groups for s in g):
        raise SplatError(
            "consistent_depth: groups must be a list of groups, each a list of (camera, depth, image[, "
            "variance]) sources."
        )
    if not any(len(g) >= 2 for g in groups):
        raise SplatError("consistent_depth: no group has two photographs to compare; give at least one.")
    if int(steps) != steps or steps < 1 or steps % 2 == 0 or not (0 < span < 1):
        raise SplatError(
            f"consistent_depth: need an odd number of steps (the depth itself among them) and 0 < span < 1; "
            f"got steps={steps}, span={span}."
        )
    if int(window) != window or window < 1 or window % 2 == 0 or prior < 0:
        raise SplatError(f"consistent_depth: need an odd window ≥ 1 and prior ≥ 0; got {window}, {prior}.")
    target = _on_host(target)
    groups = [[(_on_host(src[0]), *src[1:]) for src in g] for g in groups]
    u = np.linspace(-np.log1p(span), np.log1p(span), int(steps))
    cost = np.full((u.size, *d.shape), np.inf)
    for i, ui in enumerate(u):
        trial = d * np.exp(ui)
        total, n = np.zeros(d.shape), np.zeros(d.shape)
        for g in groups:
            if len(g) < 2:
                continue
            stack = []
            for src in g:
                vals, ok = reproject(target, trial, target_alpha, src[0], src[1], src[2])
                stack.append(np.where(ok[..., None], vals, np.nan))
            stack = np.stack(stack)
            seen = np.isfinite(stack[..., 0]).sum(0)
            med = _nanmedian0(stack)
            # the mean over the sources that see each pixel (NaN where one does not), without
            # np.nanmean's warning for pixels none sees: warning filters are process-wide, not per thread
            rel = (np.abs(stack - med) / (np.abs(med) + SWEEP_FLOOR)).mean(-1)
            sees = np.isfinite(rel)
            dev = np.where(sees, rel, 0.0).sum(0) / np.maximum(sees.sum(0), 1)
            has = seen >= 2
            total += np.where(has, dev, 0.0)
            n += has
        has = n > 0
        c = np.where(has, total / np.maximum(n, 1), 0.0)
        share = uniform_filter(has.astype(np.float64), window, mode="constant")
        mean = uniform_filter(c, window, mode="constant") / np.maximum(share, np.finfo(float).tiny)
        cost[i] = np.where(has & (share >= 0.5), mean + prior * abs(ui), np.inf)
    best = np.argmin(cost, axis=0)
    # only a depth that can itself be judged is moved: at the edge of the photographs' fields of view a
    # scale can bring a second photograph into view and win for want of competition
    scale = np.where(np.isfinite(cost[u.size // 2]), np.exp(u[best]), 1.0)
    return d * scale, scale
