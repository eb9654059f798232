"""Other photographs reprojected into a view through the splat's depth (image-based rendering).

The splat's colours are a fit that blurs: on the simulated capture its flat-pixel error in a camera's
channels is 0.013–0.021 (white = 1) at held-out views. Its *geometry* is good enough to carry the
photographs themselves from one view to another: each pixel of the target view is lifted to 3-D with the
splat's depth (:func:`depth_map`), projected into a source photograph, and the source's demosaiced value
read there (bilinear) when the source sees that point (its own splat depth agrees within
:data:`DEPTH_RTOL`). The photographs of a camera that see the point are combined into that camera's
reprojected response (:func:`reprojected`: their median, or with each one's noise variance, their
inverse-variance mean within :data:`TRIM_SIGMA` σ + :data:`TRIM_RTOL` of the median): 0.004–0.016 on the
same pixels (the median of Malvar-demosaiced sources), measured values rather than a model of them.
Pixels that no photograph of a camera sees keep the render for that camera (:mod:`splat.fusion`).

The scene must be Lambertian for this to hold (a glossy highlight moves with the view); the render's
view-independent colours assume the same.
"""

from __future__ import annotations

import warnings

import numpy as np

from ._errors import SplatError

__all__ = ["DEPTH_RTOL", "MIN_ALPHA", "TRIM_RTOL", "TRIM_SIGMA", "depth_map", "reproject", "reprojected"]

#: A source photograph sees a target pixel's 3-D point when the point's depth in the source and the
#: splat's depth at the projected pixel agree within this fraction: the splat's depth of one surface is
#: good to ~1 % at the simulated capture's 3–6 m (a 130-px image spans ~5 cm per pixel there), while an
#: occluder in front is ≥ 10 % nearer.
DEPTH_RTOL = 0.03

#: Pixels whose splat opacity is below this have no reliable depth (background, holes): a target pixel
#: below it is not reprojected, and a source whose depth is given as 0 there (as the pipeline does,
#: ``np.where(alpha >= MIN_ALPHA, depth, 0)``) does not vouch for visibility. The depth is normalised by
#: the opacity, so a half-transparent surface still has one; a trained splat is half-transparent over much
#: of a surface (on the CI coarse captures, 1000 steps, 9–28 % of the flat pixels of a held-out view are
#: below 0.9, 3–6 % of all pixels below 0.5), and the 3 % depth test still rejects occluded points. With
#: 0.5 instead of 0.9 those pixels are read from photographs rather than the render: three cameras fused,
#: flat held-out pixels, 0.460 → 0.396 ΔE00 (seed 0), 0.459 → 0.405 (seed 1), 0.493 → 0.469 (2000
#: steps), 1.368 → 1.298 (shot + read noise); 0.3 was no better on any of them.
MIN_ALPHA = 0.5

#: With the sources' noise variances given, :func:`reprojected` averages (inverse-variance weights) the
#: sources within ``TRIM_SIGMA`` of their own σ plus ``TRIM_RTOL`` of the median from the median: the
#: mean of Gaussian noise is the efficient estimate (the median wastes a third of the samples' worth),
#: and the band drops what the median guarded against — a source read across an edge or a missed
#: occlusion, off by far more than its noise. Three cameras fused, CI coarse capture with shot and read
#: noise, flat held-out pixels: median 1.086 ΔE00, plain mean 1.191, inverse-variance mean 1.125, this
#: band 0.992 (2σ + 0.5 %: 1.011); noise-free, 0.339 either way.
TRIM_SIGMA = 3.0
TRIM_RTOL = 0.01


def depth_map(gaussians, camera, *, mask=None) -> tuple[np.ndarray, np.ndarray]:
    """The splat's depth (expected camera-space ``z`` of the composited Gaussians, divided by their
    opacity) and accumulated opacity of a view, each (H, W).

    Renders the Gaussians with two channels, ``z`` of each centre in the camera and 1, through the
    same renderer as the colours (so depth and colour come from the same compositing weights).
    """
    from .gaussians import Gaussians, inverse_softplus
    from .outputs import render_views

    means = np.asarray(gaussians.means, np.float64)
    z = means @ np.asarray(camera.R, np.float64)[2] + float(np.asarray(camera.t, np.float64)[2])
    params = inverse_softplus(np.stack([np.maximum(z, 1e-3), np.ones_like(z)], 1).astype(np.float32))
    g = Gaussians(gaussians.means, gaussians.quats, gaussians.log_scales, gaussians.opacity_logits, params)
    img = render_views(g, [camera], mask=mask)[0].astype(np.float64)
    alpha = img[..., 1]
    return img[..., 0] / np.maximum(alpha, 1e-6), alpha


def _pixel_rays(camera):
    fx, fy = (float(x) for x in np.asarray(camera.focal, np.float64))
    cx, cy = (float(x) for x in np.asarray(camera.principal, np.float64))
    jj, ii = np.meshgrid(np.arange(camera.width) + 0.5, np.arange(camera.height) + 0.5)
    return (jj - cx) / fx, (ii - cy) / fy


