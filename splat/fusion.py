"""A photographed view fused with the splat: measured channels where a camera measured them.

For a view whose RAW file exists (every photograph the user took, held out from training or not), the
camera's own channels are *measured*; only the other cameras' channels must come from elsewhere. The
correct step therefore also corrects such views from fused responses (``splat.capture.fused_view``):

1. **Own channels**: the photograph, demosaiced by isp (:func:`measured`) or, for a Bayer view that
   other cameras' photographs see, demosaiced with their help (:func:`guided_demosaic`: each missing
   channel from the channel's own sites that look alike in the other cameras' photographs); where the
   camera's other photographs see the pixel, the inverse-variance mean with them (reprojected through
   the splat's depth, :mod:`splat.reproject`), which averages sensor noise.
2. **Another camera's channels**: its photographs reprojected into the view where any sees the pixel
   (combined, :func:`splat.reproject.reprojected`), then re-read by :func:`guided`, a joint bilateral
   filter guided by the view's own photograph (at an edge a pixel reads the reprojection from
   neighbours that look like it in its photograph; on a surface it averages the reprojection's noise;
   the own camera's reprojection alike); elsewhere the splat's render **anchored** to the
   photograph (:func:`anchor`): every channel scaled, per pixel, by the ratio of the measured to the
   rendered sum of the own channels (the Brovey transform of pan-sharpening, Gillespie et al. 1987), so
   a render error common to all channels (opacity, coverage, shading) cancels.
3. **Per-channel noise**: the own channels carry the sensor's noise (:func:`sensor_noise`: the file's
   DNG NoiseProfile at the channel's median signal; without one, a robust estimate from the mosaic,
   an upper bound on textured scenes), reprojected channels their camera's reprojection error
   (:func:`reprojection_noise`: against the measured sites of the camera's own rendered views where the
   render is :func:`smooth`, each site's own noise :func:`site_noise` removed), rendered ones the
   render's error after anchoring (:func:`render_noise`). The estimator is fitted on the
   channel-whitened problem (:func:`whitened`: channel ``k`` scaled by ``σ_ref/σ_k``), so that its single
   noise level means ``σ_k`` in each channel — the MMV's tolerance too (``δ_k ∝ σ_k``): measured
   channels constrain the estimate tightly and rendered ones softly, instead of all alike.
4. **Textured pixels** (:func:`textured`: the photograph's sites of one channel vary over the 5 × 5
   neighbourhood by more than half their level and six σ of the sensor noise) take none of the above:
   there a reprojection misplaced by a fraction of a pixel, or a channel demosaiced across a 1–2 px
   border, is off by the step itself, not by its σ, and six such channels outvote the three measured
   ones (the borders are painted over). Their responses are the render anchored to the pixel's own
   *site* — the one measured channel of a Bayer pixel, the three of a full-colour one (:func:`anchor`
   with the mosaic's sites as ``valid``) — with the sensor's σ on that channel and the render's on all
   others.

Views without a RAW file (novel views) are corrected the same way from the photographs reprojected into
them (``splat.capture.photographed_view``: every camera's channels reprojected where its photographs see the
pixel, re-read by :func:`guided` with the mean of the cameras' channel triples as the guide; elsewhere
the render anchored to the channels that were).

Measured (``benchmarks/bench_capture.py``, CI-size coarse capture, true poses, flat pixels of the six
held-out views, three cameras with Prior; docs/benchmarks.md has the tables): noise-free,
render only 1.63–1.66 ΔE00, fused 0.30–0.32 after 1000 steps (two seeds) against 0.87 for the best
camera's own DNG development (same white); as novel views (the view's own RAW unused) 0.36–0.37; with
sensor noise, render only 1.5–1.85, fused 0.63–0.81 and as novel views 0.65–0.85 on three scenes (their
DNG developments 1.77–1.96). Over all pixels of the benchmark capture's held-out views (three cameras,
Prior), the texture test took the fused estimate from 8.08 to 3.90 ΔE00 (flat pixels 0.668 → 0.670), the
best camera's DNG development 8.33 (:data:`splat._tol.TEXTURE_RTOL`).
"""

from __future__ import annotations

import dataclasses

import numpy as np

from ._errors import SplatError
from ._tol import (  # noqa: F401  (OWN_NOISE_FLOOR: pipeline, tests)
    ANCHOR_EPS,
    GUIDE_RADIUS,
    GUIDE_RANGE,
    GUIDE_RELIABILITY,
    JOINT_FIT_RIDGE,
    JOINT_NSIGMA,
    OWN_AGREE_RTOL,
    OWN_NOISE_FLOOR,
    SMOOTH_RTOL,
    TEXTURE_NSIGMA,
    TEXTURE_RTOL,
)

__all__ = [
    "anchor",
    "camera_levels",
    "guided",
    "guided_demosaic",
    "impossible",
    "measured",
    "own_agrees",
    "photo_variance",
    "rejected_bit",
    "render_error",
    "render_noise",
    "reprojection_noise",
    "sensor_noise",
    "site_noise",
    "sites",
    "smooth",
    "textured",
    "unclipped",
    "whitened",
]


