"""Which light lit the scene: choose among candidate illuminants from raw camera responses.

Raw responses ``r = s · xᵀ S E Δλ`` (one camera or several stacked, before white balance, ``s`` an
unknown exposure) of many surfaces carry the light twice: in their mean (grey-world) and in how they
spread. Under a Gaussian prior on reflectances, x ~ N(μ, Σ) learnt from a training set, the
responses under a light E are Gaussian too,

    r ~ N(s Gᵀμ, s² GᵀΣG + σ² I),        G = S·E·Δλ (n, k),

so every candidate light gets a log-likelihood of the responses, maximised over the exposure ``s``;
the estimate is the candidate with the highest one (a maximum-likelihood choice among candidates, in
the spirit of Brainard & Freeman's Bayesian colour constancy). Stacked cameras see each surface
through more channels, and their covariance constrains the light more than one camera's can.

Candidates: the CIE daylight locus, Planckian radiators, the CIE F series and the CIE LED series
(:func:`candidate_illuminants`). Baselines for comparison (:func:`grey_world`, :func:`white_patch`)
estimate the light's camera white directly.

References
----------
.. [1] Brainard, D. H., & Freeman, W. T. (1997). Bayesian color constancy. JOSA A 14(7), 1393–1411.
.. [2] Buchsbaum, G. (1980). A spatial processor model for object colour perception (grey world).
"""

from __future__ import annotations

from dataclasses import dataclass

import colour
import numpy as np

from .._errors import SpectralDataError
from .._tol import ESTIMATE_COVARIANCE_JITTER, ESTIMATE_NOISE
from . import builtin as spectra

__all__ = [
    "CANDIDATE_KINDS",
    "IlluminantEstimate",
    "candidate_illuminants",
    "estimate_illuminant",
    "grey_world",
    "white_patch",
]


def _daylight() -> dict:
    out = {}
    for cct in range(4000, 10001, 500):
        sd = colour.sd_CIE_illuminant_D_series(colour.temperature.CCT_to_xy_CIE_D(cct * 1.4388 / 1.4380))
        out[f"daylight {cct} K"] = sd
    return out


def _planckian() -> dict:
    return {f"Planckian {t} K": colour.sd_blackbody(t) for t in range(2500, 6501, 500)}


def _series(prefix: str) -> dict:
    return {k: colour.SDS_ILLUMINANTS[k].copy() for k in colour.SDS_ILLUMINANTS if k.startswith(prefix)}


#: Candidate families by name → loader of ``{name: SpectralDistribution}``: the CIE daylight locus
#: (4000–10000 K by 500 K), Planckian radiators (2500–6500 K by 500 K), CIE F (FL1–FL12, FL3.x) and
#: the CIE LED series (colour-science's ``SDS_ILLUMINANTS``).
CANDIDATE_KINDS = {
    "daylight": _daylight,
    "planckian": _planckian,
    "fluorescent": lambda: {k: v for k, v in _series("FL").items() if "." not in k},
    "led": lambda: _series("LED"),
}


def candidate_illuminants(kinds=("daylight", "planckian", "fluorescent", "led")) -> dict:
    """Candidate lights ``{name: colour.SpectralDistribution}`` of the given families.

    Raises
    ------
    SpectralDataError
        An unknown family (the message lists :data:`CANDIDATE_KINDS`).
    """
    kinds = [kinds] if isinstance(kinds, str) else list(kinds)
    out = {}
    for kind in kinds:
        if kind not in CANDIDATE_KINDS:
            raise SpectralDataError(f"candidate kind {kind!r}: choose from {', '.join(CANDIDATE_KINDS)}.")
        out.update(CANDIDATE_KINDS[kind]())
    return out


@dataclass(frozen=True)
class IlluminantEstimate:
    """The chosen candidate light and every candidate's score.

    Attributes
    ----------
    name : str
        Name of the most likely candidate.
    names : tuple of str
        Every candidate, in the order of ``scores``.
    scores : ndarray of shape (C,)
        Log-likelihood of the responses per candidate (maximised over the exposure), per response.
    exposure : float
        The exposure ``s`` of the chosen candidate (raw responses / white-normalised ones).
    white : ndarray of shape (k,)
        The chosen light's white response, normalised to a mean of 1 (divide raw responses by it,
        times ``exposure``, to white-balance them).
    """

    name: str
    names: tuple[str, ...]
    scores: np.ndarray
    exposure: float
    white: np.ndarray


