"""Scores a pipeline output against the simulator's ground truth (``CAPTURE/truth``).

Only tests and benchmarks call this; the pipeline steps never read ``truth/``. For each held-out view
with a true XYZ image: ΔE00 (mean, 95th percentile; CIELAB relative to the illuminant's white) of

- ``dng:<cam>`` the view's own RAW file developed by :mod:`isp` with its DNG ColorMatrix (white → 1
  scale and exposure of the pipeline), only for the camera that took the view;
- ``raw-<method>:<cam>`` the view's own RAW file (demosaiced by isp, Malvar 2004; full-colour files as
  they are) corrected by ``<method>`` with that camera alone — the single-camera metamer correction;
- ``<method>:<cams>`` the splat's render of the view through the channels of ``<cams>`` (one camera,
  pairs, all), corrected by Prior and Centroid with the pipeline's δ;
- ``<method>-fused:<cams>`` the same view fused with its own RAW file (:mod:`splat.fusion`: its
  measured channels, the other cameras' photographs reprojected into it (:mod:`splat.reproject`) where
  they see the pixel, else the render anchored to the photograph; per-channel noise),
  for the subsets of two or more cameras that include the view's own — what the correct step writes as
  ``<method>_fused_*`` for every photographed view;
- ``<method>-photographed:<cams>`` the same view as if it had no photograph (a novel view): the
  photographs of ``<cams>`` reprojected into it where they see the pixel (its own RAW file is never a
  source), else the render (``pipeline.photographed_view``) — what the correct step writes as
  ``<method>_fused_*`` for every novel view;

each over all pixels and (``flat_delta_E00``) over the *flat* pixels only: those whose true XYZ is
constant over their 5 × 5 neighbourhood (every channel's range ≤ 1 % of max(Y, 0.02)), where neither
demosaicing nor the splat's blur at edges enters and the estimate measures colour alone;

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

__all__ = ["flat_mask", "raw_balanced", "score", "similarity"]


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


def _dE(problem, est, ref):
    import colour

    w = problem.white_XYZ
    xy = colour.XYZ_to_xy(w)
    lab_e = colour.XYZ_to_Lab(est / w[1], xy)
    lab_r = colour.XYZ_to_Lab(ref / w[1], xy)
    d = np.asarray(colour.delta_E(lab_e, lab_r, method="CIE 2000")).ravel()
    return {"mean": float(np.mean(d)), "p95": float(np.percentile(d, 95))}


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

    from zonotope.correct import CORRECTION_METHODS
    from zonotope.correct.image import correct_image

    from .capture import load_views, read_capture
    from .colmap import read_colmap
    from .data import capture_from_colmap
    from .pipeline import (
        correct_fused,
        delta_of,
        dng_matrix_XYZ,
        fit_corrector,
        fused_fitter,
        fused_view,
        fusion_of,
        photographed_view,
        read_index,
        reprojected_of,
        white_of,
    )

    spec = read_capture(capture)
    out = Path(out)
    truth = spec.root / "truth"
    n = len(spec.cameras)
    subsets = subsets or [s for r in range(1, n + 1) for s in itertools.combinations(range(n), r)]
    raws = {v.name: v for v in load_views(spec)}
    white = white_of(spec, out, list(raws.values()))
    scale = np.concatenate(white["scale"])
    index = read_index(spec, out / "render" / "index.json")
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
    corr = {(m, s): fit_corrector(spec, list(s), m, delta) for m in methods for s in subsets}
    raw_corr = {(m, k): fit_corrector(spec, [k], m, delta) for m in raw_methods for k in range(n)}
    problem = corr[(methods[0], subsets[-1])].problem
    fusion = fusion_of(spec, out, index, raws, scale)
    fitters: dict = {}  # (method, cameras) → splat.pipeline.fused_fitter
    n_flat = []

    def add(label, est, ref, flat):
        if est.shape == ref.shape:
            rows.setdefault(label, []).append(_dE(problem, est, ref))
            est = est[flat]
        if flat.any():
            flat_rows.setdefault(label, []).append(_dE(problem, est, ref[flat]))

    def pick(img, fl):  # the pixels to correct: all, or the flat ones as a (n, 1, k) image
        return img[fl][:, None] if flat_only else img

    def unpick(est):
        return est[:, 0] if flat_only else est

    for name in held:
        ref = np.asarray(tifffile.imread(truth / "xyz" / f"{_truth_stem(name)}.tiff"), float)
        flat = flat_mask(ref)
        n_flat.append(float(flat.mean()))
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
            if name in fusion["views"] and cam in sub and len(sub) > 1:  # its RAW, the others reprojected
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

    result = {
        "held_out_views": held,
        "delta_E00": summarise(rows),
        "flat_delta_E00": summarise(flat_rows),
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
        from .pipeline import refined_views

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
