"""Benchmark: exact metamer mismatch volumes — vertex walk vs facet refinement (simplex, HiGHS).

Baseline = facet refinement (zonotope.mismatch.refine) with one ``scipy.optimize.linprog(method="highs")``
call per support LP (``oracle="highs"``), run in the same process. Also timed: the same refinement
with the warm-started simplex (``oracle="fast"``, the previous engine) and the output-sensitive
vertex walk (``oracle="walk"``, the default): end to end (``metamer_mismatch`` → Polytope with its
volume and centroid, which includes one Qhull hull of the vertices) and the walk alone
(``walk_mmv``: vertices, volume and centroid from the traced faces, what the batch uses).
ColorChecker N Ohta patches, Nikon 5100 (NPL) → Stockman & Sharpe 2° LMS under D65. CPU times
(``time.process_time``) and wall times are both medians; on a loaded shared machine the CPU times
are the steadier of the two, the ratios are taken in one process either way.

Rows: exact MMV (10 nm, 5 nm) and certified ε = 1e-3 (10 nm). Then the batched centroids (10 nm,
ε = 1e-3 of the target scale, what the Centroid estimator uses) on 1 core and on a local Dask
cluster of 2, and the channelwise / joint volume ratio for Nikon 5100 + Sigma SD Merrill.

``--walk-baseline REV`` (e.g. ``1c0528d``, the kernel before the batch kernel) only times the walk
of batched centroids against the kernel of that git revision, loaded from ``git show`` into this
process: the previous path (one ``walk_mmv`` per response) vs ``walk_mmv_batch`` (one compiled call
per chunk), on 1 core and on 2 threads, with a bit-for-bit comparison of volumes and centroids.

    .venv/bin/python benchmarks/bench_mismatch.py [--repeats 5] [--quick] [--batch N] [--walk-baseline REV]
"""

from __future__ import annotations

import argparse
import statistics
import time
from concurrent.futures import ThreadPoolExecutor

import numpy as np

import zonotope
from zonotope.mismatch import (
    MetamerMismatch,
    channelwise_intersection,
    metamer_mismatch,
    metamer_mismatch_bounds,
)
from zonotope.mismatch.walk import walk_mmv

NIKON, SIGMA, TARGET = "Nikon 5100 (NPL)", "Sigma SDMerill (NPL)", "Stockman & Sharpe 2°"


def problem(cams, step, hi=700.0):
    grid = np.arange(400.0, hi + 1, step)
    Phi = zonotope.generators(cams, "D65", grid).values
    Psi = zonotope.generators(TARGET, "D65", grid).values
    R = zonotope.resample(zonotope.reflectances("ColorChecker N Ohta"), grid).T
    return Phi, Psi, R


def timed(fn, repeats):
    """(last result, CPU times, wall times)."""
    out, cpu, wall = None, [], []
    for _ in range(repeats):
        t, w = time.process_time(), time.perf_counter()
        out = fn()
        cpu.append(time.process_time() - t)
        wall.append(time.perf_counter() - w)
    return out, cpu, wall


def _full(mmv):
    return mmv.volume, mmv.centroid, mmv


def row(step, patches, mode, repeats, base_repeats):
    """One table row: medians over patches × repeats of each engine; volume agreement."""
    Phi, Psi, R = problem(NIKON, step)
    eps = 0.0 if mode == "exact" else 1e-3
    if mode == "exact":
        engines = {
            "highs": lambda c: _full(metamer_mismatch(Phi, Psi, c, oracle="highs")),
            "fast": lambda c: _full(metamer_mismatch(Phi, Psi, c, oracle="fast")),
            "walk": lambda c: _full(metamer_mismatch(Phi, Psi, c)),
        }
    else:
        engines = {
            e: (lambda c, e=e: _full(metamer_mismatch_bounds(Phi, Psi, c, eps=eps, oracle=e).inner))
            for e in ("highs", "fast", "walk")
        }
    engines["walk alone"] = lambda c: (*walk_mmv(Phi, Psi, c)[1:3], None)
    cpu = {e: [] for e in engines}
    wall = {e: [] for e in engines}
    verts, rel = [], []
    for i in patches:
        c = R[i] @ Phi
        vols = {}
        for e, fn in engines.items():
            out, tc, tw = timed(lambda fn=fn, c=c: fn(c), base_repeats if e == "highs" else repeats)
            cpu[e] += tc
            wall[e] += tw
            vols[e] = out[0]
            if e == "walk":
                verts.append(len(out[2].vertices))
        rel.append(max(abs(vols[e] / vols["highs"] - 1) for e in engines))
    med = {e: statistics.median(cpu[e]) for e in engines}
    medw = {e: statistics.median(wall[e]) for e in engines}
    return (
        f"{step:g} nm",
        mode,
        f"{med['highs'] * 1e3:.0f} ms",
        f"{med['fast'] * 1e3:.1f} ms ({med['highs'] / med['fast']:.0f}×)",
        f"{med['walk'] * 1e3:.2f} ms ({med['highs'] / med['walk']:.0f}×)",
        f"{med['walk alone'] * 1e3:.2f} ms ({med['highs'] / med['walk alone']:.0f}×)",
        f"{medw['walk'] * 1e3:.2f} / {medw['walk alone'] * 1e3:.2f} ms",
        f"{int(np.median(verts))}",
        f"{max(rel):.1e}",
    )


