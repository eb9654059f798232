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

__all__ = ["ATYPICAL_KINDS", "atypical_reflectances"]

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
        raise ValueError(f"kinds={list(kinds)!r}: unknown family {bad}; choose from {list(ATYPICAL_KINDS)}.")
    if n < 0:
        raise ValueError(f"n must be >= 0, got {n}.")
    rng = np.random.default_rng(seed)
    out = np.empty((n, w.size))
    labels = []
    for i in range(n):
        kind = kinds[int(rng.integers(0, len(kinds)))]
        out[i] = np.clip(_MAKERS[kind](rng, w), 0.0, 1.0)
        labels.append(f"{kind} {i}")
    return out, labels
