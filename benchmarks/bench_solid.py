"""Benchmark: exact object-colour solid and inside test vs colour-science, same process.

Run: ``python benchmarks/bench_solid.py`` (prints a table; medians of ``--repeats`` runs).

- Solid: ``Zonotope(G)`` facets (H-representation), exact vertices and volume for CIE 1931 2°
  at 1 nm (380–780 nm, 401 generators) vs ``colour.volume.XYZ_outer_surface`` at the same 1 nm
  CMFs (pulse-wave points only, no facets). Caches are cleared between repeats.
- Inside test: ``Zonotope.contains`` vs ``colour.is_within_visible_spectrum`` (Delaunay of the
  outer surface) for random XYZ points, both on colour's default 360–780 nm / 5 nm CMFs.
"""

from __future__ import annotations

import argparse

import colour
import numpy as np

from zonotope import Zonotope, generators

try:  # run as a script (python benchmarks/bench_X.py) or imported as benchmarks.bench_X
    from _timing import median_time
except ImportError:
    from benchmarks._timing import median_time


def clear_colour_caches():
    colour.volume.spectrum._CACHE_OUTER_SURFACE_XYZ.clear()
    colour.volume.spectrum._CACHE_OUTER_SURFACE_XYZ_POINTS.clear()


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--repeats", type=int, default=5)
    parser.add_argument("--baseline-repeats", type=int, default=5)
    args = parser.parse_args()
    rows = []

    shape1 = colour.SpectralShape(380, 780, 1)
    cmfs1 = colour.MSDS_CMFS["CIE 1931 2 Degree Standard Observer"].copy().align(shape1)
    E1 = colour.SDS_ILLUMINANTS["E"].copy().align(shape1)
    G1 = generators(cmfs1, E1, shape1, normalise=1)

    def ours_solid():
        Z = Zonotope(G1)
        Z.halfspaces, Z.vertices, Z.volume  # noqa: B018 - force the exact construction

    def colour_solid():
        clear_colour_caches()
        colour.volume.XYZ_outer_surface(cmfs1, E1)

    t_ours = median_time(ours_solid, args.repeats)
    t_base = median_time(colour_solid, args.baseline_repeats)
    Z = Zonotope(G1)
    rows.append(
        (
            "solid, CIE 1931 1 nm (401 gen.)",
            "XYZ_outer_surface",
            t_base,
            t_ours,
            f"{Z.vertices.shape[0]} vertices, {Z.n_facets} facets",
        )
    )

    shape5 = colour.SpectralShape(360, 780, 5)  # colour's SPECTRAL_SHAPE_OUTER_SURFACE_XYZ
    cmfs5 = colour.MSDS_CMFS["CIE 1931 2 Degree Standard Observer"].copy().align(shape5)
    E5 = colour.SDS_ILLUMINANTS["E"].copy().align(shape5)
    Z5 = Zonotope(generators(cmfs5, E5, shape5, normalise=1))
    Z5.contains(Z5.centroid)  # build the cube map once (part of the solid, like colour's cache)
    rng = np.random.default_rng(0)
    for n in (10_000, 1_000_000):
        P = rng.random((n, 3)) * Z5.white * np.array([1.0, 1.0, 1.0])
        t_ours = median_time(lambda P=P: Z5.contains(P), args.repeats)
        if n <= 10_000:
            clear_colour_caches()
            colour.is_within_visible_spectrum(P[:10])  # warm colour's cache of surface points
            t_base = median_time(lambda P=P: colour.is_within_visible_spectrum(P), args.baseline_repeats)
            agree = np.mean(colour.is_within_visible_spectrum(P) == Z5.contains(P))
            note = f"agree on {100 * agree:.2f}% of points"
        else:
            t_base = float("nan")
            note = "baseline not run at 1e6 (extrapolate per point)"
        rows.append((f"contains, {n:.0e} points, 5 nm", "is_within_visible_spectrum", t_base, t_ours, note))

    print(f"{'case':36s} {'baseline':28s} {'baseline s':>11s} {'ours s':>9s} {'ratio':>8s}  notes")
    per_point_base = None
    for case, base, tb, to, note in rows:
        if "1e+04" in case:
            per_point_base = tb / 1e4
        if np.isnan(tb) and per_point_base is not None:
            ratio = per_point_base * 1e6 / to
            print(
                f"{case:36s} {base:28s} {'(' + format(per_point_base * 1e6, '.1f') + ')':>11s} "
                f"{to:9.4f} {ratio:7.0f}×  {note}"
            )
        else:
            print(f"{case:36s} {base:28s} {tb:11.4f} {to:9.4f} {tb / to:7.0f}×  {note}")


if __name__ == "__main__":
    main()
