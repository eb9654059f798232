"""Regressions fitted on responses whose error is known as draws (errors in the variables).

When the source curves are estimates (:func:`zonotope.estimate_ssf`), every training response carries
the curves' error: systematic, correlated over wavelengths, channels and responses. A per-channel
noise σ (:class:`~zonotope.correct.NoiseModel`) keeps only its variance; here the fit is given draws of
the error itself (:meth:`zonotope.spectra.estimate.SSFEstimate.response_errors`) and minimises the
expected squared error over them: the normal equations of the regression averaged over the draws,
plus the sensor noise's share of them (:func:`~zonotope.correct.regressions.expected_normal_equations`
at the estimated responses less the noise-free ones: the draws move responses by < 1 %, which changes
that share by far less).
"""

from __future__ import annotations

import numpy as np

from .._errors import OptionError, SpectralDataError
from .noise import NoiseModel, noise_model
from .problem import CorrectionProblem, Corrector
from .regressions import _solve_normal, _terms_by_row, expected_normal_equations, root_polynomial_terms

__all__ = ["fit_errors_in_variables"]

_DEGREE = {"Cheung 2004": 1, "Finlayson 2015": 2}


def fit_errors_in_variables(
    problem: CorrectionProblem,
    response_errors,
    *,
    method: str = "Finlayson 2015",
    noise=None,
    degree: int | None = None,
    ridge: float = 1e-9,
) -> Corrector:
    """A regression fitted on the training responses plus each draw of their error, averaged.

    Parameters
    ----------
    problem : CorrectionProblem
        Its source curves are the estimates whose error is drawn.
    response_errors : array_like of shape (M, N, k)
        ``M`` draws of the error of ``problem.source_of(problem.training)`` (true minus estimated
        responses), e.g. :func:`zonotope.ssf_response_errors`.
    method : {"Finlayson 2015", "Cheung 2004"}
        Root-polynomial (``degree``, default 2) or linear regression.
    noise : None, σ, σ per channel or NoiseModel
        The sensor noise of the responses to correct, averaged into each draw's normal equations.
    degree : int, optional
        Root-polynomial degree (Finlayson 2015 only).
    ridge : float
        Relative Tikhonov term, as the registry's regressions.

    Returns
    -------
    Corrector
        ``method`` as named; ``params``: ``M`` (terms × m), ``degree``, ``draws``, ``noise``.

    Raises
    ------
    OptionError
        Another method, or a degree given to Cheung 2004.
    SpectralDataError
        ``response_errors`` not of shape (M, N, k) for the problem's training set.
    """
    if method not in _DEGREE:
        raise OptionError(
            f"fit_errors_in_variables method={method!r}: choose 'Finlayson 2015' or 'Cheung 2004'."
        )
    if degree is not None and method == "Cheung 2004":
        raise OptionError("fit_errors_in_variables: Cheung 2004 is linear; give no degree.")
    degree = _DEGREE[method] if degree is None else int(degree)
    C, T = problem.source_of(problem.training), problem.target_of(problem.training)
    draws = np.asarray(response_errors, dtype=np.float64)
    if draws.ndim != 3 or draws.shape[1:] != C.shape or not np.all(np.isfinite(draws)):
        raise SpectralDataError(
            f"response_errors has shape {draws.shape}; give finite draws of shape (M, {C.shape[0]}, "
            f"{C.shape[1]}) for the problem's training responses."
        )
    model = noise_model(noise, problem.k)

    def plain(c):
        P = c if degree == 1 else root_polynomial_terms(c, degree=degree)
        return P.T @ P, P.T @ T

    G = B = 0.0
    for d in draws:
        g, b = plain(C + d)
        G, B = G + g, B + b
    G, B = G / len(draws), B / len(draws)
    if model is not None:  # the noise's share of the normal equations, at the estimated responses
        g0, b0 = plain(C)
        gn, bn = expected_normal_equations(C, T, model, degree=degree)
        G, B = G + gn - g0, B + bn - b0
    M = _solve_normal(G, B, ridge)
    if degree == 1:
        predict = lambda c: c @ M  # noqa: E731
    else:
        predict = lambda c: _terms_by_row(c, degree).T @ M  # noqa: E731
    params = {
        "M": M,
        "degree": degree,
        "draws": len(draws),
        "noise": model or NoiseModel.constant(0.0, problem.k),
    }
    return Corrector(method, problem, predict, params)
