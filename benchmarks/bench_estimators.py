"""Benchmark: the default estimator against the issue-14 goals, on every set ``zonotope evaluate`` knows.

For 1, 2 and 3 cameras (built-in Nikon 5100, Canon EOS 5D Mark II, Sigma SD Merrill; 400–700 nm, or
400–680 nm with the Sigma), D65, CIE 2015 XYZ, trained on rawtoaces 190, tested on the natural sets of
``../shared/data`` (150-spectrum subsets) and both atypical generators (100 spectra each), with test
spectra within 0.02 of a training spectrum removed. Prints per cell whether ``"Prior"`` meets:

- natural set: mean ΔE00 ≤ best regression (Cheung 2004, Finlayson 2015) + 0.03;
- atypical set: mean ΔE00 ≤ min(MAP, Centroid);
- pooled natural 95th percentile ≤ best regression's + 0.3;

plus pooled mean / p95 / max and paired comparisons (every baseline runs in the same process). The column
"Prior 1λ" is the previous default in the same run: one MAP weight λ for every response, the best one of
the same cross-validation (the diagonal λ_in = λ_bd of its scores), so before/after come from one process
and one MMV engine. Per cell the 95th percentiles of Prior, of the previous default and of the reference
(the best regression on natural sets, the better of MAP and Centroid on atypical ones) follow.

Run: ``python benchmarks/bench_estimators.py [--sets N C NS NC NSC] [--size 150] [--atypical 100]``
"""

from __future__ import annotations

import argparse
import os
from pathlib import Path

import colour
import numpy as np

from zonotope.correct import correction_problem, fit_correction
from zonotope.evaluate import atypical_test_sets, evaluate, natural_test_sets, source_split

DATA = Path(os.environ.get("ZONOTOPE_SHARED_DATA", Path(__file__).resolve().parents[2] / "shared" / "data"))
CAMERAS = {
    "N": ["Nikon 5100 (NPL)"],
    "C": ["Canon EOS 5D Mark II"],
    "NS": ["Nikon 5100 (NPL)", "Sigma SDMerill (NPL)"],
    "NC": ["Nikon 5100 (NPL)", "Canon EOS 5D Mark II"],
    "NSC": ["Nikon 5100 (NPL)", "Sigma SDMerill (NPL)", "Canon EOS 5D Mark II"],
}
METHODS = ("Cheung 2004", "Finlayson 2015", "MAP", "Centroid", "Prior")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--sets", nargs="+", default=list(CAMERAS), choices=list(CAMERAS))
    ap.add_argument("--size", type=int, default=150)
    ap.add_argument("--atypical", type=int, default=100)
    args = ap.parse_args()
    met = total = met_prev = 0
    for key in args.sets:
        cams = CAMERAS[key]
        shape = colour.SpectralShape(400, 680 if any("Sigma" in c for c in cams) else 700, 10)
        w = shape.wavelengths
        sets = natural_test_sets(w, data_dir=DATA if DATA.is_dir() else None, size=args.size)
        sets += atypical_test_sets(w, args.atypical)
        ev = evaluate([cams], methods=METHODS, shape=shape, test_sets=sets, noise=0.0)
        label = ev.rows[0].cameras
        problem = correction_problem(cams, shape=shape)
        current = fit_correction(problem, method="Prior")
        mix_cv = current.params["mix_cv"]
        one = mix_cv["one"][0]
        previous = fit_correction(problem, method="Prior", mix=one)
        split = {t.name: t.reflectances for t in source_split(sets, problem.training)[0]}
        lam_in, lam_bd = current.params["mix"]
        print(
            f"\n== {label}   (λ by CV on the training side: (λ_in, λ_bd) = ({lam_in:.1f}, {lam_bd:.1f}); "
            f"best pair {mix_cv['best']}, best single λ {one:.1f}, paired gain {mix_cv['gain']:.4f} "
            f"± {mix_cv['se']:.4f})"
        )
        print(
            f"{'test set':22s}"
            + "".join(f"{m:>15s}" for m in METHODS)
            + f"{'Prior 1λ':>11s}  goal (1λ)       p95: Prior / 1λ / reference"
        )
        for name in dict.fromkeys(r.test_set for r in ev.rows):
            rows = {r.method: r for r in ev.rows if r.test_set == name}
            mean = {m: rows[m].mean for m in METHODS}
            X = split[name]
            prev_dE = problem.delta_E(previous(problem.source_of(X)), problem.target_of(X))
            prev = float(np.mean(prev_dE))
            if rows["Prior"].kind == "natural":
                goal = min(mean["Cheung 2004"], mean["Finlayson 2015"]) + 0.03
                ref = min(("Cheung 2004", "Finlayson 2015"), key=mean.get)
            else:
                goal = min(mean["MAP"], mean["Centroid"])
                ref = min(("MAP", "Centroid"), key=mean.get)
            ok, ok_prev = mean["Prior"] <= goal, prev <= goal
            met, met_prev, total = met + ok, met_prev + ok_prev, total + 1
            print(
                f"{name[:22]:22s}"
                + "".join(f"{mean[m]:15.3f}" for m in METHODS)
                + f"{prev:11.3f}"
                + ("  met" if ok else "  MISSED")
                + (" (met)   " if ok_prev else " (MISSED)")
                + f"  {rows['Prior'].p95:.2f} / {np.percentile(prev_dE, 95):.2f}"
                + f" / {rows[ref].p95:.2f} ({ref})"
            )
        for kind in ("natural", "atypical"):
            pooled = ev.pooled_stats(kind, label)
            print(
                f"pooled {kind} mean / p95 / max: "
                + ", ".join(f"{m} {v[1]:.3f} / {v[2]:.2f} / {v[3]:.1f}" for m, v in pooled.items())
            )
            for other in METHODS[:-1]:
                p = ev.paired("Prior", other, kind=kind, cameras=label)
                print(
                    f"  Prior vs {other}: better on {100 * p.a_better:.0f} %, "
                    f"worse on {100 * p.b_better:.0f} %, "
                    f"mean {p.mean_diff:+.3f}, p95 {p.p95_diff:+.2f}, max {p.max_diff:+.2f}"
                )
        nat = ev.pooled_stats("natural", label)
        best95 = min(nat["Cheung 2004"][2], nat["Finlayson 2015"][2])
        print(f"natural p95: Prior {nat['Prior'][2]:.3f} vs best regression {best95:.3f} (goal: ≤ +0.3)")
        prior = [r for r in ev.rows if r.method == "Prior"]
        print(
            "credible radius (median) / coverage: "
            + ", ".join(f"{r.test_set} {r.radius:.2f} / {100 * r.coverage:.0f} %" for r in prior)
        )
        for note in ev.notes:
            print(f"note: {note}")
    print(f"\nmean goals met in {met} of {total} cells (previous default, one λ: {met_prev} of {total})")


if __name__ == "__main__":
    main()
