"""Spectral curves on one grid: built-in cameras, observers, illuminants and reflectance sets, file
readers (one ``load_*`` per kind), generators and generator pairs, atypical test spectra, the
choice of a scene light among candidate illuminants (``illuminant_estimate``), and sensitivities
estimated for cameras nobody measured (:mod:`~zonotope.spectra.estimate`).

Why one folder: every other part of ``zonotope`` starts from curves resampled onto one
:class:`~zonotope._tol` grid, so reading, resampling and combining them live together.
"""

from __future__ import annotations

from .._errors import float_array as float_array  # used as ``spectra.float_array`` by other modules
from ..utilities.lazy import lazy_exports
from .atypical import ATYPICAL_KINDS, STRUCTURED_KINDS, atypical_reflectances, structured_reflectances
from .builtin import (
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
from .loading import SpectralFileNotFoundError, load_camera, load_reflectances
from .pair import GeneratorPair, generator_pair

#: One loader per kind: the file readers behind load_camera / load_reflectances stay in ``builtin``.
_DEPRECATED = {
    "read_camera": ("builtin", "load_camera"),
    "read_reflectances": ("builtin", "load_reflectances"),
    "read_sfu1995": ("builtin", "load_reflectances"),
}
__getattr__, __dir__, _LAZY = lazy_exports(
    __name__,
    {
        "illuminant_estimate": [
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
        "estimate": [
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
    deprecated=_DEPRECATED,
)

__all__ = [
    "ATYPICAL_KINDS",
    "CAMERAS",
    "ILLUMINANTS",
    "OBSERVERS",
    "REFLECTANCES",
    "STRUCTURED_KINDS",
    "GeneratorPair",
    "SpectralFileNotFoundError",
    "atypical_reflectances",
    "camera",
    "common_shape",
    "generator_pair",
    "generators",
    "illuminant",
    "list_builtin",
    "load_camera",
    "load_reflectances",
    "observer",
    "read_spectral_csv",
    "reflectances",
    "resample",
    "spectral_matrix",
    "structured_reflectances",
    *_LAZY,
]
