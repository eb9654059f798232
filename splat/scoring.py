"""Scores a pipeline output against the simulator's ground truth (``CAPTURE/truth``).

Only tests and benchmarks call this; the pipeline steps never read ``truth/``. For each held-out view
with a true XYZ image: ΔE00 (mean, 95th percentile; CIELAB relative to the illuminant's white) of

- ``dng:<cam>`` the view's own RAW file developed by :mod:`isp` with its DNG ColorMatrix (white → 1
  scale and exposure of the pipeline), only for the camera that took the view;
- ``dev:<cam>`` the view's own RAW file **developed well** (:func:`develop`), the strongest single-photograph
  baseline: the pipeline's white (the marked card), every demosaicing method of isp's registry (the one
  with the lowest mean ΔE00 over the camera's held-out views is kept, named in ``dev_demosaic``; each
  method's own figures stay as ``dev-<demosaic>:<cam>``), no
  clipping before the matrix, a least-squares 3 × 3 matrix fitted on the ColorChecker through the
  camera's spectral sensitivities (:func:`chart_matrix`; what a chart profile does);
- ``raw-<method>:<cam>`` the view's own RAW file (demosaiced by isp, Malvar 2004; full-colour files as
  they are) corrected by ``<method>`` with that camera alone — the single-camera metamer correction;
- ``<method>:<cams>`` the splat's render of the view through the channels of ``<cams>`` (one camera,
  pairs, all), corrected by Prior and Centroid with the pipeline's δ;
- ``<method>-fused:<cams>`` the same view fused with its own RAW file (:mod:`splat.fusion`: its
  measured channels, the other cameras' photographs reprojected into it (:mod:`splat.reproject`) where
  they see the pixel, else the render anchored to the photograph; per-channel noise),
  for the subsets that include the view's own — what the correct step writes as ``<method>_fused_*``
  for every photographed view; with the view's own camera alone this is the **one-camera pipeline**
  (its photograph averaged with its other photographs reprojected into it, no other camera), which
  separates the gain of the other cameras' channels from that of averaging more photographs (the
  depth used to reproject is the jointly trained model's: a one-camera capture would have less
  geometry, so this baseline is, if anything, favoured);
- ``<method>-photographed:<cams>`` the same view as if it had no photograph (a novel view): the
  photographs of ``<cams>`` reprojected into it where they see the pixel (its own RAW file is never a
  source), else the render (``splat.capture.photographed_view``) — what the correct step writes as
  ``<method>_fused_*`` for every novel view;

each over all pixels and (``flat_delta_E00``) over the *flat* pixels only: those whose true XYZ is
constant over their 5 × 5 neighbourhood (every channel's range ≤ 1 % of max(Y, 0.02)), where neither
demosaicing nor the splat's blur at edges enters and the estimate measures colour alone; and, with
the noise averaged out, per **region mean** (:func:`region_labels`: connected uniform regions of the
true image): ``chart_delta_E00`` the ΔE00 between the estimate's and the truth's mean XYZ over each
ColorChecker patch seen, ``uniform_delta_E00`` the same over every other uniform surface (regions
pooled over the held-out views); ``per_view`` keeps every view's numbers, so that estimates can be
compared on the same views;

plus the held-out render PSNR per channel (render × exposure against the view's RAW mosaic on its valid
pixels; peak 1 = saturation; ``psnr_db``) and the same with both divided by the view's relative EXIF
exposure (``psnr_exposure_normalised_db``: as if every view were shot at the capture's median exposure,
``PSNR + 20 log10(exposure)`` per view). The model's error grows with the signal, so with peak 1 a view
shot one stop brighter scores ≈ 6 dB lower for the same fit: on the benchmark capture the per-view PSNR
of the training views follows the log of their mean signal with correlation −0.99, and the held-out
views, shot at 1.39× the training views' mean exposure, scored 30.6 dB against 34.5 on the training
views, normalised 33.0 against 33.5. Compare models on one capture with either; compare held-out with
training views, or captures with each other, only normalised. Then the pose error of the recovered
cameras against the true ones after a similarity alignment (Umeyama 1991) of the camera centres (with
``--refine-poses``, also of the training views as recovered and as refined by training,
``pose_training_views``).
"""

from __future__ import annotations

