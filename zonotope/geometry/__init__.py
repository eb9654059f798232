"""Convex geometry of colour: the object-colour solid (:class:`Zonotope`), general polytopes,
MacAdam limits, the LP distance to a zonotope.

Why lazy: ``import zonotope`` loads the solid; polytopes and MacAdam limits load on first use.
"""

from __future__ import annotations

from ..utilities.lazy import lazy_exports
from .solid import Parallelograms, Support, Zonotope

__getattr__, __dir__, _LAZY = lazy_exports(
    __name__,
    {
        "polytope": ["Polytope"],
        "macadam": [
            "MacAdamLimits",
            "invert",
            "is_object_colour",
            "macadam_limits",
            "object_colour_solid",
            "section",
        ],
        "lp": ["distance_to_zonotope"],
    },
)

__all__ = ["Parallelograms", "Support", "Zonotope", *_LAZY]