def reproject(target, target_depth, target_alpha, source, source_depth, source_image):
    """A source photograph's values at each pixel of a target view, and where they are valid.

    Parameters
    ----------
    target, source : splat.Camera
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
        The target pixel has a depth (opacity ≥ :data:`MIN_ALPHA`), projects inside the source, in
        front of it, and the source's depth there agrees within :data:`DEPTH_RTOL` (not occluded).
    """
    from scipy.ndimage import map_coordinates

    src = np.asarray(source_image, np.float64)
    sd = np.asarray(source_depth, np.float64)
    if src.ndim != 3:
        raise SplatError(f"reproject: the source image must be (Hs, Ws, c), got shape {src.shape}.")
    if src.shape[:2] != sd.shape or sd.shape != (source.height, source.width):
        raise SplatError(
            f"reproject: source image {src.shape[:2]} and depth {sd.shape} must both be the source "
            f"camera's size {(source.height, source.width)}."
        )
    d = np.asarray(target_depth, np.float64)
    if d.shape != (target.height, target.width):
        raise SplatError(f"reproject: target depth {d.shape} is not the target's size.")
    if np.shape(target_alpha) != d.shape:
        raise SplatError(
            f"reproject: target alpha {np.shape(target_alpha)} is not the target's size {d.shape}."
        )
    x, y = _pixel_rays(target)
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):  # inf depths: not valid below
        pc = np.stack([x * d, y * d, d], -1)
        world = (pc - np.asarray(target.t, np.float64)) @ np.asarray(target.R, np.float64)  # Rᵀ(x − t)
        ps = world @ np.asarray(source.R, np.float64).T + np.asarray(source.t, np.float64)
    zs = ps[..., 2]
    with np.errstate(divide="ignore", invalid="ignore"):
        fx, fy = (float(v) for v in np.asarray(source.focal, np.float64))
        cx, cy = (float(v) for v in np.asarray(source.principal, np.float64))
        u = fx * ps[..., 0] / zs + cx - 0.5  # column coordinate of pixel centres
        v = fy * ps[..., 1] / zs + cy - 0.5
    inside = (
        (np.asarray(target_alpha) >= MIN_ALPHA)
        & (zs > 0)
        & (u >= 0)
        & (u <= source.width - 1)
        & (v >= 0)
        & (v <= source.height - 1)
    )
    u, v = np.where(inside, u, 0.0), np.where(inside, v, 0.0)
    seen = map_coordinates(sd, [v, u], order=1, mode="nearest")
    valid = inside & (np.abs(seen - zs) <= DEPTH_RTOL * np.abs(zs))
    vals = np.stack(
        [map_coordinates(src[..., j], [v, u], order=1, mode="nearest") for j in range(src.shape[-1])], -1
    )
    return np.where(valid[..., None], vals, 0.0), valid


def reprojected(target, target_depth, target_alpha, sources) -> tuple[np.ndarray, np.ndarray]:
    """Several source photographs reprojected into a target view and combined, and how many see each
    pixel.

    Parameters
    ----------
    target : splat.Camera
    target_depth, target_alpha : ndarray of shape (H, W)
    sources : iterable of (Camera, depth (Hs, Ws), image (Hs, Ws, c)) or (…, variance (Hs, Ws, c))
        With a per-pixel noise variance for every source, the sources that see a pixel are combined by
        their inverse-variance mean over those within ``TRIM_SIGMA`` σ + ``TRIM_RTOL`` × |median| of
        the median (the median where none is); without, by the median.

    Returns
    -------
    values : ndarray of shape (H, W, c)
        0 at pixels that no source sees.
    count : ndarray of shape (H, W), int
        Sources that see each pixel.
    """
    stack, var = [], []
    for src in sources:
        cam, depth, image, *rest = src
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
        vals, ok = reproject(target, target_depth, target_alpha, cam, depth, image)
        stack.append(np.where(ok[..., None], vals[..., :c], np.nan))
        if rest:
            var.append(np.where(ok[..., None], vals[..., c:], np.nan))
    if not stack:
        raise SplatError("reprojected: no source photograph given.")
    if len({v.shape for v in stack}) > 1:
        raise SplatError(
            "reprojected: the source images differ in size or channel count: "
            f"{[v.shape[-1] for v in stack]} channels."
        )
    if var and len(var) != len(stack):
        raise SplatError("reprojected: give a variance for every source or for none.")
    stack = np.stack(stack)
    count = np.isfinite(stack[..., 0]).sum(0)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)  # all-NaN pixels: no source sees them
        med = np.nanmedian(stack, axis=0)
    if var:
        z = np.nan_to_num(stack)
        var = np.nan_to_num(np.stack(var), nan=np.inf)
        keep = np.isfinite(stack) & (np.abs(z - med) <= TRIM_SIGMA * np.sqrt(var) + TRIM_RTOL * np.abs(med))
        w = np.where(keep, 1.0 / np.maximum(var, 1e-30), 0.0)
        wsum = w.sum(0)
        mean = (z * w).sum(0) / np.where(wsum > 0, wsum, 1.0)
        med = np.where(wsum > 0, mean, med)
    return np.where(count[..., None] > 0, med, 0.0), count
