"""The correct step: the white scale, noise level and δ (each cached in ``OUT/correct``), the fused and
photographed responses of a view (:mod:`splat.fusion`), the correction fits and the corrected images,
at the working resolution and at full size (:mod:`splat.strips`).
"""

from __future__ import annotations

import functools
import os
import time
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from .. import strips as _strips
from .._errors import SplatError
from .._tol import FEASIBLE_DISTANCE
from ..strips import FULL_METHOD
from .config import PipelineConfig, read_working, step_workspace, working_summary
from .files import read_index, read_tiff, write_json, write_png8, write_tiff
from .illuminant import illuminant_of
from .raw import RawView, load_views, open_raw, white_scale
from .spec import CaptureError, CaptureSpec
from .workspace import curves_fingerprint, peak_rss_mib, read_json, release_free_memory, reset_peak_rss

if TYPE_CHECKING:
    from zonotope.utilities import ProgressCallback

__all__ = [
    "WHITE_POINT",
    "XYZ_to_sRGB",
    "choose_delta",
    "correct_fused",
    "correct_step",
    "correction_problem_of",
    "curves_white",
    "delta_of",
    "dng_matrix_XYZ",
    "fit_corrector",
    "fit_fused_corrector",
    "fused_fitter",
    "fused_view",
    "fusion_of",
    "levelled_white",
    "noise_sigma",
    "own_noise",
    "photographed_view",
    "pipeline_mix",
    "reprojected_of",
    "ssf_record",
    "ssf_sigma",
    "white_of",
]

#: The ``white_point`` option of every estimator the correct step fits
#: (:func:`zonotope.correct.white_point_preserving`): a response proportional to the white card's maps to
#: the grey's colour. Why: the noise-aware estimators pull light neutrals towards green-yellow as the
#: tolerance grows (three cameras, δ = 0.03: Prior's mean ΔE00 over seven neutrals 0.54, 0.07 with it),
#: while no all-colour mean got worse by more than 0.001 (docs/notes/2026-11-29-neutral-bias.md).
WHITE_POINT = True


def XYZ_to_sRGB(XYZ, white_XYZ) -> np.ndarray:
    """XYZ (white ``white_XYZ``, Y = 1) → sRGB-encoded values in [0, 1] (Bradford to D65, clipped).

    Parameters
    ----------
    XYZ : array_like of shape (..., 3)
    white_XYZ : array_like of shape (3,)
    """
    import colour

    srgb = colour.RGB_COLOURSPACES["sRGB"]
    w = np.asarray(white_XYZ, float)
    rgb = colour.XYZ_to_RGB(
        np.asarray(XYZ, float),
        srgb,
        illuminant=colour.XYZ_to_xy(w),
        chromatic_adaptation_transform="Bradford",
    )
    return np.asarray(colour.models.eotf_inverse_sRGB(np.clip(rgb, 0, 1)))


def white_of(spec: CaptureSpec, out: Path, views: list[RawView] | None = None) -> dict:
    """The white → 1 scale (:func:`splat.capture.white_scale`), cached in ``OUT/correct/white.json``."""
    path = out / "correct" / "white.json"
    if path.is_file():
        d = read_json(path, what="white scale")
        d["scale"] = [np.asarray(s) for s in d["scale"]]
        return d
    d = white_scale(spec, views if views is not None else load_views(spec))
    write_json(
        path, {k: [np.asarray(x).tolist() for x in v] if isinstance(v, list) else v for k, v in d.items()}
    )
    d["scale"] = [np.asarray(s) for s in d["scale"]]
    return d


def correction_problem_of(spec: CaptureSpec, cameras: list[int]):
    """``zonotope.correct.CorrectionProblem`` of a subset of the capture's cameras (10 nm grid,
    400–700 nm narrowed to the curves' common range, training set rawtoaces 190): the cameras under
    the capture's light, the observer under its ``reference`` light (the same light without one)."""
    import zonotope
    from zonotope.correct import correction_problem

    curves = [spec.load_ssf(k) for k in cameras]
    light = spec.load_illuminant()
    reference = spec.load_reference()
    obs = zonotope.observer(spec.observer)
    lights = [light] if reference is None else [light, reference]
    common = zonotope.common_shape(*curves, obs, *lights, interval=10)
    shape = np.arange(max(common.start, 400.0), min(common.end, 700.0) + 5, 10.0)
    return correction_problem(
        curves,
        target=spec.observer,
        illuminant=light,
        shape=shape,
        training="rawtoaces 190",
        reference=reference,
    )


def capture_generators(spec: CaptureSpec) -> np.ndarray:
    """Every camera's generators under the capture's light, white → 1, stacked (n, 3 cameras): the
    joint object-colour solid that :func:`fused_view`'s rejection test measures against."""
    return np.asarray(correction_problem_of(spec, list(range(len(spec.cameras)))).Phi, float)


def noise_sigma(out: Path, scale: np.ndarray) -> float:
    """RMS training residual on the white → 1 scale, median over channels (for the report)."""
    s = read_json(out / "train" / "summary.json").get("residual_sigma_raw")
    if s is None:
        raise CaptureError(
            f"{out / 'train' / 'summary.json'}: not a splat train summary (no residual_sigma_raw)."
        )
    return float(np.median(np.asarray(s) / scale))


def choose_delta(
    problem,
    responses: np.ndarray,
    *,
    n: int = 200,
    percentile: float = 95.0,
    floor: float = 1e-3,
    seed: int = 0,
) -> dict:
    """The MMV noise tolerance δ: the ``percentile`` of the max-norm distances from a sample of the
    responses to the object-colour solid (at least ``floor``).

    Stacked cameras' rendered responses are rarely exactly consistent (sensor noise averaged over views,
    model error, SSF calibration); δ is the smallest tolerance that makes ``percentile`` % of them
    feasible. The rest (counted in ``beyond_delta``) go to zonotope's ``on_infeasible="nearest"``.

    Parameters
    ----------
    problem : zonotope.correct.CorrectionProblem
    responses : array_like of shape (..., k)
        White → 1 responses.

    Returns
    -------
    dict
        ``delta``, ``sampled``, ``outside`` (share off the solid), ``beyond_delta``, ``max_distance``.
    """
    from zonotope import distance_to_zonotope

    flat = np.asarray(responses, float).reshape(-1, problem.k)
    rng = np.random.default_rng(seed)
    pick = flat[rng.choice(len(flat), min(n, len(flat)), replace=False)]
    d = np.array([distance_to_zonotope(problem.Phi, np.zeros(problem.k), c)[0] for c in pick])
    delta = max(float(np.percentile(d, percentile)), floor) if d.size else floor
    return {
        "delta": delta,
        "sampled": len(pick),
        "outside": float(np.mean(d > FEASIBLE_DISTANCE)),
        "beyond_delta": float(np.mean(d > delta)),
        "max_distance": float(d.max()) if d.size else 0.0,
        "rule": f"{percentile:g}th percentile of the distances of {len(pick)} sampled responses to the "
        f"object-colour solid (max-norm, white = 1), at least {floor:g}",
    }


def delta_of(spec: CaptureSpec, out: Path, index: dict, scale: np.ndarray) -> dict:
    """δ of :func:`choose_delta` on responses pooled from every rendered view, cached in
    ``OUT/correct/delta.json`` (so resumed runs and scoring use the same δ)."""
    path = out / "correct" / "delta.json"
    if path.is_file():
        return read_json(path, what="noise tolerance")
    rng = np.random.default_rng(0)
    pool = []
    for info in index.values():
        img = np.maximum(read_tiff(out / "render" / info["dir"] / "render.tiff") / scale, 0).reshape(
            -1, scale.size
        )
        pool.append(img[rng.choice(len(img), min(len(img), 2000), replace=False)])
    tol = choose_delta(correction_problem_of(spec, list(range(len(spec.cameras)))), np.concatenate(pool))
    write_json(path, tol)
    return tol


