"""A pipeline: an ordered list of named pure stages (optax ``chain``-like) that keeps every intermediate.

A :class:`Stage` is a name and a function ``fn(x, raw) -> x`` where ``x`` is the current array and
``raw`` the :class:`~isp.raw.RawImage` whose metadata the stage may read. A :class:`Pipeline` is an
immutable tuple of stages; ``replace``, ``remove``, ``insert``, ``reorder`` and ``until`` return new
pipelines. Running it returns a :class:`Development` with the output and every intermediate.

>>> from isp import default_pipeline
>>> p = default_pipeline(demosaic="bilinear")
>>> p.names
('linearise', 'white_balance', 'demosaic', 'camera_to_XYZ', 'XYZ_to_linear_sRGB', 'tonemap', 'encode_sRGB')
>>> p.until("XYZ_to_linear_sRGB").names[-1]
'XYZ_to_linear_sRGB'
"""

from __future__ import annotations

import os
from collections.abc import Callable, Iterable
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from . import stages as st
from ._errors import PipelineError
from .raw import RawImage

if TYPE_CHECKING:
    from zonotope.correct import Corrector

__all__ = ["Development", "MetamerCorrection", "Pipeline", "Stage", "chain", "correction_stage",
           "default_pipeline", "develop", "metamer_correction"]

StageFn = Callable[[np.ndarray, RawImage], np.ndarray]


@dataclass(frozen=True)
class Stage:
    """One named operation ``fn(x, raw) -> x``.

    Attributes
    ----------
    name : str
        Unique within a pipeline; used to replace, remove or stop after it.
    fn : callable
        ``(array, RawImage) -> array``; must not modify its input.
    """

    name: str
    fn: StageFn = field(repr=False)

    def __call__(self, x: np.ndarray, raw: RawImage) -> np.ndarray:
        return self.fn(x, raw)


@dataclass(frozen=True, eq=False)
class Development:
    """The result of running a pipeline.

    Attributes
    ----------
    image : ndarray
        Output of the last stage that ran.
    intermediates : dict of str → ndarray
        Output of every stage, in order (``"input"`` first: the raw mosaic).
    raw : RawImage
    """

    image: np.ndarray
    intermediates: dict[str, np.ndarray]
    raw: RawImage = field(repr=False)


