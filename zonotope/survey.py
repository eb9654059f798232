"""Camera-set survey: which cameras, stacked, best remove each other's metamer mismatch?

For every set of ``size`` cameras drawn from a list (built-in names, files, or every camera file
of a folder), one task computes

- the Vora value of the stacked channels against the target (:func:`zonotope.vora.vora_value`);
- the metamer mismatch volumes of the responses to a reflectance set (certified to ε, the volume
  is the mean of the certified lower and upper bounds): their median and 90th percentile, in the
  target's XYZ units (Y of the perfect white = 1);
- the mean ΔE00 of the best colour regression (Cheung 2004, Finlayson 2015, Dyer 2017), fitted on
  a training set and tested on the reflectance set.

The tasks run where :func:`zonotope.parallel.executor` says (serial, a local Dask cluster or a
running one); the cameras and reflectance sets are sent to each worker once. Each set is evaluated
on its own grid: 400–700 nm at the given step, narrowed to the range all its cameras are measured
on. The results are the same wherever they are computed (each task is a pure function of its set).

Rows are ranked by the median MMV volume (smaller: the set leaves less colour undetermined), ties
broken by the Vora value.
"""

from __future__ import annotations

import math
import time
from collections.abc import Sequence
from dataclasses import asdict, dataclass, fields
from itertools import combinations
from pathlib import Path

import numpy as np

from ._errors import OptionError, SpectralDataError, ZonotopeError
from .spectra.loading import load_camera
from .utilities.config import check_count, check_nonnegative, with_options
from .utilities.progress import ProgressCallback

__all__ = [
    "REGRESSIONS",
    "TABLE_HEADER",
    "TABLE_SUFFIXES",
    "SurveyConfig",
    "SurveyRow",
    "best_partners",
    "load_cameras",
    "survey",
    "write_table",
]

#: Regressions whose best mean ΔE00 is reported per camera set.
REGRESSIONS = ("Cheung 2004", "Finlayson 2015", "Dyer 2017")


@dataclass(frozen=True)
class SurveyRow:
    """The scores of one camera set (or the reason it failed, in ``error``)."""

    cameras: tuple[str, ...]
    channels: int
    grid: str
    vora: float
    mmv_median: float
    mmv_p90: float
    best_regression: str
    dE00: float
    seconds: float
    error: str = ""

    def as_dict(self) -> dict:
        """A flat dict (cameras joined with ``" + "``) for tables."""
        d = asdict(self)
        d["cameras"] = " + ".join(self.cameras)
        return d


def _file_camera_name(path: Path) -> str:
    """A camera file's name in a survey: its stem without a ``_380_780_5`` grid suffix or ``_ssf``."""
    import re

    return re.sub(r"_\d+_\d+_\d+$", "", path.stem).removesuffix("_ssf")


def load_cameras(spec: str | Path | Sequence[str | Path]) -> tuple[dict, list[str]]:
    """Cameras by name: a folder (every camera file below it), or names / files.

    Parameters
    ----------
    spec
        A folder: every ``.json`` / ``.csv`` file below it that :func:`zonotope.spectra.read_camera`
        reads (others, e.g. ``aliases.json`` or curves with negative lobes, are skipped); one file
        per camera name (the file stem without a ``_380_780_5`` grid suffix; JSON preferred).
        Otherwise built-in camera names or camera files (a comma-separated string also works),
        a file named as in a folder.

    Returns
    -------
    cameras : dict of str to colour.MultiSpectralDistributions
    skipped : list of str
        Files of a folder that were not cameras, with the reason.
    """
    from .spectra import builtin as spectra

    skipped: list[str] = []
    if isinstance(spec, str | Path) and Path(spec).is_dir():
        files = sorted(Path(spec).rglob("*"), key=lambda p: (p.suffix.lower() != ".json", str(p)))
        cams: dict = {}
        for f in files:
            if f.suffix.lower() not in (".json", ".csv") or not f.is_file():
                continue
            name = _file_camera_name(f)
            if name in cams:
                continue
            try:
                cams[name] = spectra.read_camera(f)
            except (ZonotopeError, ValueError, OSError) as error:
                skipped.append(f"{f}: {error}")
        if not cams:
            raise SpectralDataError(f"cameras: no camera file (rawtoaces/camspec JSON or CSV) in {spec}.")
        return cams, skipped
    names = [s.strip() for s in spec.split(",")] if isinstance(spec, str) else [str(s) for s in spec]
    cams = {}
    for n in names:
        if not n:
            continue
        if Path(n).is_dir():
            more, skip = load_cameras(Path(n))
            cams.update(more)
            skipped += skip
            continue
        curve = load_camera(n)
        cams[_file_camera_name(Path(n)) if Path(n).is_file() else curve.name] = curve
    return cams, skipped


