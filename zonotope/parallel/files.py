"""Folder batches: one output per input, written atomically and at most once, resumable, with a manifest.

:func:`run_files` runs a function per file on an :func:`zonotope.parallel.executor`; the record
folder :data:`BATCH_RECORD` says which outputs the batch wrote (:func:`check_batch_folder` refuses a
user's file with an output's name), and :func:`check_settings` refuses to resume with other options.
"""

from __future__ import annotations

import os
import re
import shutil
from collections.abc import Callable, Iterable, Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from .._errors import ZonotopeError
from ..utilities.progress import ProgressCallback
from .cluster import executor
from .executors import ParallelError, TaskFailure

__all__ = [
    "BATCH_RECORD",
    "FILE_MIN_TASKS",
    "MANIFEST_COLUMNS",
    "FileTask",
    "check_batch_folder",
    "check_settings",
    "run_files",
]


#: Smallest folder batch that starts a local cluster by default: starting one costs seconds, and on a
#: loaded 2-core machine 3 RAW files took 7.3 s serial against 15.6 s on a 2-worker local cluster.
FILE_MIN_TASKS = 8


@dataclass(frozen=True)
class FileTask:
    """One input file and the output it becomes."""

    input: str
    output: str


#: Columns of the manifest CSV written by :func:`run_files`.
MANIFEST_COLUMNS = ("input", "output", "status", "seconds", "worker", "error")

#: Folder, beside a batch's outputs, that records what the batch wrote: one empty file
#: ``<output name>.<size>-<mtime_ns>`` per output, made by the worker just before it publishes it.
#: An existing output is the batch's (``done``) only if it still has a recorded size and time; the
#: folder's presence also says that the manifest and settings record beside it are the batch's.
BATCH_RECORD = ".zonotope-batch"


def _stamp(path: Path, st: os.stat_result | None = None) -> str:
    st = path.stat() if st is None else st
    return f"{path.name}.{st.st_size}-{st.st_mtime_ns}"


def _recorded(path: Path) -> bool:
    """Whether ``path`` is an output this batch tool wrote (its size and time are recorded)."""
    try:
        return (path.parent / BATCH_RECORD / _stamp(path)).is_file()
    except OSError:
        return False


def check_batch_folder(tasks: Iterable[FileTask], manifest: str | os.PathLike) -> None:
    """Refuse a folder batch that would replace or count as its own a file it did not write.

    Run before any long work (a fit). The manifest, its settings record and every existing output
    must have been written by a folder batch (:data:`BATCH_RECORD`): a user's ``manifest.csv`` is
    never replaced, and a user's file that merely has an output's name is never counted ``done``.

    Raises
    ------
    ParallelError
        Naming the first such file and what to do.
    """
    manifest = Path(manifest)
    owned = (manifest.parent / BATCH_RECORD).is_dir()
    for p in (manifest, _settings_path(manifest)):
        if p.exists() and not owned:
            raise ParallelError(
                f"{p} was not written by a folder batch (no {BATCH_RECORD} record beside it); move it "
                "out of the folder or choose another output folder."
            )
    for t in tasks:
        out = Path(t.output)
        if out.exists() and not _recorded(out):
            raise ParallelError(
                f"{out} exists but was not written by this batch (no record in "
                f"{out.parent / BATCH_RECORD}); move it out of the folder or choose another output folder."
            )


def _forget_stale(tasks: list[FileTask]) -> None:
    """Remove record entries of outputs that no longer match them (another attempt, a removed file)."""
    by_folder: dict[Path, dict[str, str | None]] = {}
    for t in tasks:
        out = Path(t.output)
        try:
            current = _stamp(out) if out.is_file() else None
        except OSError:
            current = None
        by_folder.setdefault(out.parent, {})[out.name] = current
    for folder, names in by_folder.items():
        record = folder / BATCH_RECORD
        if not record.is_dir():
            continue
        for entry in record.iterdir():
            name, _, stamp = entry.name.rpartition(".")
            if name in names and entry.name != names[name] and re.fullmatch(r"\d+-\d+", stamp):
                entry.unlink(missing_ok=True)


def _publish(tmp: Path, dest: Path) -> bool:
    """Make ``tmp`` appear at ``dest`` atomically, only if nothing is there yet; True if it was ours.

    ``os.link`` creates ``dest`` or fails, so two attempts of one task (a worker killed after
    writing, its task re-run elsewhere) never both replace the file: the first one wins.
    """
    try:
        os.link(tmp, dest)
        return True
    except FileExistsError:
        return False
    except OSError:  # file systems without hard links: an atomic rename (last attempt wins)
        os.replace(tmp, dest)
        return True
    finally:
        tmp.unlink(missing_ok=True)


def _temp_for(dest: Path) -> Path:
    import uuid

    return dest.with_name(f".{dest.stem}.{uuid.uuid4().hex[:12]}.part{dest.suffix}")


