"""Metamer mismatch volumes: :class:`MetamerMismatch` and :func:`metamer_mismatch` (``volume``), the
exact vertex walk and its numba kernel (``walk``, ``walk_kernel``), facet refinement (``refine``), the
support-LP oracles (``oracle``), membership tests (``membership``) and the generators of a change of
light (``illuminant``: illuminant-induced MMVs).

Why one folder: these modules are the steps of one computation, the MMV of a response.
"""

from __future__ import annotations

from ..utilities.lazy import lazy_exports
from .volume import (
    ORACLES,
    CertifiedMMV,
    MetamerMismatch,
    MMVBatch,
    MMVBatchConfig,
    channelwise_intersection,
    metamer_mismatch,
    metamer_mismatch_batch,
    metamer_mismatch_bounds,
)

__getattr__, __dir__, _LAZY = lazy_exports(
    __name__,
    {
        "membership": [
            "joint_halfspaces",
            "mmv_contains",
            "mmv_distance",
            "outside_mmv_fraction",
            "solid_distance",
        ],
        "illuminant": ["illuminant_mismatch", "illuminant_pair", "relative_volume"],
    },
)

__all__ = [
    "ORACLES",
    "CertifiedMMV",
    "MMVBatch",
    "MMVBatchConfig",
    "MetamerMismatch",
    "channelwise_intersection",
    "metamer_mismatch",
    "metamer_mismatch_batch",
    "metamer_mismatch_bounds",
    *_LAZY,
]
