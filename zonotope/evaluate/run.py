"""The evaluation run: its options (:class:`EvaluationConfig`) and :func:`evaluate`."""

from __future__ import annotations

import inspect
import time
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from .._errors import OptionError, SpectralDataError, ZonotopeError
from ..correct.methods import (
    CORRECTION_METHODS,
    DELTA_SIGMAS,
    CorrectionProblem,
    NoiseModel,
    correction_problem,
    fit_correction,
    noise_model,
    noise_options,
)
from ..correct.prior import project_to_mmv
from ..mismatch.membership import outside_mmv_fraction
from ..utilities.config import check_count, check_nonnegative, with_options
from ..utilities.progress import ProgressCallback
from .noise import DEFAULT_NOISE, _noise_levels, _seed_of, noise_label
from .sets import TestSet, atypical_test_sets, natural_test_sets, source_split
from .table import Evaluation, EvaluationRow, _stats

__all__ = ["DEFAULT_METHODS", "EvaluationConfig", "evaluate"]

#: Estimators evaluated by default (every one of CORRECTION_METHODS).
DEFAULT_METHODS: tuple[str, ...] = tuple(CORRECTION_METHODS)


def _mmv_batch(problem: CorrectionProblem, C: np.ndarray, *, eps: float, delta: float, executor=None):
    """Centroids (N, m) and volumes (N,) of the MMVs of responses C (N, k)."""
    from ..mismatch.volume import metamer_mismatch_batch

    out = metamer_mismatch_batch(
        problem.Phi, problem.Psi, C, eps=eps, delta=delta, on_infeasible="nearest", executor=executor
    )
    return out.centroids, out.volumes


def _outside_solid(problem: CorrectionProblem, C: np.ndarray, atol: float = 1e-6) -> np.ndarray:
    """Which responses (N, k) no reflectance in [0, 1] can produce: the nearest producible response
    is farther than ``atol`` (an absolute slack in response units, white = 1) in some channel."""
    from ..correct.prior import fiber_lsq

    n = problem.Phi.shape[0]
    x = fiber_lsq(problem.Phi, C, np.eye(n), np.full(n, 0.5))
    return np.abs(x @ problem.Phi - C).max(axis=1) > atol


@dataclass(frozen=True, eq=False)
class EvaluationConfig:
    """Options of :func:`evaluate` (checked when made; see :mod:`zonotope.utilities.config`).

    Attributes
    ----------
    methods : tuple of str
        Estimators (keys or aliases of :data:`zonotope.correct.CORRECTION_METHODS`); those that do
        not apply (the ACES IDT with stacked cameras) are skipped with a note.
    illuminant, target, training
        See :func:`zonotope.correct.correction_problem`.
    shape : colour.SpectralShape or array_like of wavelengths, optional
        Wavelength grid; default 400–700 nm / 10 nm.
    test_sets : tuple of TestSet, optional
        Default: :func:`natural_test_sets` (built-ins) and ``atypical`` atypical spectra.
    atypical : int
        Number of atypical spectra added when ``test_sets`` is None (0 for none).
    noise : noise level or sequence of noise levels
        Each level: 0 (noise-free), a σ (constant Gaussian noise, white = 1; one or one per channel),
        a :class:`~zonotope.correct.NoiseModel` or ``{"shot": .., "read": ..}`` (variance
        ``shot · c + read`` per channel). Default :data:`DEFAULT_NOISE`. At each level the estimators
        are fitted for that noise (:func:`~zonotope.correct.noise_options` of the σ as given, or of
        the model; the MMVs with tolerance ``delta = DELTA_SIGMAS · σ`` at white) and applied to
        noisy held-out responses.
    seed : int
        Seed of the atypical spectra and of the noise (the same draws for every method and level).
    centroid_eps : float
        Certification tolerance of the MMVs.
    exclude_within : float or None
        Test spectra within this L∞ distance of a training spectrum are removed
        (:func:`source_split`, per camera set's training data); ``None`` keeps every test spectrum.

    Raises
    ------
    OptionError
        A value out of range (named, with what is allowed).
    UnknownMethodError
        An unknown estimator name (the valid ones are listed).
    """

    methods: tuple[str, ...] = DEFAULT_METHODS
    illuminant: object = "D65"
    target: object = "CIE 2015 2°"
    shape: object = None
    training: object = "rawtoaces 190"
    test_sets: tuple[TestSet, ...] | None = None
    atypical: int = 100
    noise: object = DEFAULT_NOISE
    seed: int = 0
    centroid_eps: float = 1e-3
    exclude_within: float | None = 0.02

    def __post_init__(self):
        name = "EvaluationConfig"
        methods = self.methods
        if isinstance(methods, str) or not isinstance(methods, Sequence) or not methods:
            raise OptionError(f"{name}.methods={methods!r}: give a non-empty list of estimator names.")
        for m in methods:
            CORRECTION_METHODS.resolve(m)
        object.__setattr__(self, "methods", tuple(methods))
        if self.test_sets is not None:
            sets = self.test_sets
            if not isinstance(sets, Sequence) or not all(isinstance(t, TestSet) for t in sets):
                raise OptionError(
                    f"{name}.test_sets: give a list of TestSet objects (or None for the defaults)."
                )
            object.__setattr__(self, "test_sets", tuple(sets))
        _check_shape(name, self.shape)
        check_count(name, "atypical", self.atypical)
        check_count(name, "seed", self.seed)
        object.__setattr__(self, "noise", _noise_levels(f"{name}.noise", self.noise))
        object.__setattr__(self, "centroid_eps", check_nonnegative(name, "centroid_eps", self.centroid_eps))
        object.__setattr__(
            self,
            "exclude_within",
            check_nonnegative(name, "exclude_within", self.exclude_within, allow_none=True),
        )


