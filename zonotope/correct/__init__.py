"""Colour correction: the method registry :data:`CORRECTION_METHODS` and :func:`fit_correction`
(``methods``), the problem (``problem``), regressions, MMV-based estimators (``mmv``), the reflectance
prior (``prior``, ``bvls``), image correction (``image``) and saved corrections and LUTs (``profile``).

Why one folder: every estimator, and every consumer that fits one, goes through the one registry.
"""

from __future__ import annotations

from ..utilities.lazy import lazy_exports
from .methods import (
    CORRECTION_METHODS,
    DELTA_SIGMAS,
    CorrectionProblem,
    Corrector,
    NoiseModel,
    NoiseModelError,
    PriorConfig,
    check_reflectances,
    correct,
    correction_problem,
    estimate_noise,
    expected_normal_equations,
    fit_Centroid,
    fit_Cheung2004,
    fit_correction,
    fit_Dyer2017,
    fit_Finlayson2015,
    fit_MAP,
    fit_Prior,
    fit_Projection,
    mmv_centroids,
    noise_from_profile,
    noise_model,
    noise_options,
    parse_noise,
    root_polynomial_terms,
    select_regression,
)

__getattr__, __dir__, _LAZY = lazy_exports(
    __name__,
    {
        "image": ["correct_image"],
        "prior": ["ReflectancePrior", "fiber_lsq", "interior_solution", "map_reflectance", "project_to_mmv"],
        "profile": [
            "LUT_SHAPERS",
            "LUT_SPACES",
            "LUTConfig",
            "SavedCorrectionNotFoundError",
            "apply_correction_LUT",
            "correction_LUT",
            "load_correction",
            "save_correction",
            "write_correction_LUT",
        ],
    },
)

__all__ = [
    "CORRECTION_METHODS",
    "DELTA_SIGMAS",
    "CorrectionProblem",
    "Corrector",
    "NoiseModel",
    "NoiseModelError",
    "PriorConfig",
    "check_reflectances",
    "correct",
    "correction_problem",
    "estimate_noise",
    "expected_normal_equations",
    "fit_Centroid",
    "fit_Cheung2004",
    "fit_Dyer2017",
    "fit_Finlayson2015",
    "fit_MAP",
    "fit_Prior",
    "fit_Projection",
    "fit_correction",
    "mmv_centroids",
    "noise_from_profile",
    "noise_model",
    "parse_noise",
    "noise_options",
    "root_polynomial_terms",
    "select_regression",
    *_LAZY,
]
