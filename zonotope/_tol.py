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
        Two generators are merged when their unit vectors (after orienting them alike) lie
        closer than ``parallel`` in Euclidean distance, i.e. when the angle between them is
        below ``parallel`` radians (to first order). Units matter for tabulated data: the CIE
        1931 2° CMFs at 1 nm (colour-science's table, 360–830 nm) have a tail from 699 nm whose
        chromaticity is constant only to the table's 6–7 digits; neighbouring unit vectors there
        differ by 2–6·10⁻⁸ but the run's ends by up to ~5·10⁻⁷. At the default 1e-7 the solid
        keeps 346 generators (116,292 facets); at ``parallel=1e-6`` (already from 5e-7) it keeps
        340 and agrees with the R package zonohedra, whose default ``e1 = 1e-6`` compares the
        *coordinates* of unit vectors (max-norm, groups chained along each coordinate): 340
        generators, 340·339 = 115,260 boundary parallelograms (tests/test_zonohedra.py).
        The default stays 1e-7 so that distinct measured directions are never merged.
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