def measured(view, white_scale, *, method: str = "Malvar 2004") -> np.ndarray:
    """A RAW view's own channels on the white → 1 scale at exposure 1: demosaiced by isp (``method``,
    any of :func:`isp.stages.demosaic`'s; a full-colour file as it is), divided by its EXIF exposure and
    the camera's white scale (3,).

    Malvar 2004 suits the view's own flat regions; a photograph *reprojected* into another view is read
    there at points that can lie within a pixel or two of an edge of its own (a flat patch of the target
    can be a few source pixels wide), where Malvar's gradient correction overshoots: the pipeline
    demosaics sources with ``"bilinear"`` (a convex combination of measured sites, no overshoot)."""
    from isp.stages import demosaic

    if view.exif is None:
        raise SplatError(f"{view.name}: no exposure (EXIF or the capture file's override); cannot fuse.")
    lin = (
        view.values.astype(np.float64)
        if view.full_colour
        else demosaic(view.values.sum(-1), cfa=view.cfa, method=method)
    )
    return lin / view.exif / np.asarray(white_scale, float)


def sites(view, white_scale) -> tuple[np.ndarray, np.ndarray]:
    """A RAW view's measured sites, not demosaiced: its values on the scale of :func:`measured`
    (white → 1 at exposure 1; 0 off the sites of a Bayer mosaic) and where they are usable
    (``weight > 0``: not saturated, not dead, on the channel's CFA sites), both (H, W, 3)."""
    if view.exif is None:
        raise SplatError(f"{view.name}: no exposure (EXIF or the capture file's override); cannot fuse.")
    values = np.asarray(view.values, float) / view.exif / np.asarray(white_scale, float)
    return values, np.asarray(view.weight) > 0


def render_error(view, white_scale, render_own: np.ndarray, *, size: int | None = None) -> np.ndarray:
    """The render's local relative error against a RAW view's own measured sites: per pixel, the
    standard deviation of ``log(measured / rendered)`` over the usable sites (:func:`sites`, both
    levels above :data:`splat._tol.RENDER_ERROR_FLOOR`) of the ``size × size`` window (default
    :data:`splat._tol.RENDER_ERROR_WINDOW`); 0 where the window holds fewer than two. A common gain
    over the window (what anchoring to the photograph removes) does not count; a render whose shape is
    wrong within the window does.

    Why: the fusion's one render σ is the render's error averaged over every photograph, and most of
    it sits at the edges of surfaces, where the render is off by a step; a pixel there is told of it
    by its own photograph.

    Returns
    -------
    ndarray of shape (H, W), float
    """
    from scipy.ndimage import uniform_filter

    from ._tol import RENDER_ERROR_FLOOR, RENDER_ERROR_WINDOW

    size = RENDER_ERROR_WINDOW if size is None else int(size)
    values, at = sites(view, white_scale)
    r = np.asarray(render_own, float)
    if r.shape != values.shape:
        raise SplatError(f"render_error: render {r.shape} and the view's sites {values.shape} do not match.")
    floor = RENDER_ERROR_FLOOR
    ok = at & (values > floor) & (r > floor)
    lg = np.where(ok, np.log(np.maximum(values, floor) / np.maximum(r, floor)), 0.0)
    n = uniform_filter(ok.sum(-1).astype(float), size, mode="nearest")
    s1 = uniform_filter(lg.sum(-1), size, mode="nearest")
    s2 = uniform_filter((lg**2).sum(-1), size, mode="nearest")
    enough = np.rint(n * size * size) >= 2  # at least two sites in the window
    mean = s1 / np.maximum(n, 1e-12)
    return np.where(enough, np.sqrt(np.maximum(s2 / np.maximum(n, 1e-12) - mean**2, 0.0)), 0.0)


def smooth(render: np.ndarray, *, rtol: float = SMOOTH_RTOL, size: int = 5) -> np.ndarray:
    """Pixels where a view's render is smooth: every channel's range over the ``size × size``
    neighbourhood is at most ``rtol`` × the pixel's mean over channels (at least 0.02; borders
    extended).

    Parameters
    ----------
    render : ndarray of shape (H, W, k)
        The view's render, white → 1 (or any picture of the view on that scale).
    rtol : float
    size : int
        Odd window width (px).

    Returns
    -------
    ndarray of shape (H, W), bool
    """
    from scipy.ndimage import maximum_filter, minimum_filter

    r = np.asarray(render, float)
    if r.ndim != 3:
        raise SplatError(f"smooth: the render must be (H, W, k), got shape {r.shape}.")
    if not (isinstance(size, (int, np.integer)) and size >= 1 and size % 2 == 1):
        raise SplatError(f"smooth: size must be an odd number of pixels ≥ 1, got {size!r}.")
    lim = rtol * np.maximum(r.mean(-1), 0.02)
    ok = np.ones(r.shape[:2], bool)
    for c in range(r.shape[-1]):
        x = r[..., c]
        ok &= maximum_filter(x, size, mode="nearest") - minimum_filter(x, size, mode="nearest") <= lim
    return ok


