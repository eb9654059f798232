"""Benchmark: colour correction under response noise — noise-naive vs noise-aware estimators.

For 1, 2 and 3 cameras (Nikon 5100; + Canon EOS 5D Mark II; + Sigma SD Merrill; 400–700 nm, 400–680 nm
with the Sigma), D65, CIE 2015 XYZ, trained on rawtoaces 190 and tested on held-out sets never fitted
on: the natural sets of ``zonotope evaluate`` (built-ins and 150-spectrum subsets of ``../shared/data``,
spectra within 0.02 of a training one removed) pooled, and both atypical generators pooled. Noise:
shot-limited, σ at white per level (variance σ² · c per channel, white = 1), one seeded draw per test
response shared by every method. Per cell: mean / p95 / max ΔE00 and the fit time of each method, all
in this one process.

Methods: ``naive linear`` / ``naive root-poly`` (fitted noise-free), ``NA linear`` / ``NA root-poly``
(fitted for the noise model: noise-averaged normal equations), ``aug root-poly`` (10 noisy replicas of
the training set at the model's root mean σ), ``Guarded`` (the default of ``correct_image``: NA
root-poly with a linear fallback outside the training support, fitted for the noise model), ``Prior``
(told the noise model), ``Prior naive`` (σ = 0).

With ``--coverage`` the estimators that know their uncertainty (``Prior``) are applied through
``with_uncertainty``: the median 95 % credible radius and the share of test responses within it.

Run: ``python benchmarks/bench_noise.py [--cameras 1 2 3] [--sigmas 0 0.002 0.005] [--size 150]
[--atypical 100] [--methods ...] [--noise-kind shot|constant] [--coverage] [--json out.json]``;
``--prior-cache`` times a cold and a cached ``"Prior"`` fit instead.
"""

from __future__ import annotations

import argparse
import json
import os
import time
from pathlib import Path

import colour
import numpy as np

from zonotope.correct import NoiseModel, correction_problem, fit_correction
from zonotope.evaluate import atypical_test_sets, natural_test_sets, source_split

DATA = Path(os.environ.get("ZONOTOPE_SHARED_DATA", Path(__file__).resolve().parents[2] / "shared" / "data"))
CAMERAS = {
    1: ["Nikon 5100 (NPL)"],
    2: ["Nikon 5100 (NPL)", "Canon EOS 5D Mark II"],
    3: ["Nikon 5100 (NPL)", "Sigma SDMerill (NPL)", "Canon EOS 5D Mark II"],
}


def methods(model: NoiseModel | None, sigma_rms: float) -> dict[str, tuple[str, dict]]:
    """Method label → (registry name, options) for one noise model."""
    na = {"noise": model} if model is not None else {}
    return {
        "naive linear": ("Cheung 2004", {}),
        "naive root-poly": ("Finlayson 2015", {}),
        "NA linear": ("Cheung 2004", na),
        "NA root-poly": ("Finlayson 2015", na),
        "aug root-poly": ("Finlayson 2015", {"noise": sigma_rms} if model is not None else {}),
        "Guarded": ("Guarded", na),
        "Prior": ("Prior", na),
        "Prior naive": ("Prior", {}),
    }


def stats(dE: np.ndarray) -> tuple[float, float, float]:
    return float(np.mean(dE)), float(np.percentile(dE, 95)), float(np.max(dE))


