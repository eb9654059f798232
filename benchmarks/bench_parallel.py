"""Throughput of the batch paths, serial vs a local Dask cluster, and the per-task overhead.

Baseline: the serial executor (this process), in the same run. For each path the same items run
``--repeat`` times (median reported) on: serial; a local Dask cluster of ``--workers`` processes
(one thread each) started once and reused (its start-up time is reported apart, it is paid once
per batch by the CLIs). Results are checked identical to the serial ones.

Work is split

- MMVs: per chunk of ``--chunk`` responses (the lockstep simplex shares its per-call overhead
  inside a chunk, so a chunk is also the smallest unit worth a task);
- images: per file (RAW development is independent per file and each output is written by the
  task that made it, so nothing but a status row travels back);
- survey: per camera set (the cameras and reflectance sets are sent to each worker once).

Run: ``python benchmarks/bench_parallel.py [--quick]``.
"""

from __future__ import annotations

import argparse
import os
import statistics
import tempfile
import time
from pathlib import Path

import numpy as np


def _median_time(fn, repeat):
    ts, out = [], None
    for _ in range(repeat):
        t = time.perf_counter()
        out = fn()
        ts.append(time.perf_counter() - t)
    return statistics.median(ts), out


def _noop(x):
    return x


def _dngs(folder: Path, n: int, size: int) -> list[Path]:
    import zonotope
    from isp.simulate import chart_image, simulate_capture, simulate_dng, spectral_setup

    setup = spectral_setup("Nikon 5100 (NPL)")
    R = zonotope.resample(zonotope.reflectances("ColorChecker N Ohta"), setup.wavelengths).T.clip(0, 1)
    out = []
    for i in range(n):
        image, _ = chart_image(R[np.random.default_rng(i).permutation(24)], rows=4, cols=6, patch=size, gap=2)
        cap = simulate_capture(image, setup, training=R, seed=i)
        out.append(simulate_dng(folder / f"shot{i}.dng", cap))
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--quick", action="store_true")
    ap.add_argument("--workers", type=int, default=os.cpu_count() or 2)
    ap.add_argument("--repeat", type=int, default=5)
    ap.add_argument("--chunk", type=int, default=64)
    ap.add_argument("--mmvs", type=int, help="responses (default 1024, 256 with --quick)")
    ap.add_argument("--images", type=int, help="DNG files (default 12, 6 with --quick)")
    ap.add_argument(
        "--cameras",
        type=int,
        help="measured cameras added to the 3 built-in ones (default 3, 1 with --quick)",
    )
    args = ap.parse_args()

    from isp import default_pipeline
    from isp.batch import _develop_one
    from zonotope.mismatch import MetamerMismatch, metamer_mismatch_batch
    from zonotope.parallel import FileTask, executor, run_files
    from zonotope.survey import load_cameras, survey

    n_mmv = args.mmvs or (256 if args.quick else 1024)
    n_img = args.images or (6 if args.quick else 12)
    n_noop = 200 if args.quick else 1000
    print(
        f"machine: {os.cpu_count()} cores, shared with other users while this ran (timings are noisy); "
        f"local cluster: {args.workers} worker processes × 1 thread; median of {args.repeat}",
        flush=True,
    )
    print("| path | unit | serial (this process) | local cluster | speed-up, check |")
    print("|---|---|---:|---:|---|", flush=True)

    class Rows(list):
        def append(self, row):  # print each row as soon as it is measured
            super().append(row)
            print("| " + " | ".join(row) + " |", flush=True)

    rows = Rows()
    where = f"local:{args.workers}"
    t0 = time.perf_counter()
    with executor(where) as ex:
        startup = time.perf_counter() - t0
        rows.append(("local cluster start-up (once per batch)", "", f"{startup:.1f} s", "", ""))
        # per-task overhead: a task that does nothing
        ts, _ = _median_time(lambda: list(ex.map(_noop, range(n_noop))), args.repeat)
        ts_s, _ = _median_time(lambda: list(map(_noop, range(n_noop))), args.repeat)
        rows.append(
            (
                "per-task overhead (no-op task)",
                "",
                f"{ts_s / n_noop * 1e6:.2f} µs",
                f"{ts / n_noop * 1e3:.2f} ms",
                "",
            )
        )

        # MMVs: certified (ε = 1e-3), 10 nm, one camera → LMS
        mm = MetamerMismatch("Nikon 5100 (NPL)", shape=np.arange(400.0, 701.0, 10.0))
        rng = np.random.default_rng(0)
        X = rng.random((n_mmv, 31)) @ np.triu(np.ones((31, 31))) / 31 * rng.random((n_mmv, 1)) * 2
        C = mm.source_of(np.clip(X, 0, 1))

        def mmvs(executor=None):
            return metamer_mismatch_batch(mm.Phi, mm.Psi, C, chunk=args.chunk, executor=executor)

        t_s, a = _median_time(mmvs, args.repeat)
        t_d, b = _median_time(lambda: mmvs(ex), args.repeat)
        same = np.array_equal(a.centroids, b.centroids) and np.array_equal(a.volume_bounds, b.volume_bounds)
        rows.append(
            (
                f"MMVs/s ({n_mmv} responses, chunks of {args.chunk})",
                "MMVs/s",
                f"{n_mmv / t_s:.0f}",
                f"{n_mmv / t_d:.0f}",
                f"{t_s / t_d:.2f}× {'identical' if same else 'DIFFER'}",
            )
        )

        # images: isp develop of simulated DNGs, one task per file
        with tempfile.TemporaryDirectory() as tmp:
            tmp = Path(tmp)
            (tmp / "in").mkdir()
            files = _dngs(tmp / "in", n_img, 40)
            # isp develop's defaults: (pipeline, crop, save_stages)
            options = (default_pipeline(), None, None)
            counter = iter(range(10**6))

            def develop(scheduler):
                out = tmp / f"out{next(counter)}"
                out.mkdir()
                tasks = [FileTask(str(f), str(out / f"{f.stem}.tif")) for f in files]
                return run_files(
                    tasks, _develop_one, options, manifest=out / "manifest.csv", scheduler=scheduler
                )

            t_s, r1 = _median_time(lambda: develop("serial"), args.repeat)
            addr = ex.client.scheduler.address
            t_d, r2 = _median_time(lambda: develop(addr), args.repeat)
            ok = all(r["status"] == "ok" for r in r1 + r2)
            h, w = 4 * 40 + 5 * 2, 6 * 40 + 7 * 2
            rows.append(
                (
                    f"images/min (isp develop, {n_img} DNGs of {w}×{h})",
                    "images/min",
                    f"{n_img / t_s * 60:.0f}",
                    f"{n_img / t_d * 60:.0f}",
                    f"{t_s / t_d:.2f}× {'all ok' if ok else 'FAILED'}",
                )
            )

        # camera sets: survey of pairs
        cams, _ = load_cameras(["Nikon 5100 (NPL)", "Sigma SDMerill (NPL)", "Canon EOS 5D Mark II"])
        shared = Path(__file__).resolve().parents[2] / "shared" / "data" / "ssf_jiang2013_camspec"
        if shared.is_dir():
            more, _ = load_cameras(shared)
            extra = args.cameras if args.cameras is not None else 1 if args.quick else 3
            for name in sorted(more)[:extra]:
                cams[name] = more[name]
        n_sets = len(cams) * (len(cams) - 1) // 2
        t_s, s1 = _median_time(lambda: survey(cams, size=2, scheduler="serial"), args.repeat)
        t_d, s2 = _median_time(
            lambda: survey(cams, size=2, scheduler=ex.client.scheduler.address), args.repeat
        )
        same = [(r.cameras, r.vora, r.mmv_median, r.dE00) for r in s1] == [
            (r.cameras, r.vora, r.mmv_median, r.dE00) for r in s2
        ]
        rows.append(
            (
                f"camera sets/min (survey, {len(cams)} cameras, {n_sets} pairs)",
                "sets/min",
                f"{n_sets / t_s * 60:.1f}",
                f"{n_sets / t_d * 60:.1f}",
                f"{t_s / t_d:.2f}× {'identical' if same else 'DIFFER'}",
            )
        )


if __name__ == "__main__":
    main()