def _file_task(task: FileTask, shared) -> dict:
    """Run ``work(input, temporary_output, options)`` for one file on a worker; never raises."""
    import socket
    import time

    work, options = shared
    dest = Path(task.output)
    row = {
        "input": task.input,
        "output": task.output,
        "seconds": 0.0,
        "worker": f"{socket.gethostname()}:{os.getpid()}",
        "error": "",
    }
    if dest.exists():  # a re-run of a task whose first attempt finished (its worker then died)
        if _recorded(dest):
            return {**row, "status": "done"}
        return {
            **row,
            "status": "failed",
            "error": f"{dest} appeared during the batch and was not written by it; it was left as it is.",
        }
    tmp = _temp_for(dest)
    t0 = time.perf_counter()
    entry = None
    try:
        work(task.input, str(tmp), options)
        if not tmp.is_file():
            raise ZonotopeError(f"the task wrote nothing for {task.input}")
        # recorded before it appears, so that a kill between the two never leaves an output unrecorded
        entry = dest.parent / BATCH_RECORD / _stamp(dest, tmp.stat())
        entry.touch()
        if not _publish(tmp, dest):  # another attempt published first: its entry is the one that counts
            entry.unlink(missing_ok=True)
    except Exception as error:  # one bad file is reported, the batch goes on
        tmp.unlink(missing_ok=True)
        if entry is not None and not dest.exists():
            entry.unlink(missing_ok=True)
        return {
            **row,
            "status": "failed",
            "seconds": time.perf_counter() - t0,
            "error": f"{type(error).__name__}: {error}".replace("\n", " "),
        }
    return {**row, "status": "ok", "seconds": time.perf_counter() - t0}


def _write_manifest(path: Path, rows: list[dict]) -> None:
    import csv
    import io

    buf = io.StringIO()
    w = csv.DictWriter(buf, fieldnames=MANIFEST_COLUMNS, lineterminator="\n")
    w.writeheader()
    for r in rows:
        w.writerow({k: (f"{r[k]:.3f}" if k == "seconds" else r[k]) for k in MANIFEST_COLUMNS})
    tmp = _temp_for(path)
    tmp.write_text(buf.getvalue(), encoding="utf-8")
    os.replace(tmp, path)


def _check_tasks(tasks: list[FileTask]) -> None:
    """Refuse a layout where two inputs share an output or an output is an input (before any work).

    Raises
    ------
    ParallelError
        Naming the two inputs (or the output) concerned.
    """
    first: dict[Path, str] = {}
    for t in tasks:
        out = Path(t.output).resolve()
        if out in first:
            if Path(first[out]).resolve() == Path(t.input).resolve():
                raise ParallelError(f"input {t.input} is given more than once; give each file once.")
            raise ParallelError(
                f"inputs {first[out]} and {t.input} would both be written to {t.output}; "
                "rename one of them or give them separately to different output folders."
            )
        first[out] = str(t.input)
    ins = {Path(t.input).resolve() for t in tasks}
    clash = [str(t.output) for t in tasks if Path(t.output).resolve() in ins]
    if clash:
        raise ParallelError(f"output {clash[0]} is one of the inputs; choose another output folder.")


def _settings_path(manifest: str | os.PathLike) -> Path:
    manifest = Path(manifest)
    return manifest.with_name(manifest.stem + ".settings.json")


def _settings_json(settings: Mapping[str, Any]) -> dict:
    import json

    return json.loads(json.dumps(dict(settings), sort_keys=True, default=str))


def check_settings(manifest: str | os.PathLike, settings: Mapping[str, Any]) -> None:
    """Refuse to resume a folder batch that was started with other settings.

    A rerun skips the outputs that exist, so one made with other options (another estimator,
    demosaicing, white balance, ...) would silently stay among the new ones. :func:`run_files`
    keeps a batch's ``settings`` beside its manifest (``manifest.csv`` → ``manifest.settings.json``);
    call this before long work (a fit) to refuse early.

    Parameters
    ----------
    manifest : path
        The batch's manifest path.
    settings : mapping
        The options that change the outputs (JSON-serialisable; others are stored as text).

    Raises
    ------
    ParallelError
        The folder holds a batch with other settings; names the first differences.
    """
    import json

    path = _settings_path(manifest)
    if not path.is_file():
        return
    try:
        old = json.loads(path.read_text())
    except (OSError, ValueError) as error:
        raise ParallelError(
            f"{path}: unreadable batch settings ({error}); delete it to start over."
        ) from error
    new = _settings_json(settings)
    if old != new:
        diff = sorted(k for k in old.keys() | new.keys() if old.get(k) != new.get(k))
        shown = "; ".join(f"{k}: {old.get(k)!r} then, {new.get(k)!r} now" for k in diff[:3])
        raise ParallelError(
            f"{path.parent} holds outputs of a batch with other settings ({shown}); a rerun only "
            "resumes the same batch: choose another output folder, or delete this one to start over."
        )


