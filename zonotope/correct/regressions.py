"""Regression estimators of :mod:`zonotope.correct`: least-squares matrix (Cheung 2004),
root-polynomial (Finlayson 2015) and the ACES IDT (Dyer 2017)."""

from __future__ import annotations

import itertools
import warnings

import colour
import numpy as np

from .._errors import OptionError, SpectralDataError
from ..utilities.registry import MethodRegistry
from .noise import NoiseModel
from .problem import CorrectionProblem, Corrector

__all__ = [
    "REGRESSIONS",
    "expected_normal_equations",
    "fit_Cheung2004",
    "fit_Dyer2017",
    "fit_Finlayson2015",
    "root_polynomial_exponents",
    "root_polynomial_terms",
]


def root_polynomial_terms(responses, *, degree: int = 2) -> np.ndarray:
    """Root-polynomial expansion of any number of channels (Finlayson et al. 2015, eq. 6).

    For every multiset of channels of size ``d ≤ degree`` that is not a single channel repeated,
    the term ``(∏ c_i)^(1/d)``; plus the channels themselves. Every term is homogeneous of degree
    1, so the expansion scales with exposure. For 3 channels this is exactly
    ``colour.characterisation.polynomial_expansion_Finlayson2015`` (same terms; order may differ).

    Parameters
    ----------
    responses : array_like of shape (..., k)
        Negative values are clipped to 0 (roots of negatives are undefined).
    degree
        1 (linear), 2 (k(k+1)/2 terms), 3, ...

    Returns
    -------
    ndarray of shape (..., n_terms)
    """
    c = np.asarray(responses, dtype=np.float64)
    return _terms_by_row(c.reshape(-1, c.shape[-1]), degree).T.reshape(*c.shape[:-1], -1)


#: Products of root-polynomial terms stay below this (float64 overflows at ≈ 1.8e308); larger
#: responses are scaled down first, which changes nothing since every term has degree 1.
_PRODUCT_SAFE = 1e300


def _terms_by_row(c: np.ndarray, degree: int) -> np.ndarray:
    """The root-polynomial terms of ``c (N, k)`` as ``(n_terms, N)``: every channel and product is a
    contiguous row, which keeps the products of photo-sized chunks cache-friendly."""
    if degree < 1:
        raise OptionError(f"degree={degree!r}: give a polynomial degree ≥ 1.")
    k = c.shape[1]
    combos = [
        combo
        for d in range(2, degree + 1)
        for combo in itertools.combinations_with_replacement(range(k), d)
        if len(set(combo)) > 1
    ]
    # one (n_terms, N) array written row by row: no list of rows stacked (a copy of every term) at the end
    out = np.empty((k + len(combos), c.shape[0]), dtype=np.result_type(c.dtype, 0.0))
    ct = np.maximum(c.T, 0.0, out=out[:k])  # (k, N)
    peak = float(np.max(ct, initial=0.0, where=np.isfinite(ct)))
    if peak > _PRODUCT_SAFE ** (1.0 / degree):  # products of `degree` channels would overflow;
        return _terms_by_row(c / peak, degree) * peak  # every term is homogeneous of degree 1
    for row, combo in enumerate(combos, start=k):
        p = np.multiply(ct[combo[0]], ct[combo[1]], out=out[row])
        for i in combo[2:]:
            p *= ct[i]
        if len(combo) == 2:
            np.sqrt(p, out=p)
        else:
            p **= 1.0 / len(combo)
    return out


def root_polynomial_exponents(k: int, *, degree: int = 2) -> np.ndarray:
    """Exponents ``P (n_terms, k)`` of the root-polynomial terms: term ``a`` is ``∏_i c_i ** P[a, i]``,
    in the order of :func:`root_polynomial_terms` (degree 1: the identity)."""
    if degree < 1:
        raise OptionError(f"degree={degree!r}: give a polynomial degree ≥ 1.")
    rows = list(np.eye(k))
    for d in range(2, degree + 1):
        for combo in itertools.combinations_with_replacement(range(k), d):
            if len(set(combo)) > 1:
                rows.append(np.bincount(combo, minlength=k) / d)
    return np.array(rows)


