"""``zonotope`` command line: ``zonotope summary`` (built-in cameras), more subcommands to come."""

from __future__ import annotations

import argparse
import sys
import time
from collections.abc import Sequence

__all__ = ["main"]


def _summary(args: argparse.Namespace) -> int:
    import colour
    from rich.console import Console
    from rich.table import Table

    from . import spectra
    from .solid import Zonotope
    from .vora import rank_camera_sets, vora_value

    console = Console(width=max(Console().width, 120))
    cameras = args.camera or list(spectra.CAMERAS)
    shape = colour.SpectralShape(args.start, args.end, args.interval) if args.start else None
    table = Table(title=f"Object-colour solids and Vora values (illuminant {args.illuminant}, "
                        f"target {args.target})")
    for col in ("camera", "grid (nm)", "generators", "volume", "vertices", "facets",
                "Vora", "build (ms)"):
        table.add_column(col, justify="left" if col == "camera" else "right")
    rows = [*cameras, args.target]
    for name in rows:
        is_target = name == args.target
        curve = spectra.observer(name) if is_target else spectra.camera(name)
        tgt = spectra.observer(args.target)
        grid = shape or spectra.common_shape(curve, tgt, spectra.illuminant(args.illuminant))
        G = spectra.generators(curve, args.illuminant, grid)
        t0 = time.perf_counter()
        Z = Zonotope(G)
        volume, n_vertices, n_facets = Z.volume, Z.vertices.shape[0], Z.n_facets
        ms = 1e3 * (time.perf_counter() - t0)
        v = vora_value(G.values, spectra.generators(tgt, args.illuminant, grid).values)
        label = f"{name} (target)" if is_target else curve.name
        table.add_row(label, f"{grid.start:g}–{grid.end:g}/{grid.interval:g}", str(Z.n_generators),
                      f"{volume:.5f}", str(n_vertices), str(n_facets), f"{v:.4f}", f"{ms:.1f}")
    console.print(table)
    if len(cameras) > 1:
        sets = Table(title="Camera sets ranked by Vora value (channels stacked)")
        for col in ("cameras", "channels", "Vora"):
            sets.add_column(col)
        for size in range(2, len(cameras) + 1):
            for s in rank_camera_sets(cameras, args.target, args.illuminant, shape, size=size):
                sets.add_row(" + ".join(s.cameras), str(s.channels), f"{s.vora:.4f}")
        console.print(sets)
    console.print("Volumes are in normalised response units (white = 1 per channel); "
                  "the unit cube has volume 1.")
    return 0


def _parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(prog="zonotope", description=__doc__)
    sub = parser.add_subparsers(dest="command", required=True)
    p = sub.add_parser("summary", help="solids and Vora values of the built-in (or given) cameras")
    p.add_argument("--camera", action="append", help="built-in camera name (repeatable)")
    p.add_argument("--illuminant", default="D65")
    p.add_argument("--target", default="Stockman & Sharpe 2°")
    p.add_argument("--start", type=float, help="grid start in nm (default: common range)")
    p.add_argument("--end", type=float, default=700.0)
    p.add_argument("--interval", type=float, default=5.0)
    p.set_defaults(func=_summary)
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    """Entry point of the ``zonotope`` command."""
    from ._errors import ZonotopeError

    args = _parser().parse_args(argv)
    try:
        return args.func(args)
    except ZonotopeError as error:
        print(f"zonotope: error: {error}", file=sys.stderr)
        return 2


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
