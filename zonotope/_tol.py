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
    "CONE_INTERIOR",
    "CONE_STEPS",
    "DEGENERATE",
    "EDGE_ZERO",
    "FEASIBLE_ABS",
    "FEASIBLE_REL",
    "GRID",
    "HIGHS_FEASIBILITY",
    "HULL2_COLLINEAR",
    "HYPERPLANE_RANK",
    "LOCUS_ZERO",
    "MAGNITUDE_MAX",
    "MAGNITUDE_MIN",
    "NEGATIVE_NOISE",
    "NORMAL_ZERO",
    "PARALLEL_EDGES",
    "PARALLEL_PREFILTER",
    "PHASE1",
    "PIVOT",
    "RATIO_PIVOT",
    "REDUCED_COST",
    "REFLECTANCE_MAX",
    "REFLECTANCE_MIN",
    "SECTION_MERGE",
    "SECTION_PLANE",
    "SINGULAR",
    "SWEEP_GENERIC",
    "TOL",
    "VERTEX_MERGE",
    "ZONOGON_HALFTURN",
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
      ``geometry.zonohedron``'s notes on the 1e-12…1e-11 rad band);
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

#: ``on_infeasible="nearest"``: the tolerance δ that makes an infeasible response feasible is its
#: distance to the solid times ``1 + FEASIBLE_REL`` plus ``FEASIBLE_ABS × scale``. The distance is the
#: one the LP's reflectance (clipped to [0, 1]) attains, not HiGHS' reported optimum, which may fall
#: short by its primal feasibility tolerance (≈ 1e-7, absolute) — more than this margin, which only
#: has to cover the round-off of re-solving at δ.
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

# --- sections, reflectances of boundary points, cube map, plots (spectra/macadam/cubemap/viz) ---

#: :func:`zonotope.geometry.macadam.section`: an edge end within ``SECTION_PLANE × scale`` of the cutting
#: plane lies *on* it (it is a vertex of the section), farther ends are on one side. The signed
#: distances are dot products of coordinates of size ``scale`` and carry ≈ 10 ε · scale ≈ 2e-15 ·
#: scale of rounding; 1e-13 is fifty times that, and four orders below :data:`SECTION_MERGE`, so a
#: vertex is never counted on both sides and never lost between them.
SECTION_PLANE = 1e-13

#: :func:`zonotope.geometry.macadam.section`: cut points closer than ``SECTION_MERGE × scale`` (rounded to
#: that grid) are one vertex — the same vertex reached from the edges of neighbouring facets, which
#: agree to the ≈ 1e-15 · scale rounding of the edge interpolation. Distinct vertices of a measured
#: solid's section lie ≥ 1e-6 · scale apart (one generator's length at 10 nm is ≈ 1e-2 · scale).
SECTION_MERGE = 1e-10

#: :func:`zonotope.geometry.macadam.reflectance_for` on a zonogon facet: the ``tol`` of scipy's bounded least
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
#: candidates (never changes an answer: the test is exact over the candidates, see ``geometry.cubemap``).
CAP_MARGIN = 1e-9

#: :func:`zonotope.viz.plot_spectral_locus`: wavelengths whose target generator is shorter than
#: ``LOCUS_ZERO ×`` the longest one are not drawn: their direction is rounding noise of a curve that
#: has reached 0 (the tails of the CIE observers fall to ≈ 1e-7 of the peak before they are 0).
#: A drawing threshold only; no computed value depends on it.
LOCUS_ZERO = 1e-9

# --- MMV engine: simplex kernels, vertex walk, refinement, membership; zonohedron sweeps -------
# The numba kernels (mismatch.walk_kernel) read these as compile-time constants and cache the compiled
# code on disk keyed by the kernel's own source file: after changing a value used there, delete
# zonotope/mismatch/__pycache__/walk_kernel.* so that it is recompiled.

#: Simplex kernels (walk, ``mmv_distance``): a basis matrix whose Gauss–Jordan pivot falls below
#: ``PIVOT ×`` its largest entry is singular. Basis columns are source generators (|det| of a
#: well-posed 3-channel basis is ≥ 1e-6 of the entries³ on measured cameras); elimination leaves
#: pivots of exactly dependent columns at ≈ k ε ≈ 1e-15 of the largest entry, so 1e-13 separates
#: them with two orders either way.
PIVOT = 1e-13