#: Gauss–Hermite nodes of the per-channel noise expectations in :func:`expected_normal_equations`.
_HERMITE_NODES = 48


def expected_normal_equations(responses, targets, noise: NoiseModel, *, degree: int = 2):
    """Normal equations of a root-polynomial regression averaged over the noise of its inputs.

    With noisy inputs ``c + n`` (``n`` independent per channel, variance ``noise.variance(c)``) the
    expected squared error ``E‖φ(c + n) M − t‖²`` summed over the training set is minimised by
    ``G M = B`` with ``G = Σ E[φ φᵀ]`` and ``B = Σ E[φ] tᵀ``: the fit a noise-augmented training set
    of infinitely many replicas converges to. Every product of two terms is ``∏_i (c_i + n_i)₊^q_i``,
    so its expectation is a product of one-channel moments ``E[(c_i + n_i)₊^q]``, computed by
    Gauss–Hermite quadrature. For ``degree = 1`` (a matrix, inputs not clipped) the moments are
    exact: ``G = CᵀC + diag(Σ var)``.

    Parameters
    ----------
    responses : ndarray of shape (N, k)
        Noise-free training responses.
    targets : ndarray of shape (N, m)
    noise : NoiseModel
    degree
        1: linear matrix on the raw responses; ≥ 2: root-polynomial terms of responses clipped at 0.

    Returns
    -------
    G : ndarray of shape (n_terms, n_terms)
    B : ndarray of shape (n_terms, m)
    """
    C = np.asarray(responses, dtype=np.float64)
    T = np.asarray(targets, dtype=np.float64)
    var = noise.check_channels(C.shape[1]).variance(C)
    if degree == 1:
        return C.T @ C + np.diag(var.sum(axis=0)), C.T @ T
    P = root_polynomial_exponents(C.shape[1], degree=degree)
    Q = P[:, None, :] + P[None, :, :]  # (terms, terms, k) exponents of the products
    qs, where = np.unique(np.concatenate([P.ravel(), Q.ravel()]), return_inverse=True)
    z, wz = np.polynomial.hermite_e.hermegauss(_HERMITE_NODES)
    x = np.maximum(C[..., None] + np.sqrt(var)[..., None] * z, 0.0)  # (N, k, nodes)
    with np.errstate(divide="ignore"):
        logx = np.log(x)
    moments = np.stack([np.exp(q * logx) if q > 0 else np.ones_like(x) for q in qs]) @ (wz / wz.sum())
    # moments (q, N, k); E[φ_a] and E[φ_a φ_b] are products of one-channel moments over channels
    ch = np.arange(C.shape[1])
    idx_P, idx_Q = where[: P.size].reshape(P.shape), where[P.size :].reshape(Q.shape)
    Ephi = np.prod(moments[idx_P, :, ch], axis=1)  # (terms, k, N) → (terms, N)
    G = np.stack([np.prod(moments[idx_Q[a], :, ch], axis=1).sum(axis=-1) for a in range(P.shape[0])])
    return G, Ephi @ T


def _solve_normal(G: np.ndarray, B: np.ndarray, ridge: float) -> np.ndarray:
    """``G M = B`` with the relative ridge of :func:`_lstsq`."""
    lam = ridge * np.trace(G) / G.shape[0]
    return np.linalg.solve(G + lam * np.eye(G.shape[0]), B)


def _lstsq(A: np.ndarray, B: np.ndarray, ridge: float) -> np.ndarray:
    """Least squares ``A M ≈ B`` with a small relative ridge for rank-deficient stacks."""
    if A.shape[0] < A.shape[1]:
        raise SpectralDataError(
            f"training set has {A.shape[0]} samples but the regression has {A.shape[1]} terms; use "
            "a larger training set (e.g. 'rawtoaces 190') or a lower degree."
        )
    AtA = A.T @ A
    lam = ridge * np.trace(AtA) / AtA.shape[0]
    return np.linalg.solve(AtA + lam * np.eye(AtA.shape[0]), A.T @ B)


