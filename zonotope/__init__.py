"""zonotope — geometric colour science of cameras.

Exact object-colour solids (zonotopes), metamer mismatch volumes, Vora values and
metamer-based colour correction.

Module map, in data-flow order (each layer imports only the layers above it; the test
``tests/test_architecture.py`` enforces it):

===========================  ==================================================================
``spectra``, ``_loading``,   spectral curves on one grid: built-in cameras, observers,
``_generators``              illuminants, reflectance sets; file readers; :func:`generators`;
                             :class:`GeneratorPair` (source Φ and target Ψ on one grid)
``solid``, ``polytope``      :class:`Zonotope` (object-colour solid, exact) and :class:`Polytope`
``vora``, ``macadam``        Vora values and camera-set ranking; MacAdam limits (object colours)
``mismatch``                 metamer mismatch volumes (:func:`metamer_mismatch`,
                             :class:`MetamerMismatch`), certified by facet refinement
``prior``, ``atypical``      a reflectance prior and atypical test spectra
``correct``                  estimators: :func:`fit_correction` over :data:`CORRECTION_METHODS`
``image``, ``profile``       :func:`correct_image` (unique colours, batches, cache); 3-D LUTs
                             and saved corrections
``evaluate``, ``report``,    applications: ΔE00 evaluation, HTML/Markdown reports, pictures,
``viz``, ``cli``             the ``zonotope`` command
===========================  ==================================================================

Shared infrastructure: ``_errors`` (one exception hierarchy), ``_tol`` (every tolerance, with
its reason), ``_registry`` (:class:`MethodRegistry` for every ``method=`` table), ``_progress``
(:class:`ProgressCallback`, the one ``progress(stage, done, total)`` type of every long-running
function), ``_config`` (config dataclasses taken as one checked object or as keywords),
``parallel`` (executors), ``_io`` (atomic output files).

``import zonotope`` loads the spectra and the solid; everything else loads on first use of a
public name. Two module names are not shadowed by a function of the same name:
``zonotope.correct`` and ``zonotope.evaluate`` are modules (their one-call functions are
``zonotope.correct.correct`` and ``zonotope.evaluate.evaluate``).

>>> import zonotope
>>> G = zonotope.generators("Nikon 5100 (NPL)", "D65")
>>> solid = zonotope.Zonotope(G)
>>> bool(solid.contains(solid.centroid))
True
"""

from __future__ import annotations

import importlib
from importlib.metadata import PackageNotFoundError, version

from ._errors import (
    GeometryError,
    InfeasibleResponseError,
    OptionError,
    SpectralDataError,
    UnknownMethodError,
    ZonotopeError,
)
from ._generators import GeneratorPair, generator_pair
from ._loading import SpectralFileNotFoundError, load_camera, load_reflectances
from ._registry import Method, MethodRegistry
from ._tol import REFLECTANCE_MAX, REFLECTANCE_MIN, TOL, Tolerances
from .solid import Parallelograms, Support, Zonotope
from .spectra import (
    CAMERAS,
    ILLUMINANTS,
    OBSERVERS,
    REFLECTANCES,
    camera,
    common_shape,
    generators,
    illuminant,
    list_builtin,
    observer,
    read_camera,
    read_reflectances,
    read_sfu1995,
    read_spectral_csv,
    reflectances,
    resample,
    spectral_matrix,
)
from .vora import CameraSetScore, projector, rank_camera_sets, vora_value

try:
    __version__ = version("zonotope")
except PackageNotFoundError:  # pragma: no cover - running from a source tree that is not installed
    __version__ = "0+unknown"

__all__ = [
    "CAMERAS",
    "ILLUMINANTS",
    "OBSERVERS",
    "REFLECTANCES",
    "REFLECTANCE_MAX",
    "REFLECTANCE_MIN",
    "TOL",
    "CameraSetScore",
    "GeneratorPair",
    "GeometryError",
    "InfeasibleResponseError",
    "Method",
    "MethodRegistry",
    "OptionError",
    "Parallelograms",
    "SpectralDataError",
    "SpectralFileNotFoundError",
    "Support",
    "Tolerances",
    "UnknownMethodError",
    "Zonotope",
    "ZonotopeError",
    "camera",
    "common_shape",
    "generator_pair",
    "generators",
    "illuminant",
    "list_builtin",
    "load_camera",
    "load_reflectances",
    "observer",
    "projector",
    "rank_camera_sets",
    "read_camera",
    "read_reflectances",
    "read_sfu1995",
    "read_spectral_csv",
    "reflectances",
    "resample",
    "spectral_matrix",
    "vora_value",
]

#: Public names loaded on first use, by module.
_EXPORTS = {
    "polytope": ["Polytope"],
    "membership": ["joint_halfspaces", "mmv_contains", "mmv_distance", "outside_mmv_fraction"],
    "macadam": [
        "MacAdamLimits",
        "invert",
        "is_object_colour",
        "macadam_limits",
        "object_colour_solid",
        "section",
    ],
    "mismatch": [
        "ORACLES",
        "CertifiedMMV",
        "MMVBatch",
        "MMVBatchConfig",
        "MetamerMismatch",
        "channelwise_intersection",
        "metamer_mismatch",
        "metamer_mismatch_batch",
        "metamer_mismatch_bounds",
    ],
    "prior": ["ReflectancePrior", "fiber_lsq", "interior_solution", "map_reflectance", "project_to_mmv"],
    "atypical": ["ATYPICAL_KINDS", "STRUCTURED_KINDS", "atypical_reflectances", "structured_reflectances"],
    "correct": [
        "CORRECTION_METHODS",
        "CorrectionProblem",
        "Corrector",
        "NoiseModel",
        "NoiseModelError",
        "PriorConfig",
        "check_reflectances",
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
        "noise_model",
        "root_polynomial_terms",
        "select_regression",
    ],
    "image": ["correct_image"],
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
    "evaluate": [
        "ATYPICAL_SEED",
        "DEFAULT_METHODS",
        "Evaluation",
        "EvaluationConfig",
        "EvaluationRow",
        "PairedComparison",
        "TestSet",
        "atypical_test_set",
        "atypical_test_sets",
        "natural_test_sets",
        "source_split",
    ],
    "report": ["ReportConfig", "ReportExistsError", "write_report"],
    "viz": [
        "mmv_polytope",
        "plot_grey_mmvs",
        "plot_mmv",
        "plot_mmv_comparison",
        "plot_object_colour_solid",
        "plot_sensitivities",
        "plot_spectral_locus",
        "plot_vora_chain",
    ],
    "_progress": ["ProgressCallback"],
    "_lp": ["distance_to_zonotope"],
    "_io": [
        "OutputExistsError",
        "atomic_dir",
        "atomic_file",
        "atomic_path",
        "atomic_write_bytes",
        "atomic_write_text",
        "check_output",
    ],
}
_WHERE = {name: module for module, names in _EXPORTS.items() for name in names}

__all__ += sorted(_WHERE)


def __getattr__(name: str):
    if name in _WHERE:
        value = getattr(importlib.import_module(f".{_WHERE[name]}", __name__), name)
        globals()[name] = value
        return value
    raise AttributeError(f"module 'zonotope' has no attribute {name!r}")


def __dir__():
    return sorted(set(globals()) | set(__all__))