#: Simplex pricing (walk, ``mmv_distance``, :class:`~zonotope.mismatch.oracle.SimplexOracle`): a reduced
#: cost counts as improving above ``REDUCED_COST ×`` the largest objective coefficient. Reduced
#: costs are sums of ≈ n products, rounded to ≈ n ε ≈ 1e-14 of that coefficient at n ≤ 100; 1e-11
#: stops on rounding noise (no cycling on ties) while a support LP's optimum moves by at most
#: 1e-11 × Σ|Ψu| ≈ 1e-11 of the target scale, below :data:`CERTIFY`.
REDUCED_COST = 1e-11

#: Phase 1 (walk, :class:`~zonotope.mismatch.oracle.SimplexOracle`, ``mmv_distance``): a response is
#: feasible when the artificial variables sum to at most ``PHASE1 × scale`` (source scale, or 1).
#: Equal to :data:`CERTIFY`: a response on the solid's boundary computed in float64 (≈ 1e-15 ·
#: scale off) is feasible, one a billionth of the scale outside is not.
PHASE1 = 1e-9

#: Vertex walk: an edge vector shorter than ``EDGE_ZERO ×`` the target scale is zero (a non-basic
#: wavelength the target does not see, after the basic variables compensate). Edge vectors are
#: differences of sums of k+1 products of size ≈ scale/n, rounded to ≈ 1e-16 · scale; the shortest
#: real edges of a 5 nm MMV are ≈ 1e-6 · scale.
EDGE_ZERO = 1e-13

#: Vertex walk: a basic variable within ``DEGENERATE × (hi − lo)`` of a bound makes the vertex
#: degenerate (more than k + 3 active bounds); the walk then declines and refinement answers.
#: Basic values come from a k×k solve with ≈ 1e-15 relative rounding; 1e-12 flags ties of
#: rounding size and no genuine vertex (bounded away from its bounds by ≥ 1e-9 on measured data).
DEGENERATE = 1e-12

#: Vertex walk: a direction w is interior to a vertex's normal cone when a·w > ``CONE_INTERIOR ×``
#: |a| |w| for every edge vector a (sin of its angle to each cone facet above 1e-10 rad). Well above
#: the ≈ 1e-16 rounding of the products, and far below the angular size of any real normal cone
#: (an MMV with 5 000 vertices has cones of ≈ 1e-3 sr).
CONE_INTERIOR = 1e-10

#: Vertex walk, the search for an interior direction: the steps η tried along the direction back
#: into the cone (w = w₀ + η d₀), largest first; then a perceptron. Not a tolerance but a schedule:
#: η = 0.1 almost always succeeds, the smaller steps cover thin cones down to :data:`CONE_INTERIOR`.
CONE_STEPS = (0.0, 1e-1, 1e-2, 1e-3, 1e-4, 1e-5, 1e-6, 1e-7, 1e-8, 1e-9)

#: Vertex walk, 2-D hull of the central projections of a cone's edge vectors: points whose cross
#: product lies within ``HULL2_COLLINEAR × span²`` of a hull edge are collinear with it (the
#: farthest is kept). The cross products carry ≈ 4 ε · span² ≈ 1e-15 · span² of rounding; real
#: turns of the projected edges are ≳ 1e-8.
HULL2_COLLINEAR = 1e-14

#: Vertex walk: two projected edge vectors closer than ``PARALLEL_EDGES × span`` in both
#: coordinates are parallel (one hull point twice): single moves cannot cross such a cone facet,
#: so the walk declines. Projections are exact to ≈ 1e-15 · span; distinct measured edge
#: directions differ by ≥ 1e-7 rad (:attr:`Tolerances.parallel`).
PARALLEL_EDGES = 1e-12

#: :class:`~zonotope.mismatch.oracle.SimplexOracle` ratio test: basic variables whose rate of change is
#: below ``RATIO_PIVOT`` (in variable units per unit step, variables in [0, 1]) do not bound the
#: step. Dropping pivots that small keeps the basis well conditioned (|pivot| ≥ 1e-9 bounds the
#: growth of the basis inverse) at the cost of a bound violation ≤ 1e-9 × step ≤ 1e-9, which phase
#: 2 removes and :data:`PHASE1` tolerates.
RATIO_PIVOT = 1e-9

#: :class:`~zonotope.mismatch.oracle.HighsOracle` (reference twin): HiGHS' primal and dual feasibility
#: tolerances, tightened from their default 1e-7 so that the reference's support values are exact
#: to ≈ 1e-10 of the scale, below :data:`CERTIFY` (1e-9) of the refinement it checks.
HIGHS_FEASIBILITY = 1e-10

