"""The fused correction's per-pixel uncertainty map against the truth: coverage, rank and cost.

Scores a finished :mod:`bench_capture_accuracy` (or ``splat run``) work folder whose capture has truth
(``WORK/capture/truth/xyz``; the simulator's): for each held-out view, its fused responses (all
cameras, as the correct step makes them) corrected by Prior, every ``--stride``-th pixel, and per pixel

* the map the correct step writes (:func:`splat.capture.correct.fused_uncertainty`: the 95 % credible
  radius of the Gaussian natural-reflectance posterior, closed form, the rendered channels told the
  render's local error against the view's own sites, :func:`splat.fusion.render_error`);
* with ``--prior-radius``, Prior's own credible radius (:meth:`zonotope.correct.Corrector.with_uncertainty`,
  which computes an MMV wherever its gate opens), for comparison, on the same pixels.

Printed: the share of pixels whose true colour (ΔE00 of the correction against the truth) lies within the
radius (coverage; the claim is 95 % under the model), on all and on flat pixels; Spearman's rank
correlation of radius and error; coverage and median error per radius band; and each radius' time,
summed over the views in one process (the correction's own time beside it).

    python benchmarks/bench_uncertainty_map.py --work /tmp/acc_bench --stride 4 --prior-radius
    python benchmarks/bench_uncertainty_map.py --capture /tmp/ucap --out /tmp/uout --stride 2 --prior-radius
"""

from __future__ import annotations

import argparse
import sys
import time

import numpy as np

try:  # run as a script (python benchmarks/bench_X.py) or imported as benchmarks.bench_X
    from _workfolder import add_work_arguments, work_folders
except ImportError:
    from benchmarks._workfolder import add_work_arguments, work_folders

QUANTUM = 2e-3  #: the colour deduplication step of the corrections, bench_capture_accuracy's


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    add_work_arguments(ap)
    ap.add_argument("--stride", type=int, default=4, help="every n-th pixel of each view")
    ap.add_argument("--views", type=int, default=0, help="at most this many held-out views (0: all)")
    ap.add_argument("--prior-radius", action="store_true", help="also Prior's own radius (slow)")
    a = ap.parse_args(argv)
    capture, out = work_folders(ap, a)

    import tifffile
    from scipy.stats import spearmanr

    from splat.capture import correct_fused, fused_fitter, fused_view, fusion_of, read_capture, reprojected_of
    from splat.capture.correct import correction_problem_of, fused_uncertainty, ssf_sigma
    from splat.fusion import render_error
    from splat.scoring import _dE_all, _truth_stem, correction_inputs, flat_mask

    spec = read_capture(capture)
    raws, index, _white, scale = correction_inputs(spec, out)
    fusion = fusion_of(spec, out, index, raws, scale)
    cams = list(range(len(spec.cameras)))
    fit = fused_fitter(spec, cams, "Prior")
    problem = correction_problem_of(spec, cams)
    band = ssf_sigma(spec, cams)
    band = band if band.any() else None
    held = [k for k, v in index.items() if v["kind"] == "holdout"]
    held = held[: a.views] if a.views else held
    s = a.stride
    radii: dict[str, list] = {"map": [], "Prior": []}
    errors, flats = [], []
    seconds = {"correction": 0.0, "map": 0.0, "Prior": 0.0}
    for name in held:
        truth = np.asarray(tifffile.imread(capture / "truth" / "xyz" / f"{_truth_stem(name)}.tiff"))
        ref, flat = truth[::s, ::s].astype(float), flat_mask(truth.astype(float))[::s, ::s]
        d = out / "render" / spec.out_stem(name)
        render = np.asarray(tifffile.imread(d / "render.tiff"), float) / scale
        f, code, sigma = fused_view(fusion, name, render, raws[name], scale, cams, reprojected_of(d, scale))
        f, code = f[::s, ::s], code[::s, ::s]
        t0 = time.perf_counter()
        est = correct_fused(f, code, sigma, fit, QUANTUM)
        t1 = time.perf_counter()
        own = slice(3 * raws[name].camera, 3 * raws[name].camera + 3)  # as the correct step tells its map
        local = render_error(raws[name], scale[own], render[..., own])[::s, ::s]
        rendered = (fusion["render_sigma"], local * np.maximum(f, 0).mean(-1))
        radii["map"].append(fused_uncertainty(problem, est, code, sigma, band, rendered=rendered).ravel())
        t2 = time.perf_counter()
        seconds["correction"] += t1 - t0
        seconds["map"] += t2 - t1
        if a.prior_radius:
            r = np.zeros(code.shape)
            for cd, s_ in sigma.items():
                sel = code == cd
                if sel.any():
                    cor, w = fit(s_)
                    r[sel] = cor.with_uncertainty(f[sel] * w)[1]
            seconds["Prior"] += time.perf_counter() - t2
            radii["Prior"].append(r.ravel())
        errors.append(_dE_all(problem, est, ref))
        flats.append(flat.ravel())
        print(f"{name}: {code.size} px", file=sys.stderr, flush=True)
    e, fl = np.concatenate(errors), np.concatenate(flats)
    print(f"{len(held)} held-out views, every {s}th pixel: {e.size} px ({fl.sum()} flat)")
    print(f"median ΔE00 of the correction: all {np.median(e):.2f}, flat {np.median(e[fl]):.2f}")
    print(
        f"time, summed over the views: correction {seconds['correction']:.2f} s, "
        + ", ".join(f"{k} radius {seconds[k]:.2f} s" for k in radii if radii[k])
    )
    for k, v in radii.items():
        if not v:
            continue
        r = np.concatenate(v)
        print(
            f"{k}: median radius {np.median(r):.2f} (flat {np.median(r[fl]):.2f}); coverage all "
            f"{np.mean(e <= r):.3f}, flat {np.mean(e[fl] <= r[fl]):.3f}; Spearman(radius, error) all "
            f"{spearmanr(r, e)[0]:.2f}, flat {spearmanr(r[fl], e[fl])[0]:.2f}"
        )
        for lo, hi in ((0, 1), (1, 2), (2, 4), (4, 8), (8, np.inf)):
            m = (r >= lo) & (r < hi)
            if m.any():
                print(
                    f"    radius {lo}–{hi}: {m.mean():.3f} of the pixels, coverage "
                    f"{np.mean(e[m] <= r[m]):.3f}, median error {np.median(e[m]):.2f}"
                )
    return 0


if __name__ == "__main__":
    sys.exit(main())
