"""Benchmark: colour-science issue #364 — classify the 2,734 real Munsell colours, same process.

Run: ``python benchmarks/bench_macadam.py [--repeats 5]`` (prints a table; medians of repeats).

- Exact: :func:`zonotope.geometry.macadam.is_object_colour` on the exact object-colour solid of the CIE
  1931 2° observer under illuminant C (360–780 nm, 1 nm); the solid is built once (its build
  time is a separate row, caches cleared) and the classification is timed on it.
- Baseline: ``colour.is_within_macadam_limits(xyY, "C")`` (Delaunay of MacAdam's tabulated
  optimal colours, colour-science).
- Witnesses: :func:`zonotope.geometry.macadam.invert` for the accepted colours (one reflectance each).
"""

from __future__ import annotations

import argparse

import colour
import numpy as np
from colour.notation.datasets.munsell import MUNSELL_COLOURS_REAL

from zonotope import Zonotope
from zonotope.geometry.macadam import _solid_cached, invert, is_object_colour, object_colour_solid

try:  # run as a script (python benchmarks/bench_X.py) or imported as benchmarks.bench_X
    from _timing import median_time
except ImportError:
    from benchmarks._timing import median_time


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--repeats", type=int, default=5)
    args = parser.parse_args()
    xyY = np.array([v for _, v in MUNSELL_COLOURS_REAL])
    xyY[:, 2] /= 100.0
    XYZ = colour.xyY_to_XYZ(xyY)

    def build():
        _solid_cached.cache_clear()
        Z = object_colour_solid("CIE 1931 2°", "C")
        return Z.halfspaces

    t_build = median_time(build, args.repeats)
    Z = object_colour_solid("CIE 1931 2°", "C")
    _ = Z.halfspaces

    def exact():
        Z2 = Zonotope(Z.generators)  # fresh caches except the generators
        Z2.__dict__["halfspaces"] = Z.halfspaces
        return is_object_colour(XYZ, solid=Z2)

    t_exact = median_time(exact, args.repeats)
    t_colour = median_time(lambda: colour.is_within_macadam_limits(xyY, "C"), args.repeats)
    inside = is_object_colour(XYZ, solid=Z)
    cs = colour.is_within_macadam_limits(xyY, "C")
    t_inv = median_time(lambda: invert(XYZ[inside], solid=Z), args.repeats)
    R = invert(XYZ[inside], solid=Z)
    err = np.abs(R @ Z.generators - XYZ[inside]).max()
    print(f"2,734 real Munsell colours, illuminant C, CIE 1931 2° (medians of {args.repeats})")
    print(f"{'method':48s} {'outside':>8s} {'time (s)':>10s}")
    print(f"{'colour.is_within_macadam_limits (baseline)':48s} {np.count_nonzero(~cs):8d} {t_colour:10.4f}")
    print(f"{'exact solid: is_object_colour':48s} {np.count_nonzero(~inside):8d} {t_exact:10.4f}")
    print(f"{'exact solid: build (generators, facets, H-rep)':48s} {'':8s} {t_build:10.4f}")
    print(f"{'exact solid: invert (witness reflectances)':48s} {'':8s} {t_inv:10.4f}")
    print(f"ratio exact / colour-science (classification only): {t_exact / t_colour:.1f}")
    print(f"witness re-integration error (max |ΔXYZ|, Y_white = 1): {err:.2e}")
    print(
        "outside the exact solid:",
        ", ".join(
            f"{h} {v:g}/{c:g}" for (h, v, c), _ in (MUNSELL_COLOURS_REAL[i] for i in np.nonzero(~inside)[0])
        ),
    )


if __name__ == "__main__":
    main()