import itertools
import json
import os
from pathlib import Path

import numpy as np

from ._tol import REGION_MIN_PIXELS, REGION_RTOL

__all__ = [
    "chart_matrix",
    "correction_inputs",
    "develop",
    "flat_mask",
    "raw_balanced",
    "region_labels",
    "score",
    "similarity",
]


def similarity(X, Y):
    """Umeyama (1991): ``s, R, t`` minimising ``Σ |s R x + t − y|²`` for points (P, 3)."""
    X, Y = np.asarray(X, float), np.asarray(Y, float)
    mx, my = X.mean(0), Y.mean(0)
    U, S, Vt = np.linalg.svd((Y - my).T @ (X - mx) / len(X))
    D = np.eye(3)
    D[2, 2] = np.sign(np.linalg.det(U @ Vt))
    R = U @ D @ Vt
    s = np.trace(np.diag(S) @ D) / (X - mx).var(0).sum()
    return s, R, my - s * R @ mx


def _truth_stem(name: str) -> str:
    """``"<folder>/<stem>"``: where the simulator keeps a view's truth inside the capture."""
    p = Path(name)
    return f"{p.parent.as_posix()}/{p.stem}"


def _pose_error(est: dict, tru: dict, names: list) -> dict:
    """Centre and rotation error of the views ``names`` (name → :class:`splat.data.View` in ``est`` and
    ``tru``) after a similarity alignment of their centres (:func:`similarity`)."""
    X = np.array([np.asarray(est[k].camera.centre, float) for k in names])
    Y = np.array([np.asarray(tru[k].camera.centre, float) for k in names])
    s, R, t = similarity(X, Y)
    err = np.linalg.norm(s * X @ R.T + t - Y, axis=1)
    ang = []
    for k in names:
        Re = np.asarray(est[k].camera.R, float) @ R.T  # world_true → cam, estimated
        Rt = np.asarray(tru[k].camera.R, float)
        cosang = (np.trace(Re @ Rt.T) - 1) / 2
        ang.append(float(np.degrees(np.arccos(np.clip(cosang, -1, 1)))))
    return {
        "centre_error_mean": float(err.mean()),
        "centre_error_max": float(err.max()),
        "scene_extent": float(np.linalg.norm(Y.max(0) - Y.min(0))),
        "rotation_error_deg_mean": float(np.mean(ang)),
    }


def raw_balanced(view, scale) -> np.ndarray:
    """A RAW view on the white → 1 scale at exposure 1 (:func:`splat.fusion.measured`)."""
    from .fusion import measured

    return measured(view, scale)


def _dE_all(problem, est, ref) -> np.ndarray:
    """ΔE00 per pixel (CIELAB relative to the problem's white), flattened."""
    import colour

    w = problem.white_XYZ
    xy = colour.XYZ_to_xy(w)
    lab_e = colour.XYZ_to_Lab(est / w[1], xy)
    lab_r = colour.XYZ_to_Lab(ref / w[1], xy)
    return np.asarray(colour.delta_E(lab_e, lab_r, method="CIE 2000")).ravel()


def _dE(problem, est, ref):
    d = _dE_all(problem, est, ref)
    return {"mean": float(np.mean(d)), "p95": float(np.percentile(d, 95))}


def chart_matrix(spec, k: int, *, chart: str = "ColorChecker N Ohta") -> np.ndarray:
    """Least-squares matrix (3, 3) from camera ``k``'s white → 1 responses to XYZ (scene white, Y = 1),
    fitted on the ``chart``'s reflectances through the capture's spectral sensitivities and illuminant
    (the grid and normalisation of :func:`splat.capture.correction_problem_of`): ``XYZ = c @ M``."""
    import zonotope

    from .capture import correction_problem_of

    problem = correction_problem_of(spec, [k])
    R = np.asarray(zonotope.resample(zonotope.reflectances(chart), problem.wavelengths), float).T
    M, *_ = np.linalg.lstsq(R @ problem.Phi, R @ problem.Psi, rcond=None)
    return M


def develop(view, white_scale, M, *, demosaic: str = "Menon 2007") -> np.ndarray:
    """A RAW view developed as a careful photographer would: demosaiced by isp (``demosaic``; a
    full-colour file as it is), put on the white → 1 scale of ``white_scale`` (3,) at exposure 1, and
    ``M`` (:func:`chart_matrix`) applied with no clipping before it; XYZ (H, W, 3)."""
    from .fusion import measured

    return measured(view, white_scale, method=demosaic) @ M


