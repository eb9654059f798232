"""The batch subcommands of ``zonotope``: ``correct`` (folders of multi-channel images) and ``survey``.

Kept apart from :mod:`zonotope.cli` (which registers them with :func:`add_commands`) so that the
execution-layer options live in one place. Both run where :func:`zonotope.parallel.executor`
says: ``--scheduler`` (``serial``, ``local[:N]``, ``tcp://host:8786`` or a scheduler file), else
``$ZONOTOPE_SCHEDULER``, else serial for small jobs and a local Dask cluster for large ones.
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np

from .._tol import DELTA_SIGMAS

__all__ = ["add_commands", "default_method"]

_IMAGE_SUFFIXES = (".tif", ".tiff")


def _scheduler_option(p: argparse.ArgumentParser) -> None:
    from ..parallel import SCHEDULER_HELP

    p.add_argument(
        "--scheduler",
        help="where to run; " + SCHEDULER_HELP,
    )


def add_commands(sub) -> None:
    """Register ``correct`` and ``survey`` on the ``zonotope`` sub-parser collection."""
    p = sub.add_parser("correct", help="colour-correct multi-channel float TIFFs (e.g. splat renders) to XYZ")
    p.add_argument("inputs", nargs="+", help="N-band float TIFF files (H, W, channels) or folders of them")
    p.add_argument("-o", "--output", required=True, help="output folder (XYZ float32 TIFFs + manifest.csv)")
    p.add_argument(
        "--camera",
        action="append",
        required=True,
        help="camera name or file, in the images' channel order (repeat to stack cameras)",
    )
    p.add_argument(
        "--method",
        help="zonotope.correct estimator (default: that of zonotope.correct_image, 'Guarded': the "
        "root-polynomial fitted for the noise with a linear fallback outside its training support, fast "
        "on photographs; 'Prior' is better on atypical colours and costs seconds to minutes per image)",
    )
    p.add_argument("--illuminant", default="D65", help="the scene light the images were taken under")
    p.add_argument(
        "--exact-curves",
        action="store_true",
        help="the measured curves of --camera are of these very camera units (a lab measurement): do not "
        "tell a fit of stacked cameras the spread between units of one model (zonotope.unit_sigma)",
    )
    p.add_argument(
        "--reference",
        metavar="LIGHT",
        help="output the colours as under this light (e.g. D65), fitted scene light → LIGHT "
        "(default: as under the scene light, --illuminant)",
    )
    p.add_argument("--training", default="rawtoaces 190", help="training reflectances (name or file)")
    p.add_argument("--target", default="CIE 2015 2°", help="observer of the XYZ output")
    p.add_argument(
        "--quantum",
        type=float,
        default=2e-3,
        help="responses equal after rounding to this are corrected once (0: exact)",
    )
    p.add_argument(
        "--noise",
        type=_noise_argument,
        default="auto",
        help="noise of the images' responses (white = 1), which the estimator is fitted for "
        f"(Centroid: δ = {DELTA_SIGMAS:g}σ): 'auto' (default: estimated from the flat regions of the first "
        "image), a σ such as 0.005 (0: noise-free), or shot and read variances per unit response as "
        "SHOT:READ (the DNG NoiseProfile's S:O at white = 1)",
    )
    _scheduler_option(p)
    p.add_argument("-q", "--quiet", action="store_true", help="no progress display")
    p.set_defaults(func=_correct)

    p = sub.add_parser("survey", help="rank camera sets by metamer mismatch, Vora value and regression ΔE00")
    p.add_argument(
        "--cameras",
        action="append",
        required=True,
        metavar="DIR_OR_NAMES",
        help="a folder of camera files, or comma-separated names/files (repeatable)",
    )
    p.add_argument("--size", type=int, default=2, help="cameras per set (default 2)")
    p.add_argument(
        "--with",
        dest="containing",
        action="append",
        metavar="CAMERA",
        help="only sets containing this camera (repeatable)",
    )
    p.add_argument(
        "--reflectances",
        default="ColorChecker N Ohta",
        help="reflectance set for the MMV volumes and the ΔE00 test (name or file)",
    )
    p.add_argument("--training", default="rawtoaces 190", help="training set of the regressions")
    p.add_argument("--target", default="CIE 2015 2°")
    p.add_argument("--illuminant", default="D65")
    p.add_argument("--interval", type=float, default=10.0, help="grid step in nm (default 10)")
    p.add_argument("--eps", type=float, default=1e-3, help="MMV certification tolerance (default 1e-3)")
    p.add_argument(
        "-o", "--output", help="write the ranked table here (.csv; .parquet if pyarrow is installed)"
    )
    p.add_argument(
        "--force", action="store_true", help="replace an -o table written by an earlier 'zonotope survey'"
    )
    p.add_argument("--top", type=int, default=20, help="rows to print (default 20)")
    p.add_argument(
        "--partners",
        type=int,
        default=10,
        help="also print the N best partners of each built-in camera in the survey (default 10)",
    )
    _scheduler_option(p)
    p.add_argument("-q", "--quiet", action="store_true", help="no progress display")
    p.set_defaults(func=_survey)


#: Seconds between two plain progress lines when stderr is not a terminal (piped into a file or a pager).
PLAIN_PROGRESS_EVERY = 10.0


def _bar(console, quiet: bool, description: str, *, every: float = PLAIN_PROGRESS_EVERY):
    """A (context, callback) pair: rich's live bar on a terminal; otherwise (piped, where rich draws
    nothing until the end) a plain line on stderr at the start, at most every ``every`` seconds, and
    when the count completes, so a long run piped into a file shows that it is alive."""
    from rich.progress import BarColumn, MofNCompleteColumn, Progress, TextColumn, TimeElapsedColumn

    if not quiet and not console.is_terminal:
        import contextlib
        import sys
        import time

        t0 = time.monotonic()
        state = {"at": -float("inf")}

        def plain(stage: str, done: int, total: int) -> None:
            now = time.monotonic()
            if now - state["at"] >= every or (total and done >= total):
                state["at"] = now
                count = f"{done}/{total}" if total else f"{done}"
                print(f"[{now - t0:7.1f} s] {description}: {count}", file=sys.stderr, flush=True)

        return contextlib.nullcontext(), plain
    bar = Progress(
        TextColumn("{task.description}"),
        BarColumn(),
        MofNCompleteColumn(),
        TimeElapsedColumn(),
        console=console,
        disable=quiet,
    )
    task = bar.add_task(description, total=None)
    return bar, lambda stage, done, total: bar.update(task, completed=done, total=total)


def _image_files(inputs) -> list[Path]:
    from .._errors import ZonotopeError

    files: list[Path] = []
    for s in inputs:
        p = Path(s)
        if p.is_dir():
            files += sorted(f for f in p.iterdir() if f.is_file() and f.suffix.lower() in _IMAGE_SUFFIXES)
        elif p.is_file():
            files.append(p)
        else:
            raise ZonotopeError(f"input {s!r} is neither a file nor a folder.")
    if not files:
        raise ZonotopeError(f"no TIFF files ({', '.join(_IMAGE_SUFFIXES)}) in {', '.join(map(str, inputs))}.")
    return files


def correct_file(src: str, tmp_out: str, options) -> None:
    """Worker side of ``zonotope correct``: one N-band TIFF → an XYZ float32 TIFF (raises on bad input)."""
    import tifffile

    from .._errors import ZonotopeError
    from ..correct.image import correct_image

    corrector, quantum = options
    try:
        raw = tifffile.imread(src)
    except (OSError, ValueError, tifffile.TiffFileError) as error:
        raise ZonotopeError(f"{src}: not a readable TIFF ({error}).") from error
    if not np.issubdtype(raw.dtype, np.floating):  # 16-bit counts were read as responses of ~1000 × white
        raise ZonotopeError(
            f"{src}: {raw.dtype} pixels; zonotope correct reads float TIFFs of responses with the white "
            "at 1 per channel (divide by the white's value and save as float32)."
        )
    img = np.asarray(raw, dtype=np.float64)
    k = corrector.problem.Phi.shape[1]
    if img.ndim != 3 or img.shape[-1] != k:
        raise ZonotopeError(
            f"{src}: image of shape {img.shape}; the cameras have {k} channels, so it must "
            f"be (H, W, {k}) with channels last."
        )
    if not np.all(np.isfinite(img)):
        raise ZonotopeError(f"{src}: the image holds NaN or inf values.")
    xyz = correct_image(img, corrector, quantum=quantum)
    p = corrector.problem
    tifffile.imwrite(
        tmp_out,
        xyz.astype(np.float32),
        photometric="minisblack",
        planarconfig="contig",
        description=ascii(f"XYZ, colours as under {p.target_illuminant or p.illuminant}")[1:-1],
    )


def _check_lights(args: argparse.Namespace) -> None:
    """Refuse an unknown ``--illuminant`` or ``--reference`` in one line that lists the lights, before
    any file is read or fit made."""
    from .._errors import ZonotopeError
    from ..spectra import builtin as spectra

    for flag, name in (("--illuminant", args.illuminant), ("--reference", args.reference)):
        if name is not None:
            try:
                spectra.illuminant(name)
            except ZonotopeError as error:
                raise ZonotopeError(f"{flag} {name}: {error}") from None


def _noise_argument(text: str):
    """The argparse type of ``zonotope correct --noise`` (:func:`parse_noise`)."""
    from ..correct.noise import NoiseModelError, parse_noise

    try:
        return parse_noise(text)
    except NoiseModelError as error:
        raise argparse.ArgumentTypeError(str(error).removeprefix("--noise ")) from None


def _resolve_cli_noise(noise, files, k: int):
    """The noise (a NoiseModel, a σ, or None) for ``--noise``: ``"auto"`` estimates it from the first
    image."""
    from ..correct.image import _resolve_noise
    from ..correct.noise import noise_model

    if isinstance(noise, str):  # "auto"
        import tifffile

        try:
            img = np.asarray(tifffile.imread(files[0]))
        except (OSError, ValueError, tifffile.TiffFileError):
            return None, "none", f"noise not estimated: {files[0]} is not a readable TIFF"
        if img.ndim != 3 or img.shape[-1] != k:
            return None, "none", f"noise not estimated: {files[0]} has shape {img.shape}"
        return _resolve_noise("auto", img, k)
    if isinstance(noise, float):  # a σ is passed as given, as fit_correction(..., noise=σ) takes it
        return (noise if noise > 0 else None), ("none" if noise == 0 else "--noise"), ""
    model = noise_model(noise, k)
    return model, ("none" if model is None else "--noise"), ""


def _with_ssf_bands(model, cameras, illuminant: str, k: int, *, exact: bool = False):
    """``(noise, note)``: ``model`` (None, a σ or a NoiseModel) with the response σ of every camera whose
    file holds estimated curves (:func:`zonotope.spectra.estimate.read_ssf_estimate`) added to its
    channels' read variance and, for two or more stacked cameras, the spread between units of one
    model (:func:`zonotope.unit_sigma`) added for the measured ones unless ``exact``; a note naming
    them ("" and ``model`` unchanged when nothing is added). Why: a fit of stacked cameras told only
    the images' noise leans on channel differences finer than the curves are known: estimated curves
    +2.5 to +4.6 ΔE00 noise-free (docs/notes/2026-11-29-ssf-stacking.md), published curves of another
    unit +3.6 to +6.0 (docs/notes/2026-12-01-published-curves.md); the capture does the same
    (``splat.capture.ssf_sigma``)."""
    from ..correct.noise import NoiseModel, noise_model
    from ..spectra.estimate import read_ssf_estimate
    from ..ssf_band import curves_sigma

    if k != 3 * len(cameras):
        return model, ""
    estimates = [read_ssf_estimate(c) for c in cameras]
    measured = [i for i, e in enumerate(estimates) if e is None]
    band = curves_sigma(estimates, illuminant, exact=measured if exact else ())
    sigmas = band.reshape(-1, 3)
    if not band.any():
        return model, ""
    base = noise_model(model, k) or NoiseModel.constant(0.0, k, source="noise-free")
    told = NoiseModel(base.shot, base.read + band**2, source=f"{base.source} + the curves' uncertainty")
    notes = []
    named = [
        f"{c} σ {' / '.join(f'{v:.4f}' for v in sig)}"
        for c, e, sig in zip(cameras, estimates, sigmas, strict=True)
        if e is not None
    ]
    if named:
        notes.append("estimated curves: their band added, " + ", ".join(named))
    if measured and sigmas[measured[0]].any():
        notes.append(
            "measured curves of another unit of each model: the spread between units added, σ "
            + " / ".join(f"{v:.4f}" for v in sigmas[measured[0]])
            + " (--exact-curves if they were measured on these very cameras)"
        )
    return told, "; ".join(notes)


def _describe(noise) -> str:
    if noise is None:
        return "none"
    return f"σ = {noise:g} (--noise)" if isinstance(noise, float) else noise.describe()


def default_method() -> str:
    """The estimator ``zonotope correct`` uses without ``--method``: the default of
    :func:`zonotope.correct_image`, read from its signature so that the two cannot drift apart."""
    import inspect

    from ..correct.image import correct_image

    return inspect.signature(correct_image).parameters["method"].default


def _correct(args: argparse.Namespace) -> int:
    from rich.console import Console

    from .._errors import ZonotopeError
    from ..correct import CORRECTION_METHODS, fit_correction, noise_options
    from ..parallel import (
        FILE_MIN_TASKS,
        FileTask,
        _check_tasks,
        check_batch_folder,
        check_settings,
        resolve_scheduler,
        run_files,
    )

    console = Console(stderr=True)
    method = args.method or default_method()
    if not (np.isfinite(args.quantum) and args.quantum >= 0):
        raise ZonotopeError(f"--quantum {args.quantum}: must be a finite number ≥ 0.")
    _check_lights(args)
    files = _image_files(args.inputs)
    out_dir = Path(args.output)
    if out_dir.exists() and not out_dir.is_dir():
        raise ZonotopeError(f"-o {out_dir}: must be a folder.")
    tasks = [FileTask(str(f), str(out_dir / f"{f.stem}_XYZ.tif")) for f in files]
    _check_tasks(tasks)  # two inputs with one output name: refused before the fit (minutes), not after
    check_batch_folder(tasks, out_dir / "manifest.csv")  # a user's file is never replaced nor counted done
    # a bad --scheduler is refused before the fit; a cluster only for FILE_MIN_TASKS files or more
    where = resolve_scheduler(args.scheduler, tasks=len(tasks), min_tasks=FILE_MIN_TASKS)
    from ..correct import correction_problem

    problem = correction_problem(
        args.camera,
        target=args.target,
        illuminant=args.illuminant,
        training=args.training,
        reference=args.reference,
    )
    model, _, note = _resolve_cli_noise(args.noise, files, problem.k)
    model, band = _with_ssf_bands(model, args.camera, args.illuminant, problem.k, exact=args.exact_curves)
    note = "; ".join(x for x in (note, band) if x)
    if not args.quiet or "estimated curves" in band:  # the estimates' band is news even when quiet
        console.print(f"noise: {_describe(model)}" + (f" ({note})" if note else ""), soft_wrap=True)
    settings = {  # what the outputs depend on: a rerun into this folder must ask for the same
        "cameras": list(args.camera),
        "method": CORRECTION_METHODS.resolve(method, argument="--method"),
        "illuminant": args.illuminant,
        "training": args.training,
        "target": args.target,
        "quantum": args.quantum,
        "noise": model if isinstance(model, float) else repr(model.key()) if model is not None else 0.0,
    }
    if args.reference is not None:  # absent: as under the scene light (folders written before it resume)
        settings["reference"] = f"colours as under {args.reference}"
    check_settings(out_dir / "manifest.csv", settings)
    corrector = None  # a rerun with every output present (all 'done') needs no fit
    if not args.quiet:
        console.print(f"colours as under {args.reference or args.illuminant}", soft_wrap=True)
    if not all(Path(t.output).exists() for t in tasks):
        if not args.quiet:  # the fit takes minutes for MMV estimators; say so before it starts
            console.print(f"fitting {method} for {' + '.join(args.camera)}…")
        corrector = fit_correction(problem, method=method, **noise_options(method, model))
    out_dir.mkdir(parents=True, exist_ok=True)
    bar, callback = _bar(console, args.quiet, f"correcting ({where})")
    with bar:
        rows = run_files(
            tasks,
            correct_file,
            (corrector, args.quantum),
            manifest=out_dir / "manifest.csv",
            scheduler=where,
            progress=callback,
            settings=settings,
        )
    failed = [r for r in rows if r["status"] == "failed"]
    for r in failed:
        console.print(f"[red]failed:[/] {r['input']}: {r['error']}", soft_wrap=True)
    counts = {s: sum(r["status"] == s for r in rows) for s in ("ok", "done", "failed")}
    console.print(
        f"{counts['ok']} corrected, {counts['done']} already done, {counts['failed']} failed → "
        f"{out_dir} (manifest: {out_dir / 'manifest.csv'})",
        soft_wrap=True,
    )
    return 1 if failed else 0


def _survey(args: argparse.Namespace) -> int:
    from rich.console import Console
    from rich.table import Table

    from .._errors import ZonotopeError
    from ..parallel import resolve_scheduler
    from ..spectra import builtin as spectra
    from ..survey import TABLE_HEADER, TABLE_SUFFIXES, best_partners, load_cameras, survey, write_table
    from ..utilities.io import check_output

    if args.output:  # checked before the (long) survey: format, never an input, only a previous table
        if Path(args.output).suffix.lower() not in TABLE_SUFFIXES:
            raise ZonotopeError(f"-o {args.output}: write the table as {' or '.join(TABLE_SUFFIXES)}.")
        inputs = [p for spec in args.cameras for p in ([spec] if Path(spec).is_dir() else spec.split(","))]
        check_output(  # an earlier survey's table only with --force (it may have taken hours)
            args.output,
            overwrite=args.force,
            signature=TABLE_HEADER,
            inputs=[p for p in inputs if Path(p).exists()],
            what="-o",
        )
    console = Console(stderr=True)
    out = Console(width=max(Console().width, 130))
    cams, skipped = load_cameras(
        [c for spec in args.cameras for c in ([spec] if Path(spec).is_dir() else spec.split(","))]
    )
    for s in skipped:
        console.print(f"[yellow]skipped:[/] {s}", soft_wrap=True)
    from itertools import combinations

    if not 1 <= args.size <= len(cams):  # before any bar or worker starts
        raise ZonotopeError(
            f"--size {args.size}: sets of 1…{len(cams)} cameras (the number of cameras loaded)."
        )
    want = set(args.containing or ())
    n_sets = (
        sum(1 for s in combinations(cams, args.size) if not want or want & set(s))
        if 1 <= args.size <= len(cams)
        else 0
    )
    where = resolve_scheduler(args.scheduler, tasks=n_sets, min_tasks=8)
    bar, callback = _bar(console, args.quiet, f"{len(cams)} cameras, sets of {args.size} ({where})")
    with bar:
        rows = survey(
            cams,
            size=args.size,
            target=args.target,
            illuminant=args.illuminant,
            interval=args.interval,
            reflectances=args.reflectances,
            training=args.training,
            eps=args.eps,
            containing=args.containing,
            scheduler=where,
            progress=callback,
        )
    cols = ("rank", "cameras", "grid (nm)", "Vora", "MMV median", "MMV p90", "best regression", "ΔE00")

    def table(title, rs):
        t = Table(title=title)
        for c in cols:
            t.add_column(c, justify="left" if c in ("cameras", "best regression") else "right")
        for r in rs:
            t.add_row(
                str(rows.index(r) + 1),
                " + ".join(r.cameras),
                r.grid,
                f"{r.vora:.4f}",
                f"{r.mmv_median:.3e}",
                f"{r.mmv_p90:.3e}",
                r.best_regression,
                f"{r.dE00:.3f}",
            )
        return t

    out.print(
        table(
            f"Camera sets ranked by median MMV volume ({args.reflectances}, target {args.target}, "
            f"{args.illuminant})",
            [r for r in rows if not r.error][: args.top],
        )
    )
    if args.size >= 2 and args.partners > 0:
        for name in spectra.list_builtin()["cameras"]:
            if name in cams:
                out.print(
                    table(
                        f"{args.partners} best partners of {name}", best_partners(rows, name, args.partners)
                    )
                )
    for r in rows:
        if r.error:
            console.print(f"[red]failed:[/] {' + '.join(r.cameras)}: {r.error}", soft_wrap=True)
    if args.output:
        console.print(f"wrote {write_table(rows, args.output)}")
    return 1 if any(r.error for r in rows) else 0