def run_cell(n_cams: int, sigma: float, args) -> list[dict]:
    cams = CAMERAS[n_cams]
    shape = colour.SpectralShape(400, 680 if any("Sigma" in c for c in cams) else 700, 10)
    w = shape.wavelengths
    problem = correction_problem(cams, shape=shape)
    sets = natural_test_sets(w, data_dir=DATA if DATA.is_dir() else None, size=args.size)
    sets += atypical_test_sets(w, args.atypical)
    sets = source_split(sets, problem.training)[0]
    kind = NoiseModel.shot_limited if args.noise_kind == "shot" else NoiseModel.constant
    model = kind(sigma, problem.k) if sigma > 0 else None
    sigma_rms = model.effective_sigma(problem.source_of(problem.training)) if model else 0.0
    rng = np.random.default_rng(12345 + n_cams)
    data = {}
    for kind in ("natural", "atypical"):
        X = np.concatenate([t.reflectances for t in sets if t.kind == kind])
        C = problem.source_of(X)
        data[kind] = (C if model is None else model.sample(C, rng), problem.target_of(X))
    rows = []
    for label, (name, opts) in methods(model, sigma_rms).items():
        if args.methods and label not in args.methods:
            continue
        if model is None and label in ("NA linear", "NA root-poly", "aug root-poly", "Prior naive"):
            continue  # identical to the naive fits without noise
        t0 = time.perf_counter()
        est = fit_correction(problem, method=name, **opts)
        fit_s = time.perf_counter() - t0
        for kind, (C, T) in data.items():
            t0 = time.perf_counter()
            if args.coverage and est.predict_with_radius is not None:
                XYZ, radius = est.with_uncertainty(C)
            else:
                XYZ, radius = est(C), None
            apply_s = time.perf_counter() - t0
            dE = problem.delta_E(XYZ, T)
            mean, p95, mx = stats(dE)
            cover = float(np.mean(dE <= radius)) if radius is not None else None
            row = {
                "cameras": n_cams,
                "sigma": sigma,
                "set": kind,
                "n": int(C.shape[0]),
                "method": label,
                "mean": mean,
                "p95": p95,
                "max": mx,
                "fit_s": fit_s,
                "apply_s": apply_s,
                "coverage": cover,
                "radius": float(np.median(radius)) if radius is not None else None,
            }
            rows.append(row)
            print(
                f"{n_cams} cam  σ={sigma:<6g} {kind:8s} n={C.shape[0]:4d}  {label:16s} "
                f"mean {mean:6.3f}  p95 {p95:6.2f}  max {mx:6.2f}   "
                f"fit {fit_s:8.3f} s  apply {apply_s:7.3f} s"
                + (
                    f"  95 % radius (median) {row['radius']:.2f}, coverage {100 * cover:.0f} %"
                    if radius is not None
                    else ""
                ),
                flush=True,
            )
    return rows


def prior_cache(args) -> None:
    """Cold and cached ``"Prior"`` fit times (``cache_dir``), per camera count and noise level."""
    import tempfile

    for n in args.cameras:
        cams = CAMERAS[n]
        shape = colour.SpectralShape(400, 680 if any("Sigma" in c for c in cams) else 700, 10)
        problem = correction_problem(cams, shape=shape)
        for sigma in args.sigmas:
            opts = {"noise": NoiseModel.shot_limited(sigma, problem.k)} if sigma > 0 else {}
            with tempfile.TemporaryDirectory() as tmp:
                times = []
                for _ in range(2):
                    t0 = time.perf_counter()
                    fit_correction(problem, method="Prior", cache_dir=tmp, **opts)
                    times.append(time.perf_counter() - t0)
            print(
                f"{n} cam σ={sigma:g}: Prior fit cold {times[0]:.2f} s, cached {times[1]:.2f} s", flush=True
            )


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--cameras", nargs="+", type=int, default=[1, 2, 3], choices=[1, 2, 3])
    ap.add_argument("--sigmas", nargs="+", type=float, default=[0.0, 0.002, 0.005])
    ap.add_argument("--size", type=int, default=150)
    ap.add_argument("--atypical", type=int, default=100)
    ap.add_argument("--methods", nargs="*", default=None)
    ap.add_argument("--json", type=Path, default=None)
    ap.add_argument(
        "--noise-kind",
        choices=["shot", "constant"],
        default="shot",
        help="shot: variance σ² · c (default); constant: σ at every level",
    )
    ap.add_argument(
        "--coverage", action="store_true", help="Prior: with_uncertainty radii and their coverage"
    )
    ap.add_argument("--prior-cache", action="store_true", help="only time cold vs cached Prior fits")
    args = ap.parse_args()
    if args.prior_cache:
        prior_cache(args)
        return
    rows = []
    for n in args.cameras:
        for s in args.sigmas:
            rows += run_cell(n, s, args)
    if args.json:
        args.json.write_text(json.dumps(rows, indent=1))
    print("\nbest natural per cell (mean ΔE00), and every method's gap to it:")
    for n in args.cameras:
        for s in args.sigmas:
            cell = [r for r in rows if r["cameras"] == n and r["sigma"] == s and r["set"] == "natural"]
            if not cell:
                continue
            best = min(cell, key=lambda r: r["mean"])
            gaps = ", ".join(f"{r['method']} {r['mean'] - best['mean']:+.3f}" for r in cell)
            print(f"{n} cam σ={s:g}: best {best['method']} {best['mean']:.3f}; {gaps}")


if __name__ == "__main__":
    main()