def levelled_white(spec: CaptureSpec, out: Path, index: dict, raws: dict, white: dict) -> dict:
    """``white`` (:func:`white_of`) with each camera's scale times its level relative to the others
    (:func:`splat.fusion.camera_levels`, the patch's camera fixed; one per channel for cameras whose
    curves are not ``ssf_exact``, one for all channels otherwise), measured where a view's own
    unclipped, smooth, untextured channels meet another camera's reprojected photographs — for a pair
    with such a camera, on every unclipped pixel where too few are smooth; cached in
    ``OUT/correct/levels.json``. Without reprojected photographs it is ``white`` unchanged.

    Why: the cameras without the patch inherit its white through their brightest neutral surfaces and
    their curves' white; on the path-traced capture the first left the Sigma 3.7 % below and the Nikon
    1.4 % above the Canon, and with three cameras the correction took the mismatch for colour
    (docs/benchmarks.md); published curves of another unit put a camera's channels 5–25 % apart
    (docs/notes/2026-12-01-published-curves.md)."""
    from .._tol import CAMERA_LEVEL_MIN_PIXELS
    from ..fusion import OWN_NOISE_FLOOR, camera_levels, measured, sensor_noise, smooth, textured, unclipped

    path = out / "correct" / "levels.json"
    if path.is_file():
        doc = read_json(path, what="camera levels")
    else:
        n = len(spec.cameras)
        scale = np.concatenate(white["scale"])
        uncertain = [k for k, c in enumerate(spec.cameras) if not c.ssf_exact]  # published or estimated
        pairs = []
        for name, info in index.items():
            v = raws.get(name)
            d = out / "render" / info["dir"]
            if v is None or v.exif is None or not (d / "reprojected_count.tiff").is_file():
                continue
            k = v.camera
            ws = scale[3 * k : 3 * k + 3]
            img = read_tiff(d / "render.tiff") / scale
            values, count = reprojected_of(d, scale)
            noise = np.maximum(sensor_noise(v, ws), OWN_NOISE_FLOOR)
            whole = unclipped(v)
            ok = whole & smooth(img) & ~textured(v, ws, noise=noise)
            own = measured(v, ws)
            for c in range(n):
                sel = ok & (count[..., c] > 0)
                if np.count_nonzero(sel) < CAMERA_LEVEL_MIN_PIXELS and (k in uncertain or c in uncertain):
                    # textured pixels too: their sums agree within 1–3 % per channel (exact curves, the
                    # fine-textured CI capture), where an uncertain white is 5–25 % off
                    sel = whole & (count[..., c] > 0)
                if c != k and sel.any():
                    pairs.append((k, c, own[sel], values[..., 3 * c : 3 * c + 3][sel]))
        problem = correction_problem_of(spec, list(range(n)))
        got = camera_levels(
            pairs, problem.training @ problem.Phi, n, fixed=spec.white_camera, per_channel=uncertain
        )
        doc = {
            "level": [[round(float(x), 4) for x in row] for row in got["level"]],
            "ratios": got["ratios"],
            "per_channel": uncertain,
            "rule": "camera c's reprojected photographs against its responses predicted from camera k's own "
            "measured channels (least-squares map on the training reflectances), per view and channel: "
            "log-least-squares levels, per channel for the cameras without ssf_exact, the patch's camera "
            "at 1",
        }
        write_json(path, doc)
    level = np.asarray(doc["level"], float)  # (cameras, 3); (cameras,) in records of earlier versions
    return dict(
        white,
        scale=[np.asarray(s) * level[k] for k, s in enumerate(white["scale"])],
        levels_applied=level,
        levels_measured=sorted({int(k) for r in doc["ratios"] for k in r[:2]}),
    )


def curves_white(spec: CaptureSpec, white: dict) -> list[str]:
    """The folders of the cameras whose white rests on their curves' white alone: curves not
    ``ssf_exact`` (published or estimated), not the camera of the white patch, and no level measured
    against another camera (:func:`levelled_white`'s ``levels_measured``: no plain surface that it and
    another camera both saw). Why: two measurements of one model give a camera's channels 5–25 % apart
    (docs/notes/2026-12-01-published-curves.md), which such a camera's colours then carry; the report
    says so."""
    measured = set(white.get("levels_measured", ())) | {spec.white_camera}
    return [c.folder for k, c in enumerate(spec.cameras) if not c.ssf_exact and k not in measured]


def fusion_of(spec: CaptureSpec, out: Path, index: dict, raws: dict, scale: np.ndarray) -> dict:
    """The noise levels of the fused correction (:mod:`splat.fusion`), in ``OUT/correct/fusion.json``.

    Cached, so that resumed runs and scoring use the same; white → 1 units:

    - ``render_sigma``: the render's error after anchoring (:func:`splat.fusion.render_noise` over every
      rendered view that has a RAW file);
    - ``reprojected_sigma``: per camera, the error of its photographs reprojected into another of its
      views (``render/<view>/reprojected.tiff``) against that view's measured sites (the mosaic itself,
      not demosaiced) where the view's render is smooth (:func:`splat.fusion.smooth`), each site's own
      noise removed (:func:`splat.fusion.reprojection_noise` with :func:`splat.fusion.site_noise`),
      pooled over the camera's rendered views; at least :data:`splat.fusion.OWN_NOISE_FLOOR`; a camera
      without such a view gets the largest of the others; ``reprojected_sites``: how many residuals
      each estimate rests on (1 300–3 400 per camera on the CI coarse captures);
    - per view with a RAW file, ``own_sigma``: its sensor noise per channel
      (:func:`splat.fusion.sensor_noise`, at least :data:`splat.fusion.OWN_NOISE_FLOOR`).

    Each to two significant digits (:func:`_two_digits`). The returned dict also holds ``generators``
    (:func:`capture_generators`, not cached: they follow from the capture file), the joint solid of
    :func:`fused_view`'s rejection test.

    Empty ``views`` when no rendered view has a RAW file.
    """
    from ..fusion import (
        OWN_NOISE_FLOOR,
        measured,
        render_noise,
        reprojection_noise,
        sensor_noise,
        site_noise,
        sites,
        smooth,
    )

    path = out / "correct" / "fusion.json"
    if path.is_file():
        return dict(read_json(path, what="fusion record"), generators=capture_generators(spec))
    n = len(spec.cameras)
    pairs, views, resid = [], {}, {}
    for name, info in index.items():
        v = raws.get(name)
        if v is None or v.exif is None:
            continue
        k = v.camera
        ws = scale[3 * k : 3 * k + 3]
        d = out / "render" / info["dir"]
        img = read_tiff(d / "render.tiff") / scale
        m = measured(v, ws)
        pairs.append((img[..., 3 * k : 3 * k + 3], m))
        own = np.maximum(sensor_noise(v, ws), OWN_NOISE_FLOOR)
        views[name] = {"camera": k, "own_sigma": [_two_digits(x) for x in own]}
        if (d / "reprojected_count.tiff").is_file():
            seen = read_tiff(d / "reprojected_count.tiff")[..., k] > 0
            rep = read_tiff(d / "reprojected.tiff")[..., 3 * k : 3 * k + 3] / ws
            # at the measured sites themselves (no demosaicing), where the render is smooth
            mosaic, at = sites(v, ws)
            at &= (seen & smooth(img))[..., None]
            resid.setdefault(k, []).append(((rep - mosaic)[at], site_noise(v, ws)[at]))
    rep_sigma = {
        k: _two_digits(
            max(
                reprojection_noise(np.concatenate([a for a, _ in r]), np.concatenate([b for _, b in r])),
                OWN_NOISE_FLOOR,
            )
        )
        for k, r in resid.items()
    }
    worst = max(rep_sigma.values(), default=None)
    doc = {
        "render_sigma": _two_digits(render_noise(pairs)) if pairs else None,
        "reprojected_sigma": [rep_sigma.get(k, worst) for k in range(n)] if rep_sigma else None,
        "reprojected_sites": [int(sum(a.size for a, _ in resid.get(k, []))) for k in range(n)],
        "own_noise_floor": OWN_NOISE_FLOOR,
        "channels": 3 * n,
        "views": views,
        "rule": "own channels: the RAW file's sensor noise (at least own_noise_floor); reprojected "
        "photographs: their error against the measured sites of each camera's own views where the "
        "render is smooth, less the sites' own noise; rendered channels: the render's "
        "leave-one-channel-out error after anchoring, pooled over views and cameras",
    }
    write_json(path, doc)
    return dict(doc, generators=capture_generators(spec))


def _two_digits(x: float) -> float:
    """``x`` to two significant digits: the noise estimates are no better, and views whose noise agrees
    to that share one fitted estimator (each fit costs seconds)."""
    return float(f"{float(x):.2g}")