class Pipeline:
    """An ordered, immutable list of uniquely named stages.

    Parameters
    ----------
    stages
        :class:`Stage` objects, or ``(name, fn)`` pairs.

    Raises
    ------
    PipelineError
        Duplicate names, or an item that is not a stage.
    """

    def __init__(self, stages: Iterable[Stage | tuple[str, StageFn]]) -> None:
        items = []
        for s in stages:
            if isinstance(s, tuple) and len(s) == 2:
                s = Stage(*s)
            if not isinstance(s, Stage) or not callable(s.fn):
                raise PipelineError(f"{s!r} is not a Stage or a (name, fn) pair with a callable fn.")
            items.append(s)
        names = [s.name for s in items]
        dup = sorted({n for n in names if names.count(n) > 1})
        if dup:
            raise PipelineError(f"stage names must be unique; {dup} appear more than once.")
        self._stages: tuple[Stage, ...] = tuple(items)

    @property
    def stages(self) -> tuple[Stage, ...]:
        """The stages, in order."""
        return self._stages

    @property
    def names(self) -> tuple[str, ...]:
        """Stage names, in order."""
        return tuple(s.name for s in self._stages)

    def __len__(self) -> int:
        return len(self._stages)

    def __repr__(self) -> str:
        return f"Pipeline({' → '.join(self.names)})"

    def _index(self, name: str) -> int:
        try:
            return self.names.index(name)
        except ValueError:
            raise PipelineError(f"no stage named {name!r}; stages are {list(self.names)}.") from None

    def __getitem__(self, name: str) -> Stage:
        return self._stages[self._index(name)]

    # -- editing (each returns a new pipeline) ---------------------------------------------------
    def replace(self, name: str, stage: Stage | StageFn) -> Pipeline:
        """Replace stage ``name`` by ``stage`` (a Stage, or a function that keeps the name)."""
        i = self._index(name)
        new = stage if isinstance(stage, Stage) else Stage(name, stage)
        return Pipeline((*self._stages[:i], new, *self._stages[i + 1:]))

    def remove(self, name: str) -> Pipeline:
        """Drop stage ``name``."""
        i = self._index(name)
        return Pipeline(self._stages[:i] + self._stages[i + 1:])

    def insert(self, stage: Stage, *, before: str | None = None, after: str | None = None) -> Pipeline:
        """Insert ``stage`` before or after a named stage (at the end when neither is given)."""
        if before is not None and after is not None:
            raise PipelineError("give before= or after=, not both.")
        i = (self._index(before) if before is not None else
             self._index(after) + 1 if after is not None else len(self._stages))
        return Pipeline((*self._stages[:i], stage, *self._stages[i:]))

    def reorder(self, names: Iterable[str]) -> Pipeline:
        """The same stages in the order ``names`` (every name exactly once)."""
        names = list(names)
        if sorted(names) != sorted(self.names):
            raise PipelineError(f"reorder needs each of {list(self.names)} exactly once; got {names}.")
        return Pipeline(self[n] for n in names)

    def until(self, name: str) -> Pipeline:
        """The stages up to and including ``name`` (stop after it)."""
        return Pipeline(self._stages[:self._index(name) + 1])

    # -- running -------------------------------------------------------------------------------
    def __call__(self, raw: RawImage, *, stop_after: str | None = None, keep: bool = True,
                 on_stage: Callable[[int, str], None] | None = None) -> Development:
        """Develop ``raw``.

        Parameters
        ----------
        raw
            The RAW image (its ``mosaic`` is the first input).
        stop_after
            Name of the last stage to run.
        keep
            Keep every intermediate (else only the input and the output).
        on_stage
            Called as ``on_stage(i, name)`` before each stage (progress displays).

        Returns
        -------
        Development

        Raises
        ------
        PipelineError
            Unknown ``stop_after``; a stage that returned something other than a finite array.
        """
        run = self.until(stop_after) if stop_after is not None else self
        x = np.asarray(raw.mosaic)
        inter: dict[str, np.ndarray] = {"input": x}
        for i, s in enumerate(run.stages):
            if on_stage is not None:
                on_stage(i, s.name)
            y = s(x, raw)
            if not isinstance(y, np.ndarray):
                raise PipelineError(f"stage {s.name!r} returned {type(y).__name__}, not an ndarray.")
            if y.dtype.kind == "f" and not np.all(np.isfinite(y)):
                raise PipelineError(f"stage {s.name!r} produced NaN or inf; check its input and options.")
            if keep:
                inter[s.name] = y
            x = y
        if not keep and run.stages:
            inter[run.stages[-1].name] = x
        return Development(image=x, intermediates=inter, raw=raw)


def chain(*stages: Stage | tuple[str, StageFn]) -> Pipeline:
    """Build a :class:`Pipeline` from stages given in order."""
    return Pipeline(stages)


# ---------------------------------------------------------------------------------------------
# Standard stages bound to RawImage metadata
# ---------------------------------------------------------------------------------------------


def _linearise(x, raw: RawImage):
    table = None if raw.table_applied else raw.linearisation_table
    return st.linearise(x, black_level=raw.black_level, white_level=raw.white_level, table=table)


def _white_balance(x, raw: RawImage):
    cfa = raw.cfa if np.ndim(x) == 2 else None
    return st.white_balance(x, neutral=raw.as_shot_neutral, cfa=cfa)


def _demosaic_stage(method: str) -> Stage:
    st._resolve(method, st.DEMOSAIC_METHODS, "demosaic")  # fail early on a bad name
    return Stage("demosaic", lambda x, raw: st.demosaic(x, cfa=raw.cfa, method=method))


def _camera_to_XYZ(x, raw: RawImage):
    return st.camera_to_XYZ(x, matrix=st.matrix_XYZ_from_balanced(raw.profile, raw.as_shot_neutral))


def correction_stage(XYZ_from_responses: Callable[[np.ndarray], np.ndarray], *,
                     balanced: bool = True, name: str = "camera_to_XYZ") -> Stage:
    """A stage that replaces the DNG ColorMatrix by any ``(N, k) → (N, 3)`` estimator.

    Parameters
    ----------
    XYZ_from_responses
        Camera responses → XYZ (e.g. a fitted ``zonotope.correct`` corrector).
    balanced
        True: the stage expects white-balanced input (white = ones). False: un-balanced camera
        RGB, the white being the image's AsShotNeutral (remove the ``white_balance`` stage).
    name
        Stage name (default replaces ``"camera_to_XYZ"``).

    Returns
    -------
    Stage
    """
    def fn(x, raw: RawImage):
        white = None if balanced else raw.as_shot_neutral
        return st.apply_correction(x, XYZ_from_responses=XYZ_from_responses, white_response=white)

    return Stage(name, fn)


