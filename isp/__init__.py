"""isp — a RAW processing pipeline, one replaceable operation at a time.

Read a RAW/DNG file (:func:`read_raw`), develop it with a :class:`Pipeline` of small pure stages
(:func:`default_pipeline`: linearise → white balance → demosaic → camera → XYZ → linear sRGB →
tone mapping → sRGB encoding → orientation), replace or reorder any stage, inspect every
intermediate, and write 16-bit TIFF/PNG atomically (:func:`write_image`; TIFFs with the sRGB ICC
profile and the camera's metadata of :mod:`isp.exif`). :mod:`isp.whitebalance` turns a white-balance
choice (as shot, a temperature, an illuminant, a grey patch) into the camera neutral. When the
camera's spectral sensitivities are known, :func:`metamer_correction` replaces the DNG ColorMatrix
by a ``zonotope.correct`` estimator.
:mod:`isp.simulate` renders spectral scenes through a camera's sensitivities into real DNG files.

Module map, in data-flow order (``isp`` uses only public ``zonotope`` names and never ``splat``):

- ``cfa``: Bayer patterns (:data:`CFA_PATTERNS`, :func:`cfa_masks`);
- ``raw``, ``dng``, ``exif``: RAW/DNG reading (:class:`RawImage`), DNG tags and colour matrices,
  output metadata;
- ``stages``, ``whitebalance``: the pure operations (:data:`DEMOSAIC_METHODS`,
  :data:`TONEMAP_METHODS` registries), white-balance choices;
- ``pipeline``: :class:`Pipeline` / :func:`default_pipeline` / :func:`develop`;
- ``metamer``: the bridge to ``zonotope.correct`` (:func:`metamer_correction`);
- ``profiles``: camera profiles (``profiles.dcp`` read/write/apply DCPs, ``profiles.fitting`` fit
  them to sensitivities, ``profiles.chart`` to a photographed chart, ``profiles.icc`` ICC profiles,
  ``profiles.lut`` 3-D LUTs, ``profiles.tone`` the default tone curve, ``profiles.models`` camera
  model aliases, ``profiles.rawtherapee`` check against RawTherapee);
- ``io``, ``batch``: atomic image files, folders of RAW files;
- ``cli``: the ``isp`` command, on top of the library (no library module imports it);
- ``simulate``: the spectral forward model (reflectances → RAW mosaic → DNG).

The names of ``simulate``, ``profiles`` and ``batch`` load on first use.

>>> import isp
>>> isp.default_pipeline(demosaic="Menon 2007").names[2]
'demosaic'
"""

from zonotope.utilities.lazy import install_moved_modules, lazy_exports

from ._errors import InputFileNotFoundError, PipelineError, PipelineMethodError, RawFormatError
from .cfa import CFA_PATTERNS, cfa_masks
from .dng import (
    DNGMetadata,
    DNGProfile,
    camera_neutral_to_xy,
    matrix_interpolated,
    noise_profile,
    read_dng_tags,
    write_dng,
    xy_to_camera_neutral,
)
from .exif import output_tags, srgb_icc_profile
from .io import write_image
from .metamer import (
    MetamerConfig,
    MetamerCorrection,
    maker_mismatch,
    metamer_correction,
    metamer_noise,
    photograph_method,
    sensitivities_maker,
)
from .pipeline import Development, Pipeline, Stage, chain, correction_stage, default_pipeline, develop
from .raw import RawImage, auto_white_balance, read_raw
from .stages import (
    DEMOSAIC_METHODS,
    TONEMAP_METHODS,
    XYZ_to_linear_sRGB,
    apply_correction,
    camera_to_XYZ,
    demosaic,
    encode_sRGB,
    linearise,
    matrix_XYZ_from_balanced,
    mosaic,
    orient,
    tonemap,
    white_balance,
)
from .whitebalance import white_balance_neutral