def fused_view(
    fusion: dict,
    name: str,
    render: np.ndarray,
    view: RawView,
    scale: np.ndarray,
    cameras,
    reprojected=None,
    *,
    texture_rtol: float | None = None,
):
    """Fused responses of a view with a RAW file, restricted to ``cameras`` (which must include the
    view's own), and their per-channel noise.

    The own channels are measured (where the camera's other photographs see the pixel, the
    inverse-variance mean of the measurement and their reprojection: noise is averaged, a noise-free
    photograph keeps most of its weight; where their reprojection is farther from the measurement than
    :data:`splat._tol.JOINT_NSIGMA` times the sum of the two σ plus :data:`splat._tol.OWN_AGREE_RTOL`
    of the measurement in any channel, it is misplaced and the
    measurement stays alone: on the benchmark capture a 4-pixel black patch read its neighbour, 1.56 →
    18.96 ΔE00, once the render step lifted half-transparent pixels); another camera's channels are its
    photographs reprojected into the view where any sees the pixel (``reprojected``: values (H, W, 3n)
    white → 1 and counts (H, W, n), all cameras, as the render step writes them), else the render
    anchored to the photograph. Every camera's reprojection (the view's own camera's too) is first
    re-read by :func:`splat.fusion.guided`, guided by the view's photograph. Its σ stays the
    unfiltered reprojection's (``fusion_of``): an upper bound, as the filter averages noise.

    Where the photograph is **textured** (:func:`splat.fusion.textured`, with the view's ``own_sigma``
    as the noise) none of that holds: a reprojection misplaced by a fraction of a pixel, or a channel
    demosaiced across a 1–2 px border, is off by the step itself, not by its σ. There the responses
    are the render anchored to the pixel's own measured site (:func:`splat.fusion.anchor` with the
    mosaic's sites: no demosaicing, no reprojection), σ the sensor's for the measured channel(s) and
    the render's for all others. On the benchmark capture this took the all-pixel ΔE00 of three
    cameras from 8.08 to 3.90 (README).

    Where ``fusion`` holds the capture's ``generators`` (:func:`fusion_of` adds them), another camera's
    reprojection is **rejected** where no surface can give it together with the view's own channels
    (:func:`splat.fusion.impossible`, beyond :data:`splat._tol.JOINT_NSIGMA` σ): a reprojection
    misplaced onto a neighbouring surface. There the camera's channels are the render anchored to the
    photograph, as where no photograph sees the pixel. On the benchmark capture this took the Canon's
    chart patches from 0.41 to 0.31 ΔE00.

    Parameters
    ----------
    texture_rtol : float, optional
        :func:`splat.fusion.textured`'s threshold (default :data:`splat._tol.TEXTURE_RTOL`);
        ``float("inf")`` turns the texture test off.

    Returns
    -------
    fused : ndarray of shape (H, W, 3·len(cameras))
    code : ndarray of shape (H, W), int
        Below ``2**m`` (``m = len(cameras)``): bit ``i`` set where ``cameras[i]``'s reprojected
        photographs enter (for the view's own camera: are averaged with its measurement). A textured
        pixel has bit ``m`` set and, from bit ``m + 1``, which of the own camera's three channels its
        site measured. A pixel whose own photograph is clipped (not :func:`splat.fusion.unclipped`) has
        bit ``m + 4`` set: its own channels are the camera's other photographs reprojected (bit of the
        own camera set; σ theirs) or the render (σ the render's), never the clipped measurement.
        Bit ``m + 5 + i`` is set where ``cameras[i]``'s reprojection was rejected (bit ``i``
        cleared, σ as where none was; :func:`splat.fusion.rejected_bit`); for the view's own camera,
        where its other photographs disagreed with the measurement.
    sigma : dict
        ``code`` → σ per channel (3·len(cameras),).
    """
    from .._tol import JOINT_NSIGMA
    from ..fusion import (
        TEXTURE_RTOL,
        anchor,
        guided,
        guided_demosaic,
        impossible,
        measured,
        own_agrees,
        rejected_bit,
        sites,
        textured,
        unclipped,
    )

    k = view.camera
    cameras = list(cameras)
    m = len(cameras)
    if k not in cameras:
        raise SplatError(f"{name}: its camera is not among the cameras {cameras} to fuse.")
    idx = [3 * c + j for c in cameras for j in range(3)]
    pos = 3 * cameras.index(k)
    own = slice(pos, pos + 3)
    # the pixel's demosaiced photograph is a measurement: no saturated or dead site within its reach
    valid = unclipped(view)
    ws = scale[3 * k : 3 * k + 3]
    photo = measured(view, ws)
    rep_sigma = fusion.get("reprojected_sigma")
    use = reprojected is not None and rep_sigma is not None
    own_photo = photo
    if use:
        raw_values, count = reprojected
        raw_values = np.asarray(raw_values, float)

        seen_by = {c: count[..., c] > 0 for c in cameras if (count[..., c] > 0).any()}

        def reread(c, guide):  # camera c's reprojection re-read where the view's photograph puts it
            return guided(raw_values[..., 3 * c : 3 * c + 3], seen_by[c], guide)

        others = [c for c in seen_by if c != k]
        if others and not view.full_colour:  # the own mosaic demosaiced with the other cameras' help
            seen = np.stack([seen_by[c] for c in others])
            trip = np.stack([reread(c, photo) for c in others])
            n_seen = seen.sum(0)[..., None]
            mean = np.where(n_seen > 0, (trip * seen[..., None]).sum(0) / np.maximum(n_seen, 1), photo)
            own_photo = guided_demosaic(view, ws, np.concatenate([mean, photo], -1))
        values = raw_values.copy()  # re-read with the sharpest photograph of the view as the guide
        for c in seen_by:
            values[..., 3 * c : 3 * c + 3] = reread(c, own_photo)
    fused = anchor(render[..., idx], own_photo, own, valid)
    generators = fusion.get("generators")
    anchored = fused.copy() if use and generators is not None else None
    code = np.zeros(fused.shape[:2], int)
    if use:
        m_own = fused[..., own].copy()
        s_own = np.asarray(fusion["views"][name]["own_sigma"], float)
        s_rep = float(rep_sigma[k])
        for i, c in enumerate(cameras):
            seen = count[..., c] > 0
            if c == k:  # inverse-variance mean of the measurement and the camera's other photographs
                rep_own = np.maximum(values[..., 3 * c : 3 * c + 3], 0)
                # …where they agree with it: farther than the two σ allow is a misplaced reprojection
                far = seen & valid & ~own_agrees(m_own, rep_own, s_own, s_rep)
                seen = seen & ~far
                wm, wr = 1 / s_own**2, 1 / s_rep**2
                comb = (wm * m_own + wr * rep_own) / (wm + wr)
                fused[..., own] = np.where(seen[..., None] & valid[..., None], comb, m_own)
                # clipped: the camera's other photographs alone where they see the pixel, else the render
                fused[..., own] = np.where((seen & ~valid)[..., None], rep_own, fused[..., own])
                code |= seen.astype(int) << i
                code = np.where(far, code | rejected_bit(m, i), code)
                continue
            fused[..., 3 * i : 3 * i + 3] = np.where(
                seen[..., None], np.maximum(values[..., 3 * c : 3 * c + 3], 0), fused[..., 3 * i : 3 * i + 3]
            )
            code |= seen.astype(int) << i
    rtol = TEXTURE_RTOL if texture_rtol is None else texture_rtol
    so = np.asarray(fusion["views"][name]["own_sigma"], float)
    tex = textured(view, ws, rtol=rtol, noise=so) & valid if np.isfinite(rtol) else np.zeros_like(valid)
    if anchored is not None:  # reprojections that no surface gives together with the own channels
        G = np.asarray(generators, float)
        for i, c in enumerate(cameras):
            at = (code >> i & 1).astype(bool) & valid & ~tex  # textured pixels: anchored to their site
            if c == k or not at.any():
                continue
            tol = JOINT_NSIGMA * (float(so.sum()) + 3 * float(rep_sigma[c]))
            cols = [3 * k, 3 * k + 1, 3 * k + 2, 3 * c, 3 * c + 1, 3 * c + 2]
            bad = np.zeros_like(at)
            bad[at] = impossible(G[:, cols], fused[..., own][at], fused[at][:, 3 * i : 3 * i + 3], tol)
            fused[bad, 3 * i : 3 * i + 3] = anchored[bad, 3 * i : 3 * i + 3]
            code = np.where(bad, (code & ~(1 << i)) | rejected_bit(m, i), code)
        del anchored
    if tex.any():  # the render anchored to the pixel's own site(s): no demosaicing, no reprojection
        mosaic, at = sites(view, ws)
        fused[tex] = anchor(render[..., idx], mosaic, own, at)[tex]
        bits = (at * (1 << np.arange(3))).sum(-1)
        code = np.where(tex, (1 << m) | (bits << (m + 1)), code)
    clipped = 1 << (m + 4)  # the own photograph clipped: its channels reprojected or rendered
    code = np.where(valid, code, code | clipped)
    rej = sum(rejected_bit(m, i) for i in range(m))  # rejected reprojections: σ as where none was
    base = code & ~rej
    sigma = _sigma_by_code(fusion, base[base < 1 << m], cameras)
    for cd, s_ in sigma.items():  # the own channels: measured, or averaged with their reprojection
        s_[own] = 1 / np.sqrt(1 / so**2 + 1 / float(rep_sigma[k]) ** 2) if cd >> (pos // 3) & 1 else so
    for cd in np.unique(code[code & rej != 0]):
        sigma[int(cd)] = sigma[int(cd) & ~rej].copy()
    for cd in np.unique(base[base >= clipped]):
        s_ = _sigma_by_code(fusion, np.array([cd & ((1 << m) - 1)]), cameras)[cd & ((1 << m) - 1)]
        sigma[int(cd)] = s_
    for cd in np.unique(
        code[(code >= 1 << m) & (code < clipped)]
    ):  # textured: the site's channel(s) measured, the rest rendered
        s_ = np.full(3 * m, float(fusion["render_sigma"]))
        s_[own] = np.where((cd >> (m + 1)) >> np.arange(3) & 1, so, s_[own])
        sigma[int(cd)] = s_
    present = {int(c) for c in np.unique(code)}  # a base pattern only a rejection led to is not one
    return fused, code, {c: s_ for c, s_ in sigma.items() if c in present}


def _sigma_by_code(fusion: dict, code: np.ndarray, cameras: list) -> dict:
    """σ per channel of ``cameras`` for each pattern in ``code``: a camera's ``reprojected_sigma`` where
    its bit is set, ``render_sigma`` elsewhere."""
    sigma = {}
    for cd in np.unique(code):
        s_ = np.full(3 * len(cameras), fusion["render_sigma"], float)
        for i, c in enumerate(cameras):
            if cd >> i & 1:
                s_[3 * i : 3 * i + 3] = fusion["reprojected_sigma"][c]
        sigma[int(cd)] = s_
    return sigma


def photographed_view(
    fusion: dict, render: np.ndarray, reprojected, cameras, *, texture_rtol: float | None = None
):
    """Responses of a view from the photographs alone, for a view without a RAW file (a novel view):
    each camera's channels are its photographs reprojected into the view where any sees the pixel
    (re-read by :func:`splat.fusion.guided`, guided by the mean of the cameras' channel triples); where
    none of a camera's does, its rendered channels anchored (Brovey, :func:`splat.fusion.anchor`'s rule)
    to the sum of the channels that were reprojected there, or the render itself where no photograph
    sees the pixel. Where that picture of the view is **textured** — not :func:`splat.fusion.smooth`
    over the 3 × 3 neighbourhood at ``texture_rtol`` (default :data:`splat._tol.TEXTURE_RTOL`;
    ``float("inf")`` turns the test off), before the re-reading — the render itself, as if no
    photograph saw the pixel: at a 1–2 px border the reprojections are off by the step (as in
    :func:`fused_view`), and with no photograph of the view there is no site to anchor to. Three
    cameras, Prior, held-out views as novel views, all | flat pixels ΔE00 without → with the test:
    benchmark capture (every 4th pixel) 8.68 | 0.726 → 5.83 | 0.594; CI coarse capture (1000 steps,
    every 2nd) 4.90 | 0.449 → 4.03 | 0.425; CI fine 11.98 | 1.365 → 10.44 | 1.423. The 5 × 5 window of
    :func:`fused_view`'s test flagged more flat pixels here (the reprojections blur a cell's border into
    its neighbours): 5.44 | 0.707, 4.41 | 0.472, 10.70 | 1.838.

    Parameters
    ----------
    fusion : dict
        :func:`fusion_of`.
    render : ndarray of shape (H, W, 3n)
        The view's render, white → 1.
    reprojected : tuple
        Values (H, W, 3n) white → 1 and counts (H, W, n), as the render step writes them.
    cameras : sequence of int

    Returns
    -------
    fused, code, sigma
        As :func:`fused_view`; bit ``i`` of ``code`` set where ``cameras[i]``'s photographs enter; σ is
        the camera's ``reprojected_sigma`` there, ``render_sigma`` elsewhere.
    """
    from ..fusion import ANCHOR_EPS, TEXTURE_RTOL, guided, smooth

    cameras = list(cameras)
    values, count = reprojected
    idx = [3 * c + j for c in cameras for j in range(3)]
    render = np.maximum(np.asarray(render, np.float64)[..., idx], 0)
    values = np.maximum(np.asarray(values, np.float64)[..., idx], 0)
    seen = np.stack([count[..., c] > 0 for c in cameras], -1)  # (H, W, m)
    code = (seen.astype(int) << np.arange(len(cameras))).sum(-1)
    chan = np.repeat(seen, 3, -1)

    def assemble(values):  # Brovey per pixel over the channels reprojected there; 1 where none was
        num = np.where(chan, values, 0).sum(-1) + ANCHOR_EPS
        den = np.where(chan, render, 0).sum(-1) + ANCHOR_EPS
        ratio = np.divide(num, den, out=np.ones_like(num), where=chan.any(-1) & (den > 0))
        return np.where(chan, values, render * ratio[..., None])

    # No photograph of the view itself to guide splat.fusion.guided: the guide is the mean of the
    # cameras' channel triples (a picture of the view from all photographs, its noise averaged)
    guide = assemble(values).reshape(*values.shape[:2], len(cameras), 3).mean(-2)
    for i in range(len(cameras)):
        if seen[..., i].any():
            values[..., 3 * i : 3 * i + 3] = guided(values[..., 3 * i : 3 * i + 3], seen[..., i], guide)
    fused = assemble(values)
    rtol = TEXTURE_RTOL if texture_rtol is None else texture_rtol
    if np.isfinite(rtol):  # textured: the render, no photograph
        tex = ~smooth(guide, rtol=rtol, size=3)
        fused[tex] = render[tex]
        code = np.where(tex, 0, code)
    return fused, code, _sigma_by_code(fusion, code, cameras)


def fused_fitter(spec: CaptureSpec, cameras: list[int], method: str):
    """``fit(σ) → (corrector, scale)`` for :func:`correct_fused`: :func:`fit_fused_corrector` with
    :func:`pipeline_mix`, once per distinct noise pattern (cached)."""
    mix = pipeline_mix(method)
    cache: dict = {}
    # the unwhitened problem, built once when first needed (0.04–0.15 s each, ~50 noise patterns a run)
    problem = functools.cache(lambda: correction_problem_of(spec, list(cameras)))
    band = functools.cache(lambda: ssf_sigma(spec, list(cameras)))

    def fit(sigma):
        key = tuple(np.round(sigma, 6))
        if key not in cache:
            cache[key] = fit_fused_corrector(
                spec, list(cameras), method, sigma, mix=mix, problem=problem(), band=band()
            )
        return cache[key]

    return fit


def _write_corrected(o: Path, stem: str, XYZ: np.ndarray, white_XYZ) -> None:
    """``<stem>_XYZ.tiff`` (float32), ``<stem>_sRGB.tiff`` (16-bit) and ``<stem>_sRGB.png`` of a view."""
    from isp import write_image

    write_tiff(o / f"{stem}_XYZ.tiff", XYZ)
    rgb = XYZ_to_sRGB(XYZ, white_XYZ)
    write_image(o / f"{stem}_sRGB.tiff", rgb, overwrite=True)
    write_png8(o / f"{stem}_sRGB.png", rgb)


def fused_uncertainty(
    problem, XYZ: np.ndarray, code: np.ndarray, sigma: dict, band=None, *, prior=None, rendered=None
) -> np.ndarray:
    """Per pixel, the 95 % credible radius in ΔE00 of a fused correction's colour
    (:func:`zonotope.correct.posterior_radius`): the natural-reflectance prior seen through the cameras
    with each pixel's noise pattern (``sigma[code]``, and estimated curves' ``band`` in quadrature, as
    the fit is told). It says where the answer is sure (several cameras saw the pixel) and where it is
    not (one camera's site on a textured pixel, or the render alone), on a capture without a reference.

    ``rendered``: ``(render_sigma, local)``, the fusion's render σ and, per pixel (H, W), the render's
    local error there (:func:`splat.fusion.render_error` times the pixel's level). The channels that
    are the render (σ equal to ``render_sigma``) are then given the larger of the two, in half-octave
    steps: the fit keeps the one σ (told the local one, its all-pixel ΔE00 on the benchmark capture went
    from 3.97 to 4.67), the map says how far the render may be off at this pixel.

    ``prior``: the problem's :class:`zonotope.correct.ReflectancePrior`, when the caller keeps it over
    many views (default: fitted here).

    Returns
    -------
    ndarray of shape code.shape, float32
    """
    from zonotope.correct import ReflectancePrior, posterior_radius

    if prior is None:
        prior = ReflectancePrior.fit(problem.training)
    level = np.zeros(code.shape, int)
    rs = None
    if rendered is not None:
        rs, local = float(rendered[0]), np.asarray(rendered[1], float)
        if rs > 0:  # half-octave steps above the render σ, at most 2¹⁰ times it
            ratio = np.maximum(np.nan_to_num(local / rs, nan=1.0, posinf=1.0), 1.0)
            level = np.minimum(np.rint(2 * np.log2(ratio)).astype(int), 20)
    out = np.full(code.shape, np.nan, np.float32)
    for cd, s_ in sigma.items():
        at = code == cd
        for q in np.unique(level[at]) if at.any() else ():
            sel = at & (level == q)
            s_q = np.asarray(s_, float).copy()
            if q > 0:
                s_q[s_q == rs] = rs * 2.0 ** (q / 2)
            s_q = s_q if band is None else np.hypot(s_q, band)
            out[sel] = posterior_radius(problem, XYZ[sel], s_q, prior=prior)
    return out


def _write_uncertainty(o: Path, stem: str, radius: np.ndarray) -> dict:
    """``<stem>_uncertainty.tiff`` (float32 ΔE00) and a viridis ``.png`` (dark purple 0, yellow ≥
    :data:`splat._tol.UNCERTAINTY_PNG_MAX` ΔE00: one scale for every view); returns its summary."""
    from matplotlib import colormaps

    from .._tol import UNCERTAINTY_PNG_MAX

    write_tiff(o / f"{stem}_uncertainty.tiff", radius)
    level = np.clip(np.nan_to_num(radius, nan=UNCERTAINTY_PNG_MAX) / UNCERTAINTY_PNG_MAX, 0, 1)
    rgb = colormaps["viridis"](level)
    write_png8(o / f"{stem}_uncertainty.png", rgb[..., :3])
    r = radius[np.isfinite(radius)]
    return {
        "median": round(float(np.median(r)), 3),
        "p90": round(float(np.percentile(r, 90)), 3),
        "within_2": round(float(np.mean(r <= 2.0)), 4),
    }


def reprojected_of(d: Path, scale: np.ndarray):
    """A rendered view's reprojected photographs (white → 1) and counts, or None (not written)."""
    if not (d / "reprojected_count.tiff").is_file():
        return None
    return read_tiff(d / "reprojected.tiff") / scale, read_tiff(d / "reprojected_count.tiff")


def correct_fused(fused, code, sigma: dict, fit, quantum: float) -> np.ndarray:
    """Correct fused responses pixel group by pixel group (one noise pattern each): ``fit(σ)`` gives
    ``(corrector, scale)`` (:func:`fused_fitter`); returns XYZ (..., 3)."""
    from zonotope.correct.image import correct_image

    out = np.zeros((*fused.shape[:-1], 3))
    for cd, s_ in sigma.items():
        sel = code == cd
        if sel.any():
            cor, w = fit(s_)
            # whitened units: no channel is quantised more coarsely than ``quantum``
            out[sel] = correct_image((fused[sel] * w)[:, None], cor, quantum=quantum)[:, 0]
    return out


def fit_corrector(
    spec: CaptureSpec,
    cameras: list[int],
    method: str,
    delta: float,
    *,
    mix=None,
):
    """A fitted estimator with the noise tolerance δ, i.e. responses of noise σ = δ / ``DELTA_SIGMAS``,
    passed as :func:`zonotope.correct.noise_options` says (Prior and the regressions get ``noise=σ``,
    Centroid ``delta=δ``). Cameras with estimated curves add their :func:`ssf_sigma` to σ in
    quadrature. ``mix``: Prior's λ (:func:`pipeline_mix` for rendered responses); None: Prior chooses
    it by cross-validation."""
    from zonotope.correct import DELTA_SIGMAS

    sigma = delta / DELTA_SIGMAS
    band = ssf_sigma(spec, cameras)
    if band.any():
        sigma = np.hypot(sigma, band)
    return _fit_on(correction_problem_of(spec, cameras), method, sigma, mix=mix)


def fit_fused_corrector(
    spec: CaptureSpec, cameras: list[int], method: str, noise, *, mix=None, problem=None, band=None
):
    """An estimator for fused responses with per-channel noise ``noise`` (σ per channel of ``cameras``):
    fitted by :func:`fit_corrector`'s rule on the channel-whitened problem
    (:func:`splat.fusion.whitened`, δ = ``DELTA_SIGMAS`` · σ_ref); returns it and the scale to apply to
    responses.
    ``mix``: Prior's atypical-branch weight (:func:`pipeline_mix`); without it Prior chooses it by its own
    cross-validation for every noise pattern (~3–5 s each). ``problem``: the cameras'
    :func:`correction_problem_of`, when the caller already has it; ``band``: their :func:`ssf_sigma`,
    likewise."""
    from ..fusion import whitened

    if problem is None:
        problem = correction_problem_of(spec, cameras)
    if band is None:
        band = ssf_sigma(spec, cameras)
    if band.any():  # estimated curves: their response error joins the sensor noise
        noise = np.hypot(noise, band)
    problem, scale, ref = whitened(problem, noise)
    return _fit_on(problem, method, ref, mix=mix), scale


def pipeline_mix(method: str):
    """Prior's atypical-branch weight λ for the pipeline's responses, fused or rendered: 1, the MAP
    estimate alone (None for other methods); Prior's own cross-validation is left to single photographs
    (the scorer's ``raw-`` baselines).

    Why: the measured channels' small σ makes the fused MMV thin (δ_k ∝ σ_k), so its centroid adds
    little to the MAP and cost three quarters of the time: on the CI coarse captures (1000 steps, three
    cameras, flat held-out pixels) λ chosen by cross-validation gave 0.500 ΔE00 noise-free and 1.399
    noisy, λ = 1 0.497 and 1.392, and a noisy view took 31 s against 7.9 s. The render corrected alone
    is no better with the centroid either (its error is the model's): three cameras, held-out views,
    cross-validated λ against λ = 1, chart / uniform / flat / all pixels 6.04 / 7.74 / 7.96 / 16.42
    against 5.22 / 7.72 / 7.85 / 16.39 on the ray-traced capture, all pixels 5.00 against 4.96 on the
    path-traced one, and one 512 × 384 view of the 12 MP benchmark capture 9.38 against 9.36 ΔE00; 96
    rows of that view took 85.0 s against 1.2 s (docs/notes/2026-11-29-render-mix.md)."""
    from zonotope.correct import CORRECTION_METHODS

    if CORRECTION_METHODS.resolve(method, argument="method") != "Prior":
        return None
    return 1.0


def ssf_sigma(spec: CaptureSpec, cameras: list[int]) -> np.ndarray:
    """σ per channel (3 per camera, white → 1) of the response error that the cameras' curves carry:
    estimated curves their band (:meth:`zonotope.SSFEstimate.response_sigma` under the capture's
    light); measured curves, in a fit of two or more cameras, the spread between units of one model
    (:func:`zonotope.unit_sigma`), unless the camera says ``ssf_exact = true``; else 0.

    Why: a fit on several cameras' curves that is told only the sensor noise amplifies the curves'
    errors — estimated curves, three cameras: +4.1 ΔE00 noise-free, +0.6 with their σ
    (docs/notes/2026-11-29-ssf-stacking.md); published curves of another unit: +6.0, +0.8 with the
    units' σ (docs/notes/2026-12-01-published-curves.md) — so the correct step adds it to the noise
    in quadrature."""
    from zonotope.ssf_band import curves_sigma

    exact = [i for i, k in enumerate(cameras) if spec.cameras[k].ssf_exact]
    return curves_sigma([spec.ssf_estimate(k) for k in cameras], spec.load_illuminant(), exact=exact)


#: What an estimate's sources are called in ``correct/summary.json`` and the report.
_SOURCE_WORDS = {"dng": "DNG colour matrices", "chart": "chart photographs"}


def ssf_record(spec: CaptureSpec, cameras: list[int]) -> dict:
    """Per camera (its folder), where its sensitivities came from and the σ told to the fit for them
    (:func:`ssf_sigma`): ``{"measured": name or file, "exact": ssf_exact, "sigma"}`` or
    ``{"estimated": what from (the DNG colour matrices, chart photographs), "file", "sigma",
    "calibration"}``, ``file`` the DNG (``ssf = "estimate"``) or the estimate's own file.
    Why: the report must say when the colours rest on estimated curves, and how well they are known."""
    sigma = ssf_sigma(spec, cameras).reshape(-1, 3)
    out = {}
    for k, sig in zip(cameras, sigma, strict=True):
        cam, est = spec.cameras[k], spec.ssf_estimate(k)
        told = [round(float(v), 6) for v in sig]
        if est is None:
            out[cam.folder] = {"measured": cam.ssf, "exact": cam.ssf_exact, "sigma": told}
            continue
        from_dng = cam.ssf == "estimate"
        out[cam.folder] = {
            "estimated": " + ".join(_SOURCE_WORDS.get(s, s) for s in (("dng",) if from_dng else est.sources))
            or "an estimate file",
            "file": (spec.first_dng(k) if from_dng else Path(cam.ssf)).name,
            "sigma": told,
            "calibration": est.calibration,
        }
    return out


def _fit_on(problem, method: str, sigma, *, mix=None):
    """``method`` fitted on ``problem`` with responses of noise ``sigma`` (one σ or one per channel), told
    to it as its registry entry says (:func:`zonotope.correct.noise_options`), with
    ``white_point=`` :data:`WHITE_POINT`; ``mix``: Prior's λ (None: its cross-validation)."""
    from zonotope.correct import CORRECTION_METHODS, fit_correction, noise_options

    name = CORRECTION_METHODS.resolve(method, argument="method")  # unknown names: a project error
    opts = noise_options(name, sigma)
    opts["white_point"] = WHITE_POINT
    if name == "Prior" and mix is not None:
        opts["mix"] = mix
    return fit_correction(problem, method=name, **opts)


def dng_matrix_XYZ(balanced: np.ndarray, profile, neutral, white_XYZ) -> np.ndarray:
    """A camera's DNG development: white-balanced responses (white → 1) → XYZ of the scene white
    ``white_XYZ`` (Y = 1): ColorMatrix → XYZ D50 (isp), Bradford back to the scene white."""
    import colour

    from isp.dng import D50_xy
    from isp.stages import matrix_XYZ_from_balanced

    M = matrix_XYZ_from_balanced(profile, neutral)
    cat = colour.adaptation.matrix_chromatic_adaptation_VonKries(
        colour.xy_to_XYZ(D50_xy), np.asarray(white_XYZ) / white_XYZ[1], transform="Bradford"
    )
    return balanced @ (cat @ M).T


def correct_step(
    capture: str | os.PathLike,
    out: str | os.PathLike,
    *,
    config: PipelineConfig = PipelineConfig(),
    progress: ProgressCallback | None = None,
) -> dict:
    """Colour-correct every rendered view with all cameras (``config.method``), and develop each
    camera's channels with its own DNG matrix; held-out RAW files are also developed by isp. A
    photograph's answer is its fused correction (working and full resolution); the render corrected
    alone is written for held-out and novel views only (scored there, or the only answer).

    Returns
    -------
    dict
        The summary written to ``correct/summary.json``: method, σ and δ, infeasible shares.
    """
    from zonotope.correct import CORRECTION_METHODS
    from zonotope.correct.image import correct_image

    from .._tol import JOINT_NSIGMA, UNCERTAINTY_PNG_MAX
    from ..fusion import measured, rejected_bit, render_error

    spec, ws = step_workspace(capture, out, config)
    out = ws.root
    index_path = out / "render" / "index.json"
    if not index_path.is_file():
        raise CaptureError(f"{out}: nothing rendered yet; run the render step first.")
    index = read_index(spec, index_path)
    t0 = time.perf_counter()
    reset_peak_rss()
    raws = {v.name: v for v in read_working(spec, ws, config)}  # decoded once per run
    # white, δ and the fusion noise levels are functions of these (δ pools the photographed views only,
    # so that novel views rendered later do not change it): a change recomputes every corrected image
    photographed = {k: v for k, v in index.items() if k in raws}
    ws.begin(
        "correct",
        {
            # the curves, lights, observer and white: the poses and the model do not depend on them
            "curves": curves_fingerprint(spec),
            "method": CORRECTION_METHODS.resolve(config.method, argument="method"),
            "quantum": config.quantum,
            "photographed": sorted(photographed),
            "noise": config.noise,
            "full_resolution": FULL_METHOD,
            "white_point": WHITE_POINT,
            "full_reprojection": config.full_reprojection,
        },
    )
    prep = iter(range(1, 9))  # the parts before the first photograph, each reported when done

    def prepared():
        if progress is not None:
            progress("correct: light, white, levels, noise, fits", next(prep), 8)

    if progress is not None:
        progress("correct: light, white, levels, noise, fits", 0, 8)
    spec, light = illuminant_of(spec, out, photographed or index, raws)  # "estimate": the light now
    prepared()
    white = white_of(spec, out, list(raws.values()))
    prepared()
    white = levelled_white(spec, out, photographed or index, raws, white)
    prepared()
    scale = np.concatenate(white["scale"])
    n = len(spec.cameras)
    tol = delta_of(spec, out, photographed or index, scale)
    prepared()
    corrector = fit_corrector(
        spec, list(range(n)), config.method, tol["delta"], mix=pipeline_mix(config.method)
    )
    prepared()
    problem = corrector.problem
    wXYZ = problem.white_XYZ
    mname = corrector.method.replace(" ", "")
    profiles = {}
    for v in raws.values():
        profiles.setdefault(v.camera, (v.profile, v.neutral))
    fusion = fusion_of(spec, out, index, raws, scale)
    prepared()
    noise_used = own_noise(fusion, raws, scale, config.noise)
    prepared()
    fusion = dict(
        fusion, views={m: dict(d, own_sigma=noise_used[m]["sigma"]) for m, d in fusion["views"].items()}
    )
    fit = fused_fitter(spec, list(range(n)), config.method)
    fit_full = fused_fitter(spec, list(range(n)), FULL_METHOD)
    full_model = full_reprojection(spec, out, raws, fusion, scale) if config.full_reprojection else None
    prepared()
    n_fused = {"views": 0, "novel": 0, "full_resolution": 0}
    full_info, rejected, uncertainty = {}, {}, {}
    band = ssf_sigma(spec, list(range(n)))
    band = band if band.any() else None
    from zonotope.correct import ReflectancePrior

    prior = ReflectancePrior.fit(problem.training)  # the uncertainty maps' prior, once for every view
    # one progress bar over the rows of every photograph still to correct at full resolution
    todo_rows = {
        m: raws[m].size[0]
        for m, info in index.items()
        if m in fusion["views"] and not (out / "correct" / info["dir"] / "full_XYZ.tiff").is_file()
    }
    rows_done = [0]

    def full_progress(what, done, total, _name=None):
        if progress is not None:
            progress("full resolution rows", rows_done[0] + done, sum(todo_rows.values()))

    for i, (name, info) in enumerate(index.items()):
        d = out / "render" / info["dir"]
        o = out / "correct" / info["dir"]
        img = read_tiff(d / "render.tiff") / scale
        # the render alone corrected: where it is scored (held-out views) or the view has no photograph
        # (novel); a photographed view's answer is its fused correction
        if info["kind"] != "view" and not (o / f"{mname}_XYZ.tiff").is_file():

            def colours(_what, done, total, name=name):  # one bar per view: its distinct responses solved
                if progress is not None:
                    progress(f"{name}: render corrected alone", done, total)

            XYZ = correct_image(np.maximum(img, 0), corrector, quantum=config.quantum, progress=colours)
            _write_corrected(o, mname, XYZ, wXYZ)
        for k in range(n):
            prof, neutral = profiles[k]
            f = o / f"dng_{spec.label(k)}_XYZ.tiff"
            if prof is None or f.is_file():
                continue
            X = dng_matrix_XYZ(np.maximum(img[..., 3 * k : 3 * k + 3], 0), prof, neutral, wXYZ)
            write_tiff(f, X)
            write_png8(o / f"dng_{spec.label(k)}_sRGB.png", XYZ_to_sRGB(X, wXYZ))
        r = raws.get(name)
        rep = reprojected_of(d, scale)
        novel = name not in fusion["views"] and rep is not None and fusion["reprojected_sigma"] is not None
        want_fused = (name in fusion["views"] or novel) and not (o / f"{mname}_fused_XYZ.tiff").is_file()
        want_full = name in fusion["views"] and not (o / "full_XYZ.tiff").is_file()
        if want_fused or want_full:
            if novel:  # no RAW file here: the photographs reprojected into the view, the render elsewhere
                fused, code, sigma = photographed_view(fusion, img, rep, list(range(n)))
            else:  # a photograph: its RAW file, the others reprojected into it, the render anchored to it
                fused, code, sigma = fused_view(fusion, name, img, r, scale, list(range(n)), rep)
                rejected[name] = {
                    spec.label(c): round(float(np.mean(code & rejected_bit(n, c) != 0)), 6)
                    for c in range(n)
                    if c != r.camera
                }
            if want_fused:
                XYZ = correct_fused(fused, code, sigma, fit, config.quantum)
                _write_corrected(o, f"{mname}_fused", XYZ, wXYZ)
                rendered = None
                if not novel:  # the render's local error, told by this photograph's own sites
                    own = img[..., 3 * r.camera : 3 * r.camera + 3]
                    local = render_error(r, scale[3 * r.camera : 3 * r.camera + 3], own)
                    rendered = (fusion["render_sigma"], local * np.maximum(fused, 0).mean(-1))
                radius = fused_uncertainty(problem, XYZ, code, sigma, band, prior=prior, rendered=rendered)
                uncertainty[name] = _write_uncertainty(o, f"{mname}_fused", radius)
            if want_full:  # at the photograph's own size, strip by strip (splat.strips)
                full_info[name] = _full_resolution(
                    spec,
                    o,
                    r,
                    fused,
                    code,
                    sigma,
                    white["scale"][r.camera],
                    noise_used[name],
                    fit_full,
                    wXYZ,
                    full_progress,
                    full_model,
                    workers=config.workers,
                )
                rows_done[0] += todo_rows.get(name, 0)
        if (o / f"{mname}_fused_XYZ.tiff").is_file():
            n_fused["views" if name in fusion["views"] else "novel"] += 1
        if (o / "full_XYZ.tiff").is_file():
            n_fused["full_resolution"] += 1
        if r is not None and r.profile is not None and not (o / "raw_dng_XYZ.tiff").is_file():
            bal = np.maximum(measured(r, white["scale"][r.camera]), 0)
            X = dng_matrix_XYZ(bal, r.profile, r.neutral, wXYZ)
            write_tiff(o / "raw_dng_XYZ.tiff", X)
            write_png8(o / "raw_dng_sRGB.png", XYZ_to_sRGB(X, wXYZ))
        release_free_memory()  # what this view's strips freed, before the next view's (bounded by a view)
        if progress is not None:
            progress("correct", i + 1, len(index))
    summary = {
        "method": corrector.method,
        "delta": tol["delta"],
        "noise": tol,
        "training_residual": noise_sigma(out, scale),
        "fusion": {
            "render_sigma": fusion["render_sigma"],
            "views": n_fused["views"],
            "novel": n_fused["novel"],
            "files": f"{mname}_fused_XYZ.tiff / _sRGB.tiff / .png next to {mname}_XYZ.tiff",
            "rejected": rejected,
            "rejected_rule": "share of each photograph's pixels where another camera's reprojected "
            "photographs were left out: no surface gives them together with the photograph's own channels "
            f"(beyond {JOINT_NSIGMA:g} σ of the two cameras' joint object-colour solid); the render "
            "anchored to the photograph instead (views fused in this run)",
        },
        "uncertainty": {
            "files": f"{mname}_fused_uncertainty.tiff (float32, ΔE00) / .png (dark purple 0, yellow ≥ "
            f"{UNCERTAINTY_PNG_MAX:g})",
            "rule": "per pixel of the fused correction (working size), the 95 % credible radius in ΔE00 "
            "of its colour under the natural-reflectance prior (rawtoaces 190, Gaussian, bounds ignored) "
            "seen through the cameras with that pixel's noise (zonotope.correct.posterior_radius): what "
            "the cameras cannot tell apart and what their noise hides; not the model's geometry errors "
            "beyond the noise the fusion declares",
            "per_view": uncertainty,
        },
        "full_resolution": {
            "views": n_fused["full_resolution"],
            "method": FULL_METHOD,
            "files": "full_XYZ.tiff (float32) / full_sRGB.png, each photograph at its RAW file's size",
            "how": "own channels: the RAW file demosaiced (Malvar 2004) strip by strip; other cameras' "
            "channels: where the photograph is binned for work, their photographs (the few that see most "
            "of it) reprojected at full resolution through the splat's depth rendered strip by strip; "
            "elsewhere (and where none sees a pixel, or the working pixel is textured) the "
            "working-resolution fused responses (the render where no photograph sees a pixel) upsampled "
            "bilinearly and sharpened by the photograph (Brovey ratio of its own channels at full to "
            f"working resolution); {FULL_METHOD} fitted per noise pattern on the channel-whitened problem",
            "per_view": full_info,
        },
        "own_noise": {
            m: {"sigma": d["sigma"], "sigma_full": d["sigma_full"], "source": d["source"]}
            for m, d in noise_used.items()
        },
        "working": working_summary(spec, list(raws.values())),
        "white": {
            "method": white["method"],
            "scale": [np.asarray(s).tolist() for s in white["scale"]],
            "from_curves": curves_white(spec, white),
            "levels": np.broadcast_to(np.asarray(white["levels_applied"], float).reshape(n, -1), (n, 3))
            .round(4)
            .tolist(),
        },
        "white_XYZ": np.asarray(wXYZ).tolist(),
        "illuminant": {
            "light": spec.illuminant,
            "reference": spec.reference or spec.illuminant,
            "estimate": light,
        },
        "ssf": ssf_record(spec, list(range(n))),
        "views": list(index),
        "duration_s": time.perf_counter() - t0,
        "peak_rss_mib": peak_rss_mib(),
    }
    write_json(out / "correct" / "summary.json", summary)
    return summary


def own_noise(fusion: dict, raws: dict, scale: np.ndarray, noise) -> dict:
    """The noise σ of each photographed view's own channels (white → 1, exposure 1) and where it came
    from: ``noise = "auto"`` the full-resolution sensor noise of the RAW file (its DNG NoiseProfile at
    the channel's median level, else the mosaic's own estimate: :func:`splat.fusion.sensor_noise`,
    at least :data:`splat.fusion.OWN_NOISE_FLOOR`), a σ as given, or ``{"shot", "read"}`` as
    ``sqrt(shot · x + read)`` at the channel's median level ``x``.

    Returns
    -------
    dict
        View name → ``{"sigma": [3 floats], "sigma_full": [3 floats], "source": str}``: ``sigma`` at the
        working resolution (what the fused correction uses; ``"auto"`` keeps ``fusion.json``'s),
        ``sigma_full`` at the photograph's full resolution (binning divides σ by the √ of the sites
        averaged).
    """
    from ..fusion import OWN_NOISE_FLOOR
    from ..resolution import sites_per_block

    out = {}
    for name, d in fusion["views"].items():
        v = raws[name]
        k = v.camera
        ws = scale[3 * k : 3 * k + 3]
        root = np.sqrt(sites_per_block(v.source_cfa, v.binning)) if v.binning > 1 else np.ones(3)
        if noise == "auto":
            sigma = np.asarray(d["own_sigma"], float)
            full = np.maximum(sigma * root, OWN_NOISE_FLOOR)
            source = "DNG NoiseProfile" if v.noise_profile is not None else "estimated from the mosaic"
        else:
            if isinstance(noise, dict):
                vals, w = np.asarray(v.values, float) / v.exif / ws, np.asarray(v.weight) > 0
                x = np.array(
                    [np.median(vals[..., j][w[..., j]]) if w[..., j].any() else 0.0 for j in range(3)]
                )
                full = np.sqrt(noise["shot"] * np.maximum(x, 0) + noise["read"]) * np.ones(3)
            else:
                full = np.full(3, float(noise))
            full = np.maximum(full, OWN_NOISE_FLOOR)
            sigma = np.maximum(full / root, OWN_NOISE_FLOOR)
            source = "--noise"
        out[name] = {
            "sigma": [_two_digits(x) for x in sigma],
            "sigma_full": [_two_digits(x) for x in full],
            "source": source,
        }
    return out


class _Reprojection:
    """:class:`splat.strips.FullReprojection` and the photographs it reads (``names``: camera → views)."""

    def __init__(self, rep, names):
        self.rep, self.names = rep, names


def full_reprojection(
    spec: CaptureSpec,
    out: Path,
    raws: dict,
    fusion: dict,
    scale: np.ndarray,
    *,
    views=None,
    open_source=None,
    own_sources: int | None = None,
    min_alpha: float | None = None,
):
    """``model(view, (H, W)) → splat.strips.FullReprojection`` (None where the photograph is at its
    working resolution, or no camera's reprojection noise is known): for each other camera, its
    :data:`splat._tol.FULL_SOURCES` photographs that see most of the view, and for the view's own camera
    its :data:`splat._tol.FULL_OWN_SOURCES` other photographs that do (at the working resolution,
    through the splat's depth: :func:`splat.capture.nearest_sources` counting every pixel, photographs
    that see none of it left out), read from their RAW files (bilinear demosaic, as the render step's
    sources) a band of rows at a time. σ of a channel reprojected at full resolution: the camera's
    working ``reprojected_sigma`` and, in quadrature, its photographs' full-resolution sensor noise over
    √(photographs) (the binned estimate holds the noise of a binned site only).

    ``views`` (name → :class:`splat.data.View` at the working resolution; default the model's registered
    views, pose corrections applied) and ``open_source`` (``RawView → RawSource``; default
    :func:`open_raw` of its file) stand in for what ``OUT`` and the capture hold (benchmarks);
    ``own_sources`` replaces :data:`splat._tol.FULL_OWN_SOURCES` (0: the other cameras' only),
    ``min_alpha`` :data:`splat.reproject.MIN_ALPHA` (where a pixel of the view and of a source has a
    depth)."""
    from .._tol import FULL_OWN_SOURCES, FULL_SOURCE_STRIDE, FULL_SOURCES
    from ..camera import Camera
    from ..fusion import OWN_NOISE_FLOOR, sensor_noise
    from ..reproject import MIN_ALPHA, depth_map
    from ..resolution import sites_per_block
    from ..strips import FullReprojection, raw_row_source
    from .config import working_views
    from .render import nearest_sources
    from .train import load_gaussians, load_model_capture, refined_views

    rep_sigma = fusion.get("reprojected_sigma")
    own_n = FULL_OWN_SOURCES if own_sources is None else own_sources
    t = MIN_ALPHA if min_alpha is None else float(min_alpha)
    state: dict = {}

    def loaded():
        if not state:
            state["g"], state["alive"] = load_gaussians(out)
            if views is None:
                _, cap = load_model_capture(spec, out)
                state["views"] = {v.name: v for v in refined_views(working_views(cap.views, raws), out)}
            else:
                state["views"] = dict(views)
            state["depth"] = {}
        return state

    def depth(name):
        st = loaded()
        if name not in st["depth"]:
            d, a = depth_map(st["g"], st["views"][name].camera, mask=st["alive"])
            st["depth"][name] = (d, a, np.where(a >= t, d, 0.0))
        return st["depth"][name]

    def full_sigma(r):  # a photograph's own full-resolution sensor noise, white → 1 at exposure 1
        ws = scale[3 * r.camera : 3 * r.camera + 3]
        root = np.sqrt(sites_per_block(r.source_cfa, r.binning)) if r.binning > 1 else np.ones(3)
        return np.maximum(sensor_noise(r, ws) * root, OWN_NOISE_FLOOR)

    def model(view: RawView, shape):
        if view.binning == 1 or rep_sigma is None:
            return None
        st = loaded()
        if view.name not in st["views"]:
            return None
        cam = st["views"][view.name].camera
        d, a, _ = depth(view.name)
        f = view.binning
        full = Camera(
            cam.R, cam.t, np.asarray(cam.focal) * f, np.asarray(cam.principal) * f, shape[1], shape[0]
        )
        groups, names, sig = {}, {}, np.zeros(3 * len(spec.cameras))
        for c in range(len(spec.cameras)):  # the view's own camera too: its other photographs
            cands = [
                (name, st["views"][name].camera, depth(name)[2])
                for name, r in raws.items()
                if r.camera == c and r.exif is not None and name in st["views"] and name != view.name
            ]
            n_src = own_n if c == view.camera else FULL_SOURCES
            best = nearest_sources(
                cam, d, a, cands, n_src, seen_only=True, stride=FULL_SOURCE_STRIDE, min_alpha=t
            )
            chosen = [raws[nm] for nm, _, _ in best]
            if not chosen:
                continue
            ws = scale[3 * c : 3 * c + 3]
            srcs, noise = [], []
            for r in chosen:
                raw = open_raw(r.path, spec.cameras[c]) if open_source is None else open_source(r)
                rc = st["views"][r.name].camera
                fr = r.binning
                H_, W_ = raw.shape
                full_c = Camera(rc.R, rc.t, np.asarray(rc.focal) * fr, np.asarray(rc.principal) * fr, W_, H_)
                noise.append(full_sigma(r))
                srcs.append(raw_row_source(raw, full_c, depth(r.name)[2], fr, r.exif, ws, noise[-1]))
            groups[c], names[c] = srcs, chosen
            sig[3 * c : 3 * c + 3] = np.hypot(float(rep_sigma[c]), np.mean(noise, 0) / np.sqrt(len(noise)))
        if not groups:
            return None
        return _Reprojection(FullReprojection(st["g"], st["alive"], full, groups, sig, scale, f, t), names)

    return model


def _full_resolution(
    spec: CaptureSpec,
    o: Path,
    view: RawView,
    fused,
    code,
    sigma,
    own_scale,
    noise: dict,
    fit,
    wXYZ,
    progress,
    model=None,
    *,
    workers=None,
):
    """Write ``full_XYZ.tiff`` and ``full_sRGB.png`` of a photographed view at its RAW file's size
    (:func:`splat.strips.full_resolution_view`; ``model(view, (H, W))``: the other cameras' photographs
    to reproject at full resolution, :func:`full_reprojection`); returns what was done and how long it
    took.

    Where the working grid is the RAW file's own (binning 1), the working fusion is a full-resolution
    one that knows more than the strips: ``fit`` corrects ``fused`` itself
    (:func:`splat.strips.corrected_working`). On the benchmark capture's 12 held-out views the strips
    gave 6.58 / 1.00 ΔE00 (all / flat pixels), the fused responses 3.99 / 0.52
    (docs/notes/2026-11-30-full-size-output.md)."""
    t = time.perf_counter()
    k = view.camera
    source = open_raw(view.path, spec.cameras[k])
    H, W = source.shape
    if view.binning == 1 and tuple(np.shape(fused)[:2]) == (H, W):
        XYZ = _strips.corrected_working(fused, code, sigma, fit)
        _strips.write_full(
            o / "full_XYZ.tiff", o / "full_sRGB.png", iter([XYZ]), (H, W), _strips.sRGB8_encoder(wXYZ), rows=H
        )
        return {
            "size": [W, H],
            "binning": 1,
            "from": "the working fusion (the working grid is the RAW file's)",
            "reprojected_at_full_resolution": None,
            "seconds": time.perf_counter() - t,
            "workers": 1,
        }
    rows = _strips.STRIP_ROWS
    reprojection = model(view, (H, W)) if model is not None else None
    workers = _strips.default_workers() if workers is None else int(workers)
    strips = _strips.full_resolution_view(
        _strips.Photograph(
            source, view.exif, np.asarray(own_scale, float), np.asarray(noise["sigma_full"], float)
        ),
        _strips.WorkingFusion(fused, code, sigma, slice(3 * k, 3 * k + 3), view.binning),
        fit,
        strip_rows=rows,
        progress=progress,
        reprojection=None if reprojection is None else reprojection.rep,
        workers=workers,
    )
    _strips.write_full(
        o / "full_XYZ.tiff", o / "full_sRGB.png", strips, (H, W), _strips.sRGB8_encoder(wXYZ), rows=rows
    )
    return {
        "size": [W, H],
        "binning": view.binning,
        "reprojected_at_full_resolution": (
            {spec.label(i): [Path(r.name).name for r in g] for i, g in reprojection.names.items()}
            if reprojection is not None
            else None
        ),
        "seconds": time.perf_counter() - t,
        "workers": workers,
    }