# ---------------------------------------------------------------------------------------------
# Metamer-based correction (zonotope.correct) for a camera whose sensitivities are known
# ---------------------------------------------------------------------------------------------

#: Default wavelength range (nm) and step of the metamer correction fit: 31 samples keep fitting
#: and the per-colour optimisations fast; the range is narrowed to the curves' common range.
METAMER_RANGE = (400.0, 700.0, 10.0)
_SPECTRAL_SUFFIXES = (".json", ".csv", ".txt", ".reflect", ".spd")

#: Errors of one colour's metamer estimate that fall back to the regression (e.g. Qhull on the
#: degenerate mismatch volume of a response on or outside the solid's boundary).
_ESTIMATOR_ERRORS = (ArithmeticError, RuntimeError, ValueError, np.linalg.LinAlgError)


def _spectral(source, builtin: Callable, read: Callable, what: str):
    """A built-in curve set by name, or one read from a file (clear errors, no tracebacks)."""
    if not isinstance(source, str | os.PathLike):
        return source  # already a colour MSDS
    path = Path(source)
    if path.is_file():
        try:
            return read(path)
        except (OSError, KeyError, TypeError, ValueError) as exc:
            raise ValueError(f"cannot read {what} file {path}: {exc}") from exc
    if path.suffix.lower() in _SPECTRAL_SUFFIXES or os.sep in str(source):
        raise FileNotFoundError(f"{what} file {path} not found.")
    return builtin(str(source))


@dataclass(eq=False)
class MetamerCorrection:
    """White-balanced camera RGB ``(N, 3)`` → XYZ ``(N, 3)`` with a fitted ``zonotope.correct`` estimator.

    Built by :func:`metamer_correction`; pass it as ``default_pipeline(correction=...)``. Calls go
    through :func:`zonotope.image.correct_image`, which corrects each distinct colour (responses
    rounded to ``quantum``) once and carries the result to its pixels with the estimator's
    regression. A colour whose estimate fails (e.g. the degenerate metamer mismatch volume of a
    response outside the object-colour solid) gets the root-polynomial regression's estimate
    instead; ``fallbacks`` counts them.

    Exposure: the estimators other than regressions are not exposure-invariant; they need the
    response of a perfect white reflector, ``white_level`` (after white balance; 1 when the white
    just saturates). Responses are divided by it, negative values (noise, demosaicing overshoot)
    set to 0, and a response brighter than the white in some channel (a highlight, or the
    pipeline's saturation white ``(1, 1, 1)`` when ``white_level < 1``) is corrected at the
    exposure that brings it to the white's level and scaled back (exposure-linear above the
    white). The result is multiplied by ``white_level``, so ``f(c)`` is the XYZ at the image's
    exposure, on the same footing as the DNG ColorMatrix path.

    Attributes
    ----------
    corrector : zonotope.correct.Corrector
    quantum : float
        Deduplication step in response units (white = 1); 0 for exact deduplication only.
    batch_size : int
        Distinct colours per call of the estimator.
    progress : callable, optional
        ``progress(done, total)`` in distinct colours while correcting an image (not the white).
    white_level : float
        White-balanced response of a perfect white reflector in the image (default 1).
    fallbacks : int
        Colours that fell back to the regression so far.
    neutral : ndarray of shape (3,), optional
        The camera's un-balanced response to the perfect white under the fit's illuminant, max 1
        (compare with a file's AsShotNeutral: :meth:`neutral_mismatch`).
    """

    corrector: Corrector
    quantum: float = 2e-3
    batch_size: int = 64
    progress: Callable[[int, int], None] | None = None
    white_level: float = 1.0
    fallbacks: int = 0
    neutral: np.ndarray | None = field(default=None, repr=False)

    def __post_init__(self) -> None:
        import dataclasses

        from zonotope.correct import fit_correction

        if not (np.isfinite(self.white_level) and self.white_level > 0):
            raise ValueError(f"white_level={self.white_level}: must be a positive number (the response of "
                             "a perfect white reflector after white balance, 1 when it just saturates).")
        c = self.corrector
        self._regression = c.params.get("regression") or fit_correction(c.problem, method="Finlayson 2015")
        self._safe = dataclasses.replace(c, predict=self._predict)

    @property
    def method(self) -> str:
        """The estimator's name (key of ``zonotope.correct.CORRECTION_METHODS``)."""
        return self.corrector.method

    def neutral_mismatch(self, as_shot_neutral) -> float:
        """Largest relative difference between a file's AsShotNeutral and :attr:`neutral`.

        Both are normalised to the green channel. A large value (say > 0.1) means the file was
        white-balanced for another light than the fit's illuminant, or that the sensitivities do
        not belong to this camera. NaN when :attr:`neutral` is unknown.
        """
        if self.neutral is None:
            return float("nan")
        a = np.asarray(as_shot_neutral, dtype=np.float64).reshape(-1)
        n = np.asarray(self.neutral, dtype=np.float64)
        ratio = (a / a[1]) / (n / n[1])
        return float(np.max(np.abs(ratio - 1.0)))

    def _predict(self, c: np.ndarray) -> np.ndarray:
        predict = self.corrector.predict
        try:
            return predict(c)
        except _ESTIMATOR_ERRORS:
            pass
        out = np.empty((c.shape[0], self.corrector.problem.m))
        for i in range(c.shape[0]):
            try:
                out[i] = predict(c[i:i + 1])[0]
            except _ESTIMATOR_ERRORS:
                out[i] = self._regression(c[i:i + 1])[0]
                self.fallbacks += 1
        return out

    def __call__(self, responses) -> np.ndarray:
        from zonotope.image import correct_image

        c = np.maximum(np.asarray(responses, dtype=np.float64), 0.0) / self.white_level
        over = np.maximum(np.max(c, axis=-1, keepdims=True), 1.0)  # brighter than the white: scale down
        progress = self.progress if c.ndim > 1 and c.size > c.shape[-1] else None
        XYZ = correct_image(c / over, self._safe, quantum=self.quantum, batch_size=self.batch_size,
                            progress=progress)
        return XYZ * (over * self.white_level)