def region_labels(
    XYZ, chart_XYZ=None, *, radius: int = 2, rtol: float = REGION_RTOL, min_pixels: int = REGION_MIN_PIXELS
):
    """Uniform regions of a true XYZ image, and which of them show a chart patch.

    A region is a connected set of pixels whose true XYZ is constant over their ``(2 radius + 1)²``
    neighbourhood (:func:`flat_mask`; two such neighbours always share their colour), of at least
    ``min_pixels`` pixels: a surface's interior, as one measures a patch's mean colour away from its
    borders (with ``radius = 1`` the pixels next to a border enter, where the splat's blur and a
    reprojection's misplacement dominate a small patch's mean). A region shows chart patch ``j`` when
    its mean XYZ matches ``chart_XYZ[j]`` within ``rtol`` (relative, per channel, floor 0.01).

    Parameters
    ----------
    XYZ : array_like of shape (H, W, 3)
    chart_XYZ : array_like of shape (P, 3), optional

    Returns
    -------
    labels : ndarray of shape (H, W), int
        0 outside every region, else the region's number (1, 2, …).
    chart : dict
        Region number → chart patch index.
    """
    from scipy.ndimage import label

    XYZ = np.asarray(XYZ, float)
    lab, n = label(flat_mask(XYZ, radius=radius, rtol=rtol), structure=np.ones((3, 3)))
    sizes = np.bincount(lab.ravel(), minlength=n + 1)
    keep = sizes >= min_pixels
    keep[0] = False
    lab = np.where(keep[lab], lab, 0)
    chart = {}
    if chart_XYZ is not None:
        C = np.asarray(chart_XYZ, float)
        for r in np.flatnonzero(keep):
            mean = XYZ[lab == r].mean(0)
            err = np.abs(C - mean) / np.maximum(mean, 0.01)
            j = int(np.argmin(err.max(-1)))
            if err[j].max() <= rtol:
                chart[int(r)] = j
    return lab, chart


def _chart_XYZ(spec, chart: str = "ColorChecker N Ohta") -> np.ndarray:
    """The chart's XYZ under the capture's illuminant (Y_white = 1), on a 5 nm grid as the truth."""
    import zonotope

    light = spec.load_illuminant()
    obs = zonotope.observer(spec.observer)
    refl = zonotope.reflectances(chart)
    shape = zonotope.common_shape(obs, light, refl, interval=5)
    Psi = np.asarray(zonotope.generators(obs, light, shape, normalise=None).values, float)
    R = np.asarray(zonotope.resample(refl, shape), float).T
    return R @ Psi / Psi[:, 1].sum()


def _region_dE(problem, est, ref, labels, chart) -> tuple[list, list]:
    """ΔE00 of the mean XYZ over each region: (chart regions, other regions)."""
    if not labels.any():
        return [], []
    idx = labels.ravel()
    n = idx.max() + 1
    cnt = np.bincount(idx, minlength=n)
    ok = np.flatnonzero(cnt > 0)
    ok = ok[ok > 0]
    mean_e = np.stack([np.bincount(idx, est.reshape(-1, 3)[:, c], n) for c in range(3)], -1)[ok]
    mean_r = np.stack([np.bincount(idx, ref.reshape(-1, 3)[:, c], n) for c in range(3)], -1)[ok]
    d = _dE_all(problem, mean_e / cnt[ok, None], mean_r / cnt[ok, None])
    is_chart = np.array([int(r) in chart for r in ok])
    return list(d[is_chart]), list(d[~is_chart])


def flat_mask(XYZ, *, radius: int = 2, rtol: float = 0.01) -> np.ndarray:
    """Pixels whose true XYZ is constant over their ``(2 radius + 1)²`` neighbourhood: every channel's
    range there ≤ ``rtol · max(Y, 0.02)`` (a relative tolerance; image borders are extended)."""
    from scipy.ndimage import maximum_filter, minimum_filter

    XYZ = np.asarray(XYZ, float)
    size = 2 * radius + 1
    ok = np.ones(XYZ.shape[:2], bool)
    lim = rtol * np.maximum(XYZ[..., 1], 0.02)
    for c in range(3):
        x = XYZ[..., c]
        ok &= maximum_filter(x, size, mode="nearest") - minimum_filter(x, size, mode="nearest") <= lim
    return ok


