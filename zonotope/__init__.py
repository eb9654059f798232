"""zonotope — geometric colour science of cameras.

Exact object-colour solids (zonotopes), metamer mismatch volumes, Vora values and
metamer-based colour correction.

>>> import zonotope
>>> G = zonotope.generators("Nikon 5100 (NPL)", "D65")
>>> solid = zonotope.Zonotope(G)
>>> bool(solid.contains(solid.centroid))
True
"""

from ._errors import GeometryError, InfeasibleResponseError, SpectralDataError, ZonotopeError
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

__all__ = [
    "CAMERAS",
    "ILLUMINANTS",
    "OBSERVERS",
    "REFLECTANCES",
    "GeometryError",
    "InfeasibleResponseError",
    "SpectralDataError",
    "ZonotopeError",
    "camera",
    "common_shape",
    "generators",
    "illuminant",
    "list_builtin",
    "observer",
    "read_camera",
    "read_reflectances",
    "read_sfu1995",
    "read_spectral_csv",
    "reflectances",
    "resample",
    "spectral_matrix",
]
__version__ = "0.1.0"

from ._tol import TOL, Tolerances
from .solid import Support, Zonotope

__all__ += ["TOL", "Support", "Tolerances", "Zonotope"]

from .vora import CameraSetScore, projector, rank_camera_sets, vora_value  # noqa: E402

__all__ += ["CameraSetScore", "projector", "rank_camera_sets", "vora_value"]
