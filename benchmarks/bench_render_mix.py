"""Prior's λ for the render corrected alone: the cross-validated λ against λ = 1 (the MAP estimate alone,
:func:`splat.capture.pipeline_mix`), on a trained and corrected run.

    python benchmarks/bench_render_mix.py CAPTURE OUT                 # scored against CAPTURE/truth
    python benchmarks/bench_render_mix.py CAPTURE OUT --view nikon/DSC_0002.dng [--truth T.tiff] [--rows 96]

Without ``--view``: :func:`splat.scoring.score` of a copy of OUT (the scorer writes ``score.json``), all
cameras, once with each λ rule in the same process, printing the render-alone ΔE00 (all pixels, flat
pixels, chart-patch and uniform-surface means) and the scorer's wall time (most of it the render's
correction). With ``--view``: that view's render corrected alone with each rule (the correct step's δ,
white and quantum), alternated ``--runs`` times: wall time, distinct responses solved, the ΔE00 between
the two, and with ``--truth`` (an XYZ TIFF whose size divides the render's) the ΔE00 of each to it.
"""

from __future__ import annotations

import argparse
import json
import shutil
import statistics
import tempfile
import time
from pathlib import Path

import numpy as np


def _rules():
    return {"cross-validated λ": None, "λ = 1 (pipeline_mix)": 1.0}


def _scored(capture: Path, out: Path) -> None:
    import splat.capture as C
    from splat.capture import read_capture
    from splat.scoring import score

    cams = read_capture(capture).cameras
    names = "+".join(c.folder for c in cams)
    label = f"Prior:{names}"
    real = C.pipeline_mix
    print(
        "| λ | all pixels | flat | chart means | uniform means | scorer wall s |\n"
        "|---|---:|---:|---:|---:|---:|"
    )
    for rule, mix in _rules().items():
        with tempfile.TemporaryDirectory() as d:
            work = Path(d) / "out"
            shutil.copytree(out, work)
            C.pipeline_mix = lambda method, mix=mix: mix  # the scorer reads it from splat.capture
            try:
                t = time.perf_counter()
                res = score(
                    capture, work, methods=("Prior",), raw_methods=(), subsets=[tuple(range(len(cams)))]
                )
                wall = time.perf_counter() - t
            finally:
                C.pipeline_mix = real
        cells = [
            res.get(sect, {}).get(label, {}).get("mean")
            for sect in ("delta_E00", "flat_delta_E00", "chart_delta_E00", "uniform_delta_E00")
        ]
        print(
            f"| {rule} | " + " | ".join("–" if c is None else f"{c:.3f}" for c in cells) + f" | {wall:.0f} |"
        )


def _view(capture: Path, out: Path, name: str, truth: Path | None, rows: int | None, runs: int) -> None:
    import colour
    import tifffile

    from splat.capture import (
        PipelineConfig,
        correction_problem_of,
        fit_corrector,
        read_capture,
        read_index,
    )
    from zonotope.correct.image import correct_image

    spec = read_capture(capture)
    index = read_index(spec, out / "render" / "index.json")
    white = json.loads((out / "correct" / "white.json").read_text())
    level = json.loads((out / "correct" / "levels.json").read_text())["level"]
    scale = np.concatenate([np.asarray(s) * level[k] for k, s in enumerate(white["scale"])])
    delta = json.loads((out / "correct" / "delta.json").read_text())["delta"]
    quantum = PipelineConfig().quantum
    img = np.asarray(tifffile.imread(out / "render" / index[name]["dir"] / "render.tiff"), float)
    img = np.maximum(img / scale, 0)[slice(rows)]
    n = len(spec.cameras)
    wXYZ = correction_problem_of(spec, list(range(n))).white_XYZ
    xy = colour.XYZ_to_xy(wXYZ)

    def lab(X):
        return colour.XYZ_to_Lab(X / wXYZ[1], xy)

    fits = {
        rule: fit_corrector(spec, list(range(n)), "Prior", delta, mix=mix) for rule, mix in _rules().items()
    }
    times = {rule: [] for rule in fits}
    got, solved = {}, {}
    for _ in range(runs):
        for rule, cor in fits.items():  # alternated, so that the machine's load falls on both alike
            seen = [0]
            t = time.perf_counter()
            got[rule] = correct_image(
                img, cor, quantum=quantum, progress=lambda _w, _d, n_, seen=seen: seen.__setitem__(0, n_)
            )
            times[rule].append(time.perf_counter() - t)
            solved[rule] = seen[0]
    print(
        f"{name}, {img.shape[1]} × {img.shape[0]} px, δ = {delta:.4g}, quantum {quantum}, medians of {runs}:"
    )
    a, b = got.values()
    d = colour.delta_E(lab(a), lab(b), method="CIE 2000")
    for rule in fits:
        print(
            f"  {rule}: {statistics.median(times[rule]):.1f} s wall, {solved[rule]} distinct responses solved"
        )
    print(f"  ΔE00 between them: mean {np.mean(d):.3f}, p95 {np.percentile(d, 95):.3f}, max {np.max(d):.3f}")
    if truth is not None:
        ref = np.asarray(tifffile.imread(truth), float)
        f = a.shape[0] // ref.shape[0] if rows is None else a.shape[1] // ref.shape[1]
        ref = ref[: a.shape[0] // f]
        for rule, X in got.items():
            Xb = (
                X[: ref.shape[0] * f, : ref.shape[1] * f]
                .reshape(ref.shape[0], f, ref.shape[1], f, 3)
                .mean((1, 3))
            )
            e = colour.delta_E(lab(ref), lab(Xb), method="CIE 2000")
            print(
                f"  {rule}: ΔE00 to the truth (render binned {f}×) mean {np.mean(e):.3f}, "
                f"median {np.median(e):.3f}"
            )


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("capture", type=Path)
    ap.add_argument("out", type=Path)
    ap.add_argument("--view", help="a rendered view's name (e.g. nikon/DSC_0002.dng): time both rules on it")
    ap.add_argument("--truth", type=Path, help="with --view: the view's true XYZ (TIFF)")
    ap.add_argument("--rows", type=int, help="with --view: the first ROWS rows of the render only")
    ap.add_argument("--runs", type=int, default=1)
    a = ap.parse_args(argv)
    if a.view:
        _view(a.capture, a.out, a.view, a.truth, a.rows, a.runs)
    else:
        _scored(a.capture, a.out)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