def guided(
    values: np.ndarray,
    seen: np.ndarray,
    guide: np.ndarray,
    *,
    radius: int = GUIDE_RADIUS,
    range_sigma: float = GUIDE_RANGE,
    reliability: float = GUIDE_RELIABILITY,
) -> np.ndarray:
    """One camera's reprojected channels re-read where the view's own photograph says they belong: a
    joint (cross) bilateral filter (Petschnigg et al. 2004; Kopf et al. 2007) guided by the photograph.

    A photograph reprojected into a view is resampled from another viewpoint and resolution through an
    estimated depth: near the view's edges it mixes the two surfaces, misplaced by a fraction of a
    pixel, and everywhere it carries its sensor noise. The view's own photograph is sharp and in place.
    Each pixel ``p`` where the camera's photographs are seen takes the weighted mean of the reprojected
    values ``O(q)`` over the ``(2 radius + 1)²`` window, with weights

    ``w(p, q) = seen(q) · exp(−R(q) / reliability) · exp(−‖G(q) − G(p)‖² / (2 range_sigma² ℓ(p)²))
    · exp(−‖q − p‖² / (2 (radius / 1.5)²))``

    ``G`` the guide, ``ℓ(p) = max(mean G(p), 0.02)`` its level (the range kernel is relative, as the
    camera's response is), ``R(q)`` the largest range of a reprojected channel over ``q``'s 3 × 3
    neighbourhood relative to ``max(mean O(q), 0.02)`` (a pixel on an edge of the *reprojection* vouches
    for little). So a pixel reads the reprojection from neighbours that look like it in its own
    photograph and lie inside a surface of the reprojection; on a flat surface this is a local mean,
    which averages the reprojection's noise. Unseen pixels are returned as they are; the ranges ``R``
    see them with the values given (0 as the render step writes them), so a pixel at the border of
    what the photographs see vouches for little too. Neighbours outside the image weigh nothing, and
    the weights are summed as logarithms with a running maximum per pixel (online log-sum-exp), so that
    a weight far below the smallest float does not lose the mean its digits.

    Parameters
    ----------
    values : ndarray of shape (H, W, 3)
        One camera's reprojected channels (white → 1).
    seen : ndarray of shape (H, W), bool
        Where any of the camera's photographs sees the pixel.
    guide : ndarray of shape (H, W, c)
        The view's own photograph (:func:`measured`, white → 1).
    radius, range_sigma, reliability
        See ``splat._tol.GUIDE_RADIUS`` (and the two after it) for how they were chosen.

    Returns
    -------
    ndarray of shape (H, W, 3)
    """
    from scipy.ndimage import maximum_filter, minimum_filter

    O = np.asarray(values, float)
    G = np.asarray(guide, float)
    seen = np.asarray(seen, bool)
    H, W = seen.shape
    if O.shape != (H, W, 3) or G.ndim != 3 or G.shape[:2] != (H, W):
        raise SplatError(
            f"guided: values {O.shape}, seen {seen.shape} and guide {G.shape} must be (H, W, 3), (H, W) "
            "and (H, W, c) of one view."
        )
    if int(radius) != radius or radius < 1 or not range_sigma > 0 or not reliability > 0:
        raise SplatError(
            f"guided: radius must be an integer ≥ 1 and range_sigma, reliability > 0; got {radius}, "
            f"{range_sigma}, {reliability}."
        )
    if not (np.all(np.isfinite(O)) and np.all(np.isfinite(G))):
        raise SplatError("guided: values and guide must be finite.")
    r = int(radius)
    span = np.zeros((H, W))
    for j in range(3):
        span = np.maximum(
            span, maximum_filter(O[..., j], 3, mode="nearest") - minimum_filter(O[..., j], 3, mode="nearest")
        )
    log_rel = np.where(seen, -span / np.maximum(O.mean(-1), 0.02) / reliability, -np.inf)
    return _bilateral(O, log_rel, G, r, range_sigma, at=seen)


def _bilateral(O, log_rel, G, r: int, range_sigma: float, *, at):
    """The joint bilateral weighted mean of ``O`` (H, W, m) at the pixels ``at`` (others keep ``O``):
    neighbour ``q`` of ``p`` weighs ``exp(log_rel(q) − ‖G(q) − G(p)‖² / (2 range_sigma² ℓ(p)²) −
    ‖q − p‖² / (2 (r / 1.5)²))``, ``log_rel = −∞`` for a neighbour that may not enter; a pixel with no
    such neighbour keeps ``O``.

    The log-weights are accumulated with a running per-pixel maximum (the online log-sum-exp): a weight
    far below 1e-308 would otherwise be subnormal and the weighted mean would lose its digits. In strips
    of rows, so the temporaries stay small on large photographs."""
    H, W, m = O.shape
    level = np.maximum(G.mean(-1), 0.02)
    pad = ((r, r), (r, r), (0, 0))
    Gp, Op = np.pad(G, pad, mode="edge"), np.pad(O, pad, mode="edge")
    Rp = np.pad(log_rel, r, constant_values=-np.inf)  # no neighbour outside the image
    out = O.copy()
    for y0 in range(0, H, _GUIDED_ROWS):
        y1 = min(y0 + _GUIDED_ROWS, H)
        Gc, lev = G[y0:y1], level[y0:y1, :, None]
        top = np.full((y1 - y0, W), -np.inf)
        num, den = np.zeros((y1 - y0, W, m)), np.zeros((y1 - y0, W))
        for dy in range(-r, r + 1):
            for dx in range(-r, r + 1):
                qy, qx = slice(r + y0 + dy, r + y1 + dy), slice(r + dx, r + dx + W)
                d2 = (((Gp[qy, qx] - Gc) / lev) ** 2).sum(-1)
                lw = Rp[qy, qx] - d2 / (2 * range_sigma**2) - (dy * dy + dx * dx) / (2 * (r / 1.5) ** 2)
                new_top = np.maximum(top, lw)
                ref = np.where(np.isfinite(new_top), new_top, 0.0)
                old = np.exp(np.where(np.isfinite(top), top - ref, -np.inf))  # rescale what was summed
                w = np.exp(np.where(np.isfinite(lw), lw - ref, -np.inf))
                num = num * old[..., None] + w[..., None] * Op[qy, qx]
                den = den * old + w
                top = new_top
        ok = at[y0:y1] & (den > 0)  # some neighbour may enter (the pixel itself, where it may)
        out[y0:y1] = np.where(ok[..., None], num / np.where(ok, den, 1.0)[..., None], O[y0:y1])
    return out


