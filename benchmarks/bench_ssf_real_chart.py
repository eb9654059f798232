"""SSF estimation from a real camera's own files: the Canon EOS 550D (Kiss X4) chart DNG.

The other SSF benchmarks synthesise the DNG matrices and simulate the chart photograph from measured
curves. Here both come from a real file (``raw_samples/tinydng_colorchart_Canon_EOS_Kiss_X4_MagicLantern.dng``
of the shared data): its ColorMatrix1 (D65; Magic Lantern writes no second matrix and no
ForwardMatrix) and its photographed ColorChecker (found by :func:`isp.profiles.chart_detect.detect_chart`,
read by :func:`isp.profiles.chart.read_chart`; the light is tungsten, taken as CIE A). Nobody
measured the 550D's curves; the Canon 600D (rawtoaces and camspec) and the 60D (camspec) carry the
same 18 MP APS-C sensor generation and stand in for the truth. Their spread is printed first: no
estimate can be judged closer to the 550D than the stand-ins are to each other. Every estimate's basis
is learned without the 600D and the 60D.

Tables: curve RMSE / angle per channel against each stand-in; the chart's raw patch means predicted
from each curve set under A with one gain per channel (for the DNG-only estimate a prediction of
measurements it never saw; for the chart estimates, half the patches predicted from the other half);
and the correction ΔE00 of a regression fitted on each curve set, applied to each stand-in's
responses (natural sets, noise-free and σ = 0.005), against the fit on that stand-in's own curves.

    python benchmarks/bench_ssf_real_chart.py --data ../shared/data
"""

from __future__ import annotations

import argparse
import dataclasses
import sys
import time
from pathlib import Path

import colour
import numpy as np

import zonotope
from zonotope.spectra import builtin as spectra
from zonotope.spectra.estimate import (
    SSF_SHAPE,
    Chart,
    DNGMatrices,
    estimate_ssf,
    learn_ssf_basis,
    read_dng_matrices,
    ssf_basis,
)

sys.path.insert(0, str(Path(__file__).parent))
from bench_ssf import W, curve_errors, jiang2013, measured_cameras, msds

DNG = "raw_samples/tinydng_colorchart_Canon_EOS_Kiss_X4_MagicLantern.dng"
#: The stand-ins for the 550D's curves (same sensor generation), by measured-camera name.
STAND_INS = ("Canon EOS 600D (rawtoaces)", "Canon 600D (camspec)", "Canon 60D (camspec)")
#: Model keys left out of every basis (bench_ssf._model_key of the stand-ins).
HELD_MODELS = ("canon600d", "canon60d")
LIGHT = "A"
#: The prior weight the shipped basis gives a DNG alone (its real-DNG calibration); this script's own
#: basis, learned without the stand-ins, has no such calibration.
REAL_PRIOR = ssf_basis().real_dng.prior
REFLECTANCES = "ColorChecker N Ohta"


def chart_means(path: Path) -> np.ndarray:
    """The real photograph's raw patch means (24 × 3, black subtracted, 1 = saturation)."""
    from isp.profiles.chart import read_chart
    from isp.profiles.chart_detect import detect_chart

    found = detect_chart(path, illuminant=LIGHT)
    reading = read_chart(path, found.corners)
    print(
        f"chart: {found.squares} squares segmented, fit ΔE00 {found.delta_E:.2f} under {LIGHT}; white patch "
        f"raw {np.round(reading.rgb[18], 4).tolist()} of saturation",
        file=sys.stderr,
    )
    return reading.rgb


def predicted(values: np.ndarray, patches=slice(None)) -> np.ndarray:
    """Raw means of the ColorChecker under A through ``values`` (31 × 3), before any gain."""
    R = spectra.resample(zonotope.reflectances(REFLECTANCES), W).T[patches]
    E = spectra.resample(zonotope.illuminant(LIGHT), W)[:, 0]
    return (R * E) @ values


def gain_residual(P: np.ndarray, C: np.ndarray) -> tuple[float, np.ndarray]:
    """Relative RMS of C − g·P, one least-squares gain g per channel (exposure and light level unknown)."""
    g = np.sum(P * C, axis=0) / np.sum(P * P, axis=0)
    return float(np.sqrt(np.mean((C - g * P) ** 2) / np.mean(C**2))), g