def walk_baseline(rev, N, repeats):
    """Batched centroid walks: the kernel of git revision ``rev`` (per-response calls) vs this tree's."""
    import importlib.util
    import pathlib
    import subprocess
    import sys
    import tempfile

    import zonotope.mismatch.walk as W
    from zonotope.mismatch.walk import walk_mmv_batch

    root = pathlib.Path(__file__).resolve().parents[1]
    cmd = ["git", "show", f"{rev}:zonotope/_mmv_walk_kernel.py"]
    src = subprocess.run(cmd, cwd=root, capture_output=True, text=True, check=True).stdout
    src = src.replace("from ._tol", "from zonotope._tol")
    path = pathlib.Path(tempfile.mkdtemp()) / "_baseline_walk_kernel.py"
    path.write_text(src)
    spec = importlib.util.spec_from_file_location("_baseline_walk_kernel", path)
    mod = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = mod
    spec.loader.exec_module(mod)

    mm = MetamerMismatch(NIKON, shape=np.arange(400.0, 701.0, 10.0))
    rng = np.random.default_rng(0)
    X = np.clip(rng.random((N, 31)) @ np.triu(np.ones((31, 31))) / 31 * rng.random((N, 1)) * 2, 0, 1)
    C = mm.source_of(X)
    Phi, Psi, d = mm.Phi, mm.Psi, np.zeros(mm.k)

    def old(part):  # the previous _batch_chunk loop: one walk_mmv per response (its input set-up
        # included), baseline kernel
        out = []
        for c in part:
            F, G, lo, hi, zb, zu = W._inputs(Phi, Psi, d)
            out.append(mod.walk(F, G, lo, hi, np.ascontiguousarray(c), 200_000, zb, zu)[1:3])
        return np.array([o[0] for o in out]), np.array([o[1] for o in out])

    def new(part):
        vol, cen, _, _ = walk_mmv_batch(Phi, Psi, part, d)
        return vol, cen

    def threaded(fn):
        parts = [C[s : s + 64] for s in range(0, N, 64)]
        with ThreadPoolExecutor(2) as ex:
            res = list(ex.map(fn, parts))
        return np.concatenate([r[0] for r in res]), np.concatenate([r[1] for r in res])

    old(C[:2]), new(C[:2])  # compile / load both kernels
    ov, oc = old(C)
    nv, nc = new(C)
    same = np.array_equal(ov, nv) and np.array_equal(oc, nc)
    print(f"{N} responses (10 nm, Nikon 5100 → LMS): volumes and centroids bit-identical: {same}")
    for label, fo, fn in (
        ("1 core", lambda: old(C), lambda: new(C)),
        ("2 threads (ThreadPoolExecutor, chunks of 64)", lambda: threaded(old), lambda: threaded(new)),
    ):
        cpu, wall = {"old": [], "new": []}, {"old": [], "new": []}
        for _ in range(repeats):  # interleaved, medians
            for name, fnc in (("old", fo), ("new", fn)):
                _, tc, tw = timed(fnc, 1)
                cpu[name] += tc
                wall[name] += tw
        mc = {k: statistics.median(v) / N * 1e3 for k, v in cpu.items()}
        mw = {k: statistics.median(v) / N * 1e3 for k, v in wall.items()}
        print(
            f"walk of batched centroids, {label}: CPU {mc['old']:.3f} → {mc['new']:.3f} ms per response "
            f"(×{mc['new'] / mc['old']:.3f}), wall {mw['old']:.3f} → {mw['new']:.3f} ms "
            f"(×{mw['new'] / mw['old']:.3f}); 10⁴ responses: {mw['old'] * 10:.1f} → {mw['new'] * 10:.1f} s "
            f"wall, {mc['old'] * 10:.1f} → {mc['new'] * 10:.1f} CPU-s [baseline {rev}, medians of {repeats}]"
        )


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeats", type=int, default=5)
    ap.add_argument("--quick", action="store_true", help="fewer patches and a short batch")
    ap.add_argument("--batch", type=int, default=None, help="responses in the 2-process batch timing")
    ap.add_argument("--walk-baseline", default=None, metavar="REV", help="only the batch-walk comparison")
    args = ap.parse_args()
    r = args.repeats
    if args.walk_baseline:
        walk_baseline(args.walk_baseline, args.batch or 1000, r)
        return
    p10 = [1, 12] if args.quick else [1, 5, 12, 18]
    p5 = [5] if args.quick else [5, 12]
    rows = [
        row(10, p10, "exact", r, r),
        row(5, p5, "exact", r, max(1, r // 2)),
        row(10, p10, "ε=1e-3", r, r),
    ]
    header = (
        "grid",
        "mode",
        "HiGHS refinement (baseline)",
        "simplex refinement",
        "walk, end to end",
        "walk alone",
        "walk wall (end to end / alone)",
        "vertices",
        "max |ΔV|/V vs baseline",
    )
    print("CPU-time medians (process_time); ratios against the baseline in this process")
    print("| " + " | ".join(header) + " |")
    print("|" + "---|" * len(header))
    for x in rows:
        print("| " + " | ".join(x) + " |")
    # certified ε = 1e-3 of the target scale (what correct/report use), per patch, walk (default)
    Phi, Psi, R = problem(NIKON, 10)
    ts = []
    for x in R:
        _, t, _ = timed(lambda x=x: metamer_mismatch_bounds(Phi, Psi, x @ Phi, eps=1e-3).centroid, r)
        ts += t
    med = statistics.median(ts) * 1e3
    print(f"\ncertified ε=1e-3 (target scale), 10 nm, 24 patches × {r}: median {med:.2f} ms CPU (walk)")
    # batch of centroids (what the Centroid estimator asks: eps=1e-3, outer=False): the previous
    # engine (simplex refinement in lockstep chunks) on 1 core as the baseline, then the walk on 1
    # core and on a local Dask cluster of 2 processes (its start-up included in the time)
    N = args.batch or (500 if args.quick else 10_000)
    mm = MetamerMismatch(NIKON, shape=np.arange(400.0, 701.0, 10.0))
    rng = np.random.default_rng(0)
    X = np.clip(rng.random((N, 31)) @ np.triu(np.ones((31, 31))) / 31 * rng.random((N, 1)) * 2, 0, 1)
    C = mm.source_of(X)
    n1 = min(N, 500)
    from zonotope.parallel import executor

    rate = {}
    for label, n, kw in (
        ("simplex refinement (previous engine), lockstep chunks of 256, 1 core", n1, dict(oracle="fast")),
        ("walk, 1 core", n1, dict()),
        ("walk, 2 threads (ThreadPoolExecutor; the kernel releases the GIL), chunks of 64", N, dict(where=2)),
        ("walk, local Dask cluster of 2", N, dict(where="local:2")),
    ):
        where = kw.pop("where", "serial")
        t, tc = time.perf_counter(), time.process_time()
        if isinstance(where, int):
            with ThreadPoolExecutor(where) as ex:
                zonotope.mismatch.metamer_mismatch_batch(
                    mm.Phi, mm.Psi, C[:n], eps=1e-3, outer=False, executor=ex, chunk=64
                )
        else:
            with executor(where) as ex:  # the cluster's start-up is part of the measured time
                zonotope.mismatch.metamer_mismatch_batch(
                    mm.Phi, mm.Psi, C[:n], eps=1e-3, outer=False, executor=ex, **kw
                )
        dt, dc = time.perf_counter() - t, time.process_time() - tc
        rate[label] = dt / n
        print(
            f"batch centroids, {label}: {n} responses (10 nm, ε=1e-3) in {dt:.1f} s wall, "
            f"{dc:.1f} s CPU of this process → {dt / n * 1e4:.1f} s per 10⁴ ({dt / n * 1e3:.2f} ms each)"
        )
    per = min(rate[k] for k in rate if "2" in k)
    print(
        f"Centroid correction of a 1 MP image with 10⁵ distinct colours (one MMV per distinct colour, "
        f"2 workers, the faster rate above): ≈ {per * 1e5:.0f} s"
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
