"""Every photograph corrected at its full resolution, strip by strip, with memory bounded by the strip.

The train and render steps work at the working resolution (:mod:`splat.resolution`); the fused
responses of a photographed view (``splat.capture.fused_view``: its own channels, the other cameras'
photographs reprojected into it through the splat's depth, the render anchored to it where no
photograph sees a pixel) are made there too. This module carries them to the photograph's full size,
one strip of ``STRIP_ROWS`` rows at a time:

1. **Own channels**: the view's RAW rows, read from the file's samples (:meth:`splat.capture.RawSource.rows`)
   with a margin of :data:`HALO` rows, demosaiced by isp (Malvar 2004, as :func:`splat.fusion.measured`)
   and cut to the strip: the same values as demosaicing the whole image (the margin covers the 5 × 5
   filter), at exposure 1 on the white → 1 scale.
2. **The other channels**: where the photograph is binned for work and a :class:`FullReprojection` is
   given, the other cameras' photographs **at their full resolution**, reprojected into the strip
   (:func:`reprojected_strip`): the splat's depth rendered for the strip alone (a camera whose principal
   point is moved to the strip, :func:`strip_camera`), each pixel lifted to 3-D with it, projected into
   each source photograph, read there from the source's RAW rows (only the rows the strip lands on,
   demosaiced bilinearly a band at a time, :func:`raw_row_source`), kept where the source's own depth
   (working resolution) agrees (:func:`splat.reproject.reproject_rows`), and combined per camera as the
   render step combines them (:func:`splat.reproject.reprojected`). The photograph's own camera's
   other photographs are read the same way and averaged into its own channels with the measurement,
   inverse-variance weighted, where they see a plain pixel whose own site is valid (the noise the
   working fusion averages away; the fit is told the two σ combined). Pixels no photograph of a camera
   sees, pixels where the photograph is textured at full resolution (:func:`textured_rows`: a
   reprojection misplaced by a fraction of a pixel is off by the step there, as at the working
   resolution, :func:`splat.capture.fused_view`), and pixels where the working fusion rejected the
   camera's reprojection (:func:`splat.fusion.rejected_bit`: no surface gives it with the own
   channels) take the
   working-resolution fused responses upsampled bilinearly (pixel centres aligned: full-resolution
   centre ``y + ½`` lies at ``(y + ½)/f`` in the working image, clamped at the borders), then sharpened
   by the photograph itself — every channel times the ratio of the own channels' full-resolution sum
   to their upsampled working-resolution sum (the Brovey transform of :func:`splat.fusion.anchor`,
   Gillespie et al. 1987): an edge the photograph shows within a working pixel appears in every
   channel, where plain upsampling would blur it over ``f`` pixels. Pixels whose own site is saturated
   or dead keep the upsampled values. Up to binning :data:`splat._tol.RENDER_ANCHOR_BINNING`, where
   the photograph is textured and the splat covers the pixel
   (opacity ≥ :data:`splat._tol.RENDER_ANCHOR_ALPHA`), every channel is instead the splat's render at
   full resolution (from the same pass as the strip's depth) anchored to the pixel's own measured
   sites (:func:`splat.fusion.anchor`), as the working fusion treats its textured pixels: the render
   is sharper than the working responses upsampled, and no demosaicing crosses the edge. The working
   fusion's depth sweep (:func:`splat.reproject.consistent_depth`) and guided re-reading are not
   repeated at full size.
3. **Per-pixel correction**: each pixel takes the noise pattern (``code``) of the working pixel it lies
   in, its own channels the sensor's full-resolution noise, its other channels their working σ plus the
   noise the ratio carries into them, or where they are reprojected at full resolution, the σ given for
   that (:class:`FullReprojection`); one noise-aware closed-form regression is fitted per pattern on
   the channel-whitened problem (``splat.capture.fused_fitter``) and applied in chunks of
   :data:`splat._tol.CORRECT_CHUNK` pixels.

Outputs are written strip by strip (:class:`tifffile.TiffWriter` from an iterator of strips, the PNG by
:class:`PNGStripWriter`), so the peak memory is the files' samples (2 bytes a pixel, the photograph's
and its sources') plus one strip's work and a band of each source's rows, whatever the image size.
"""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path
from typing import NamedTuple

import numpy as np

from ._errors import SplatError
from ._tol import (
    ANCHOR_EPS,
    CORRECT_CHUNK,
    FULL_WORKERS,
    RENDER_ANCHOR_ALPHA,
    RENDER_ANCHOR_BINNING,
    SOURCE_BLOCK_ROWS,
    SOURCE_CACHE_ROWS,
    STRIP_ROWS,
)
from .fusion import anchor, own_agrees, rejected_bit

__all__ = [
    "FULL_METHOD",
    "HALO",
    "CachedRows",
    "FullReprojection",
    "PNGStripWriter",
    "Photograph",
    "WorkingFusion",
    "corrected_working",
    "default_workers",
    "demosaic_rows",
    "full_resolution_view",
    "nearest_rows",
    "raw_row_source",
    "reprojected_strip",
    "sRGB8_encoder",
    "strip_camera",
    "textured_rows",
    "upsample_rows",
    "write_full",
]

