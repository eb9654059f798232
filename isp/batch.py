"""Develop every RAW file of a folder with one pipeline, resumably, on a serial or Dask executor.

:func:`develop_folder` is the library side of ``isp develop DIR -o OUTDIR``. A metamer correction is
fitted once, after the folder checks, and sent to the workers once with the pipeline. Outputs are
``OUTDIR/<stem>.tif`` (16-bit TIFF), written atomically and at most once; a rerun skips outputs that
exist and that it wrote (resume; a user's file with an output's name is refused, never counted)
and refuses other settings than the first run's; a file that fails is listed with its
error and the others go on; ``OUTDIR/manifest.csv`` lists every input, its output, status, time and
worker. Where the work runs is :func:`zonotope.parallel.executor`'s choice (``executor=``,
``ZONOTOPE_SCHEDULER``, or serial for one file and a local Dask cluster for more).
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from pathlib import Path
from typing import Any

from ._errors import PipelineError

__all__ = ["RAW_SUFFIXES", "develop_file", "develop_folder", "raw_files"]

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


def develop_file(
    src: str | Path,
    out: str | Path,
    *,
    pipeline,
    crop: Sequence[int] | None = None,
    save_stages: str | Path | None = None,
    overwrite: bool = False,
    progress: Callable[[str, int, int], None] | None = None,
):
    """Read ``src``, develop it with ``pipeline`` and write ``out``; returns ``(raw, development)``.

    The image is written as ``isp develop FILE`` writes it: 16-bit, with the sRGB ICC profile when
    the pipeline ends encoded, the camera's metadata, never over ``src``. ``crop`` is
    ``(top, left, height, width)`` of the mosaic; ``save_stages`` a folder that receives every
    intermediate as a float32 TIFF (refused when it holds files, unless ``overwrite``).
    ``progress(stage, done, total)`` follows the pipeline's stages.
    """
    from .exif import output_tags, srgb_icc_profile
    from .io import write_image
    from .raw import read_raw

    src, out = Path(src), Path(out)
    if save_stages is not None:
        stage_dir = Path(save_stages)
        if stage_dir.exists() and any(stage_dir.iterdir()) and not overwrite:
            raise PipelineError(f"--save-stages {stage_dir} is not empty; use --overwrite or another folder.")
    raw = read_raw(src)
    if crop:
        raw = raw.crop(*crop)
    dev = pipeline(raw, progress=progress, keep=save_stages is not None)
    encoded = "encode_sRGB" in pipeline.names
    write_image(
        out,
        dev.image,
        overwrite=overwrite,
        protect=[src],
        icc_profile=srgb_icc_profile() if encoded else None,
        tiff_tags=output_tags(raw),
    )
    if save_stages is not None:
        stage_dir.mkdir(parents=True, exist_ok=True)
        for i, (name, arr) in enumerate(dev.intermediates.items()):
            write_image(
                stage_dir / f"{i:02d}_{name}.tif", arr, dtype="float32", overwrite=overwrite, protect=[src]
            )
    return raw, dev


def _develop_one(src: str, tmp_out: str, options) -> None:
    """Worker side of :func:`develop_folder`: ``options`` is ``(pipeline, crop, save_stages)``."""
    pipeline, crop, save_stages = options
    stages = None if save_stages is None else Path(save_stages) / Path(src).stem
    develop_file(src, tmp_out, pipeline=pipeline, crop=crop, save_stages=stages)


def develop_folder(
    inputs: str | Path,
    out: str | Path,
    *,
    pipeline,
    metamer: tuple[Any, Any] | None = None,
    executor: str | None = None,
    settings: Mapping[str, Any] | None = None,
    progress: Callable[[str, int, int], None] | None = None,
    **options: Any,
) -> list[dict]:
    """Develop every RAW file of the folder ``inputs`` into the folder ``out``.

    Parameters
    ----------
    inputs
        Folder of RAW files (:func:`raw_files`); never written to.
    out
        Output folder (another one than ``inputs``); receives ``<stem>.tif`` and ``manifest.csv``.
    pipeline : isp.Pipeline
        The development of every file (e.g. :func:`isp.default_pipeline`).
    metamer
        ``(camera, MetamerConfig)``: fit :func:`isp.metamer_correction` once, after the folder checks,
        and use it as the pipeline's ``camera_to_XYZ`` stage; None keeps ``pipeline`` as it is.
    executor
        ``"serial"``, ``"local[:N]"`` or a Dask scheduler address; None asks
        :func:`zonotope.parallel.resolve_scheduler` (``ZONOTOPE_SCHEDULER``, else by folder size).
    settings
        What the outputs depend on, kept beside the manifest: a rerun into ``out`` with other
        settings is refused before any work (it would mix outputs of two developments). With
        ``metamer``, its noise model (``MetamerConfig.noise``, exact values) is added as
        ``"noise"``: results fitted for another noise are not reused.
    progress
        ``progress(description, done, total)``: called once with ``done=0`` before the work, then
        after each file.
    **options
        ``crop`` and ``save_stages`` of :func:`develop_file`, for every file (``save_stages`` gets
        one sub-folder per input stem).

    Returns
    -------
    list of dict
        The manifest rows (``input``, ``output``, ``status`` in ``ok``/``done``/``failed``, ``error``, ...).

    Raises
    ------
    PipelineError
        ``out`` is a file or the input folder, no RAW files, or two inputs share a stem.
    zonotope.parallel.ParallelError
        ``out`` holds a ``manifest.csv`` or a file with an output's name that no folder batch wrote
        (:func:`zonotope.parallel.check_batch_folder`): it is never replaced nor counted done.
    TypeError
        An option other than ``crop`` and ``save_stages``.
    """
    from zonotope.parallel import (
        FILE_MIN_TASKS,
        FileTask,
        check_batch_folder,
        check_settings,
        resolve_scheduler,
        run_files,
    )

    unknown = sorted(set(options) - {"crop", "save_stages"})
    if unknown:
        raise TypeError(f"develop_folder() got unknown options {unknown}; valid: ['crop', 'save_stages'].")
    crop, save_stages = options.get("crop"), options.get("save_stages")

    out_dir = Path(out)
    if out_dir.exists() and not out_dir.is_dir():
        raise PipelineError(f"-o {out_dir}: with an input folder the output must be a folder.")
    files = raw_files(inputs)
    if not files:
        raise PipelineError(f"no RAW files ({', '.join(sorted(RAW_SUFFIXES))}) in {inputs}.")
    if out_dir.resolve() == Path(inputs).resolve():
        raise PipelineError("-o must be another folder than the input folder (inputs are never touched).")
    tasks = [FileTask(str(f), str(out_dir / f"{f.stem}.tif")) for f in files]
    taken: dict[str, Path] = {}
    for f in files:  # IMG_0001.CR2 next to IMG_0001.dng: refused before the fit or any folder is made
        if f.stem in taken:
            raise PipelineError(
                f"{taken[f.stem]} and {f} would both be developed to {out_dir / (f.stem + '.tif')}; "
                "move one of them to another folder."
            )
        taken[f.stem] = f
    # before any work; a cluster only for FILE_MIN_TASKS files or more
    where = resolve_scheduler(executor, tasks=len(tasks), min_tasks=FILE_MIN_TASKS)
    if settings is not None and metamer is not None:
        noise = getattr(metamer[1], "noise", None)
        settings = {**settings, "noise": "none" if noise is None else repr(noise.key())}
    check_batch_folder(tasks, out_dir / "manifest.csv")  # a user's file is never replaced nor counted done
    if settings is not None:
        check_settings(out_dir / "manifest.csv", settings)
    if metamer is not None:  # fitted once, sent to every worker once
        from .metamer import metamer_correction
        from .pipeline import correction_stage

        camera, config = metamer
        pipeline = pipeline.replace("camera_to_XYZ", correction_stage(metamer_correction(camera, config)))
    out_dir.mkdir(parents=True, exist_ok=True)
    description = f"developing ({where})"
    if progress is not None:
        progress(description, 0, len(tasks))

    def report(stage: str, done: int, total: int) -> None:
        progress(description, done, total)

    return run_files(
        tasks,
        _develop_one,
        (pipeline, None if not crop else tuple(crop), None if save_stages is None else str(save_stages)),
        manifest=out_dir / "manifest.csv",
        scheduler=where,
        progress=None
        if progress is None
        else (lambda stage, done, total: progress(description, done, total)),
        settings=settings,
    )
