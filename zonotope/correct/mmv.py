"""Estimators of :mod:`zonotope.correct` that use metamer mismatch volumes or a reflectance prior:
MMV centroid, projected regression, constrained MAP and the Bayes-gated ``"Prior"`` mixture."""

from __future__ import annotations

import contextlib
import dataclasses
import math
import os
import threading
from dataclasses import dataclass

import numpy as np

from .._errors import OptionError, SpectralDataError
from .._tol import (
    CENTROID_MIN_WEIGHT,
    DELTA_SIGMAS,
    GATE_NONE,
    GATE_SURE,
    NOISE_JACOBIAN_STEP,
    SCALED_SAME,
    VOLUME_FLOOR,
)
from ..utilities.config import check_count, check_nonnegative, with_options
from .noise import NoiseModel, noisy, scalar_sigma
from .prior import (
    ReflectancePrior,
    _bounded_map,
    gaussian_radius,
    interior_solution,
    map_reflectance,
    project_to_mmv,
)
from .problem import CorrectionProblem, Corrector
from .regressions import REGRESSIONS, fit_Cheung2004, fit_Finlayson2015

__all__ = [
    "CENTROID_MIN_WEIGHT",
    "GATE_NONE",
    "GATE_SURE",
    "MIX_GRID",
    "PriorConfig",
    "fit_Centroid",
    "fit_MAP",
    "fit_Prior",
    "fit_Projection",
    "learn_mix",
    "mmv_centroids",
    "select_regression",
]


_LOG_VOLUMES: dict[tuple, list] = {}  # (shape, max_terms, seed) → [(Φ / column max, Φ, log volume), ...]
_LOG_VOLUMES_REFERENCE: dict[bytes, float] = {}  # Φ bytes → log volume (the reference twin's memo)
_SUBSETS: dict[tuple, np.ndarray] = {}  # (n, k, seed) → the sampled k-subsets of _log_volume_uncached
_LOG_FLOOR = math.log(VOLUME_FLOOR)  # the log volume of a degenerate solid (volumes are clamped)


def _log_volume(Phi: np.ndarray, *, max_terms: int = 2_000_000, seed: int = 0) -> float:
    """Log k-volume of the source object-colour solid (exact, or sampled for large C(n, k));
    memoised in this process per Φ *up to a scaling of its channels*.

    Scaling channel ``j`` of Φ by ``s_j`` (``Φ diag(s)``, e.g. :func:`splat.fusion.whitened`) scales
    every k × k minor by ``∏ s_j``, hence the exact volume (a sum of minors) and the sampled estimate
    (a mean of minors over k-subsets that depend on ``n``, ``k`` and ``seed`` only) alike:
    ``log vol(Φ diag(s)) = log vol(Φ) + Σ log |s_j|``. So a Φ that equals a memoised one up to
    channel scaling (compared with each channel divided by its largest |entry|, within ``SCALED_SAME``) takes
    the memoised value plus the log ratio of the channels' largest entries, without recomputing; this
    differs from a direct computation (:func:`_log_volume_reference`) by rounding only (< 1e-13
    measured, ``tests/test_prior_fit_speed.py``). An identical Φ gets the memoised value itself.
    """
    Phi = np.ascontiguousarray(Phi, dtype=np.float64)
    top = np.max(np.abs(Phi), axis=0) if Phi.ndim == 2 and Phi.size else np.zeros(1)
    if not np.all(np.isfinite(top)) or not np.all(top > 0):  # no channel scaling to factor out
        return _log_volume_reference(Phi, max_terms=max_terms, seed=seed)
    unit = Phi / top
    entries = _LOG_VOLUMES.setdefault((Phi.shape, max_terms, seed), [])
    for unit_0, Phi_0, log_vol in entries:
        if np.array_equal(Phi_0, Phi):
            return log_vol
        if np.allclose(unit_0, unit, rtol=0.0, atol=SCALED_SAME):
            top_0 = np.max(np.abs(Phi_0), axis=0)
            return max(log_vol + float(np.sum(np.log(top) - np.log(top_0))), _LOG_FLOOR)
    log_vol = _log_volume_uncached(Phi, max_terms=max_terms, seed=seed)
    if log_vol > _LOG_FLOOR + 1.0:  # a clamped (degenerate) volume does not scale: never reused
        if sum(len(v) for v in _LOG_VOLUMES.values()) >= 64:
            _LOG_VOLUMES.clear()
            entries = _LOG_VOLUMES.setdefault((Phi.shape, max_terms, seed), [])
        entries.append((unit, Phi.copy(), log_vol))
    return log_vol


def _log_volume_reference(Phi: np.ndarray, *, max_terms: int = 2_000_000, seed: int = 0) -> float:
    """Reference twin of :func:`_log_volume`: computed for every distinct Φ (memoised per exact Φ)."""
    key = np.ascontiguousarray(Phi, dtype=np.float64).tobytes() + repr((Phi.shape, max_terms, seed)).encode()
    if key not in _LOG_VOLUMES_REFERENCE:
        if len(_LOG_VOLUMES_REFERENCE) > 64:
            _LOG_VOLUMES_REFERENCE.clear()
        _LOG_VOLUMES_REFERENCE[key] = _log_volume_uncached(Phi, max_terms=max_terms, seed=seed)
    return _LOG_VOLUMES_REFERENCE[key]


def _clear_log_volume_caches() -> None:
    """Forget every memoised log volume and sampled subset (benchmarks time a cold process with it)."""
    _LOG_VOLUMES.clear()
    _LOG_VOLUMES_REFERENCE.clear()
    _SUBSETS.clear()


def _subsets(n: int, k: int, seed: int) -> np.ndarray:
    """The 200 000 seeded random k-subsets of ``range(n)`` that the sampled volume averages over,
    ``(200000, k)``; they depend on ``n``, ``k`` and ``seed`` only (memoised, as uint8 when n ≤ 256)."""
    key = (n, k, seed)
    if key not in _SUBSETS:
        rng = np.random.default_rng(seed)
        idx = np.argsort(rng.random((200_000, n)), axis=1)[:, :k]
        _SUBSETS.clear()  # one entry: a process samples one source solid's shape
        _SUBSETS[key] = idx.astype(np.uint8) if n <= 256 else idx
    return _SUBSETS[key]