#: Refinement's outer bound (:meth:`zonotope.mismatch.refine.Refinement.outer`): a support direction
#: whose component inside the MMV's affine hull is shorter than ``NORMAL_ZERO ×`` the longest is
#: dropped (it is normal to the hull: no constraint inside it). Unit directions projected onto a
#: basis round to ≈ 1e-16; genuine facet normals have components ≈ 1.
NORMAL_ZERO = 1e-12

#: Refinement's outer bound: vertices from the half-space intersection within ``VERTEX_MERGE ×``
#: their span (one grid cell) are one. A degenerate vertex (more than d planes through it) comes
#: back once per d-subset, ≈ 1e-11 of the span apart; distinct vertices of a certified bound are at
#: least :data:`CERTIFY` apart. Equal to :data:`AFFINE` (the polytope's own flatness threshold).
VERTEX_MERGE = 1e-9

#: Zonohedron reduction: candidate parallel pairs are those with 1 − cos θ ≤ max(PARALLEL_PREFILTER,
#: parallel²) (then confirmed by |u_i − u_j| ≤ parallel). The cosine of unit vectors carries
#: ≈ 2e-16 of rounding, so 1 − cos θ cannot resolve θ below ≈ 2e-8; the floor 1e-12 keeps every
#: pair the exact distance test might merge among the candidates for any ``parallel`` ≥ 1e-6 rad.
PARALLEL_PREFILTER = 1e-12

#: Zonogon facets: a coplanar generator is flipped (t ↦ 1 − t) to point into the facet's upper
#: half-plane when its angle is below ``−ZONOGON_HALFTURN`` or at least π − ``ZONOGON_HALFTURN``
#: rad; the angles of unit vectors are exact to ≈ 1e-16 rad, coplanar generators are ≥ 1e-7 rad
#: apart (:attr:`Tolerances.parallel`), so the value only decides which end of a half-turn owns
#: the generator lying on the axis.
ZONOGON_HALFTURN = 1e-12

#: Zonohedron vertex sweep: the fixed generic directions w, e of the sweep are *too close* to the
#: data (the sweep declines and key deduplication answers) when a facet normal, a climbing
#: coefficient, a shadow direction or a gap between shadow events is within ``SWEEP_GENERIC`` (rad
#: or relative) of zero. Rounding of those quantities is ≈ 1e-15; any margin above it is correct,
#: 1e-9 keeps the sweep's combinatorics far from ties at the cost of declining on ~1e-9 of inputs.
SWEEP_GENERIC = 1e-9

#: :func:`zonotope.mismatch.membership` (dense half-spaces of a zonotope in any dimension): a subset of d − 1
#: generators spans a hyperplane when its smallest singular value exceeds ``HYPERPLANE_RANK ×`` the
#: largest generator entry. Equal to :attr:`Tolerances.rank` for the same reason: singular values
#: of exactly dependent subsets come out at ≈ 1e-15 relative, measured independent ones ≥ 1e-4.
HYPERPLANE_RANK = 1e-10

#: :class:`~zonotope.Zonotope`: generator magnitudes outside [MAGNITUDE_MIN, MAGNITUDE_MAX] are
#: refused: the products of two (cross products) or three (volumes) would under- or overflow
#: float64 (range ≈ 1e±308). A range guard, not a tolerance; data in any physical unit fit.
MAGNITUDE_MIN = 1e-150

#: See :data:`MAGNITUDE_MIN`.
MAGNITUDE_MAX = 1e150

#: Facet sweep of a zonohedron: the angle of generator k in the sweep of generator i (its direction
#: in the plane ⊥ h_i) is rounded by ≈ ``ANGLE_ROUNDING / s_ik`` rad, s_ik the sine of the angle
#: between them: the projection has length |h_k|·s_ik and an absolute error of a few ε·|h_k|
#: (ε = 2.2e-16; measured 0.2 ε/s on the near-parallel pair of tests/test_solid.py). Coplanarity
#: (``Tolerances.coplanar``) is decided within that tolerance *plus* this rounding, so an exactly
#: coplanar triple with a near-parallel pair is never split into slivers. 16 ε leaves a margin of
#: ~80× over the measured rounding and stays ≤ 4e-8 rad for pairs kept apart by ``parallel``.
ANGLE_ROUNDING = 16 * 2.220446049250313e-16