def guided_demosaic(
    view, white_scale, guide, *, radius: int = GUIDE_RADIUS, range_sigma: float = GUIDE_RANGE
):
    """A Bayer view's own channels, demosaiced with the other cameras' help: each channel's measured
    sites as they are (white → 1, exposure 1, as :func:`measured`); at the other pixels the joint
    bilateral mean (:func:`guided`'s weights without the reliability term) of the channel's usable sites
    (neither saturated nor dead) in the ``(2 radius + 1)²`` window, guided by ``guide`` — in
    ``splat.capture.fused_view``, the other cameras' reprojected photographs (re-read by :func:`guided`) next
    to the view's own Malvar demosaicing. A site across an edge in the guide weighs little, so an edge
    that the other cameras see is not blurred into the interpolated channels, as it is by a
    demosaicing that sees one mosaic only. Pixels without a usable site of the channel in the window
    keep :func:`measured` (Malvar 2004). A full-colour view is returned as :func:`measured` gives it.

    Parameters
    ----------
    view : RawView
    white_scale : array_like of shape (3,)
    guide : ndarray of shape (H, W, c)

    Returns
    -------
    ndarray of shape (H, W, 3)
    """
    own = measured(view, white_scale)
    G = np.asarray(guide, float)
    if G.ndim != 3 or G.shape[:2] != own.shape[:2] or not np.all(np.isfinite(G)):
        raise SplatError(
            f"guided_demosaic: the guide must be finite (H, W, c) of the view's size {own.shape[:2]}, "
            f"got {G.shape}."
        )
    if view.full_colour:
        return own
    mosaic, at = sites(view, white_scale)
    out = own.copy()
    for j in range(3):  # sites keep their value; a pixel with no usable site in its window keeps Malvar's
        out[..., j] = _bilateral(
            np.where(at[..., j], mosaic[..., j], own[..., j])[..., None],
            np.where(at[..., j], 0.0, -np.inf),
            G,
            int(radius),
            range_sigma,
            at=~at[..., j],
        )[..., 0]
    return out


_GUIDED_ROWS = 64  # rows per strip of :func:`guided` (memory only; results do not depend on it)


def _robust_sigma(x: np.ndarray) -> float:
    """1.4826 · median absolute deviation (σ of a normal sample, unmoved by a minority of outliers)."""
    x = np.asarray(x, float).ravel()
    if x.size == 0:
        return 0.0
    return float(1.4826 * np.median(np.abs(x - np.median(x))))


def sensor_noise(view, white_scale) -> np.ndarray:
    """Noise σ of each of a RAW view's channels (3,), white → 1 units at exposure 1, from the file.

    With a noise model in the file (the DNG NoiseProfile, ``RawView.noise_profile``:
    variance ``S_j·x + O_j`` of the linear value ``x``), ``σ_j = sqrt(S_j·x_j + O_j)`` at ``x_j``, the
    median of channel ``j``'s valid site values (weight > 0; the typical signal level): the sensor's
    own noise, whatever the scene. On the simulated capture it is the realised noise within a few per
    cent (:mod:`splat.sim.capture` writes the exact profile).

    Without one, an estimate from the image: differences of horizontally and vertically adjacent sites
    of the same colour (two sites apart on a Bayer mosaic, adjacent on a full-colour sensor) carry twice
    the noise variance and, away from edges, little of the scene; their robust σ
    (:func:`_robust_sigma`, which discards the edges as outliers) divided by √2 estimates the noise at
    the typical signal level. Valid sites only. Texture finer than a few sites is taken for noise, so
    on a textured scene this is an upper bound: 1.4–2.6 × the realised noise on the simulated capture's
    coarse texture, 3–27 × on its fine (pixel-scale) one.

    Either σ is then divided by the view's exposure and the camera's white scale (3,).

    Raises
    ------
    SplatError
        The view has no exposure (``view.exif`` is None).
    """
    if view.exif is None:
        raise SplatError(f"{view.name}: no exposure (EXIF or the capture file's override); cannot fuse.")
    vals = np.asarray(view.values, float)
    w = np.asarray(view.weight) > 0
    if view.noise_profile is not None:
        P = np.asarray(view.noise_profile, float)
        x = np.array([np.median(vals[..., j][w[..., j]]) if w[..., j].any() else 0.0 for j in range(3)])
        sigma = np.sqrt(P[:, 0] * np.maximum(x, 0.0) + P[:, 1])
        return sigma / view.exif / np.asarray(white_scale, float)
    step = 1 if view.full_colour else 2
    out = np.zeros(3)
    for j in range(3):
        diffs = []
        for axis in (0, 1):
            a = np.take(vals[..., j], range(step, vals.shape[axis]), axis=axis)
            b = np.take(vals[..., j], range(vals.shape[axis] - step), axis=axis)
            ok = np.take(w[..., j], range(step, vals.shape[axis]), axis=axis) & np.take(
                w[..., j], range(vals.shape[axis] - step), axis=axis
            )
            diffs.append((a - b)[ok])
        out[j] = _robust_sigma(np.concatenate(diffs)) / np.sqrt(2)
    return out / view.exif / np.asarray(white_scale, float)