def _training(problem: CorrectionProblem, noise: float, copies: int, seed: int):
    """Training responses and targets, with ``copies`` noisy replicas when ``noise > 0``."""
    C, T = problem.source_of(problem.training), problem.target_of(problem.training)
    if noise <= 0:
        return C, T
    rng = np.random.default_rng(seed)
    Cn = np.concatenate([C + rng.normal(0.0, noise, C.shape) for _ in range(copies)])
    return Cn, np.tile(T, (copies, 1))


def _fit_matrix(problem: CorrectionProblem, noise, copies: int, seed: int, ridge: float, *, degree: int):
    """Regression matrix of ``degree`` (1: on the responses, else root-polynomial terms): for a
    :class:`NoiseModel` from the noise-averaged normal equations, for a σ on noisy replicas."""
    if isinstance(noise, NoiseModel):
        if noise.is_zero:
            noise = 0.0
        else:
            C, T = problem.source_of(problem.training), problem.target_of(problem.training)
            terms = root_polynomial_exponents(problem.k, degree=degree).shape[0]
            if C.shape[0] < terms:
                _lstsq(np.zeros((C.shape[0], terms)), T, ridge)  # the too-small-training-set error
            return _solve_normal(*expected_normal_equations(C, T, noise, degree=degree), ridge)
    C, T = _training(problem, noise, copies, seed)
    A = C if degree == 1 else root_polynomial_terms(C, degree=degree)
    return _lstsq(A, T, ridge)


def fit_Cheung2004(
    problem: CorrectionProblem,
    *,
    ridge: float = 1e-9,
    noise: float | NoiseModel = 0.0,
    copies: int = 10,
    seed: int = 0,
) -> Corrector:
    """Least-squares ``k × m`` matrix from source to target responses (no offset).

    Parameters
    ----------
    problem : CorrectionProblem
    ridge
        Relative Tikhonov term (tiny by default; it only matters for dependent channels).
    noise, copies, seed
        With ``noise = σ > 0`` the regression is trained on ``copies`` replicas of the training
        responses with seeded Gaussian noise σ, so it learns not to amplify noise (stacked cameras
        have nearly collinear channels, which a noise-free fit exploits). With a
        :class:`~zonotope.correct.NoiseModel` (shot + read per channel) it solves the noise-averaged normal
        equations instead (:func:`expected_normal_equations`: the limit of infinitely many
        replicas, deterministic; ``copies`` and ``seed`` unused).

    Returns
    -------
    Corrector
        ``params["M"]`` of shape (k, m): ``target ≈ responses @ M``.
    """
    M = _fit_matrix(problem, noise, copies, seed, ridge, degree=1)
    return Corrector("Cheung 2004", problem, lambda c: c @ M, {"M": M, "noise": noise})


def fit_Finlayson2015(
    problem: CorrectionProblem,
    *,
    degree: int = 2,
    ridge: float = 1e-9,
    noise: float | NoiseModel = 0.0,
    copies: int = 10,
    seed: int = 0,
) -> Corrector:
    """Root-polynomial regression of any number of channels (Finlayson et al. 2015).

    Parameters
    ----------
    problem : CorrectionProblem
    degree
        Root-polynomial degree (2 by default, the paper's recommendation for small training sets).
    ridge
        Relative Tikhonov term.
    noise, copies, seed
        Train on noisy replicas (see :func:`fit_Cheung2004`).

    Returns
    -------
    Corrector
        ``params["M"]`` of shape (n_terms, m): ``target ≈ root_polynomial_terms(c) @ M``.
    """
    M = _fit_matrix(problem, noise, copies, seed, ridge, degree=degree)
    M32 = M.astype(np.float32)  # float32 photos: ΔE00 changes by < 0.01 (test_noise_image.py)
    return Corrector(
        "Finlayson 2015",
        problem,
        lambda c: _terms_by_row(c, degree).T @ (M32 if c.dtype == np.float32 else M),
        {"M": M, "degree": degree, "noise": noise},
    )