# -- colour-correction estimators (correct.prior, correct.mmv, correct.problem, atypical, report) --

#: :func:`zonotope.correct.prior.interior_solution`: the closed-form MAP reflectance counts as inside [0, 1]ⁿ
#: (and so as the exact bounded solution) when no entry is below ``-INTERIOR_SLACK`` or above
#: ``1 + INTERIOR_SLACK``. The closed form is exact to ≈ 1e-15 (a 6 × 6 solve of a well-conditioned
#: Gram matrix); a row on a bound to rounding is the same solution either way, and it is clipped, which
#: moves its colour by ≤ 1e-12 of the white.
INTERIOR_SLACK = 1e-12

#: :func:`zonotope.correct.prior.fiber_lsq` (:func:`zonotope.correct.bvls.box_lsq`'s per-row fallback):
#: tolerance of
#: the TRF fallback when scipy's BVLS does not converge (never seen); at 1e-12 its answer agrees with
#: BVLS's exact active-set solution to the constraint weighting.
BVLS_FALLBACK = 1e-12

#: :func:`zonotope.correct.bvls.box_lsq` (the batched solver of :func:`zonotope.correct.prior.fiber_lsq`):
#: a row is
#: solved when it meets the KKT conditions of ``min ‖Mx − r‖², 0 ≤ x ≤ 1`` with the gradient
#: ``g = Mᵀ(Mx − r)`` within ``BVLS_KKT · |M|ᵀ(|M||x| + |r|)`` of its required sign or of zero (relative
#: to the terms summed in ``g``, the scale of its rounding error). Measured on the Prior MAP of
#: :data:`BVLS_CONDITION` (1500 responses each at σ = 0.002, 0.01, 1e-5): at convergence the free
#: variables' ``|g|`` is ≤ 8.4e-16 of that scale (p99 1.8e-16) and the bound variables' multipliers are
#: ≥ 2.9e-7 of it at σ ≥ 0.002 (≥ 4e-11 at σ = 1e-5): 1e-13 is 100× above the rounding and below every
#: genuine multiplier seen; any value in 1e-15…1e-11 settled the same rows in the same ≤ 5 iterations
#: there. (At 1e-10 the exact-constraint form, cond(MᵀM) ≈ 1.5e11, accepted wrong active sets: one
#: reason for :data:`BVLS_CONDITION`.)
BVLS_KKT = 1e-13

#: :func:`zonotope.correct.bvls.box_lsq`: problems whose ``MᵀM`` has a condition number above this are
#: solved by
#: scipy's per-row BVLS (QR-based) instead of the batched normal equations. Measured on a Prior MAP
#: (three cameras, 9 channels, 29 bands, 600 responses the closed form does not cover; σ swept), the
#: largest difference from scipy's BVLS is 3e-14 at cond 9e3 (σ = 1e-3), 1e-12 at 4e6, 9e-11 at 4e8,
#: 8e-10 at 3.6e9, 9e-9 at 4e10, and 5e-3 at 3.6e11 (active sets wrongly decided); at 1e9 it is
#: ≲ 2e-10. The splat pipeline's problems (σ ≥ 0.002) have cond ≤ 3e3; the exact-constraint form
#: (``noise = 0``, weight 1e5: cond ≈ 1.5e11) goes to scipy.
BVLS_CONDITION = 1e9

#: :func:`zonotope.correct.prior.project_to_mmv`: ``METRIC_JITTER × I`` is added to the CIELAB metric ``JᵀJ``
#: before its Cholesky factor is taken (``JᵀJ`` is positive definite, entries ≈ 1e3–1e5; the jitter
#: only guards against rounding making it semidefinite and changes distances by < 1e-15 relative).
METRIC_JITTER = 1e-12

#: :func:`zonotope.correct.prior.project_to_mmv`: relative weight of the prior energy that picks one
#: reflectance among the ties of the projection (the MMV point is unique, its fiber is not): at 1e-4
#: of the colour term's scale it decides only among (near-)ties, and the projection's result is used
#: only when it moves the estimate by more than ``tol_dE`` (0.01 ΔE*ab).
PROJECTION_TIE = 1e-4

#: :func:`zonotope.correct.fit_Prior`: where the posterior weight ``w`` of "natural" reaches
#: ``GATE_SURE`` the atypical branch is not computed (its weight under 1 % moves the estimate by < 1 %
#: of the distance between the branches); where ``w ≤ GATE_NONE`` the natural branch (a projection onto
#: the MMV) is skipped for the same reason (a weight of 1e-4 moves it by < 1e-4 of the gap).
GATE_SURE = 0.99

