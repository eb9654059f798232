"""The working resolution of a capture: CFA-aware binning of RAW mosaics and the intrinsics that go with it.

Real cameras write 12–60 MP RAW files; training a splat on them whole costs memory and time that buy
nothing at the splat's own level of detail. The train and render steps therefore work on each
photograph **binned** by an integer factor ``f``: every ``f × f`` block of the mosaic becomes one
pixel whose channel ``j`` is the mean of the block's valid sites of colour ``j`` (on a Bayer mosaic,
``f`` even: ``f²/4`` red, ``f²/2`` green and ``f²/4`` blue sites per block). Each channel stays a
measurement of that colour alone (no demosaicing, no interpolation across colours), its noise variance
is the site's divided by the number of sites averaged (the DNG NoiseProfile of the binned view is
scaled so), and its weight is the fraction of the block's sites of that colour that were valid
(saturated and dead sites are left out of the mean, not averaged in).

A block covers full-resolution pixel edges ``[f·i, f·(i + 1))``, so with pixel centres at ``+ 0.5``
(:mod:`splat.camera`) the binned camera's intrinsics are the full-resolution ones divided by ``f``
exactly (:func:`scale_camera`). The ``H mod f`` last rows and ``W mod f`` last columns do not fill a
block and are left out of training (at most ``f − 1`` pixels at the bottom and right edges); every
output image is still made at the photograph's full resolution (:mod:`splat.strips`).

Only 2 × 2 Bayer patterns and full-colour files reach here: isp's RAW reader refuses other CFAs
(X-Trans and the like) with a message naming the file.
"""

from __future__ import annotations

import math

import numpy as np

from ._errors import SplatError
from ._tol import BIN_ROWS, TRAIN_PIXEL_BUDGET

__all__ = [
    "bin_mosaic",
    "binned_noise_profile",
    "cfa_period",
    "scale_camera",
    "sites_per_block",
    "working_factor",
    "working_footprint",
]


def cfa_period(full_colour: bool) -> int:
    """The period of the colour filter pattern: 1 for a full-colour file, 2 for a 2 × 2 Bayer mosaic."""
    return 1 if full_colour else 2


