"""One place for the numerical tolerances of the geometry (trimesh's ``tol`` idea).

All are *relative*: they are multiplied by the natural scale of the object they test
(generator lengths, solid diameter), so results do not change with units.

Vocabulary (one meaning each, across the three packages):

``tol``
    Only ever a :class:`Tolerances` object of *relative* tolerances (the ``tol`` of
    :class:`~zonotope.Zonotope`).
``atol``
    An absolute slack in the object's own units (response units): the ``atol`` of a
    :class:`~zonotope.Polytope` (constructor and attribute), of every ``contains(points, atol=...)``,
    of :func:`~zonotope.is_object_colour`, :func:`~zonotope.invert`, :func:`~zonotope.mmv_contains`
    and :attr:`~zonotope.CertifiedMMV.atol`.
``rtol``
    A relative tolerance passed as a single float (e.g. :func:`zonotope.vora.projector`).
``eps``
    The certification tolerance of a metamer mismatch volume, relative to the target's scale
    (``eps = 0``: exact; ``eps > 0``: certified inner and outer bounds).
``delta``
    Per-channel tolerance on the source response (noise), in response units.
``ambient_dim`` / ``affine_dim``
    On both :class:`~zonotope.Zonotope` and :class:`~zonotope.Polytope`: the number of
    coordinates (channels) of the space, and the dimension of the object's affine hull
    (``affine_dim ≤ ambient_dim``; -1 for an empty polytope). There is no bare ``dim``.

Array-shape letters: ``n`` wavelengths (rows of generator matrices), ``k`` source channels, ``m``
target channels, ``N`` a count of items (points, responses, reflectances). ``splat`` says
"N-channel" in prose (the thesis' name for its Gaussians), but its shape letter for channels is
``k`` too (they are the stacked cameras' source channels) and ``G`` counts Gaussians.

Why each value: float64 rounding is ε = 2.2e-16 and sums of n ≤ 10³ generators or LP solutions
carry errors of about n·ε·scale ≲ 1e-12·scale. Tolerances that decide *combinatorics* (is this
generator zero, is this point off the plane) sit three or more orders above that, so rounding never
flips a decision, and as far below the 1e-6 relative accuracy any measured spectral data carry,
so that no measured feature is merged away. The per-value reasons are next to each value.
"""

from __future__ import annotations

from dataclasses import dataclass

