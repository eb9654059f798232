"""``zonotope`` command line.

- ``zonotope summary``: object-colour solids and Vora values of cameras (built-in names or files);
- ``zonotope list [cameras|observers|illuminants|reflectances]`` (or ``zonotope cameras``): the built-in
  curves;
- ``zonotope evaluate``: ΔE00 of every colour-correction estimator on natural and atypical sets;
- ``zonotope report``: HTML + Markdown report (Vora table, MMVs, evaluation, pictures) for a camera set;
- ``zonotope correct``: colour-correct folders of N-band float TIFFs to XYZ (serial or Dask);
- ``zonotope survey``: rank camera sets by MMV volume, Vora value and regression ΔE00 (serial or Dask);
- ``zonotope ssf estimate``: a camera's sensitivities from its DNG colour matrices and/or a chart photo.
"""

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

    from ..geometry.solid import Zonotope
    from ..spectra import builtin as spectra
    from ..spectra.loading import load_camera
    from ..vora import rank_camera_sets, vora_value

    console = Console(width=max(Console().width, 120))
    cameras = args.camera or list(spectra.CAMERAS)
    curves = {c: load_camera(c) for c in cameras}  # built-in names or camera files, as evaluate/report
    shape = colour.SpectralShape(args.start, args.end, args.interval) if args.start else None
    table = Table(
        title=f"Object-colour solids and Vora values (illuminant {args.illuminant}, target {args.target})"
    )
    for col in ("camera", "grid (nm)", "generators", "volume", "vertices", "facets", "Vora", "build (ms)"):
        table.add_column(col, justify="left" if col == "camera" else "right")
    rows = [*cameras, args.target]
    for name in rows:
        is_target = name == args.target
        curve = spectra.observer(name) if is_target else curves[name]
        tgt = spectra.observer(args.target)
        grid = shape or spectra.common_shape(curve, tgt, spectra.illuminant(args.illuminant))
        G = spectra.generators(curve, args.illuminant, grid)
        t0 = time.perf_counter()
        Z = Zonotope(G)
        volume, n_vertices, n_facets = Z.volume, Z.vertices.shape[0], Z.n_facets
        ms = 1e3 * (time.perf_counter() - t0)
        v = vora_value(G.values, spectra.generators(tgt, args.illuminant, grid).values)
        label = f"{name} (target)" if is_target else curve.name
        table.add_row(
            label,
            f"{grid.start:g}–{grid.end:g}/{grid.interval:g}",
            str(Z.n_generators),
            f"{volume:.5f}",
            str(n_vertices),
            str(n_facets),
            f"{v:.4f}",
            f"{ms:.1f}",
        )
    console.print(table)
    if len(cameras) > 1:
        sets = Table(title="Camera sets by size, each size ranked by Vora value (channels stacked)")
        for col in ("cameras", "channels", "Vora"):
            sets.add_column(col)
        for size in range(2, len(cameras) + 1):
            for s in rank_camera_sets(list(curves.values()), args.target, args.illuminant, shape, size=size):
                sets.add_row(" + ".join(s.cameras), str(s.channels), f"{s.vora:.4f}")
        console.print(sets)
    console.print(
        "Volumes are in normalised response units (white = 1 per channel); the unit cube has volume 1."
    )
    return 0


def _list(args: argparse.Namespace) -> int:
    from ..spectra import builtin as spectra

    kinds = spectra.list_builtin()
    kind = args.kind or ("cameras" if args.command == "cameras" else None)
    for k, names in kinds.items():
        if kind is None or k == kind:
            if kind is None:
                print(f"{k}:")
            for name in names:
                print(f"  {name}" if kind is None else name)
    return 0


def _version() -> str:
    from importlib.metadata import PackageNotFoundError, version

    try:
        return version("zonotope")
    except PackageNotFoundError:  # pragma: no cover - a source tree that was never installed
        return "0+unknown"


def _shape(args: argparse.Namespace):
    """The grid: 400–700 nm by default, narrowed to the range every camera is measured on (one-line
    errors for cameras off that range, e.g. in µm, and for grids over the size cap)."""
    from ..evaluate.sets import _evaluation_shape

    return _evaluation_shape(args.camera, start=args.start, end=args.end, interval=args.interval)