def working_factor(
    shape: tuple[int, int],
    full_colour: bool,
    *,
    size: int | None = None,
    budget: int = TRAIN_PIXEL_BUDGET,
) -> int:
    """The binning factor of a photograph of ``shape`` ``(H, W)``.

    Without ``size``: the smallest factor whose binned image holds at most ``budget`` pixels
    (:data:`splat._tol.TRAIN_PIXEL_BUDGET`), 1 for an image already within it. With ``size`` (the
    ``--train-size`` option: the longer side of the working image in pixels): the smallest factor that
    brings the longer side to at most ``size``. A factor above 1 is rounded up to a multiple of the CFA
    period (:func:`cfa_period`), so that every block holds whole Bayer quads.

    Raises
    ------
    SplatError
        ``size`` that is not a positive integer.
    """
    H, W = (int(x) for x in shape)
    if size is not None:
        if isinstance(size, bool) or not isinstance(size, int) or size < 1:
            raise SplatError(
                f"train_size={size!r}: must be a positive number of pixels (e.g. --train-size 640)."
            )
        f = math.ceil(max(H, W) / size)
    else:
        f = math.ceil(math.sqrt(H * W / budget))
        while (H // f) * (W // f) > budget:  # floor division can leave the product just above it
            f += 1
    if f <= 1:
        return 1
    p = cfa_period(full_colour)
    return p * math.ceil(f / p)


def sites_per_block(cfa: str | None, f: int) -> np.ndarray:
    """Number of R, G, B sites in an ``f × f`` block (3,): ``f²`` each for a full-colour file
    (``cfa`` None), else ``f²/4 · (count of the colour in the 2 × 2 pattern)``."""
    if cfa is None:
        return np.full(3, f * f, float)
    return np.array([cfa.count(c) for c in "RGB"], float) * (f * f / 4)


def binned_noise_profile(noise_profile, cfa: str | None, f: int):
    """The DNG NoiseProfile ``(3, 2)`` rows ``(S, O)`` of a view binned by ``f``: the variance of the
    mean of ``n_j`` independent sites is the site's divided by ``n_j`` (:func:`sites_per_block`), so
    both coefficients are divided by it. None stays None."""
    if noise_profile is None:
        return None
    return np.asarray(noise_profile, float) / sites_per_block(cfa, f)[:, None]


def bin_mosaic(rows, shape: tuple[int, int], f: int, *, cfa: str | None, strip_rows: int = BIN_ROWS):
    """Bin a linear mosaic by ``f``, strip by strip.

    Parameters
    ----------
    rows : callable
        ``rows(r0, r1) → (values, weight)``, each (r1 − r0, W, 3) float32: the linear values (0 off a
        colour's sites) and weights (1 on valid sites) of full-resolution rows ``r0:r1``
        (:meth:`splat.capture.RawSource.rows`). Called with ``r0`` a multiple of ``f``.
    shape : tuple of int
        ``(H, W)`` of the full-resolution mosaic.
    f : int
        Binning factor (a multiple of the CFA period).
    cfa : str or None
        The 2 × 2 Bayer pattern of the mosaic's top-left corner (e.g. ``"RGGB"``); None for a full-colour
        file.
    strip_rows : int
        Full-resolution rows read per call (rounded to a multiple of ``f``): memory only, the result
        does not depend on it.

    Returns
    -------
    values : ndarray of shape (H // f, W // f, 3), float32
        Per block and channel, the mean of the block's valid sites of that colour (0 where none is).
    weight : ndarray of shape (H // f, W // f, 3), float32
        The fraction of the block's sites of that colour that are valid.
    """
    H, W = (int(x) for x in shape)
    period = cfa_period(cfa is None)
    if f < 1 or f % period:
        raise SplatError(f"binning factor {f}: must be a positive multiple of the CFA period {period}.")
    sites = sites_per_block(cfa, f)
    h, w = H // f, W // f
    if h < 1 or w < 1:
        raise SplatError(
            f"binning factor {f} leaves nothing of a {W}×{H} image; choose a larger --train-size."
        )
    values = np.zeros((h, w, 3), np.float32)
    weight = np.zeros((h, w, 3), np.float32)
    step = max(1, strip_rows // f) * f
    for r0 in range(0, h * f, step):
        r1 = min(r0 + step, h * f)
        v, wt = rows(r0, r1)
        v = np.asarray(v, np.float32)[:, : w * f]
        wt = np.asarray(wt, np.float32)[:, : w * f]
        # the block's columns first (contiguous), then its rows, accumulated in float64
        s = (v * wt).reshape((r1 - r0) // f, f, w, f, 3).sum(3).sum(1, dtype=np.float64)
        n = wt.reshape((r1 - r0) // f, f, w, f, 3).sum(3).sum(1, dtype=np.float64)
        values[r0 // f : r1 // f] = np.where(n > 0, s / np.maximum(n, 1), 0.0)
        weight[r0 // f : r1 // f] = n / sites
    return values, weight


def scale_camera(camera, f: int):
    """The camera of a view binned by ``f``: focal lengths and principal point divided by ``f`` (exact
    with pixel centres at ``+ 0.5``), size ``(W // f, H // f)``; ``f = 1`` returns ``camera``."""
    if f == 1:
        return camera
    from .camera import Camera

    return Camera(
        camera.R,
        camera.t,
        np.asarray(camera.focal) / f,
        np.asarray(camera.principal) / f,
        camera.width // f,
        camera.height // f,
    )


def working_footprint(f: int, config=None):
    """The :class:`splat.RenderConfig` (``config``, default the renderer's) that renders a splat
    trained at ``1 / f`` of a photograph's resolution at its full resolution with the footprint each
    Gaussian had in training: the 2-D dilation ``eps2d`` is in pixels², so ``f²`` times it covers the
    same patch of the scene. Why: with the training's ``eps2d`` at ``f`` times the resolution each
    Gaussian shrinks, and the surfaces it covered open up (lower opacity, holes); with this the full-size
    render is the working one, evaluated at the finer pixel centres."""
    from dataclasses import replace

    from .rendering import RenderConfig

    config = config or RenderConfig()
    return config if f == 1 else replace(config, eps2d=config.eps2d * f * f)