#: See :data:`GATE_SURE`.
GATE_NONE = 1e-4

#: :func:`zonotope.correct.fit_Prior`: the MMV centroid (tens of ms) is computed only where its
#: weight ``(1 − w)(1 − λ)`` in the estimate reaches this, the 1 %-of-the-gap rule of :data:`GATE_SURE`.
CENTROID_MIN_WEIGHT = 0.01

#: :meth:`zonotope.correct.CorrectionProblem.lab_metric`: central-difference step of target → CIELAB,
#: relative to the white's largest channel. Lab is smooth away from black; the truncation error
#: (∝ step²) and the rounding error (∝ ε/step) balance near ε^(1/3) ≈ 6e-6; at 1e-6 both are
#: ≲ 1e-10 relative (an estimate), far below what a linearised metric is used for.
LAB_STEP = 1e-6

#: :func:`zonotope.report.write_report`: certification tolerance ``eps`` of the MMV volumes it shows,
#: the default of :func:`zonotope.correct.fit_Centroid` and ``evaluate`` (volumes certified to 0.1 %
#: of the target scale, far below the differences the report compares).
REPORT_MMV_EPS = 1e-3

#: The report's credible-radius map: a cell's label is written in black on cells brighter than this
#: fraction of the magma colour scale and in white below (legibility, not numerics).
LABEL_INK = 0.6

#: :func:`zonotope.spectra.atypical.structured_reflectances` ("rough"): ``GP_JITTER × I`` on the squared-
#: exponential kernel so its Cholesky factor exists (the kernel of 8–25 nm on a 10 nm grid has
#: eigenvalues down to ≈ 1e-16); 1e-9 changes the spectra by ≈ 3e-5 rms, far below their 0.2–0.35 spread.
GP_JITTER = 1e-9

#: ``zonotope.spectra.atypical.sharpened_reflectances``: reflectances are clipped to ``[SHARPEN_CLIP,
#: 1 − SHARPEN_CLIP]`` before their logit is taken (measured zeros and ones would give infinite
#: logits); 1e-3 is below the noise of reflectance measurements.
SHARPEN_CLIP = 1e-3

#: The source solid's volume in Prior's evidence is clamped to this (``log`` = −690.8) so that a
#: degenerate solid (zero volume: fewer independent wavelengths than channels) has a finite log volume;
#: real solids are far above it (the simulated capture's 9-channel solid: log volume ≈ −18, its
#: channel-whitened versions within ±20 of that). A clamped log volume is not reused
#: under channel scaling (:func:`zonotope.correct.mmv._log_volume`): it does not scale.
VOLUME_FLOOR = 1e-300

#: Two source solids' Φ are "the same up to channel scaling" (Prior reuses the log volume,
#: :func:`zonotope.correct.mmv._log_volume`) when, each channel divided by its largest |entry|,
#: they agree to this (absolute): a scaled copy agrees to a few ulp (~1e-16); distinct cameras or
#: grids differ by ≥ 1e-4.
SCALED_SAME = 1e-14

#: The MMV's per-channel response tolerance δ = DELTA_SIGMAS · σ for responses with noise σ: a few σ,
#: so that the noise-free response lies within δ of the measured one with high probability (3σ per
#: channel: 99.7 % for Gaussian noise), while the MMV grows only by that margin.
DELTA_SIGMAS = 3.0

#: Central-difference step of the regression Jacobian that carries response noise to ΔE00 (Prior's
#: noise radius; response units): small against the noise it carries (σ ≥ 1e-3) and far above float64
#: rounding of responses ≤ 1.
NOISE_JACOBIAN_STEP = 1e-4

__all__ += [
    "BVLS_CONDITION",
    "BVLS_FALLBACK",
    "BVLS_KKT",
    "CENTROID_MIN_WEIGHT",
    "DELTA_SIGMAS",
    "GATE_NONE",
    "GATE_SURE",
    "GP_JITTER",
    "INTERIOR_SLACK",
    "LABEL_INK",
    "LAB_STEP",
    "METRIC_JITTER",
    "NOISE_JACOBIAN_STEP",
    "PROJECTION_TIE",
    "REPORT_MMV_EPS",
    "SCALED_SAME",
    "SHARPEN_CLIP",
    "VOLUME_FLOOR",
]