def _log_volume_uncached(Phi: np.ndarray, *, max_terms: int, seed: int) -> float:
    n, k = Phi.shape
    if k == 3 or math.comb(n, k) <= max_terms:
        from ..geometry.solid import VolumeUnderflowError, Zonotope

        try:
            volume = Zonotope(Phi).volume
        except VolumeUnderflowError:  # below float64's range: the floor, as for the sampled estimate
            volume = 0.0
        return float(np.log(max(volume, VOLUME_FLOOR)))
    idx = _subsets(n, k, seed)  # unbiased estimate: C(n, k) × mean |det| of random k-subsets
    dets = np.abs(np.linalg.det(Phi[idx]))
    return float(np.log(math.comb(n, k)) + np.log(max(dets.mean(), VOLUME_FLOOR)))


def mmv_centroids(
    problem: CorrectionProblem,
    responses,
    *,
    eps: float = 1e-3,
    delta: float = 0.0,
    executor=None,
    volumes: bool = False,
):
    """Volume centroids of the metamer mismatch volumes of ``responses (N, k)`` → ``(N, m)``.

    Uses :func:`zonotope.mismatch.metamer_mismatch_batch` on the problem's Φ and Ψ (responses
    refined side by side); a response outside the source solid is replaced by the nearest feasible
    one (``on_infeasible="nearest"``). ``executor`` (e.g. :func:`zonotope.parallel.executor`) runs
    the chunks elsewhere; the results are identical to the serial ones. With ``volumes=True`` the
    MMV volumes ``(N,)`` are returned too (the lower certified bound, target units).
    """
    from ..mismatch.volume import metamer_mismatch_batch

    C = np.asarray(responses, dtype=np.float64)
    out = metamer_mismatch_batch(
        problem.Phi,
        problem.Psi,
        C,
        eps=eps,
        delta=delta,
        on_infeasible="nearest",
        outer=False,
        executor=executor,
    )
    return (out.centroids, out.volumes) if volumes else out.centroids


def fit_Centroid(
    problem: CorrectionProblem, *, eps: float = 1e-3, delta: float = 0.0, executor=None
) -> Corrector:
    """The volume centroid of the metamer mismatch volume (the estimate that ignores priors).

    Parameters
    ----------
    problem : CorrectionProblem
    eps
        Certification tolerance of the MMV (response units); the certified MMV's centroid is used
        (exact volume centroid for ``eps = 0``).
    delta
        Per-channel response tolerance of the MMV (``DELTA_SIGMAS · σ`` with noisy responses).
    executor
        Where the MMV chunks run (:func:`zonotope.parallel.executor`); None: this process.
        Results are identical either way.
    """
    return Corrector(
        "Centroid",
        problem,
        lambda c: mmv_centroids(problem, c, eps=eps, delta=delta, executor=executor),
        {"eps": eps, "delta": delta},
    )


def fit_Projection(
    problem: CorrectionProblem, *, degree: int = 2, noise: float | NoiseModel = 0.0
) -> Corrector:
    """Root-polynomial estimate projected onto the MMV in linearised CIELAB when outside.

    See :func:`project_to_mmv`. Inside estimates are returned unchanged, so on natural colours this
    equals ``"Finlayson 2015"``; outside ones move to the closest physically possible colour.
    """
    reg = fit_Finlayson2015(problem, degree=degree, noise=noise)
    prior = ReflectancePrior.fit(problem.training)
    sigma = scalar_sigma(noise, problem.source_of(problem.training))

    def predict(c):
        return project_to_mmv(problem, c, reg(c), prior=prior, noise=sigma)[0]

    return Corrector("Projection", problem, predict, {"regression": reg})


def fit_MAP(
    problem: CorrectionProblem, *, shrinkage: float = 0.01, noise: float | NoiseModel = 0.0
) -> Corrector:
    """Ψᵀ of the most probable natural reflectance in the fiber (:func:`map_reflectance`).

    A Gaussian prior learnt from the training set, restricted to physically possible reflectances
    that reproduce the response exactly. Always inside the MMV. Robust on atypical spectra,
    but close to a linear (Wiener) estimate on natural ones, hence behind root-polynomials there.
    """
    prior = ReflectancePrior.fit(problem.training, shrinkage=shrinkage)
    sigma = scalar_sigma(noise, problem.source_of(problem.training))

    def predict(c):
        return map_reflectance(problem, c, prior, noise=sigma) @ problem.Psi

    return Corrector("MAP", problem, predict, {"prior": prior})


def select_regression(
    problem: CorrectionProblem, *, degree: int = 2, noise: float = 0.0, folds: int = 10, seed: int = 0
) -> tuple[Corrector, dict]:
    """The better of the linear matrix and the root-polynomial, by k-fold cross-validation on the
    training set only.

    Each candidate (``"Cheung 2004"``, ``"Finlayson 2015"`` of ``degree``) is fitted on ``folds − 1``
    folds of the training reflectances and scored by the CIEDE2000 of the held-out fold (seeded
    folds; with ``noise > 0`` the held-out responses get seeded noise σ); the one with the lower
    mean wins and is refitted on the whole training set. No test data are involved.

    Returns
    -------
    regression : Corrector
    cv : dict
        ``"scores"``: mean held-out ΔE00 per candidate; ``"errors"``: the winner's held-out ΔE00 per
        training sample; ``"errors_ab"``: the same in ΔE*ab; ``"order"``: the training sample of each
        error (indices into ``problem.training``).
    """
    R = problem.training
    folds = int(max(2, min(folds, R.shape[0])))
    perm = np.random.default_rng(seed).permutation(R.shape[0])
    parts = np.array_split(perm, folds)
    rng = np.random.default_rng(seed + 1)
    if isinstance(noise, NoiseModel):  # held-out responses with the model's noise at their level
        draws = [noisy(problem.source_of(R[f]), noise, rng) - problem.source_of(R[f]) for f in parts]
    else:
        draws = [rng.normal(0.0, noise, (f.size, problem.k)) if noise > 0 else 0.0 for f in parts]
    candidates = {
        "Cheung 2004": lambda pb: fit_Cheung2004(pb, noise=noise),
        "Finlayson 2015": lambda pb: fit_Finlayson2015(pb, degree=degree, noise=noise),
    }
    scores, errors, errors_ab = {}, {}, {}
    for name, fit in candidates.items():
        est_all, ref_all = [], []
        try:
            for f, z in zip(parts, draws):
                sub = dataclasses.replace(problem, training=R[np.setdiff1d(perm, f)])
                est_all.append(fit(sub)(problem.source_of(R[f]) + z))
                ref_all.append(problem.target_of(R[f]))
        except SpectralDataError:  # fewer training samples than regression terms
            continue
        est, ref = np.concatenate(est_all), np.concatenate(ref_all)
        errors[name] = problem.delta_E(est, ref)
        errors_ab[name] = np.linalg.norm(problem.to_Lab(est) - problem.to_Lab(ref), axis=-1)
        scores[name] = float(np.mean(errors[name]))
    if not scores:
        raise SpectralDataError(
            f"training set of {R.shape[0]} samples is too small for cross-validation of the regressions; "
            "use a larger one (e.g. 'rawtoaces 190')."
        )
    best = min(scores, key=scores.get)
    cv = {
        "scores": scores,
        "errors": errors[best],
        "errors_ab": errors_ab[best],
        "order": np.concatenate(parts),
    }
    return candidates[best](problem), cv


