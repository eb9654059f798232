"""Benchmark: batched exact MMV membership vs one HiGHS feasibility LP per (c, y) pair, same process.

Also times :func:`zonotope.mismatch.membership.mmv_distance` (one compiled simplex per pair; the L1
distance to the MMV, 0 inside). Nikon 5100 → Stockman & Sharpe LMS, D65, 400–700 nm at 10 nm
(31 wavelengths, C(31, 5) facet directions of the joint 6-D solid). The LP baseline is timed on
50 pairs and reported per pair.

    python benchmarks/bench_membership.py [--repeats 5] [--pairs 10000]
"""

from __future__ import annotations

import argparse

import colour
import numpy as np
from scipy.optimize import linprog

import zonotope
from zonotope.mismatch.membership import joint_halfspaces, mmv_contains, mmv_distance

try:  # run as a script (python benchmarks/bench_X.py) or imported as benchmarks.bench_X
    from _timing import median_time
except ImportError:
    from benchmarks._timing import median_time


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--repeats", type=int, default=5)
    parser.add_argument("--pairs", type=int, default=10_000)
    args = parser.parse_args()
    grid = colour.SpectralShape(400, 700, 10)
    Phi = zonotope.generators("Nikon 5100 (NPL)", "D65", grid).values
    Psi = zonotope.generators("Stockman & Sharpe 2°", "D65", grid).values
    J = np.concatenate([Phi, Psi], axis=1)
    rng = np.random.default_rng(0)
    x = rng.random((args.pairs, Phi.shape[0]))
    C = x @ Phi
    Y = x @ Psi + 0.02 * rng.normal(size=(args.pairs, 3))
    t_build = median_time(lambda: joint_halfspaces(J), args.repeats)
    hs = joint_halfspaces(J)
    t_batch = median_time(lambda: mmv_contains(Phi, Psi, C, Y, halfspaces=hs), args.repeats)
    got = mmv_contains(Phi, Psi, C, Y, halfspaces=hs)

    def lps():
        return [
            linprog(
                np.zeros(Phi.shape[0]), A_eq=J.T, b_eq=np.concatenate([c, y]), bounds=(0, 1), method="highs"
            ).status
            == 0
            for c, y in zip(C[:50], Y[:50])
        ]

    t_lp = median_time(lps, args.repeats) / 50
    agree = np.mean(np.array(lps()) == got[:50])
    mmv_distance(Phi, Psi, C[:2], Y[:2])  # compile (or load the cached kernel) outside the timing
    t_dist = median_time(lambda: mmv_distance(Phi, Psi, C, Y), args.repeats)
    d = mmv_distance(Phi, Psi, C, Y)
    agree_d = np.mean((d <= 1e-9) == got)
    print(
        f"Nikon 5100 → LMS, 10 nm, {args.pairs} pairs (medians of {args.repeats}); "
        f"{hs[0].shape[0]} half-spaces"
    )
    print(f"{'method':40s} {'per pair (µs)':>14s} {'total (s)':>10s}")
    print(f"{'HiGHS feasibility LP (baseline)':40s} {1e6 * t_lp:14.1f} {t_lp * args.pairs:10.2f}")
    print(f"{'mmv_contains (batched, exact)':40s} {1e6 * t_batch / args.pairs:14.1f} {t_batch:10.2f}")
    print(f"{'joint_halfspaces (once)':40s} {'':14s} {t_build:10.2f}")
    name = "mmv_distance (compiled simplex per pair)"
    print(f"{name:40s} {1e6 * t_dist / args.pairs:14.1f} {t_dist:10.2f}")
    print(
        f"speed-up per pair: {t_lp * args.pairs / t_batch:.1f}×; agreement on 50 LP pairs: {agree:.0%}; "
        f"inside: {got.mean():.1%}"
    )
    print(
        f"mmv_distance: {t_lp * args.pairs / t_dist:.0f}× the LP per pair; its 'inside' (distance ≤ 1e-9) "
        f"agrees with mmv_contains on {agree_d:.2%} of the pairs"
    )


if __name__ == "__main__":
    main()