# -- illuminants: choosing the scene light among candidates (zonotope.spectra.illuminant_estimate) --

#: Response noise σ (relative to the white's mean response) of the illuminant likelihood: a few times
#: raw shot noise at mid-grey, so that the likelihood does not hinge on differences the data cannot
#: resolve (and keeps the response covariance invertible when the prior is nearly flat along a channel).
ESTIMATE_NOISE = 0.01

#: Diagonal added to the training reflectances' covariance (reflectance² units): 190 spectra on 31
#: wavelengths give a rank-deficient covariance; 1e-4 (σ = 0.01 per wavelength) is below the spread of
#: any natural set and makes it positive definite.
ESTIMATE_COVARIANCE_JITTER = 1e-4

__all__ += ["ESTIMATE_COVARIANCE_JITTER", "ESTIMATE_NOISE"]
# --- spectral sensitivity estimation (zonotope.spectra.estimate) ------------------------------

#: :func:`zonotope.spectra.estimate.estimate_ssf`: weight of the second-difference smoothness penalty
#: relative to the data (per unit column norm); chosen by leave-one-camera-out over the measured
#: cameras (docs/notes/2026-11-29-ssf-estimation.md): smaller lets ripples through, larger flattens peaks.
SSF_SMOOTHNESS = 0.01

#: Weight of each channel's distance to its basis span, relative to the data; chosen with
#: SSF_SMOOTHNESS by leave-one-camera-out (same note).
SSF_SUBSPACE = 10.0

#: Weight of the Gaussian prior on each channel's basis coefficients beyond the first (in units of the
#: measured cameras' spread along them), relative to the data; chosen by leave-one-camera-out.
SSF_PRIOR = 1e-4

#: A colour matrix whose condition number reaches this is singular for practical purposes (real
#: ColorMatrix tags measure ≈ 3–30; an all-zero or damaged tag is far above), as isp.dng refuses it.
SSF_MATRIX_CONDITION_MAX = 1e8

#: A chart patch with a channel at or above this fraction of saturation is clipped (raw highlights
#: bend well before the white level on many sensors; 0.98 keeps ≥ 2 % headroom).
SSF_CHART_CLIP = 0.98

#: A chart whose brightest patch mean is below this fraction of saturation is too dark: at 1 % the
#: darkest patches sit within a few read-noise σ of black on a 12–14 bit sensor.
SSF_CHART_DARK = 0.01

#: Fewest chart patches for a chart estimate: 3 channels × basis components must be outnumbered.
SSF_CHART_MIN_PATCHES = 8

#: A chart with more than this fraction of negative patch means had its black level subtracted twice
#: (noise alone makes a few dark patches negative, never a quarter of them).
SSF_CHART_NEGATIVE = 0.25

#: Relative ridge added to the normal equations of the SSF fit so that their Cholesky factor exists
#: when the smoothness/subspace weights are set to 0; 1e-12 of the mean diagonal changes no digit that
#: matters (curves are O(1)).
SSF_CHOLESKY_JITTER = 1e-12

__all__ += [
    "SSF_CHART_CLIP",
    "SSF_CHART_DARK",
    "SSF_CHART_MIN_PATCHES",
    "SSF_CHART_NEGATIVE",
    "SSF_CHOLESKY_JITTER",
    "SSF_MATRIX_CONDITION_MAX",
    "SSF_PRIOR",
    "SSF_SMOOTHNESS",
    "SSF_SUBSPACE",
]
# --- hardening: units of spectral files ---------------------------------------------------------
#: :func:`zonotope.load_camera` / :func:`zonotope.load_reflectances`: a file whose largest wavelength
#: is below this is not in nanometres (visible and near-IR data end above 680 nm; a table in µm, such
#: as 0.38–0.78, ends below 3) and is refused with the factor to apply, instead of building a grid
#: nobody meant (or failing deep inside as an AssertionError).
WAVELENGTH_NM_MIN = 100.0

__all__ += ["WAVELENGTH_NM_MIN"]
# --- Default image estimator and bounded memory (correction under noise) ---

#: Share of (noisy) natural training responses that the guarded regression keeps on its
#: root-polynomial (``zonotope.correct.fit_Guarded``): the disagreement with the matrix beyond this
#: quantile marks a response outside the training support. At 0.95 every natural cell of the
#: evaluation stays within +0.03 ΔE00 of the best method and every atypical one beats the best
#: regression (docs/notes/2026-11-29-noise-default.md); 0.97 missed one atypical cell, 0.90 natural ones.
GUARD_QUANTILE = 0.95

