"""A seeded generator of *atypical* reflectance spectra, for stress-testing colour correction.

Natural reflectances are smooth and rarely saturated, which is what regression-based colour
correction is trained for. The spectra made here are the opposite: they sit near the boundary of
the object-colour solid, where metamer mismatch volumes are small and regressions extrapolate.

Families (chosen uniformly unless ``kinds`` is given)
-----------------------------------------------------
``"band-pass"``
    ``lo + (hi − lo)·s(λ)`` with ``s`` a band ``[λ₁, λ₂]`` whose edges are logistic steps of
    width ``w`` ∈ [2, 15] nm; ``lo`` ∈ [0, 0.1], ``hi`` ∈ [0.7, 1]. A band touching either end of
    the grid is a short-pass / long-pass spectrum. With sharp edges and ``lo = 0``, ``hi = 1`` this
    is an optimal colour (Schrödinger), i.e. a point *on* the solid's surface.
``"band-stop"``
    ``1 −`` a band-pass spectrum (same parameters).
``"narrow-band"``
    One or two Gaussian peaks of FWHM 5–25 nm over a dark base (``≤ 0.05``).
``"spiky"``
    A smooth random base (sum of three broad Gaussians, scaled into [0.05, 0.6]) plus 2–5 narrow
    spikes of height 0.3–0.9, clipped to [0, 1].

Every spectrum lies in [0, 1] at every wavelength, so it is a physically valid reflectance.
The same ``seed`` always gives the same spectra (``numpy.random.default_rng``).
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from .._errors import OptionError, SpectralDataError
from .._tol import GP_JITTER, SHARPEN_CLIP

__all__ = [
    "ATYPICAL_KINDS",
    "STRUCTURED_KINDS",
    "atypical_reflectances",
    "structured_reflectances",
]

#: Families of atypical spectra :func:`atypical_reflectances` can draw.
ATYPICAL_KINDS: tuple[str, ...] = ("band-pass", "band-stop", "narrow-band", "spiky")


def _logistic(t: np.ndarray) -> np.ndarray:
    return 0.5 * (1.0 + np.tanh(0.5 * t))


def _band(rng: np.random.Generator, w: np.ndarray) -> np.ndarray:
    span = w[-1] - w[0]
    centre = rng.uniform(w[0] - 0.1 * span, w[-1] + 0.1 * span)
    width = rng.uniform(0.08, 0.5) * span
    lo_edge, hi_edge = centre - width / 2, centre + width / 2
    soft = rng.uniform(2.0, 15.0)
    s = _logistic((w - lo_edge) / soft * 4.0) * _logistic((hi_edge - w) / soft * 4.0)
    lo, hi = rng.uniform(0.0, 0.1), rng.uniform(0.7, 1.0)
    return lo + (hi - lo) * s


def _narrow(rng: np.random.Generator, w: np.ndarray) -> np.ndarray:
    x = np.full(w.shape, rng.uniform(0.0, 0.05))
    for _ in range(rng.integers(1, 3)):
        fwhm = rng.uniform(5.0, 25.0)
        sigma = fwhm / 2.3548
        x += rng.uniform(0.5, 0.95) * np.exp(-0.5 * ((w - rng.uniform(w[0], w[-1])) / sigma) ** 2)
    return x


def _spiky(rng: np.random.Generator, w: np.ndarray) -> np.ndarray:
    base = np.zeros(w.shape)
    for _ in range(3):
        base += rng.uniform(0, 1) * np.exp(-0.5 * ((w - rng.uniform(w[0], w[-1])) / 60.0) ** 2)
    base = 0.05 + 0.55 * base / max(base.max(), 1e-12)
    for _ in range(rng.integers(2, 6)):
        i = rng.integers(0, w.size)
        base[i] += rng.uniform(0.3, 0.9)
    return base


_MAKERS = {
    "band-pass": _band,
    "band-stop": lambda rng, w: 1.0 - _band(rng, w),
    "narrow-band": _narrow,
    "spiky": _spiky,
}


def atypical_reflectances(
    wavelengths: Sequence[float] | np.ndarray,
    n: int = 100,
    *,
    seed: int = 20240601,
    kinds: Sequence[str] | None = None,
) -> tuple[np.ndarray, list[str]]:
    """Draw ``n`` atypical reflectance spectra on a wavelength grid.

    Parameters
    ----------
    wavelengths : array_like of shape (n_wavelengths,)
        The grid in nm (strictly increasing).
    n
        Number of spectra.
    seed
        Seed of ``numpy.random.default_rng``; the same seed gives the same spectra.
    kinds
        Families to draw from (subset of :data:`ATYPICAL_KINDS`); default all, uniformly.

    Returns
    -------
    reflectances : ndarray of shape (n, n_wavelengths)
        Values in [0, 1].
    labels : list of str
        ``"<kind> <i>"`` per spectrum.

    Raises
    ------
    ValueError
        An unknown family in ``kinds`` or ``n < 0``.

    Examples
    --------
    >>> X, labels = atypical_reflectances(np.arange(400, 701, 10), 4, seed=1)
    >>> X.shape, bool(X.min() >= 0 and X.max() <= 1)
    ((4, 31), True)
    """
    w = np.asarray(wavelengths, dtype=np.float64)
    kinds = tuple(kinds) if kinds is not None else ATYPICAL_KINDS
    bad = [k for k in kinds if k not in _MAKERS]
    if bad or not kinds:
        raise OptionError(f"kinds={list(kinds)!r}: unknown family {bad}; choose from {list(ATYPICAL_KINDS)}.")
    if n < 0:
        raise OptionError(f"n={n!r}: give a number of spectra ≥ 0.")
    rng = np.random.default_rng(seed)
    out = np.empty((n, w.size))
    labels = []
    for i in range(n):
        kind = kinds[int(rng.integers(0, len(kinds)))]
        out[i] = np.clip(_MAKERS[kind](rng, w), 0.0, 1.0)
        labels.append(f"{kind} {i}")
    return out, labels


# --- a second, independent generator ------------------------------------------------------------

#: Families of :func:`structured_reflectances` (a generator written independently of
#: :func:`atypical_reflectances`, so that an estimator tuned on one can be checked on the other).
STRUCTURED_KINDS: tuple[str, ...] = ("steps", "interference", "rough")


def _steps(rng: np.random.Generator, w: np.ndarray) -> np.ndarray:
    """Piecewise constant, 1–5 transitions between a dark and a bright level (multi-transition
    near-optimal colours: the solid's surface holds optimal colours with more than 2 transitions)."""
    cuts = np.sort(rng.uniform(w[0], w[-1], rng.integers(1, 6)))
    lo, hi = rng.uniform(0.0, 0.15), rng.uniform(0.75, 1.0)
    level = np.searchsorted(cuts, w) % 2  # 0, 1, 0, ... between successive cuts
    if rng.random() < 0.5:
        level = 1 - level
    return np.where(level == 1, hi, lo)


def _interference(rng: np.random.Generator, w: np.ndarray) -> np.ndarray:
    """Thin-film (structural colour) fringes ``a + b·cos(4π n d / λ + φ)``: 1–4 fringes over the grid."""
    fringes = rng.uniform(1.0, 4.0)
    nd = fringes / (2.0 * (1.0 / w[0] - 1.0 / w[-1]))  # optical thickness giving that many fringes
    a = rng.uniform(0.3, 0.7)
    b = rng.uniform(0.6, 1.0) * min(a, 1.0 - a)
    return a + b * np.cos(4.0 * np.pi * nd / w + rng.uniform(0, 2 * np.pi))


def _rough(rng: np.random.Generator, w: np.ndarray) -> np.ndarray:
    """A Gaussian process with a short correlation length (8–25 nm) around 0.5: high-frequency spectra
    that no smooth natural-reflectance basis represents."""
    ell = rng.uniform(8.0, 25.0)
    K = np.exp(-0.5 * ((w[:, None] - w[None, :]) / ell) ** 2) + GP_JITTER * np.eye(w.size)
    z = np.linalg.cholesky(K) @ rng.standard_normal(w.size)
    return 0.5 + rng.uniform(0.2, 0.35) * z


_STRUCTURED = {"steps": _steps, "interference": _interference, "rough": _rough}


def structured_reflectances(
    wavelengths: Sequence[float] | np.ndarray,
    n: int = 100,
    *,
    seed: int = 7_041_993,
    kinds: Sequence[str] | None = None,
) -> tuple[np.ndarray, list[str]]:
    """Draw ``n`` atypical spectra of a second, independent family (:data:`STRUCTURED_KINDS`).

    ``"steps"``: piecewise-constant spectra with 1–5 transitions between a dark (≤ 0.15) and a
    bright (≥ 0.75) level; ``"interference"``: thin-film fringes ``a + b cos(4π n d / λ + φ)`` with
    1–4 fringes over the grid; ``"rough"``: a Gaussian process of correlation length 8–25 nm around
    0.5. All clipped to [0, 1]. Same contract as :func:`atypical_reflectances` (seeded, labels).

    Parameters
    ----------
    wavelengths : array_like of shape (n_wavelengths,)
    n
        Number of spectra.
    seed
        Seed of ``numpy.random.default_rng``.
    kinds
        Families to draw from (subset of :data:`STRUCTURED_KINDS`); default all, uniformly.

    Returns
    -------
    reflectances : ndarray of shape (n, n_wavelengths)
    labels : list of str

    Raises
    ------
    SpectralDataError
        An unknown family or ``n < 0`` (a ``ValueError``).

    Examples
    --------
    >>> X, labels = structured_reflectances(np.arange(400, 701, 10), 3, seed=1)
    >>> X.shape, bool(X.min() >= 0 and X.max() <= 1)
    ((3, 31), True)
    """
    w = np.asarray(wavelengths, dtype=np.float64)
    kinds = tuple(kinds) if kinds is not None else STRUCTURED_KINDS
    bad = [k for k in kinds if k not in _STRUCTURED]
    if bad or not kinds:
        raise SpectralDataError(
            f"kinds={list(kinds)!r}: unknown family {bad}; choose from {list(STRUCTURED_KINDS)}."
        )
    if n < 0:
        raise SpectralDataError(f"n must be >= 0, got {n}.")
    rng = np.random.default_rng(seed)
    out = np.empty((n, w.size))
    labels = []
    for i in range(n):
        kind = kinds[int(rng.integers(0, len(kinds)))]
        out[i] = np.clip(_STRUCTURED[kind](rng, w), 0.0, 1.0)
        labels.append(f"{kind} {i}")
    return out, labels


def sharpened_reflectances(reflectances, n: int, *, seed: int = 0) -> np.ndarray:
    """Atypical spectra made from natural ones: each a contrast-stretched training spectrum.

    A training-side helper of :func:`zonotope.correct.mmv.learn_mix` (not in ``__all__``).

    Training-side augmentation for :func:`zonotope.correct.fit_Prior` (no test generator involved):
    a randomly drawn spectrum ``x`` of ``reflectances`` keeps its shape, i.e. where it rises and
    falls, but its logit is stretched by a steepness ``s`` (log-uniform in [2, 30]) about a random
    level ``z₀`` (between its 20th and 80th logit percentile) and mapped into ``[lo, hi]``
    (``lo`` ∈ [0, 0.1], ``hi`` ∈ [0.6, 1])::

        y = lo + (hi − lo) · σ(s · (logit x − z₀))

    Steep ``s`` turns a smooth natural spectrum into a saturated band- or step-like one with the same
    transitions (a more concentrated dye or a sharper filter of the same material), i.e. towards the
    boundary of the object-colour solid, where regressions extrapolate.

    Parameters
    ----------
    reflectances : array_like of shape (N, n_wavelengths)
        Natural spectra in [0, 1] (the training set).
    n
        Number of spectra to make.
    seed
        Seed of ``numpy.random.default_rng``.

    Returns
    -------
    ndarray of shape (n, n_wavelengths)
        In [0, 1].

    Raises
    ------
    SpectralDataError
        No spectra given or ``n < 0``.
    """
    R = np.asarray(reflectances, dtype=np.float64)
    if R.ndim != 2 or R.shape[0] == 0:
        raise SpectralDataError(f"reflectances: give an (N, n_wavelengths) array with N ≥ 1, got {R.shape}.")
    if n < 0:
        raise SpectralDataError(f"n must be >= 0, got {n}.")
    rng = np.random.default_rng(seed)
    x = np.clip(R[rng.integers(0, R.shape[0], n)], SHARPEN_CLIP, 1.0 - SHARPEN_CLIP)
    z = np.log(x / (1.0 - x))
    z0 = rng.uniform(np.percentile(z, 20, axis=1), np.percentile(z, 80, axis=1))
    s = np.exp(rng.uniform(np.log(2.0), np.log(30.0), n))
    lo = rng.uniform(0.0, 0.1, (n, 1))
    hi = rng.uniform(0.6, 1.0, (n, 1))
    return np.clip(lo + (hi - lo) * _logistic(s[:, None] * (z - z0[:, None])), 0.0, 1.0)
