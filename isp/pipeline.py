"""A pipeline: an ordered list of named pure stages (optax ``chain``-like) that keeps every intermediate.

A :class:`Stage` is a name and a function ``fn(x, raw) -> x`` where ``x`` is the current array and
``raw`` the :class:`~isp.raw.RawImage` whose metadata the stage may read. A stage that says how far
its output rows reach into its input (``reach``: 0 for a per-pixel stage, the kernel's reach for a
demosaicing) may be run on strips of rows: without ``keep``, runs of such stages go strip by strip
and keep float32 images between them, so a 60 MP development needs ≈ 2 GB instead of ≈ 10 GB.
A :class:`Pipeline` is an immutable tuple of stages; ``replace``, ``remove``, ``insert``,
``reorder`` and ``until`` return new pipelines. Running it returns a :class:`Development` with the
output and every intermediate.

>>> from isp import default_pipeline
>>> p = default_pipeline(demosaic="bilinear")
>>> p.names  # doctest: +NORMALIZE_WHITESPACE
('linearise', 'white_balance', 'demosaic', 'camera_to_XYZ', 'XYZ_to_linear_sRGB', 'tonemap', 'encode_sRGB',
 'orient')
>>> p.until("XYZ_to_linear_sRGB").names[-1]
'XYZ_to_linear_sRGB'
"""

from __future__ import annotations

import weakref
from collections.abc import Callable, Iterable
from dataclasses import dataclass, field
from typing import TYPE_CHECKING

import numpy as np

from . import stages as st
from ._errors import PipelineError
from .raw import RawImage

if TYPE_CHECKING:
    from zonotope.utilities import ProgressCallback

__all__ = ["Development", "Pipeline", "Stage", "chain", "correction_stage", "default_pipeline", "develop"]

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
    reach : int or None
        How many rows above and below an output row its value depends on (0: per pixel; even, so
        that a strip of a mosaic keeps its CFA phase), with the output as tall and wide as the input
        and row ``r`` of a strip being row ``r`` of the image. None (the default, safe for any
        function): the stage needs the whole image (e.g. a global tone curve, a rotation).
    """

    name: str
    fn: StageFn = field(repr=False)
    reach: int | None = None

    def __post_init__(self) -> None:
        if self.reach is not None and (
            isinstance(self.reach, bool)
            or not isinstance(self.reach, int)
            or self.reach < 0
            or self.reach % 2
        ):
            raise PipelineError(f"stage {self.name!r}: reach={self.reach!r} must be None or an even int ≥ 0.")

    def __call__(self, x: np.ndarray, raw: RawImage) -> np.ndarray:
        """Apply the stage to the array ``x`` of the image ``raw``."""
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
        return Pipeline((*self._stages[:i], new, *self._stages[i + 1 :]))

    def remove(self, name: str) -> Pipeline:
        """Drop stage ``name``."""
        i = self._index(name)
        return Pipeline(self._stages[:i] + self._stages[i + 1 :])

    def insert(self, stage: Stage, *, before: str | None = None, after: str | None = None) -> Pipeline:
        """Insert ``stage`` before or after a named stage (at the end when neither is given)."""
        if before is not None and after is not None:
            raise PipelineError("give before= or after=, not both.")
        i = (
            self._index(before)
            if before is not None
            else self._index(after) + 1
            if after is not None
            else len(self._stages)
        )
        return Pipeline((*self._stages[:i], stage, *self._stages[i:]))

    def reorder(self, names: Iterable[str]) -> Pipeline:
        """The same stages in the order ``names`` (every name exactly once)."""
        names = list(names)
        if sorted(names) != sorted(self.names):
            raise PipelineError(f"reorder needs each of {list(self.names)} exactly once; got {names}.")
        return Pipeline(self[n] for n in names)

    def until(self, name: str) -> Pipeline:
        """The stages up to and including ``name`` (stop after it)."""
        return Pipeline(self._stages[: self._index(name) + 1])

    # -- running -------------------------------------------------------------------------------
    def __call__(
        self,
        raw: RawImage,
        *,
        stop_after: str | None = None,
        keep: bool = True,
        progress: ProgressCallback | None = None,
    ) -> Development:
        """Develop ``raw``.

        Parameters
        ----------
        raw
            The RAW image (its ``mosaic`` is the first input).
        stop_after
            Name of the last stage to run.
        keep
            Keep every intermediate (else only the input and the output). Without it, each run of
            stages with a ``reach`` goes strip by strip (:data:`isp._tol.STRIP_PIXELS` per strip)
            and the images between runs are float32 (≈ 6e-8 relative, far below a 16-bit output's
            step): the memory of a development is then a few float32 images, not every stage's
            float64 temporaries at full size.
        progress
            Called as ``progress("develop", i, n)`` before stage ``i`` (0-based; its name is
            ``stages[i].name``) of the ``n`` stages run, and ``progress("develop", n, n)`` at the
            end (:class:`zonotope.ProgressCallback`).

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
        n = len(run.stages)
        i = 0
        while i < n:
            if progress is not None:
                progress("develop", i, n)
            j = i + 1
            if not keep and run.stages[i].reach is not None and x.ndim >= 2:
                while j < n and run.stages[j].reach is not None:
                    j += 1
                y = _stripwise(run.stages[i:j], x, raw, progress=progress, first=i, total=n)
            else:
                y = _checked(run.stages[i], run.stages[i](x, raw))
            if keep:
                inter[run.stages[i].name] = y
            x = y
            i = j
        if not keep and run.stages:
            inter[run.stages[-1].name] = x
        if progress is not None:
            progress("develop", n, n)
        return Development(image=x, intermediates=inter, raw=raw)


