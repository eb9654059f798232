"""The correction problem: source and target generators on one grid, training reflectances, and the
fitted-estimator type :class:`~zonotope.correct.Corrector` that every method of
:mod:`zonotope.correct` returns."""

from __future__ import annotations

import os
from collections.abc import Callable
from dataclasses import dataclass, field

import colour
import numpy as np

from .._errors import SpectralDataError
from .._tol import LAB_STEP, MAGNITUDE_MAX, REFLECTANCE_MAX, REFLECTANCE_MIN
from ..spectra import builtin as spectra
from ..spectra.loading import load_camera, load_reflectances
from ..spectra.pair import GeneratorPair

__all__ = ["CorrectionProblem", "Corrector", "check_reflectances", "correction_problem"]


def _finite_peak(c: np.ndarray) -> float:
    """Largest finite ``|c|`` (0 for none), without a full-size temporary in the common case:
    ``fmax``/``fmin`` skip NaN; only an infinite entry costs a masked pass."""
    if c.size == 0:
        return 0.0
    flat = c.reshape(-1)
    peak = max(abs(float(np.fmax.reduce(flat))), abs(float(np.fmin.reduce(flat))))
    if np.isinf(peak):
        peak = float(np.max(np.abs(flat), initial=0.0, where=np.isfinite(flat)))
    return 0.0 if np.isnan(peak) else peak


@dataclass(frozen=True, eq=False, kw_only=True)
class CorrectionProblem(GeneratorPair):
    """Source and target generators on one grid (a :class:`~zonotope.GeneratorPair`), plus the
    training reflectances and the map from the target to XYZ.

    Attributes
    ----------
    Phi : ndarray of shape (n, k)
        Source generators (camera channels stacked), white → 1 per channel.
    Psi : ndarray of shape (n, m)
        Target generators (XYZ with Y_white = 1 by default).
    wavelengths : ndarray of shape (n,)
    training : ndarray of shape (N, n)
        Training reflectances, one per row.
    XYZ_from_target : ndarray of shape (m, 3)
        ``XYZ = target @ XYZ_from_target`` (identity for an XYZ target).
    sources, target, illuminant, training_name : str
        Names, for reports.
    target_illuminant : str
        The reference light the target sees (``correction_problem(reference=...)``); ``""`` when
        it is ``illuminant``.
    """

    training: np.ndarray
    XYZ_from_target: np.ndarray
    training_name: str = ""

    @property
    def white_XYZ(self) -> np.ndarray:
        """XYZ of the perfect white reflector, shape (3,) (Y = 1 for the default target)."""
        return self.Psi.sum(axis=0) @ self.XYZ_from_target

    def to_XYZ(self, target) -> np.ndarray:
        """Target values ``(..., m)`` → XYZ ``(..., 3)``."""
        return np.asarray(target, dtype=np.float64) @ self.XYZ_from_target

    def to_Lab(self, target) -> np.ndarray:
        """Target values ``(..., m)`` → CIELAB ``(..., 3)`` relative to the illuminant's white."""
        white = self.white_XYZ
        return colour.XYZ_to_Lab(self.to_XYZ(target) / white[1], colour.XYZ_to_xy(white))

    def delta_E(self, estimate, reference) -> np.ndarray:
        """CIEDE2000 between two arrays of target values ``(..., m)`` → ``(...)``."""
        return colour.delta_E(self.to_Lab(estimate), self.to_Lab(reference), method="CIE 2000")

    def lab_metric(self, target) -> np.ndarray:
        """Jacobian metric ``JᵀJ`` of target → CIELAB at each point, shape ``(..., m, m)``.

        A small step ``d`` in target space changes Lab by ≈ ``J d``, so ``dᵀ(JᵀJ)d`` ≈ ΔE*ab².
        Derivatives by central differences of ``colour.XYZ_to_Lab`` (no re-typed formula).
        """
        t = np.asarray(target, dtype=np.float64)
        h = LAB_STEP * max(float(np.abs(self.Psi.sum(0)).max()), 1e-12)
        cols = []
        for j in range(self.m):
            e = np.zeros(self.m)
            e[j] = h
            cols.append((self.to_Lab(t + e) - self.to_Lab(t - e)) / (2 * h))
        J = np.stack(cols, axis=-1)  # (..., 3, m)
        return np.einsum("...ij,...ik->...jk", J, J)


def _as_names(cameras) -> list:
    if isinstance(cameras, str | colour.MultiSpectralDistributions):
        return [cameras]
    return list(cameras)


def _label(c) -> str:
    return c if isinstance(c, str) else str(getattr(c, "name", "camera"))