def run_files(
    tasks: Iterable[FileTask],
    work: Callable[[str, str, Any], None],
    options: Any = None,
    *,
    manifest: str | os.PathLike,
    scheduler: str | None = None,
    min_tasks: int = FILE_MIN_TASKS,
    progress: ProgressCallback | None = None,
    settings: Mapping[str, Any] | None = None,
) -> list[dict]:
    """Make one output file per input file, on the chosen executor; resumable, with a manifest.

    Parameters
    ----------
    tasks : iterable of FileTask
        Inputs and their outputs (outputs must differ from every input and from each other).
    work : callable
        ``work(input_path, temporary_output_path, options)`` writes the output to the temporary
        path (same folder and suffix as the output); a module-level function, so that workers can
        import it. It may raise: the file is then reported ``failed`` and the others go on.
    options : object
        Sent to every worker once (e.g. a fitted estimator).
    manifest : path
        CSV rewritten atomically as the batch goes (columns :data:`MANIFEST_COLUMNS`).
    scheduler, min_tasks
        Where to run (see :func:`executor`). With no scheduler, a local cluster is started only for
        ``min_tasks`` files or more (default :data:`FILE_MIN_TASKS`).
    progress : callable, optional
        ``progress("files", done, total)`` over the files that had to be made
        (:class:`~zonotope.utilities.ProgressCallback`).
    settings : mapping, optional
        The options that change the outputs: kept beside the manifest, and a rerun into the same
        folder with other settings is refused (:func:`check_settings`).

    Returns
    -------
    list of dict
        One row per task, in input order: ``status`` is ``ok`` (made now), ``done`` (the output
        already existed and was written by this batch tool: skipped, which is how a rerun resumes) or
        ``failed`` (``error`` says why).

    Raises
    ------
    ParallelError
        Two inputs share an output, or the folder holds a manifest, settings record or output that
        a folder batch did not write (:func:`check_batch_folder`): it is never replaced or counted.

    Notes
    -----
    Each output is written to a temporary file and published with a hard link, so it appears
    complete or not at all, and a task run twice (its worker killed after writing) never writes it
    a second time. What was written is recorded in :data:`BATCH_RECORD` before it appears, so a
    rerun after a kill still resumes. Inputs are only read.
    """
    import time

    tasks = list(tasks)
    _check_tasks(tasks)
    manifest = Path(manifest)
    check_batch_folder(tasks, manifest)
    for folder in {manifest.parent, *(Path(t.output).parent for t in tasks)}:
        (folder / BATCH_RECORD).mkdir(parents=True, exist_ok=True)
    if settings is not None:
        import json

        from ..utilities.io import atomic_write_bytes

        check_settings(manifest, settings)
        if not _settings_path(manifest).is_file():
            text = json.dumps(_settings_json(settings), sort_keys=True, indent=1, ensure_ascii=False)
            atomic_write_bytes(_settings_path(manifest), (text + "\n").encode())
    rows: list[dict] = []
    todo: list[int] = []
    for i, t in enumerate(tasks):
        if Path(t.output).exists():
            rows.append(
                {
                    "input": t.input,
                    "output": t.output,
                    "status": "done",
                    "seconds": 0.0,
                    "worker": "",
                    "error": "",
                }
            )
        else:
            rows.append(
                {
                    "input": t.input,
                    "output": t.output,
                    "status": "pending",
                    "seconds": 0.0,
                    "worker": "",
                    "error": "",
                }
            )
            todo.append(i)
    _write_manifest(manifest, rows)
    last = time.monotonic()
    try:
        if todo:  # a finished batch run again has nothing to make: no cluster is started
            with executor(scheduler, tasks=len(todo), min_tasks=min_tasks) as ex:
                for j, out in ex.outcomes(
                    _file_task,
                    [tasks[i] for i in todo],
                    shared=(work, options),
                    progress=progress,
                    stage="files",
                ):
                    i = todo[j]
                    if isinstance(out, TaskFailure):  # the task itself was lost (e.g. killed too often)
                        out = {**rows[i], "status": "failed", "error": out.error.replace("\n", " ")}
                    rows[i] = out
                    if time.monotonic() - last > 2.0:
                        _write_manifest(manifest, rows)
                        last = time.monotonic()
    finally:
        _remove_temporaries(tasks)
        _forget_stale(tasks)
        _write_manifest(manifest, rows)
    return rows


def _remove_temporaries(tasks: list[FileTask]) -> None:
    """Remove the temporaries of attempts whose worker died while writing (only this batch's): the
    ``.part`` files, and the atomic writers' own temporaries of a ``.part`` file (a worker killed
    inside ``zonotope.utilities.io``'s write of it leaves ``..stem.<hex>.part.tif.<pid>.tmp-….tif``)."""
    from ..utilities.io import _TMP

    names: dict[Path, set[str]] = {}
    for t in tasks:
        out = Path(t.output)
        names.setdefault(out.parent, set()).add(out.stem)
    pattern = re.compile(r"^\.(.+)\.[0-9a-f]{12}\.part(\.[^.]*)?$")
    for folder, stems in names.items():
        if not folder.is_dir():
            continue
        for entry in folder.iterdir():
            inner = _TMP.match(entry.name)
            m = pattern.match(inner.group("name") if inner else entry.name)
            if not (m and m.group(1) in stems):
                continue
            if entry.is_dir() and not entry.is_symlink():
                shutil.rmtree(entry, ignore_errors=True)
            else:
                entry.unlink(missing_ok=True)
