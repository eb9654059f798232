"""The full-size output a user keeps (``full_XYZ.tiff``) against the truth, beside the working-size answer.

Scores a finished :mod:`bench_capture_accuracy` (or ``splat run``) work folder whose capture has truth
(``WORK/capture/truth/xyz``; the simulator's). For each held-out view, its fused responses (all cameras,
as the correct step makes them, ``fused_view``) give:

* **working answer**: Prior on the fused responses (``correct_fused``; the report's left image);
* **full-size output**: what the correct step writes as ``full_XYZ.tiff`` (``_full_resolution`` with the
  root-polynomial fit, :data:`splat.strips.FULL_METHOD`, into a temporary folder): at binning 1 the
  fused responses corrected (:func:`splat.strips.corrected_working`), else the strips;
* **strips**: the strip path forced (:func:`splat.strips.full_resolution_view` with the other cameras'
  photographs reprojected at full resolution, as the correct step prepares them), which the full-size
  output was at every binning before;
* **working answer sharpened**: the working answer upsampled bilinearly and multiplied by the ratio of
  the photograph's own channel sum to the upsampled fused one (the strips' Brovey ratio carried into
  the colour instead of the responses), an alternative for binnings above 1;
* **strips, training's depth rule**: the strips with the splat's depth at full resolution as it was
  before :data:`splat._tol.FULL_MIN_ALPHA` and :func:`splat.resolution.working_footprint`: rendered
  with the renderer's own 2-D dilation, a pixel lifted (and a source's depth vouching) from opacity
  :data:`splat.reproject.MIN_ALPHA`.

At a binning above 1 the working answer is scored upsampled bilinearly to the photograph's size. A run
made with ``--train-size`` is scored with the same ``--train-size`` (the views are read at its binning).

Printed per estimate: mean ΔE00 over all and flat pixels, and over the regions' mean colours (chart
patches, uniform surfaces: noise averaged), per camera and over the views; and the time of the last two
in one process (median over the views).

    python benchmarks/bench_full_output.py --work /tmp/acc_bench
    python benchmarks/bench_full_output.py --capture /tmp/acc_bench/capture --out /tmp/acc_f2 --train-size 255
"""

from __future__ import annotations

import argparse
import statistics
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

try:  # run as a script (python benchmarks/bench_X.py) or imported as benchmarks.bench_X
    from _workfolder import add_work_arguments, work_folders
