"""The bridge from :mod:`isp` to ``zonotope.correct``: metamer-based colour correction of RAW images.

When the spectral sensitivities of the camera are known, :func:`metamer_correction` fits a
``zonotope.correct`` estimator and returns a :class:`MetamerCorrection`, a callable white-balanced
camera RGB ``(N, 3)`` → XYZ ``(N, 3)`` that replaces the DNG ColorMatrix in
``isp.default_pipeline(correction=...)``. ``zonotope`` is imported lazily, inside the functions,
so ``import isp`` stays light. (Split out of :mod:`isp.pipeline`, which knows nothing of spectra.)

>>> import isp
>>> isp.metamer.METAMER_RANGE
(400.0, 700.0, 10.0)
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any, ClassVar

import numpy as np

from ._errors import PipelineError

if TYPE_CHECKING:
    from zonotope.correct import Corrector
    from zonotope.utilities import ProgressCallback

__all__ = [
    "METAMER_RANGE",
    "MetamerConfig",
    "MetamerCorrection",
    "maker_mismatch",
    "metamer_correction",
    "metamer_noise",
    "photograph_method",
    "sensitivities_maker",
]


#: Default wavelength range (nm) and step of the metamer correction fit: 31 samples keep fitting
#: and the per-colour optimisations fast; the range is narrowed to the curves' common range.
METAMER_RANGE = (400.0, 700.0, 10.0)


def _check_cie1931(target, where: str) -> None:
    """Refuse a target observer other than CIE 1931 2°: isp's XYZ (DNG matrices, sRGB output) is CIE
    1931 XYZ, and an estimator fitted to another observer's XYZ (``zonotope.correct`` defaults to CIE
    2015 2°) would be mixed in silently (≈ 0.25 ΔE00 on the ColorChecker)."""
    import zonotope

    cie1931 = zonotope.observer("CIE 1931 2°").name
    try:
        name = zonotope.observer(target).name if isinstance(target, str) else getattr(target, "name", None)
    except zonotope.ZonotopeError:
        name = None
    if name != cie1931:
        raise PipelineError(
            f"{where}: target {target!r} is not CIE 1931 2°; isp works in CIE 1931 XYZ (DNG, sRGB), and "
            "another observer's XYZ would be mixed in silently (≈ 0.25 ΔE00). Fit the estimator with "
            "target='CIE 1931 2°' (isp.metamer_correction does)."
        )


def photograph_method() -> str:
    """The estimator ``zonotope`` uses for photographs: the default ``method`` of
    :func:`zonotope.correct.correct_image`.

    Read from that function's signature, so that ``isp`` follows ``zonotope``'s choice (measured
    there for accuracy and cost at photo scale) instead of naming an estimator of its own.
    """
    import inspect

    from zonotope.correct import correct_image

    return inspect.signature(correct_image).parameters["method"].default


#: Errors of one colour's metamer estimate that fall back to the regression (e.g. Qhull on the
#: degenerate mismatch volume of a response on or outside the solid's boundary).
_ESTIMATOR_ERRORS = (ArithmeticError, RuntimeError, ValueError, np.linalg.LinAlgError)


@dataclass(eq=False)
class MetamerCorrection:
    """White-balanced camera RGB ``(N, 3)`` → XYZ ``(N, 3)`` with a fitted ``zonotope.correct`` estimator.

    Built by :func:`metamer_correction`; pass it as ``default_pipeline(correction=...)``. Calls go
    through :func:`zonotope.correct.image.correct_image`, which corrects each distinct colour (responses
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
        ``progress("distinct colours", done, total)`` while correcting an image (not the white;
        :class:`zonotope.ProgressCallback`), counted over every call (a pipeline calls once per
        strip).
    white_level : float
        White-balanced response of a perfect white reflector in the image (default 1).
    fallbacks : int
        Colours that fell back to the regression so far.
    reach : int
        0: a pixel's estimate depends on that pixel only, so :func:`isp.correction_stage` runs it
        strip by strip (a 60 MP image in the memory of one strip). ``correct_image`` groups colours
        within chunks of 2²⁰ pixels anyway, the size of a strip (:data:`isp._tol.STRIP_PIXELS`),
        so strips change which pixels share a group, not the number of solves.
    neutral : ndarray of shape (3,), optional
        The camera's un-balanced response to the perfect white under the fit's illuminant, max 1
        (compare with a file's AsShotNeutral: :meth:`neutral_mismatch`).
    noise : zonotope.correct.NoiseModel, optional
        The noise of the responses (white = 1) the estimator was fitted for; None: noise-free.
        Its ``source`` says where it came from.
    """

    corrector: Corrector
    quantum: float = 2e-3
    batch_size: int = 64
    progress: ProgressCallback | None = None
    white_level: float = 1.0
    fallbacks: int = 0
    neutral: np.ndarray | None = field(default=None, repr=False)
    noise: Any = None
    reach: ClassVar[int] = 0

    def __post_init__(self) -> None:
        import dataclasses

        from zonotope.correct import fit_correction

        if not (np.isfinite(self.white_level) and self.white_level > 0):
            raise PipelineError(
                f"white_level={self.white_level}: must be a positive number (the response of "
                "a perfect white reflector after white balance, 1 when it just saturates)."
            )
        c = self.corrector
        _check_cie1931(c.problem.target, "MetamerCorrection")
        self._regression = c.params.get("regression") or fit_correction(c.problem, method="Finlayson 2015")
        self._safe = dataclasses.replace(c, predict=self._predict)
        self._counted = (0, 0)  # (done, total) of the calls before this one, for ``progress``

    @property
    def method(self) -> str:
        """The estimator's name (key of ``zonotope.correct.CORRECTION_METHODS``)."""
        return self.corrector.method

    def describe_noise(self) -> str:
        """One line: the noise the estimator was fitted for, and where it came from."""
        return "none (noise-free fit)" if self.noise is None else self.noise.describe()

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
                out[i] = predict(c[i : i + 1])[0]
            except _ESTIMATOR_ERRORS:
                out[i] = self._regression(c[i : i + 1])[0]
                self.fallbacks += 1
        return out

    def __call__(self, responses) -> np.ndarray:
        """White-balanced camera RGB ``(N, 3)`` → XYZ ``(N, 3)``."""
        from zonotope.correct.image import correct_image

        c = np.maximum(np.asarray(responses, dtype=np.float64), 0.0) / self.white_level
        over = np.maximum(np.max(c, axis=-1, keepdims=True), 1.0)  # brighter than the white: scale down
        progress = None
        if self.progress is not None and c.ndim > 1 and c.size > c.shape[-1]:
            before, last = self._counted, [0, 0]

            def progress(stage: str, done: int, total: int) -> None:  # counts carried across calls
                last[:] = done, total
                self.progress(stage, before[0] + done, before[1] + total)

        c /= over
        XYZ = correct_image(
            c, self._safe, quantum=self.quantum, batch_size=self.batch_size, progress=progress
        )
        if progress is not None:
            self._counted = (before[0] + last[0], before[1] + last[1])
        XYZ *= over * self.white_level
        return XYZ


@dataclass(frozen=True)
class MetamerConfig:
    """The options of :func:`metamer_correction`, checked when the object is made.

    Attributes
    ----------
    method : str, optional
        Estimator (key or alias of ``zonotope.correct.CORRECTION_METHODS``); None (default):
        :func:`photograph_method`, the one ``zonotope`` uses for photographs.
    illuminant : str or colour.SpectralDistribution
        Scene illuminant of the fit (name or SD); should match the light the file's white balance
        was set for.
    reference : str or colour.SpectralDistribution, optional
        The light whose colours the output holds (e.g. ``"D65"``): the estimator is fitted scene
        light → colours as under ``reference`` (``zonotope.correct.correction_problem``), and a
        neutral under the scene light comes out as that light's white (the pipeline adapts it to
        sRGB's D65 as it does any white). None (default): the colours as under the scene light.
    training : str, path or colour.MultiSpectralDistributions
        Training reflectances: built-in set name, a file readable by ``zonotope.load_reflectances``
        or an MSDS.
    target : str
        Observer of the XYZ output: CIE 1931 2° (the default, and the only one accepted: it is the
        observer of sRGB and DNG; any other would be mixed into isp's XYZ silently).
    shape : colour.SpectralShape or array_like, optional
        Wavelength grid; default 400–700 nm every 10 nm (:data:`METAMER_RANGE`), narrowed to the
        range all curves cover.
    white_level : float
        White-balanced response of a perfect white reflector in the image, > 0 (default 1).
    quantum : float
        Deduplication step in response units (white = 1), ≥ 0; 0 for exact deduplication only.
    batch_size : int
        Distinct colours per call of the estimator, ≥ 1.
    noise : zonotope.correct.NoiseModel, float or None
        Noise of the responses (white = 1, after the division by ``white_level``) the estimator is
        fitted for: a model (e.g. :func:`metamer_noise` of the RAW file), a σ, or None / 0
        (noise-free, the default). Turned into estimator options by
        :func:`zonotope.correct.noise_options` only.
    estimator_options : mapping of str to object
        Keywords passed on to the estimator's fitting function (e.g. ``{"degree": 3}``); kept
        apart so that a misspelt field of this config is refused instead of passed on.

    Raises
    ------
    PipelineError
        A field out of range (named, with what is allowed).
    """

    method: str | None = None
    illuminant: Any = "D65"
    reference: Any = None
    training: Any = "rawtoaces 190"
    target: Any = "CIE 1931 2°"
    shape: Any = None
    white_level: float = 1.0
    quantum: float = 2e-3
    batch_size: int = 64
    noise: Any = None
    estimator_options: Mapping[str, Any] = field(default_factory=dict)

    def __post_init__(self) -> None:
        from ._config import check_int, check_number, check_options

        owner = "MetamerConfig"
        if self.method is not None and not (isinstance(self.method, str) and self.method.strip()):
            raise PipelineError(f"{owner}.method={self.method!r}: give an estimator name, e.g. 'Prior'.")
        check_number(
            owner,
            "white_level",
            self.white_level,
            lambda v: np.isfinite(v) and v > 0,
            "must be a positive number (the response of a perfect white reflector after white "
            "balance, 1 when it just saturates)",
        )
        check_number(
            owner, "quantum", self.quantum, lambda v: np.isfinite(v) and v >= 0, "give a finite number ≥ 0"
        )
        check_int(owner, "batch_size", self.batch_size, minimum=1)
        _check_cie1931(self.target, f"{owner}.target")
        opts = check_options(owner, "estimator_options", self.estimator_options)
        fields = {"method", "target", "illuminant", "reference", "shape", "training", "noise", "delta"}
        clash = sorted(set(opts) & fields)
        if clash:
            raise PipelineError(
                f"{owner}.estimator_options: {', '.join(clash)} are fields of {owner} itself; set them "
                f"there, not in estimator_options (the noise, as a σ or a model: {owner}.noise)."
            )
        object.__setattr__(self, "estimator_options", opts)
        if self.noise is not None:
            from zonotope.correct import NoiseModelError, noise_model

            try:
                object.__setattr__(self, "noise", noise_model(self.noise, 3))
            except NoiseModelError as exc:
                raise PipelineError(f"{owner}.noise: {exc}") from None


def metamer_correction(
    camera,
    config: MetamerConfig | None = None,
    *,
    progress: ProgressCallback | None = None,
    **options,
) -> MetamerCorrection:
    """Fit a metamer-based colour correction (``zonotope.correct``) for a camera with known SSF.

    Replaces the DNG ColorMatrix by an estimator that knows the camera's spectral sensitivities
    (use it with ``default_pipeline(correction=metamer_correction(...))``). The file's white
    balance (AsShotNeutral) is kept: the estimators take white-balanced responses in which a
    perfect white reflector under ``illuminant`` gives 1 in every channel.

    Parameters
    ----------
    camera
        Built-in camera name (``zonotope.list_builtin()["cameras"]``), a camera file readable by
        ``zonotope.load_camera`` (rawtoaces/camspec JSON, CSV) or a colour MSDS.
    config
        The options (:class:`MetamerConfig`: method, illuminant, reference, training, target, shape,
        white_level, quantum, batch_size, noise, estimator_options); default all defaults.
    progress
        See :class:`MetamerCorrection`.
    **options
        Fields of :class:`MetamerConfig` as keywords (override those of ``config``), e.g.
        ``method="MAP", quantum=0, noise=0.01``; the estimator's own options go in
        ``estimator_options`` (e.g. ``estimator_options={"degree": 3}``).

    Returns
    -------
    MetamerCorrection

    Raises
    ------
    PipelineError
        A bad option (named), or a camera without exactly 3 channels.
    ValueError
        Unknown method, camera, illuminant or training set (``zonotope.SpectralDataError`` is a
        ValueError), an unreadable file.
    FileNotFoundError
        A camera or training file that does not exist.
    """
    import colour

    import zonotope
    from zonotope.correct import fit_correction, noise_options

    from ._config import with_options

    cfg = with_options(MetamerConfig, config, options, where="metamer_correction")
    method = cfg.method or photograph_method()
    target, illuminant, shape = cfg.target, cfg.illuminant, cfg.shape
    cam = zonotope.load_camera(camera)
    train = zonotope.load_reflectances(cfg.training)
    if shape is None:
        lo, hi, step = METAMER_RANGE
        curves = [cam, zonotope.observer(target), zonotope.illuminant(illuminant)]
        if cfg.reference is not None:
            curves.append(zonotope.illuminant(cfg.reference))
        if isinstance(train, colour.MultiSpectralDistributions):
            curves.append(train)
        common = zonotope.common_shape(*curves, interval=step)
        shape = np.arange(max(common.start, lo), min(common.end, hi) + step / 2, step)
    corrector = fit_correction(
        cam,
        method=method,
        target=target,
        illuminant=illuminant,
        reference=cfg.reference,
        shape=shape,
        training=train,
        **noise_options(method, cfg.noise),
        **cfg.estimator_options,
    )
    if corrector.problem.k != 3:
        raise PipelineError(
            f"camera {getattr(cam, 'name', camera)!r} has {corrector.problem.k} channels; a Bayer RAW has 3."
        )
    white = zonotope.generators(cam, illuminant, corrector.problem.wavelengths, normalise=None).values.sum(0)
    return MetamerCorrection(
        corrector,
        quantum=cfg.quantum,
        batch_size=cfg.batch_size,
        progress=progress,
        white_level=cfg.white_level,
        neutral=white / white.max(),
        noise=cfg.noise,
    )


def metamer_noise(raw, *, white_balance="as-shot", white_level: float = 1.0, noise="auto"):
    """The noise model of the responses a metamer correction receives from ``raw``, and where it came from.

    The metamer stage takes linearised raw values ``x`` (0 at black, 1 at saturation), multiplies
    them by the white-balance gains ``g = max(n) / n`` (``n`` the camera neutral) and divides by
    ``white_level``: a channel's perfect white reads ``white_level / g`` in raw units, and the
    model is carried through exactly that (``zonotope.correct.noise_from_profile(white=...)``).
    With ``noise="auto"`` the file's DNG ``NoiseProfile`` is used when present and plausible;
    otherwise (none, malformed or implausible: reported in the note) the noise is estimated from
    flat regions of the mosaic's colour planes (one site per 2 × 2 cell and channel, before
    demosaicing, whose interpolation would hide part of it; saturated sites left out).

    Parameters
    ----------
    raw : isp.RawImage
    white_balance
        The pipeline's white-balance choice (:func:`isp.default_pipeline`).
    white_level
        Response of a perfect white reflector after white balance (:class:`MetamerConfig`).
    noise
        ``"auto"``; or a :class:`zonotope.correct.NoiseModel`, a σ, one σ per channel or a mapping
        with ``"shot"`` and ``"read"`` (white = 1) given by the user, used as it is; None or 0:
        noise-free.

    Returns
    -------
    model : zonotope.correct.NoiseModel or None
        None: noise-free. ``model.source`` names the origin (``"DNG NoiseProfile"``,
        ``"estimated from image"``, ``"--noise"``, ...).
    note : str
        Why the NoiseProfile or the estimate was not used ("" otherwise).

    Raises
    ------
    zonotope.correct.NoiseModelError
        A given ``noise`` that is negative, NaN or of the wrong channel count.
    """
    from zonotope.correct import NoiseModelError, estimate_noise, noise_from_profile, noise_model

    from ._errors import RawFormatError
    from .dng import noise_profile
    from .pipeline import _Neutral

    if not (isinstance(noise, str) and noise == "auto"):
        return noise_model(noise, 3), ""
    n = np.asarray(_Neutral(white_balance)(raw), dtype=np.float64)
    gains = n.max() / n
    notes = []
    try:
        pairs = noise_profile(getattr(raw, "tags", None) or {}, planes=3)
    except RawFormatError as exc:
        pairs = None
        notes.append(f"NoiseProfile ignored: {exc}")
    else:
        model, note = noise_from_profile(pairs, white=white_level / gains, k=3)
        if model is not None:
            return model, ""
        if pairs is not None:
            notes.append(note)
    if np.ndim(raw.mosaic) != 2:
        return None, "; ".join([*notes, "noise not estimated: the file holds no Bayer mosaic"])
    try:
        model = estimate_noise(_balanced_planes(raw, gains) / white_level)
    except NoiseModelError as exc:
        return None, "; ".join([*notes, f"noise not estimated: {exc}"])
    if model.is_zero:
        return None, "; ".join([*notes, "estimated noise is zero"])
    return model, "; ".join(notes)


def _balanced_planes(raw, gains: np.ndarray) -> np.ndarray:
    """White-balanced linear colour planes ``(H/2, W/2, 3)`` of a Bayer mosaic (one site per 2 × 2
    cell and channel); saturated sites NaN."""
    from .cfa import CHANNEL_INDEX, check_cfa
    from .stages import linearise

    table = None if raw.table_applied else raw.linearisation_table
    x = linearise(
        raw.mosaic, black_level=raw.black_level, white_level=raw.white_level, table=table, clip=False
    )
    cfa = check_cfa(raw.cfa)
    H, W = (x.shape[0] // 2) * 2, (x.shape[1] // 2) * 2
    planes = np.empty((H // 2, W // 2, 3))
    done = set()
    for k, letter in enumerate(cfa):
        c = CHANNEL_INDEX[letter]
        if c not in done:  # the first green site of the cell: averaging the two would halve the variance
            i, j = divmod(k, 2)
            planes[..., c] = x[i:H:2, j:W:2]
            done.add(c)
    planes = np.where(planes >= 1.0, np.nan, planes)
    return planes * gains


#: ``manufacturer`` values that name no maker: ``zonotope.ssf_json`` writes them for an estimate made
#: without a make (a chart photograph alone, a one-word ``--name``).
NO_MAKER = frozenset({"", "unknown", "estimated"})
#: First words of an EXIF ``Make`` that name another company than the cameras' brand, and the brand.
MAKER_ALIASES = {"ricoh": "pentax", "om": "olympus", "arashi": "insta360"}


def _maker_key(name: str) -> str:
    words = str(name).replace(",", " ").split()
    first = words[0].lower().rstrip(".") if words else ""
    return MAKER_ALIASES.get(first, first)


def sensitivities_maker(camera) -> str | None:
    """The manufacturer a camera's sensitivities name, or None where they name none.

    A built-in name (``zonotope.list_builtin()["cameras"]``) gives its first word; a rawtoaces JSON file
    its ``header.manufacturer`` (``zonotope ssf estimate`` writes the DNG's make there); a CSV or a
    colour MSDS gives None. Why: a metamer correction is right only for the sensor whose curves it is
    fitted on, and a file's make is the one check every DNG allows (:func:`maker_mismatch`).
    """
    import json
    import os
    from pathlib import Path

    if not isinstance(camera, str | os.PathLike):
        return None
    path = Path(camera)
    if path.suffix.lower() == ".json" and path.is_file():
        try:
            header = json.loads(path.read_text(encoding="utf-8")).get("header") or {}
        except (OSError, UnicodeDecodeError, ValueError, AttributeError):
            return None
        made = str(header.get("manufacturer") or "").strip() if isinstance(header, dict) else ""
        return None if made.lower() in NO_MAKER else made
    import zonotope

    name = str(camera)
    return name.split()[0] if name in zonotope.list_builtin()["cameras"] else None


def maker_mismatch(camera, make: str) -> str | None:
    """A warning when a RAW file's ``make`` (EXIF Make; "" when not recorded) is another manufacturer
    than the one ``camera``'s sensitivities name (:func:`sensitivities_maker`), else None.

    Compared by first word, case ignored, with :data:`MAKER_ALIASES` ("NIKON CORPORATION" is a Nikon,
    "RICOH IMAGING" a Pentax). Different makers can share a sensor, so this warns, never refuses.
    """
    made = sensitivities_maker(camera)
    if not made or not str(make).strip() or _maker_key(made) == _maker_key(make):
        return None
    return (
        f"the sensitivities {str(camera)!r} are a {made} camera's but the file is from "
        f"{str(make).strip()!r}: its colours are right only if they are this sensor's curves."
    )
