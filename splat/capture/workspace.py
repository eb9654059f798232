"""The output folder ``OUT`` of a capture run, owned and recorded by splat.

:class:`Workspace` is the one place that decides what may be written, kept or removed under ``OUT``:

- a marker file (:data:`MARKER`) says that splat made the folder; a folder that holds files but no
  marker is refused, so nothing splat did not write is ever replaced or removed;
- every path handed out lies inside ``OUT``, whatever the capture names (a camera folder given as an
  absolute path or with ``..`` is read, never written next to: :meth:`splat.capture.CaptureSpec.out_stem`);
- capture inputs (camera folders, ``[poses]`` files, the ``[white]`` image) may not lie inside ``OUT``,
  where a step could replace them;
- a settings record (:data:`SETTINGS`) keeps, per step, a key over what the step's results depend on
  (the capture's files and tables, the step's options, the results of the step before it, the software
  version); a step whose key changed removes its own and its dependents' results before it recomputes.

Why: a rerun with other options, an edited ``capture.toml`` or another capture must never serve results
made from something else, and a user's files must never be lost to a cache.
"""

from __future__ import annotations

import functools
import hashlib
import json
import os
import shutil
from pathlib import Path

from .spec import CaptureError, CaptureSpec

__all__ = [
    "DECODE_CACHE",
    "MARKER",
    "SETTINGS",
    "STEP_OUTPUTS",
    "Workspace",
    "capture_fingerprint",
    "curves_fingerprint",
    "file_stamp",
    "peak_rss_mib",
    "read_json",
    "reset_peak_rss",
]

#: Marker file: its presence says OUT was made by splat.
MARKER = ".splat-output.json"
#: Settings record: per step, the key of what its results were made from.
SETTINGS = "settings.json"
#: What each step writes (relative to OUT), in step order; a step's dependents are the ones after it.
STEP_OUTPUTS = {
    "poses": ("previews", "poses", "decoded"),
    "train": ("train",),
    "render": ("render",),
    "correct": ("correct",),
    "report": ("report.html",),
}
_ORDER = tuple(STEP_OUTPUTS)
#: Where the RAW files decoded at the working resolution are kept (:meth:`Workspace.decode_cache`),
#: relative to OUT: an output of the poses step (the first), so that it outlives option changes of the
#: later steps and goes with a capture whose poses are recomputed.
DECODE_CACHE = "decoded"


def _version() -> str:
    from importlib.metadata import PackageNotFoundError, version

    try:
        return version("zonotope")
    except PackageNotFoundError:  # pragma: no cover - a source tree that was never installed
        return "0+unknown"


def read_json(path: Path, *, what: str = "summary") -> dict:
    """A JSON object written by splat, or a one-line :class:`CaptureError` naming the file."""
    try:
        doc = json.loads(Path(path).read_text())
    except (OSError, UnicodeDecodeError, json.JSONDecodeError) as e:
        raise CaptureError(
            f"{path}: not a readable splat {what} ({type(e).__name__}); remove it or choose a new "
            "output folder."
        ) from e
    if not isinstance(doc, dict):
        raise CaptureError(
            f"{path}: not a splat {what} (no JSON object); remove it or choose a new output folder."
        )
    return doc


def file_stamp(p: Path) -> list:
    """``[size, modification time in ns]`` of a file: what a cached result made from it is keyed on."""
    st = p.stat()
    return [st.st_size, st.st_mtime_ns]


def _files_of(path: Path | None) -> dict:
    if path is None:
        return {}
    if path.is_file():
        return {path.name: file_stamp(path)}
    return {q.relative_to(path).as_posix(): file_stamp(q) for q in sorted(path.rglob("*")) if q.is_file()}


def capture_fingerprint(spec: CaptureSpec) -> dict:
    """What the poses (and so every later step) read of the capture: each camera's table but its curves
    and RAW files (name, size, modification time), the ``[poses]`` files.

    Sizes and times rather than contents: hashing tens of gigabytes of RAW files on every run would cost
    more than a step; any edit or replacement of a file changes its time. The curves and the light are
    read by the correct step only (:func:`curves_fingerprint`), so changing them keeps the poses and
    the trained model."""
    cams = []
    for k, c in enumerate(spec.cameras):
        cams.append(
            {
                "folder": c.folder,
                "cfa": c.cfa,
                "black_level": c.black_level,
                "white_level": c.white_level,
                "exposure": dict(sorted(c.exposure.items())),
                "files": {p.name: file_stamp(p) for p in spec.raw_files(k)},
            }
        )
    return {
        "cameras": cams,
        "colmap": _files_of(spec.colmap),
        "transforms": _files_of(spec.transforms),
    }


