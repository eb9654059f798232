"""What a trained model gives: (H, W, k) renders, depth, per-camera images, PCA false colour, PSNR."""

from __future__ import annotations

import threading
from dataclasses import replace

import jax.numpy as jnp
import numpy as np

from ._errors import SplatError
from .camera import Camera
from .data import Capture
from .gaussians import Gaussians, depth_colour_params
from .rendering import RenderConfig, render

__all__ = ["correct_image", "pca_false_colour", "psnr", "render_depth", "render_views", "split_cameras"]

#: One render at a time in the process. Renders issued from several threads at once (the full-resolution
#: strips' depth maps, ``splat.strips.full_resolution_view(workers=)``) deadlock on the "cpu" back-end:
#: each render's host callback holds one of XLA's intra-op threads while it waits for an operand that
#: another must compute (two threads on two cores: 20 concurrent strip renders hung where one thread made
#: 300 in 6.4 s). The callback's kernel runs one at a time anyway (``splat.rendering``'s kernel lock).
_RENDER_LOCK = threading.Lock()


def render_views(
    gaussians: Gaussians, cameras, *, mask=None, method: str = "auto", config: RenderConfig | None = None
) -> np.ndarray:
    """Multispectral renders of several views, shape (V, H, W, k) (one image size).

    Parameters
    ----------
    gaussians : Gaussians
    cameras : iterable of Camera
    mask : array_like of bool, shape (G,), optional
        Alive Gaussians (e.g. :attr:`TrainResult.alive`).
    method, config
        As in :func:`splat.render` (default ``RenderConfig()``); nothing is dropped whatever
        ``config.tile_capacity`` (see ``_render_complete``).
    """
    cams: list[Camera] = list(cameras)
    config = config or RenderConfig()
    with _RENDER_LOCK:
        m = None if mask is None else jnp.asarray(mask)
        return np.stack(
            [
                np.asarray(_render_complete(gaussians, c, method=method, config=config, mask=m).image)
                for c in cams
            ]
        )


def _render_complete(
    gaussians: Gaussians, camera: Camera, *, method: str = "auto", config: RenderConfig, mask=None
):
    """:func:`splat.render` with nothing dropped: where the ``"tiled"`` back-end's tile capacity is too
    small for the model, the view is rendered again with the power of two at or above its fullest tile
    (one compilation per capacity). Why: a render the pipeline writes or measures from (renders, depth
    maps, residual noise, scores) must show the whole model, whatever the capacity training used."""
    out = render(gaussians, camera, method=method, config=config, mask=mask)
    if int(out.n_dropped) > 0:
        k = 1 << max(int(out.max_per_tile) - 1, 1).bit_length()
        out = render(gaussians, camera, method=method, config=replace(config, tile_capacity=k), mask=mask)
    return out


def render_depth(
    gaussians: Gaussians,
    camera: Camera,
    *,
    mask=None,
    method: str = "auto",
    config: RenderConfig | None = None,
) -> tuple[np.ndarray, np.ndarray]:
    """The model's depth in one view: each pixel's compositing-weighted mean of the Gaussians' depths.

    ``depth = Σ_i w_i z_i / Σ_i w_i`` with ``w_i = α_i T_i`` the weights that composite the colours and
    ``z_i`` the camera-frame depth of Gaussian i's centre (3DGS' "expected depth"). Compared with a true
    depth it shows where the geometry is wrong, e.g. Gaussians settled in front of a surface that only a
    few views see.

    Parameters
    ----------
    gaussians : Gaussians
    camera : Camera
    mask : array_like of bool, shape (G,), optional
        Alive Gaussians (e.g. :attr:`TrainResult.alive`).
    method, config
        As in :func:`splat.render` (default ``RenderConfig()``; its ``background`` is ignored); nothing
        is dropped (see ``_render_complete``).

    Returns
    -------
    depth : ndarray of shape (H, W)
        In the units of the scene; NaN where nothing is drawn (``alpha == 0``).
    alpha : ndarray of shape (H, W)
        Accumulated opacity ``Σ_i w_i``: where it is well below 1 the depth is of a thin veil.
    """
    config = replace(config or RenderConfig(), background=0.0)
    depth = depth_colour_params(gaussians, camera, near=config.near)[:, None]
    g = replace(gaussians, colour_params=depth.astype(gaussians.colour_params.dtype))
    out = _render_complete(
        g, camera, method=method, config=config, mask=None if mask is None else jnp.asarray(mask)
    )
    alpha = np.asarray(out.alpha, np.float64)
    num = np.asarray(out.image[..., 0], np.float64)
    with np.errstate(invalid="ignore", divide="ignore"):
        depth = np.where(alpha > 0, num / alpha, np.nan)
    return depth, alpha


