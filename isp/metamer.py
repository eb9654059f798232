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
from typing import TYPE_CHECKING, Any

import numpy as np

from ._errors import PipelineError

if TYPE_CHECKING:
    from zonotope.correct import Corrector
    from zonotope.utilities import ProgressCallback

__all__ = ["METAMER_RANGE", "MetamerConfig", "MetamerCorrection", "metamer_correction"]


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
        :class:`zonotope.ProgressCallback`).
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
    progress: ProgressCallback | None = None
    white_level: float = 1.0
    fallbacks: int = 0
    neutral: np.ndarray | None = field(default=None, repr=False)

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
        progress = self.progress if c.ndim > 1 and c.size > c.shape[-1] else None
        XYZ = correct_image(
            c / over, self._safe, quantum=self.quantum, batch_size=self.batch_size, progress=progress
        )
        return XYZ * (over * self.white_level)


@dataclass(frozen=True)
class MetamerConfig:
    """The options of :func:`metamer_correction`, checked when the object is made.

    Attributes
    ----------
    method : str
        Estimator (key or alias of ``zonotope.correct.CORRECTION_METHODS``; default ``"Prior"``).
    illuminant : str or colour.SpectralDistribution
        Scene illuminant of the fit (name or SD); should match the light the file's white balance
        was set for.
    training : str, path or colour.MultiSpectralDistributions
        Training reflectances: built-in set name, a file readable by ``zonotope.read_reflectances``
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
    estimator_options : mapping of str to object
        Keywords passed on to the estimator's fitting function (e.g. ``{"noise": 0.01}``); kept
        apart so that a misspelt field of this config is refused instead of passed on.

    Raises
    ------
    PipelineError
        A field out of range (named, with what is allowed).
    """

    method: str = "Prior"
    illuminant: Any = "D65"
    training: Any = "rawtoaces 190"
    target: Any = "CIE 1931 2°"
    shape: Any = None
    white_level: float = 1.0
    quantum: float = 2e-3
    batch_size: int = 64
    estimator_options: Mapping[str, Any] = field(default_factory=dict)

    def __post_init__(self) -> None:
        from ._config import check_int, check_number, check_options

        owner = "MetamerConfig"
        if not (isinstance(self.method, str) and self.method.strip()):
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
        clash = sorted(set(opts) & {"method", "target", "illuminant", "shape", "training"})
        if clash:
            raise PipelineError(
                f"{owner}.estimator_options: {', '.join(clash)} are fields of {owner} itself; "
                "set them there, not in estimator_options."
            )
        object.__setattr__(self, "estimator_options", opts)


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
        ``zonotope.read_camera`` (rawtoaces/camspec JSON, CSV) or a colour MSDS.
    config
        The options (:class:`MetamerConfig`: method, illuminant, training, target, shape,
        white_level, quantum, batch_size, estimator_options); default all defaults.
    progress
        See :class:`MetamerCorrection`.
    **options
        Fields of :class:`MetamerConfig` as keywords (override those of ``config``), e.g.
        ``method="MAP", quantum=0``; the estimator's own options go in ``estimator_options``
        (e.g. ``estimator_options={"noise": 0.01}``).

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
    from zonotope.correct import fit_correction

    from ._config import with_options

    cfg = with_options(MetamerConfig, config, options, where="metamer_correction")
    target, illuminant, shape = cfg.target, cfg.illuminant, cfg.shape
    cam = zonotope.load_camera(camera)
    train = zonotope.load_reflectances(cfg.training)
    if shape is None:
        lo, hi, step = METAMER_RANGE
        curves = [cam, zonotope.observer(target), zonotope.illuminant(illuminant)]
        if isinstance(train, colour.MultiSpectralDistributions):
            curves.append(train)
        common = zonotope.common_shape(*curves, interval=step)
        shape = np.arange(max(common.start, lo), min(common.end, hi) + step / 2, step)
    corrector = fit_correction(
        cam,
        method=cfg.method,
        target=target,
        illuminant=illuminant,
        shape=shape,
        training=train,
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
    )
