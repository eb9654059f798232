"""Benchmark: the estimators' bias on neutral greys as the response tolerance δ grows.

The simulated capture's problem (``splat.sim.capture.SimCaptureConfig.ci()`` cameras: Nikon 5100 (NPL),
Sigma SD Merrill (NPL), Canon EOS 5D Mark II; D65, CIE 1931 2°, 400–700 nm (400–680 nm with the Sigma) /
10 nm, trained on rawtoaces 190), fitted for each δ as the capture pipeline does
(``noise_options(method, δ / DELTA_SIGMAS)``: the regressions and ``"Prior"`` get ``noise = σ``,
``"Centroid"`` ``delta = δ``). Test surfaces: the flat white card (reflectance 0.9) and the six neutral
patches of ColorChecker N Ohta (white 9.5 … black 2). Per method, δ and patch: Δa*, Δb* and ΔE00 of the
estimate of the exact response (noise-free), and the mean Δa*, Δb*, ΔE00 over ``--draws`` noisy
responses (Gaussian σ = δ / DELTA_SIGMAS per channel, seeded, the same draws for every method).

With ``--all-colours`` it runs instead the cells of ``benchmarks/bench_noise.py`` (natural and atypical
test sets, 1–3 cameras, shot-limited noise σ at white; same data, draws and code) for every estimator that
does not preserve the white by default (registry property ``white_point``; plus ``"Centroid"``, told
δ = DELTA_SIGMAS · σ at white) as fitted by default and with ``white_point=True``, in this
one process: the labels ``bench_noise.py`` prints, the white-point preserving ones suffixed `` wp``.

Run: ``python benchmarks/bench_neutral_bias.py [--cameras 1 2 3] [--deltas 0.001 0.011 0.03 0.13]
[--methods Prior Centroid Guarded "NA root-poly" "NA linear"] [--draws 50] [--json out.json]``.
A method label ``NAME+key=value`` passes an option, e.g. ``"Prior+white_point=True"``.
``python benchmarks/bench_neutral_bias.py --all-colours [--cameras 1 2 3] [--sigmas 0 0.002 0.005]
[--size 150] [--atypical 100] [--methods ...] [--json out.json]``.
"""

from __future__ import annotations

import argparse
import ast
import json
import time
from pathlib import Path

import colour
import numpy as np

from zonotope.correct import DELTA_SIGMAS, correction_problem, fit_correction, noise_options

CAMERAS = ["Nikon 5100 (NPL)", "Sigma SDMerill (NPL)", "Canon EOS 5D Mark II"]
LABELS = {"NA root-poly": "Finlayson 2015", "NA linear": "Cheung 2004"}
PATCHES = ["card 0.9", "white 9.5", "neutral 8", "neutral 6.5", "neutral 5", "neutral 3.5", "black 2"]


def _line(cell, suffix: str = "") -> str:
    """Δa*, Δb* and ΔE00 of each patch of ``cell`` (keys ``da``, ``db``, ``dE00`` + ``suffix``)."""
    da = " ".join(f"{r['da' + suffix]:+.2f}" for r in cell)
    db = " ".join(f"{r['db' + suffix]:+.2f}" for r in cell)
    de = " ".join(f"{r['dE00' + suffix]:.2f}" for r in cell)
    return f"Δa* {da}  Δb* {db}  ΔE00 {de}"


def problem_of(n_cams: int):
    """The capture's correction problem of its first ``n_cams`` cameras (as ``correction_problem_of``)."""
    import zonotope

    cams = CAMERAS[:n_cams]
    curves = [zonotope.load_camera(c) for c in cams]
    obs, light = zonotope.observer("CIE 1931 2°"), zonotope.illuminant("D65")
    common = zonotope.common_shape(*curves, obs, light, interval=10)
    shape = np.arange(max(common.start, 400.0), min(common.end, 700.0) + 5, 10.0)
    return correction_problem(
        cams, target="CIE 1931 2°", illuminant="D65", shape=shape, training="rawtoaces 190"
    )


def neutrals(wavelengths) -> np.ndarray:
    """The white card and the six ColorChecker N Ohta neutrals, reflectances ``(7, n)``."""
    cc = colour.SDS_COLOURCHECKERS["ColorChecker N Ohta"]
    rows = [np.full(wavelengths.size, 0.9)]
    for name in ("white 9.5 (.05 D)", "neutral 8 (.23 D)", "neutral 6.5 (.44 D)", "neutral 5 (.70 D)"):
        rows.append(cc[name].copy().interpolate(colour.SpectralShape(380, 780, 1))[wavelengths])
    for name in ("neutral 3.5 (1.05 D)", "black 2 (1.5 D)"):
        rows.append(cc[name].copy().interpolate(colour.SpectralShape(380, 780, 1))[wavelengths])
    return np.array(rows)


def parse_label(label: str) -> tuple[str, dict]:
    """``"Prior+white_point=True"`` → ("Prior", {"white_point": True})."""
    name, *opts = label.split("+")
    extra = {}
    for o in opts:
        key, value = o.split("=", 1)
        try:
            extra[key] = ast.literal_eval(value)
        except (ValueError, SyntaxError):
            extra[key] = value
    return LABELS.get(name, name), extra


