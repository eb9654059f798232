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

>>> import isp
>>> isp.default_pipeline(demosaic="Menon 2007").names[2]
'demosaic'
"""

from ._errors import PipelineError, PipelineMethodError, RawFormatError
from .dng import (
    DNGProfile,
    camera_neutral_to_xy,
    matrix_interpolated,
    read_dng_tags,
    write_dng,
    xy_to_camera_neutral,
)
from .exif import output_tags, srgb_icc_profile
from .io import write_image
from .metamer import MetamerCorrection, metamer_correction
from .pipeline import Development, Pipeline, Stage, chain, correction_stage, default_pipeline, develop
from .raw import CFA_PATTERNS, RawImage, read_raw
from .stages import (
    DEMOSAIC_METHODS,
    TONEMAP_METHODS,
    XYZ_to_linear_sRGB,
    apply_correction,
    camera_to_XYZ,
    cfa_masks,
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
    "DNGProfile",
    "Development",
    "MetamerCorrection",
    "Pipeline",
    "PipelineError",
    "PipelineMethodError",
    "RawFormatError",
    "RawImage",
    "Stage",
    "XYZ_to_linear_sRGB",
    "apply_correction",
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
    "matrix_XYZ_from_balanced",
    "matrix_interpolated",
    "metamer_correction",
    "mosaic",
    "orient",
    "output_tags",
    "read_dng_tags",
    "read_raw",
    "srgb_icc_profile",
    "tonemap",
    "white_balance",
    "white_balance_neutral",
    "write_dng",
    "write_image",
    "xy_to_camera_neutral",
]