def _grid(curves, interval: float) -> np.ndarray:
    from .spectra import builtin as spectra

    common = spectra.common_shape(*curves)
    start = max(400.0, math.ceil(common.start / interval) * interval)
    end = min(700.0, math.floor(common.end / interval) * interval)
    if end - start < 100:
        raise SpectralDataError(f"the cameras share only {common.start:g}–{common.end:g} nm.")
    return np.arange(start, end + interval / 2, interval)


def _score(names: tuple[str, ...], shared) -> SurveyRow:
    """One camera set → its :class:`SurveyRow` (a task; never raises for bad data)."""
    from .correct.methods import correction_problem, fit_correction
    from .mismatch.volume import metamer_mismatch_batch
    from .spectra import builtin as spectra
    from .vora import vora_value

    cameras, opts = shared
    t0 = time.perf_counter()
    k = 0
    try:
        curves = [cameras[n] for n in names]
        w = _grid([*curves, spectra.observer(opts["target"])], opts["interval"])
        train = opts["training"]
        training = spectra.resample(spectra.reflectances(train) if isinstance(train, str) else train, w).T
        problem = correction_problem(
            curves, target=opts["target"], illuminant=opts["illuminant"], shape=w, training=training
        )
        k = problem.Phi.shape[1]
        R = np.clip(spectra.resample(opts["reflectances"], w).T, 0.0, 1.0)
        C, T = problem.source_of(R), problem.target_of(R)
        v = vora_value(problem.Phi, problem.Psi)
        vols = metamer_mismatch_batch(
            problem.Phi, problem.Psi, C, eps=opts["eps"], on_infeasible="nearest"
        ).volumes
        best, best_dE = "", math.inf
        for m in REGRESSIONS:
            try:
                fitted = fit_correction(problem, method=m)
            except SpectralDataError:  # e.g. the ACES IDT takes one RGB camera only
                continue
            dE = float(np.mean(problem.delta_E(fitted(C), T)))
            if dE < best_dE:
                best, best_dE = m, dE
        return SurveyRow(
            names,
            k,
            f"{w[0]:g}–{w[-1]:g}/{w[1] - w[0]:g}",
            v,
            float(np.median(vols)),
            float(np.percentile(vols, 90)),
            best,
            best_dE,
            time.perf_counter() - t0,
        )
    except (ZonotopeError, ValueError, np.linalg.LinAlgError) as error:
        return SurveyRow(
            names,
            k,
            "",
            math.nan,
            math.nan,
            math.nan,
            "",
            math.nan,
            time.perf_counter() - t0,
            f"{type(error).__name__}: {error}",
        )


@dataclass(frozen=True)
class SurveyConfig:
    """Options of :func:`survey` (checked when made; see :mod:`zonotope.utilities.config`).

    Attributes
    ----------
    size : int
        Cameras per set (1 = each camera alone), ≥ 1 (and at most the number of cameras).
    target, illuminant
        Observer (XYZ colour-matching functions or LMS) and scene illuminant.
    interval : float
        Grid step in nm, 1–20 (each set on 400–700 nm narrowed to its cameras' common range).
    reflectances
        Reflectance set (built-in name, file or MSDS) for the MMV volumes and the ΔE00 test.
    training
        Training set of the regressions.
    eps : float
        Certification tolerance of the MMVs (relative to the target scale), ≥ 0.
    containing : tuple of str, optional
        Only the sets that contain at least one of these camera names (e.g. partners of one camera).

    Raises
    ------
    OptionError
        A value out of range (named, with what is allowed).
    """

    size: int = 2
    target: object = "CIE 2015 2°"
    illuminant: object = "D65"
    interval: float = 10.0
    reflectances: object = "ColorChecker N Ohta"
    training: object = "rawtoaces 190"
    eps: float = 1e-3
    containing: tuple[str, ...] | None = None

    def __post_init__(self) -> None:
        name = "SurveyConfig"
        check_count(name, "size", self.size, minimum=1)
        interval = check_nonnegative(name, "interval", self.interval)
        if not 1 <= interval <= 20:
            raise OptionError(f"{name}.interval={self.interval!r}: give a grid step of 1–20 nm.")
        object.__setattr__(self, "interval", interval)
        object.__setattr__(self, "eps", check_nonnegative(name, "eps", self.eps))
        if self.containing is not None:
            c = self.containing
            if isinstance(c, str) or not all(isinstance(x, str) for x in c):
                raise OptionError(f"{name}.containing={c!r}: give a list of camera names or None.")
            object.__setattr__(self, "containing", tuple(c))