#: Relative luminance below which the guarded regression's disagreement stops growing (Y / Y_white):
#: the ΔXYZ / Y^(2/3) scale would otherwise send every near-black noisy response to the fallback.
GUARD_Y_FLOOR = 1e-3

__all__ += ["GUARD_QUANTILE", "GUARD_Y_FLOOR"]

# -- SSF band: sampled cameras and its noise ------------------------------------------------------

#: Correlation length (nm, squared-exponential) of the perturbations drawn by ``sample_ssfs``: the
#: band comes from 5-component basis residuals, which vary over tens of nanometres, not per sample.
SSF_SAMPLE_CORRELATION_NM = 40.0

#: Mean of ``sample_ssfs`` draws vs the estimate, as a fraction of the channel peak: the draws are
#: symmetric about it, so only sampling error (σ/√n ≤ 0.2/√400 = 0.01 at the widest band) remains.
SSF_SAMPLE_MEAN_ATOL = 0.03

__all__ += ["SSF_SAMPLE_CORRELATION_NM", "SSF_SAMPLE_MEAN_ATOL"]

# --- reference light on the command line (zonotope correct --reference) ---
#: Chroma C*ab a spectrally flat grey may keep after a scene light → reference light regression: the
#: root-polynomial maps the white to the reference white only in least squares (A → D65: 2.2 measured;
#: 1.5 under one light).
REFERENCE_CLI_GREY_CHROMA = 3.0

# --- neutral bias (white-point preserving estimates, zonotope.correct.neutral) ---
#: CIELAB chroma at which the achromatic-axis offset of ``white_point_preserving`` has fallen to
#: exp(−½) of itself: chosen on the training set only (rawtoaces 190, noisy replicas, 1–3 cameras):
#: 2, 4 and 8 tie within 0.001 ΔE00, 1 and 16 lose (docs/notes/2026-11-29-neutral-bias.md).
NEUTRAL_CHROMA = 4.0

#: Grey levels (fractions of the white's response) at which the achromatic-axis offset is tabulated:
#: half stops from 2⁻¹² to ½ (the offset of noise-aware fits varies smoothly with log luminance), then
#: steps of 0.025 up to 1, where the box face x ≤ 1 bends Prior's and Centroid's offsets (half stops
#: there left Prior's 0.9 grey 0.60 ΔE00 off at δ = 0.13).
NEUTRAL_LEVELS = tuple(2.0 ** (-12.0 + 0.5 * i) for i in range(23)) + tuple(
    0.5 + 0.025 * i for i in range(1, 21)
)

#: ΔE00 within which a white-point preserving estimate of a response proportional to the white's is the
#: grey's colour: the offset is exact at the tabulated levels and constant in exposure for the regressions,
#: so only float rounding (≈ 1e-12 of the values) remains.
NEUTRAL_GREY_DE00 = 1e-6

#: The same for estimators that solve per response (``Prior``, ``Centroid``): their solvers return one
#: response's estimate to about 1e-5 of the white depending on the batch it is solved in, so the grey
#: tabulated at fit comes back within 4e-4 ΔE00 of the tabulated one (measured near the white).
NEUTRAL_GREY_SOLVED_DE00 = 2e-3

__all__ += ["NEUTRAL_CHROMA", "NEUTRAL_GREY_DE00", "NEUTRAL_GREY_SOLVED_DE00", "NEUTRAL_LEVELS"]
# -- illuminants: the grey-edge baseline (zonotope.spectra.illuminant_estimate.grey_edge) --

#: An image whose largest grey-edge norm is below this fraction of its largest response has no edges
#: to speak of (a flat field; float noise of the Gaussian derivative is ~1e-16 of it): no estimate.
GREY_EDGE_FLOOR = 1e-9

__all__ += ["GREY_EDGE_FLOOR"]
# -- SSF band calibration and stacked cameras ------------------------------------------------------

#: Fraction of wavelengths (× channels × held-out cameras) at which the measured curve must lie within
#: ``SSFEstimate.band()``: the coverage the shipped basis' ``band_k`` is calibrated to (issue's 90 %).
SSF_BAND_COVERAGE = 0.9

__all__ += ["SSF_BAND_COVERAGE"]
# -- SSF: the σ told to a fit on estimated curves (docs/notes/2026-11-29-ssf-goal.md) ---------------