__all__ = [
    "AFFINE",
    "ANGLE",
    "ANGLE_ROUNDING",
    "BVLS",
    "CAP_HEMISPHERE",
    "CAP_MARGIN",
    "CERTIFY",
    "COLLINEAR",
    "FEASIBLE_ABS",
    "FEASIBLE_REL",
    "GRID",
    "LOCUS_ZERO",
    "NEGATIVE_NOISE",
    "REFLECTANCE_MAX",
    "REFLECTANCE_MIN",
    "SECTION_MERGE",
    "SECTION_PLANE",
    "SINGULAR",
    "TOL",
    "Tolerances",
]


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
        Default absolute slack of inside tests, relative to the solid's scale (its largest
        per-channel extent): ``atol = contains × scale``.

    Notes
    -----
    Reasons for the defaults:

    - ``zero = 1e-12``: dropping a generator that short moves any vertex by < 1e-12 of the
      solid's scale, the size of float64 rounding on sums of ~10³ generators: nothing a test at
      ``contains`` (1e-9) could see;
    - ``parallel = 1e-7``: see above (measured on the CIE 1931 1 nm table); the facet normal
      ``g_i × g_j`` of two generators at angle θ carries a relative error ≈ ε / θ, so keeping pairs
      at θ ≥ 1e-7 keeps normals accurate to ≈ 2e-9;
    - ``coplanar = 1e-11`` rad: only generators coplanar to rounding are grouped into one zonogon;
      a larger value would merge genuine facets of near-coplanar measured data (see
      ``_zonohedron``'s notes on the 1e-12…1e-11 rad band);
    - ``rank = 1e-10``: singular values of exact rank-deficient stacks (duplicated or linearly
      dependent channels) come out at ≈ 1e-15 relative; measured independent channels are ≥ 1e-4;
    - ``contains = 1e-9``: three orders above the ≈ 1e-12 error of the exact half-spaces, so a
      point computed *on* the boundary (a vertex, a support point) tests inside.
    """

    zero: float = 1e-12
    parallel: float = 1e-7
    coplanar: float = 1e-11
    rank: float = 1e-10
    contains: float = 1e-9


#: The tolerances every function uses unless given others: :class:`Tolerances` with its defaults.
TOL = Tolerances()

#: Affine-hull flatness of a :class:`~zonotope.Polytope`, relative to its diameter: points farther
#: than ``AFFINE × diameter`` from a hyperplane span another dimension. MMV vertices come from the
#: simplex oracle exact to ≈ 1e-12 of the scale; 1e-9 leaves a margin of 10³ against rounding
#: while keeping every MMV thicker than a billionth of the target scale full-dimensional. It is
#: also the default ``atol`` of a polytope's inside test and of its half-space conversion.
AFFINE = 1e-9

#: Coplanar hull triangles (Qhull triangulates every facet) are one facet when their unit normals
#: satisfy ``1 − cos θ < ANGLE`` (θ < 4.5e-5 rad) and their offsets agree to ``AFFINE``. Triangles of
#: one true facet agree to rounding; distinct facets of a certified MMV differ by far more.
ANGLE = 1e-9

#: Exact MMVs (``eps = 0``): a facet is certified when the support value in its direction exceeds its
#: offset by at most ``CERTIFY × target scale``. Equal to :data:`AFFINE` so that the exact
#: polytope and its affine hull use one threshold; the support values are LP optima exact to
#: ≈ 1e-12 of the scale.
CERTIFY = 1e-9

#: ``on_infeasible="nearest"``: the tolerance δ that makes an infeasible response feasible is its LP
#: distance to the solid times ``1 + FEASIBLE_REL`` plus ``FEASIBLE_ABS × scale``. HiGHS reports the
#: distance to its primal feasibility tolerance (1e-7), so a smaller margin leaves the LP infeasible.
FEASIBLE_REL = 1e-7

#: See :data:`FEASIBLE_REL` (absolute part, relative to the source scale: a response exactly on
#: the boundary, distance 0, still gets a strictly positive δ).
FEASIBLE_ABS = 1e-10

#: 2-D convex hulls of a :class:`~zonotope.Polytope` (Andrew's monotone chain): a point is dropped
#: as collinear when the cross product of its two edges is at most ``COLLINEAR ×`` the product of
#: their extents, i.e. when the turn is below ≈ 1e-15 rad. That is a few float64 roundings (ε =
#: 2.2e-16) of the cross product itself: only points collinear to rounding are dropped, so a polygon
#: never loses a genuine vertex, and a rounding-level bump never becomes one.
COLLINEAR = 1e-15

#: Vertex enumeration of a thin or flat ``{y : A y ≤ b}`` (unit rows): an m-subset of rows whose
#: ``|det|`` is at most ``SINGULAR`` is skipped as (nearly) parallel. Its intersection point would
#: carry a relative error ≈ ε / |det| ≳ 2e-4, far above :data:`AFFINE`; every vertex of the polytope
#: is also reached from a well-conditioned subset of its active rows (for unit normals of distinct
#: facets, |det| is the volume of their parallelotope, ≫ 1e-12).
SINGULAR = 1e-12

#: --- zonotope core (issue 10: facet sweep, MMV walk, refinement, membership) -------------------

#: Facet sweep of a zonohedron: the angle of generator k in the sweep of generator i (its direction
#: in the plane ⊥ h_i) is rounded by ≈ ``ANGLE_ROUNDING / s_ik`` rad, s_ik the sine of the angle
#: between them: the projection has length |h_k|·s_ik and an absolute error of a few ε·|h_k|
#: (ε = 2.2e-16; measured 0.2 ε/s on the near-parallel pair of tests/test_solid.py). Coplanarity
#: (``Tolerances.coplanar``) is decided within that tolerance *plus* this rounding, so an exactly
#: coplanar triple with a near-parallel pair is never split into slivers. 16 ε leaves a margin of
#: ~80× over the measured rounding and stays ≤ 4e-8 rad for pairs kept apart by ``parallel``.
ANGLE_ROUNDING = 16 * 2.220446049250313e-16

#: Wavelength comparisons (grid snapping of ``common_shape``, "does the curve cover the grid?"),
#: relative to the wavelength: grids built with ``arange``/``linspace`` differ from their ideal
#: values by a few ulps (≈ 1e-13 nm at 700 nm), and measured tables are tabulated to ≥ 0.1 nm,
#: so 1e-9 separates float noise from a real difference by four orders either way.
GRID = 1e-9

#: A spectral curve's negative values above ``-NEGATIVE_NOISE ×`` its peak are float noise left by
#: interpolation where a curve reaches 0 (colour leaves values like -3e-22) and are cleared; a real
#: negative lobe (a colour-matching function) is ≥ 1e-3 of the peak.
NEGATIVE_NOISE = 1e-12

#: Reflectances are accepted in ``[REFLECTANCE_MIN, REFLECTANCE_MAX]``: slightly negative values
#: (≥ -1e-6: the rounding of measured or resampled data) and fluorescent/gloss values up to 1.5;
#: anything outside is refused, which catches percent data (values up to 100) without clipping them.
REFLECTANCE_MIN = -1e-6

#: See :data:`REFLECTANCE_MIN`.
REFLECTANCE_MAX = 1.5

# --- sections, reflectances of boundary points, cube map, plots (spectra/macadam/_cubemap/viz) ---

#: :func:`zonotope.macadam.section`: an edge end within ``SECTION_PLANE × scale`` of the cutting
#: plane lies *on* it (it is a vertex of the section), farther ends are on one side. The signed
#: distances are dot products of coordinates of size ``scale`` and carry ≈ 10 ε · scale ≈ 2e-15 ·
#: scale of rounding; 1e-13 is fifty times that, and four orders below :data:`SECTION_MERGE`, so a
#: vertex is never counted on both sides and never lost between them.
SECTION_PLANE = 1e-13

#: :func:`zonotope.macadam.section`: cut points closer than ``SECTION_MERGE × scale`` (rounded to
#: that grid) are one vertex — the same vertex reached from the edges of neighbouring facets, which
#: agree to the ≈ 1e-15 · scale rounding of the edge interpolation. Distinct vertices of a measured
#: solid's section lie ≥ 1e-6 · scale apart (one generator's length at 10 nm is ≈ 1e-2 · scale).
SECTION_MERGE = 1e-10

#: :func:`zonotope.macadam.reflectance_for` on a zonogon facet: the ``tol`` of scipy's bounded least
#: squares (``lsq_linear(method="bvls")``) over the facet's coplanar generators. At its floor
#: (float64 rounding) so that the reflectance re-integrates to the point to ≈ 1e-15 relative, which
#: the tests check; the problem is at most a few dozen generators, so the cost is nil.
BVLS = 1e-15

#: Cube map of :meth:`zonotope.Zonotope.contains`: a facet whose shadow's angular cap is within
#: ``CAP_HEMISPHERE`` rad of a hemisphere (π/2) is made a candidate of every cell. The shadow of a
#: facet is spherically convex only when its cap is below a hemisphere, and the cap angle itself
#: comes from ``arccos`` of a minimum cosine, whose rounding near π/2 is ≈ ε; 1e-6 rad is far above
#: that and costs nothing (such facets — huge and close to the centre — are rare).
CAP_HEMISPHERE = 1e-6

#: Cube map: the angular margin (rad) added to every facet's cap before the cap/cell overlap test,
#: so that rounding of the ``arccos`` of unit-vector dot products (≈ ε / sin θ ≲ 1e-12 rad away
#: from θ ≈ 0) never drops the exit facet from a cell's candidates. A larger margin only adds
#: candidates (never changes an answer: the test is exact over the candidates, see ``_cubemap``).
CAP_MARGIN = 1e-9

#: :func:`zonotope.viz.plot_spectral_locus`: wavelengths whose target generator is shorter than
#: ``LOCUS_ZERO ×`` the longest one are not drawn: their direction is rounding noise of a curve that
#: has reached 0 (the tails of the CIE observers fall to ≈ 1e-7 of the peak before they are 0).
#: A drawing threshold only; no computed value depends on it.
LOCUS_ZERO = 1e-9