def site_noise(view, white_scale) -> np.ndarray:
    """Noise σ of every site of a RAW view (H, W, 3), white → 1 units at exposure 1: with the file's
    noise model (DNG NoiseProfile) ``sqrt(S_j·x + O_j)`` at each site's own value ``x``, else
    :func:`sensor_noise`'s image estimate everywhere; divided by the exposure and the white scale."""
    if view.exif is None:
        raise SplatError(f"{view.name}: no exposure (EXIF or the capture file's override); cannot fuse.")
    var = photo_variance(view, np.asarray(view.values, float) / view.exif, reach=None)
    return np.sqrt(var) / np.asarray(white_scale, float)


def impossible(generators, values_a, values_b, tol: float) -> np.ndarray:
    """Which pairs of two cameras' responses no surface can produce: farther than ``tol`` (L1, white → 1
    units) from the two cameras' joint object-colour solid (:func:`zonotope.solid_distance`).

    A misplaced reprojection reads another surface: the view's own channels say a black chart patch,
    the other camera's say its orange neighbour. Metamerism cannot explain that, since no reflectance
    in [0, 1] gives both, so the test rejects only what physics rules out and keeps every real
    difference between the cameras (the information stacking them is for). A pair brighter than the
    white (a surface lit more strongly than the card) is tested at the white's level, divided by its
    largest response, and its distance scaled back.

    Most pairs are settled without the LP: a smooth reflectance (a constant and five cosines over the
    wavelengths, a ridge fit about the mid-grey, since two cameras' channels are nearly collinear;
    clipped to [0, 1]) gives responses whose L1 distance to the pair bounds the solid's from above, and
    a pair it brings within ``tol`` is possible. The decisions are the LP's for every pair
    (:func:`zonotope.solid_distance` runs on the rest: ~20 % of the pixels of a benchmark view against
    ~50 % with a plain least-squares fit).

    Parameters
    ----------
    generators : array_like of shape (n, 6)
        Camera A's three generators, then camera B's (white → 1 per channel, as the correction's).
    values_a, values_b : array_like of shape (N, 3)
        The two cameras' responses at N pixels (white → 1, exposure 1).
    tol : float
        L1 slack: the pair's noise (a few σ summed over the six channels).

    Returns
    -------
    ndarray of shape (N,), bool
    """
    from zonotope import solid_distance

    z = np.concatenate([np.asarray(values_a, float), np.asarray(values_b, float)], axis=-1)
    if z.ndim != 2 or z.shape[1] != 6 or np.shape(generators)[-1] != 6:
        raise SplatError(
            f"impossible: need (N, 3) responses of each camera and (n, 6) generators; got {z.shape}."
        )
    if not len(z):
        return np.zeros(0, bool)
    G = np.asarray(generators, float)
    level = np.maximum(z.max(axis=1), 1.0)
    z = z / level[:, None]
    basis = np.cos(np.outer(np.linspace(0.0, np.pi, G.shape[0]), np.arange(6)))  # (n, 6), smooth
    A = G.T @ basis
    AtA = A.T @ A
    fit = basis @ np.linalg.solve(AtA + JOINT_FIT_RIDGE * np.trace(AtA) / 6 * np.eye(6), A.T)  # (n, 6)
    grey = 0.5 * G.sum(axis=0)  # the responses of the mid-grey, x = 0.5 (the basis' constant)
    out = np.zeros(len(z), bool)
    step = 65536  # pairs at a time: (step, n) reflectances in memory
    for s in range(0, len(z), step):
        part, lv = z[s : s + step], level[s : s + step]
        x = np.clip(0.5 + (part - grey) @ fit.T, 0.0, 1.0)
        need = np.abs(x @ G - part).sum(axis=1) * lv > tol
        if need.any():
            out[s : s + step][need] = solid_distance(G, part[need]) * lv[need] > tol
    return out


def own_agrees(measured, reprojected, sigma, reprojected_sigma) -> np.ndarray:
    """Where the view's own camera's other photographs, reprojected, agree with its measurement
    (..., 3): within :data:`splat._tol.JOINT_NSIGMA` times the sum of the two σ (3,) plus
    :data:`splat._tol.OWN_AGREE_RTOL` of the measurement, in every channel; (...) bool. Elsewhere the
    reprojection is misplaced (a neighbour read across an edge) and must not be averaged in. Computed in
    ``measured``'s dtype (float32 in the full-resolution strips)."""
    m = np.asarray(measured)
    dt = m.dtype if np.issubdtype(m.dtype, np.floating) else np.float64
    tol = (JOINT_NSIGMA * (np.asarray(sigma, float) + np.asarray(reprojected_sigma, float))).astype(dt)
    return (np.abs(reprojected - m) <= tol + dt.type(OWN_AGREE_RTOL) * np.abs(m)).all(-1)


def rejected_bit(m: int, i: int) -> int:
    """The bit of a fused view's noise-pattern code (``splat.capture.fused_view``, ``m`` cameras) set
    where camera ``i``'s reprojection was rejected (:func:`impossible`): the full-resolution pass
    (:mod:`splat.strips`) does not read that camera's photographs there either."""
    return 1 << (m + 5 + i)