def correction_inputs(spec, out: Path) -> tuple[dict, dict, dict, np.ndarray]:
    """What the correct step works from in ``OUT``: the RAW views by name, the render step's index, the
    white (the patch's, each camera at its level against the others: ``levelled_white``) and its
    scale (3 per camera, white → 1). Why: every scorer of fused estimates must start where the correct
    step does, or it scores another white."""
    from .capture import levelled_white, load_views, read_index, white_of

    out = Path(out)
    raws = {v.name: v for v in load_views(spec)}
    index = read_index(spec, out / "render" / "index.json")
    white = levelled_white(spec, out, index, raws, white_of(spec, out, list(raws.values())))
    return raws, index, white, np.concatenate(white["scale"])


def score(
    capture: str | os.PathLike,
    out: str | os.PathLike,
    *,
    stride: int = 2,
    methods=("Prior", "Centroid"),
    subsets=None,
    raw_methods=("Prior",),
    flat_only: bool = False,
    quantum: float = 2e-3,
) -> dict:
    """Score ``OUT`` against ``CAPTURE/truth`` and write ``OUT/score.json``.

    Parameters
    ----------
    capture, out : path
    stride : int
        ΔE of the splat estimates on every ``stride``-th pixel in each direction (the estimators cost
        milliseconds per colour); the DNG development on all pixels.
    methods : sequence of str
    subsets : sequence of tuple of int, optional
        Camera subsets (default: each camera, each pair, all).
    raw_methods : sequence of str
        Estimators applied to each held-out RAW file with its own camera alone (on every ``stride``-th
        pixel, δ of the pipeline); empty to skip.
    flat_only : bool
        Correct only the flat pixels (the splat and ``raw-`` estimates then appear in
        ``flat_delta_E00`` alone): the 9-channel estimators are slow per distinct colour, and
        the flat pixels of a coarse texture share few colours.
    quantum : float
        Colour deduplication step of :func:`zonotope.correct.image.correct_image`.

    Returns
    -------
    dict
    """
    import tifffile

    from isp.stages import DEMOSAIC_METHODS
    from zonotope.correct import CORRECTION_METHODS
    from zonotope.correct.image import correct_image

    from .capture import (
        correct_fused,
        delta_of,
        dng_matrix_XYZ,
        fit_corrector,
        fused_fitter,
        fused_view,
        fusion_of,
        photographed_view,
        pipeline_mix,
        read_capture,
        reprojected_of,
    )
    from .capture.illuminant import illuminant_of
    from .colmap import read_colmap
    from .data import capture_from_colmap

    spec = read_capture(capture)
    out = Path(out)
    spec, _ = illuminant_of(spec, out)  # "estimate": the light the correct step chose
    truth = spec.root / "truth"
    n = len(spec.cameras)
    subsets = subsets or [s for r in range(1, n + 1) for s in itertools.combinations(range(n), r)]
    raws, index, white, scale = correction_inputs(spec, out)
    delta = delta_of(spec, out, index, scale)["delta"]
    held = [
        k
        for k, v in index.items()
        if v["kind"] == "holdout" and (truth / "xyz" / f"{_truth_stem(k)}.tiff").is_file()
    ]
    rows: dict[str, list] = {}
    flat_rows: dict[str, list] = {}
    psnr: dict[str, list] = {}
    psnr_norm: dict[str, list] = {}  # the same, as if shot at the median exposure
    # the render corrected alone as the correct step does it (its λ); the single RAW files' baselines with
    # Prior's own cross-validated λ
    corr = {
        (m, s): fit_corrector(spec, list(s), m, delta, mix=pipeline_mix(m)) for m in methods for s in subsets
    }
    raw_corr = {(m, k): fit_corrector(spec, [k], m, delta) for m in raw_methods for k in range(n)}
    problem = corr[(methods[0], subsets[-1])].problem
    fusion = fusion_of(spec, out, index, raws, scale)
    fitters: dict = {}  # (method, cameras) → splat.capture.fused_fitter
    n_flat = []

    chart_XYZ = _chart_XYZ(spec)
    region: list = [None, None]  # the current view's region labels on the stride grid, chart regions
    chart_rows: dict[str, list] = {}
    uniform_rows: dict[str, list] = {}
    per_view: dict[str, dict] = {}

    def add(label, est, ref, flat):
        row = {}
        if est.shape == ref.shape:
            row = _dE(problem, est, ref)
            rows.setdefault(label, []).append(row)
            # region means on the stride grid for every estimate (the same pixels of the same regions)
            lab, chart = region
            e, r = (
                (est, ref)
                if est.shape[:2] == lab.shape
                else (est[::stride, ::stride], ref[::stride, ::stride])
            )
            ch, un = _region_dE(problem, e, r, lab, chart)
            chart_rows.setdefault(label, []).extend(ch)
            uniform_rows.setdefault(label, []).extend(un)
            row = dict(
                row, chart=float(np.mean(ch)) if ch else None, uniform=float(np.mean(un)) if un else None
            )
            est = est[flat]
        if flat.any():
            d = _dE(problem, est, ref[flat])
            row = dict(row, flat=d["mean"])
            flat_rows.setdefault(label, []).append(d)
        per_view.setdefault(current[0], {})[label] = row

    def pick(img, fl):  # the pixels to correct: all, or the flat ones as a (n, 1, k) image
        return img[fl][:, None] if flat_only else img

    def unpick(est):
        return est[:, 0] if flat_only else est

    dev_M = {k: chart_matrix(spec, k) for k in range(n)}
    current = [None]
    for name in held:
        current[0] = name
        ref = np.asarray(tifffile.imread(truth / "xyz" / f"{_truth_stem(name)}.tiff"), float)
        flat = flat_mask(ref)
        n_flat.append(float(flat.mean()))
        lab, chart = region_labels(ref, chart_XYZ)  # on all pixels, then read on the stride grid
        region[:] = [lab[::stride, ::stride], chart]
        d = out / "correct" / spec.out_stem(name)
        raw_dng = d / "raw_dng_XYZ.tiff"
        cam = raws[name].camera
        if raw_dng.is_file():
            est = np.asarray(tifffile.imread(raw_dng), float)
            add(f"dng:{spec.cameras[cam].folder}", est, ref, flat)
        elif raws[name].profile is not None:  # the correct step was not run: develop it here, as it would
            bal = np.maximum(raw_balanced(raws[name], white["scale"][cam]), 0)
            est = dng_matrix_XYZ(bal, raws[name].profile, raws[name].neutral, problem.white_XYZ)
            add(f"dng:{spec.cameras[cam].folder}", est, ref, flat)
        folder = spec.cameras[cam].folder
        for dm in ("as is",) if raws[name].full_colour else DEMOSAIC_METHODS:
            est = develop(
                raws[name], white["scale"][cam], dev_M[cam], demosaic="Malvar 2004" if dm == "as is" else dm
            )
            add(f"dev-{dm}:{folder}", est, ref, flat)
        r, fl = ref[::stride, ::stride], flat[::stride, ::stride]
        if raw_corr:
            bal = raw_balanced(raws[name], white["scale"][cam])[::stride, ::stride]
            for m in raw_methods:
                cor = raw_corr[(m, cam)]
                est = unpick(correct_image(pick(np.maximum(bal, 0), fl), cor, quantum=quantum))
                add(f"raw-{cor.method}:{spec.cameras[cam].folder}", est, r, fl)
        render = np.asarray(tifffile.imread(out / "render" / spec.out_stem(name) / "render.tiff"), float)
        c = np.maximum(render / scale, 0)[::stride, ::stride]
        for (_m, s), cor in corr.items():
            idx = [3 * k + j for k in s for j in range(3)]
            est = unpick(correct_image(pick(c[..., idx], fl), cor, quantum=quantum))
            label = f"{cor.method}:{'+'.join(spec.cameras[k].folder for k in s)}"
            add(label, est, r, fl)
        rep = reprojected_of(out / "render" / spec.out_stem(name), scale)
        for sub in subsets:
            views = []
            if name in fusion["views"] and cam in sub:  # its RAW, the others reprojected (alone: one camera)
                f = fused_view(fusion, name, render / scale, raws[name], scale, list(sub), rep)
                views.append(("fused", f))
            if rep is not None and fusion["reprojected_sigma"] is not None:  # as if it had no photograph
                views.append(("photographed", photographed_view(fusion, render / scale, rep, list(sub))))
            cams = "+".join(spec.cameras[k].folder for k in sub)
            for kind, (f, code, sigma) in views:
                f, code = f[::stride, ::stride], code[::stride, ::stride]
                if flat_only:
                    f, code = f[fl], code[fl]
                for m in methods:
                    if (m, sub) not in fitters:
                        fitters[(m, sub)] = fused_fitter(spec, list(sub), m)
                    est = correct_fused(f, code, sigma, fitters[(m, sub)], quantum)
                    add(f"{CORRECTION_METHODS.resolve(m)}-{kind}:{cams}", est, r, fl)
        v = raws[name]
        pred = render[..., 3 * cam : 3 * cam + 3] * v.exif
        w = v.weight > 0
        for j in range(3):
            mse = np.mean((np.minimum(pred[..., j], 1) - v.values[..., j])[w[..., j]] ** 2)
            key = f"{spec.cameras[cam].folder}:{'RGB'[j]}"
            psnr.setdefault(key, []).append(float(10 * np.log10(1 / mse)))
            psnr_norm.setdefault(key, []).append(float(10 * np.log10(v.exif**2 / mse)))

    def summarise(table):
        return {
            k: {
                "mean": float(np.mean([x["mean"] for x in v])),
                "p95": float(np.mean([x["p95"] for x in v])),
                "views": len(v),
            }
            for k, v in table.items()
        }

    # dev: each camera's best demosaicing over its held-out views (the strongest such baseline)
    dev_demosaic = {}
    for k in range(n):
        folder = spec.cameras[k].folder
        cand = {
            lb: np.mean([x["mean"] for x in v])
            for lb, v in rows.items()
            if lb.startswith("dev-") and lb.endswith(f":{folder}")
        }
        if not cand:
            continue
        best = min(cand, key=cand.get)
        dev_demosaic[folder] = best[4 : -len(folder) - 1]
        for table in (rows, flat_rows, chart_rows, uniform_rows):
            if best in table:
                table[f"dev:{folder}"] = table[best]
        for views_ in per_view.values():
            if best in views_:
                views_[f"dev:{folder}"] = views_[best]

    def pooled(table):
        return {k: {"mean": float(np.mean(v)), "regions": len(v)} for k, v in table.items() if v}

    result = {
        "held_out_views": held,
        "delta_E00": summarise(rows),
        "flat_delta_E00": summarise(flat_rows),
        "chart_delta_E00": pooled(chart_rows),
        "uniform_delta_E00": pooled(uniform_rows),
        "dev_demosaic": dev_demosaic,
        "per_view": per_view,
        "flat_fraction": float(np.mean(n_flat)) if n_flat else 0.0,
        "psnr_db": {k: float(np.mean(v)) for k, v in psnr.items()},
        "psnr_exposure_normalised_db": {k: float(np.mean(v)) for k, v in psnr_norm.items()},
        "delta": delta,
        "white": white["method"],
    }
    # pose error after a similarity alignment of the camera centres
    if (truth / "images.txt").is_file() and (out / "poses" / "model").is_dir():
        est = {v.name: v for v in capture_from_colmap(read_colmap(out / "poses" / "model")).views}
        tru = {v.name: v for v in capture_from_colmap(read_colmap(truth)).views}
        common = sorted(set(est) & set(tru))
        if len(common) >= 3:
            result["pose"] = dict(registered=len(common), of=len(tru), **_pose_error(est, tru, common))
        # with --refine-poses: the training views' poses as recovered and as refined by training
        from .capture import refined_views

        refined = {v.name: v for v in refined_views(list(est.values()), out)}
        trained = [k for k in common if refined[k].camera is not est[k].camera]
        if len(trained) >= 3:
            result["pose_training_views"] = {
                "views": len(trained),
                "recovered": _pose_error(est, tru, trained),
                "refined": _pose_error(refined, tru, trained),
            }
    p = out / "score.json"
    p.write_text(json.dumps(result, indent=1))
    return result
