"""One place for the numerical tolerances of the geometry (trimesh's ``tol`` idea).

All are *relative*: they are multiplied by the natural scale of the object they test
(generator lengths, solid diameter), so results do not change with units.
"""

from __future__ import annotations

from dataclasses import dataclass

__all__ = ["TOL", "Tolerances"]


@dataclass(frozen=True)
class Tolerances:
    """Relative tolerances used by the geometry.

    Attributes
    ----------
    zero
        A generator shorter than ``zero`` × the longest one is dropped (it adds nothing).
    parallel
        Two unit generators closer than this (after orienting them alike) are merged.
    coplanar
        Angular tolerance (radians) under which a third generator counts as lying in the plane
        of two others, so that their facet is one zonogon instead of several slivers.
    rank
        Singular values below ``rank`` × the largest count as zero.
    contains
        Default absolute slack of inside tests, relative to the solid's diameter.
    """

    zero: float = 1e-12
    parallel: float = 1e-7
    coplanar: float = 1e-11
    rank: float = 1e-10
    contains: float = 1e-9


TOL = Tolerances()
