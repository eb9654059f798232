"""Colour correction: the method registry :data:`CORRECTION_METHODS` and :func:`fit_correction`
(``methods``), the problem (``problem``), regressions (on responses whose error is known as draws:
``eiv``), MMV-based estimators (``mmv``), the reflectance
prior (``prior``, ``bvls``), white-point preserving estimates (``neutral``), image correction (``image``)
and saved corrections and LUTs (``profile``).

Why one folder: every estimator, and every consumer that fits one, goes through the one registry.
"""

from __future__ import annotations

from ..utilities.lazy import lazy_exports
from . import methods
from .methods import *  # noqa: F403  (the registry's public names, listed once in methods.__all__)

__getattr__, __dir__, _LAZY = lazy_exports(
    __name__,
    {
        "eiv": ["fit_errors_in_variables"],
        "image": ["correct_image"],
        "neutral": ["neutral_offsets", "white_point_preserving"],
        "prior": [
            "ReflectancePrior",
            "fiber_lsq",
            "interior_solution",
            "map_reflectance",
            "posterior_radius",
            "project_to_mmv",
        ],
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

__all__ = [*methods.__all__, *_LAZY]
