"""The guarded regression: a noise-aware root-polynomial that hands responses outside its training
support to a linear matrix fitted for them, the default estimator of whole images."""

from __future__ import annotations

import dataclasses

import numpy as np

from .._errors import OptionError
from .._tol import GUARD_QUANTILE, GUARD_Y_FLOOR
from ..spectra.atypical import sharpened_reflectances
from .noise import NoiseModel, noisy
from .problem import CorrectionProblem, Corrector
from .regressions import fit_Cheung2004, fit_Finlayson2015

__all__ = ["fit_Guarded"]


def _disagreement(problem: CorrectionProblem, root: np.ndarray, linear: np.ndarray) -> np.ndarray:
    """``‖XYZ(root) − XYZ(linear)‖ / Y(linear)^(2/3)`` per row (white Y = 1): CIELAB distances near a
    colour of luminance Y scale as ΔXYZ / Y^(2/3) (the derivative of Y^(1/3)), so this ranks
    disagreements about as ΔE does, at the cost of two small matrix products (no Lab conversion)."""
    A = problem.XYZ_from_target.astype(root.dtype, copy=False)
    y_white = float(problem.white_XYZ[1])
    diff = np.linalg.norm((root - linear) @ A, axis=-1) / y_white
    Y = np.maximum((linear @ A[:, 1]) / y_white, GUARD_Y_FLOOR)
    return diff / np.cbrt(Y) ** 2


def fit_Guarded(
    problem: CorrectionProblem,
    *,
    degree: int = 2,
    noise: float | NoiseModel = 0.0,
    quantile: float = GUARD_QUANTILE,
    augment: int = 300,
    replicas: int = 20,
    guard: bool | str = "auto",
    seed: int = 0,
) -> Corrector:
    """Root-polynomial regression with a linear fallback for responses outside its training support.

    Per response, the root-polynomial ``R(c)`` (Finlayson 2015) and the least-squares matrix ``L(c)``
    of the training set, both fitted for ``noise``. Where they disagree (‖ΔXYZ‖ / Y^(2/3), a cheap
    stand-in for ΔE) more than the ``quantile`` of their disagreement on noisy training responses, the
    estimate is instead a matrix ``W(c)`` fitted for ``noise`` on the training spectra plus ``augment``
    contrast-stretched copies of them (:func:`~zonotope.spectra.atypical.sharpened_reflectances`; no
    test generator involved). Why: the root-polynomial is the best regression on natural colours and
    the worst on saturated, narrow-band ones with stacked cameras, where a matrix is safer; with one
    camera it beats every matrix on both, so there the estimator is ``R`` itself. Fit: tens of
    milliseconds; apply: three small matrix products per response more than ``R``. Measurements:
    ``docs/notes/2026-11-29-noise-default.md``.

    Parameters
    ----------
    problem : CorrectionProblem
    degree
        Root-polynomial degree.
    noise
        σ or :class:`~zonotope.correct.NoiseModel` the three regressions are fitted for (see
        :func:`~zonotope.correct.fit_Cheung2004`); the threshold is taken over training responses
        with that noise.
    quantile
        Share of (noisy) training responses kept on the root-polynomial; the rest of the
        disagreement range goes to the fallback.
    augment
        Number of contrast-stretched spectra added to the fallback's training set.
    replicas
        Noisy copies of the training responses the threshold is taken over (unused without noise).
    guard
        Use the fallback: ``"auto"`` (default) with stacked cameras (``k > m``), or True / False.
    seed
        Seed of the stretched spectra and of the noise draws.

    Returns
    -------
    Corrector
        ``params``: ``"root"`` (the root-polynomial), ``"guard"`` (whether the fallback is used),
        ``"degree"``, ``"noise"``; with the fallback also ``"linear"`` and ``"fallback"`` (the two
        matrices' correctors) and ``"threshold"``.

    Raises
    ------
    OptionError
        ``quantile`` outside (0, 1], ``augment`` / ``replicas`` below 1, or an unknown ``guard``.
    """
    if not 0.0 < quantile <= 1.0:
        raise OptionError(f"quantile={quantile!r}: give the share of training responses kept, in (0, 1].")
    for name, value in (("augment", augment), ("replicas", replicas)):
        if isinstance(value, bool) or not isinstance(value, int | np.integer) or value < 1:
            raise OptionError(f"{name}={value!r}: give a whole number >= 1.")
    if isinstance(guard, str):
        if guard != "auto":
            raise OptionError(f"guard={guard!r}: give 'auto', True or False.")
        guard = problem.k > problem.m
    root = fit_Finlayson2015(problem, degree=degree, noise=noise)
    params = {"root": root, "guard": bool(guard), "degree": degree, "noise": noise}
    if not guard:  # the root-polynomial itself: nothing else to fit
        return Corrector("Guarded", problem, root.predict, params)
    linear = fit_Cheung2004(problem, noise=noise)
    wide = dataclasses.replace(
        problem,
        training=np.vstack([problem.training, sharpened_reflectances(problem.training, augment, seed=seed)]),
    )
    fallback = fit_Cheung2004(wide, noise=noise)
    M_lin, M_fb = linear.params["M"], fallback.params["M"]
    rng = np.random.default_rng(seed)
    C = problem.source_of(problem.training)
    noisy_C = C if _noise_free(noise) else np.vstack([noisy(C, noise, rng) for _ in range(replicas)])
    threshold = float(np.quantile(_disagreement(problem, root.predict(noisy_C), noisy_C @ M_lin), quantile))

    def guarded(c: np.ndarray) -> np.ndarray:
        est = root.predict(c)
        outside = _disagreement(problem, est, c @ M_lin.astype(c.dtype, copy=False)) > threshold
        est[outside] = c[outside] @ M_fb.astype(c.dtype, copy=False)
        return est

    params.update(linear=linear, fallback=fallback, threshold=threshold)
    return Corrector("Guarded", problem, guarded, params)


def _noise_free(noise) -> bool:
    if isinstance(noise, NoiseModel):
        return noise.is_zero
    return not np.any(np.asarray(noise, dtype=np.float64) > 0)