def _rich_progress(console):
    """A (progress, callback) pair; ``callback(stage, done, total)``
    (:class:`~zonotope.utilities.ProgressCallback`).

    A new stage name completes the previous bar and starts a new one.

    On a terminal, rich's live bars; otherwise (output piped into a file or a pager, where rich
    draws nothing) one plain line per step on stderr, with the time since the start.
    """
    from rich.progress import BarColumn, Progress, TextColumn, TimeElapsedColumn

    if not console.is_terminal:
        import contextlib

        t0 = time.monotonic()

        last = {"stage": None}

        def plain(stage: str, done: int, total: int) -> None:
            if stage != last["stage"]:  # one line per stage
                last["stage"] = stage
                print(f"[{time.monotonic() - t0:7.1f} s] {stage}", file=sys.stderr, flush=True)

        return contextlib.nullcontext(), plain
    progress = Progress(
        TextColumn("{task.description}"), BarColumn(), TimeElapsedColumn(), console=console, transient=True
    )
    state: dict = {"task": None, "stage": None, "total": 1}

    def callback(stage: str, done: int, total: int) -> None:
        if stage != state["stage"]:
            if state["task"] is not None:  # the previous stage is finished
                progress.update(state["task"], completed=state["total"])
            state.update(task=progress.add_task(stage, total=max(total, 1)), stage=stage)
        state["total"] = max(total, 1)
        progress.update(state["task"], completed=done, total=state["total"])

    return progress, callback


#: First line of every Markdown file ``evaluate --markdown`` writes (what ``--force`` may replace).
_MD_SIGNATURE = "written by zonotope evaluate"


def _evaluate(args: argparse.Namespace) -> int:
    from rich.console import Console
    from rich.table import Table

    from ..correct.noise import parse_noise
    from ..evaluate import (
        DEFAULT_METHODS,
        DEFAULT_NOISE,
        TestSet,
        _noise_levels,
        atypical_test_sets,
        evaluate,
        natural_test_sets,
    )

    console = Console(width=max(Console().width, 130))
    # bad --noise (text or values) is refused in one line before any work
    noise = DEFAULT_NOISE if not args.noise else [parse_noise(t, auto=False) for t in args.noise]
    noise = _noise_levels("--noise", noise)
    if args.markdown:  # refuse a bad output path before the long run, never an input file
        from ..utilities.io import check_output

        check_output(
            args.markdown,
            overwrite=args.force,
            signature=_MD_SIGNATURE,
            what="--markdown",
            inputs=[*args.camera, args.training, *(args.test_set or [])],
        )
    shape = _shape(args)
    w = shape.wavelengths
    sets = natural_test_sets(w, data_dir=args.data, size=args.size, seed=args.seed)
    for path in args.test_set or []:
        from .._errors import SpectralDataError
        from .._tol import REFLECTANCE_MAX, REFLECTANCE_MIN
        from ..spectra import builtin as spectra

        R = spectra.resample(spectra.read_reflectances(path), w).T
        if R.max() > REFLECTANCE_MAX or R.min() < REFLECTANCE_MIN:  # percent data are refused
            raise SpectralDataError(
                f"--test-set {path}: reflectances must lie in [0, 1] (got {R.min():.3g}…{R.max():.3g}); "
                "divide percent data by 100."
            )
        sets.append(TestSet(path, R.clip(0, 1)))
    if args.atypical:
        sets.extend(atypical_test_sets(w, args.atypical, seed=args.seed))  # generators A and B
    camera_sets = [args.camera] if not args.pairs else [[c] for c in args.camera] + [args.camera]
    progress, callback = _rich_progress(console)
    with progress:
        ev = evaluate(
            camera_sets,
            methods=args.method or DEFAULT_METHODS,
            illuminant=args.illuminant,
            shape=shape,
            training=args.training,
            test_sets=sets,
            noise=noise,
            seed=args.seed,
            progress=callback,
        )
    table = Table(title="CIEDE2000 per estimator")
    cols = ("cameras", "test set", "noise", "estimator", "n", "mean", "median", "p95", "max", "in MMV")
    cols += ("radius", "covered")
    for col in cols:
        table.add_column(col, justify="left" if col in ("cameras", "test set", "estimator") else "right")
    for r in ev.rows:
        table.add_row(*r.cells())
    console.print(table)
    console.print("radius: median 95 % credible radius (ΔE00); covered: share of true colours within it")
    console.print(ev.noise_markdown(), soft_wrap=True)  # methods side by side per noise level
    for cams in dict.fromkeys(r.cameras for r in ev.rows):
        for kind in ("natural", "atypical"):
            for z in ev.noise_levels:
                pooled = ev.pooled_stats(kind, cams, z)
                if pooled:
                    console.print(
                        f"{cams} · {kind} · noise {z} (pooled mean / p95 / max): "
                        + ", ".join(f"{m} {v[1]:.3f}/{v[2]:.2f}/{v[3]:.1f}" for m, v in pooled.items())
                    )
    console.print(ev.pooled_markdown(), soft_wrap=True)  # pooled statistics and paired comparisons
    for note in ev.notes:
        console.print(f"note: {note}", soft_wrap=True)
    if args.markdown:
        from ..utilities.io import atomic_write_text, check_output

        check_output(args.markdown, overwrite=args.force, signature=_MD_SIGNATURE, what="--markdown")
        atomic_write_text(args.markdown, f"<!-- {_MD_SIGNATURE} -->\n{ev.to_markdown()}")
        console.print(f"wrote {args.markdown}")
    return 0