def correction_problem(
    cameras,
    *,
    target: str | colour.MultiSpectralDistributions = "CIE 2015 2°",
    illuminant: str | colour.SpectralDistribution = "D65",
    shape: colour.SpectralShape | np.ndarray | None = None,
    training: str | colour.MultiSpectralDistributions | np.ndarray = "rawtoaces 190",
    reference: str | colour.SpectralDistribution | None = None,
) -> CorrectionProblem:
    """Build the generator matrices and training set of a correction task.

    Parameters
    ----------
    cameras
        One camera or a list (built-in names, paths to camera files, colour MSDS); their channels
        are stacked in the given order.
    target
        Observer: an XYZ colour-matching function set (default CIE 2015 2°) or LMS cone
        fundamentals (mapped to XYZ for ΔE, see module notes).
    illuminant
        Scene illuminant (name or SD): the light the cameras saw (their white → 1 under it).
    shape
        Wavelength grid; default the common range of all curves (see :func:`zonotope.common_shape`).
    training
        Training reflectances: a built-in name, a file path, an MSDS or an array ``(N, n)`` already
        on ``shape``.
    reference
        Reference light (name or SD) whose colours the estimates are: the target is the observer
        under ``reference`` (XYZ with Y_white = 1 under it, ΔE relative to its white), while the
        responses are the cameras' under ``illuminant``; every estimator of
        :data:`~zonotope.correct.CORRECTION_METHODS` then fits scene light → reference light
        unchanged (and its MMVs are the combined observer- and illuminant-induced ones). None
        (default): the scene illuminant itself.

    Returns
    -------
    CorrectionProblem

    Raises
    ------
    SpectralDataError
        Curves that do not share a wavelength range, an unknown name, a duplicated camera, a
        training set with fewer samples than regression terms.
    """
    names = _as_names(cameras)
    if not names:
        raise SpectralDataError("cameras: give at least one camera (built-in name, file or MSDS).")
    curves = [load_camera(c) for c in names]
    labels = [_label(c) if isinstance(c, str) else c.name for c in curves]
    dup = sorted({x for x in labels if labels.count(x) > 1})
    if dup:
        raise SpectralDataError(
            f"cameras: {dup} given more than once; a duplicated camera adds no information "
            "(its channels are parallel). Remove the duplicate."
        )
    obs = spectra.observer(target)
    light = spectra.illuminant(illuminant)
    seen = light if reference is None else spectra.illuminant(reference)
    train_curve = None
    if isinstance(training, str | os.PathLike):
        train_curve = load_reflectances(training)
    elif isinstance(training, colour.MultiSpectralDistributions):
        train_curve = training
    if shape is None:
        extra = [train_curve] if train_curve is not None else []
        shape = spectra.common_shape(*curves, obs, light, *([seen] if reference is not None else []), *extra)
    G = spectra.generators(curves, light, shape)
    Phi = G.values
    w = np.asarray(shape.wavelengths if isinstance(shape, colour.SpectralShape) else shape, float)
    tname = _label(target) if isinstance(target, str) else getattr(target, "name", "target")
    is_lms = any(s in str(getattr(obs, "name", tname)).lower() for s in ("cone", "lms", "stockman"))
    T = spectra.generators(obs, seen, shape, normalise=(2 if is_lms else 1))
    Psi = T.values
    if is_lms:
        xyz = spectra.generators("CIE 2015 2°", seen, shape, normalise=1).values
        M = np.linalg.lstsq(Psi, xyz, rcond=None)[0]
    else:
        M = np.eye(Psi.shape[1], 3) if Psi.shape[1] == 3 else None
        if M is None:
            raise SpectralDataError(f"target {tname!r} has {Psi.shape[1]} channels; expected 3 (XYZ or LMS).")
    if train_curve is not None:
        R = spectra.resample(train_curve, w).T
        tr_name = getattr(train_curve, "name", str(training))
    else:
        R = spectra.float_array(training, "training")
        tr_name = "array"
        if R.ndim != 2 or R.shape[1] != w.size:
            raise SpectralDataError(
                f"training: an array must have shape (N, {w.size}) on the grid; got {R.shape}."
            )
    check_reflectances(R, "training")
    return CorrectionProblem(
        Phi=Phi,
        Psi=Psi,
        wavelengths=w,
        training=R,
        XYZ_from_target=M,
        sources=tuple(labels),
        target=tname,
        illuminant=_label(illuminant) if isinstance(illuminant, str) else getattr(illuminant, "name", "?"),
        target_illuminant=""
        if reference is None
        else (reference if isinstance(reference, str) else getattr(reference, "name", "?")),
        training_name=tr_name,
        source_channels=tuple(G.labels),
        target_channels=tuple(T.labels),
    )


def check_reflectances(R: np.ndarray, what: str) -> None:
    """Raise :class:`SpectralDataError` unless ``R`` is a non-empty (N, n) array of reflectances.

    Values slightly above 1 (fluorescence, gloss: the rawtoaces set reaches 1.05) are accepted;
    values above 1.5 are taken for percent data.
    """
    if R.ndim != 2 or R.shape[0] == 0:
        raise SpectralDataError(f"{what}: no reflectances (shape {R.shape}); give at least one sample.")
    if not np.all(np.isfinite(R)):
        raise SpectralDataError(f"{what}: reflectances contain NaN or inf.")
    if R.min() < REFLECTANCE_MIN or R.max() > REFLECTANCE_MAX:
        raise SpectralDataError(
            f"{what}: reflectances must lie in [0, 1] (got {R.min():.3g}…{R.max():.3g}); "
            "percent data must be divided by 100."
        )