def curves_fingerprint(spec: CaptureSpec) -> dict:
    """What the correct step reads of ``capture.toml`` besides the earlier steps' results: each camera's
    curves (name, or file with its size and time; ``"estimate"`` is of the DNG files the poses already
    record) and whether they are the very camera's (``ssf_exact``), the scene and reference lights
    (name, or file), the observer and the ``[white]`` table."""

    def stamp(name: str | None, root: Path) -> dict | None:
        if name is None:
            return None
        p = Path(name) if Path(name).is_absolute() else root / name
        return {"name": name, "file": file_stamp(p) if p.is_file() else None}

    w = spec.white
    return {
        "ssf": [stamp(c.ssf, spec.root) for c in spec.cameras],
        "ssf_exact": [c.ssf_exact for c in spec.cameras],
        "illuminant": stamp(spec.illuminant, spec.root),
        "reference": stamp(spec.reference, spec.root),
        "observer": spec.observer,
        "white": [w.method, w.image, w.box, w.reflectance],
    }


def _inside(p: Path, root: Path) -> bool:
    return p == root or root in p.parents


class Workspace:
    """``OUT`` for one capture: checked, marked and recorded on construction.

    Parameters
    ----------
    spec : CaptureSpec
    out : path
        The output folder: new, empty, or made by splat (it holds :data:`MARKER`).

    Raises
    ------
    CaptureError
        ``out`` inside the capture; a capture input inside ``out``; ``out`` a file, or a folder with
        files but no marker; a marker or settings record that is not splat's.
    """

    def __init__(self, spec: CaptureSpec, out: str | os.PathLike):
        self.spec = spec
        self.root = Path(out).resolve()
        root = spec.root.resolve()
        if _inside(self.root, root):
            raise CaptureError(
                f"output folder {self.root} lies inside the capture {root}; choose a folder outside "
                "it (the capture is never written to)."
            )
        inputs = [(f"camera folder {c.folder!r}", (spec.root / c.folder).resolve()) for c in spec.cameras]
        inputs += [("[poses].colmap", spec.colmap), ("[poses].transforms", spec.transforms)]
        if spec.white.image is not None:
            inputs.append(("[white].image", spec.root / spec.white.image))
        for what, p in inputs:
            if p is not None and _inside(Path(p).resolve(), self.root):
                raise CaptureError(
                    f"{spec.file}: {what} lies inside the output folder {self.root}, which splat owns and "
                    "may replace; move it out or choose another output folder."
                )
        if self.root.exists() and not self.root.is_dir():
            raise CaptureError(f"output folder {self.root} is a file; choose a folder.")
        marker = self.root / MARKER
        if self.root.is_dir() and not marker.is_file() and any(self.root.iterdir()):
            raise CaptureError(
                f"output folder {self.root} holds files that splat did not write (no {MARKER}); choose an "
                "empty or new folder."
            )
        self.root.mkdir(parents=True, exist_ok=True)
        if marker.is_file():
            doc = read_json(marker, what="output marker")
            if doc.get("written_by") != "splat":
                raise CaptureError(f"{marker}: not a splat output marker; choose an empty or new folder.")
        else:
            self._write(marker, {"written_by": "splat", "version": _version()})
        self._settings = self.root / SETTINGS
        self.record = read_json(self._settings, what="settings record") if self._settings.is_file() else {}
        if not isinstance(self.record.get("steps", {}), dict):
            raise CaptureError(f"{self._settings}: not a splat settings record; choose a new output folder.")
        self.record.setdefault("steps", {})

    # ------------------------------------------------------------------------------------ paths
    def path(self, *parts: str) -> Path:
        """``OUT/<parts>``, refused if it would lie outside ``OUT``."""
        p = self.root.joinpath(*parts)
        if not _inside(Path(os.path.normpath(p)), self.root):
            raise CaptureError(f"{p}: an output path outside {self.root}; refusing to write there.")
        return p

    def view_dir(self, step: str, name: str) -> Path:
        """``OUT/<step>/<label>/<stem>`` of view ``name`` (see :meth:`CaptureSpec.out_stem`)."""
        return self.path(step, self.spec.out_stem(name))

    # ------------------------------------------------------------------------------ the record
    def key(self, step: str) -> str | None:
        """The recorded key of ``step``'s results (None when it never ran here)."""
        entry = self.record["steps"].get(step)
        return entry.get("key") if isinstance(entry, dict) else None

    def check_made_from(self, spec: CaptureSpec) -> None:
        """Refuse to read results made from other inputs: the recorded poses' capture fingerprint and
        correction's curves must be those of ``spec`` as it is now (steps not recorded are not checked).
        Why: ``splat report`` and ``splat export`` read OUT without rerunning the steps, so an edited
        ``capture.toml``, a replaced RAW file or another capture would otherwise get the old results.

        Raises
        ------
        CaptureError
            One line naming OUT and the command that brings it up to date.
        """
        steps = self.record["steps"]
        now = {
            "poses": ("capture", capture_fingerprint(spec)),
            "correct": ("curves", curves_fingerprint(spec)),
        }
        for step, (field, value) in now.items():
            recorded = steps.get(step, {}).get("settings", {})
            if field in recorded and recorded[field] != json.loads(json.dumps(value, default=str)):
                what = "its RAW files or camera tables" if step == "poses" else "its curves, lights or white"
                raise CaptureError(
                    f"{self.root} was made from another capture or an earlier {spec.file.name} ({what} "
                    f"differ): give the capture it was made from, or run `splat run {spec.root} -o "
                    f"{self.root}` to bring it up to date first."
                )

    def begin(self, step: str, settings: dict) -> str:
        """Record that ``step`` now works from ``settings`` (plus the key of the step before it and the
        software version); when that differs from the record, first remove the results of ``step`` and
        every later step. Returns the key.

        Raises
        ------
        CaptureError
            A result path of ``step`` or a later one exists but no step that writes it is recorded (a
            file splat did not write, e.g. a user's ``report.html``): it is never replaced.
        """
        i = _ORDER.index(step)
        steps = self.record["steps"]
        for s in _ORDER[i:]:
            for o in STEP_OUTPUTS[s]:
                p = self.path(o)
                if p.exists() and s not in steps:
                    raise CaptureError(
                        f"{p}: not written by splat's {s} step (no record in {self._settings.name}); move it "
                        "out of the output folder or choose another one."
                    )
        upstream = self.key(_ORDER[i - 1]) if i else None
        doc = {"step": step, "settings": settings, "upstream": upstream, "version": _version()}
        key = hashlib.sha256(json.dumps(doc, sort_keys=True, default=str).encode()).hexdigest()
        if self.key(step) == key:
            return key
        for s in _ORDER[i:]:
            if s in steps:
                for o in STEP_OUTPUTS[s]:
                    p = self.path(o)
                    if p.is_dir():
                        shutil.rmtree(p)
                    elif p.exists():
                        p.unlink()
                del steps[s]
                self._write(self._settings, self.record)  # recorded as gone before the next removal
        steps[step] = {"key": key, "settings": settings, "upstream": upstream, "version": _version()}
        self._write(self._settings, self.record)
        return key

    def decode_cache(self, options: dict) -> tuple[Path, dict] | None:
        """``(OUT/decoded, options + version)``: the ``cache`` of :func:`splat.capture.raw.load_views`,
        where the poses step keeps each RAW file decoded at the working resolution and the train, render and
        correct steps read it (``options``: everything the working binning depends on), so that a run
        decodes each file once.

        Each file's entry is named by a hash of the file (path, size, modification time), its camera's
        overrides, ``options`` and the software version, so it is never read for other inputs or
        options. None (decode every time) when the poses step is not recorded here: the folder is
        one of its outputs, so it is written only where the record says splat owns it."""
        if "poses" not in self.record["steps"]:
            return None
        return self.path(DECODE_CACHE), {"options": options, "version": _version()}

    def _write(self, path: Path, doc: dict) -> None:
        from zonotope.utilities import atomic_path

        atomic_path(path, lambda p: p.write_text(json.dumps(doc, indent=1, sort_keys=True, default=str)))