def run(args) -> list[dict]:
    rows = []
    for n_cams in args.cameras:
        problem = problem_of(n_cams)
        R = neutrals(problem.wavelengths)
        C, T = problem.source_of(R), problem.target_of(R)
        lab_true = problem.to_Lab(T)
        for delta in args.deltas:
            sigma = delta / DELTA_SIGMAS
            rng = np.random.default_rng(7)
            noisy = C[None] + rng.normal(0.0, sigma, (args.draws, *C.shape))
            for label in args.methods:
                name, extra = parse_label(label)
                t0 = time.perf_counter()
                est = fit_correction(problem, method=name, **noise_options(name, sigma), **extra)
                fit_s = time.perf_counter() - t0
                lab0 = problem.to_Lab(est(C))
                labn = problem.to_Lab(est(noisy.reshape(-1, problem.k)).reshape(args.draws, *C.shape[:1], 3))
                d0 = lab0 - lab_true
                dn = (labn - lab_true).mean(axis=0)
                e0 = colour.delta_E(lab0, lab_true, method="CIE 2000")
                en = colour.delta_E(labn, lab_true, method="CIE 2000").mean(axis=0)
                for i, patch in enumerate(PATCHES):
                    rows.append(
                        {
                            "cameras": n_cams,
                            "delta": delta,
                            "method": label,
                            "patch": patch,
                            "da": float(d0[i, 1]),
                            "db": float(d0[i, 2]),
                            "dE00": float(e0[i]),
                            "da_noisy": float(dn[i, 1]),
                            "db_noisy": float(dn[i, 2]),
                            "dE00_noisy": float(en[i]),
                        }
                    )
                cell = rows[-len(PATCHES) :]
                print(
                    f"{n_cams} cam δ={delta:<6g} {label:28s} fit {fit_s:6.1f} s  " + _line(cell), flush=True
                )
                print(f"{'':30s}{'noisy mean':>27s}          " + _line(cell, "_noisy"), flush=True)
    return rows


def all_colours(args) -> list[dict]:
    """``bench_noise.py``'s cells with each white-point capable method also fitted ``white_point=True``."""
    import bench_noise

    from zonotope.correct import CORRECTION_METHODS

    plain = bench_noise.methods

    def methods(model, sigma_rms):
        rows = dict(plain(model, sigma_rms))
        rows["Centroid"] = ("Centroid", noise_options("Centroid", model))  # δ from σ at white
        out = {}
        for label, (name, opts) in rows.items():
            if model is None and label in ("NA linear", "NA root-poly", "aug root-poly", "Prior naive"):
                continue  # bench_noise skips these without noise (identical to the naive fits)
            out[label] = (name, opts)
            if not CORRECTION_METHODS.properties(name)["white_point"]:  # not already its default
                out[label + " wp"] = (name, {**opts, "white_point": True})
        return out

    bench_noise.methods = methods
    bench_noise.DATA = Path(args.data) if args.data else bench_noise.DATA
    rows = []
    for n in args.cameras:
        for sigma in args.sigmas:
            rows += bench_noise.run_cell(n, sigma, args)
    print("\nwhite-point preserving − default, mean / p95 ΔE00 (same process, same draws):")
    for r in rows:
        if r["method"].endswith(" wp"):
            base = next(
                b
                for b in rows
                if (b["cameras"], b["sigma"], b["set"], b["method"])
                == (r["cameras"], r["sigma"], r["set"], r["method"][:-3])
            )
            print(
                f"{r['cameras']} cam σ={r['sigma']:<6g} {r['set']:8s} {r['method'][:-3]:16s} "
                f"mean {base['mean']:.3f} → {r['mean']:.3f} ({r['mean'] - base['mean']:+.3f})  "
                f"p95 {base['p95']:.2f} → {r['p95']:.2f} ({r['p95'] - base['p95']:+.2f})"
            )
    return rows


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--cameras", nargs="+", type=int, default=[3], choices=[1, 2, 3])
    ap.add_argument("--deltas", nargs="+", type=float, default=[0.001, 0.011, 0.03, 0.13])
    ap.add_argument("--methods", nargs="+", default=None)
    ap.add_argument("--draws", type=int, default=300)
    ap.add_argument("--json", type=Path, default=None)
    ap.add_argument("--all-colours", action="store_true", help="bench_noise.py's cells, with white_point")
    ap.add_argument("--sigmas", nargs="+", type=float, default=[0.0, 0.002, 0.005])
    ap.add_argument("--size", type=int, default=150)
    ap.add_argument("--atypical", type=int, default=100)
    ap.add_argument("--data", default=None, help="../shared/data by default")
    args = ap.parse_args()
    args.noise_kind, args.coverage = "shot", False  # bench_noise.run_cell's remaining options
    if args.all_colours:
        rows = all_colours(args)
    else:
        args.methods = args.methods or ["Prior", "Centroid", "Guarded", "NA root-poly", "NA linear"]
        print("patches: " + ", ".join(PATCHES))
        rows = run(args)
    if args.json:
        args.json.write_text(json.dumps(rows, indent=1))


if __name__ == "__main__":
    main()