def split_chart_residual(C: np.ndarray, basis, dng=None) -> float:
    """Estimate from alternate patches, predict the other half; relative RMS over both halves."""
    refl = spectra.resample(zonotope.reflectances(REFLECTANCES), W)
    err, norm = 0.0, 0.0
    for fit_idx, test_idx in (
        (np.arange(0, 24, 2), np.arange(1, 24, 2)),
        (np.arange(1, 24, 2), np.arange(0, 24, 2)),
    ):
        sub = colour.MultiSpectralDistributions(refl[:, fit_idx], W, name="half chart")
        e = estimate_ssf(dng, chart=Chart(C[fit_idx], sub, LIGHT), basis=basis).values
        P = predicted(e, test_idx)
        g = np.sum(P * C[test_idx], axis=0) / np.sum(P * P, axis=0)
        err += np.sum((C[test_idx] - g * P) ** 2)
        norm += np.sum(C[test_idx] ** 2)
    return float(np.sqrt(err / norm))


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--data", type=Path, required=True, help="folder laid out like ../shared/data")
    p.add_argument("--components", type=int, default=5)
    p.add_argument("--seed", type=int, default=0)
    p.add_argument(
        "--colordata",
        type=Path,
        help="LibRaw's src/tables/colordata.cpp: also estimate from Adobe's 550D matrix as LibRaw carries it",
    )
    args = p.parse_args(argv)
    path = args.data / DNG
    if not path.is_file():
        p.error(f"{path}: not found; --data must be a folder laid out like ../shared/data.")
    cams = measured_cameras(args.data)
    missing = [s for s in STAND_INS if s not in cams]
    if missing:
        p.error(f"--data: no measured curves for {', '.join(missing)}.")
    t0 = time.perf_counter()
    pool = {
        n: c["values"]
        for n, c in cams.items()
        if c["model"] not in HELD_MODELS and c["redistributable"] and c["set"] != "spectroscope"
    }
    basis = learn_ssf_basis(pool, n_components=args.components)
    with_real_dng = dataclasses.replace(basis, real_dng=ssf_basis().real_dng)
    C = chart_means(path)
    dng = read_dng_matrices(path)
    chart = Chart(C, REFLECTANCES, LIGHT, name="550D chart")
    mean = np.mean([v / v.max(axis=0) for v in pool.values()], axis=0)
    curves = {
        "mean camera (no data)": mean,
        "DNG matrix (ColorMatrix1, D65), exact-matrix prior": estimate_ssf(dng, basis=basis).values,
        "DNG matrix, real-DNG prior (the default)": estimate_ssf(dng, basis=basis, prior=REAL_PRIOR).values,
        "chart, colour Jiang 2013": np.maximum(jiang2013(C, pool, light=LIGHT), 0.0),
        "chart": estimate_ssf(chart=chart, basis=basis).values,
        # with the shipped real-DNG calibration, as the default basis: it sets the matrices' weight
        "DNG + chart": estimate_ssf(dng, chart=chart, basis=with_real_dng).values,
        "DNG + chart, matrices trusted as exact fits": estimate_ssf(dng, chart=chart, basis=basis).values,
    }
    if args.colordata:
        from real_matrices import colour_matrix, read_colordata

        adobe = colour_matrix(read_colordata(args.colordata), "Canon EOS 550D")
        print(f"the file's ColorMatrix1 − Adobe's (LibRaw):\n{np.round(dng.color_matrices[0] - adobe, 4)}")
        curves["Adobe's 550D matrix (LibRaw, D65)"] = estimate_ssf(
            DNGMatrices((adobe,), ("D65",)), basis=basis, prior=REAL_PRIOR
        ).values
    print(f"{len(pool)} basis cameras; estimates in {time.perf_counter() - t0:.1f} s", file=sys.stderr)
    refs = {s: cams[s]["values"] for s in STAND_INS}

    print(
        "\n**Curves** — RMSE R / G / B (peak 1 per channel) and angle R / G / B (°) against each stand-in.\n"
    )
    print("| curves | " + " | ".join(STAND_INS) + " | mean |")
    print("|---|" + "---|" * (len(STAND_INS) + 1))
    rows = {f"{s} (measured)": v for s, v in refs.items()} | curves
    for name, v in rows.items():
        cells, rm, am = [], [], []
        for s in STAND_INS:
            if rows.get(f"{s} (measured)") is v:
                cells.append("—")
                continue
            r, a = curve_errors(v, refs[s])
            rm.append(r)
            am.append(a)
            cells.append(f"{'/'.join(f'{x:.3f}' for x in r)}; {'/'.join(f'{x:.1f}' for x in a)}°")
        r, a = np.mean(rm, axis=0), np.mean(am, axis=0)
        print(
            f"| {name} | "
            + " | ".join(cells)
            + f" | {'/'.join(f'{x:.3f}' for x in r)}; {'/'.join(f'{x:.1f}' for x in a)}° |"
        )

    print(
        "\n**The real chart predicted** — relative RMS of the 24 raw patch means minus the curves' prediction"
    )
    print("under A with one gain per channel (ColorChecker N Ohta reflectances).\n")
    print("| curves | residual | gains R / G / B (G = 1) | kind |")
    print("|---|---|---|---|")
    for name, v in rows.items():
        res, g = gain_residual(predicted(v), C)
        kind = "fitted to this chart" if "chart" in name else "never saw the chart"
        print(f"| {name} | {res:.4f} | {'/'.join(f'{x:.3f}' for x in g / g[1])} | {kind} |")
    for name, d in (("chart", None), ("DNG + chart", dng)):
        res = split_chart_residual(C, with_real_dng, d)
        print(f"| {name}, half predicted from the other half | {res:.4f} | — | held-out patches |")

    correction_table(rows, refs, args.data, seed=args.seed)
    print(f"\ntotal {time.perf_counter() - t0:.0f} s", file=sys.stderr)
    return 0