def unclipped(view, *, reach: int = 2) -> np.ndarray:
    """Pixels of a RAW view whose demosaiced photograph is a measurement: no saturated or dead site of
    any channel within ``reach`` pixels (a Bayer mosaic; ``reach = 2`` is Malvar 2004's 5 × 5
    footprint, 1 bilinear's 3 × 3) or at the pixel itself (a full-colour or binned view: a channel
    without a usable sample there).

    Why: a channel read from a clipped site is a lower bound, off by the clipping, not by the sensor's
    σ; told that σ, an estimator trusts it over every other camera's channels (the white card of the
    path-traced capture: the Nikon's green clips in its held-out views, docs/benchmarks.md).

    Returns
    -------
    ndarray of shape (H, W), bool
    """
    from scipy.ndimage import maximum_filter

    w = np.asarray(view.weight) > 0
    if view.full_colour:
        return w.all(-1)
    if int(reach) != reach or reach < 0:
        raise SplatError(f"unclipped: reach must be an integer ≥ 0, got {reach!r}.")
    from isp.cfa import cfa_masks

    bad = (cfa_masks(w.shape[:2], view.cfa) & ~w).any(-1)
    return ~maximum_filter(bad, 2 * int(reach) + 1, mode="constant", cval=False) if reach else ~bad


def photo_variance(view, photo, *, reach: int | None = 1) -> np.ndarray:
    """Noise variance of a RAW view's demosaiced photograph ``photo`` (H, W, 3) at exposure 1 (white
    scale 1, as :func:`measured` with ``white_scale = 1``): with the file's noise model (DNG
    NoiseProfile) ``(S_j·x + O_j) / e²`` at each pixel's own linear value ``x = photo · e`` (``e`` the
    exposure; interpolated pixels are taken as measured ones, an upper bound), else
    :func:`sensor_noise`'s image estimate squared everywhere.

    Where the photograph is not :func:`unclipped` (a saturated or dead site within ``reach`` pixels, the
    demosaicing's footprint: 1 for the bilinear demosaicing of reprojection sources; None for the
    sites themselves, no such test) the variance is the full scale squared, ``1 / e²``: a clipped
    reading is a bound, and an inverse-variance mean then gives it no weight next to a measured one."""
    if view.exif is None:
        raise SplatError(f"{view.name}: no exposure (EXIF or the capture file's override); cannot fuse.")
    photo = np.asarray(photo, float)
    if view.noise_profile is None:
        var = np.broadcast_to(sensor_noise(view, np.ones(3)) ** 2, photo.shape).copy()
    else:
        P = np.asarray(view.noise_profile, float)
        var = (P[:, 0] * np.maximum(photo * view.exif, 0.0) + P[:, 1]) / view.exif**2
    if reach is not None:
        var[~unclipped(view, reach=reach)] = 1.0 / view.exif**2
    return var


def reprojection_noise(residual, site_sigma) -> float:
    """σ of reprojected photographs from their residuals against measured sites of known noise.

    A residual ``r_i`` (reprojected value − the site's measured value) has variance ``σ_i² + σ²``:
    ``σ_i`` the site's own noise (:func:`site_noise`), ``σ`` the reprojection's. Returns the ``σ ≥ 0``
    for which ``r_i / sqrt(σ_i² + σ²)`` has robust standard deviation 1 (:func:`_robust_sigma`;
    bisection), 0 when the sites' own noise already explains the spread. Heteroscedastic sites (dark and
    bright, short and long exposures) are weighed by their own noise, as a single pooled σ cannot.
    """
    r = np.asarray(residual, float)
    s = np.asarray(site_sigma, float)
    if r.shape != s.shape or not np.all(np.isfinite(r)) or not np.all(np.isfinite(s)) or (s < 0).any():
        raise SplatError(
            f"reprojection_noise: residuals {r.shape} and site σ {s.shape} must match, finite, σ ≥ 0."
        )
    r, s = r.ravel(), s.ravel()
    if r.size == 0:
        return 0.0

    def spread(sigma):
        return _robust_sigma(r / np.sqrt(np.maximum(s**2 + sigma**2, np.finfo(float).tiny)))

    if spread(0.0) <= 1.0:
        return 0.0
    lo, hi = 0.0, max(_robust_sigma(r), 1e-12) * 2
    for _ in range(60):
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if spread(mid) > 1.0 else (lo, mid)
    return 0.5 * (lo + hi)


def anchor(render: np.ndarray, own_measured: np.ndarray, own: slice, valid: np.ndarray | None = None):
    """Anchor a view's render to its photograph (the Brovey transform): every channel times the ratio
    of the measured to the rendered sum of the own channels, the own channels replaced by the measured.

    Parameters
    ----------
    render : ndarray of shape (H, W, k)
        The splat's render of the view (white → 1, exposure 1).
    own_measured : ndarray of shape (H, W, 3)
        The view's own channels as measured (:func:`measured`, or the RAW sites themselves).
    own : slice
        Where the own channels sit among the ``k``.
    valid : ndarray of shape (H, W) or (H, W, 3), bool, optional
        Pixels whose photograph is usable (not saturated, not dead); the others keep the render. Per
        channel (``(H, W, 3)``, e.g. a mosaic's sites, ``RawView.weight > 0``): the ratio is taken over
        the channels measured at the pixel, only those are replaced, the other own channels are the
        render times the ratio; a pixel without any keeps the render.

    Returns
    -------
    ndarray of shape (H, W, k)
        Non-negative fused responses.
    """
    r = np.maximum(np.asarray(render, float), 0.0)
    m = np.maximum(np.asarray(own_measured, float), 0.0)
    if r.shape[:2] != m.shape[:2] or m.shape[-1] != 3 or r[..., own].shape[-1] != 3:
        raise SplatError(
            f"anchor: render {r.shape} and measured {m.shape} do not match (own channels {own})."
        )
    if valid is None:
        v = np.ones(m.shape, bool)
    else:
        v = np.asarray(valid, bool)
        if v.shape == m.shape[:2]:
            v = np.repeat(v[..., None], 3, -1)
        elif v.shape != m.shape:
            raise SplatError(f"anchor: valid must be (H, W) or (H, W, 3) as {m.shape}, got {v.shape}.")
    ratio = ((m * v).sum(-1, keepdims=True) + ANCHOR_EPS) / (
        (r[..., own] * v).sum(-1, keepdims=True) + ANCHOR_EPS
    )
    fused = r * ratio
    fused[..., own] = np.where(v, m, fused[..., own])
    return np.where(v.any(-1, keepdims=True), fused, r)