@dataclass(frozen=True, eq=False)
class Corrector:
    """A fitted estimator: ``corrector(responses (..., k)) → target (..., m)``.

    Attributes
    ----------
    method : str
        Key of :data:`CORRECTION_METHODS`.
    problem : CorrectionProblem
    params : dict
        Fitted parameters (matrices, prior statistics, ...), for inspection.
    """

    method: str
    problem: CorrectionProblem = field(repr=False)
    predict: Callable[[np.ndarray], np.ndarray] = field(repr=False)
    params: dict = field(default_factory=dict, repr=False)
    #: ``(N, k) → ((N, m) estimates, (N,) credible radii in ΔE00)`` for estimators that know their
    #: uncertainty (``"Prior"``); None for the others.
    predict_with_radius: Callable[[np.ndarray], tuple[np.ndarray, np.ndarray]] | None = field(
        default=None, repr=False
    )
    #: Responses per call of ``predict``: the working memory of a call is bounded by this many rows
    #: whatever the number of responses (only the input and the output grow with it). float32
    #: responses reach ``predict`` as float32 (regressions then compute in float32), others as float64.
    batch_size: int = field(default=16_384, repr=False)

    def with_uncertainty(self, responses) -> tuple[np.ndarray, np.ndarray]:
        """Estimates and, per estimate, a 95 % credible radius in ΔE00 (a confidence map per pixel).

        Parameters
        ----------
        responses : array_like of shape (..., k)

        Returns
        -------
        estimates : ndarray of shape (..., m)
        radius : ndarray of shape (...)
            NaN where the response is not finite.

        Raises
        ------
        SpectralDataError
            Wrong channel count, or an estimator without an uncertainty model (use ``"Prior"``).
        """
        if self.predict_with_radius is None:
            raise SpectralDataError(
                f"the {self.method!r} estimator has no uncertainty model; fit method='Prior' for "
                "estimates with credible radii."
            )
        c, flat = self._responses(responses)
        out = np.full((flat.shape[0], self.problem.m), np.nan)
        rad = np.full(flat.shape[0], np.nan)
        for i, rows, ok in self._chunks(flat):
            if ok.any():
                j = np.arange(i, i + ok.size)[ok]
                out[j], rad[j] = self.predict_with_radius(rows[ok])
        return out.reshape(*c.shape[:-1], self.problem.m), rad.reshape(c.shape[:-1])

    def _responses(self, responses) -> tuple[np.ndarray, np.ndarray]:
        """The responses as an array and its ``(N, k)`` view (not yet converted to float64: chunks
        are, one at a time), or the channel-count error."""
        c = np.asarray(responses)
        k = self.problem.k
        if not np.issubdtype(c.dtype, np.floating):
            if c.dtype.kind not in "biu":
                raise SpectralDataError(
                    f"responses must be numbers, an array_like of shape (..., {k}); got dtype {c.dtype} "
                    f"({str(responses)[:40]!r})."
                )
            c = c.astype(np.float64)
        if c.shape[-1:] != (k,):
            raise SpectralDataError(
                f"responses: last axis must have the {k} source channels "
                f"({', '.join(self.problem.sources)}); got shape {c.shape}."
            )
        peak = _finite_peak(c)
        if peak > MAGNITUDE_MAX:
            raise SpectralDataError(
                f"responses of magnitude {peak:.3g} exceed {MAGNITUDE_MAX:g}; give them on the scale "
                "the correction was fitted on (the white ≈ 1)."
            )
        return c, c.reshape(-1, k)

    def _chunks(self, flat: np.ndarray):
        """``(start, rows (n, k) float64 or float32, finite (n,))`` per chunk of :attr:`batch_size` rows."""
        step = max(int(self.batch_size), 1)
        dtype = np.float32 if flat.dtype == np.float32 else np.float64
        for i in range(0, flat.shape[0], step):
            rows = np.asarray(flat[i : i + step], dtype=dtype)
            yield i, rows, np.all(np.isfinite(rows), axis=1)

    def __call__(self, responses) -> np.ndarray:
        """Estimate target values.

        Parameters
        ----------
        responses : array_like of shape (..., k)

        Returns
        -------
        ndarray of shape (..., m)
        """
        c, flat = self._responses(responses)
        out = np.full((flat.shape[0], self.problem.m), np.nan)
        for i, rows, ok in self._chunks(flat):
            if ok.all():
                out[i : i + ok.size] = self.predict(rows)
            elif ok.any():
                out[np.arange(i, i + ok.size)[ok]] = self.predict(rows[ok])
        return out.reshape(*c.shape[:-1], self.problem.m)
