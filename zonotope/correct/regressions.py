"""Regression estimators of :mod:`zonotope.correct`: least-squares matrix (Cheung 2004),
root-polynomial (Finlayson 2015) and the ACES IDT (Dyer 2017)."""

from __future__ import annotations

import itertools
import warnings

import colour
import numpy as np

from .._errors import OptionError, SpectralDataError
from ..utilities.registry import MethodRegistry
from .problem import CorrectionProblem, Corrector

__all__ = ["REGRESSIONS", "fit_Cheung2004", "fit_Dyer2017", "fit_Finlayson2015", "root_polynomial_terms"]


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
    c = np.maximum(np.asarray(responses, dtype=np.float64), 0.0)
    k = c.shape[-1]
    if degree < 1:
        raise OptionError(f"degree={degree!r}: give a polynomial degree ≥ 1.")
    cols = [c[..., i] for i in range(k)]
    for d in range(2, degree + 1):
        for combo in itertools.combinations_with_replacement(range(k), d):
            if len(set(combo)) > 1:
                cols.append(np.prod(c[..., list(combo)], axis=-1) ** (1.0 / d))
    return np.stack(cols, axis=-1)


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


def fit_Cheung2004(
    problem: CorrectionProblem, *, ridge: float = 1e-9, noise: float = 0.0, copies: int = 10, seed: int = 0
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
        have nearly collinear channels, which a noise-free fit exploits).

    Returns
    -------
    Corrector
        ``params["M"]`` of shape (k, m): ``target ≈ responses @ M``.
    """
    C, T = _training(problem, noise, copies, seed)
    M = _lstsq(C, T, ridge)
    return Corrector("Cheung 2004", problem, lambda c: c @ M, {"M": M, "noise": noise})


def fit_Finlayson2015(
    problem: CorrectionProblem,
    *,
    degree: int = 2,
    ridge: float = 1e-9,
    noise: float = 0.0,
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
    C, T = _training(problem, noise, copies, seed)
    M = _lstsq(root_polynomial_terms(C, degree=degree), T, ridge)
    return Corrector(
        "Finlayson 2015",
        problem,
        lambda c: root_polynomial_terms(c, degree=degree) @ M,
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