def reset_peak_rss() -> None:
    """Start a new peak-memory measurement (Linux: ``/proc/self/clear_refs`` resets the process's
    peak resident set size); elsewhere a no-op, and :func:`peak_rss_mib` reports the process's peak."""
    try:
        with open("/proc/self/clear_refs", "w") as fh:
            fh.write("5")
    except OSError:
        pass


@functools.cache
def _malloc_trim():
    """The C library's ``malloc_trim`` (glibc), or None where it has none (looked up once: ``find_library``
    runs ``ldconfig``)."""
    import ctypes
    import ctypes.util

    name = ctypes.util.find_library("c")
    try:
        return ctypes.CDLL(name).malloc_trim if name else None
    except (OSError, AttributeError):
        return None


def release_free_memory() -> None:
    """Hand the C heap's free pages back to the system (glibc ``malloc_trim(0)``; elsewhere a no-op).
    Why: strips computed on threads free their arrays into per-thread heaps that glibc keeps; over the
    correct step's photographs the resident size grew by ~200 MiB per 12 MP photograph without it."""
    trim = _malloc_trim()
    if trim is not None:
        trim(0)


def peak_rss_mib() -> float:
    """Peak resident memory (MiB) since :func:`reset_peak_rss` (Linux ``VmHWM``), else of the process."""
    try:
        with open("/proc/self/status") as fh:
            for line in fh:
                if line.startswith("VmHWM:"):
                    return round(int(line.split()[1]) / 1024, 1)
    except (OSError, ValueError, IndexError):
        pass
    import resource
    import sys

    rss = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
    return round(rss / (2**20 if sys.platform == "darwin" else 1024), 1)
