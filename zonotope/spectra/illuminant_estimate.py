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

Stacked cameras of one scene rarely share one raw gain: ``exposures="per camera"`` gives each its
own exposure. ``bootstrap=B`` resamples the responses B times and reports how far the chosen light's
white moves (its angular uncertainty: the sampling part only, not a light far from every candidate).

A marked card of known reflectance (:func:`grey_card`) chooses the candidate whose predicted card
response points the way the measured one does.

Candidates: the CIE daylight locus, Planckian radiators, the CIE F series and the CIE LED series
(:func:`candidate_illuminants`). Baselines for comparison (:func:`grey_world`, :func:`white_patch`,
:func:`grey_edge`) estimate the light's camera white directly.

References
----------
.. [1] Brainard, D. H., & Freeman, W. T. (1997). Bayesian color constancy. JOSA A 14(7), 1393–1411.
.. [2] Buchsbaum, G. (1980). A spatial processor model for object colour perception (grey world).
.. [3] van de Weijer, J., Gevers, T., & Gijsenij, A. (2007). Edge-based color constancy. IEEE Trans.
   Image Process. 16(9), 2207–2214 (grey-edge, eq. 8).
"""

from __future__ import annotations

from dataclasses import dataclass

import colour
import numpy as np

from .._errors import SpectralDataError
from .._tol import ESTIMATE_COVARIANCE_JITTER, ESTIMATE_NOISE, GREY_EDGE_FLOOR
from . import builtin as spectra

__all__ = [
    "CANDIDATE_KINDS",
    "IlluminantEstimate",
    "candidate_illuminants",
    "estimate_illuminant",
    "grey_card",
    "grey_edge",
    "grey_world",
    "white_angle",
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
        The exposure ``s`` of the chosen candidate (raw responses / white-normalised ones; the first
        camera's with one exposure per camera).
    white : ndarray of shape (k,)
        The chosen light's white response, normalised to a mean of 1 (divide raw responses by it,
        times ``exposure``, to white-balance them).
    exposures : ndarray of shape (k,)
        The exposure per channel (one value per camera with ``exposures="per camera"``).
    angular_uncertainty : float
        Degrees: :func:`estimate_illuminant` with ``bootstrap``: the RMS angle between the first
        camera's white of the chosen light and of the light chosen on each resample;
        :func:`grey_card`: the RMS angle (over cameras) between the card's response and the chosen
        light's prediction of it (what no candidate explains). NaN when not computed.
    agreement : float
        Share of the bootstrap resamples that chose the same light (NaN without ``bootstrap``).
    """

    name: str
    names: tuple[str, ...]
    scores: np.ndarray
    exposure: float
    white: np.ndarray
    exposures: np.ndarray | None = None
    angular_uncertainty: float = float("nan")
    agreement: float = float("nan")


def _camera_generators(cams, light, grid, base=None) -> np.ndarray:
    """``S·E·Δλ`` (n, k) scaled so the white's mean response is 1 (the exposure absorbs the rest);
    ``base``: ``S·Δλ`` on ``grid`` when the caller has it (the cameras resampled once for every light)."""
    if base is None:
        base = np.asarray(spectra.generators(cams, None, grid, normalise=None).values, dtype=np.float64)
    G = base * spectra.resample(spectra.illuminant(light), grid)[:, :1]
    return G / G.sum(axis=0).mean()


def _blocks(cams: list, grid: np.ndarray, exposures: str) -> list[slice]:
    """Channel blocks that share one exposure: all channels, or each camera's."""
    sizes = [spectra.generators(c, "D65", grid).values.shape[1] for c in cams]
    if exposures == "shared":
        return [slice(0, int(sum(sizes)))]
    if exposures == "per camera":
        ends = np.cumsum(sizes)
        return [slice(int(e - n), int(e)) for e, n in zip(ends, sizes)]
    raise SpectralDataError(f"exposures = {exposures!r}: choose 'shared' or 'per camera'.")


def _ll_at(R: np.ndarray, s: np.ndarray, m: np.ndarray, C: np.ndarray, noise: float) -> float:
    """Mean log-likelihood of ``R`` (N, k) for per-channel exposures ``s`` (k,)."""
    cov = s[:, None] * C * s[None, :] + np.diag((noise * s) ** 2)
    L = np.linalg.cholesky(cov)
    z = np.linalg.solve(L, (R - s * m).T)
    return -0.5 * float(np.mean(np.sum(z * z, axis=0))) - float(np.log(np.diag(L)).sum())


