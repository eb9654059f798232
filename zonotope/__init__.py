"""zonotope — geometric colour science of cameras.

Exact object-colour solids (zonotopes), metamer mismatch volumes, Vora values and
metamer-based colour correction.

Module map, in data-flow order (each layer imports only the layers above it; the test
``tests/test_architecture.py`` enforces it and that no import circle exists):

========================  ========================================================================
``utilities``             plumbing: :class:`~zonotope.utilities.MethodRegistry` for every ``method=``
                          table, atomic output files, config checks, progress callbacks, lazy exports
``spectra``               spectral curves on one grid: built-in cameras, observers, illuminants,
                          reflectance sets; file readers; :func:`generators`; :class:`GeneratorPair`;
                          atypical test spectra; :func:`estimate_ssf` for cameras nobody measured
``geometry``              :class:`Zonotope` (object-colour solid, exact), :class:`Polytope`, MacAdam limits
``mismatch``              metamer mismatch volumes (:func:`metamer_mismatch`, :class:`MetamerMismatch`):
                          vertex walk, facet refinement, oracles, membership
``correct``               estimators: :func:`fit_correction` over :data:`CORRECTION_METHODS`,
                          :func:`correct_image`, saved corrections and 3-D LUTs
``vora``, ``evaluate``    applications: Vora values, ΔE00 evaluation, camera surveys, executors,
``survey``, ``parallel``  HTML/Markdown reports, pictures
``report``, ``viz``,
``ssf_band``              (:func:`ssf_noise`, :func:`band_mmvs`, :func:`ssf_response_errors`,
                          :func:`unit_sigma`, :func:`curves_sigma`: the SSF band in noise, MMVs
                          and error draws; the spread of published curves)
``cli``                   the ``zonotope`` command
========================  ========================================================================

Shared at the top: ``_errors`` (one exception hierarchy) and ``_tol`` (every tolerance, with its
reason). Old module paths (``zonotope.solid``, ``zonotope.prior``, ...) still import, with a
:class:`DeprecationWarning`, through the one table ``_MOVED_MODULES``.

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

from importlib.metadata import PackageNotFoundError, version

from ._errors import (
    GeometryError,
    InfeasibleResponseError,
    OptionError,
    SpectralDataError,
    UnknownMethodError,
    ZonotopeError,
)
from ._tol import REFLECTANCE_MAX, REFLECTANCE_MIN, TOL, Tolerances
from .geometry.solid import Parallelograms, Support, Zonotope
from .spectra.builtin import (
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
    read_spectral_csv,
    reflectances,
    resample,
    spectral_matrix,
)
from .spectra.loading import SpectralFileNotFoundError, load_camera, load_reflectances
from .spectra.pair import GeneratorPair, generator_pair
from .utilities.lazy import install_moved_modules, lazy_exports
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
    "read_spectral_csv",
    "reflectances",
    "resample",
    "spectral_matrix",
    "vora_value",
]

#: Old dotted module name -> its module now. Served by one import hook: importing an old name warns
#: (DeprecationWarning) and returns the new module object.
_MOVED_MODULES = {
    "zonotope._registry": "zonotope.utilities.registry",
    "zonotope._io": "zonotope.utilities.io",
    "zonotope._config": "zonotope.utilities.config",
    "zonotope._progress": "zonotope.utilities.progress",
    "zonotope._loading": "zonotope.spectra.loading",
    "zonotope._generators": "zonotope.spectra.pair",
    "zonotope.atypical": "zonotope.spectra.atypical",
    "zonotope.solid": "zonotope.geometry.solid",
    "zonotope._zonohedron": "zonotope.geometry.zonohedron",
    "zonotope.polytope": "zonotope.geometry.polytope",
    "zonotope.macadam": "zonotope.geometry.macadam",
    "zonotope._cubemap": "zonotope.geometry.cubemap",
    "zonotope._lp": "zonotope.geometry.lp",
    "zonotope._mmv_walk": "zonotope.mismatch.walk",
    "zonotope._mmv_walk_kernel": "zonotope.mismatch.walk_kernel",
    "zonotope._mmv_refine": "zonotope.mismatch.refine",
    "zonotope._oracle": "zonotope.mismatch.oracle",
    "zonotope.membership": "zonotope.mismatch.membership",
    "zonotope._correction_problem": "zonotope.correct.problem",
    "zonotope._regressions": "zonotope.correct.regressions",
    "zonotope._mmv_estimators": "zonotope.correct.mmv",
    "zonotope.prior": "zonotope.correct.prior",
    "zonotope._bvls": "zonotope.correct.bvls",
    "zonotope.image": "zonotope.correct.image",
    "zonotope.profile": "zonotope.correct.profile",
    "zonotope._batch_cli": "zonotope.cli.batch",
}
install_moved_modules(_MOVED_MODULES)

#: Public names loaded on first use, by module (relative to this package).
__getattr__, __dir__, _LAZY = lazy_exports(
    __name__,
    {
        "geometry.polytope": ["Polytope"],
        "mismatch.membership": [
            "joint_halfspaces",
            "mmv_contains",
            "mmv_distance",
            "outside_mmv_fraction",
            "solid_distance",
        ],
        "mismatch.illuminant": ["illuminant_mismatch", "illuminant_pair", "relative_volume"],
        "spectra.illuminant_estimate": [
            "CANDIDATE_KINDS",
            "IlluminantEstimate",
            "candidate_illuminants",
            "estimate_illuminant",
            "grey_card",
            "grey_edge",
            "grey_world",
            "white_angle",
            "white_patch",
        ],
        "geometry.macadam": [
            "MacAdamLimits",
            "invert",
            "is_object_colour",
            "macadam_limits",
            "object_colour_solid",
            "section",
        ],
        "mismatch.volume": [
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
        "correct.eiv": ["fit_errors_in_variables"],
        "correct.prior": [
            "ReflectancePrior",
            "fiber_lsq",
            "interior_solution",
            "map_reflectance",
            "posterior_radius",
            "project_to_mmv",
        ],
        "spectra.atypical": [
            "ATYPICAL_KINDS",
            "STRUCTURED_KINDS",
            "atypical_reflectances",
            "structured_reflectances",
        ],
        "correct.methods": [
            "CORRECTION_METHODS",
            "DELTA_SIGMAS",
            "IMAGE_METHOD",
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
            "fit_Guarded",
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
        ],
        "correct.image": ["correct_image"],
        "correct.neutral": ["neutral_offsets", "white_point_preserving"],
        "correct.profile": [
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
        "ssf_band": [
            "BandMMVs",
            "band_mmvs",
            "curves_sigma",
            "ssf_noise",
            "ssf_response_errors",
            "unit_sigma",
        ],
        "viz": [
            "mmv_polytope",
            "plot_grey_mmvs",
            "plot_mmv",
            "plot_mmv_band",
            "plot_mmv_comparison",
            "plot_object_colour_solid",
            "plot_sensitivities",
            "plot_spectral_locus",
            "plot_vora_chain",
        ],
        "geometry.lp": ["distance_to_zonotope"],
        "spectra.estimate": [
            "SSF_SHAPE",
            "Chart",
            "DNGMatrices",
            "SSFBasis",
            "SSFCalibration",
            "SSFEstimate",
            "estimate_ssf",
            "learn_ssf_basis",
            "read_dng_matrices",
            "read_ssf_band",
            "read_ssf_estimate",
            "sample_ssfs",
            "ssf_basis",
            "synthesise_dng_matrices",
            "write_ssf_json",
        ],
    },
    eager=__all__,
    deprecated={
        "read_camera": ("spectra.builtin", "load_camera"),
        "read_reflectances": ("spectra.builtin", "load_reflectances"),
        "read_sfu1995": ("spectra.builtin", "load_reflectances"),
    },
)
__all__ += _LAZY