#: Rows read above and below a strip for demosaicing: Malvar 2004's 5 × 5 filters and isp's mirror pad
#: of 4 reach 2 + 4 rows; 8 (even, so a strip's margin starts on the file's own CFA phase) covers both.
HALO = 8

#: The estimator of the full-resolution correction: the root-polynomial regression fitted for the
#: responses' noise, :func:`zonotope.correct.image.correct_image`'s default for photographs (closed form:
#: a few µs a pixel). The MMV-based estimators cost milliseconds per distinct colour, and a
#: full-resolution photograph has as many distinct colours as pixels.
FULL_METHOD = "Finlayson 2015"


def default_workers() -> int:
    """Strips :func:`full_resolution_view` computes at once by default: the CPU cores this process may
    use, at most :data:`splat._tol.FULL_WORKERS`."""
    import os

    try:
        cores = len(os.sched_getaffinity(0))
    except AttributeError:  # not on Linux
        cores = os.cpu_count() or 1
    return max(1, min(cores, FULL_WORKERS))


def demosaic_rows(source, r0: int, r1: int, *, method: str = "Malvar 2004") -> tuple[np.ndarray, np.ndarray]:
    """Rows ``r0:r1`` of a RAW file demosaiced (linear, exposure of the file, white scale 1) and their
    validity (the pixel's own site neither saturated nor dead), each (r1 − r0, W, ·): the same values as
    demosaicing the whole file and cutting the rows out.

    Parameters
    ----------
    source : splat.capture.RawSource
    r0, r1 : int
    method : str
        :func:`isp.stages.demosaic` method.
    """
    from isp.stages import demosaic

    H = source.shape[0]
    a = max(0, r0 - HALO)
    a -= a % 2
    b = min(H, r1 + HALO)
    if not source.full_colour and getattr(source, "data", None) is not None:
        # the mosaic and the own site's validity straight from the samples: the same numbers as
        # `rows` (tested), without its three-channel values and weights
        lin = demosaic(_mosaic_rows(source, a, b), cfa=source.cfa, method=method)
        dn = source.data[r0:r1]
        h, w = dn.shape
        black = np.tile(np.asarray(source.black, np.float64), ((r1 - r0 + 1) // 2 + 1, (w + 1) // 2))
        black = black[r0 % 2 : r0 % 2 + h, :w]
        dead = (dn <= 0) & (black > 0)
        return lin[r0 - a : r1 - a], ~((dn >= source.white) | dead)
    values, weight = source.rows(a, b)
    if source.full_colour:
        lin = values.astype(np.float64)
    else:
        lin = demosaic(values.sum(-1), cfa=source.cfa, method=method)
    return lin[r0 - a : r1 - a], weight[r0 - a : r1 - a].sum(-1) > 0


def _mosaic_rows(source, a: int, b: int) -> np.ndarray:
    """Rows ``a:b`` (``a`` even) of a Bayer file's linear mosaic (H, W) float32: the same numbers as
    ``source.rows(a, b)[0].sum(-1)`` (one measured channel per site) without building the three-channel
    values and weights (2.5× less work for a source read for its values only)."""
    raw_dn = source.data[a:b].astype(np.float64)
    h, w = raw_dn.shape
    black = np.tile(np.asarray(source.black, np.float64), ((h + 1) // 2, (w + 1) // 2))[:h, :w]
    return np.clip((raw_dn - black) / (source.white - black), -0.05, 1.0).astype(np.float32)


def _demosaic_values(source, r0: int, r1: int, *, method: str) -> np.ndarray:
    """:func:`demosaic_rows`' values alone (float64, or float32 from a full-colour file)."""
    from isp.stages import demosaic

    if source.full_colour or getattr(source, "data", None) is None:  # a stand-in with rows() only
        return demosaic_rows(source, r0, r1, method=method)[0]
    H = source.shape[0]
    a = max(0, r0 - HALO)
    a -= a % 2
    b = min(H, r1 + HALO)
    return demosaic(_mosaic_rows(source, a, b), cfa=source.cfa, method=method)[r0 - a : r1 - a]


def _axis(n_full: int, f: int, n_work: int, lo: int, hi: int):
    """Bilinear taps along one axis: for full-resolution indices ``lo:hi``, the two working indices and
    the weight of the second (centre ``i + ½`` at ``(i + ½)/f − ½`` in working pixels, clamped)."""
    x = (np.arange(lo, hi) + 0.5) / f - 0.5
    x = np.clip(x, 0, n_work - 1)
    i0 = np.floor(x).astype(np.int64)
    i1 = np.minimum(i0 + 1, n_work - 1)
    return i0, i1, (x - i0)


def upsample_rows(img: np.ndarray, f: int, r0: int, r1: int, width: int) -> np.ndarray:
    """Rows ``r0:r1`` of ``img`` (h, w, C) upsampled bilinearly by ``f`` to ``width`` columns
    (pixel centres aligned, borders clamped): (r1 − r0, width, C), the same whatever the strip; float32
    for a float32 ``img`` (weights rounded to float32: the full-resolution stage's responses stay float32,
    half the memory traffic of every step after it), else float64."""
    img = np.asarray(img)
    h, w = img.shape[:2]
    i0, i1, ty = _axis(0, f, h, r0, r1)
    j0, j1, tx = _axis(0, f, w, 0, width)
    if img.dtype == np.float32:
        ty, tx = ty.astype(np.float32), tx.astype(np.float32)
    top = img[i0]
    bot = img[i1]
    rows = top + (bot - top) * ty[:, None, None]
    return rows[:, j0] * (1 - tx)[None, :, None] + rows[:, j1] * tx[None, :, None]


def nearest_rows(img: np.ndarray, f: int, r0: int, r1: int, width: int) -> np.ndarray:
    """Rows ``r0:r1`` of ``img`` (h, w, ...) repeated ``f × f`` (each full-resolution pixel takes the
    working pixel it lies in; clamped beyond the binned area)."""
    h, w = img.shape[:2]
    i = np.minimum(np.arange(r0, r1) // f, h - 1)
    j = np.minimum(np.arange(width) // f, w - 1)
    return img[i][:, j]


class Photograph(NamedTuple):
    """A photographed view at full resolution: its RAW file (:class:`splat.capture.RawSource`), relative
    exposure, its camera's white scale (3,) and its own channels' full-resolution noise σ (3,), white → 1."""

    source: object
    exposure: float
    white_scale: np.ndarray
    sigma: np.ndarray


class WorkingFusion(NamedTuple):
    """A view's fused responses at the working resolution (``splat.capture.fused_view``): ``fused`` (h, w, k),
    white → 1; ``code`` (h, w), the noise pattern per pixel, ``sigma[code]`` its σ per channel (k,);
    ``own``, where the view's own channels sit among the ``k``; ``binning``, the working resolution's
    factor."""

    fused: np.ndarray
    code: np.ndarray
    sigma: dict
    own: slice
    binning: int


class FullReprojection(NamedTuple):
    """The cameras' photographs, to be reprojected into a photograph at its full resolution.

    Attributes
    ----------
    gaussians : splat.Gaussians
        The model, whose depth is rendered strip by strip at full resolution.
    mask : ndarray of shape (G,), bool, or None
        Its alive Gaussians.
    camera : splat.Camera
        The photograph's camera at its full resolution (``H × W`` of its RAW file).
    groups : dict
        Camera position ``i`` among the fused channels (``3 i : 3 i + 3``) → list of
        :class:`splat.reproject.RowSource`: that camera's photographs at their full resolution, values
        on the white → 1 scale at exposure 1, their variance if known (the render step's combination
        rule, :func:`splat.reproject.reprojected`). At the photograph's own position: its camera's
        other photographs, averaged with the measurement.
    sigma : ndarray of shape (k,)
        σ of a channel where it is reprojected at full resolution (at the own position, of the
        reprojection alone).
    render_scale : ndarray of shape (k,), optional
        What puts the splat's render on the white → 1 scale (its divisor): given, and the binning at
        most :data:`splat._tol.RENDER_ANCHOR_BINNING`, the photograph's textured pixels are the render
        at full resolution anchored to their own measured sites instead of the photograph demosaiced
        and the working responses upsampled.
    binning : int
        The working resolution's factor: the splat's depth (and colour) is rendered at full resolution
        with the footprint it was trained with (:func:`splat.resolution.working_footprint`).
    min_alpha : float, optional
        The splat's opacity from which a pixel is lifted with its depth (default
        :data:`splat.reproject.MIN_ALPHA`; the groups' depths should be cut at the same).
    """

    gaussians: object
    mask: object
    camera: object
    groups: dict
    sigma: np.ndarray
    render_scale: np.ndarray | None = None
    binning: int = 1
    min_alpha: float | None = None


def strip_camera(camera, r0: int, r1: int):
    """Rows ``r0:r1`` of ``camera``'s image as a camera of their own: the principal point moved up by
    ``r0``, height ``r1 − r0`` (the same rays through the same pixels)."""
    from .camera import Camera

    c = np.asarray(camera.principal, np.float64)
    return Camera(
        camera.R,
        camera.t,
        camera.focal,
        np.array([c[0], c[1] - r0]),
        camera.width,
        r1 - r0,
    )


def reprojected_strip(rep: FullReprojection, r0: int, r1: int, need=None, *, colour: bool = False):
    """Rows ``r0:r1`` of the photograph, each group's photographs (``rep.groups``) reprojected there at
    full resolution: the splat's depth rendered for the strip alone (:func:`splat.reproject.depth_map` of
    :func:`strip_camera`, the working footprint), every pixel whose opacity reaches ``rep.min_alpha``
    lifted with it and read in the sources (only the rows they need), occlusion tested against each
    source's working-resolution depth, combined per camera as the render step does. Returns, in
    ``rep.groups``' order, values (r1 − r0, W, 3) and counts (r1 − r0, W); with ``colour``, also the
    splat's render of the strip (r1 − r0, W, k), as :func:`splat.outputs.render_views` gives it, from
    the same pass as the depth, and its opacity (r1 − r0, W).

    ``need`` (r1 − r0, W) bool: the pixels wanted; the others are not read (count 0), and a strip with
    none is neither rendered nor read unless ``colour`` (the wanted pixels' values are the same either
    way)."""
    from .reproject import MIN_ALPHA, depth_map, reprojected
    from .resolution import working_footprint

    W = int(rep.camera.width)
    none = need is not None and not np.any(need)
    min_alpha = MIN_ALPHA if rep.min_alpha is None else float(rep.min_alpha)
    if none and not colour:
        return [np.zeros((r1 - r0, W, 3), np.float32) for _ in rep.groups], [
            np.zeros((r1 - r0, W), np.int64) for _ in rep.groups
        ]
    cam = strip_camera(rep.camera, r0, r1)
    depth, alpha, *render = depth_map(
        rep.gaussians, cam, mask=rep.mask, colour=colour, config=working_footprint(rep.binning)
    )
    opacity = alpha
    if need is not None:  # a pixel below min_alpha is not lifted nor read
        alpha = np.where(need, alpha, 0.0)
    values, counts = [], []
    for sources in rep.groups.values():
        if none:
            v, n = np.zeros((r1 - r0, W, 3)), np.zeros((r1 - r0, W), np.int64)
        else:
            v, n = reprojected(cam, depth, alpha, sources, min_alpha=min_alpha)
        values.append(v.astype(np.float32))
        counts.append(n)
    return (values, counts, render[0].astype(np.float32), opacity) if colour else (values, counts)


class CachedRows:
    """A row reader that reads whole blocks of ``block`` rows (aligned to multiples of ``block``) and keeps
    the most recently used ones, at most ``max(rows, the rows of the current request)`` rows in all:
    strips of a view ask for overlapping runs of a source's rows, each block read once while the runs
    move through the image, whatever a run's length (a run longer than ``rows`` is read whole and kept).

    ``read(a, b) → (b − a, W, c)`` with ``read`` giving the same rows whatever ``a, b`` (as
    :func:`demosaic_rows`); ``height``: the image's rows. Memory: the blocks kept, at most
    ``max(rows, the current request + 2 blocks)`` rows, and while several missing blocks are read at
    once, that read (copied into its blocks).

    Safe to call from several threads (strips computed at once): a block being read by one caller is
    waited for, not read again, by another; the reads themselves run outside the lock, concurrently."""

    def __init__(
        self, read: Callable, height: int, rows: int = SOURCE_CACHE_ROWS, block: int = SOURCE_BLOCK_ROWS
    ):
        import threading

        self.read, self.height, self.rows, self.block = read, int(height), int(rows), max(1, int(block))
        self.blocks: dict = {}  # block index → rows, least recently used first
        self._lock = threading.Lock()
        self._reading: dict = {}  # block index → _Slot, while a caller reads it

    def __call__(self, a: int, b: int) -> np.ndarray:
        """Rows ``a:b`` (0 ≤ a < b ≤ height)."""
        n = self.block
        k0, k1 = a // n, (min(b, self.height) - 1) // n + 1
        need = range(k0, k1)
        got: dict = {}
        with self._lock:
            for k in need:  # the kept ones become the most recent
                if k in self.blocks:
                    got[k] = self.blocks[k] = self.blocks.pop(k)
            keep = max(self.rows // n, len(need))
            waiting = {k: self._reading[k] for k in need if k not in got and k in self._reading}
            missing = [k for k in need if k not in got and k not in waiting]
            # the oldest blocks go before the new ones are read (memory bounded by `keep` blocks)
            old = [k for k in self.blocks if k not in need]
            for k in old[: max(0, len(self.blocks) + len(missing) - keep)]:
                del self.blocks[k]
            mine = {k: _Slot() for k in missing}
            self._reading.update(mine)
        try:
            i = 0
            while i < len(missing):  # consecutive missing blocks in one read (one demosaic margin)
                j = i
                while j + 1 < len(missing) and missing[j + 1] == missing[j] + 1:
                    j += 1
                lo, hi = missing[i] * n, min(self.height, (missing[j] + 1) * n)
                rows = self.read(lo, hi)
                for k in range(missing[i], missing[j] + 1):  # own copies: each is freed on its own
                    part = rows[k * n - lo : (k + 1) * n - lo]
                    got[k] = part.copy() if j > i else part
                    mine[k].set(got[k])
                i = j + 1
        finally:
            with self._lock:
                for k in missing:
                    if k in got:
                        self.blocks[k] = got[k]
                    self._reading.pop(k, None)
                for k in need:  # in request order for the next eviction
                    if k in self.blocks:
                        self.blocks[k] = self.blocks.pop(k)
            for k in missing:  # a failed read wakes its waiters with the failure
                mine[k].set(None)
        for k, slot in waiting.items():
            got[k] = slot.get()
        if k1 - k0 == 1:
            return got[k0][a - k0 * n : b - k0 * n]
        out = np.concatenate([got[k] for k in need])
        return out[a - k0 * n : b - k0 * n]


class _Slot:
    """A block being read by one caller of :class:`CachedRows`, waited for by others."""

    def __init__(self):
        import threading

        self._event, self._value = threading.Event(), None

    def set(self, value) -> None:
        if not self._event.is_set():
            self._value = value
            self._event.set()

    def get(self) -> np.ndarray:
        self._event.wait()
        if self._value is None:
            raise SplatError("a source's rows could not be read (the read failed in another strip).")
        return self._value


def raw_row_source(raw, camera, depth, binning: int, exposure: float, white_scale, sigma) -> object:
    """A RAW file as a :class:`splat.reproject.RowSource` on the white → 1 scale at exposure 1: rows
    demosaiced bilinearly (as the render step's sources: no overshoot near edges) by
    :class:`CachedRows`; variance from the file's NoiseProfile at each value (else ``sigma`` (3,) squared).

    Parameters
    ----------
    raw : splat.capture.RawSource
    camera : splat.Camera
        At the file's full resolution.
    depth : ndarray of shape (H // binning, W // binning)
        Its splat depth at the working resolution (0 where unreliable).
    binning, exposure, white_scale, sigma
        The working resolution's factor, the relative exposure, the camera's white scale (3,) and the
        file's full-resolution noise σ (3,), white → 1.
    """
    from .reproject import RowSource

    ws = np.asarray(white_scale, float)
    div = (float(exposure) * ws).astype(np.float32)

    def read(a, b):
        return (_demosaic_values(raw, a, b, method="bilinear") / div).astype(np.float32)

    P = raw.info.get("noise_profile")
    if P is not None:  # affine in x: a·max(x, 0) + b, coefficients folded once (float32, as the values)
        P = np.asarray(P, float)
        gain = float(exposure) * ws
        slope, offset = (P[:, 0] / gain).astype(np.float32), (P[:, 1] / gain**2).astype(np.float32)

        def variance(x):
            return slope * np.maximum(np.asarray(x, np.float32), 0) + offset
    else:
        s2 = np.square(np.asarray(sigma, float))

        def variance(x):
            return np.broadcast_to(s2, np.shape(x)).astype(np.float32)

    return RowSource(camera, np.asarray(depth, float), int(binning), CachedRows(read, raw.shape[0]), variance)


def full_resolution_view(
    photo: Photograph,
    working: WorkingFusion,
    fit: Callable,
    *,
    strip_rows: int = STRIP_ROWS,
    progress: Callable | None = None,
    reprojection: FullReprojection | None = None,
    workers: int = 1,
):
    """Yield the corrected full-resolution XYZ of a photograph, strip by strip.

    Parameters
    ----------
    photo : Photograph
    working : WorkingFusion
    fit : callable
        ``fit(σ (k,)) → (corrector, scale)``: a fitted closed-form estimator and the channel scale to
        apply to responses first (``splat.capture.fused_fitter`` with :data:`FULL_METHOD`).
    strip_rows : int
        Rows per strip (even on a Bayer mosaic): memory only, the output does not depend on it.
    progress : callable, optional
        ``progress("full resolution", rows done, rows)`` after each strip.
    reprojection : FullReprojection, optional
        The cameras' photographs at full resolution (:func:`reprojected_strip`): where one of another
        camera's sees a pixel and the photograph is not textured there at full resolution
        (:func:`textured_rows`), that camera's channels are their values there instead of the upsampled
        working responses, σ ``reprojection.sigma``; the own camera's other photographs are averaged
        with the measurement there (inverse variance, σ combined) where they agree with it
        (:func:`splat.fusion.own_agrees`). Without, every other channel is the upsampled working fusion
        (the previous path).
    workers : int
        Strips computed at once, each on a thread of its own (NumPy, the renderer and the regressions
        release the GIL for most of a strip's work): time only, the output is the same for any number;
        memory grows to ``workers + 1`` strips' work. 1: one strip after the other, in this thread.

    Yields
    ------
    ndarray of shape (rows, W, 3), float32
        XYZ of consecutive strips, top to bottom.
    """
    source, exposure, own_scale, own_sigma = photo
    fused, code, sigma, own, f = working
    H, W = source.shape
    if strip_rows < 2 or strip_rows % 2:
        raise SplatError(f"strip_rows={strip_rows}: must be an even number ≥ 2.")
    if isinstance(workers, bool) or not isinstance(workers, int | np.integer) or workers < 1:
        raise SplatError(f"workers={workers!r}: must be a whole number ≥ 1 (strips computed at once).")
    own_sigma = np.asarray(own_sigma, float)
    patterns = {int(c): _full_sigma(np.asarray(s, float), own, own_sigma, fused) for c, s in sigma.items()}
    fused = np.asarray(fused, np.float32)  # float32 from here on: the responses carry ≥ 1e-3 noise
    code = np.asarray(code)
    k = fused.shape[-1]
    m = k // 3
    # a pixel's pattern: its working code, and from bit `shift` on, the cameras reprojected at full size
    shift = max(int(code.max()).bit_length(), m + 1) if code.size else m + 1
    rep_sigma = None
    me = own.start // 3
    if reprojection is not None:
        rep_sigma = np.asarray(reprojection.sigma, float)
        if rep_sigma.shape != (k,) or any(not 0 <= i < m for i in reprojection.groups):
            raise SplatError(
                f"full_resolution_view: reprojection σ {rep_sigma.shape} must be ({k},) and its groups "
                f"cameras' positions among {m}."
            )
        # the own channels where the camera's other photographs agree with the measurement (own_agrees) and
        # are averaged in: the two σ combined
        own_rep_sigma = rep_sigma[own]  # kept: rep_sigma is replaced by a copy below
        w_own = 1 / np.square(np.maximum(own_sigma, 1e-6)), 1 / np.square(np.maximum(own_rep_sigma, 1e-6))
        rep_sigma = rep_sigma.copy()
        rep_sigma[own] = 1 / np.sqrt(w_own[0] + w_own[1])
        w_own = tuple(w.astype(np.float32) for w in w_own)
    divisor = (exposure * np.asarray(own_scale, float)).astype(np.float32)
    fitted = _Fitted(fit, patterns, rep_sigma, shift, m)
    render_scale = None
    if reprojection is not None and reprojection.render_scale is not None:
        render_scale = np.asarray(reprojection.render_scale, np.float32)
        if render_scale.shape != (k,):
            raise SplatError(f"full_resolution_view: render_scale {render_scale.shape} must be ({k},).")

    def strip(r0: int, r1: int) -> np.ndarray:
        lin, valid = demosaic_rows(source, r0, r1)
        photo = np.maximum(lin.astype(np.float32) / divisor, 0)
        up = np.maximum(upsample_rows(fused, f, r0, r1, W), 0)
        ratio = (photo.sum(-1) + np.float32(ANCHOR_EPS)) / (up[..., own].sum(-1) + np.float32(ANCHOR_EPS))
        resp = up * np.where(valid, ratio, 1)[..., None]
        resp[..., own] = np.where(valid[..., None], photo, up[..., own])
        del up, photo, lin
        cd = nearest_rows(code, f, r0, r1, W)
        if reprojection is not None:  # the other cameras' photographs at full resolution
            plain = ~textured_rows(source, r0, r1, exposure, own_scale, own_sigma)
            anchored = render_scale is not None and f <= RENDER_ANCHOR_BINNING and not plain.all()
            values, seen, *render = reprojected_strip(  # read only where used
                reprojection, r0, r1, need=plain, colour=anchored
            )
            if anchored:  # textured: the render at full resolution anchored to the pixel's own sites
                sites, weight = source.rows(r0, r1)
                tex = ~plain & (weight > 0).any(-1) & (render[1] >= RENDER_ANCHOR_ALPHA)  # the splat there
                got = anchor(  # the pixels as one column: (N, 1, ·)
                    (render[0][tex] / render_scale)[:, None],
                    (sites[tex] / divisor)[:, None],
                    own,
                    (weight[tex] > 0)[:, None],
                )
                resp[tex] = got[:, 0]
                del render, sites, weight, got
            work_cd = cd  # the working code: its rejections, before the full-resolution flags join it
            for i, (vals, n) in zip(reprojection.groups, zip(values, seen, strict=True), strict=True):
                if i == me:  # the camera's other photographs: the inverse-variance mean with the measurement
                    vals = np.maximum(vals, 0)
                    agree = own_agrees(resp[..., own], vals, own_sigma, own_rep_sigma)
                    use = (n > 0) & plain & valid & agree
                    a, b = w_own
                    mean = (a * resp[..., own] + b * vals) / (a + b)
                    resp[..., own] = np.where(use[..., None], mean, resp[..., own])
                else:
                    use = (n > 0) & plain & (work_cd & rejected_bit(m, i) == 0)  # not where rejected at work
                    resp[..., 3 * i : 3 * i + 3] = np.where(
                        use[..., None], np.maximum(vals, 0), resp[..., 3 * i : 3 * i + 3]
                    )
                cd = cd | (use.astype(cd.dtype) << (shift + i))
            del values, seen
        # pixels grouped by noise pattern: one gather and one scatter per strip
        cd = cd.ravel()
        # the same stable order from 16-bit keys where they fit (numpy sorts those by radix, in O(n))
        small = cd.size and cd.max() <= np.iinfo(np.uint16).max
        order = np.argsort(cd.astype(np.uint16) if small else cd, kind="stable")
        counts = np.bincount(cd, minlength=int(cd.max()) + 1) if cd.size else np.zeros(0, int)
        flat = resp.reshape(-1, k)[order]
        out = np.empty((len(flat), 3), np.float32)
        a = 0
        for c in np.flatnonzero(counts):
            b = a + int(counts[c])
            cor, scale = fitted(int(c))
            out[a:b] = _apply(cor, flat[a:b] * scale)
            a = b
        XYZ = np.empty_like(out)
        XYZ[order] = out
        return XYZ.reshape(r1 - r0, W, 3)

    bounds = [(r0, min(H, r0 + strip_rows)) for r0 in range(0, H, strip_rows)]
    if workers == 1:
        for r0, r1 in bounds:
            XYZ = strip(r0, r1)
            if progress is not None:
                progress("full resolution", r1, H)
            yield XYZ
        return
    yield from _in_order(strip, bounds, workers, lambda r1: progress and progress("full resolution", r1, H))


def corrected_working(fused: np.ndarray, code: np.ndarray, sigma: dict, fit: Callable) -> np.ndarray:
    """The working fused responses corrected noise pattern by noise pattern (``fit(σ) → (corrector,
    scale)``, each pattern its working σ), as the strips correct theirs: float32 XYZ (h, w, 3).

    The full-resolution output where the working grid is the RAW file's own: there the working fusion
    is a full-resolution one that knows more than a strip (the own channels demosaiced with the other
    cameras' help and averaged with the camera's other photographs, textured pixels anchored to their
    own sites)."""
    fused = np.asarray(fused, np.float32)
    code = np.asarray(code)
    out = np.zeros((*code.shape, 3), np.float32)
    for c, s_ in sigma.items():
        sel = code == c
        if sel.any():
            cor, scale = fit(np.asarray(s_, float))
            out[sel] = _apply(cor, fused[sel] * np.asarray(scale, np.float32))
    return out


def _in_order(work: Callable, bounds: list, workers: int, done: Callable):
    """``work(r0, r1)`` of each of ``bounds`` on ``workers`` threads, at most ``workers`` ahead of the
    one being yielded, yielded in order (``done(r1)`` after each); a failure is raised at its strip's
    turn, and the strips not yet started are cancelled when the consumer stops early."""
    from collections import deque
    from concurrent.futures import ThreadPoolExecutor

    todo = iter(bounds)
    pending: deque = deque()
    with ThreadPoolExecutor(max_workers=workers, thread_name_prefix="strip") as pool:
        try:
            for r0, r1 in todo:
                pending.append((r1, pool.submit(work, r0, r1)))
                if len(pending) >= workers:
                    break
            while pending:
                r1, fut = pending.popleft()
                XYZ = fut.result()
                for r0_, r1_ in todo:  # the next strip starts while this one is consumed
                    pending.append((r1_, pool.submit(work, r0_, r1_)))
                    break
                done(r1)
                yield XYZ
        finally:
            for _, fut in pending:
                fut.cancel()


class _Fitted:
    """``fitted(pattern) → (corrector, scale)``, each pattern fitted once (thread-safe): the working
    pattern's σ (low ``shift`` bits) with the channels of the cameras flagged above it at ``rep_sigma``."""

    def __init__(self, fit: Callable, patterns: dict, rep_sigma, shift: int, m: int):
        import threading

        self.fit, self.patterns, self.rep_sigma, self.shift, self.m = fit, patterns, rep_sigma, shift, m
        self.done: dict = {}
        self.lock = threading.Lock()

    def __call__(self, c: int):
        got = self.done.get(c)
        if got is not None:
            return got
        with self.lock:  # one fit per pattern, whichever strip meets it first
            if c not in self.done:
                s_ = self.patterns[c & ((1 << self.shift) - 1)].copy()
                for i in range(self.m):  # channels reprojected at full resolution
                    if c >> (self.shift + i) & 1:
                        s_[3 * i : 3 * i + 3] = self.rep_sigma[3 * i : 3 * i + 3]
                cor, scale = self.fit(s_)
                self.done[c] = cor, np.asarray(scale, np.float32)
            return self.done[c]


def textured_rows(source, r0: int, r1: int, exposure: float, white_scale, sigma) -> np.ndarray:
    """Rows ``r0:r1`` of :func:`splat.fusion.textured` of the RAW file at its full resolution (its
    measured sites, a 2-row margin for the 5 × 5 window: the same as testing the whole file), noise
    ``sigma`` (3,) on the white → 1 scale: (r1 − r0, W) bool."""
    from types import SimpleNamespace

    from .fusion import textured

    H = source.shape[0]
    a, b = max(0, r0 - 2), min(H, r1 + 2)
    a -= a % 2
    values, weight = source.rows(a, b)
    view = SimpleNamespace(values=values, weight=weight, exif=float(exposure))
    return textured(view, white_scale, noise=sigma)[r0 - a : r1 - a]


def _apply(corrector, responses: np.ndarray) -> np.ndarray:
    """A closed-form corrector on (N, k) float32 responses, :data:`CORRECT_CHUNK` at a time (regressions
    compute in float32 on float32 input)."""
    out = np.empty((len(responses), 3), np.float32)
    for a in range(0, len(responses), CORRECT_CHUNK):
        out[a : a + CORRECT_CHUNK] = corrector.predict(responses[a : a + CORRECT_CHUNK])
    return out


def _full_sigma(s: np.ndarray, own: slice, own_sigma: np.ndarray, fused: np.ndarray) -> np.ndarray:
    """σ per channel at full resolution for a working pattern ``s``: the own channels the sensor's
    full-resolution σ; each other channel its working σ and, in quadrature, the noise the Brovey ratio
    carries into it (the channel's median level times the own sum's relative σ)."""
    out = s.copy()
    own_level = max(float(np.median(np.maximum(fused[..., own], 0).sum(-1))), ANCHOR_EPS)
    rel = float(np.sqrt(np.sum(np.square(own_sigma)))) / own_level
    level = np.median(np.maximum(fused, 0).reshape(-1, fused.shape[-1]), axis=0)
    out = np.hypot(out, rel * level)
    out[own] = own_sigma
    return np.maximum(out, 1e-6)


def sRGB8_encoder(white_XYZ) -> Callable[[np.ndarray], np.ndarray]:
    """``XYZ (..., 3) → 8-bit sRGB (..., 3)``, as ``splat.capture.XYZ_to_sRGB`` (Bradford from the scene white
    ``white_XYZ`` to D65, clipped, sRGB-encoded) rounded to 8 bits: the linear map taken once from
    colour-science, the encoding through a table of 2¹⁶ linear levels (8-bit output differs from the
    exact curve by at most one level in the darkest shades)."""
    import colour

    srgb = colour.RGB_COLOURSPACES["sRGB"]
    w = np.asarray(white_XYZ, float)
    # XYZ_to_RGB is linear in XYZ: its matrix is its image of the identity
    M = colour.XYZ_to_RGB(
        np.eye(3), srgb, illuminant=colour.XYZ_to_xy(w), chromatic_adaptation_transform="Bradford"
    )
    levels = np.linspace(0, 1, 2**16)
    lut = (np.asarray(colour.models.eotf_inverse_sRGB(levels)) * 255 + 0.5).astype(np.uint8)
    M32 = np.asarray(M, np.float32)

    def encode(XYZ):
        rgb = np.asarray(XYZ, np.float32) @ M32
        idx = (np.clip(rgb, 0, 1) * np.float32(2**16 - 1) + np.float32(0.5)).astype(np.uint16)
        return lut[idx]

    return encode


class PNGStripWriter:
    """An 8-bit RGB PNG written a strip of rows at a time (zlib fed row by row, ``IDAT`` chunks as the
    compressor emits them): memory is one strip, whatever the image's height.

    Parameters
    ----------
    fh : binary file
    width, height : int
    level : int
        zlib level (1: a 24 MP PNG at the default level 6 took seconds more for ~10 % less size).
    """

    _SIGNATURE = b"\x89PNG\r\n\x1a\n"

    def __init__(self, fh, width: int, height: int, *, level: int = 1):
        import struct
        import zlib

        self.fh, self.width, self.height, self.done = fh, int(width), int(height), 0
        self._z = zlib.compressobj(level)
        fh.write(self._SIGNATURE)
        self._chunk(b"IHDR", struct.pack(">IIBBBBB", self.width, self.height, 8, 2, 0, 0, 0))

    def _chunk(self, kind: bytes, data: bytes) -> None:
        import struct
        import zlib

        self.fh.write(struct.pack(">I", len(data)) + kind + data)
        self.fh.write(struct.pack(">I", zlib.crc32(data, zlib.crc32(kind)) & 0xFFFFFFFF))

    def write(self, rgb8: np.ndarray) -> None:
        """Append rows (n, width, 3) of uint8."""
        rgb8 = np.asarray(rgb8)
        if rgb8.dtype != np.uint8 or rgb8.shape[1:] != (self.width, 3) or self.done + len(rgb8) > self.height:
            raise SplatError(
                f"PNG strip {rgb8.shape} {rgb8.dtype}: need uint8 rows (n, {self.width}, 3), at most "
                f"{self.height - self.done} more."
            )
        rows = np.zeros((len(rgb8), 1 + 3 * self.width), np.uint8)  # filter byte 0 (None) per row
        rows[:, 1:] = rgb8.reshape(len(rgb8), -1)
        data = self._z.compress(rows.tobytes())
        if data:
            self._chunk(b"IDAT", data)
        self.done += len(rgb8)

    def close(self) -> None:
        """Finish the stream; refuses an image with rows missing."""
        if self.done != self.height:
            raise SplatError(f"PNG: {self.done} of {self.height} rows written.")
        self._chunk(b"IDAT", self._z.flush())
        self._chunk(b"IEND", b"")


def write_full(
    xyz_path: Path,
    png_path: Path,
    strips,
    shape: tuple[int, int],
    to_sRGB8: Callable,
    *,
    rows: int = STRIP_ROWS,
) -> None:
    """Write a full-resolution image given as an iterator of XYZ strips (:func:`full_resolution_view`):
    ``xyz_path`` a float32 TIFF and ``png_path`` its 8-bit sRGB (``to_sRGB8(XYZ) → uint8``,
    :func:`sRGB8_encoder`; :class:`PNGStripWriter`), both strip by strip, never whole in memory.
    ``rows``: the strips' height (the last may be shorter), the TIFF's RowsPerStrip.
    Both atomically (temporaries in the same folder, renamed at the end, the PNG first); NaN or
    infinite values, or rows missing, are refused before either file appears."""
    import tifffile

    from zonotope.utilities import atomic_path

    H, W = shape
    done = [0]

    def write(p_xyz, p_png):
        with open(p_png, "wb") as fh:
            png = PNGStripWriter(fh, W, H)

            def segments():
                for s in strips:
                    if not np.all(np.isfinite(s)):
                        raise SplatError(f"{xyz_path}: refusing to write NaN/inf values.")
                    if done[0] + len(s) > H:
                        raise SplatError(f"{xyz_path}: more than {H} rows given.")
                    png.write(to_sRGB8(s))
                    done[0] += len(s)
                    yield np.ascontiguousarray(s, np.float32).tobytes()
                if done[0] != H:  # before the TIFF writer counts the bytes
                    raise SplatError(f"{xyz_path}: {done[0]} of {H} rows written.")

            with tifffile.TiffWriter(p_xyz) as tif:
                tif.write(
                    segments(),
                    shape=(H, W, 3),
                    dtype=np.float32,
                    photometric="minisblack",
                    planarconfig="contig",
                    rowsperstrip=rows,
                    metadata=None,
                )
            if done[0] != H:
                raise SplatError(f"{xyz_path}: {done[0]} of {H} rows written.")
            png.close()

    # the TIFF (what marks the view done) appears last
    atomic_path(xyz_path, lambda p_xyz: atomic_path(png_path, lambda p_png: write(p_xyz, p_png)))