def split_cameras(image, capture: Capture) -> dict[int, np.ndarray]:
    """Split a multispectral image into the images each camera would have taken (thesis fig. 3.2).

    Parameters
    ----------
    image : array_like of shape (..., k)
    capture : Capture
        Its channel map says which channels belong to which camera.

    Returns
    -------
    dict camera_id -> ndarray of shape (..., k)
        ``k`` = number of channels of that camera; pixel-aligned across cameras.
    """
    image = np.asarray(image)
    if image.shape[-1] != capture.n_channels:
        raise SplatError(f"image has {image.shape[-1]} channels; the capture has {capture.n_channels}.")
    return {cid: image[..., list(ch)] for cid, ch in capture.channels.items()}


def pca_false_colour(image, *, mask=None, percentile: float = 99.0) -> np.ndarray:
    """False-colour view of an N-channel image: its first 3 principal components as RGB (fig. 3.3).

    Parameters
    ----------
    image : array_like of shape (H, W, k)
    mask : array_like of bool, shape (H, W), optional
        Pixels used to fit the components (e.g. alpha > 0.5); all pixels are coloured.
    percentile : float
        Each component is stretched so that this percentile of ``|score|`` maps to the edge of [0, 1].

    Returns
    -------
    ndarray of shape (H, W, 3) in [0, 1]
        Component 1 → R, 2 → G, 3 → B (missing components, for k < 3, are 0.5); the sign of each
        component is fixed so that its largest loading is positive.
    """
    image = np.asarray(image, float)
    if image.ndim != 3:
        raise SplatError(f"image must have shape (H, W, k); got {image.shape}.")
    X = image.reshape(-1, image.shape[-1])
    fit = X if mask is None else X[np.asarray(mask, bool).reshape(-1)]
    if len(fit) < 2:
        raise SplatError("pca_false_colour needs at least 2 pixels to fit the components.")
    mu = fit.mean(0)
    _, _, Vt = np.linalg.svd(fit - mu, full_matrices=False)
    Vt = Vt[:3] * np.sign(Vt[:3][np.arange(min(3, len(Vt))), np.abs(Vt[:3]).argmax(1)])[:, None]
    scores = (X - mu) @ Vt.T
    s = np.percentile(np.abs((fit - mu) @ Vt.T), percentile, axis=0)
    rgb = np.full((X.shape[0], 3), 0.5)
    rgb[:, : scores.shape[1]] = 0.5 + 0.5 * scores / np.where(s > 0, s, 1)
    return np.clip(rgb, 0, 1).reshape(*image.shape[:2], 3)


def psnr(a, b, *, peak: float = 1.0) -> float:
    """Peak signal-to-noise ratio ``10 log10(peak² / mean((a − b)²))`` in dB (arrays of one shape)."""
    a, b = np.asarray(a, float), np.asarray(b, float)
    if a.shape != b.shape:
        raise SplatError(f"psnr needs arrays of one shape; got {a.shape} and {b.shape}.")
    mse = np.mean((a - b) ** 2)
    return float("inf") if mse == 0 else float(10 * np.log10(peak**2 / mse))


def correct_image(
    image, capture: Capture, cameras, *, camera_ids=None, method: str = "Prior", **options
) -> np.ndarray:
    """Colour-correct a pixel-aligned multi-camera image with :func:`zonotope.correct.correct`.

    Parameters
    ----------
    image : array_like of shape (H, W, k)
        A render of the trained model (linear, white-balanced: the perfect white gives 1 per
        channel, as in :func:`splat.synthetic_scene`).
    capture : Capture
        Its channel map picks each camera's channels.
    cameras : sequence
        The spectral cameras (names or curves for :mod:`zonotope`) of ``camera_ids``, in that order.
    camera_ids : sequence of int, optional
        Which cameras' channels to use, stacked in this order (default: all, in id order).
    method, **options
        See :func:`zonotope.correct.fit_correction`.

    Returns
    -------
    ndarray of shape (H, W, 3)
        XYZ (or the target of ``options``).
    """
    from zonotope.correct import correct

    image = np.asarray(image, float)
    ids = sorted(capture.channels) if camera_ids is None else list(camera_ids)
    if len(ids) != len(cameras):
        raise SplatError(f"{len(cameras)} spectral cameras for camera ids {ids}; give one per id.")
    idx = [c for i in ids for c in capture.channels[i]]
    out = correct(image[..., idx].reshape(-1, len(idx)), list(cameras), method=method, **options)
    return np.asarray(out).reshape(*image.shape[:-1], -1)
