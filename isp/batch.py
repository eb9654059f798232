"""``isp develop DIR -o OUTDIR``: develop every RAW file of a folder with the single-file options.

Each file runs the single-file command itself (:func:`isp.cli._develop` on a copy of the options
with that file as input), so every option of ``isp develop FILE`` means the same in a folder batch.
A metamer correction is fitted once, here, and sent to the workers once. Outputs are
``OUTDIR/<stem>.tif`` (16-bit TIFF), written atomically and at most once; a rerun skips outputs that
exist (resume); a file that fails is listed with its error and the others go on;
``OUTDIR/manifest.csv`` lists every input, its output, status, time and worker. Where the work runs
is :func:`zonotope.parallel.executor`'s choice (``--scheduler``, ``ZONOTOPE_SCHEDULER``, or serial
for one file and a local Dask cluster for more).
"""

from __future__ import annotations

import argparse
import contextlib
import io
from pathlib import Path

from ._errors import PipelineError

__all__ = ["RAW_SUFFIXES", "develop_folder", "raw_files"]

#: File suffixes (lower case) taken as RAW files in a folder.
RAW_SUFFIXES = frozenset(
    {
        ".dng",
        ".nef",
        ".nrw",
        ".cr2",
        ".cr3",
        ".crw",
        ".arw",
        ".srf",
        ".sr2",
        ".raf",
        ".orf",
        ".rw2",
        ".rwl",
        ".pef",
        ".srw",
        ".x3f",
        ".3fr",
        ".iiq",
        ".erf",
        ".kdc",
        ".mrw",
        ".mef",
        ".mos",
        ".raw",
    }
)


def raw_files(folder: str | Path) -> list[Path]:
    """The RAW files directly in ``folder`` (by suffix, :data:`RAW_SUFFIXES`), sorted by name."""
    folder = Path(folder)
    if not folder.is_dir():
        raise PipelineError(f"input folder {str(folder)!r} does not exist or is not a folder.")
    return sorted(p for p in folder.iterdir() if p.is_file() and p.suffix.lower() in RAW_SUFFIXES)


def _develop_one(src: str, tmp_out: str, options) -> None:
    """Worker side: ``isp develop src -o tmp_out`` with the batch's options; raises on failure."""
    from .cli import _develop

    values, fitted = options
    ns = argparse.Namespace(**values)
    ns.input, ns.output, ns.quiet, ns.overwrite = src, tmp_out, True, False
    ns.fitted_metamer = fitted
    if values.get("save_stages"):
        ns.save_stages = str(Path(values["save_stages"]) / Path(src).stem)
    err = io.StringIO()
    with contextlib.redirect_stderr(err), contextlib.redirect_stdout(err):
        rc = _develop(ns)
    if rc != 0:
        raise PipelineError(" ".join(err.getvalue().split()) or f"isp develop exited with status {rc}")


def develop_folder(args: argparse.Namespace) -> int:
    """The folder branch of ``isp develop`` (prints; returns the exit status).

    Exit status 0 when every file was developed (now or by an earlier run), 1 when some failed
    (listed, and in the manifest), 2 for bad options.
    """
    from rich.console import Console

    from zonotope.parallel import FILE_MIN_TASKS, FileTask, check_settings, resolve_scheduler, run_files

    from .cli import _fail, _metamer, _progress

    console = Console(stderr=True)
    out_dir = Path(args.output)
    if out_dir.exists() and not out_dir.is_dir():
        return _fail(f"-o {out_dir}: with an input folder the output must be a folder.")
    files = raw_files(args.input)
    if not files:
        return _fail(f"no RAW files ({', '.join(sorted(RAW_SUFFIXES))}) in {args.input}.")
    if out_dir.resolve() == Path(args.input).resolve():
        return _fail("-o must be another folder than the input folder (inputs are never touched).")
    if getattr(args, "overwrite", False):
        return _fail(
            "--overwrite does not apply to folders: a rerun keeps finished "
            "outputs (delete them to develop again)."
        )
    tasks = [FileTask(str(f), str(out_dir / f"{f.stem}.tif")) for f in files]
    taken: dict[str, Path] = {}
    for f in files:  # IMG_0001.CR2 next to IMG_0001.dng: refused before the fit or any folder is made
        if f.stem in taken:
            return _fail(
                f"{taken[f.stem]} and {f} would both be developed to {out_dir / (f.stem + '.tif')}; "
                "move one of them to another folder."
            )
        taken[f.stem] = f
    # before any work; a cluster only for FILE_MIN_TASKS files or more
    where = resolve_scheduler(getattr(args, "scheduler", None), tasks=len(tasks), min_tasks=FILE_MIN_TASKS)
    # what the outputs depend on: a rerun into this folder (which skips finished files) must ask for the same
    ignore = {"func", "fitted_metamer", "scheduler", "quiet", "input", "output", "overwrite", "command"}
    settings = {k: v for k, v in sorted(vars(args).items()) if k not in ignore}
    check_settings(out_dir / "manifest.csv", settings)
    fitted, error = _metamer(args)  # fitted once, sent to every worker once
    if error:
        return _fail(error)
    out_dir.mkdir(parents=True, exist_ok=True)
    values = {k: v for k, v in vars(args).items() if k not in ("func", "fitted_metamer")}
    with _progress(console, args.quiet) as bar:  # plain timed lines when stderr is not a terminal
        task = bar.add_task(f"developing ({where})", total=len(tasks))
        rows = run_files(
            tasks,
            _develop_one,
            (values, fitted),
            manifest=out_dir / "manifest.csv",
            scheduler=where,
            progress=lambda stage, done, total: bar.update(task, completed=done),
            settings=settings,
        )
    failed = [r for r in rows if r["status"] == "failed"]
    counts = {s: sum(r["status"] == s for r in rows) for s in ("ok", "done", "failed")}
    for r in failed:
        console.print(f"[red]failed:[/] {r['input']}: {r['error']}", soft_wrap=True)
    if not args.quiet or failed:
        console.print(
            f"{counts['ok']} developed, {counts['done']} already done, {counts['failed']} failed "
            f"→ {out_dir} (manifest: {out_dir / 'manifest.csv'})",
            soft_wrap=True,
        )
    return 1 if failed else 0