def fit_Dyer2017(problem: CorrectionProblem) -> Corrector:
    """ACES input device transform (``colour.matrix_idt``, rawtoaces v1), back to target XYZ.

    ``colour.matrix_idt`` fits a 3 × 3 matrix from white-balanced camera RGB to ACES2065-1 by
    minimising CIELAB error on the training set, with the training XYZ adapted (CAT02) to the
    ACES white. The estimate here is that matrix followed by ACES2065-1 → XYZ and CAT02 back to
    the scene illuminant's white, then expressed in the target's coordinates.

    Raises
    ------
    SpectralDataError
        When the source is not a single 3-channel camera (the IDT is defined for RGB only).
    """
    if problem.k != 3:
        raise SpectralDataError(
            f"the ACES IDT (Dyer 2017) needs exactly one RGB camera; this problem has {problem.k} "
            "channels. Use 'Cheung 2004' or 'Finlayson 2015' for stacked cameras."
        )
    w = problem.wavelengths
    white = problem.white_XYZ
    cmfs = colour.MultiSpectralDistributions(
        problem.Psi @ problem.XYZ_from_target, w, labels=["x", "y", "z"], name="target"
    )
    # matrix_idt multiplies by the illuminant itself: give it the plain sensitivities (Φ is S·E·Δλ
    # per channel, the constant factors are removed by its white balance) and a flat light.
    sens = colour.characterisation.RGB_CameraSensitivities(problem.Phi, w, labels=["r", "g", "b"])
    flat = colour.SpectralDistribution(np.ones(w.size), w, name="flat")
    cmfs_flat = colour.MultiSpectralDistributions(cmfs.values, w, labels=["x", "y", "z"])
    train = colour.MultiSpectralDistributions(
        problem.training.T, w, labels=[str(i) for i in range(problem.training.shape[0])]
    )
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        M, _, _, RGB = colour.matrix_idt(sens, flat, train, cmfs_flat, additional_data=True)
    C = problem.source_of(problem.training)
    scale = np.median(RGB / np.maximum(C, 1e-12), axis=0)  # our white-balanced → theirs (diagonal)
    aces = colour.RGB_COLOURSPACES["ACES2065-1"]
    A = colour.adaptation.matrix_chromatic_adaptation_VonKries(
        colour.xy_to_XYZ(aces.whitepoint), white / white[1], transform="CAT02"
    )
    X2T = np.linalg.pinv(problem.XYZ_from_target)
    full = np.diag(scale) @ M.T @ aces.matrix_RGB_to_XYZ.T @ A.T
    s = float(np.sum((C @ full @ X2T) * problem.target_of(problem.training)) / np.sum((C @ full @ X2T) ** 2))
    full = s * full @ X2T
    return Corrector("Dyer 2017", problem, lambda c: c @ full, {"M": full, "M_IDT": M})


#: The regressions' registry entries (names, aliases, properties; see
#: :data:`zonotope.correct.CORRECTION_METHODS`, which holds them too). Here, below the MMV-based
#: estimators, because Prior resolves its ``regression=`` option against them.
REGRESSIONS: MethodRegistry = MethodRegistry("regression")
REGRESSIONS.register(
    "Cheung 2004",
    fit_Cheung2004,
    aliases=("least squares", "matrix", "lstsq"),
    closed_form=True,
    needs_mmv=False,
    centroid=False,
    noise_option="noise",
)
REGRESSIONS.register(
    "Finlayson 2015",
    fit_Finlayson2015,
    aliases=("root-polynomial", "rootpoly"),
    closed_form=True,
    needs_mmv=False,
    centroid=False,
    noise_option="noise",
)
REGRESSIONS.register(
    "Dyer 2017",
    fit_Dyer2017,
    aliases=("idt", "aces idt", "aces"),
    closed_form=True,
    needs_mmv=False,
    centroid=False,
    noise_option=None,
)
