"""Automatic ColorChecker detection: how often the chart is found and how far its patch centres are.

Renders N scenes (linear sRGB, 600 × 900): a ColorChecker of colour-science's reference colours under
D65, at a random angle, pitch 30–65 px, perspective tilt of each corner up to 10 % of the chart's
width, mirrored in a quarter of them, 30 random flat rectangles of clutter, noise σ 0.01. Known patch
centres. Two detectors on the same scenes, in the same process:

- ``colour-checker-detection``: the package's own ``detect_colour_checkers_segmentation``, its
  patches sampled at the centres of a 6 × 4 division of the quadrilateral it returns, in the
  orientation it picks (the strongest simple baseline: what the package gives a user);
- ``isp``: :func:`isp.profiles.chart_detect.detect_chart_rgb` (the same segmenter; its own grouping,
  grid fit, orientation and consistency check).

A scene counts as found when patch 1 comes first and every centre is within a quarter of the pitch
(the patch box then lies inside the patch); the error columns are over the found scenes.

    python benchmarks/bench_chart_detect.py --scenes 40
    python benchmarks/bench_chart_detect.py --scenes 12 --pitch 12 20   # small charts
"""

from __future__ import annotations

import argparse
import time
import warnings

import colour
import numpy as np

from isp.profiles.chart import ChartError, chart_reference
from isp.profiles.chart_detect import _apply, _homography, detect_chart_rgb

BOX = np.array([[-0.4, -0.4], [6.4, -0.4], [6.4, 4.4], [-0.4, 4.4]])
GRID = np.array([(j + 0.5, i + 0.5) for i in range(4) for j in range(6)])


def scene(rng, size=(600, 900), pitches=(30, 65)):
    """(image, true centres, pitch, mirrored) of one random scene."""
    H, W = size
    pitch, angle, tilt = rng.uniform(*pitches), rng.uniform(-180, 180), rng.uniform(0, 0.1)
    mirror = bool(rng.random() < 0.25)
    c, s = np.cos(np.radians(angle)), np.sin(np.radians(angle))
    R = pitch * np.array([[c, s], [-s, c]]) @ np.diag([1, -1 if mirror else 1])
    body = (BOX - [3, 2]) @ R.T + [W / 2, H / 2] + rng.uniform(-tilt, tilt, (4, 2)) * 6 * pitch
    Hm = _homography(BOX, body)
    XYZ, _, white = chart_reference("colorchecker", "D65")
    ref = colour.XYZ_to_sRGB(
        XYZ, colour.XYZ_to_xy(white), chromatic_adaptation_transform="Bradford", apply_cctf_encoding=False
    )
    yy, xx = np.mgrid[0:H, 0:W]
    img = np.ones((H, W, 3)) * rng.uniform(0.15, 0.45, 3) * (0.6 + 0.4 * xx / W)[..., None]
    for _ in range(30):
        x0, y0, w, h = rng.uniform(0, W), rng.uniform(0, H), *rng.uniform(10, 120, 2)
        img[int(y0) : int(y0 + h), int(x0) : int(x0 + w)] = rng.uniform(0.02, 0.9, 3)
    acc = np.zeros_like(img)
    Hi = np.linalg.inv(Hm)
    for dy in (-0.25, 0.25):
        for dx in (-0.25, 0.25):
            u, v = _apply(Hi, np.column_stack([xx.ravel() + dx, yy.ravel() + dy])).T.reshape(2, H, W)
            inside = (u > -0.4) & (u < 6.4) & (v > -0.4) & (v < 4.4)
            j, i = np.clip(np.floor(u), 0, 5).astype(int), np.clip(np.floor(v), 0, 3).astype(int)
            patch = inside & (np.abs(u - j - 0.5) < 0.42) & (np.abs(v - i - 0.5) < 0.42)
            acc += np.where(inside[..., None], np.where(patch[..., None], ref[i * 6 + j], 0.03), img) / 4
    return acc + rng.normal(0, 0.01, acc.shape), _apply(Hm, GRID), pitch, mirror


def package_centres(image):
    """Patch centres as colour-checker-detection samples them (first chart it returns), or None."""
    import cv2
    from colour_checker_detection import SETTINGS_SEGMENTATION_COLORCHECKER_CLASSIC as S
    from colour_checker_detection import detect_colour_checkers_segmentation

    found = detect_colour_checkers_segmentation(np.clip(image, 0, 1).astype(np.float32), additional_data=True)
    if not found:
        return None
    d = found[0]
    w, h = S["working_width"], int(S["working_width"] / S["aspect_ratio"])
    rect = np.array([[w, 0], [w, h], [0, h], [0, 0]], dtype=np.float32)
    M = cv2.getPerspectiveTransform(np.asarray(d.quadrilateral, np.float32), rect)
    m = np.asarray(d.swatch_masks, dtype=np.float64)
    centres = _apply(np.linalg.inv(M), np.column_stack([(m[:, 2] + m[:, 3]) / 2, (m[:, 0] + m[:, 1]) / 2]))
    scale = image.shape[1] / S["working_width"]
    return (centres + 0.5) * scale - 0.5


def isp_centres(image):
    try:
        return detect_chart_rgb(image, illuminant="D65").centres
    except ChartError:
        return None


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--scenes", type=int, default=40)
    p.add_argument("--seed", type=int, default=0)
    p.add_argument(
        "--pitch", type=float, nargs=2, default=[30, 65], metavar=("LO", "HI"), help="patch pitch, px"
    )
    args = p.parse_args()
    warnings.simplefilter("ignore")
    rng = np.random.default_rng(args.seed)
    rows = {"colour-checker-detection": [], "isp": []}
    times = {k: [] for k in rows}
    mirrored = 0
    for _ in range(args.scenes):
        image, truth, pitch, mirror = scene(rng, pitches=args.pitch)
        mirrored += mirror
        for name, fn in (("colour-checker-detection", package_centres), ("isp", isp_centres)):
            t = time.perf_counter()
            c = fn(image)
            times[name].append(time.perf_counter() - t)
            err = None if c is None else np.linalg.norm(c - truth, axis=1)
            ok = err is not None and err.max() < 0.25 * pitch
            rows[name].append((ok, err.max() if ok else np.nan, err.mean() if ok else np.nan))
    print(
        f"{args.scenes} scenes ({mirrored} mirrored), pitch {args.pitch[0]:g}–{args.pitch[1]:g} px, "
        f"seed {args.seed}"
    )
    print("| detector | found | centre error mean / max px (found scenes) | median s |")
    print("|---|---:|---:|---:|")
    for name, r in rows.items():
        ok = np.array([x[0] for x in r])
        mx, mn = np.array([x[1] for x in r]), np.array([x[2] for x in r])
        print(
            f"| {name} | {ok.sum()}/{len(ok)} | {np.nanmean(mn):.2f} / {np.nanmax(mx):.2f} | "
            f"{np.median(times[name]):.2f} |"
        )


if __name__ == "__main__":
    main()
