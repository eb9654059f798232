"""Benchmark: correct a 1-megapixel two-camera image rendered from real reflectances.

A mosaic of Munsell matte chips (../shared/data; built-in reflectance sets when absent), each tile
under its own exposure, seen by two cameras (6 channels), D65, 400–700 nm / 10 nm. Prints the time
of ``correct_image`` (deduplication + batching) for the prior-aware estimator and the ΔE00 between
it and the exact per-pixel estimator, next to per-pixel root-polynomial regression as baseline.

Goal (issue 4): ≤ 30 s on 2 cores, within 0.5 ΔE00 of the exact per-pixel estimator.
Goal (issue 14), with ``--noise 0.005``: a noisy 1 MP two-camera image (as many distinct colours as
pixels) in ≤ 60 s on 2 cores, compared with exact per-pixel estimates on a pixel sample; the share of
pixels that need a solver (the rest are exact closed forms) is printed.

``--fit-apply N``: fit + apply of each estimator on N natural responses (Munsell chips under random
exposures), median of ``--repeats`` runs, against MAP (issue 14: within 10× of MAP).

``--bvls N``: ``zonotope.correct.prior.fiber_lsq`` (the batched exact solver of
``zonotope.correct.bvls``) against
its former per-row loop of ``scipy.optimize.lsq_linear(method="bvls")`` (the baseline, same process),
on N rows of a noisy Prior MAP as the splat pipeline's correct step poses it: three cameras' 9
channels, whitened by per-channel noise (σ_ref = ``--noise``, default 0.005), the shared prior
objective, and responses the closed form does NOT cover (the only ones that reach the solver);
median of ``--repeats`` runs each, and the largest difference between the two answers.

``--prior-fit N``: ``fit_correction(method="Prior")`` as ``splat correct`` calls it
(``splat.capture.fit_fused_corrector``: the simulated capture's three cameras' 9 channels, 400–680 nm,
CIE 1931 2° target, rawtoaces 190 — checked equal to ``correction_problem_of`` of the simulated capture —
whitened by N seeded per-channel noise patterns as ``splat.fusion.whitened`` does, ``noise = σ_ref``,
``mix = 1``),
N patterns in a row from cold caches, against the reference twin ``zonotope.correct.mmv.
_fit_Prior_reference`` (the implementation before: BLAS threads as configured, the log volume computed
per whitened Φ), interleaved in one process, median of ``--repeats``; and the largest difference.

Run: ``python benchmarks/bench_correct.py [--size 1000] [--tile 25] [--vignette] [--noise 0.005]``
or ``python benchmarks/bench_correct.py --fit-apply 10000`` or ``... --bvls 2000 --noise 0.005``
or ``... --prior-fit 6``
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
from zonotope.correct.image import correct_image
from zonotope.correct.prior import ReflectancePrior, fiber_lsq, interior_solution

try:  # run as a script (python benchmarks/bench_X.py) or imported as benchmarks.bench_X
    from _timing import median_time
except ImportError:
    from benchmarks._timing import median_time

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
    ap.add_argument("--noise", type=float, default=0.0, help="Gaussian response noise σ (white = 1)")
    ap.add_argument("--fit-apply", type=int, default=0, help="time fit + apply on N responses instead")
    ap.add_argument("--repeats", type=int, default=5)
    ap.add_argument("--workers", type=int, default=0, help="MMV centroids in N threads (0: here)")
    ap.add_argument(
        "--bvls", type=int, default=0, help="time fiber_lsq against scipy's per-row BVLS on N rows"
    )
    ap.add_argument("--prior-fit", type=int, default=0, help="time Prior's fit on N whitened noise patterns")
    args = ap.parse_args()
    if args.prior_fit:
        prior_fit(args.prior_fit, args.noise or 0.005, args.repeats)
        return
    if args.fit_apply:
        fit_apply(args.fit_apply, args.repeats)
        return
    if args.bvls:
        bvls(args.bvls, args.noise or 0.005, args.repeats)
        return

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
    if args.noise > 0:
        image = image + rng.normal(0.0, args.noise, image.shape)
    H, W, k = image.shape
    print(
        f"image {H}×{W}×{k} ({H * W / 1e6:.2f} MP) "
        f"from {pool_name}; cameras {' + '.join(problem.sources)}; {os.cpu_count()} CPU cores"
    )

    pool = None
    if args.workers > 0:
        from concurrent.futures import ThreadPoolExecutor

        pool = ThreadPoolExecutor(args.workers)
    t0, c0 = time.perf_counter(), time.process_time()
    opts = {"noise": args.noise} if args.noise > 0 else {}
    if pool is not None:
        opts["executor"] = pool
    est = fit_correction(problem, method=args.method, **opts)
    t_fit = time.perf_counter() - t0
    cpu_fit = time.process_time() - c0
    if "needs_solver" in est.params:
        share = float(np.mean(est.params["needs_solver"](image.reshape(-1, image.shape[-1])[::97])))
        print(f"share of pixels that need a solver (1 in 97 sampled): {100 * share:.1f} %")
    with tempfile.TemporaryDirectory() as cache:
        t0, c0 = time.perf_counter(), time.process_time()
        base = None if args.no_base else "auto"
        fast = correct_image(image, est, quantum=args.quantum, cache_dir=cache, base=base)
        t_fast = time.perf_counter() - t0
        cpu_fast = time.process_time() - c0  # CPU seconds of this process (all its threads)
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
    if pool is not None:
        pool.shutdown()
        opts.pop("executor")
    rp = fit_correction(problem, method="Finlayson 2015", **opts)
    t0, c0 = time.perf_counter(), time.process_time()
    base = rp(image)
    t_rp = time.perf_counter() - t0
    cpu_rp = time.process_time() - c0

    d_fast_exact = problem.delta_E(fast[sample], exact[sample])
    d_fast = problem.delta_E(fast, truth)
    d_exact = problem.delta_E(exact[sample], truth[sample])
    d_rp = problem.delta_E(base, truth)
    print(f"{'':34s} {'seconds':>8s} {'colours':>8s} {'ΔE00 vs truth mean/max':>24s}")
    label = f"{args.method} correct_image (q={args.quantum:g})"
    print(f"{label:34s} {t_fast + t_fit:8.2f} {n_q:8d} {d_fast.mean():12.3f} / {d_fast.max():.2f}")
    print(f"{'  same, warm disk cache':34s} {t_cached:8.2f}")
    print(
        f"CPU seconds of this process (robust to load; all threads): fit {cpu_fit:.1f}, "
        f"correct_image {cpu_fast:.1f}, "
        f"per-pixel root-polynomial {cpu_rp:.2f} (ratio {cpu_fast / max(cpu_rp, 1e-9):.0f}×)"
    )
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
    limit = 60 if args.noise > 0 else 30
    ok = (t_fast + t_fit) <= limit and d_fast_exact.max() <= 0.5
    print(f"goal (≤ {limit} s, ≤ 0.5 ΔE00 from exact): {'met' if ok else 'MISSED'}")


def fit_apply(n: int, repeats: int) -> None:
    """Median wall time of fit + apply on ``n`` natural responses, per estimator, against MAP."""
    shape = colour.SpectralShape(400, 700, 10)
    w = np.asarray(shape.wavelengths)
    pool, pool_name = reflectance_pool(w)
    rng = np.random.default_rng(1)
    for cams in (["Nikon 5100 (NPL)"], cameras()):
        problem = correction_problem(cams, shape=shape)
        X = pool[rng.integers(0, pool.shape[0], n)] * rng.uniform(0.3, 1.0, (n, 1))
        C = X @ problem.Phi
        times = {}
        for method in ("Finlayson 2015", "MAP", "MAP, every row solved (before the closed form)", "Prior"):
            runs = []
            for _ in range(repeats):
                t0 = time.perf_counter()
                if method.startswith("MAP, every"):
                    prior = ReflectancePrior.fit(problem.training, shrinkage=0.01)
                    fiber_lsq(problem.Phi, C, prior.root, prior.root @ prior.mean) @ problem.Psi
                else:
                    fit_correction(problem, method=method)(C)
                runs.append(time.perf_counter() - t0)
            times[method] = float(np.median(runs))
        est = fit_correction(problem, method="Prior")
        share = float(np.mean(est.params["needs_solver"](C)))
        print(
            f"{' + '.join(problem.sources)}: fit + apply {n} responses ({pool_name}), median of {repeats}: "
            + ", ".join(f"{m} {t:.3g} s" for m, t in times.items())
            + f"; Prior / MAP = {times['Prior'] / times['MAP']:.1f} (goal ≤ 10), Prior / MAP solved per row "
            f"= {times['Prior'] / times['MAP, every row solved (before the closed form)']:.1f}; "
            f"{100 * share:.1f} % of responses need a solver"
        )


def bvls(n_rows: int, noise: float, repeats: int) -> None:
    """fiber_lsq (batched) against the per-row scipy BVLS loop it replaced, on noisy Prior MAP rows."""
    from zonotope.correct.bvls import PDAS_STEPS, _scipy_bvls, box_lsq

    shape = np.arange(400.0, 681.0, 10.0)  # the Sigma's measured range, as the splat pipeline narrows it
    pool, pool_name = reflectance_pool(shape)
    cams = ["Nikon 5100 (NPL)", "Sigma SDMerill (NPL)", "Canon EOS 5D Mark II"]
    problem = correction_problem(cams, shape=shape, training="rawtoaces 190")
    rng = np.random.default_rng(2)
    sigma = noise * rng.uniform(0.5, 2.0, problem.k)  # per-channel noise, whitened as splat.fusion does
    ref = float(np.median(sigma))
    Phi = problem.Phi * (ref / sigma)
    prior = ReflectancePrior.fit(problem.training)
    C = np.empty((0, problem.k))
    while len(C) < n_rows:  # responses of chips under random exposures, plus noise; keep the solver's
        X = pool[rng.integers(0, len(pool), 20 * n_rows)] * rng.uniform(0.2, 1.0, (20 * n_rows, 1))
        c = X @ Phi + rng.normal(0.0, ref, (len(X), problem.k))
        _, interior = interior_solution(prior, Phi, c, noise=ref)
        C = np.vstack([C, c[~interior]])
    C = C[:n_rows]
    U, b = prior.root, prior.root @ prior.mean
    M = np.vstack([U, Phi.T / ref])
    R = np.hstack([np.broadcast_to(b, (n_rows, U.shape[0])), C / ref])

    def per_row():  # fiber_lsq before: one scipy BVLS per response (box_lsq's own per-row fallback)
        return np.array([_scipy_bvls(M, r) for r in R])

    t_new = median_time(lambda: fiber_lsq(Phi, C, U, b, noise=ref), repeats, warmup=True)
    t_old = median_time(per_row, repeats)
    x_new, x_old = fiber_lsq(Phi, C, U, b, noise=ref), per_row()
    _, fallback = box_lsq(M, R)
    _, after_first = box_lsq(M, R, max_iter=PDAS_STEPS)
    bound = np.mean(np.sum((x_new <= 0) | (x_new >= 1), axis=1))
    ev = np.linalg.eigvalsh(M.T @ M)
    print(
        f"fiber_lsq on {n_rows} noisy Prior MAP rows not covered by the closed form ({' + '.join(cams)}, "
        f"{problem.k} channels whitened, σ_ref = {ref:.4g}, {shape.size} bands, {pool_name}; "
        f"{bound:.1f} of {shape.size} entries on a bound per row, cond(MᵀM) = {ev[-1] / ev[0]:.3g}), "
        f"median of {repeats}:"
    )
    print(f"  per-row scipy BVLS loop (baseline) {t_old:8.3f} s  ({1e3 * t_old / n_rows:.3f} ms per row)")
    print(f"  batched box_lsq (fiber_lsq now)    {t_new:8.3f} s  ({1e3 * t_new / n_rows:.3f} ms per row)")
    print(
        f"  ratio {t_old / t_new:.1f}×; max |Δx| = {np.abs(x_new - x_old).max():.2e}; rows left to the "
        f"primal phase {int(after_first.sum())}, to scipy {int(fallback.sum())}"
    )


def prior_fit(n_patterns: int, noise: float, repeats: int) -> None:
    """fit_Prior against its reference twin on ``n_patterns`` whitened 9-channel problems in a row."""
    import dataclasses
    import statistics

    from threadpoolctl import threadpool_info

    import zonotope.correct.mmv as mmv

    shape = np.arange(400.0, 681.0, 10.0)  # correction_problem_of of the simulated capture: its grid,
    cams = ["Nikon 5100 (NPL)", "Sigma SDMerill (NPL)", "Canon EOS 5D Mark II"]  # cameras, training
    problem = correction_problem(
        cams, shape=shape, training="rawtoaces 190", target="CIE 1931 2 Degree Standard Observer"
    )
    with tempfile.TemporaryDirectory() as tmp:  # the pipeline's problem of the simulated capture
        from splat.capture import correction_problem_of, read_capture
        from splat.sim.capture import write_synthetic_capture

        spec = read_capture(write_synthetic_capture(Path(tmp) / "capture"))
        piped = correction_problem_of(spec, [0, 1, 2])
    fields = ("Phi", "Psi", "training", "white_XYZ", "XYZ_from_target")
    same_problem = all(np.array_equal(getattr(problem, f), getattr(piped, f)) for f in fields)
    rng = np.random.default_rng(3)
    problems = []
    for _ in range(n_patterns):  # splat.fusion.whitened: channel k scaled by σ_ref / σ_k
        sigma = noise * rng.uniform(0.5, 2.0, problem.k)
        ref = float(np.median(sigma))
        problems.append((dataclasses.replace(problem, Phi=problem.Phi * (ref / sigma)), ref, ref / sigma))
    opts = {"mix": 1.0}  # splat.capture.pipeline_mix("Prior")

    def run(fit):
        mmv._clear_log_volume_caches()  # a fresh `splat correct` process
        return [fit(pb, noise=ref, **opts) for pb, ref, _ in problems]

    def one_thread_reference(pb, **kw):
        with mmv._one_blas_thread():
            return mmv._fit_Prior_reference(pb, **kw)

    variants = {
        "reference (before)": mmv._fit_Prior_reference,
        "reference, one BLAS thread": one_thread_reference,
        "fit_Prior (now)": mmv.fit_Prior,
    }
    times = {name: [] for name in variants}
    first = {name: [] for name in variants}
    for _ in range(repeats):  # interleaved: the load drifts alike for all
        for name, fit in variants.items():
            mmv._clear_log_volume_caches()
            t0 = time.perf_counter()
            fit(problems[0][0], noise=problems[0][1], **opts)
            first[name].append(time.perf_counter() - t0)
            t0 = time.perf_counter()
            run(fit)
            times[name].append(time.perf_counter() - t0)
    new, old = run(mmv.fit_Prior), run(mmv._fit_Prior_reference)
    C = problem.training @ problem.Phi
    C = np.vstack([C, 1.3 * C + 0.01, rng.uniform(0.0, 1.0, (200, problem.k))])  # some off the solid
    d_pred = d_logvol = 0.0
    same = True
    for (_, _, scale), a, b in zip(problems, new, old):
        pa, pr = a(C * scale), b(C * scale)
        d_pred = max(d_pred, float(np.max(np.abs(pa - pr) / np.maximum(np.abs(pr), 1e-300))))
        d_logvol = max(d_logvol, abs(a.params["log_volume"] - b.params["log_volume"]))
        same &= (
            a.params["regression"].method == b.params["regression"].method
            and a.params["mix"] == b.params["mix"]
            and a.params["cv_scores"] == b.params["cv_scores"]
            and a.params["r_nat"] == b.params["r_nat"]
        )
    blas = ", ".join(f"{i['internal_api']} {i['num_threads']} threads" for i in threadpool_info())
    print(
        f"Prior fit as splat.capture.fit_fused_corrector calls it ({' + '.join(cams)}, "
        f"{problem.k} channels, "
        f"{shape.size} bands, {n_patterns} whitened noise patterns, σ ≈ {noise:g}, mix = 1); {blas}; "
        f"load average {os.getloadavg()[0]:.1f} on {os.cpu_count()} cores; median of {repeats}, interleaved "
        f"(the problem equals correction_problem_of of the simulated capture: {same_problem}):"
    )
    base = statistics.median(times["reference (before)"])
    base1 = statistics.median(first["reference (before)"])
    for name in variants:
        t, t1 = statistics.median(times[name]), statistics.median(first[name])
        print(
            f"  {name:28s} {n_patterns} patterns {t:7.3f} s ({base / t:5.1f}×)   "
            f"first pattern alone {t1:6.3f} s ({base1 / t1:4.1f}×)"
        )
    print(
        f"  now vs reference: predictions on {len(C)} responses max relative difference {d_pred:.1e}, "
        f"log volume max |Δ| {d_logvol:.1e}; regression, mix, CV scores and r_nat identical: {same}"
    )


if __name__ == "__main__":
    main()
