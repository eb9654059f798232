"""Why stacked cameras with estimated sensitivities lose accuracy, and what repairs it.

Leave one camera model out (as ``bench_ssf.py``): every held-out camera is estimated from DNG matrices
synthesised from its measured curves, with the basis learned without its model. For random sets of
1–3 cameras, a correction is fitted on the estimated curves and applied to the responses of the
measured cameras (the honest setting), against the same correction fitted on the measured curves.
Diagnostics per set: the correction applied to the estimated cameras' own responses (is the stacked
problem with estimated curves itself easy?), the correlation between different cameras' response
errors (do their estimates share the basis' errors?), and the gain of the fitted matrix on those
errors. Fits compared, all in one process:

* ``none``: noise-free (the fit trusts the estimated curves exactly);
* ``band``: told the band's response σ (``SSFEstimate.response_sigma``, fully correlated: an upper bound);
* ``calibrated``: told ``SSFEstimate.response_sigma()`` (the default: the bound times the basis'
  ``response_scale``), the scale calibrated on the other models' estimates only;
* ``draws`` (``--draws``): a regression fitted on 16 camera sets drawn within the band (errors in
  the variables with the band's wavelength correlation);
* ``one camera``: the first camera of the set alone (do not stack);
* ``oracle σ``: told the set's true response error RMS (ground truth; no user has it, a bound).

    python benchmarks/bench_ssf_stack.py --data ../shared/data            # docs/benchmarks.md table
    python benchmarks/bench_ssf_stack.py --data ../shared/data --sets 6   # quick
"""

from __future__ import annotations

import argparse
import dataclasses
import sys
import time
from pathlib import Path

import numpy as np

from zonotope.correct import NoiseModel, correction_problem, fit_correction, noise_options
from zonotope.evaluate import atypical_test_sets, natural_test_sets
from zonotope.spectra.estimate import SSF_SHAPE, estimate_ssf, ssf_basis, synthesise_dng_matrices

sys.path.insert(0, str(Path(__file__).parent))
from bench_ssf import basis_without, measured_cameras, msds

W = np.asarray(SSF_SHAPE.wavelengths)
METHODS = ("Cheung 2004", "Finlayson 2015")
FITS = ("measured", "none", "band", "calibrated", "one camera", "oracle σ")


def training_responses(values: np.ndarray, name: str) -> np.ndarray:
    """White-balanced responses (white → 1) to the 190 training reflectances under D65."""
    pb = correction_problem(msds(values, name), shape=SSF_SHAPE)
    return pb.training @ pb.Phi


def held_out_estimates(cams: dict[str, dict]) -> dict:
    """Every camera's DNG-matrix estimate with the basis learned without its model."""
    out = {}
    for n, c in cams.items():
        basis = basis_without(cams, c["model"], redistributable_only=True, k=5)
        out[n] = estimate_ssf(synthesise_dng_matrices(msds(c["values"], n)), basis=basis, name=n)
    return out


def fit_on_draws(estimates, method: str, sigma: float, *, n: int = 16, seed: int = 0):
    """A regression fitted on the responses of ``n`` camera sets drawn within the estimates' bands."""
    from zonotope.correct.regressions import expected_normal_equations, root_polynomial_terms
    from zonotope.spectra.estimate import sample_ssfs

    degree = 1 if method == "Cheung 2004" else 2
    draws = [sample_ssfs(e, n, seed=seed + i) for i, e in enumerate(estimates)]
    G = B = 0.0
    k = 3 * len(estimates)
    noise = NoiseModel(np.zeros(k), np.full(k, sigma**2), source="sensor")
    for d in range(n):
        pb = correction_problem([dr[d] for dr in draws], shape=SSF_SHAPE)
        g, b = expected_normal_equations(
            pb.source_of(pb.training), pb.target_of(pb.training), noise, degree=degree
        )
        G, B = G + g, B + b
    M = np.linalg.solve(G + 1e-9 * np.trace(G) / G.shape[0] * np.eye(G.shape[0]), B)
    if degree == 1:
        return lambda c: c @ M
    return lambda c: root_polynomial_terms(c, degree=degree) @ M


