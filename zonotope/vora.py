"""Vora value: how well the span of a set of sensors covers the span of the eye's sensors.

v(Q, X) = tr(P_Q P_X) / rank(X), with P_A = A A⁺ the orthogonal projector onto the column space
of A (Vora & Trussell 1993, eq. 9). Q and X are ``(n_wavelengths, channels)`` matrices of
sensitivities × illuminant on one grid. v = 1 when the camera spans the eye's space (it is
colorimetric), v = 0 when it is orthogonal to it. Projectors make the value invariant to any
invertible mixing of the channels, and rank-deficient Q (duplicated or dependent channels) is
legal.

References
----------
.. [1] Vora, P. L., & Trussell, H. J. (1993). Measure of goodness of a set of color-scanning
   filters. JOSA A, 10(7), 1499–1508.
"""

from __future__ import annotations

import os
from collections.abc import Sequence
from dataclasses import dataclass
from itertools import combinations

import numpy as np

from ._errors import OptionError, SpectralDataError, UnknownMethodError
from ._tol import TOL
from .spectra import builtin as spectra
from .spectra.loading import load_camera

__all__ = ["CameraSetScore", "projector", "rank_camera_sets", "vora_value"]


def projector(A, *, rtol: float = TOL.rank) -> tuple[np.ndarray, int]:
    """Orthogonal projector onto the column space of A, and its rank.

    Parameters
    ----------
    A : array_like of shape (n, k)

    Returns
    -------
    P : ndarray of shape (n, n)
    rank : int
        Numerical rank of A with its columns scaled to unit length (zero columns dropped).
    """
    A = spectra.float_array(A, "A")
    if A.ndim != 2:
        raise SpectralDataError(f"expected a (n_wavelengths, channels) matrix, got shape {A.shape}.")
    if not np.all(np.isfinite(A)):  # a NaN column would otherwise be dropped as if it were zero
        bad = sorted({int(c) for c in np.nonzero(~np.isfinite(A))[1]})
        raise SpectralDataError(
            f"channels {bad} of a ({A.shape[0]}, {A.shape[1]}) sensitivity matrix hold "
            "NaN or inf; fill or trim the data (nothing is dropped silently)."
        )
    # unit columns first: the column space is the same, and a channel many orders of magnitude
    # weaker than another (e.g. 1e-226 beside 1) still counts instead of falling under rtol
    peak = np.abs(A).max(axis=0) if A.size else np.zeros(A.shape[1])
    A = A[:, peak > 0] / peak[peak > 0]  # max-scaling first: squares of 1e-226 underflow
    A = A / np.linalg.norm(A, axis=0)
    U, s, _ = np.linalg.svd(A, full_matrices=False)
    r = int(np.sum(s > rtol * (s[0] if s.size else 0.0)))
    Ur = U[:, :r]
    return Ur @ Ur.T, r