def textured(
    view, white_scale, *, rtol: float = TEXTURE_RTOL, noise=None, n_sigma: float = TEXTURE_NSIGMA
) -> np.ndarray:
    """Pixels where a RAW view's photograph is textured: in some channel ``j``, the measured sites within
    the pixel's 5 × 5 neighbourhood span more than ``rtol`` × their largest value (at least 0.02) and,
    given the sensor noise, more than ``n_sigma · noise[j]``.

    Sites of one channel only are compared (two pixels apart on a Bayer mosaic), so no demosaicing
    enters and the test needs no truth; saturated and dead sites (weight 0) are left out. On the scale of
    :func:`measured` (white → 1 at exposure 1; borders extended). See :data:`splat._tol.TEXTURE_RTOL`
    and :data:`splat._tol.TEXTURE_NSIGMA`.

    Parameters
    ----------
    view : splat.capture.RawView
    white_scale : array_like of shape (3,)
    rtol : float
    noise : array_like of shape (3,), optional
        The sensor noise σ per channel on the same scale (:func:`sensor_noise`); None: no noise floor.
    n_sigma : float

    Returns
    -------
    ndarray of shape (H, W), bool
    """
    from scipy.ndimage import maximum_filter, minimum_filter

    if not rtol > 0:
        raise SplatError(f"textured: rtol must be positive, got {rtol!r}.")
    floor = np.zeros(3) if noise is None else float(n_sigma) * np.asarray(noise, float)
    if floor.shape != (3,) or not np.all(np.isfinite(floor)) or np.any(floor < 0):
        raise SplatError(
            f"textured: noise must be 3 finite σ ≥ 0 and n_sigma finite ≥ 0, got {noise!r} and {n_sigma!r}."
        )
    m, w = sites(view, white_scale)
    out = np.zeros(m.shape[:2], bool)
    for j in range(3):
        if not w[..., j].any():
            continue
        hi = maximum_filter(np.where(w[..., j], m[..., j], -np.inf), 5, mode="nearest")
        lo = minimum_filter(np.where(w[..., j], m[..., j], np.inf), 5, mode="nearest")
        seen = np.isfinite(hi)  # some site of the channel in the window
        span = np.where(seen, hi - lo, 0)
        out |= seen & (span > rtol * np.maximum(np.where(seen, hi, 0), 0.02)) & (span > floor[j])
    return out


def render_noise(pairs) -> float:
    """σ of the render's error after anchoring, white → 1, from views whose own channels are measured.

    For each pair ``(render_own, measured_own)`` (H, W, 3) and each own channel ``j``, the render is
    anchored on the *other two* own channels only and its prediction of channel ``j`` compared with the
    measurement (leave one channel out: the anchoring has not seen the channel it predicts, as with
    another camera's channels). The result is the root mean square over channels and views of the
    robust σ of these residuals.

    One σ for every rendered channel: per camera, the estimate is too optimistic for a sensor whose
    three channels are nearly proportional (the Sigma's: 0.001–0.004, against 0.012–0.018 for its
    true error in the other cameras' channels on the simulated capture), so the cameras are pooled.
    """
    sig = []
    for r_own, m_own in pairs:
        r_own = np.maximum(np.asarray(r_own, float), 0.0)
        m_own = np.maximum(np.asarray(m_own, float), 0.0)
        for j in range(3):
            o = [i for i in range(3) if i != j]
            ratio = (m_own[..., o].sum(-1) + ANCHOR_EPS) / (r_own[..., o].sum(-1) + ANCHOR_EPS)
            sig.append(_robust_sigma(ratio * r_own[..., j] - m_own[..., j]))
    if not sig:
        raise SplatError("render_noise: no measured view to estimate the render's error from.")
    return float(np.sqrt(np.mean(np.square(sig))))


def whitened(problem, noise):
    """The channel-whitened problem: ``Φ`` with channel ``k`` scaled by ``σ_ref / σ_k``.

    An estimator fitted on it with noise ``σ_ref`` (the median of ``noise``) and applied to responses
    scaled the same way treats channel ``k`` as having noise ``σ_k`` (the least-squares parts exactly;
    the MMV's max-norm tolerance ``δ = DELTA_SIGMAS·σ_ref`` becomes ``DELTA_SIGMAS·σ_k`` per channel).
    The noise-free MMV does not change: scaling a channel scales a response and its generator alike.
    The whitened ``Φ`` no longer maps white to 1 in every channel; nothing outside this round trip
    should use it.

    Parameters
    ----------
    problem : zonotope.correct.CorrectionProblem
    noise : array_like of shape (k,)
        Positive σ per channel (white = 1 units of ``problem``).

    Returns
    -------
    problem : CorrectionProblem
    scale : ndarray of shape (k,)
        Multiply responses by it before the estimator.
    sigma_ref : float
    """
    s = np.asarray(noise, float)
    if s.shape != (problem.k,) or not np.all(np.isfinite(s)) or np.any(s <= 0):
        raise SplatError(f"whitened: noise must be {problem.k} positive numbers, got {noise!r}.")
    ref = float(np.median(s))
    scale = ref / s
    return dataclasses.replace(problem, Phi=problem.Phi * scale), scale, ref