def _loglik(R: np.ndarray, G: np.ndarray, mu: np.ndarray, Sigma: np.ndarray, noise: float, blocks):
    """Mean log-likelihood of responses ``R`` (N, k) under light generators ``G``, best exposure(s)."""
    m, C = G.T @ mu, G.T @ Sigma @ G
    s0 = np.empty(G.shape[1])
    mean = R.mean(axis=0)
    for b in blocks:  # each block's exposure: the one matching its mean response along m (least squares)
        s0[b] = float(mean[b] @ m[b] / (m[b] @ m[b]))
    best = (-np.inf, s0)
    for t in np.exp(np.linspace(-0.4, 0.4, 17)):  # refined on a log grid, the blocks' ratios kept
        ll = _ll_at(R, t * s0, m, C, noise)
        if ll > best[0]:
            best = (ll, t * s0)
    return best


def white_angle(a, b) -> float:
    """Angle in degrees between two white responses (the angular error of colour constancy)."""
    a, b = np.asarray(a, dtype=np.float64), np.asarray(b, dtype=np.float64)
    a, b = a / np.linalg.norm(a), b / np.linalg.norm(b)
    # 2·atan2(|a − b|, |a + b|): exact near 0° where arccos of the cosine loses half the digits
    return float(np.degrees(2.0 * np.arctan2(np.linalg.norm(a - b), np.linalg.norm(a + b))))


