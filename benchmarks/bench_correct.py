"""Benchmark: correct a 1-megapixel two-camera image rendered from real reflectances.

A mosaic of Munsell matte chips (../shared/data; built-in reflectance sets when absent), each tile
under its own exposure, seen by two cameras (6 channels), D65, 400–700 nm / 10 nm. Prints the time
of ``correct_image`` (deduplication + batching) for the prior-aware estimator and the ΔE00 between
it and the exact per-pixel estimator, next to per-pixel root-polynomial regression as baseline.

Goal (issue 4): ≤ 30 s on 2 cores, within 0.5 ΔE00 of the exact per-pixel estimator.

Run: ``python benchmarks/bench_correct.py [--size 1000] [--tile 25] [--vignette]``
"""

from __future__ import annotations

import argparse
import os
import tempfile
import time
from pathlib import Path

import colour
import numpy as np

import zonotope.spectra as spectra
from zonotope.correct import correction_problem, fit_correction
from zonotope.image import correct_image

DATA = Path(os.environ.get("ZONOTOPE_SHARED_DATA", Path(__file__).resolve().parents[2] / "shared" / "data"))


def reflectance_pool(w: np.ndarray) -> tuple[np.ndarray, str]:
    munsell = DATA / "reflectance_munsell_matte_joensuu_5nm" / "munsell_matte_1269_380_780_5nm.csv"
    if munsell.is_file():
        return np.clip(spectra.resample(spectra.read_reflectances(munsell), w).T, 0, 1), "Munsell matte 1269"
    sets = [
        spectra.resample(spectra.reflectances(n), w).T
        for n in ("ColorChecker N Ohta", "CIE 1995 TCS", "NIST CQS 9.0", "BabelColor Average")
    ]
    return np.clip(np.vstack(sets), 0, 1), "built-in sets (no shared data)"


def cameras() -> list:
    sony = DATA / "ssf_rawtoaces" / "data" / "camera" / "Sony_ILCE-7M3_380_780_5.json"
    return ["Nikon 5100 (NPL)", str(sony) if sony.is_file() else "Canon EOS 5D Mark II"]


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--size", type=int, default=1000, help="image side in pixels (default 1000 → 1 MP)")
    ap.add_argument("--tile", type=int, default=25, help="tile side in pixels")
    ap.add_argument("--vignette", action="store_true", help="add smooth radial shading (many more colours)")
    ap.add_argument("--method", default="Prior")
    ap.add_argument("--quantum", type=float, default=2e-3)
    ap.add_argument("--no-base", action="store_true", help="no regression transfer within groups")
    args = ap.parse_args()

    shape = colour.SpectralShape(400, 700, 10)
    w = np.asarray(shape.wavelengths)
    pool, pool_name = reflectance_pool(w)
    problem = correction_problem(cameras(), shape=shape)
    rng = np.random.default_rng(0)
    n_t = args.size // args.tile
    chips = rng.integers(0, pool.shape[0], (n_t, n_t))
    exposure = rng.uniform(0.4, 1.0, (n_t, n_t))
    R = np.repeat(np.repeat(pool[chips], args.tile, 0), args.tile, 1)  # (H, W, n)
    gain = np.repeat(np.repeat(exposure, args.tile, 0), args.tile, 1)[..., None]
    if args.vignette:
        yy, xx = np.mgrid[0 : R.shape[0], 0 : R.shape[1]] / R.shape[0] - 0.5
        gain = gain * (1.0 - 0.4 * (xx**2 + yy**2))[..., None]
    image = (R @ problem.Phi) * gain  # (H, W, 6)
    truth = (R @ problem.Psi) * gain
    H, W, k = image.shape
    print(
        f"image {H}×{W}×{k} ({H * W / 1e6:.2f} MP) "
        f"from {pool_name}; cameras {' + '.join(problem.sources)}; {os.cpu_count()} CPU cores"
    )

    t0 = time.perf_counter()
    est = fit_correction(problem, method=args.method)
    t_fit = time.perf_counter() - t0
    with tempfile.TemporaryDirectory() as cache:
        t0 = time.perf_counter()
        base = None if args.no_base else "auto"
        fast = correct_image(image, est, quantum=args.quantum, cache_dir=cache, base=base)
        t_fast = time.perf_counter() - t0
        t0 = time.perf_counter()
        correct_image(image, est, quantum=args.quantum, cache_dir=cache, base=base)
        t_cached = time.perf_counter() - t0
    n_q = np.unique(np.round(image.reshape(-1, 6) / args.quantum).astype(np.int64), axis=0).shape[0]
    n_exact = np.unique(image.reshape(-1, 6), axis=0).shape[0]
    if n_exact <= 20_000:  # exact: every distinct float response, no rounding, no transfer
        t0 = time.perf_counter()
        exact = correct_image(image, est, quantum=0)
        t_exact = time.perf_counter() - t0
        sample = np.ones(image.shape[:2], dtype=bool)
    else:  # too many distinct colours for the exact estimator everywhere: a seeded pixel sample
        sample = np.zeros(image.shape[:2], dtype=bool)
        sample.flat[rng.choice(sample.size, 3000, replace=False)] = True
        exact = np.full(truth.shape, np.nan)
        t0 = time.perf_counter()
        exact[sample] = est(image[sample])
        t_exact = (time.perf_counter() - t0) * n_exact / 3000  # extrapolated to every colour
    rp = fit_correction(problem, method="Finlayson 2015")
    t0 = time.perf_counter()
    base = rp(image)
    t_rp = time.perf_counter() - t0

    d_fast_exact = problem.delta_E(fast[sample], exact[sample])
    d_fast = problem.delta_E(fast, truth)
    d_exact = problem.delta_E(exact[sample], truth[sample])
    d_rp = problem.delta_E(base, truth)
    print(f"{'':34s} {'seconds':>8s} {'colours':>8s} {'ΔE00 vs truth mean/max':>24s}")
    label = f"{args.method} correct_image (q={args.quantum:g})"
    print(f"{label:34s} {t_fast + t_fit:8.2f} {n_q:8d} {d_fast.mean():12.3f} / {d_fast.max():.2f}")
    print(f"{'  same, warm disk cache':34s} {t_cached:8.2f}")
    what = "exact per pixel" + ("" if sample.all() else " (3000-px sample; time extrapolated)")
    print(
        f"{args.method + ' ' + what:34s} {t_exact + t_fit:8.2f} {n_exact:8d} "
        f"{d_exact.mean():12.3f} / {d_exact.max():.2f}"
    )
    print(
        f"{'Finlayson 2015 per pixel (baseline)':34s} {t_rp:8.2f} {image.shape[0] * image.shape[1]:8d} "
        f"{d_rp.mean():12.3f} / {d_rp.max():.2f}"
    )
    print(
        f"correct_image vs exact per-pixel ({int(sample.sum())} px): ΔE00 mean {d_fast_exact.mean():.4f}, "
        f"p99 {np.percentile(d_fast_exact, 99):.4f}, max {d_fast_exact.max():.4f}"
    )
    ok = (t_fast + t_fit) <= 30 and d_fast_exact.max() <= 0.5
    print(f"goal (≤ 30 s, ≤ 0.5 ΔE00 from exact): {'met' if ok else 'MISSED'}")


if __name__ == "__main__":
    main()