def metamer_correction(camera, *, method: str = "Prior", illuminant="D65", training="rawtoaces 190",
                       target="CIE 1931 2°", shape=None, white_level: float = 1.0, quantum: float = 2e-3,
                       batch_size: int = 64, progress: Callable[[int, int], None] | None = None,
                       **options) -> MetamerCorrection:
    """Fit a metamer-based colour correction (``zonotope.correct``) for a camera with known SSF.

    Replaces the DNG ColorMatrix by an estimator that knows the camera's spectral sensitivities
    (use it with ``default_pipeline(correction=metamer_correction(...))``). The file's white
    balance (AsShotNeutral) is kept: the estimators take white-balanced responses in which a
    perfect white reflector under ``illuminant`` gives 1 in every channel.

    Parameters
    ----------
    camera
        Built-in camera name (``zonotope.list_builtin()["cameras"]``), a camera file readable by
        ``zonotope.read_camera`` (rawtoaces/camspec JSON, CSV) or a colour MSDS.
    method
        Estimator (key or alias of ``zonotope.correct.CORRECTION_METHODS``; default ``"Prior"``).
    illuminant
        Scene illuminant of the fit (name or SD); should match the light the file's white balance
        was set for.
    training
        Training reflectances: built-in set name, a file readable by ``zonotope.read_reflectances``
        or an MSDS.
    target
        Observer of the XYZ output; CIE 1931 2° (default) is the one of sRGB and DNG.
    shape
        Wavelength grid; default 400–700 nm every 10 nm (:data:`METAMER_RANGE`), narrowed to the
        range all curves cover.
    white_level, quantum, batch_size, progress
        See :class:`MetamerCorrection`.
    **options
        Passed to the estimator's fitting function (e.g. ``noise=0.01``).

    Returns
    -------
    MetamerCorrection

    Raises
    ------
    ValueError
        Unknown method, camera, illuminant or training set (``zonotope.SpectralDataError`` is a
        ValueError), an unreadable file, or a camera without exactly 3 channels.
    FileNotFoundError
        A camera or training file that does not exist.
    """
    import colour

    import zonotope
    from zonotope.correct import fit_correction

    cam = _spectral(camera, zonotope.camera, zonotope.read_camera, "camera")
    train = _spectral(training, zonotope.reflectances, zonotope.read_reflectances, "training")
    if shape is None:
        lo, hi, step = METAMER_RANGE
        curves = [cam, zonotope.observer(target), zonotope.illuminant(illuminant)]
        if isinstance(train, colour.MultiSpectralDistributions):
            curves.append(train)
        common = zonotope.common_shape(*curves, interval=step)
        shape = np.arange(max(common.start, lo), min(common.end, hi) + step / 2, step)
    corrector = fit_correction(cam, method=method, target=target, illuminant=illuminant, shape=shape,
                               training=train, **options)
    if corrector.problem.k != 3:
        raise ValueError(f"camera {getattr(cam, 'name', camera)!r} has {corrector.problem.k} channels; "
                         "a Bayer RAW has 3.")
    white = zonotope.generators(cam, illuminant, corrector.problem.wavelengths, normalise=None).values.sum(0)
    return MetamerCorrection(corrector, quantum=quantum, batch_size=batch_size, progress=progress,
                             white_level=white_level, neutral=white / white.max())


