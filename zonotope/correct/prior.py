"""Natural-reflectance prior and quadratic programs over the fiber of a response.

The *fiber* of a source response ``c`` is the set of reflectances ``{x ∈ [0, 1]ⁿ : Φᵀx = c}``;
its image under the target generators Ψ is the metamer mismatch volume (MMV) of ``c``. Estimators
that pick one reflectance of the fiber (the most natural one, or the one whose colour is closest
to a regression estimate) land inside the MMV by construction.

The problems here are bounded least squares, solved exactly by a batched active-set method
(:mod:`zonotope.correct.bvls`, scipy's BVLS for the rows it does not settle).
``problem`` arguments are :class:`zonotope.correct.CorrectionProblem` instances (anything with
``Phi (n, k)``, ``Psi (n, m)``, ``m``, ``training (N, n)`` and ``lab_metric``).
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property

import numpy as np

from .._errors import GeometryError, SpectralDataError
from .._tol import INTERIOR_SLACK, METRIC_JITTER, PROJECTION_TIE
from .bvls import box_lsq, fiber_box_lsq

__all__ = [
    "ReflectancePrior",
    "fiber_lsq",
    "interior_solution",
    "map_reflectance",
    "posterior_radius",
    "project_to_mmv",
]

#: 95 % quantile of χ² with 3 degrees of freedom: the radius² (in σ² units) of the 95 % ball of an
#: isotropic 3-D Gaussian, used for the CIELAB spread of a target-space Gaussian.
CHI2_3_95 = 7.814727903251178

#: :func:`fiber_lsq` with one objective block per response builds its ``(rows, p + k, n)`` matrices this
#: many rows at a time (≈ 10 MB for p + k = 40, n = 31).
_ROWS_PER_BLOCK = 1024

#: Whether :func:`fiber_lsq` solves the exact constraint (``noise = 0``) with
#: :func:`zonotope.correct.bvls.fiber_box_lsq` (True) or, as before, by :func:`box_lsq`, which hands
#: those rows to scipy's per-row BVLS (False: the reference twin for the tests and
#: ``benchmarks/bench_profile.py``).
_STIFF_SOLVER = True


def interior_solution(prior: ReflectancePrior, A, values, *, noise=0.0) -> tuple[np.ndarray, np.ndarray]:
    """Closed-form most probable reflectance with ``Aᵀx = values``, ignoring the bounds, and whether it
    lies in [0, 1].

    ``x = μ + ΣA(AᵀΣA + σ²I)⁻¹(values − Aᵀμ)`` minimises the prior energy ``½(x − μ)ᵀΣ⁻¹(x − μ)``
    subject to ``Aᵀx = values`` (``noise = 0``) or plus ``‖Aᵀx − values‖² / 2σ²``. When it lies in
    [0, 1]ⁿ it is *the* solution of the bounded problem too (the bounds are inactive at a feasible
    unconstrained optimum of a convex problem), so the bounded least squares need only be solved for
    the other rows: the exact fast path of :func:`map_reflectance` and :func:`project_to_mmv`.

    Parameters
    ----------
    prior : ReflectancePrior
    A : ndarray of shape (n, p)
        Constraint columns (Φ for a fiber, ``[Φ Ψ]`` for a fiber with a given target colour).
    values : ndarray of shape (N, p)
    noise : float or array_like of shape (p,)
        σ of a Gaussian relaxation of the constraint (0: exact), one per column of ``A`` if an array.

    Returns
    -------
    x : ndarray of shape (N, n)
    interior : ndarray of bool, shape (N,)
        ``0 ≤ x ≤ 1`` (up to :data:`zonotope._tol.INTERIOR_SLACK`): ``x`` is the exact bounded solution.
    """
    A = np.asarray(A, dtype=np.float64)
    V = np.atleast_2d(np.asarray(values, dtype=np.float64))
    SA = prior.cov @ A
    K = A.T @ SA + np.diag(np.broadcast_to(np.asarray(noise, dtype=np.float64) ** 2, (A.shape[1],)))
    x = prior.mean + np.linalg.solve(K, (V - prior.mean @ A).T).T @ SA.T
    return x, (x.min(axis=1) >= -INTERIOR_SLACK) & (x.max(axis=1) <= 1.0 + INTERIOR_SLACK)


def fiber_lsq(Phi, responses, A, b, *, noise: float = 0.0, weight: float = 1e5) -> np.ndarray:
    """Minimise ``‖A x − b‖²`` over reflectances ``0 ≤ x ≤ 1`` that produce ``responses``.

    With ``noise = 0`` the constraint ``Φᵀx = c`` is exact (``x`` lies in the *fiber* of ``c``,
    whose image under Ψ is the metamer mismatch volume); it is imposed as ``weight``-scaled rows
    of a bounded least-squares problem (relative accuracy ≈ 1/weight²). With ``noise = σ > 0``
    those rows have weight ``1/σ``: the Gaussian likelihood ``‖Φᵀx − c‖² / σ²``, always feasible.
    All problems are solved together, exactly, by a batched active-set method
    (:func:`zonotope.correct.bvls.box_lsq`: primal–dual, then primal for rows that cycle; every row it
    returns meets the KKT conditions to :data:`zonotope._tol.BVLS_KKT`). The exact constraint
    (``noise = 0``), too ill-conditioned for its normal equations, is solved with the constraint
    residual as an unknown of its own (:func:`zonotope.correct.bvls.fiber_box_lsq`; measured on 600
    exact-constraint Prior MAP rows: 3.4× faster than scipy's BVLS per row, the same objective to
    2e-13 and reflectances within 1.2e-6). Rows either does not settle within its iteration cap, and
    problems too ill-conditioned (:data:`zonotope._tol.BVLS_CONDITION`), are solved one by one by
    scipy's bounded-variable least squares (``scipy.optimize.lsq_linear(method="bvls")``, Stark &
    Parker 1995, 0.5–2 ms each for 31 bands), as all were before. Measured
    (``benchmarks/bench_correct.py --bvls 2000``, 2 shared cores): 2000 noisy Prior MAP rows (3 cameras,
    9 whitened channels, σ_ref 0.002–0.01) in 0.02 ms per row, 25–32× faster than the per-row scipy
    loop in the same process, answers within 6e-15 of it.

    Parameters
    ----------
    Phi : ndarray of shape (n, k)
    responses : ndarray of shape (N, k)
    A : ndarray of shape (p, n) or (N, p, n)
        Objective rows, shared or one block per response.
    b : ndarray of shape (p,) or (N, p)
    noise
        Response noise σ (response units, white = 1); 0 for the exact constraint.
    weight
        Relative weight of the exact constraint rows (``noise = 0`` only).

    Returns
    -------
    ndarray of shape (N, n)
        Reflectances in [0, 1]. A response outside the object-colour solid (``noise = 0``) gives the
        reflectance whose response is nearest to it.
    """
    Phi = np.asarray(Phi, dtype=np.float64)
    C = np.atleast_2d(np.asarray(responses, dtype=np.float64))
    N, n = C.shape[0], Phi.shape[0]
    A = np.asarray(A, dtype=np.float64)
    if C.ndim != 2 or Phi.ndim != 2 or C.shape[1] != Phi.shape[1] or A.ndim not in (2, 3) or A.shape[-1] != n:
        raise GeometryError(
            f"fiber_lsq: responses {C.shape}, Phi {Phi.shape} and A {A.shape} must be (N, k), (n, k) and "
            "(p, n) or (N, p, n): one response column per column of Phi, one A column per wavelength."
        )
    b = np.broadcast_to(np.asarray(b, dtype=np.float64), (N, A.shape[-2]))
    if noise > 0:
        s = np.full(N if A.ndim == 3 else 1, 1.0 / noise)
    else:
        s = weight * np.linalg.norm(A, 2, axis=(-2, -1)).reshape(-1) / np.linalg.norm(Phi, 2)
    if noise == 0 and _STIFF_SOLVER:  # the exact constraint: too stiff for box_lsq's normal equations
        w = np.broadcast_to(s, (N,))
        if A.ndim == 2:
            return fiber_box_lsq(A, b, Phi, C, w)[0]
        out = np.empty((N, n))
        for i in range(0, N, _ROWS_PER_BLOCK):  # one (p, n) matrix per row: bounded memory
            j = slice(i, i + _ROWS_PER_BLOCK)
            out[j] = fiber_box_lsq(A[j], b[j], Phi, C[j], w[j])[0]
        return out
    R = np.concatenate([b, s[:, None] * C], axis=1)
    if A.ndim == 2:
        return box_lsq(np.vstack([A, s[0] * Phi.T]), R)[0]
    out = np.empty((N, n))
    for i in range(0, N, _ROWS_PER_BLOCK):  # one (p + k, n) matrix per row: bounded memory
        j = slice(i, i + _ROWS_PER_BLOCK)
        M = np.concatenate([A[j], s[j, None, None] * Phi.T], axis=1)
        out[j] = box_lsq(M, R[j])[0]
    return out


@dataclass(frozen=True, eq=False)
class ReflectancePrior:
    """Gaussian model of natural reflectances, ``x ~ N(mean, cov)``.

    Attributes
    ----------
    mean : ndarray of shape (n,)
    cov : ndarray of shape (n, n)
        Sample covariance shrunk towards ``shrinkage · tr(cov)/n · I`` (Ledoit–Wolf style), so
        that it is invertible with fewer samples than wavelengths.
    """

    mean: np.ndarray
    cov: np.ndarray

    @classmethod
    def fit(cls, reflectances, *, shrinkage: float = 0.01) -> ReflectancePrior:
        """Learn the prior from reflectances ``(N, n)``."""
        R = np.asarray(reflectances, dtype=np.float64)
        if R.shape[0] < 2:
            raise SpectralDataError(
                f"a reflectance prior needs at least 2 training samples, got {R.shape[0]}."
            )
        S = np.cov(R.T)
        S = (1 - shrinkage) * S + shrinkage * np.trace(S) / S.shape[0] * np.eye(S.shape[0])
        return cls(R.mean(axis=0), S)

    @cached_property
    def precision(self) -> np.ndarray:
        """Inverse covariance, shape (n, n) (computed once per prior)."""
        return np.linalg.inv(self.cov)

    @cached_property
    def root(self) -> np.ndarray:
        """Upper Cholesky factor ``U`` of the precision (``UᵀU = cov⁻¹``), shape (n, n)."""
        return np.linalg.cholesky(self.precision).T

    def energy(self, x) -> np.ndarray:
        """``½ (x − mean)ᵀ cov⁻¹ (x − mean)`` for reflectances ``(..., n)`` → ``(...)``.

        As ``½ ‖U (x − mean)‖²`` with the Cholesky factor :attr:`root` (one BLAS product; a
        three-operand ``einsum`` took 20× longer on 10⁶ responses)."""
        d = np.asarray(x, dtype=np.float64) - self.mean
        y = d @ self.root.T
        return 0.5 * np.einsum("...i,...i->...", y, y)


def gaussian_radius(problem, targets, covariance) -> np.ndarray:
    """95 % ΔE00 reach of a Gaussian spread of target colours around ``targets (N, m)``.

    With the target-space covariance ``S = Σ λᵢ vᵢvᵢᵀ`` (one ``(m, m)`` for every target, or ``(N, m, m)``)
    the mean squared ΔE00 is ``Σ ΔE00(t, t + √λᵢ vᵢ)²`` (exact where ΔE00 is locally quadratic), and the
    radius that of the 95 % ball of a 3-D Gaussian with that mean square, ``sqrt(mean² · χ²₃(0.95) / 3)``.
    Returns ``(N,)``.
    """
    t = np.atleast_2d(np.asarray(targets, dtype=np.float64))
    lam, vec = np.linalg.eigh(np.asarray(covariance, dtype=np.float64))  # columns are eigenvectors
    mean_sq = np.zeros(t.shape[0])
    for i in range(problem.m):
        step = np.sqrt(np.maximum(lam[..., i], 0.0))[..., None] * vec[..., :, i]
        mean_sq += problem.delta_E(t + step, t) ** 2
    return np.sqrt(mean_sq * CHI2_3_95 / 3.0)


def posterior_radius(problem, targets, noise, *, prior: ReflectancePrior | None = None) -> np.ndarray:
    """95 % credible radius in ΔE00 of the colour of a surface seen through its responses, per target.

    The surface's reflectance is taken from the Gaussian natural-reflectance prior ``N(μ, Σ)``
    (:class:`ReflectancePrior` of ``problem.training`` unless given) and seen with Gaussian noise σ per
    channel, bounds ignored. Its colour's posterior covariance is
    ``Ψᵀ(Σ − ΣΦ(ΦᵀΣΦ + diag σ²)⁻¹ΦᵀΣ)Ψ``, the same for every response, and each target gets its ΔE00
    reach (:func:`gaussian_radius`). It holds both what the cameras cannot tell apart (metamer mismatch
    as the prior weighs it) and what their noise hides; in closed form, so an image of any size gets
    one per pixel (Prior's own credible radius, :meth:`Corrector.with_uncertainty`, computes an MMV
    wherever its gate opens: 270–680× the time on fused capture views, with similar coverage;
    docs/notes/2026-11-30-uncertainty-map.md).

    Parameters
    ----------
    problem : CorrectionProblem
    targets : array_like of shape (N, m)
        The estimates the radius is drawn around (their colour sets the ΔE00 scale).
    noise : float or array_like of shape (k,)
        Response noise σ per channel (white = 1).
    prior : ReflectancePrior, optional

    Returns
    -------
    ndarray of shape (N,)
    """
    if prior is None:
        prior = ReflectancePrior.fit(problem.training)
    A = np.asarray(problem.Phi, dtype=np.float64)
    sigma = np.broadcast_to(np.asarray(noise, dtype=np.float64), (A.shape[1],))
    if not (np.isfinite(sigma).all() and (sigma >= 0).all()):
        raise SpectralDataError(f"noise: give finite σ >= 0 per channel; got {np.asarray(noise)!r}.")
    SA = prior.cov @ A
    K = A.T @ SA + np.diag(sigma**2)
    post = prior.cov - SA @ np.linalg.solve(K, SA.T)
    Psi = np.asarray(problem.Psi, dtype=np.float64)
    return gaussian_radius(problem, targets, Psi.T @ post @ Psi)


def map_reflectance(problem, responses, prior: ReflectancePrior, *, noise: float = 0.0) -> np.ndarray:
    """Most probable natural reflectance that the source could have seen.

    ``argmin_x ½ (x − μ)ᵀΣ⁻¹(x − μ)  s.t.  Φᵀx = c,  0 ≤ x ≤ 1`` (see :func:`fiber_lsq`).

    Rows whose unconstrained optimum already lies in [0, 1]ⁿ are solved in closed form
    (:func:`interior_solution`, exact); only the others go to the bounded least squares. Measured on
    the natural sets of ``zonotope evaluate`` (400–700 nm / 10 nm, D65, rawtoaces 190 prior): 96 % of
    responses take the closed form with Nikon 5100 alone, 98 % with Nikon 5100 + Sigma SD Merrill
    (atypical spectra: 68 % and 43 %).

    Parameters
    ----------
    problem : CorrectionProblem
    responses : ndarray of shape (N, k)
    prior : ReflectancePrior

    Returns
    -------
    ndarray of shape (N, n)
    """
    C = np.atleast_2d(np.asarray(responses, dtype=np.float64))
    x0, interior = interior_solution(prior, problem.Phi, C, noise=noise)
    return _bounded_map(problem, C, prior, x0, interior, noise=noise)


def _bounded_map(problem, C, prior: ReflectancePrior, x0, interior, *, noise: float = 0.0) -> np.ndarray:
    """:func:`map_reflectance` of the responses ``C (N, k)`` from their closed-form solution ``x0`` and
    its ``interior`` flags (:func:`interior_solution`, not modified): only the other rows are solved."""
    x = np.array(x0, dtype=np.float64)
    rest = ~interior
    if rest.any():
        x[rest] = fiber_lsq(problem.Phi, C[rest], prior.root, prior.root @ prior.mean, noise=noise)
    return np.clip(x, 0.0, 1.0)


def project_to_mmv(
    problem,
    responses,
    estimates,
    *,
    prior: ReflectancePrior | None = None,
    noise: float = 0.0,
    tol_dE: float = 0.01,
) -> tuple[np.ndarray, np.ndarray]:
    """Closest point of the metamer mismatch volume to each estimate, in linearised CIELAB.

    Minimises ``(Ψᵀx − t)ᵀ W (Ψᵀx − t)`` over the fiber of ``c`` (reflectances in [0, 1] with
    ``Φᵀx = c``), with ``W = JᵀJ`` the CIELAB metric at ``t`` (:meth:`CorrectionProblem.lab_metric`).
    This is the projection of ``t`` onto the MMV ``Ψ{x : Φᵀx = c, 0 ≤ x ≤ 1}`` in that metric,
    computed in reflectance space (:func:`fiber_lsq`); a tiny prior term picks a natural
    reflectance among the ties. An estimate is certified inside the MMV without solving anything
    when the most probable reflectance with ``Φᵀx = c`` and ``Ψᵀx = t`` (closed form,
    :func:`interior_solution`) lies in [0, 1]ⁿ — it is then a witness reflectance (98–99 % of
    root-polynomial estimates on natural sets); only the other rows are solved. With ``noise = σ``
    the witness needs ``Ψᵀx = t`` exactly and ``Φᵀx ≈ c`` under the Gaussian likelihood of σ (the
    same relaxation as the solved rows).

    Parameters
    ----------
    problem : CorrectionProblem
    responses : ndarray of shape (N, k)
    estimates : ndarray of shape (N, m)
    prior : ReflectancePrior, optional
        Tie-breaker; default fitted on the problem's training set.
    noise
        Response noise σ; > 0 relaxes the fiber constraint (see :func:`fiber_lsq`).
    tol_dE
        Estimates whose projection moves them by less than this (ΔE*ab, linearised) are returned
        unchanged (they are inside the MMV up to the solver's accuracy).

    Returns
    -------
    projected : ndarray of shape (N, m)
    inside : ndarray of bool, shape (N,)
        Whether each estimate already lay in the MMV.
    """
    prior = prior or ReflectancePrior.fit(problem.training)
    t = np.atleast_2d(np.asarray(estimates, dtype=np.float64))
    C = np.atleast_2d(np.asarray(responses, dtype=np.float64))
    sigma = np.concatenate([np.full(problem.k, float(noise)), np.zeros(problem.m)])
    _, witness = interior_solution(
        prior, np.hstack([problem.Phi, problem.Psi]), np.hstack([C, t]), noise=sigma
    )
    if witness.all():
        return t.copy(), witness
    if witness.any():
        rest = ~witness
        y, ins = project_to_mmv(problem, C[rest], t[rest], prior=prior, noise=noise, tol_dE=tol_dE)
        out = t.copy()
        out[rest] = y
        inside = witness.copy()
        inside[rest] = ins
        return out, inside
    W = problem.lab_metric(t)  # (N, m, m)
    L = np.swapaxes(np.linalg.cholesky(W + METRIC_JITTER * np.eye(problem.m)), -1, -2)  # LᵀL = W
    U = prior.root
    tie = (
        PROJECTION_TIE
        * np.linalg.norm(L, 2, axis=(-2, -1)).mean()
        * np.linalg.norm(problem.Psi, 2)
        / np.linalg.norm(U, 2)
    )
    A = np.concatenate([L @ problem.Psi.T, np.broadcast_to(tie * U, (t.shape[0], *U.shape))], axis=1)
    b = np.concatenate(
        [np.einsum("nij,nj->ni", L, t), np.broadcast_to(tie * U @ prior.mean, (t.shape[0], U.shape[0]))],
        axis=1,
    )
    y = fiber_lsq(problem.Phi, C, A, b, noise=noise) @ problem.Psi
    d = y - t
    moved = np.sqrt(np.einsum("ni,nij,nj->n", d, W, d))
    inside = moved < tol_dE
    return np.where(inside[:, None], t, y), inside