def _camera_generators(cameras, light, grid) -> np.ndarray:
    """``S·E·Δλ`` (n, k) scaled so the white's mean response is 1 (the exposure absorbs the rest)."""
    G = np.asarray(spectra.generators(cameras, light, grid, normalise=None).values, dtype=np.float64)
    return G / G.sum(axis=0).mean()


def _loglik(R: np.ndarray, G: np.ndarray, mu: np.ndarray, Sigma: np.ndarray, noise: float):
    """Mean log-likelihood of responses ``R`` (N, k) under light generators ``G``, best exposure."""
    m, C = G.T @ mu, G.T @ Sigma @ G
    k = G.shape[1]
    # exposure: the one matching the mean response along m (least squares), refined on a log grid
    s0 = float(R.mean(axis=0) @ m / (m @ m))
    best = (-np.inf, s0)
    for s in s0 * np.exp(np.linspace(-0.4, 0.4, 17)):
        cov = s * s * C + (noise * s) ** 2 * np.eye(k)
        L = np.linalg.cholesky(cov)
        z = np.linalg.solve(L, (R - s * m).T)
        ll = -0.5 * float(np.mean(np.sum(z * z, axis=0))) - float(np.log(np.diag(L)).sum())
        if ll > best[0]:
            best = (ll, s)
    return best


def estimate_illuminant(
    responses,
    cameras,
    *,
    candidates=None,
    shape=None,
    training="rawtoaces 190",
    noise: float = ESTIMATE_NOISE,
) -> IlluminantEstimate:
    """The most likely scene light among candidates, from raw responses of many surfaces.

    Parameters
    ----------
    responses : array_like of shape (N, k)
        Raw (not white-balanced) responses of N ≥ k + 1 surfaces of one scene, in any exposure.
    cameras : camera or list of cameras
        Whose stacked channels gave them (built-in names, files, MSDS).
    candidates : dict of name → SpectralDistribution, optional
        Default :func:`candidate_illuminants` (daylight, Planckian, F, LED).
    shape : array_like of shape (n,), optional
        Wavelength grid; default 400–700 nm / 10 nm.
    training : str or ndarray of shape (M, n)
        Reflectances whose mean and covariance are the prior (default rawtoaces 190).
    noise : float
        Response noise σ relative to the white (:data:`zonotope._tol.ESTIMATE_NOISE`).

    Returns
    -------
    IlluminantEstimate

    Raises
    ------
    SpectralDataError
        Responses of the wrong shape, not finite, with a channel whose mean is not positive, or fewer
        than k + 1.
    """
    grid = (
        np.arange(400.0, 701.0, 10.0)
        if shape is None
        else np.asarray(getattr(shape, "wavelengths", shape), float)
    )
    R = np.asarray(responses, dtype=np.float64)
    cams = list(cameras) if isinstance(cameras, list | tuple) else [cameras]
    k = spectra.generators(cams, "D65", grid).values.shape[1]
    if R.ndim != 2 or R.shape[1] != k:
        raise SpectralDataError(f"responses: expected shape (N, {k}) for these cameras; got {R.shape}.")
    if R.shape[0] <= k or not np.all(np.isfinite(R)) or not R.mean(axis=0).min() > 0:
        raise SpectralDataError(
            f"responses: give more than {k} finite raw responses of different surfaces, with a positive "
            f"mean per channel (got {R.shape[0]}); the light is estimated from their spread."
        )
    if isinstance(training, str):
        X = spectra.resample(spectra.reflectances(training), grid).T
    else:
        X = spectra.float_array(training, "training")
    mu = X.mean(axis=0)
    Sigma = np.cov(X.T) + ESTIMATE_COVARIANCE_JITTER * np.eye(grid.size)
    cand = candidate_illuminants() if candidates is None else dict(candidates)
    names, scores, exposures, whites = [], [], [], []
    for name, light in cand.items():
        G = _camera_generators(cams, light, grid)
        ll, s = _loglik(R, G, mu, Sigma, noise)
        names.append(name)
        scores.append(ll)
        exposures.append(s)
        whites.append(G.sum(axis=0))
    scores = np.array(scores)
    best = int(np.argmax(scores))
    return IlluminantEstimate(names[best], tuple(names), scores, float(exposures[best]), whites[best])


def grey_world(responses) -> np.ndarray:
    """Grey-world estimate of the light's white response: the mean response ``(k,)`` (Buchsbaum 1980)."""
    return np.asarray(responses, dtype=np.float64).mean(axis=0)


def white_patch(responses) -> np.ndarray:
    """White-patch (max-RGB) estimate of the light's white response: the per-channel maximum ``(k,)``."""
    return np.asarray(responses, dtype=np.float64).max(axis=0)