def _ab_to_00(problem: CorrectionProblem, target: np.ndarray, radius_ab: np.ndarray) -> np.ndarray:
    """ΔE00 reach of a CIELAB ball of radius ``radius_ab`` around each target colour: the largest
    CIEDE2000 from its centre to the ball's six axis points (ΔE00 is not a Euclidean metric)."""
    import colour

    lab = problem.to_Lab(target)
    best = np.zeros(lab.shape[0])
    for axis in range(3):
        for sign in (-1.0, 1.0):
            step = np.zeros(3)
            step[axis] = sign
            best = np.maximum(best, colour.delta_E(lab, lab + radius_ab[:, None] * step, method="CIE 2000"))
    return best


def _gate(problem: CorrectionProblem, prior: ReflectancePrior, *, noise: float, odds: float, log_vol: float):
    """The posterior probability of "natural", ``weights(c, x)``, for responses ``c (N, k)`` and their
    MAP reflectances ``x (N, n)`` under ``prior`` (see :func:`fit_Prior`)."""
    Sc = problem.Phi.T @ prior.cov @ problem.Phi + noise**2 * np.eye(problem.k)
    half_logdet = 0.5 * np.linalg.slogdet(2 * np.pi * Sc)[1]

    def weights(c, x):
        E = prior.energy(x)
        if noise > 0:
            E = E + 0.5 * np.sum((x @ problem.Phi - c) ** 2, axis=-1) / noise**2
        logit = np.log(odds) - E - half_logdet + log_vol
        return 0.5 * (1.0 + np.tanh(0.5 * logit))  # logistic, overflow-free

    return weights


def _fit_map(problem: CorrectionProblem, prior: ReflectancePrior, c, *, noise: float):
    """MAP reflectances ``x̂ (N, n)`` of responses ``c (N, k)`` and the weight ``b (N,)`` of their
    interior case: ``b = exp(−(U(x̂) − U(x₀)))``, ``U`` the posterior energy (prior energy plus
    ``‖Φᵀx − c‖² / 2σ²`` with noise) and ``x₀`` the minimiser without the bounds
    (:func:`zonotope.correct.prior.interior_solution`). ``b`` is the ratio of the Gaussian posterior density
    at the bounded mode to that at the unbounded one: 1 where ``x̂`` is interior, falling towards 0
    the more the [0, 1] bounds cost the Gaussian model; continuous in ``c``."""
    x0, interior = interior_solution(prior, problem.Phi, c, noise=noise)
    x = _bounded_map(problem, c, prior, x0, interior, noise=noise)  # map_reflectance, closed form reused

    def energy(z):
        U = prior.energy(z)
        return U + 0.5 * np.sum((z @ problem.Phi - c) ** 2, axis=-1) / noise**2 if noise > 0 else U

    b = np.where(interior, 1.0, np.exp(-np.maximum(energy(x) - energy(x0), 0.0)))
    return x, b


def _fit_regression(problem: CorrectionProblem, name: str, *, degree: int, noise: float) -> Corrector:
    if name == "Cheung 2004":
        return fit_Cheung2004(problem, noise=noise)
    return fit_Finlayson2015(problem, degree=degree, noise=noise)


#: Weights of MAP in the atypical branch that :func:`fit_Prior` chooses from by cross-validation.
MIX_GRID: tuple[float, ...] = tuple(np.round(np.linspace(0.0, 1.0, 11), 2))