def estimate_illuminant(
    responses,
    cameras,
    *,
    candidates=None,
    shape=None,
    training="rawtoaces 190",
    noise: float = ESTIMATE_NOISE,
    exposures: str = "shared",
    bootstrap: int = 0,
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
    exposures : {"shared", "per camera"}
        One unknown exposure for every channel (cameras of one raw scale, e.g. simulated), or one per
        camera (real cameras, whose raw gains differ).
    bootstrap : int
        Resamples of the responses (with replacement) for ``angular_uncertainty`` and ``agreement``;
        each candidate keeps the exposure found on all responses; seed 0, so that an estimate is
        reproducible. 0: not computed.

    Returns
    -------
    IlluminantEstimate

    Raises
    ------
    SpectralDataError
        Responses of the wrong shape, not finite, with a channel whose mean is not positive, or fewer
        than k + 1; an unknown ``exposures``.
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
    blocks = _blocks(cams, grid, exposures)
    first = _blocks(cams, grid, "per camera")[0]
    cand = candidate_illuminants() if candidates is None else dict(candidates)
    names, scores, found, whites, moments = [], [], [], [], []
    base = np.asarray(spectra.generators(cams, None, grid, normalise=None).values, dtype=np.float64)
    for name, light in cand.items():
        G = _camera_generators(cams, light, grid, base)
        ll, s = _loglik(R, G, mu, Sigma, noise, blocks)
        names.append(name)
        scores.append(ll)
        found.append(s)
        whites.append(G.sum(axis=0))
        moments.append((G.T @ mu, G.T @ Sigma @ G))
    scores = np.array(scores)
    best = int(np.argmax(scores))
    spread, agree = float("nan"), float("nan")
    if bootstrap > 0:
        rng = np.random.default_rng(0)
        picks = []
        for _ in range(int(bootstrap)):
            Rb = R[rng.integers(0, len(R), len(R))]
            ll = [_ll_at(Rb, s, m, C, noise) for s, (m, C) in zip(found, moments)]
            picks.append(int(np.argmax(ll)))
        angles = [white_angle(whites[i][first], whites[best][first]) for i in picks]
        spread = float(np.sqrt(np.mean(np.square(angles))))
        agree = float(np.mean(np.array(picks) == best))
    return IlluminantEstimate(
        names[best],
        tuple(names),
        scores,
        float(found[best][0]),
        whites[best],
        np.asarray(found[best]),
        spread,
        agree,
    )


def grey_card(
    card,
    cameras,
    *,
    reflectance=1.0,
    candidates=None,
    shape=None,
) -> IlluminantEstimate:
    """The scene light among candidates from a marked card of known reflectance.

    Each candidate predicts the card's raw response ``reflectanceᵀ·S·E·Δλ`` up to an exposure per
    camera; the chosen light is the one whose prediction points the way the measured response does
    (smallest RMS angle over the cameras' channel triples). A card sees one surface, so it fixes the
    light's white, not its spectrum: candidates with one white are told apart only by the card's own
    spectral shape.

    Parameters
    ----------
    card : array_like of shape (k,) or (N, k)
        The card's raw responses through the stacked cameras (pixels are averaged).
    cameras : camera or list of cameras
        Whose stacked channels gave them.
    reflectance : float or array_like of shape (n,)
        The card's reflectance: a number for a spectrally flat grey or white card (its value does not
        matter), or its spectrum on ``shape``.
    candidates : dict of name → SpectralDistribution, optional
        Default :func:`candidate_illuminants`.
    shape : array_like of shape (n,), optional
        Wavelength grid; default 400–700 nm / 10 nm.

    Returns
    -------
    IlluminantEstimate
        ``scores`` are minus the RMS angles (degrees); ``exposures`` per camera;
        ``angular_uncertainty`` the chosen light's RMS angle.

    Raises
    ------
    SpectralDataError
        A card response of the wrong shape, not finite, or not positive in every channel; a
        reflectance spectrum not on the grid or negative.
    """
    grid = (
        np.arange(400.0, 701.0, 10.0)
        if shape is None
        else np.asarray(getattr(shape, "wavelengths", shape), float)
    )
    c = np.asarray(card, dtype=np.float64)
    c = c.reshape(-1, c.shape[-1]).mean(axis=0) if c.ndim == 2 else c
    cams = list(cameras) if isinstance(cameras, list | tuple) else [cameras]
    k = spectra.generators(cams, "D65", grid).values.shape[1]
    if c.shape != (k,) or not np.all(np.isfinite(c)) or not c.min() > 0:
        raise SpectralDataError(
            f"card: expected {k} finite positive raw responses (or (N, {k}) pixels) for these cameras; "
            f"got {np.asarray(card).shape} with minimum {np.nanmin(c) if c.size else 'none'}."
        )
    refl = np.broadcast_to(np.asarray(reflectance, dtype=np.float64), grid.shape)
    if not np.all(np.isfinite(refl)) or refl.min() < 0 or not refl.max() > 0:
        raise SpectralDataError(f"reflectance: one number or {grid.size} values ≥ 0 on the grid, not all 0.")
    blocks = _blocks(cams, grid, "per camera")
    cand = candidate_illuminants() if candidates is None else dict(candidates)
    names, errs, found, whites = [], [], [], []
    base = np.asarray(spectra.generators(cams, None, grid, normalise=None).values, dtype=np.float64)
    for name, light in cand.items():
        G = _camera_generators(cams, light, grid, base)
        p = refl @ G
        s = np.empty(k)
        angles = []
        for b in blocks:
            s[b] = float(c[b] @ p[b] / (p[b] @ p[b]))
            angles.append(white_angle(c[b], p[b]))
        names.append(name)
        errs.append(float(np.sqrt(np.mean(np.square(angles)))))
        found.append(s)
        whites.append(G.sum(axis=0))
    errs = np.array(errs)
    best = int(np.argmin(errs))
    return IlluminantEstimate(
        names[best], tuple(names), -errs, float(found[best][0]), whites[best], found[best], float(errs[best])
    )


def grey_world(responses) -> np.ndarray:
    """Grey-world estimate of the light's white response: the mean response ``(k,)`` (Buchsbaum 1980)."""
    return np.asarray(responses, dtype=np.float64).mean(axis=0)


def white_patch(responses) -> np.ndarray:
    """White-patch (max-RGB) estimate of the light's white response: the per-channel maximum ``(k,)``."""
    return np.asarray(responses, dtype=np.float64).max(axis=0)


def grey_edge(image, *, sigma: float = 1.0, p: float = 1.0) -> np.ndarray:
    """Grey-edge estimate of the light's white response from an image (van de Weijer et al. 2007).

    First order: the Minkowski ``p``-norm over the pixels of each channel's gradient magnitude after a
    Gaussian blur of scale ``sigma`` (eq. 8 with n = 1): the average edge is achromatic.

    Parameters
    ----------
    image : array_like of shape (H, W, k)
        Raw responses of one image (its spatial layout is what the method uses).
    sigma : float
        Gaussian scale in pixels (> 0).
    p : float
        Minkowski norm (≥ 1; 1 the mean edge, large values approach the strongest edge).

    Returns
    -------
    ndarray of shape (k,)

    Raises
    ------
    SpectralDataError
        Not an (H, W, k) image of at least 3 × 3 finite pixels, ``sigma`` ≤ 0, ``p`` < 1, or an image
        without edges (flat: no estimate).
    """
    from scipy.ndimage import gaussian_filter

    f = np.asarray(image, dtype=np.float64)
    if f.ndim != 3 or min(f.shape[:2]) < 3 or not np.all(np.isfinite(f)):
        raise SpectralDataError(f"grey_edge: expected a finite (H, W, k) image, H, W ≥ 3; got {f.shape}.")
    if not sigma > 0 or not p >= 1:
        raise SpectralDataError(f"grey_edge: sigma = {sigma} must be > 0 and p = {p} ≥ 1.")
    out = np.empty(f.shape[-1])
    for j in range(f.shape[-1]):
        gx = gaussian_filter(f[..., j], sigma, order=(0, 1))
        gy = gaussian_filter(f[..., j], sigma, order=(1, 0))
        out[j] = np.mean(np.hypot(gx, gy) ** p) ** (1.0 / p)
    if not out.max() > GREY_EDGE_FLOOR * float(np.abs(f).max()):
        raise SpectralDataError("grey_edge: the image has no edges (flat); use grey_world or a marked card.")
    return out