__all__ = [
    "CFA_PATTERNS",
    "DEMOSAIC_METHODS",
    "TONEMAP_METHODS",
    "DNGMetadata",
    "DNGProfile",
    "Development",
    "InputFileNotFoundError",
    "MetamerConfig",
    "MetamerCorrection",
    "Pipeline",
    "PipelineError",
    "PipelineMethodError",
    "RawFormatError",
    "RawImage",
    "Stage",
    "XYZ_to_linear_sRGB",
    "apply_correction",
    "auto_white_balance",
    "camera_neutral_to_xy",
    "camera_to_XYZ",
    "cfa_masks",
    "chain",
    "correction_stage",
    "default_pipeline",
    "demosaic",
    "develop",
    "encode_sRGB",
    "linearise",
    "maker_mismatch",
    "matrix_XYZ_from_balanced",
    "matrix_interpolated",
    "metamer_correction",
    "metamer_noise",
    "mosaic",
    "noise_profile",
    "orient",
    "output_tags",
    "photograph_method",
    "read_dng_tags",
    "read_raw",
    "sensitivities_maker",
    "srgb_icc_profile",
    "tonemap",
    "white_balance",
    "white_balance_neutral",
    "write_dng",
    "write_image",
    "xy_to_camera_neutral",
]

#: Public names loaded on first use, by module (heavier, or needed only by some users).
_LAZY = {
    "simulate": [
        "ILLUMINANT_LIGHT_SOURCE",
        "Capture",
        "SensorConfig",
        "SpectralSetup",
        "chart_image",
        "default_training",
        "fit_color_matrix",
        "simulate_capture",
        "simulate_dng",
        "spectral_setup",
        "true_XYZ",
    ],
    "profiles.dcp": [
        "DCP_TAGS",
        "DCPError",
        "DCPProfile",
        "apply_hue_sat_map",
        "apply_tone_curve",
        "dcp_stage",
        "profile_pipeline",
        "read_dcp",
        "write_dcp",
    ],
    "profiles.fitting": [
        "DCP_DEFAULT_DIMS",
        "LOOK_TABLE_DEFAULT_DIMS",
        "ProfileConfig",
        "ProfileFit",
        "fit_dcp",
        "fit_hue_sat_map",
        "profile_reflectances",
    ],
    "profiles.chart": [
        "CHART_TYPES",
        "REPORT_CSV_HEADER",
        "REPORT_MARK",
        "ChartError",
        "ChartFit",
        "ChartReading",
        "ChartType",
        "chart_dcp",
        "chart_patch_centres",
        "chart_reference",
        "fit_chart",
        "read_chart",
        "write_chart_report",
    ],
    "profiles.icc": ["ICC_CREATOR", "ICC_D50", "ICCError", "icc_profile", "read_icc_matrix", "write_icc"],
    "profiles.lut": ["lut_header", "profile_LUT"],
    "profiles.models": ["CAMERA_ALIASES", "canonical_model", "same_camera"],
    "profiles.tone": ["MID_GREY_OUT", "TOE_POWER", "camera_tone_curve"],
    "batch": ["RAW_SUFFIXES", "develop_file", "develop_folder", "raw_files"],
    "whitebalance": ["CCT_RANGE", "describe_white_balance", "white_balance_xy"],
    "dng": ["DNG_TAGS", "LIGHT_SOURCE_CCT", "xy_to_CCT_DNG"],
    "io": ["IMAGE_FORMATS", "to_uint16"],
    "cfa": ["check_cfa"],
    "metamer": ["METAMER_RANGE"],
    "stages": [
        "default_method",
        "demosaic_Malvar2004",
        "demosaic_Menon2007",
        "demosaic_bilinear",
        "auto_bright_white",
        "tonemap_Reinhard2002",
        "tonemap_auto_bright",
        "tonemap_clip",
    ],
}
__getattr__, __dir__, _lazy_names = lazy_exports(__name__, _LAZY, eager=__all__)
__all__ += _lazy_names

#: Module paths that moved, old dotted name -> new one: importing an old one warns and gives the new module.
_MOVED_MODULES = {
    "isp.dcp": "isp.profiles.dcp",
    "isp.profile_fit": "isp.profiles.fitting",
    "isp.rawtherapee": "isp.profiles.rawtherapee",
}
install_moved_modules(_MOVED_MODULES)
