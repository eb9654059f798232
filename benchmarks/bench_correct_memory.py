"""Benchmark: peak memory of every estimator correcting 10⁶ and 10⁷ responses (two cameras).

Each (estimator, N) runs in a fresh Python process, so that one run's peak does not hide the next.
Input: a float32 ``(N, 1, 6)`` image of two cameras (Nikon 5100 + Canon EOS 5D Mark II, 400–700 nm,
D65, CIE 2015 XYZ, trained on rawtoaces 190) whose pixels repeat ``--distinct`` natural colours (the
built-in natural sets under random exposures, seeded): a photo with that many distinct responses, so
that estimators solving one problem per colour finish at 10⁷ pixels. Each estimator is fitted
(noise-free) and applied through ``correct_image`` (closed forms pixel by pixel, the others on
distinct colours, grouped with its default ``quantum``). Printed per run: the resident set size after
the fit and the input (``setup``), the peak resident set size of the process (``ru_maxrss``), the
float64 output's size, and the time of ``correct_image``. Baseline: the same process's
``setup`` + output, i.e. what any method must hold; the working memory is ``peak − setup − output``.

Goal (issue 40): ≤ 2 GB at 10⁷ responses for every estimator, working memory independent of N.

Run: ``python benchmarks/bench_correct_memory.py [--sizes 1000000 10000000] [--methods ...]
[--distinct 2000]``
"""

from __future__ import annotations

import argparse
import json
import resource
import subprocess
import sys
import time

import numpy as np

TWO = ["Nikon 5100 (NPL)", "Canon EOS 5D Mark II"]


def _rss_mb() -> float:
    with open("/proc/self/statm") as fh:
        return int(fh.read().split()[1]) * resource.getpagesize() / 2**20


def child(method: str, n: int, distinct: int) -> dict:
    """One run: fit ``method``, build the image, correct it; memory figures in MiB."""
    from zonotope.correct import correction_problem, fit_correction
    from zonotope.correct.image import correct_image
    from zonotope.evaluate import natural_test_sets

    W = np.arange(400, 701, 10)
    problem = correction_problem(TWO, shape=W)
    X = np.concatenate([t.reflectances for t in natural_test_sets(W)])
    rng = np.random.default_rng(0)
    base = problem.source_of(X[rng.integers(0, X.shape[0], distinct)]) * rng.uniform(0.2, 1.0, (distinct, 1))
    corrector = fit_correction(problem, method=method)
    img = np.empty((n, 1, problem.k), dtype=np.float32)
    step = 1 << 20
    for i in range(0, n, step):  # without an N-sized index array
        m = min(step, n - i)
        img[i : i + m, 0] = base[rng.integers(0, distinct, m)]
    setup = _rss_mb()
    t0 = time.perf_counter()
    out = correct_image(img, corrector)
    seconds = time.perf_counter() - t0
    peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
    return {
        "method": method,
        "n": n,
        "setup_mb": setup,
        "peak_mb": peak,
        "output_mb": out.nbytes / 2**20,
        "input_mb": img.nbytes / 2**20,
        "seconds": seconds,
        "finite": bool(np.isfinite(out).all()),
    }


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--sizes", nargs="+", type=int, default=[1_000_000, 10_000_000])
    ap.add_argument("--methods", nargs="*", default=None, help="default: every two-camera estimator")
    ap.add_argument("--distinct", type=int, default=2000)
    ap.add_argument("--json", default=None)
    ap.add_argument("--child", nargs=2, metavar=("METHOD", "N"), help=argparse.SUPPRESS)
    args = ap.parse_args()
    if args.child:
        print(json.dumps(child(args.child[0], int(args.child[1]), args.distinct)))
        return
    from zonotope.correct import CORRECTION_METHODS

    methods = args.methods or [m for m in CORRECTION_METHODS if m != "Dyer 2017"]  # Dyer: one RGB camera
    rows = []
    for method in methods:
        for n in args.sizes:
            cmd = [sys.executable, __file__, "--child", method, str(n), "--distinct", str(args.distinct)]
            done = subprocess.run(cmd, capture_output=True, text=True)
            if done.returncode != 0:
                print(f"{method:15s} N={n:>9,d}  failed: {done.stderr.strip().splitlines()[-1:]}", flush=True)
                continue
            r = json.loads(done.stdout.strip().splitlines()[-1])
            rows.append(r)
            work = r["peak_mb"] - r["setup_mb"] - r["output_mb"]
            print(
                f"{method:15s} N={n:>11,d}  setup {r['setup_mb']:7.0f} MiB (input {r['input_mb']:5.0f})  "
                f"peak {r['peak_mb']:7.0f} MiB  output {r['output_mb']:5.0f} MiB  working {work:6.0f} MiB  "
                f"{r['seconds']:7.1f} s",
                flush=True,
            )
    if args.json:
        with open(args.json, "w") as fh:
            json.dump(rows, fh, indent=1)


if __name__ == "__main__":
    main()