def _report(args: argparse.Namespace) -> int:
    from rich.console import Console

    from ..report import write_report

    console = Console()
    progress, callback = _rich_progress(console)
    with progress:
        path = write_report(
            args.camera,
            args.output,
            illuminant=args.illuminant,
            shape=_shape(args),
            force=args.force,
            data_dir=args.data,
            atypical=args.atypical,
            size=args.size,
            progress=callback,
        )
    console.print(f"report written to {path / 'index.html'} (and report.md)")
    return 0


def _grid_options(p: argparse.ArgumentParser) -> None:
    p.add_argument("--illuminant", default="D65")
    p.add_argument("--start", type=float, help="grid start in nm (default 400, later if a camera does)")
    p.add_argument("--end", type=float, help="grid end in nm (default 700, earlier if a camera does)")
    p.add_argument("--interval", type=float, default=10.0, help="grid step in nm (default 10)")
    p.add_argument("--data", help="folder laid out like ../shared/data (Munsell, SFU, CIE 224 sets)")
    p.add_argument("--atypical", type=int, default=100, help="number of atypical spectra (0: none)")
    p.add_argument("--size", type=int, default=150, help="subsample large natural sets to this size")


def _parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(  # one command per line, as in the docstring
        prog="zonotope", description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument("--version", action="version", version=f"%(prog)s {_version()}")
    sub = parser.add_subparsers(dest="command", required=True)
    p = sub.add_parser(
        "list",
        aliases=["cameras"],
        help="names of the built-in cameras, observers, illuminants and reflectance sets",
    )
    p.add_argument(
        "kind",
        nargs="?",
        choices=["cameras", "observers", "illuminants", "reflectances"],
        help="only this kind (default all; 'zonotope cameras' lists the cameras)",
    )
    p.set_defaults(func=_list)
    p = sub.add_parser("summary", help="solids and Vora values of the built-in (or given) cameras")
    p.add_argument(
        "--camera", action="append", help="camera name or file (repeatable; default every built-in camera)"
    )
    p.add_argument("--illuminant", default="D65")
    p.add_argument("--target", default="Stockman & Sharpe 2°")
    p.add_argument("--start", type=float, help="grid start in nm (default: common range)")
    p.add_argument("--end", type=float, default=700.0)
    p.add_argument("--interval", type=float, default=5.0)
    p.set_defaults(func=_summary)

    p = sub.add_parser("evaluate", help="ΔE00 of every colour-correction estimator")
    p.add_argument(
        "--camera",
        action="append",
        required=True,
        help="camera name or file (repeat for 2–3 cameras; channels are stacked)",
    )
    p.add_argument(
        "--pairs", action="store_true", help="also evaluate each camera alone before the stacked set"
    )
    p.add_argument("--method", action="append", help="estimator (repeatable; default all)")
    p.add_argument("--training", default="rawtoaces 190", help="training reflectances (name or file)")
    p.add_argument("--test-set", action="append", help="extra test reflectance file (repeatable)")
    p.add_argument(
        "--noise",
        action="append",
        metavar="LEVEL",
        help="noise level of the held-out responses, repeatable: 0 (noise-free), a σ such as 0.005 "
        "(constant, white = 1), or SHOT:READ variances per unit response as 'zonotope correct "
        "--noise' takes them; every estimator is fitted for each level (default: 0, 4e-06:0 and "
        "2.5e-05:0, i.e. noise-free and shot noise of σ 0.002 and 0.005 at white)",
    )
    p.add_argument("--seed", type=int, default=0, help="seed of the atypical spectra and the noise draws")
    p.add_argument("--markdown", help="also write the table to this Markdown file (must not exist)")
    p.add_argument(
        "--force",
        action="store_true",
        help="replace a --markdown file written by an earlier 'zonotope evaluate'",
    )
    _grid_options(p)
    p.set_defaults(func=_evaluate)

    p = sub.add_parser("report", help="HTML + Markdown report for a camera set")
    p.add_argument("--camera", action="append", required=True, help="camera name or file (repeatable)")
    p.add_argument("-o", "--output", required=True, help="output folder (must not exist unless --force)")
    p.add_argument("--force", action="store_true", help="replace an existing report")
    _grid_options(p)
    p.set_defaults(func=_report)

    from .batch import add_commands  # correct (image folders) and survey: zonotope.parallel batches

    add_commands(sub)
    from .ssf import add_commands as add_ssf  # ssf estimate: sensitivities of cameras nobody measured

    add_ssf(sub)
    return parser


def _check_numbers(args: argparse.Namespace) -> None:
    """Refuse bad numeric options before any work (negative, inf, NaN or inverted grids, ...)."""
    import math

    from .._errors import SpectralDataError

    def bad(option: str, value, rule: str) -> SpectralDataError:
        return SpectralDataError(f"{option} {value!r}: {rule}.")

    start, end, interval = (getattr(args, a, None) for a in ("start", "end", "interval"))
    for option, value in (("--start", start), ("--end", end)):
        if value is not None and not (math.isfinite(value) and 0 < value < 10_000):
            raise bad(option, value, "a wavelength in nm must be finite and in (0, 10000)")
    if interval is not None and not (math.isfinite(interval) and interval > 0):
        raise bad("--interval", interval, "the grid step must be a finite number of nm > 0")
    if start is not None and end is not None and not end > start:
        raise bad("--end", end, f"must exceed --start {start!r}")
    for option, value, low in (
        ("--atypical", getattr(args, "atypical", None), 0),
        ("--size", getattr(args, "size", None), 1),
    ):
        if value is not None and value < low:
            raise bad(option, value, f"must be ≥ {low}")
    noise = getattr(args, "noise", None)
    if isinstance(noise, float) and not (math.isfinite(noise) and noise >= 0):
        raise bad("--noise", noise, "the response noise σ must be finite and ≥ 0")


def _check_data(args: argparse.Namespace) -> None:
    """``--data`` must be a folder that holds at least one of the real sets evaluate/report read.

    A wrong path used to be ignored: the run went on with the built-in sets only and said nothing.
    """
    folder = getattr(args, "data", None)
    if folder is None:
        return
    from pathlib import Path

    import numpy as np

    from .._errors import SpectralDataError
    from ..evaluate import natural_test_sets

    if not Path(folder).is_dir():
        raise SpectralDataError(
            f"--data {folder!r}: no such folder; give a folder laid out like ../shared/data "
            "(Munsell, SFU 1995, CIE 224 reflectances) or leave --data out."
        )
    grid = np.arange(400.0, 701.0, 10.0)
    if len(natural_test_sets(grid, data_dir=folder, size=1)) == len(natural_test_sets(grid, size=1)):
        raise SpectralDataError(
            f"--data {folder!r} holds none of the real reflectance sets (Munsell matte, SFU 1995, "
            "CIE 224 CES) in the layout of ../shared/data; point it at that folder or leave --data out."
        )


def _stdout_gone() -> int:
    """Exit status after the reader of stdout closed it: 128 + SIGPIPE, nothing printed.

    Standard output is pointed at ``os.devnull`` so that the interpreter's final flush cannot raise
    (and print a traceback) again.
    """
    import os
    import signal

    try:
        devnull = os.open(os.devnull, os.O_WRONLY)
        os.dup2(devnull, sys.stdout.fileno())
    except (OSError, ValueError, AttributeError):  # stdout without a file descriptor (captured)
        pass
    return 128 + signal.SIGPIPE


def main(argv: Sequence[str] | None = None) -> int:
    """Entry point of the ``zonotope`` command."""
    from .._errors import ZonotopeError

    args = _parser().parse_args(argv)
    try:
        _check_numbers(args)
        _check_data(args)
        status = args.func(args)
        sys.stdout.flush()  # a closed pipe shows here, not in the interpreter's exit
        return status
    except KeyboardInterrupt:
        print("zonotope: interrupted (no output was written or replaced)", file=sys.stderr)
        return 130
    except BrokenPipeError:  # the reader went away (zonotope list | head): stop quietly, as Unix tools do
        return _stdout_gone()
    except OSError as error:  # unreadable input, unwritable output folder, disk full: one line
        if isinstance(error, ZonotopeError):
            print(f"zonotope: error: {error}", file=sys.stderr)
        else:
            print(
                f"zonotope: error: {error.strerror or error}"
                + (f": {error.filename}" if error.filename else ""),
                file=sys.stderr,
            )
        return 2
    except ZonotopeError as error:
        hint = ""
        if "the grid asks for" in str(error) and args.command in ("evaluate", "report"):
            hint = (
                " (on the command line: --start/--end/--interval set the grid, default 400–700/10 nm "
                "within the cameras' range)"
            )
        print(f"zonotope: error: {error}{hint}", file=sys.stderr)
        return 2


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