def camera_levels(
    pairs, training_responses, cameras: int, *, fixed: int | None = None, per_channel=()
) -> dict:
    """Each camera's level per channel relative to the others, from photographs of the same surfaces.

    A camera's white → 1 scale is measured on the white patch for the camera that photographed it; the
    others inherit it through their brightest neutral surfaces, which are not the same surface at the
    same light in every camera's photographs (the path-traced capture: the Sigma's channels 5 % low,
    docs/benchmarks.md), and through the white of their curves, whose channel gains two measurements
    of one model give 5–25 % apart (docs/notes/2026-12-01-published-curves.md). Where camera ``c``'s
    photographs are reprojected into camera ``k``'s view, the ratio of each of their channels to camera
    ``c``'s responses *predicted* from ``k``'s own measured channels (the least-squares 3 × 3 map
    between the cameras' responses to ``training_responses``) is ``level_c / level_k`` for that
    channel, once ``k``'s own channels are divided by its level (per-channel levels do not commute with
    the map); the levels are the least-squares solution of the logarithms of these ratios (one per
    view, camera pair — each used both ways — and channel, each the ratio of sums), with camera
    ``fixed`` at 1 (its white measured on the patch), else each channel's geometric mean at 1 over the
    cameras with one level (all of them when every camera has three). Only the
    cameras in ``per_channel`` get a level per channel (those whose curves' white is uncertain:
    published or estimated curves); the others one level for all three, as their curves' white is
    exact and a level per channel would only add the maps' mismatch (up to 3 % per channel for a
    Foveon camera against two Bayer ones).

    Parameters
    ----------
    pairs : iterable of (k, c, own, other)
        ``own`` (P, 3): camera ``k``'s measured channels at P pixels of one of its views (white → 1,
        unclipped, smooth); ``other`` (P, 3): camera ``c``'s reprojected channels at the same pixels.
    training_responses : ndarray of shape (N, 3 · cameras)
        The cameras' white → 1 responses to training reflectances (``problem.training @ problem.Phi``).
    cameras : int
    fixed : int, optional
    per_channel : collection of int

    Returns
    -------
    dict
        ``level`` (cameras, 3): divide camera ``c``'s white → 1 values by ``level[c]`` (multiply its
        white scale by it); ``ratios``: ``[k, c, pixels, [ratio per channel]]`` per pair used; cameras
        that no pair links to ``fixed`` (or to the others) keep 1.
    """
    from ._tol import CAMERA_LEVEL_MIN_PIXELS

    R = np.asarray(training_responses, float)
    if R.ndim != 2 or R.shape[1] != 3 * cameras or not np.all(np.isfinite(R)):
        raise SplatError(
            f"camera_levels: training responses must be finite (N, {3 * cameras}), got {R.shape}."
        )
    links, used = [], []
    for k, c, own, other in pairs:
        own, other = np.asarray(own, float).reshape(-1, 3), np.asarray(other, float).reshape(-1, 3)
        if own.shape != other.shape or k == c or len(own) < CAMERA_LEVEL_MIN_PIXELS:
            continue
        M, *_ = np.linalg.lstsq(R[:, 3 * k : 3 * k + 3], R[:, 3 * c : 3 * c + 3], rcond=None)
        back, *_ = np.linalg.lstsq(R[:, 3 * c : 3 * c + 3], R[:, 3 * k : 3 * k + 3], rcond=None)
        a, b = own.sum(0), other.sum(0)
        pred = a @ M
        if (
            not np.all(np.isfinite([*a, *b]))
            or np.any(pred <= 0)
            or np.any(b <= 0)
            or np.any(a <= 0)
            or np.any(b @ back <= 0)
        ):
            continue  # a ratio of sums that is not positive both ways says nothing of a level
        links += [(k, c, a, b, M), (c, k, b, a, back)]  # both ways
        used.append([int(k), int(c), len(own), [float(r) for r in b / pred]])
    level = np.ones((cameras, 3))
    linked = sorted({c for _, c, *_ in links})
    free = [c for c in linked if c != fixed] if fixed in linked else linked
    if links and free:
        from scipy.optimize import least_squares

        width = [3 if c in per_channel else 1 for c in free]
        anchor = [c for c in linked if c not in per_channel] or linked  # exact whites, where there are
        at = np.cumsum([0, *width])

        def residuals(x):
            lg = np.zeros((cameras, 3))
            for i, c in enumerate(free):
                lg[c] = x[at[i] : at[i + 1]]  # one value broadcast to three channels, or three
            r = [  # the map is linear: the sum of its predictions is its prediction of the sum
                np.log(seen) - lg[c] - np.log(np.maximum((own * np.exp(-lg[k])) @ M, 1e-300))
                for k, c, own, seen, M in links
            ]
            if fixed not in linked:  # each channel's geometric mean over the anchor cameras at 1
                r.append(lg[anchor].sum(0))
            return np.concatenate(r)

        x = least_squares(residuals, np.zeros(at[-1]), method="lm").x
        for i, c in enumerate(free):
            level[c] = np.exp(x[at[i] : at[i + 1]])
        if fixed not in linked:
            level[linked] /= np.exp(np.mean(np.log(level[anchor]), axis=0))
    return {"level": level, "ratios": used}
