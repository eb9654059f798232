"""Scores a pipeline output against the simulator's ground truth (``CAPTURE/truth``).

Only tests and benchmarks call this; the pipeline steps never read ``truth/``. For each held-out view
with a true XYZ image: ΔE00 (mean, 95th percentile; CIELAB relative to the illuminant's white) of

- ``dng:<cam>`` the view's own RAW file developed by :mod:`isp` with its DNG ColorMatrix (white → 1
  scale and exposure of the pipeline), only for the camera that took the view;
- ``<method>:<cams>`` the splat's render of the view through the channels of ``<cams>`` (one camera,
  pairs, all), corrected by Prior and Centroid with the pipeline's δ;

plus the held-out render PSNR per channel (render × exposure against the view's RAW mosaic on its valid
pixels; peak 1 = saturation) and the pose error of the recovered cameras against the true ones after a
similarity alignment (Umeyama 1991) of the camera centres.
"""

from __future__ import annotations

import itertools
import json
import os
from pathlib import Path

import numpy as np

__all__ = ["score", "similarity"]


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


def _dE(problem, est, ref):
    import colour

    w = problem.white_XYZ
    xy = colour.XYZ_to_xy(w)
    lab_e = colour.XYZ_to_Lab(est / w[1], xy)
    lab_r = colour.XYZ_to_Lab(ref / w[1], xy)
    d = np.asarray(colour.delta_E(lab_e, lab_r, method="CIE 2000")).ravel()
    return {"mean": float(np.mean(d)), "p95": float(np.percentile(d, 95))}


def score(
    capture: str | os.PathLike,
    out: str | os.PathLike,
    *,
    stride: int = 2,
    methods=("Prior", "Centroid"),
    subsets=None,
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

    Returns
    -------
    dict
    """
    import tifffile

    from zonotope.image import correct_image

    from .capture import load_views, read_capture
    from .colmap import read_colmap
    from .data import capture_from_colmap
    from .pipeline import _stem, delta_of, fit_corrector, white_of

    spec = read_capture(capture)
    out = Path(out)
    truth = spec.root / "truth"
    n = len(spec.cameras)
    subsets = subsets or [s for r in range(1, n + 1) for s in itertools.combinations(range(n), r)]
    raws = {v.name: v for v in load_views(spec)}
    white = white_of(spec, out, list(raws.values()))
    scale = np.concatenate(white["scale"])
    index = json.loads((out / "render" / "index.json").read_text())
    delta = delta_of(spec, out, index, scale)["delta"]
    held = [
        k
        for k, v in index.items()
        if v["kind"] == "holdout" and (truth / "xyz" / f"{_stem(k)}.tiff").is_file()
    ]
    rows: dict[str, list] = {}
    psnr: dict[str, list] = {}
    corr = {(m, s): fit_corrector(spec, list(s), m, delta) for m in methods for s in subsets}
    problem = corr[(methods[0], subsets[-1])].problem
    for name in held:
        ref = np.asarray(tifffile.imread(truth / "xyz" / f"{_stem(name)}.tiff"), float)
        d = out / "correct" / _stem(name)
        raw_dng = d / "raw_dng_XYZ.tiff"
        cam = raws[name].camera
        if raw_dng.is_file():
            est = np.asarray(tifffile.imread(raw_dng), float)
            rows.setdefault(f"dng:{spec.cameras[cam].folder}", []).append(_dE(problem, est, ref))
        render = np.asarray(tifffile.imread(out / "render" / _stem(name) / "render.tiff"), float)
        c = np.maximum(render / scale, 0)[::stride, ::stride]
        r = ref[::stride, ::stride]
        for (_m, s), cor in corr.items():
            idx = [3 * k + j for k in s for j in range(3)]
            est = correct_image(c[..., idx], cor, quantum=2e-3)
            label = f"{cor.method}:{'+'.join(spec.cameras[k].folder for k in s)}"
            rows.setdefault(label, []).append(_dE(problem, est, r))
        v = raws[name]
        pred = render[..., 3 * cam : 3 * cam + 3] * v.exif
        w = v.weight > 0
        for j in range(3):
            mse = np.mean((np.minimum(pred[..., j], 1) - v.values[..., j])[w[..., j]] ** 2)
            psnr.setdefault(f"{spec.cameras[cam].folder}:{'RGB'[j]}", []).append(
                float(10 * np.log10(1 / mse))
            )
    summary = {
        k: {
            "mean": float(np.mean([x["mean"] for x in v])),
            "p95": float(np.mean([x["p95"] for x in v])),
            "views": len(v),
        }
        for k, v in rows.items()
    }
    result = {
        "held_out_views": held,
        "delta_E00": summary,
        "psnr_db": {k: float(np.mean(v)) for k, v in psnr.items()},
        "delta": delta,
        "white": white["method"],
    }
    # pose error after a similarity alignment of the camera centres
    if (truth / "images.txt").is_file() and (out / "poses" / "model").is_dir():
        est = {v.name: v for v in capture_from_colmap(read_colmap(out / "poses" / "model")).views}
        tru = {v.name: v for v in capture_from_colmap(read_colmap(truth)).views}
        common = sorted(set(est) & set(tru))
        if len(common) >= 3:
            X = np.array([np.asarray(est[k].camera.centre, float) for k in common])
            Y = np.array([np.asarray(tru[k].camera.centre, float) for k in common])
            s, R, t = similarity(X, Y)
            err = np.linalg.norm(s * X @ R.T + t - Y, axis=1)
            ang = []
            for k in common:
                Re = np.asarray(est[k].camera.R, float) @ R.T  # world_true → cam, estimated
                Rt = np.asarray(tru[k].camera.R, float)
                cosang = (np.trace(Re @ Rt.T) - 1) / 2
                ang.append(float(np.degrees(np.arccos(np.clip(cosang, -1, 1)))))
            extent = float(np.linalg.norm(Y.max(0) - Y.min(0)))
            result["pose"] = {
                "registered": len(common),
                "of": len(tru),
                "centre_error_mean": float(err.mean()),
                "centre_error_max": float(err.max()),
                "scene_extent": extent,
                "rotation_error_deg_mean": float(np.mean(ang)),
            }
    p = out / "score.json"
    p.write_text(json.dumps(result, indent=1))
    return result