#: ``SSFEstimate.response_sigma()`` = the held-out estimates' RMS response error times this: over
#: 0.1–1 × the RMS, 0.5 gave the lowest ΔE00 of noise-aware Finlayson 2015 fits of 2–3 stacked
#: estimated cameras (natural sets, noise-free, leave one model out; DNG and DNG + chart estimates).
SSF_FIT_SIGMA_SCALE = 0.5

__all__ += ["SSF_FIT_SIGMA_SCALE"]

#: σ per channel (R, G, B; white-balanced responses, white → 1) that measured curves of another unit
#: of a camera's model carry for this camera: the RMS difference of the 190 rawtoaces training
#: patches' responses between two measurements of one model (7 models measured twice: D65 0.0105 /
#: 0.0036 / 0.0037, A 0.0098 / 0.0045 / 0.0049, FL2 0.0063 / 0.0040 / 0.0036), told to fits of two or
#: more stacked cameras. Noise-free Finlayson 2015 fits of 2 / 3 stacked cameras on another unit's
#: curves lose +3.6 / +6.0 ΔE00 (natural sets) against the same fit on the camera's own curves, +0.60
#: / +0.83 told 1 × this σ (0.5 × +0.65 / +0.91, 2 × +0.64 / +0.85); on the camera's own curves it
#: costs +0.40 / +0.61, one camera +0.02 (benchmarks/bench_ssf_units.py,
#: docs/notes/2026-12-01-published-curves.md).
SSF_UNIT_SIGMA = (0.010, 0.004, 0.004)

__all__ += ["SSF_UNIT_SIGMA"]
# -- .cube speed: exact distance of a response to the source solid (zonotope.mismatch.volume) ---------

#: Largest number of ``(k − 1)``-subsets of Φ's rows and the k unit vectors for which the max-norm
#: distance of an infeasible response to the source solid is computed from the facets of
#: ``Z ⊕ t·cube`` (561 for 31 wavelengths and k = 3, 6,545 for k = 4; C(37, 5) = 435,897 for two
#: stacked cameras would take 10 s and 100 MB to build): above it, one HiGHS LP per response.
SOLID_DISTANCE_TERMS = 20_000

__all__ += ["SOLID_DISTANCE_TERMS"]
# -- white-point offset speed (zonotope.correct.neutral) ---------------------------------------------

#: Ratios ``X/X_n`` at or below which the chroma of the white-point offset's fade weight takes CIELAB's
#: ``f`` from colour-science (its linear branch begins at (6/29)³ ≈ 0.008856); above, ``np.cbrt``
#: (equal to colour's ``spow(·, 1/3)`` within 1 ulp, a third of its time).
NEUTRAL_CBRT_FLOOR = 0.0089

#: Largest difference allowed between the white-point offset estimate and its definition evaluated
#: with ``colour.XYZ_to_Lab`` and ``np.interp`` per channel (measured ≤ 2e-16 on 1M responses).
NEUTRAL_SHIFT_EXACT = 1e-9

__all__ += ["NEUTRAL_CBRT_FLOOR", "NEUTRAL_SHIFT_EXACT"]
# -- SSF: held-out error draws told to a fit on estimated curves (docs/notes/2026-11-29-ssf-goal.md) --

#: ``SSFEstimate.response_errors()`` scales the basis' held-out curve errors by this: over 0.3–0.7,
#: 0.7 gave the lowest ΔE00 of Finlayson 2015 fitted on the draws for three stacked estimated cameras
#: (natural sets, noise-free, leave one model out, seeds 0 and 1; two cameras within 0.01 of 0.5).
SSF_ERROR_DRAW_SCALE = 0.7

#: Smallest weight of an estimate's error draws (their misfit-predicted RMS over the calibration RMS):
#: a line fitted on misfit can go near 0 for the best-fitting estimates, which still err.
SSF_ERROR_WEIGHT_FLOOR = 0.25

__all__ += ["SSF_ERROR_DRAW_SCALE", "SSF_ERROR_WEIGHT_FLOOR"]

#: ``zonotope.ssf_response_errors`` checks that a problem's training responses are those of the
#: estimates it is given (white = 1) to this absolute difference (float64 round-off is ~1e-15).
SSF_ERROR_PROBLEM_ATOL = 1e-6

__all__ += ["SSF_ERROR_PROBLEM_ATOL"]