def learn_mix(
    problem: CorrectionProblem,
    regression: str,
    config: PriorConfig | None = None,
    *,
    seed: int = 0,
    r_nat: float | None = None,
    log_volume: float | None = None,
) -> tuple[tuple[float, float], dict]:
    """Weights ``(λ_in, λ_bd)`` of the MAP estimate in the atypical branch of :func:`fit_Prior`, by
    cross-validation on atypical spectra made from the training set only (options: ``config``, a
    :class:`PriorConfig`: degree, shrinkage, noise, odds, eps, folds, augment, executor; default all
    defaults).

    The MAP weight of a response is ``λ = b λ_in + (1 − b) λ_bd``, ``b`` the weight of its interior
    case (1 where the natural prior's most probable reflectance needs no bound, smaller the more the
    [0, 1] bounds cost the Gaussian; :func:`_fit_map`). Each training fold gives ``augment / folds``
    contrast-stretched spectra (``zonotope.spectra.atypical.sharpened_reflectances``: saturated, band- and
    step-like versions of its natural spectra); the regression and the prior are refitted on the
    other folds, the whole ``"Prior"`` estimate ``w · t_nat + (1 − w) · (λ t_MAP + (1 − λ) t_centroid)``
    is formed for each pair of :data:`MIX_GRID` × :data:`MIX_GRID`. The pair with the lowest mean
    ΔE00 on those held-out spectra wins if it beats the best single λ (``λ_in = λ_bd``) by more than
    the standard error of their paired difference (the one-standard-error rule); otherwise that
    single λ is used (the simpler model). No test data are involved; the two atypical test generators of
    ``zonotope evaluate`` are not used.

    With ``r_nat`` (the natural branch's 95 % radius) it also calibrates the scale ``s ≥ 1`` of the
    atypical branch's credible radius (split conformal, see :func:`fit_Prior`). ``log_volume``: the
    log volume of the source solid when already known (:func:`fit_Prior` passes its own), else
    computed.

    Returns
    -------
    lam : tuple of float
        ``(λ_in, λ_bd)``.
    cv : dict
        ``"scores"``: mean held-out ΔE00 per ``(λ_in, λ_bd)``; ``"n"``: number of augmented spectra;
        ``"interior"``: mean of their ``b``; ``"best"``: the best pair, ``"one"``: the best single λ
        (as a pair), ``"gain"``: the mean paired improvement of ``best`` over ``one``, ``"se"``: its
        standard error; ``"radius_scale"``: ``s``
        (1 without ``r_nat``).
    """
    from ..spectra.atypical import sharpened_reflectances

    cfg = PriorConfig() if config is None else config
    degree, shrinkage, noise_model, odds, eps = cfg.degree, cfg.shrinkage, cfg.noise, cfg.odds, cfg.eps
    noise = scalar_sigma(noise_model, problem.source_of(problem.training))
    augment, executor = cfg.augment, cfg.executor
    R = problem.training
    folds = int(max(2, min(cfg.folds, R.shape[0])))
    perm = np.random.default_rng(seed).permutation(R.shape[0])
    parts = np.array_split(perm, folds)
    rng = np.random.default_rng(seed + 2)
    log_vol = _log_volume(problem.Phi) if log_volume is None else float(log_volume)
    C_all, T_all, nat_all, map_all, w_all, in_all = [], [], [], [], [], []
    for i, f in enumerate(parts):
        X = sharpened_reflectances(R[f], -(-augment // folds), seed=seed + 17 * i)
        if X.shape[0] == 0:
            continue
        sub = dataclasses.replace(problem, training=R[np.setdiff1d(perm, f)])
        prior = ReflectancePrior.fit(sub.training, shrinkage=shrinkage)
        reg = _fit_regression(sub, regression, degree=degree, noise=noise_model)
        C = noisy(problem.source_of(X), noise_model, rng)
        x, b_fold = _fit_map(sub, prior, C, noise=noise)
        in_all.append(b_fold)
        C_all.append(C)
        T_all.append(problem.target_of(X))
        nat_all.append(project_to_mmv(sub, C, reg(C), prior=prior, noise=noise)[0])
        map_all.append(x @ problem.Psi)
        w_all.append(_gate(sub, prior, noise=noise, odds=odds, log_vol=log_vol)(C, x))
    C, T = np.concatenate(C_all), np.concatenate(T_all)
    t_nat, t_map, w = np.concatenate(nat_all), np.concatenate(map_all), np.concatenate(w_all)[:, None]
    b_in = np.concatenate(in_all)
    t_cen, vol = mmv_centroids(
        problem, C, eps=eps, delta=DELTA_SIGMAS * noise, executor=executor, volumes=True
    )

    def blend(pair):
        lam_rows = (b_in * pair[0] + (1 - b_in) * pair[1])[:, None]
        return lam_rows * t_map + (1 - lam_rows) * t_cen

    errors = {
        (float(a), float(c)): problem.delta_E(w * t_nat + (1 - w) * blend((a, c)), T)
        for a in MIX_GRID
        for c in MIX_GRID
    }
    scores = {pair: float(np.mean(e)) for pair, e in errors.items()}
    best = min(scores, key=scores.get)
    one = min((p for p in scores if p[0] == p[1]), key=scores.get)
    # one-standard-error rule: the second λ is kept only where it lowers the held-out error by more
    # than the standard error of the paired difference (else one λ for every response, the simpler model)
    gain = errors[one] - errors[best]
    se = float(np.std(gain, ddof=1) / np.sqrt(gain.size)) if gain.size > 1 else 0.0
    lam = best if float(np.mean(gain)) > se else one
    cv = {
        "scores": scores,
        "n": int(C.shape[0]),
        "interior": float(np.mean(b_in)),
        "best": best,
        "one": one,
        "gain": float(np.mean(gain)),
        "se": se,
        "radius_scale": 1.0,
    }
    arb = w[:, 0] < GATE_SURE
    if r_nat is not None and arb.any():
        # split-conformal scale of the atypical radius: the smallest s for which 95 % of the held-out
        # augmented responses that reach the atypical branch lie within the credible radius; it may
        # only widen the radius (measured: with stacked cameras the augmented spectra are easier than
        # atypical test spectra, and s < 1 lowered their coverage from 93–96 % to 82–87 %)
        wa = np.where(w[arb, 0] > GATE_NONE, w[arb, 0], 0.0)
        t_arb = blend(lam)[arb]
        est = wa[:, None] * t_nat[arb] + (1 - wa[:, None]) * t_arb
        r_arb = _mmv_radius(problem, t_cen[arb], t_arb, vol[arb])
        err, gap = problem.delta_E(est, T[arb]), problem.delta_E(t_nat[arb], t_arb)
        need = err**2 - wa * r_nat**2 - wa * (1 - wa) * gap**2
        s_i = np.sqrt(np.maximum(need, 0.0) / np.maximum((1 - wa) * r_arb**2, np.finfo(float).tiny))
        cv["radius_scale"] = max(1.0, float(np.percentile(s_i, 95)))
    return lam, cv


def _noise_radius(problem: CorrectionProblem, regression, noise: NoiseModel, responses) -> np.ndarray:
    """95 % ΔE00 reach of the response noise carried through ``regression`` at ``responses (N, k)``.

    The noise covariance ``diag(noise.variance(c))`` is mapped to a target-space covariance ``S`` by
    the regression's Jacobian (central differences), whose 95 % ΔE00 reach is
    :func:`zonotope.correct.prior.gaussian_radius`'s.
    Returns ``(N,)``.
    """
    c = np.atleast_2d(np.asarray(responses, dtype=np.float64))
    var = noise.check_channels(problem.k).variance(c)
    t = regression(c)
    h = NOISE_JACOBIAN_STEP
    S = np.zeros((c.shape[0], problem.m, problem.m))
    for j in range(problem.k):
        e = np.zeros(problem.k)
        e[j] = h
        d = (regression(c + e) - regression(np.maximum(c - e, 0.0))) / (h + np.minimum(c[:, j], h))[:, None]
        S += var[:, j, None, None] * d[:, :, None] * d[:, None, :]
    return gaussian_radius(problem, t, S)


def _mmv_radius(problem: CorrectionProblem, t_cen, t_arb, vol) -> np.ndarray:
    """ΔE00 reach from ``t_arb`` of the CIELAB ball with the MMV's volume (linearised at ``t_cen``),
    shrunk to the radius that holds 95 % of a uniform ball (0.983)."""
    J2 = problem.lab_metric(t_cen)  # JᵀJ: det = (d Lab / d target)²
    vol_lab = np.maximum(vol, 0.0) * np.sqrt(np.abs(np.linalg.det(J2)))
    return _ab_to_00(problem, t_arb, 0.983 * np.cbrt(3.0 * vol_lab / (4.0 * np.pi)))


@dataclass(frozen=True, eq=False)
class PriorConfig:
    """Options of :func:`fit_Prior` (checked when made; see :mod:`zonotope.utilities.config`).

    ``fit_Prior(problem, PriorConfig(noise=0.01))`` and ``fit_Prior(problem, noise=0.01)`` are the
    same call. Attributes: see the parameters of :func:`fit_Prior`.

    Raises
    ------
    OptionError
        A value out of range (named, with what is allowed).
    """

    degree: int = 2
    shrinkage: float = 0.01
    odds: float = 100.0
    noise: float | NoiseModel = 0.0
    eps: float = 1e-3
    regression: str = "cv"
    folds: int = 10
    mix: float | tuple[float, float] | str = "cv"
    augment: int = 300
    executor: object = None
    cache_dir: str | os.PathLike | None = None

    def __post_init__(self):
        name = "PriorConfig"
        check_count(name, "degree", self.degree, minimum=1)
        check_count(name, "folds", self.folds, minimum=2)
        check_count(name, "augment", self.augment, minimum=1)
        if not isinstance(self.noise, NoiseModel):  # a σ, or a shot + read model per channel
            object.__setattr__(self, "noise", check_nonnegative(name, "noise", self.noise))
        object.__setattr__(self, "eps", check_nonnegative(name, "eps", self.eps))
        shrinkage = check_nonnegative(name, "shrinkage", self.shrinkage)
        if shrinkage > 1:
            raise OptionError(f"{name}.shrinkage={self.shrinkage!r}: give a number in [0, 1].")
        object.__setattr__(self, "shrinkage", shrinkage)
        odds = check_nonnegative(name, "odds", self.odds)
        if odds <= 0:
            raise OptionError(f"{name}.odds={self.odds!r}: give a finite number > 0.")
        object.__setattr__(self, "odds", odds)
        if not isinstance(self.regression, str):
            raise OptionError(
                f"{name}.regression={self.regression!r}: give 'cv', 'Cheung 2004' or 'Finlayson 2015'."
            )
        if not (isinstance(self.mix, str) and self.mix == "cv"):
            pair = isinstance(self.mix, tuple | list) and len(self.mix) == 2
            values = self.mix if pair else (self.mix,)
            try:
                mix = tuple(check_nonnegative(name, "mix", v) for v in values)
            except OptionError:
                mix = (-1.0,)
            if not all(0.0 <= v <= 1.0 for v in mix):
                raise OptionError(
                    f"{name}.mix={self.mix!r}: give 'cv', a weight in [0, 1] or a pair of them "
                    "(interior MAP, bound-active MAP)."
                )
            object.__setattr__(self, "mix", mix if pair else mix[0])


def fit_Prior(problem: CorrectionProblem, config: PriorConfig | None = None, **options) -> Corrector:
    """Default estimator: posterior mean under a two-component reflectance prior, kept in the MMV.

    Model: a reflectance is either *natural* (Gaussian ``N(μ, Σ)`` learnt from the training set) or
    *atypical* (any colour of the object-colour solid: density ``1/vol``). Given the response ``c``,
    the posterior probability of "natural" is

    ``w = σ(log odds + log p(c | natural) − log p(c | atypical))``

    with ``log p(c | natural) ≈ −E(x̂) − ½ log det(2π ΦᵀΣΦ + σ²I)`` — the Laplace approximation
    of the box-truncated Gaussian evidence, ``x̂`` the MAP reflectance of :func:`map_reflectance`
    and ``E`` its prior energy — and ``log p(c | atypical) = −log vol(source solid)``. The
    estimate is ``w · t_nat + (1 − w) · t_arb``:

    - ``t_nat``, the natural branch's estimate: the regression chosen by cross-validation on the
      training set only (linear matrix or root-polynomial, :func:`select_regression`), moved onto
      the MMV in linearised CIELAB when it lies outside (:func:`project_to_mmv`);
    - ``t_arb = λ · Ψᵀx̂ + (1 − λ) · t_cen``, the atypical branch: a convex combination of the MAP
      estimate and the volume centroid of the MMV (:func:`mmv_centroids`, the posterior mean when
      every colour of the MMV is equally likely). Neither is better everywhere (on atypical test
      spectra MAP wins with one camera, the centroid with stacked ones). The MAP may be a sounder
      summary where the natural Gaussian explains the response without the physical bounds (its
      unbounded mode is a reflectance, :func:`zonotope.correct.prior.interior_solution`) than where the
      bounds push ``x̂`` onto the box's boundary (the Gaussian and [0, 1]ⁿ disagree), so
      ``λ = b λ_in + (1 − b) λ_bd`` with ``b = exp(−(U(x̂) − U(x₀)))`` the ratio of the Gaussian
      posterior density at the bounded mode ``x̂`` to that at the unbounded one ``x₀`` (1 when no
      bound is active; continuous in the response, so is the estimate). ``λ_in`` and
      ``λ_bd`` ∈ {0, 0.1, …, 1} are chosen by cross-validation on atypical spectra made from the
      training set only (:func:`learn_mix`: contrast-stretched training spectra, 300 by default,
      scored with the whole estimator refitted on the other folds); the pair is kept only where it
      beats the best single λ by more than the standard error of the paired difference (the
      one-standard-error rule), else one λ serves both cases. Chosen (400–700 nm, D65, rawtoaces 190;
      400–680 nm with the Sigma): one λ, 0.9 Nikon 5100, 0.6 Canon EOS 5D Mark II, 0.8 the two (the
      best pairs gained 0.001–0.004 ΔE00 ± 0.003–0.004); ``(λ_in, λ_bd)`` = (0.7, 0.2) Nikon 5100 +
      Sigma SD Merrill (gain 0.019 ± 0.013 over λ = 0.5) and (0.7, 0.3) all three (0.007 ± 0.004
      over 0.5): with the Sigma's channels the MAP whose Gaussian mode the bounds cut off is the
      weaker summary.

    All three points lie in the MMV, hence so does the estimate. The centroid (the costly part: 2–4 CPU-ms
    per colour at 10 nm with one or two cameras, measured on 200 atypical and 100 natural
    responses) is computed only where its weight ``(1 − w)(1 − λ)`` reaches 1 %
    (:data:`zonotope._tol.CENTROID_MIN_WEIGHT`; the atypical branch as a whole only where
    ``1 − w`` does) — below that it moves the estimate by less than 1 % of the distance between
    the branches. Measured (400–700 nm / 10 nm, D65, rawtoaces 190 training, test spectra within
    0.02 of a training one removed): on the 42 built-in natural spectra the gate opens (``w < 0.99``)
    for 9.5 % with Nikon 5100 alone and 2.4 % with Nikon 5100 + Canon EOS 5D Mark II, and a centroid
    is computed for 2.4 % (1 of 42) and 0 % — ``tests/test_correct.py`` keeps these at ≤ 10 % / ≤ 3 %
    and ≤ 3 %; on the 565–574 natural spectra of ``benchmarks/bench_estimators.py`` (built-ins and
    150-spectrum subsets of ``../shared/data``) the gate opens for 8.7–9.1 % (one camera) and
    2.4–3.2 % (two or three), a centroid is computed for 1.2–4.5 % and 1.7–3.0 %; on its 200
    atypical spectra for 32–41 % (one camera) and 79–92 % (two or three). ``x̂`` and the MMV test
    of ``t_nat`` take a closed form for most natural responses
    (:func:`zonotope.correct.prior.interior_solution`; 14 % / 5 % of the built-in natural responses need
    any solver): ``params["closed_form"]`` computes every such estimate in one vectorised pass, so
    natural images cost little more than the regression. Fit + apply on 10⁴
    natural responses (``benchmarks/bench_correct.py --fit-apply 10000``, median of 3, 2 shared
    cores, load ≈ 6–7): 4.0 s with Nikon 5100 (MAP 0.84 s: 4.8×; root-polynomial 1.6 ms), 4.1 s with
    Nikon 5100 + Sony ILCE-7M3 (MAP 0.73 s: 5.6×); most of it is the fit (:func:`learn_mix`: 300 MMV
    centroids and 10 refits), 3–5 % of these responses need a solver.

    Uncertainty (:meth:`Corrector.with_uncertainty`): a 95 % credible radius in ΔE00 per estimate,
    from the same mixture — ``r² = w r_nat² + (1 − w) r_arb² + w (1 − w) ΔE00(t_nat, t_arb)²``, with
    ``r_nat`` the 95th percentile of the regression's held-out ΔE00 in cross-validation and
    ``r_arb = s · r_MMV``: ``r_MMV`` the radius of the ball of the MMV's volume in linearised CIELAB
    (95 % of a uniform ball lies within 0.983 of its radius), as the largest ΔE00 from ``t_arb`` to
    that ball's axis points, and ``s ≥ 1`` a split-conformal scale from :func:`learn_mix` (the
    smallest that covers 95 % of the held-out contrast-stretched spectra reaching the atypical
    branch; measured 2.04 Nikon 5100, 1.09 Canon EOS 5D Mark II, 1.21 Nikon + Sigma, 1.0 Nikon +
    Canon and all three, where it would have been < 1). Where ``w ≥ 0.99`` the MMV is not computed
    and ``r = √w · r_nat``. With noise (a σ or a :class:`~zonotope.correct.NoiseModel`) the natural
    radius is per response, ``r_nat(c)² = r₀² + r_noise(c)²``: ``r_noise`` the 95 % ΔE00 reach of the
    response noise carried through the regression at ``c`` (:func:`_noise_radius`; dark colours get
    more), ``r₀`` the smallest value covering 95 % of the cross-validation errors (held out with
    noise). The 95 % is a claim *under the model*: ``r_nat`` is calibrated on natural
    held-out spectra and ``r_MMV`` is a ball of the MMV's size, not a bound (the MMV itself is the
    100 % region, noise-free). Measured coverage (``benchmarks/bench_estimators.py``): 86–100 % on
    natural sets except SFU Krinov (51–86 %, its errors exceed the training CV's); on atypical sets
    43–95 %, because the atypical spectra the gate takes for natural (``w ≥ 0.99``: 5–57 % of them)
    get the natural radius and are covered only 10–60 % of the time; the others are covered
    70–97 % (57–96 % with ``s = 1``, previous round).

    Parameters
    ----------
    problem : CorrectionProblem
    config : PriorConfig, optional
        The options below as one checked object; keywords override its fields (or replace it:
        ``fit_Prior(problem, noise=0.01)`` is ``fit_Prior(problem, PriorConfig(noise=0.01))``).
    degree
        Root-polynomial degree of the regression candidate.
    shrinkage
        Covariance shrinkage of the prior (:meth:`ReflectancePrior.fit`).
    odds
        Prior odds natural : arbitrary, a stated belief about scenes (default 100: a photographed
        surface is far more often natural than not), not fitted to any test set. The README gives
        the evaluation at odds 1, 10 and 100.
    noise
        Response noise σ (white = 1), or a :class:`~zonotope.correct.NoiseModel` (shot + read per
        channel): the regression candidates are fitted for it, and its root mean σ over the training
        responses enters the evidence, relaxes the fiber constraint and gives the MMV a tolerance
        δ = DELTA_SIGMAS · σ.
    eps
        Certification tolerance of the MMV centroids (see :func:`fit_Centroid`).
    regression
        ``"cv"`` (default): chosen by cross-validation; or ``"Cheung 2004"`` / ``"Finlayson 2015"``.
    folds
        Cross-validation folds.
    mix
        ``"cv"`` (default): the MAP weights ``(λ_in, λ_bd)`` of the atypical branch chosen by
        :func:`learn_mix`; or a fixed λ in [0, 1] for both (0: the MMV centroid alone), or a pair
        ``(λ_in, λ_bd)``.
    augment
        Number of contrast-stretched training spectra that :func:`learn_mix` scores λ on.
    executor
        Where the MMV chunks run (:func:`zonotope.parallel.executor`, or a
        ``concurrent.futures`` pool); None: this process. Results are identical either way.
    cache_dir
        Folder of an on-disk cache of the cross-validated atypical weights (the costly part of the
        fit), keyed by the generators, training set, options, noise and version
        (:mod:`zonotope.correct.fitcache`): a second fit of the same problem skips it. None: no cache.

    Returns
    -------
    Corrector
        ``params`` holds the prior, the regression, the cross-validation scores, ``mix``
        (``(λ_in, λ_bd)``) and ``mix_cv`` (its scores), ``log_volume``, ``r_nat``, ``radius_scale``
        (s), the ``weights`` function, ``closed_form`` (estimates and solver rows in one pass),
        ``needs_solver`` (which responses leave the closed forms: :func:`zonotope.correct.image.correct_image`
        groups only those), ``centroid_rows`` (which compute an MMV centroid) and ``config``;
        ``with_uncertainty`` gives credible radii.

    Raises
    ------
    OptionError
        An option out of range or unknown (:class:`PriorConfig`).

    Notes
    -----
    The fit runs its BLAS calls on one thread (:func:`_one_blas_thread`): its matrices are small
    (≤ a few thousand × 45), and on a loaded machine OpenBLAS threads that wait for a busy core made
    each normal-equation product of the cross-validation take 30–60 ms instead of 0.2 ms; the results
    are bit-identical. The source solid's log volume is memoised up to channel scaling
    (:func:`_log_volume`), so the channel-whitened problems of :func:`splat.fusion.whitened` share it.
    :func:`_fit_Prior_reference` is the implementation without both (same results:
    ``tests/test_prior_fit_speed.py``; ``benchmarks/bench_correct.py --prior-fit``).
    """
    cfg = with_options(PriorConfig, config, options, where="fit_Prior")
    with _one_blas_thread():
        return _fit_Prior(problem, cfg, log_volume=_log_volume)


def _fit_Prior_reference(
    problem: CorrectionProblem, config: PriorConfig | None = None, **options
) -> Corrector:
    """Reference twin of :func:`fit_Prior`, same signature and results: BLAS threads as configured and
    the log volume computed for every distinct Φ (:func:`_log_volume_reference`)."""
    cfg = with_options(PriorConfig, config, options, where="fit_Prior")
    return _fit_Prior(problem, cfg, log_volume=_log_volume_reference)


_BLAS_LOCK = threading.Lock()
_BLAS_STATE: dict = {"depth": 0, "limiter": None}


@contextlib.contextmanager
def _one_blas_thread():
    """Context in which BLAS (OpenBLAS, MKL, …) uses one thread; restored on exit. Process-wide while
    it lasts (threadpoolctl), which only changes the speed of BLAS calls elsewhere, not their results.

    Fits running at once in several threads share one limit: the first to enter sets it, the last to
    leave restores the original (nested ``threadpool_limits`` contexts leaving out of order would
    restore each other's "1" and leave BLAS single-threaded for good)."""
    from threadpoolctl import threadpool_limits

    with _BLAS_LOCK:
        if _BLAS_STATE["depth"] == 0:
            _BLAS_STATE["limiter"] = threadpool_limits(limits=1, user_api="blas")
        _BLAS_STATE["depth"] += 1
    try:
        yield
    finally:
        with _BLAS_LOCK:
            _BLAS_STATE["depth"] -= 1
            if _BLAS_STATE["depth"] == 0:
                _BLAS_STATE["limiter"].restore_original_limits()
                _BLAS_STATE["limiter"] = None


def _fit_Prior(problem: CorrectionProblem, cfg: PriorConfig, *, log_volume) -> Corrector:
    """:func:`fit_Prior` with checked options ``cfg`` and the log-volume function ``log_volume``."""
    degree, shrinkage, odds, noise_model, eps = cfg.degree, cfg.shrinkage, cfg.odds, cfg.noise, cfg.eps
    executor = cfg.executor
    if isinstance(noise_model, NoiseModel):
        noise_model = noise_model.check_channels(problem.k)
    # the regressions take the noise model; the gate, fiber and MMV tolerance one σ over the training set
    noise = scalar_sigma(noise_model, problem.source_of(problem.training))
    reg, cv = select_regression(problem, degree=degree, noise=noise_model, folds=cfg.folds)
    if cfg.regression != "cv":
        name = REGRESSIONS.resolve(cfg.regression) if cfg.regression in REGRESSIONS else None
        if name not in ("Cheung 2004", "Finlayson 2015"):
            raise SpectralDataError(
                f"regression={cfg.regression!r}: choose 'cv', 'Cheung 2004' or 'Finlayson 2015'."
            )
        reg = _fit_regression(problem, name, degree=degree, noise=noise_model)
    r_nat = float(np.percentile(cv["errors"], 95))
    radius_model = noise_model if isinstance(noise_model, NoiseModel) else None
    if radius_model is None and noise > 0:
        radius_model = NoiseModel.constant(noise, problem.k)
    if radius_model is not None:
        # natural radius per response: r0² + r_noise(c)², r0 the smallest that covers 95 % of the
        # cross-validation errors given each one's own noise reach
        r_cv = _noise_radius(problem, reg, radius_model, problem.source_of(problem.training[cv["order"]]))
        r0 = float(np.sqrt(np.percentile(np.maximum(cv["errors"] ** 2 - r_cv**2, 0.0), 95)))
    else:
        r0 = r_nat

    def r_nat_of(c):
        """The natural branch's 95 % radius at responses ``c (N, k)``."""
        if radius_model is None:
            return np.full(c.shape[0], r_nat)
        return np.sqrt(r0**2 + _noise_radius(problem, reg, radius_model, c) ** 2)

    log_vol = log_volume(problem.Phi)
    if cfg.mix == "cv":
        from .fitcache import load_mix, prior_fit_key, save_mix

        key = prior_fit_key(problem, cfg) if cfg.cache_dir is not None else None
        cached = load_mix(cfg.cache_dir, key) if key is not None else None
        if cached is None:
            lam, mix_cv = learn_mix(problem, reg.method, cfg, r_nat=r_nat, log_volume=log_vol)
            if key is not None:
                save_mix(cfg.cache_dir, key, lam, mix_cv)
        else:
            lam, mix_cv = cached
        radius_scale = mix_cv["radius_scale"]
    else:
        pair = cfg.mix if isinstance(cfg.mix, tuple) else (cfg.mix, cfg.mix)
        lam, mix_cv, radius_scale = (float(pair[0]), float(pair[1])), None, 1.0
    prior = ReflectancePrior.fit(problem.training, shrinkage=shrinkage)
    weights = _gate(problem, prior, noise=noise, odds=odds, log_vol=log_vol)
    PhiPsi = np.hstack([problem.Phi, problem.Psi])
    sigma = np.concatenate([np.full(problem.k, float(noise)), np.zeros(problem.m)])

    def lam_of(b):
        """λ per row, ``b λ_in + (1 − b) λ_bd``, ``b`` the weight of the interior case (:func:`_fit_map`)."""
        return b * lam[0] + (1.0 - b) * lam[1]

    def needs_centroid(w, b):
        """Rows whose MMV centroid enters the estimate with a weight ``(1 − w)(1 − λ)`` of at least
        CENTROID_MIN_WEIGHT (below it, leaving it out moves the estimate by < 1 % of the gap)."""
        return (w < GATE_SURE) & ((1.0 - w) * (1.0 - lam_of(b)) >= CENTROID_MIN_WEIGHT)

    def closed_form(c):
        """Estimates of every row that needs no solver, and which rows need one (a bounded least
        squares for a MAP reflectance off the interior or a regression not witnessed inside the MMV,
        or an MMV centroid); one vectorised pass, the rows flagged are left for :func:`solve`."""
        c = np.atleast_2d(np.asarray(c, dtype=np.float64))
        x, interior = interior_solution(prior, problem.Phi, c, noise=noise)
        w = weights(c, x)
        t = reg(c)
        _, witness = interior_solution(prior, PhiPsi, np.hstack([c, t]), noise=sigma)
        slow = ~interior | needs_centroid(w, 1.0) | ((w > GATE_NONE) & ~witness)  # interior: b = 1
        wa = np.where(w > GATE_NONE, w, 0.0)[:, None]
        t_map = np.clip(x, 0.0, 1.0) @ problem.Psi
        out = np.where((w >= GATE_SURE)[:, None], t, wa * t + (1.0 - wa) * t_map)
        return out, slow

    def centroid_rows(c):
        """Rows whose estimate computes an MMV centroid (:func:`needs_centroid` of their gate weight)."""
        c = np.atleast_2d(np.asarray(c, dtype=np.float64))
        x, b = _fit_map(problem, prior, c, noise=noise)
        return needs_centroid(weights(c, x), b)

    def needs_solver(c):
        """Rows whose estimate needs a bounded least-squares solve or an MMV centroid (the others
        are closed forms: an interior MAP reflectance, a witnessed regression and no centroid)."""
        return closed_form(c)[1]

    def solve(c, with_radius: bool):
        x, b = _fit_map(problem, prior, c, noise=noise)
        w = weights(c, x)
        out = reg(c)
        nat = w > GATE_NONE
        if nat.any():
            out[nat] = project_to_mmv(problem, c[nat], out[nat], prior=prior, noise=noise)[0]
        t_nat = out.copy()
        r_nat_c = r_nat_of(c) if with_radius else None
        r2 = w * r_nat_c**2 if with_radius else None
        arb = w < GATE_SURE  # an atypical weight under 1 % moves the estimate by < 1 % of the gap
        if arb.any():
            t_arb = x[arb] @ problem.Psi
            cen = needs_centroid(w[arb], b[arb])
            lam_arb = lam_of(b[arb])[:, None]
            mmv = np.ones_like(cen) if with_radius else cen  # radii need every MMV's volume
            if mmv.any():
                t_cen, vol = mmv_centroids(
                    problem, c[arb][mmv], eps=eps, delta=DELTA_SIGMAS * noise, executor=executor, volumes=True
                )
                use = cen[mmv]
                t_arb[cen] = lam_arb[cen] * t_arb[cen] + (1.0 - lam_arb[cen]) * t_cen[use]
            wa = np.where(nat[arb], w[arb], 0.0)[:, None]  # w ≤ GATE_NONE: the atypical branch alone
            out[arb] = wa * out[arb] + (1.0 - wa) * t_arb
            if with_radius:
                r_arb = radius_scale * _mmv_radius(problem, t_cen, t_arb, vol)
                gap = problem.delta_E(t_nat[arb], t_arb)
                wa1 = wa[:, 0]
                r2[arb] = wa1 * r_nat_c[arb] ** 2 + (1 - wa1) * r_arb**2 + wa1 * (1 - wa1) * gap**2
        if not with_radius:
            return out
        return out, np.sqrt(r2)

    def run(c, with_radius: bool):
        if with_radius:
            return solve(c, True)
        out, slow = closed_form(c)
        if slow.any():
            out[slow] = solve(c[slow], False)
        return out

    return Corrector(
        "Prior",
        problem,
        lambda c: run(c, False),
        {
            "prior": prior,
            "regression": reg,
            "cv_scores": cv["scores"],
            "mix": lam,
            "mix_cv": mix_cv,
            "log_volume": log_vol,
            "r_nat": r_nat,
            "r_nat_of": r_nat_of,
            "radius_scale": radius_scale,
            "weights": weights,
            "needs_solver": needs_solver,
            "closed_form": closed_form,
            "centroid_rows": centroid_rows,
            "odds": odds,
            "noise": noise,
            "noise_model": noise_model,
            "config": cfg,
        },
        predict_with_radius=lambda c: run(c, True),
    )