except ImportError:
    from benchmarks._workfolder import add_work_arguments, work_folders


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    add_work_arguments(ap)
    ap.add_argument("--train-size", type=int, default=None, help="the run's --train-size, if it had one")
    a = ap.parse_args(argv)
    capture, out = work_folders(ap, a)

    import tifffile

    from splat import strips
    from splat.capture import (
        PipelineConfig,
        correct_fused,
        fused_fitter,
        fused_view,
        fusion_of,
        levelled_white,
        load_views,
        open_raw,
        read_capture,
        read_index,
        reprojected_of,
        white_of,
    )
    from splat.capture.config import working_binning
    from splat.capture.correct import _full_resolution, correction_problem_of, full_reprojection, own_noise
    from splat.fusion import ANCHOR_EPS
    from splat.reproject import MIN_ALPHA
    from splat.scoring import (
        _chart_XYZ,
        _dE_all,
        _region_dE,
        _truth_stem,
        correction_inputs,
        flat_mask,
        region_labels,
    )

    spec = read_capture(capture)
    if a.train_size is None:
        raws, index, _white, scale = correction_inputs(spec, out)
    else:  # the views at the run's binning, the white as the correct step levelled it
        binning = working_binning(PipelineConfig(train_size=a.train_size), spec)
        raws = {v.name: v for v in load_views(spec, binning=binning)}
        index = read_index(spec, out / "render" / "index.json")
        white = levelled_white(spec, out, index, raws, white_of(spec, out, list(raws.values())))
        scale = np.concatenate(white["scale"])
    fusion = fusion_of(spec, out, index, raws, scale)
    cams = list(range(len(spec.cameras)))
    prior, full_fit = fused_fitter(spec, cams, "Prior"), fused_fitter(spec, cams, strips.FULL_METHOD)
    problem = correction_problem_of(spec, cams)
    noise = own_noise(fusion, raws, scale, "auto")
    model = full_reprojection(spec, out, raws, fusion, scale)
    former = full_reprojection(spec, out, raws, fusion, scale, min_alpha=MIN_ALPHA)
    wXYZ = np.asarray(problem.white_XYZ, float)
    C = _chart_XYZ(spec)
    held = [k for k, v in index.items() if v["kind"] == "holdout"]
    keys = (
        "working answer",
        "full-size output",
        "strips",
        "working answer sharpened",
        "strips, training's depth rule",
    )
    rows = {k: {"all": [], "flat": [], "chart": [], "uniform": [], "camera": []} for k in keys}
    seconds: dict[str, list] = {"full-size output": [], "strips": []}
    tmp = Path(tempfile.mkdtemp(prefix="bench_full_output_"))
    for name in held:
        truth = np.asarray(tifffile.imread(capture / "truth" / "xyz" / f"{_truth_stem(name)}.tiff"), float)
        flat = flat_mask(truth).ravel()
        labels, chart = region_labels(truth, C)
        d = out / "render" / spec.out_stem(name)
        render = np.asarray(tifffile.imread(d / "render.tiff"), float) / scale
        v = raws[name]
        f, code, sigma = fused_view(fusion, name, render, v, scale, cams, reprojected_of(d, scale))
        k = v.camera
        own = slice(3 * k, 3 * k + 3)
        est = {"working answer": correct_fused(f, code, sigma, prior, 2e-3)}
        t0 = time.perf_counter()
        _full_resolution(spec, tmp, v, f, code, sigma, scale[own], noise[name], full_fit, wXYZ, None, model)
        seconds["full-size output"].append(time.perf_counter() - t0)
        est["full-size output"] = np.asarray(tifffile.imread(tmp / "full_XYZ.tiff"), float)
        t0 = time.perf_counter()
        source = open_raw(v.path, spec.cameras[k])
        rep = model(v, source.shape)
        rep = None if rep is None else rep.rep
        photo = strips.Photograph(source, v.exif, scale[own], np.asarray(noise[name]["sigma_full"], float))
        work = strips.WorkingFusion(f, code, sigma, own, v.binning)
        est["strips"] = np.concatenate(
            list(strips.full_resolution_view(photo, work, full_fit, reprojection=rep))
        )
        seconds["strips"].append(time.perf_counter() - t0)
        old = former(v, source.shape)
        old = None if old is None else old.rep._replace(binning=1)
        est["strips, training's depth rule"] = np.concatenate(
            list(strips.full_resolution_view(photo, work, full_fit, reprojection=old))
        )
        H, W = source.shape
        fb = v.binning
        up_answer = strips.upsample_rows(est["working answer"], fb, 0, H, W)
        lin, valid = strips.demosaic_rows(source, 0, H)
        photo_sum = np.maximum(lin / (v.exif * scale[own]), 0).sum(-1)
        fused_sum = np.maximum(strips.upsample_rows(f, fb, 0, H, W)[..., own], 0).sum(-1)
        ratio = (photo_sum + ANCHOR_EPS) / (fused_sum + ANCHOR_EPS)
        est["working answer sharpened"] = up_answer * np.where(valid, ratio, 1)[..., None]
        est["working answer"] = up_answer
        for key in keys:
            e = _dE_all(problem, est[key], truth)
            ch, un = _region_dE(problem, est[key], truth, labels, chart)
            r = rows[key]
            r["all"].append(e.mean())
            r["flat"].append(e[flat].mean())
            r["chart"].append(np.mean(ch) if ch else np.nan)
            r["uniform"].append(np.mean(un) if un else np.nan)
            r["camera"].append(spec.label(k))
        print(
            f"{name}: {source.shape[1]}×{source.shape[0]}, binning {v.binning}", file=sys.stderr, flush=True
        )
    print(f"{len(held)} held-out views; mean ΔE00 all / flat pixels, chart / uniform region means")
    labels_ = [spec.label(k) for k in cams]
    print("| estimate | all / flat | chart / uniform | " + " | ".join(labels_) + " |")
    for key in keys:
        r = rows[key]
        cam = np.array(r["camera"])
        ch, un = np.array(r["chart"]), np.array(r["uniform"])
        per = " | ".join(f"{np.nanmean(ch[cam == c]):.2f} / {np.nanmean(un[cam == c]):.2f}" for c in labels_)
        print(
            f"| {key} | {np.mean(r['all']):.2f} / {np.mean(r['flat']):.3f} | "
            f"{np.nanmean(r['chart']):.3f} / {np.nanmean(r['uniform']):.3f} | {per} |"
        )
    print(", ".join(f"{k}: median {statistics.median(v):.2f} s a view" for k, v in seconds.items()))
    return 0


if __name__ == "__main__":
    sys.exit(main())
