"""Benchmark: metamer mismatch volumes, fast simplex oracle vs the scipy-HiGHS oracle.

Baseline = the same facet-refinement algorithm (zonotope._mmv_refine.refine) with one
``scipy.optimize.linprog(method="highs")`` call per support LP, run in the same process.
ColorChecker N Ohta patches, Nikon 5100 (NPL) → Stockman & Sharpe 2° LMS under D65.

Rows: exact MMV (10 nm, 5 nm) and certified ε = 1e-3 × the MMV's diameter (10 nm). Also the
batched centroids (10 nm, ε = 1e-3 of the target scale) and the channelwise / joint volume ratio
for Nikon 5100 + Sigma SD Merrill.

    .venv/bin/python benchmarks/bench_mismatch.py [--repeats 5] [--quick]
"""

from __future__ import annotations

import argparse
import statistics
import time

import numpy as np

import zonotope
from zonotope.mismatch import MetamerMismatch, _refinement, channelwise_intersection

NIKON, SIGMA, TARGET = "Nikon 5100 (NPL)", "Sigma SDMerill (NPL)", "Stockman & Sharpe 2°"


def problem(cams, step, hi=700.0):
    grid = np.arange(400.0, hi + 1, step)
    Phi = zonotope.generators(cams, "D65", grid).values
    Psi = zonotope.generators(TARGET, "D65", grid).values
    R = zonotope.resample(zonotope.reflectances("ColorChecker N Ohta"), grid).T
    return Phi, Psi, R


def timed(fn, repeats):
    out, times = None, []
    for _ in range(repeats):
        t = time.perf_counter()
        out = fn()
        times.append(time.perf_counter() - t)
    return out, times


def row(step, patches, mode, repeats, base_repeats):
    Phi, Psi, R = problem(NIKON, step)
    ours_t, base_t, verts, calls_o, calls_b = [], [], [], [], []
    for i in patches:
        c = R[i] @ Phi
        eps = 0.0
        if mode != "exact":
            exact, _, _ = _refinement(Phi, Psi, c)
            eps = 1e-3 * exact.inner.diameter  # target scale is 1 (normalised generators)
        (ref, _, _), t = timed(lambda c=c, eps=eps: _refinement(Phi, Psi, c, eps=eps), repeats)
        ours_t += t
        verts.append(len(ref.inner.vertices))
        calls_o.append(ref.lp_calls)
        (refb, _, _), tb = timed(
            lambda c=c, eps=eps: _refinement(Phi, Psi, c, eps=eps, oracle="highs"), base_repeats
        )
        base_t += tb
        calls_b.append(refb.lp_calls)
        rel = abs(refb.inner.volume - ref.inner.volume) / max(refb.inner.volume, 1e-300)
        if mode == "exact" and rel > 1e-6:
            print(f"  warning: patch {i} volumes differ by {rel:.2e} (relative)")
    b, o = statistics.median(base_t), statistics.median(ours_t)
    return (
        f"{step:g} nm",
        "Nikon 5100",
        mode,
        f"{b * 1e3:.1f} ms",
        f"{o * 1e3:.2f} ms",
        f"{b / o:.0f}×",
        f"{int(np.median(verts))}",
        f"{int(np.median(calls_o))} / {int(np.median(calls_b))}",
    )


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeats", type=int, default=5)
    ap.add_argument("--quick", action="store_true", help="fewer patches and a short batch")
    ap.add_argument("--batch", type=int, default=None, help="responses in the 2-process batch timing")
    args = ap.parse_args()
    r = args.repeats
    p10 = [1, 12] if args.quick else [1, 5, 12, 18]
    p5 = [5] if args.quick else [5, 12]
    rows = [
        row(10, p10, "exact", r, r),
        row(5, p5, "exact", r, r),
        row(10, p10, "ε=1e-3·diam", r, r),
    ]
    header = (
        "grid",
        "cameras",
        "mode",
        "baseline median",
        "ours median",
        "ratio",
        "vertices",
        "LP calls ours / baseline",
    )
    print("| " + " | ".join(header) + " |")
    print("|" + "---|" * len(header))
    for x in rows:
        print("| " + " | ".join(x) + " |")
    # certified ε = 1e-3 of the target scale (what correct/report use), per patch
    Phi, Psi, R = problem(NIKON, 10)
    ts = []
    for x in R:
        _, t = timed(lambda x=x: _refinement(Phi, Psi, x @ Phi, eps=1e-3), r)
        ts += t
    med = statistics.median(ts) * 1e3
    print(f"\ncertified ε=1e-3 (target scale), 10 nm, 24 patches × {r}: median {med:.1f} ms")
    # batch: one by one (chunk=1) as the baseline, lockstep chunks on 1 core, then 2 processes, with
    # and without the certified outer bounds (the Centroid estimator needs only the centroids)
    N = args.batch or (500 if args.quick else 10_000)
    mm = MetamerMismatch(NIKON, shape=np.arange(400.0, 701.0, 10.0))
    rng = np.random.default_rng(0)
    X = np.clip(rng.random((N, 31)) @ np.triu(np.ones((31, 31))) / 31 * rng.random((N, 1)) * 2, 0, 1)
    C = mm.source_of(X)
    n1 = min(N, 1000)
    from zonotope.parallel import executor

    for label, n, kw in (
        ("one by one (chunk=1), 1 core", n1, dict(chunk=1)),
        ("lockstep chunks of 256, 1 core", n1, dict(chunk=256)),
        ("lockstep chunks of 256, local Dask cluster of 2", N, dict(chunk=256, where="local:2")),
        (
            "centroids only (outer=False), local Dask cluster of 2",
            N,
            dict(chunk=256, where="local:2", outer=False),
        ),
    ):
        where = kw.pop("where", "serial")
        t = time.perf_counter()
        with executor(where) as ex:  # the cluster's start-up is part of the measured time
            out = mm.batch(C[:n], eps=1e-3, executor=ex, **kw)
        dt = time.perf_counter() - t
        print(
            f"batch, {label}: {n} responses (10 nm, ε=1e-3) in {dt:.1f} s → {dt / n * 1e4:.0f} s "
            f"per 10⁴, {out.lp_calls / n:.0f} LPs per response"
        )
    # channelwise / joint volume ratio
    grid = np.arange(400.0, 681.0, 10.0)
    Phi2 = zonotope.generators([NIKON, SIGMA], "D65", grid).values
    Psi2 = zonotope.generators(TARGET, "D65", grid).values
    R2 = zonotope.resample(zonotope.reflectances("ColorChecker N Ohta"), grid).T
    ratios = []
    for x in R2:
        c = x @ Phi2
        joint = zonotope.mismatch.metamer_mismatch(Phi2, Psi2, c)
        outer = channelwise_intersection(Phi2, Psi2, c, groups="camera")
        if joint.volume > 0:
            ratios.append(outer.volume / joint.volume)
    q = np.percentile(ratios, [0, 50, 100])
    print(
        f"channelwise (per camera) / joint MMV volume, Nikon 5100 + Sigma SD Merrill, 10 nm "
        f"400–680 nm, 24 patches: min {q[0]:.2f}, median {q[1]:.2f}, max {q[2]:.2f}"
    )


if __name__ == "__main__":
    main()