def default_pipeline(*, demosaic: str = "Malvar 2004", correction: str | Callable = "dng",
                     tonemap: str | None = "Reinhard 2002", tonemap_options: dict | None = None,
                     encode: bool = True) -> Pipeline:
    """The standard development of a RAW file.

    ``linearise → white_balance → demosaic → camera_to_XYZ → XYZ_to_linear_sRGB → tonemap →
    encode_sRGB``.

    Parameters
    ----------
    demosaic
        Key of :data:`isp.DEMOSAIC_METHODS`.
    correction
        ``"dng"`` (ColorMatrix/ForwardMatrix of the file, CCT-interpolated) or a callable
        ``(N, 3) → (N, 3)`` taking white-balanced camera RGB to XYZ (see :func:`correction_stage`),
        e.g. :func:`metamer_correction` for a camera whose spectral sensitivities are known.
    tonemap
        Key of :data:`isp.TONEMAP_METHODS`, or None for no tone mapping.
    tonemap_options
        Keyword options of the operator.
    encode
        End with the sRGB transfer function.

    Returns
    -------
    Pipeline
    """
    if isinstance(correction, str):
        if correction.lower() != "dng":
            raise ValueError(f"correction={correction!r}: use 'dng' or a callable responses → XYZ "
                             "(for a camera with known sensitivities: isp.metamer_correction(camera)).")
        colour_stage = Stage("camera_to_XYZ", _camera_to_XYZ)
    elif callable(correction):
        colour_stage = correction_stage(correction)
    else:
        raise ValueError(f"correction must be 'dng' or a callable; got {type(correction).__name__}.")
    stages = [
        Stage("linearise", _linearise),
        Stage("white_balance", _white_balance),
        _demosaic_stage(demosaic),
        colour_stage,
        Stage("XYZ_to_linear_sRGB", lambda x, raw: st.XYZ_to_linear_sRGB(x)),
    ]
    if tonemap is not None:
        st._resolve(tonemap, st.TONEMAP_METHODS, "tonemap")
        opts = dict(tonemap_options or {})
        stages.append(Stage("tonemap", lambda x, raw: st.tonemap(x, method=tonemap, **opts)))
    if encode:
        stages.append(Stage("encode_sRGB", lambda x, raw: st.encode_sRGB(x)))
    return Pipeline(stages)


def develop(source, *, pipeline: Pipeline | None = None, stop_after: str | None = None,
            keep: bool = True, on_stage: Callable[[int, str], None] | None = None,
            **options) -> Development:
    """Read (if needed) and develop a RAW image.

    Parameters
    ----------
    source
        A :class:`~isp.raw.RawImage` or a path to a RAW/DNG file.
    pipeline
        The pipeline to run; default :func:`default_pipeline` built with ``**options``.
    stop_after, keep, on_stage
        See :meth:`Pipeline.__call__`.
    **options
        Keywords of :func:`default_pipeline` (only when ``pipeline`` is None).

    Returns
    -------
    Development

    Examples
    --------
    >>> dev = develop("photo.dng", demosaic="Menon 2007")  # doctest: +SKIP
    >>> dev.intermediates["demosaic"].shape  # doctest: +SKIP
    """
    from .raw import read_raw

    if pipeline is not None and options:
        raise PipelineError(f"options {sorted(options)} apply to the default pipeline only; build your "
                            "pipeline with them instead.")
    raw = source if isinstance(source, RawImage) else read_raw(source)
    p = pipeline if pipeline is not None else default_pipeline(**options)
    return p(raw, stop_after=stop_after, keep=keep, on_stage=on_stage)
