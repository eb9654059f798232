"""What the curves of another unit of the same camera model cost a stacked correction.

Seven camera models were measured twice by different laboratories (rawtoaces, camspec, NPL, the
spectroscope set): the two measurements differ by what separates two units of one model plus what
separates two measurement set-ups — the situation of every user of a published curve set, which is
never of their own unit. For every set of 1–3 of those models and every choice of which measurement
plays the user's camera (B) and which the published curves (A), a correction is fitted on A's curves
and applied to B's responses, against the same estimator fitted on B's own curves (the baseline of
``bench_ssf_stack.py``: the camera's very curves, told only the sensor noise). Fits compared, in one
process:

* ``another unit``: A's curves, told only the sensor noise (what a user of published curves does);
* ``another unit, s × unit σ`` (``--scales``): A's curves told s × the RMS response difference of the
  OTHER models' measurement pairs (default s = ``SSF_FIT_SIGMA_SCALE``, the rule the shipped SSF
  estimate follows for its own error); ``own curves, s × unit σ``: B's own curves told the same (what
  that σ costs a user whose curves are their unit's);
* ``DNG estimate``: B's curves estimated from DNG matrices synthesised from them (basis learned
  without the model), told its calibrated σ — what ``zonotope ssf estimate`` gives.

Why: the goal for estimated curves is stated against the camera's very curves; this measures how
far measured curves of the same model, as a user gets them, are from that baseline themselves.

    python benchmarks/bench_ssf_units.py --data ../shared/data
"""

from __future__ import annotations

import argparse
import itertools
import sys
import time
from pathlib import Path

import numpy as np

from zonotope._tol import SSF_FIT_SIGMA_SCALE
from zonotope.correct import NoiseModel, correction_problem, fit_correction, noise_options
from zonotope.evaluate import atypical_test_sets, natural_test_sets
from zonotope.spectra.estimate import SSF_SHAPE

sys.path.insert(0, str(Path(__file__).parent))
from bench_ssf import measured_cameras, msds
from bench_ssf_stack import Source, print_delta_table, score_fits, training_responses

W = np.asarray(SSF_SHAPE.wavelengths)
FITS = ("another unit", "DNG estimate")


def unit_pairs(cams: dict[str, dict]) -> dict[str, list[str]]:
    """Model → its distinct measurements (two or more; the same data shipped twice counted once)."""
    groups: dict[str, list[str]] = {}
    for n, c in cams.items():
        members = groups.setdefault(c["model"], [])
        if not any(np.allclose(cams[m]["values"], c["values"]) for m in members):
            members.append(n)
    return {m: v for m, v in groups.items() if len(v) >= 2}


def fit(pb, told, method: str):
    told = np.broadcast_to(np.asarray(told, dtype=float), (pb.Phi.shape[1],))
    if not np.any(told > 0):
        return fit_correction(pb, method=method)
    model = NoiseModel(np.zeros(told.size), np.square(told), source="told")
    return fit_correction(pb, method=method, **noise_options(method, model))


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--data", type=Path, required=True)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--methods", default="Cheung 2004,Finlayson 2015")
    ap.add_argument(
        "--scales",
        default=f"{SSF_FIT_SIGMA_SCALE:g}",
        help="multiples of the other models' RMS unit difference to tell the fits on A's and on B's curves",
    )
    a = ap.parse_args(argv)
    methods = a.methods.split(",")
    scales = [float(v) for v in a.scales.split(",") if v]
    fits_told = [f"{who}, {v:g} × unit σ" for v in scales for who in ("another unit", "own curves")]
    cols = [*FITS, *fits_told]
    cams = measured_cameras(a.data)
    pairs = unit_pairs(cams)
    print(f"{len(pairs)} models measured twice: " + ", ".join(v[0] for v in pairs.values()), file=sys.stderr)
    t0 = time.perf_counter()
    dng = Source(cams, "dng", seed=a.seed)
    print(f"{len(cams)} DNG estimates in {time.perf_counter() - t0:.0f} s", file=sys.stderr)
    resp = {n: training_responses(cams[n]["values"], n) for v in pairs.values() for n in v}
    diff = {  # (user's B, published A) → B's responses minus A's, white-balanced, 190 patches
        (b, x): resp[b] - resp[x] for v in pairs.values() for b in v for x in v if b != x
    }
    rms = np.sqrt(np.mean(np.square(np.concatenate(list(diff.values()))), axis=0))
    print(
        "RMS response difference of two measurements of one model R / G / B: "
        + " / ".join(f"{v:.4f}" for v in rms)
    )
    print(
        "DNG estimates of the same cameras, RMS response error R / G / B: "
        + " / ".join(
            f"{v:.4f}"
            for v in np.sqrt(np.mean(np.square(np.concatenate([dng.err[b] for b, _ in diff])), axis=0))
        )
    )

    tests = natural_test_sets(W, data_dir=a.data, size=150, seed=a.seed) + atypical_test_sets(
        W, 100, seed=a.seed
    )
    acc: dict = {}
    t0 = time.perf_counter()
    models = list(pairs)
    for size in (1, 2, 3):
        for combo in itertools.combinations(models, size):
            others = [d for (b, _), d in diff.items() if cams[b]["model"] not in combo]
            unit_rms = np.tile(np.sqrt(np.mean(np.square(np.concatenate(others)), axis=0)), size)
            for roles in itertools.product(*[list(itertools.permutations(pairs[m], 2)) for m in combo]):
                users, published = [b for b, _ in roles], [x for _, x in roles]
                truth = correction_problem([msds(cams[n]["values"], n) for n in users], shape=SSF_SHAPE)
                other = correction_problem([msds(cams[n]["values"], n) for n in published], shape=SSF_SHAPE)
                est = correction_problem([dng.est[n].sensitivities for n in users], shape=SSF_SHAPE)
                cal = np.concatenate([dng.calibrated(n, set(combo)) for n in users])
                for sigma in (0.0, 0.005):
                    for m in methods:
                        fits = {
                            "own curves": fit(truth, sigma, m),
                            "another unit": fit(other, sigma, m),
                            "DNG estimate": fit(est, np.sqrt(sigma**2 + np.square(cal)), m),
                        }
                        for v in scales:
                            told = np.sqrt(sigma**2 + np.square(v * unit_rms))
                            fits[f"another unit, {v:g} × unit σ"] = fit(other, told, m)
                            fits[f"own curves, {v:g} × unit σ"] = fit(truth, told, m)
                        score_fits(acc, truth, tests, fits, size=size, sigma=sigma, method=m, seed=a.seed)
    print(f"corrections in {time.perf_counter() - t0:.0f} s", file=sys.stderr)
    print(
        "\n(mean ΔE00 over test sets and role choices; in brackets Δ to the fit on the camera's own curves)\n"
    )
    print_delta_table(acc, methods, cols, "own curves")
    return 0


if __name__ == "__main__":
    sys.exit(main())