def correction_table(rows: dict, refs: dict, data: Path, *, seed: int) -> None:
    """ΔE00 of regressions fitted on each curve set, applied to each stand-in's responses."""
    from zonotope.correct import correction_problem, fit_correction, noise_options
    from zonotope.evaluate import natural_test_sets

    tests = natural_test_sets(W, data_dir=data, size=150, seed=seed)
    print("\n**Correction** — mean ΔE00 over the natural sets (D65), a regression fitted on the curves of")
    print(
        "the row, applied to the responses of the column's stand-in; in brackets the difference to the fit on"
    )
    print("that stand-in's own curves (the measured-curve baseline).\n")
    for method in ("Cheung 2004", "Finlayson 2015"):
        for sigma in (0.0, 0.005):
            print(f"\n{method}, σ = {sigma:g}\n")
            print("| fitted on | " + " | ".join(STAND_INS) + " | mean difference |")
            print("|---|" + "---|" * (len(STAND_INS) + 1))
            fits = {}
            for name, v in rows.items():
                problem = correction_problem([msds(v, name)], shape=SSF_SHAPE)
                fits[name] = fit_correction(
                    problem, method=method, **(noise_options(method, sigma) if sigma else {})
                )
            base = {}
            for s in STAND_INS:
                truth = correction_problem([msds(refs[s], s)], shape=SSF_SHAPE)
                dE = []
                for ts in tests:
                    Cr = truth.source_of(ts.reflectances)
                    if sigma:
                        Cr = Cr + sigma * np.random.default_rng([seed, 1]).standard_normal(Cr.shape)
                    dE.append(
                        {
                            n: float(np.mean(truth.delta_E(f(Cr), truth.target_of(ts.reflectances))))
                            for n, f in fits.items()
                        }
                    )
                base[s] = {n: float(np.mean([d[n] for d in dE])) for n in fits}
            for name in rows:
                cells, diffs = [], []
                for s in STAND_INS:
                    own = base[s][f"{s} (measured)"]
                    v = base[s][name]
                    if name == f"{s} (measured)":
                        cells.append(f"**{v:.3f}**")
                        continue
                    diffs.append(v - own)
                    cells.append(f"{v:.3f} ({v - own:+.3f})")
                print(f"| {name} | " + " | ".join(cells) + f" | {np.mean(diffs):+.3f} |")


if __name__ == "__main__":
    sys.exit(main())