def survey(
    cameras,
    config: SurveyConfig | None = None,
    *,
    scheduler: str | None = None,
    progress: ProgressCallback | None = None,
    **options,
) -> list[SurveyRow]:
    """Score every set of ``size`` cameras; ranked best first.

    Parameters
    ----------
    cameras
        As :func:`load_cameras` takes, or its dict of name → MSDS.
    config : SurveyConfig, optional
        Set size, target, illuminant, grid step, reflectance and training sets, ``eps``,
        ``containing``; default ``SurveyConfig()``.
    scheduler
        Where the tasks run (:func:`zonotope.parallel.executor`); one task per camera set.
    progress
        ``progress("camera sets", done, total)`` (:class:`~zonotope.utilities.ProgressCallback`).
    **options
        :class:`SurveyConfig` fields as keywords, alone or overriding those of ``config``
        (e.g. ``survey(cams, size=3)``).

    Returns
    -------
    list of SurveyRow
        Successful sets ranked by median MMV volume (ties: higher Vora first), then failed ones.

    Raises
    ------
    OptionError
        An unknown option or a value out of range.
    SpectralDataError
        ``size`` larger than the number of cameras, ``containing`` names no camera, bad curves.
    """
    cfg = with_options(SurveyConfig, config, options, where="survey")
    size, target, illuminant, interval = cfg.size, cfg.target, cfg.illuminant, cfg.interval
    reflectances, training, eps, containing = cfg.reflectances, cfg.training, cfg.eps, cfg.containing
    from .parallel import TaskFailure, executor
    from .spectra import builtin as spectra

    cams = cameras if isinstance(cameras, dict) else load_cameras(cameras)[0]
    if not isinstance(size, int) or not 1 <= size <= len(cams):
        raise SpectralDataError(
            f"size must be an integer in 1..{len(cams)} (the number of cameras); got {size!r}."
        )
    names = sorted(cams)
    sets = list(combinations(names, size))
    if containing is not None:
        want = set(containing)
        unknown = want - set(names)
        if unknown:
            raise SpectralDataError(f"containing: {sorted(unknown)} not among the cameras {names}.")
        sets = [s for s in sets if want & set(s)]
    refl = (
        spectra.reflectances(reflectances)
        if isinstance(reflectances, str) and not Path(reflectances).is_file()
        else (
            spectra.read_reflectances(reflectances) if isinstance(reflectances, str | Path) else reflectances
        )
    )
    train = (
        training
        if not isinstance(training, str | Path) or not Path(training).is_file()
        else spectra.read_reflectances(training)
    )
    opts = dict(
        target=target,
        illuminant=illuminant,
        interval=float(interval),
        reflectances=refl,
        training=train,
        eps=float(eps),
    )
    rows: list = [None] * len(sets)
    with executor(scheduler, tasks=len(sets), min_tasks=8) as ex:
        for i, out in ex.outcomes(_score, sets, shared=(cams, opts), progress=progress, stage="camera sets"):
            if isinstance(out, TaskFailure):
                out = SurveyRow(sets[i], 0, "", math.nan, math.nan, math.nan, "", math.nan, 0.0, out.error)
            rows[i] = out
    ok = sorted((r for r in rows if not r.error), key=lambda r: (r.mmv_median, -r.vora, r.cameras))
    return ok + [r for r in rows if r.error]


def best_partners(rows: Sequence[SurveyRow], camera: str, n: int = 10) -> list[SurveyRow]:
    """The ``n`` best-ranked sets of a survey that contain ``camera``."""
    return [r for r in rows if camera in r.cameras and not r.error][:n]


#: File types :func:`write_table` writes, by suffix.
TABLE_SUFFIXES = (".csv", ".parquet")

#: The first line of a survey CSV starts with this (how ``zonotope survey -o`` recognises a table it
#: may replace).
TABLE_HEADER = "rank,cameras,"


def write_table(rows: Sequence[SurveyRow], path: str | Path) -> Path:
    """Write the ranked rows as CSV (or Parquet for ``.parquet``, if pyarrow is installed), atomically.

    Raises
    ------
    ZonotopeError
        A suffix other than ``.csv`` / ``.parquet`` (nothing is written), or Parquet without pyarrow.
    """
    import csv
    import io

    from .utilities.io import atomic_path, atomic_write_text

    path = Path(path)
    if path.suffix.lower() not in TABLE_SUFFIXES:
        raise ZonotopeError(
            f"{str(path)!r}: a survey table is written as {' or '.join(TABLE_SUFFIXES)}; "
            f"{path.suffix or 'no suffix'} is not a table format this writes."
        )
    cols = [f.name for f in fields(SurveyRow)]
    if path.suffix.lower() == ".parquet":
        try:
            import pyarrow as pa
            import pyarrow.parquet as pq
        except ImportError as error:
            raise ZonotopeError(
                f"{path}: Parquet needs pyarrow (not installed); write .csv instead."
            ) from error
        table = pa.table({c: [r.as_dict()[c] for r in rows] for c in cols})
        return atomic_path(path, lambda tmp: pq.write_table(table, tmp))
    buf = io.StringIO()
    w = csv.DictWriter(buf, fieldnames=["rank", *cols], lineterminator="\n")
    w.writeheader()
    for i, r in enumerate(rows, 1):
        d = r.as_dict()
        cells = {c: (f"{d[c]:.6g}" if isinstance(d[c], float) else d[c]) for c in cols}
        w.writerow({"rank": i if not r.error else "", **cells})
    return atomic_write_text(path, buf.getvalue())