def mmv_table(cams, est, err, bound, calibrated, a) -> int:
    """Centroid and Prior (MMV-based; told σ through their δ / noise) on estimated curves, noise-free
    ColorChecker and CIE 1995 TCS responses of the measured cameras: δ = 0 vs the calibrated σ."""
    import zonotope
    from zonotope.spectra import builtin as spectra

    names = list(cams)
    rng = np.random.default_rng(a.seed + 1)
    R = np.concatenate(
        [
            spectra.resample(zonotope.load_reflectances(n), W).T
            for n in ("ColorChecker N Ohta", "CIE 1995 TCS")
        ]
    )
    acc: dict = {}
    for size in (2, 3):
        k = 0
        while k < a.mmv_sets:
            pick = list(rng.choice(names, size, replace=False))
            models = {cams[n]["model"] for n in pick}
            if len(models) < size:
                continue
            k += 1
            truth = correction_problem([msds(cams[n]["values"], n) for n in pick], shape=SSF_SHAPE)
            eprob = correction_problem([est[n].sensitivities for n in pick], shape=SSF_SHAPE)
            cal = np.concatenate([calibrated(n, models) for n in pick])
            model = NoiseModel(np.zeros(3 * size), cal**2, source="calibrated")
            C, T = truth.source_of(R), truth.target_of(R)
            for m in ("Finlayson 2015", "Centroid", "Prior"):
                for fit_name, pb, opts in (
                    ("measured", truth, {}),
                    ("none (δ = 0)", eprob, {}),
                    ("calibrated", eprob, noise_options(m, model)),
                ):
                    t0 = time.perf_counter()
                    dE = truth.delta_E(fit_correction(pb, method=m, **opts)(C), T)
                    acc.setdefault((size, m, fit_name), []).append(float(np.mean(dE)))
                    print(
                        f"{size} {m} {fit_name}: {np.mean(dE):.3f} ({time.perf_counter() - t0:.0f} s)",
                        file=sys.stderr,
                        flush=True,
                    )
    print(
        f"\nMMV estimators, {a.mmv_sets} sets each, ColorChecker + CIE 1995 TCS, noise-free responses of the "
        "measured cameras (mean ΔE00):\n"
    )
    print("| cameras | method | measured | none (δ = 0) | calibrated |")
    print("|---|---|---|---|---|")
    for size in (2, 3):
        for m in ("Finlayson 2015", "Centroid", "Prior"):
            row = [np.mean(acc[size, m, f]) for f in ("measured", "none (δ = 0)", "calibrated")]
            print(
                f"| {size} | {m} | {row[0]:.3f} | {row[1]:.3f} ({row[1] - row[0]:+.2f}) "
                f"| {row[2]:.3f} ({row[2] - row[0]:+.2f}) |"
            )
    return 0


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--data", type=Path)
    ap.add_argument("--sets", type=int, default=20, help="random sets of each size")
    ap.add_argument("--singles", type=int, default=40, help="one-camera sets (every k-th camera)")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--mmv-sets", type=int, default=0, help="only the MMV estimators on N sets of 2 and 3")
    ap.add_argument("--draws", action="store_true", help="also fit on 16 cameras drawn in the band (slow)")
    a = ap.parse_args(argv)
    fit_names = (*FITS, "draws") if a.draws else FITS
    cams = measured_cameras(a.data)
    names = list(cams)
    t0 = time.perf_counter()
    est = held_out_estimates(cams)
    err = {n: training_responses(cams[n]["values"], n) - training_responses(est[n].values, n) for n in names}
    bound = {n: est[n].response_sigma(bound=True) for n in names}
    print(f"{len(names)} cameras estimated in {time.perf_counter() - t0:.0f} s", file=sys.stderr)

    # response_scale as the shipped basis calibrates it (bench_ssf.calibrate_band), from the OTHER models
    def calibrated(n: str, exclude: set[str]) -> np.ndarray:
        others = [m for m in names if cams[m]["model"] not in exclude]
        real = np.sqrt(np.mean(np.square(np.concatenate([err[m] for m in others])), axis=0))
        scale = real / np.sqrt(np.mean(np.square([bound[m] for m in others]), axis=0))
        return dataclasses.replace(est[n], response_scale=scale).response_sigma()

    shipped = ssf_basis()
    for k, label in ((2.0, "±2σ"), (shipped.band_k, f"±band_k = ±{shipped.band_k:.2f}σ")):
        cover: dict[str, list] = {}
        for n in names:
            e, t = est[n].values, cams[n]["values"]
            inside = np.abs(e / e.max(axis=0) - t / t.max(axis=0)) <= k * shipped.spread
            cover.setdefault(cams[n]["set"], []).append(inside.mean())
            cover.setdefault("all", []).append(inside.mean())
        print(
            f"measured curve within {label} of the estimate (fraction of wavelengths × channels): "
            + ", ".join(f"{d} {100 * np.mean(v):.0f} %" for d, v in cover.items())
        )
    ratio = np.array([np.sqrt(np.mean(np.square(err[n]), axis=0)) / bound[n] for n in names])
    print(
        "real response error RMS / fully correlated bound, median over cameras (R, G, B): "
        + " / ".join(f"{v:.2f}" for v in np.median(ratio, axis=0))
    )

    if a.mmv_sets:
        return mmv_table(cams, est, err, bound, calibrated, a)
    rng = np.random.default_rng(a.seed)
    step = max(1, len(names) // a.singles)
    sets = [[n] for n in names[::step]]
    for size in (2, 3):
        k = 0
        while k < a.sets:
            pick = list(rng.choice(names, size, replace=False))
            if len({cams[n]["model"] for n in pick}) == size:
                sets.append(pick)
                k += 1
    tests = natural_test_sets(W, data_dir=a.data, size=150, seed=a.seed) + atypical_test_sets(
        W, 100, seed=a.seed
    )
    acc: dict = {}
    diag: dict = {}
    t0 = time.perf_counter()
    for cam_set in sets:
        size = len(cam_set)
        truth = correction_problem([msds(cams[n]["values"], n) for n in cam_set], shape=SSF_SHAPE)
        eprob = correction_problem([est[n].sensitivities for n in cam_set], shape=SSF_SHAPE)
        one = correction_problem([est[cam_set[0]].sensitivities], shape=SSF_SHAPE)
        band = np.concatenate([bound[n] for n in cam_set])
        models = {cams[m]["model"] for m in cam_set}
        cal = np.concatenate([calibrated(n, models) for n in cam_set])
        oracle = np.sqrt(np.mean(np.square(np.concatenate([err[n] for n in cam_set], axis=1)), axis=0))
        if size > 1:  # correlation of different cameras' response errors, same channel
            e = [err[n] for n in cam_set]
            r = [
                np.corrcoef(e[i][:, c], e[j][:, c])[0, 1]
                for i in range(size)
                for j in range(i + 1, size)
                for c in range(3)
            ]
            diag.setdefault((size, "error correlation between cameras"), []).append(np.mean(r))
        for sigma in (0.0, 0.005):
            for m in METHODS:
                fits = {}
                for fit_name in fit_names:
                    if fit_name == "draws":
                        fits[fit_name] = fit_on_draws([est[n] for n in cam_set], m, sigma, seed=a.seed)
                        continue
                    told = {"band": band, "calibrated": cal, "oracle σ": oracle}.get(fit_name, 0.0)
                    told = np.sqrt(sigma**2 + np.square(told))
                    pb = {"measured": truth, "one camera": one}.get(fit_name, eprob)
                    if fit_name == "one camera":
                        told = told[:3] if np.ndim(told) else told
                    model = NoiseModel(np.zeros(np.size(told)), np.square(told), source=fit_name)
                    opts = noise_options(m, model) if np.any(told > 0) else {}
                    fits[fit_name] = fit_correction(pb, method=m, **opts)
                for ts in tests:
                    C = truth.source_of(ts.reflectances)
                    Ce = eprob.source_of(ts.reflectances)
                    if sigma:
                        noise = sigma * np.random.default_rng([a.seed, size]).standard_normal(C.shape)
                        C, Ce = C + noise, Ce + noise
                    T = truth.target_of(ts.reflectances)
                    for fit_name, f in fits.items():
                        x = C[:, :3] if fit_name == "one camera" else C
                        dE = truth.delta_E(f(x), T)
                        acc.setdefault((size, ts.kind, sigma, m, fit_name), []).append(float(np.mean(dE)))
                    dself = truth.delta_E(fits["none"](Ce), T)
                    acc.setdefault((size, ts.kind, sigma, m, "self"), []).append(float(np.mean(dself)))
    print(f"corrections in {time.perf_counter() - t0:.0f} s", file=sys.stderr)
    for key, v in diag.items():
        print(
            f"{key[0]} cameras, {key[1]}: median {np.median(v):.2f} [{np.percentile(v, 10):.2f}, "
            f"{np.percentile(v, 90):.2f}]"
        )
    cols = (*fit_names, "self")
    print("\n| cameras | test | σ | method | " + " | ".join(cols) + " |")
    print("|---" * (4 + len(cols)) + "|")
    for size in (1, 2, 3):
        for kind in ("natural", "atypical"):
            for sigma in (0.0, 0.005):
                for m in METHODS:
                    row = [np.mean(acc[size, kind, sigma, m, f]) for f in cols]
                    cells = " | ".join(
                        f"{v:.3f}" if i == 0 else f"{v:.3f} ({v - row[0]:+.2f})" for i, v in enumerate(row)
                    )
                    print(f"| {size} | {kind} | {sigma:g} | {m} | {cells} |")
    return 0


if __name__ == "__main__":
    sys.exit(main())