def _checked(stage: Stage, y) -> np.ndarray:
    if not isinstance(y, np.ndarray):
        raise PipelineError(f"stage {stage.name!r} returned {type(y).__name__}, not an ndarray.")
    if y.dtype.kind == "f" and not np.all(np.isfinite(y)):
        raise PipelineError(f"stage {stage.name!r} produced NaN or inf; check its input and options.")
    return y


def _stripwise(stages, x: np.ndarray, raw: RawImage, *, progress, first: int, total: int) -> np.ndarray:
    """Run the local ``stages`` on strips of rows of ``x`` (each with the rows their reaches need
    above and below, cut off again), into one float32 image: the same values as the whole image gives
    (the stages are row-local), with temporaries of one strip only."""
    from ._tol import STRIP_PIXELS

    H = x.shape[0]
    width = int(np.prod(x.shape[1:])) or 1
    rows = max(2, (STRIP_PIXELS // width) // 2 * 2)  # even: a strip of a mosaic keeps its CFA phase
    halo = sum(s.reach for s in stages)
    out: np.ndarray | None = None
    for r0 in range(0, H, rows):
        r1 = min(H, r0 + rows)
        a0, a1 = max(0, r0 - halo), min(H, r1 + halo)
        y = x[a0:a1]
        for k, s in enumerate(stages):
            if progress is not None and r0 == 0 and k:
                progress("develop", first + k, total)
            y = _checked(s, s(y, raw))
            if y.shape[0] != a1 - a0:
                raise PipelineError(
                    f"stage {s.name!r} has reach={s.reach} but changed the number of rows "
                    f"({a1 - a0} → {y.shape[0]}); give it reach=None."
                )
        y = y[r0 - a0 : r0 - a0 + (r1 - r0)]
        if out is None:
            kind = np.float32 if y.dtype.kind == "f" else y.dtype
            out = np.empty((H, *y.shape[1:]), dtype=kind)
        out[r0:r1] = y
    assert out is not None  # H ≥ 1: a RawImage's mosaic is never empty
    return out


def chain(*stages: Stage | tuple[str, StageFn]) -> Pipeline:
    """Build a :class:`Pipeline` from stages given in order."""
    return Pipeline(stages)


# ---------------------------------------------------------------------------------------------
# Standard stages bound to RawImage metadata
# ---------------------------------------------------------------------------------------------


def _linearise(x, raw: RawImage):
    table = None if raw.table_applied else raw.linearisation_table
    return st.linearise(x, black_level=raw.black_level, white_level=raw.white_level, table=table)


class _Neutral:
    """The camera neutral of a white-balance choice, computed once per RawImage (two stages use it)."""

    def __init__(self, choice) -> None:
        from .whitebalance import _key

        self.choice = choice
        self.as_shot = isinstance(choice, str) and _key(choice) in ("asshot", "camera", "")
        self._cache: tuple[weakref.ref, np.ndarray] | None = None

    def __call__(self, raw: RawImage) -> np.ndarray:
        from .whitebalance import white_balance_neutral

        if self.as_shot:
            return raw.as_shot_neutral
        if self._cache is None or self._cache[0]() is not raw:
            self._cache = (weakref.ref(raw), white_balance_neutral(raw, self.choice))
        return self._cache[1]


def _white_balance_stage(neutral: _Neutral) -> Stage:
    def fn(x, raw: RawImage):
        cfa = raw.cfa if np.ndim(x) == 2 else None
        return st.white_balance(x, neutral=neutral(raw), cfa=cfa)

    return Stage("white_balance", fn, reach=0)


def _demosaic_stage(method: str) -> Stage:
    name = st._resolve(method, st.DEMOSAIC_METHODS, "demosaic")  # fail early on a bad name
    reach = int(st.DEMOSAIC_METHODS.properties(name)["pad"])
    return Stage(
        "demosaic", lambda x, raw: st.demosaic(x, cfa=raw.cfa, method=method), reach=reach + reach % 2
    )


def _camera_to_XYZ_stage(neutral: _Neutral) -> Stage:
    def fn(x, raw: RawImage):
        return st.camera_to_XYZ(x, matrix=st.matrix_XYZ_from_balanced(raw.profile, neutral(raw)))

    return Stage("camera_to_XYZ", fn, reach=0)


def correction_stage(
    XYZ_from_responses: Callable[[np.ndarray], np.ndarray],
    *,
    balanced: bool = True,
    name: str = "camera_to_XYZ",
    reach: int | str | None = "estimator",
) -> Stage:
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
    reach
        0: per pixel, run strip by strip with the stages around it (the memory of one strip);
        None: the estimator sees the whole image at once (for an estimator whose result depends on
        the other pixels); ``"estimator"`` (default): the estimator's own ``reach`` attribute, None
        when it has none. :class:`isp.MetamerCorrection` says 0: ``zonotope.correct_image`` groups
        colours within chunks of pixels anyway, so a strip changes which pixels share a group, not
        the cost.

    Returns
    -------
    Stage
    """
    if isinstance(reach, str):
        if reach != "estimator":
            raise PipelineError(f"reach={reach!r}: give 0, None or 'estimator'.")
        reach = getattr(XYZ_from_responses, "reach", None)

    def fn(x, raw: RawImage):
        white = None if balanced else raw.as_shot_neutral
        return st.apply_correction(x, XYZ_from_responses=XYZ_from_responses, white_response=white)

    return Stage(name, fn, reach=reach)


def default_pipeline(
    *,
    demosaic: str = st.default_method(st.DEMOSAIC_METHODS),
    correction: str | Callable = "dng",
    tonemap: str | None = st.default_method(st.TONEMAP_METHODS),
    tonemap_options: dict | None = None,
    encode: bool = True,
    white_balance="as-shot",
    orient: bool = True,
) -> Pipeline:
    """The standard development of a RAW file.

    ``linearise → white_balance → demosaic → camera_to_XYZ → XYZ_to_linear_sRGB → tonemap →
    encode_sRGB → orient``.

    Parameters
    ----------
    demosaic
        Key of :data:`isp.DEMOSAIC_METHODS` (default: its entry registered with ``default=True``).
    correction
        ``"dng"`` (ColorMatrix/ForwardMatrix of the file, CCT-interpolated) or a callable
        ``(N, 3) → (N, 3)`` taking white-balanced camera RGB to XYZ (see :func:`correction_stage`),
        e.g. :func:`isp.metamer_correction` for a camera whose spectral sensitivities are known.
    tonemap
        Key of :data:`isp.TONEMAP_METHODS` (default: its ``default=True`` entry), or None for no tone
        mapping.
    tonemap_options
        Keyword options of the operator.
    encode
        End with the sRGB transfer function.
    white_balance
        ``"as-shot"`` (the file's), ``"daylight"``, ``"<T>K"``, a CIE illuminant name or
        ``"spot:x0,y0,x1,y1"`` (a grey patch of the developed image), or a camera neutral: see
        :mod:`isp.whitebalance`. The camera → XYZ matrix of the ``"dng"`` correction is the one for
        this white, as the DNG spec makes it.
    orient
        End with an ``orient`` stage that rotates/mirrors the image as the file's Orientation tag
        says (as rawpy does).

    Returns
    -------
    Pipeline
    """
    neutral = _Neutral(white_balance)
    if not neutral.as_shot:  # fail early on an unknown name, a temperature out of range, a bad neutral
        from .whitebalance import _spot, white_balance_neutral, white_balance_xy

        if not isinstance(white_balance, str):
            white_balance_neutral(None, white_balance)  # type: ignore[arg-type]
        elif _spot(white_balance) is None:
            white_balance_xy(white_balance)
    if isinstance(correction, str):
        if correction.lower() != "dng":
            raise PipelineError(
                f"correction={correction!r}: use 'dng' or a callable responses → XYZ "
                "(for a camera with known sensitivities: isp.metamer_correction(camera))."
            )
        colour_stage = _camera_to_XYZ_stage(neutral)
    elif callable(correction):
        colour_stage = correction_stage(correction)
    else:
        raise PipelineError(f"correction must be 'dng' or a callable; got {type(correction).__name__}.")
    stages = [
        Stage("linearise", _linearise, reach=0),
        _white_balance_stage(neutral),
        _demosaic_stage(demosaic),
        colour_stage,
        Stage("XYZ_to_linear_sRGB", lambda x, raw: st.XYZ_to_linear_sRGB(x), reach=0),
    ]
    if tonemap is not None:
        name = st._resolve(tonemap, st.TONEMAP_METHODS, "tonemap")
        opts = dict(tonemap_options or {})
        reach = st.TONEMAP_METHODS.properties(name).get("reach")
        stages.append(Stage("tonemap", lambda x, raw: st.tonemap(x, method=tonemap, **opts), reach=reach))
    if encode:
        stages.append(Stage("encode_sRGB", lambda x, raw: st.encode_sRGB(x), reach=0))
    if orient:
        stages.append(Stage("orient", lambda x, raw: np.ascontiguousarray(st.orient(x, raw.orientation))))
    return Pipeline(stages)


def develop(
    source,
    *,
    pipeline: Pipeline | None = None,
    stop_after: str | None = None,
    keep: bool = True,
    progress: ProgressCallback | None = None,
    **options,
) -> Development:
    """Read (if needed) and develop a RAW image.

    Parameters
    ----------
    source
        A :class:`~isp.raw.RawImage` or a path to a RAW/DNG file.
    pipeline
        The pipeline to run; default :func:`default_pipeline` built with ``**options``.
    stop_after, keep, progress
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
        raise PipelineError(
            f"options {sorted(options)} apply to the default pipeline only; build your "
            "pipeline with them instead."
        )
    raw = source if isinstance(source, RawImage) else read_raw(source)
    p = pipeline if pipeline is not None else default_pipeline(**options)
    return p(raw, stop_after=stop_after, keep=keep, progress=progress)