def vora_value(Q, X) -> float:
    """Vora value v(Q, X) = tr(P_Q P_X) / rank(X) ∈ [0, 1].

    Parameters
    ----------
    Q : array_like of shape (n, k) or colour.MultiSpectralDistributions
        Camera sensitivities × illuminant (any number of channels, e.g. 6 for two cameras), such as
        :func:`zonotope.generators` returns.
    X : array_like of shape (n, m) or colour.MultiSpectralDistributions
        Target (eye) sensitivities × illuminant on the same grid.

    Examples
    --------
    >>> import numpy as np
    >>> X = np.random.default_rng(0).random((31, 3))
    >>> round(vora_value(X @ np.array([[1, 2, 0], [0, 1, 0], [1, 0, 3]]), X), 12)
    1.0
    >>> import zonotope
    >>> G = zonotope.generators("Nikon 5100 (NPL)", shape=np.arange(400, 701, 10))
    >>> 0 < vora_value(G, zonotope.generators("CIE 1931 2°", shape=np.arange(400, 701, 10))) <= 1
    True
    """
    grids = [np.asarray(A.wavelengths) for A in (Q, X) if hasattr(A, "wavelengths")]
    if len(grids) == 2 and not (grids[0].shape == grids[1].shape and np.allclose(grids[0], grids[1])):
        raise SpectralDataError("Q and X are on different wavelength grids; resample them onto one.")
    Q = spectra.float_array(getattr(Q, "values", Q), "Q")
    X = spectra.float_array(getattr(X, "values", X), "X")
    if Q.ndim != 2 or X.ndim != 2 or Q.shape[0] != X.shape[0]:
        raise SpectralDataError(
            f"Q {Q.shape} and X {X.shape} must be (n, k) and (n, m) on the same wavelength grid."
        )
    PQ, _ = projector(Q)
    PX, rx = projector(X)
    if rx == 0:
        raise SpectralDataError("the target X is zero: its Vora value is undefined.")
    # tr(P_Q P_X) = ‖U_Qᵀ U_X‖_F², computed through the projectors' symmetric product
    return float(np.clip(np.einsum("ij,ji->", PQ, PX) / rx, 0.0, 1.0))


@dataclass(frozen=True)
class CameraSetScore:
    """One camera set and its Vora value against the target."""

    cameras: tuple[str, ...]
    channels: int
    vora: float


def _matrices(cameras, target, illuminant, shape):
    cams = [load_camera(c) if isinstance(c, str | os.PathLike) else c for c in cameras]
    tgt = spectra.observer(target) if isinstance(target, str) else target
    if shape is None:
        shape = spectra.common_shape(*cams, tgt, spectra.illuminant(illuminant))
    X = spectra.generators(tgt, illuminant, shape).values
    Qs = [spectra.generators(c, illuminant, shape).values for c in cams]
    names = [getattr(c, "name", f"camera {i}") for i, c in enumerate(cams)]
    return names, Qs, X, shape


def rank_camera_sets(
    cameras: Sequence,
    target="Stockman & Sharpe 2°",
    illuminant="D65",
    shape=None,
    *,
    method: str = "pairs",
    size: int = 2,
) -> list[CameraSetScore]:
    """Rank sets of cameras by the Vora value of their stacked channels against ``target``.

    Parameters
    ----------
    cameras
        Camera names or colour MSDS (at least one).
    method
        ``"pairs"``: every subset of ``size`` cameras (default pairs), best first.
        ``"greedy"``: start from the best single camera and add, one at a time, the camera that
        raises the value most; returns the chain (1, 2, ..., len(cameras) cameras).
    shape
        Common wavelength grid; default the intersection of all ranges (see spectra).

    Returns
    -------
    list of CameraSetScore
    """
    if not cameras:
        raise SpectralDataError("rank_camera_sets needs at least one camera.")
    names, Qs, X, _ = _matrices(cameras, target, illuminant, shape)

    def score(idx):
        Q = np.concatenate([Qs[i] for i in idx], axis=1)
        return CameraSetScore(tuple(names[i] for i in idx), Q.shape[1], vora_value(Q, X))

    if method == "pairs":
        if not 1 <= size <= len(Qs):
            raise OptionError(f"size={size!r}: give a set size in 1..{len(Qs)} (the number of cameras).")
        out = [score(idx) for idx in combinations(range(len(Qs)), size)]
        return sorted(out, key=lambda s: -s.vora)
    if method == "greedy":
        chosen: list[int] = []
        chain = []
        while len(chosen) < len(Qs):
            best = max((i for i in range(len(Qs)) if i not in chosen), key=lambda i: score([*chosen, i]).vora)
            chosen.append(best)
            chain.append(score(chosen))
        return chain
    raise UnknownMethodError(
        f"method={method!r}: choose 'pairs' or 'greedy'.",
        argument="method",
        value=method,
        valid=("pairs", "greedy"),
    )
