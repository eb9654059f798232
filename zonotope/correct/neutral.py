"""White-point preserving estimates: the offset that maps every response proportional to the white's to
the white's colour at that luminance, faded out with the estimate's chroma.

Why: estimators fitted for noisy responses, and MMVs widened by a response tolerance δ, are biased on
neutral surfaces (light greys turn green-yellow as δ grows; ``docs/notes/2026-11-29-neutral-bias.md``).
On the achromatic axis the answer is known without a prior: a response ``s · c_w`` (``c_w`` the perfect
white's) is the colour of the grey ``s``, ``s · t_w``. The offset ``s · t_w − t̂(s · c_w)`` of the
fitted estimator ``t̂`` along that axis is tabulated at fit time and added near it.
"""

from __future__ import annotations

import dataclasses
import functools

import numpy as np
from colour.colorimetry import intermediate_lightness_function_CIE1976

from .._errors import OptionError
from .._tol import NEUTRAL_CBRT_FLOOR, NEUTRAL_CHROMA, NEUTRAL_LEVELS
from .problem import Corrector

__all__ = ["neutral_offsets", "white_point_option", "white_point_preserving"]


def neutral_offsets(corrector: Corrector, levels=None) -> tuple[np.ndarray, np.ndarray]:
    """The estimator's offset per unit luminance along the achromatic axis.

    Parameters
    ----------
    corrector : Corrector
    levels : array_like of shape (L,), optional
        Grey levels ``s`` (fractions of the white's response), increasing; default
        :data:`zonotope._tol.NEUTRAL_LEVELS`.

    Returns
    -------
    levels : ndarray of shape (L,)
    beta : ndarray of shape (L, m)
        ``t_w − t̂(s · c_w) / s``: adding ``s · beta`` to the estimate of ``s · c_w`` gives ``s · t_w``.
    """
    p = corrector.problem
    s = np.asarray(NEUTRAL_LEVELS if levels is None else levels, dtype=np.float64)
    c_w, t_w = p.Phi.sum(axis=0), p.Psi.sum(axis=0)
    return s, t_w - corrector(s[:, None] * c_w) / s[:, None]


def _lab_f(ratio: np.ndarray) -> np.ndarray:
    """CIELAB's ``f(X/X_n)`` elementwise: ``np.cbrt`` above :data:`~zonotope._tol.NEUTRAL_CBRT_FLOOR`,
    colour-science's ``intermediate_lightness_function_CIE1976`` at and below it (its linear branch).
    Why: colour's ``spow`` cube root costs three times ``np.cbrt`` and agrees with it within 1 ulp."""
    f = np.cbrt(ratio)
    low = ratio <= NEUTRAL_CBRT_FLOOR
    if low.any():
        f[low] = intermediate_lightness_function_CIE1976(ratio[low], 1.0)
    return f


def white_point_preserving(corrector: Corrector, *, chroma: float | None = None) -> Corrector:
    """``corrector`` with its achromatic-axis offset added, weighted by neutrality.

    The estimate of a response ``c`` becomes ``t̂(c) + g · s · β(s)``: ``s`` the projection of ``c`` on the
    white's response, ``β`` the tabulated offset (:func:`neutral_offsets`, interpolated in ``log s``,
    held constant beyond the table), ``g = exp(−½ (C*ab / chroma)²)`` with ``C*ab`` the chroma of
    ``t̂(c) + s · β(s)``. On the axis that is the grey's colour (chroma 0, ``g = 1``), so the estimate is
    exactly ``s · t_w`` at the tabulated levels (and between them for an estimator linear in exposure,
    such as the regressions, whose ``β`` is constant); colours of chroma several times ``chroma`` keep
    ``t̂``.

    Parameters
    ----------
    corrector : Corrector
    chroma
        CIELAB chroma at which the offset has fallen to ``exp(−½) ≈ 0.61`` of itself; default
        :data:`zonotope._tol.NEUTRAL_CHROMA`.

    Returns
    -------
    Corrector
        Same method name and problem; ``params`` gains ``"white_point"`` (True), ``"neutral_levels"``,
        ``"neutral_offsets"`` and ``"neutral_chroma"``. Closed-form parts (``"closed_form"``) and
        credible radii follow the same offset.
    """
    p = corrector.problem
    chroma = float(NEUTRAL_CHROMA if chroma is None else chroma)
    levels, beta = neutral_offsets(corrector)
    logs = np.log(levels)
    c_w = p.Phi.sum(axis=0)
    to_grey = c_w / float(c_w @ c_w)  # c ↦ ⟨c, c_w⟩ / ‖c_w‖², the grey level s
    # target → XYZ / XYZ_white column by column: the ratios CIELAB's f(·) takes (a*, b* = 0 at the white)
    to_ratio = p.XYZ_from_target / p.white_XYZ
    spread = -0.5 / chroma**2

    def shift(c: np.ndarray, t: np.ndarray) -> np.ndarray:
        # einsum, not ``@``: matrix products with 3–9 inner terms through BLAS cost 2–8× more here
        t = np.asarray(t, dtype=np.float64)
        s = np.einsum("...i,i->...", np.asarray(c), to_grey, dtype=np.float64)
        ls = np.log(np.clip(s, levels[0], levels[-1]))
        b = np.empty(t.shape, dtype=np.float64)
        for j in range(beta.shape[1]):
            b[..., j] = np.interp(ls, logs, beta[:, j])
        b *= np.maximum(s, 0.0)[..., None]
        # chroma of the fully shifted estimate (on the axis exactly the grey: chroma 0, g = 1); only a*, b*
        # are needed: CIELAB's f(X/X_n), f(Y/Y_n), f(Z/Z_n) (:func:`_lab_f`) without L* or domain scaling
        f = _lab_f(np.einsum("...i,ij->...j", t + b, to_ratio))
        C2 = np.square(500.0 * (f[..., 0] - f[..., 1])) + np.square(200.0 * (f[..., 1] - f[..., 2]))
        g = np.exp(spread * C2)
        g = np.where(np.isfinite(g), g, 0.0)
        b *= g[..., None]
        b += t
        return b

    def predict(c):
        return shift(c, corrector.predict(c))

    params = dict(corrector.params)
    params.update(white_point=True, neutral_levels=levels, neutral_offsets=beta, neutral_chroma=float(chroma))
    closed = corrector.params.get("closed_form")
    if closed is not None:

        def closed_form(c):
            out, slow = closed(c)
            return shift(c, out), slow

        params["closed_form"] = closed_form
    with_radius = None
    if corrector.predict_with_radius is not None:

        def with_radius(c):
            t, r = corrector.predict_with_radius(c)
            return shift(c, t), r

    return dataclasses.replace(corrector, predict=predict, params=params, predict_with_radius=with_radius)


def white_point_option(fit, *, default: bool = False):
    """``fit(problem, ..., **options)`` that also takes ``white_point`` (default ``default``): True wraps the
    fitted estimator in :func:`white_point_preserving`. The registry entries of
    :data:`~zonotope.correct.CORRECTION_METHODS` are these (their property ``white_point`` is ``default``).
    ``params["white_point"]`` records the choice, so that a saved correction reloads the same way."""

    @functools.wraps(fit)
    def fitted(problem, *args, white_point: bool = default, **options) -> Corrector:
        if not isinstance(white_point, bool | np.bool_):
            raise OptionError(f"white_point={white_point!r}: give True or False.")
        corrector = fit(problem, *args, **options)
        if white_point:
            return white_point_preserving(corrector)
        return dataclasses.replace(corrector, params={**corrector.params, "white_point": False})

    return fitted