def _check_shape(owner: str, shape) -> None:
    """A wavelength grid: None, a colour.SpectralShape or an increasing finite 1-D array (≥ 2 nm)."""
    if shape is None or type(shape).__name__ == "SpectralShape":
        return
    try:
        w = np.asarray(shape, dtype=np.float64)
    except (TypeError, ValueError):
        w = None
    if w is None or w.ndim != 1 or w.size < 2 or not np.all(np.isfinite(w)) or np.any(np.diff(w) <= 0):
        raise OptionError(
            f"{owner}.shape={shape!r}: give a colour.SpectralShape or increasing wavelengths (nm), "
            "e.g. numpy.arange(400, 701, 10)."
        )


def evaluate(
    camera_sets: Sequence,
    config: EvaluationConfig | None = None,
    *,
    executor=None,
    progress: ProgressCallback | None = None,
    **options,
) -> Evaluation:
    """ΔE00 of each estimator, for each camera set and test set.

    Parameters
    ----------
    camera_sets
        Sequence of camera sets; each is one camera or a list of 1–3 cameras (names or files).
    config : EvaluationConfig, optional
        The options (estimators, illuminant, target, grid, training and test sets, noise, ...);
        default ``EvaluationConfig()``.
    executor
        Where the MMV batches run (:func:`zonotope.parallel.executor`; also given to the estimators
        that compute MMVs); None: this process. The table is identical either way.
    progress
        Called as ``progress(stage, 0, n)`` before and ``progress(stage, n, n)`` after each step
        (n test responses; :class:`~zonotope.utilities.ProgressCallback`).
    **options
        :class:`EvaluationConfig` fields as keywords, alone or overriding those of ``config``
        (e.g. ``evaluate(sets, noise=0.01, atypical=0)``).

    Returns
    -------
    Evaluation

    Raises
    ------
    OptionError
        An unknown option or a value out of range.
    UnknownMethodError
        An unknown estimator name.
    SpectralDataError
        An empty test set, or an invalid camera set (see :func:`correction_problem`).
    """
    cfg = with_options(EvaluationConfig, config, options, where="evaluate")
    methods, illuminant, target, shape, training = (
        cfg.methods,
        cfg.illuminant,
        cfg.target,
        cfg.shape,
        cfg.training,
    )
    test_sets, atypical, noise, seed = cfg.test_sets, cfg.atypical, cfg.noise, cfg.seed
    centroid_eps, exclude_within = cfg.centroid_eps, cfg.exclude_within
    import colour

    shape = colour.SpectralShape(400, 700, 10) if shape is None else shape
    w = np.asarray(shape.wavelengths if isinstance(shape, colour.SpectralShape) else shape, float)
    if test_sets is None:
        test_sets = natural_test_sets(w)
        if atypical:
            test_sets.extend(atypical_test_sets(w, atypical, seed=seed))
    for ts in test_sets:
        if ts.reflectances.ndim != 2 or ts.reflectances.shape[0] == 0:
            raise SpectralDataError(f"test set {ts.name!r} is empty; give at least one reflectance.")
        if ts.reflectances.shape[1] != w.size:
            raise SpectralDataError(
                f"test set {ts.name!r} has {ts.reflectances.shape[1]} wavelengths; the grid has {w.size}."
            )
    rows: list[EvaluationRow] = []
    volumes: dict = {}
    notes: list[str] = []
    errors: dict = {}
    all_sets = list(test_sets)
    for cams in camera_sets:
        cams = [cams] if isinstance(cams, str) or not isinstance(cams, Sequence) else list(cams)
        problem = correction_problem(
            cams, target=target, illuminant=illuminant, shape=shape, training=training
        )
        label = " + ".join(problem.sources)
        test_sets, split_notes = source_split(all_sets, problem.training, exclude_within=exclude_within)
        notes.extend(n for n in split_notes if n not in notes)
        data = []  # per test set: noise-free responses, targets, the shared standard normal draws
        for ts in test_sets:
            C, T = problem.source_of(ts.reflectances), problem.target_of(ts.reflectances)
            z = np.random.default_rng(_seed_of(seed, label, ts.name)).standard_normal(C.shape)
            data.append((ts, C, T, z))
        fits: dict = {}  # (method, level) → Corrector; a fit that noise does not change is made once
        for level in noise:
            model = noise_model(level, problem.k)  # what the responses get
            told = model if isinstance(level, NoiseModel) else level  # a σ is passed as given
            zlabel = noise_label(level)
            fitted = {}
            for m in dict.fromkeys(CORRECTION_METHODS.resolve(m) for m in methods):
                opts = noise_options(m, told)
                if CORRECTION_METHODS.properties(m)["centroid"]:
                    opts["eps"] = centroid_eps
                key = (m, zlabel if noise_options(m, told) else "0")
                if key not in fits:
                    if (
                        executor is not None
                        and "executor" in inspect.signature(CORRECTION_METHODS[m]).parameters
                    ):
                        opts["executor"] = executor
                    try:
                        fits[key] = fit_correction(problem, method=m, **opts)
                    except ZonotopeError as error:
                        fits[key] = None
                        notes.append(f"{label} · noise {zlabel}: {m} skipped ({error})")
                if fits[key] is not None:
                    fitted[m] = fits[key]
            for ts, C0, T, z in data:
                C = C0 if model is None else C0 + z * model.sigma(C0)
                if model is not None:
                    far = _outside_solid(problem, C)
                    if far.any():
                        notes.append(
                            f"{label} · {ts.name} · noise {zlabel}: {int(far.sum())} of {len(C)} noisy "
                            "responses lie outside the camera's object-colour solid (no reflectance "
                            "produces them); the MMV estimators used the nearest feasible response "
                            f"(delta = {DELTA_SIGMAS:g}σ), the others extrapolate."
                        )
                sigma = 0.0 if model is None else model.effective_sigma(C0)
                where = f"{label} · {ts.name} · noise {zlabel}"
                centroid = next((m for m in fitted if CORRECTION_METHODS.properties(m)["centroid"]), None)
                if centroid is not None:
                    if progress:
                        progress(f"{where}: MMVs", 0, len(C))
                    t0 = time.perf_counter()
                    delta = noise_options(centroid, told).get("delta", 0.0)
                    cents, vols = _mmv_batch(problem, C, eps=centroid_eps, delta=delta, executor=executor)
                    if progress:
                        progress(f"{where}: MMVs", len(C), len(C))
                    volumes[label, ts.name, zlabel] = (
                        float(np.mean(vols)),
                        float(np.median(vols)),
                        float(np.max(vols)),
                    )
                    mmv_time = time.perf_counter() - t0
                for m, est in fitted.items():
                    if progress:
                        progress(f"{where}: {m}", 0, len(C))
                    t0 = time.perf_counter()
                    radius = None
                    if m == centroid:
                        E = cents
                    elif est.predict_with_radius is not None:
                        E, radius = est.with_uncertainty(C)
                    else:
                        E = est(C)
                    if progress:
                        progress(f"{where}: {m}", len(C), len(C))
                    secs = time.perf_counter() - t0 + (mmv_time if m == centroid else 0.0)
                    dE = problem.delta_E(E, T)
                    errors[label, ts.name, m, zlabel] = np.asarray(dE, dtype=np.float64)
                    unc = {}
                    if radius is not None:
                        unc = {"radius": float(np.median(radius)), "coverage": float(np.mean(dE <= radius))}
                    inside = None
                    if CORRECTION_METHODS.properties(m)["closed_form"]:
                        inside = float(np.mean(project_to_mmv(problem, C, E, noise=sigma)[1]))
                    if model is None:  # exact responses: is each answer possible at all?
                        unc["outside"] = outside_mmv_fraction(problem.Phi, problem.Psi, C, E)
                    rows.append(
                        EvaluationRow(
                            label,
                            ts.name,
                            ts.kind,
                            m,
                            len(C),
                            *_stats(dE),
                            inside=inside,
                            seconds=secs,
                            noise=zlabel,
                            **unc,
                        )
                    )
    levels = ", ".join(noise_label(level) for level in noise)
    notes.append(
        f"grid {w[0]:g}–{w[-1]:g} nm / {w[1] - w[0]:g} nm, illuminant {illuminant}, target "
        f"{target} (XYZ, Y_white = 1), training {training}, noise levels {levels} (shot σw: "
        "shot-limited noise of that σ at white; the same seeded draws for every method and level)."
    )
    return Evaluation(rows, volumes, notes, errors)
