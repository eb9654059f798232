"""Metamer mismatch volumes (MMVs): every colour a target could see when the sources saw ``c``.

For source generators Φ (n, k) (one camera, or several stacked: k = 3, 6, 9, …), target
generators Ψ (n, m) (LMS, XYZ or another camera), both on one wavelength grid and made by
:func:`zonotope.generators`, the metamer mismatch volume of a source response c (k,) is

    MMV(c) = {Ψᵀx : Φᵀx = c, 0 ≤ x ≤ 1}          (responses are row vectors xᵀΦ),

a convex polytope inside the target object-colour solid. With a per-channel noise tolerance δ the
constraint becomes ``|Φᵀx − c| ≤ δ``.

How it is computed
------------------
The MMV is a *constrained zonotope*: the zonotope {Ψᵀx : 0 ≤ x ≤ 1} of the target cut by the k
linear constraints Φᵀx = c (equivalently, the section at c of the joint (k + m)-channel zonotope
of [Φ Ψ]). Its support function h(u) = max uᵀΨᵀx over the constraints is a linear program with
only k equality rows and box bounds; its dual, h(u) = min_v cᵀv + Σ_λ max(0, (Ψu − Φv)_λ), has
k variables, and the optimal reflectance is bang-bang (x_λ = 1 where (Ψu − Φv)_λ > 0) with at
most k fractional values. Two exact algorithms:

- ``oracle="walk"`` (default, 3-channel targets): an output-sensitive walk over the optimal
  bases (:mod:`zonotope.mismatch.walk`). Near the vertex of a basis the MMV is the zonotope of the
  non-basic variables' *edge vectors* e_j = ψ_j − Ψ_Bᵀ Φ_B⁻ᵀ φ_j; the edges of the MMV at that
  vertex are the extreme e_j (a 2-D hull of n − k points), and each neighbouring vertex is one
  simplex move away. Every vertex is visited once, at O(n·k·m) per vertex, with no LPs and no hull
  rebuilds; volume and centroid come from the faces traced on the vertex graph. Compiled with
  numba (first use in a fresh install: 20–60 s to compile on a loaded 2-core machine, then cached
  on disk; ~0.5 s to load); the kernel releases the GIL, so ``metamer_mismatch_batch(...,
  executor=concurrent.futures.ThreadPoolExecutor(2))`` runs walks on two cores with no process
  start-up. ``eps > 0`` takes the same exact walk (an exact MMV certifies every ε ≥ 0: inner =
  outer, centroid error 0), so a certified MMV never costs more than an exact one. It declines
  degenerate cases (a basic variable at a bound — black, white, responses on the source solid's
  boundary, Ψ = Φ — flat MMVs, targets with m ≠ 3), which then take facet refinement with the
  simplex oracle.
- Facet refinement (Lassez' convex-hull method, :mod:`zonotope.mismatch.refine`): ask h for the
  normal of every facet of the hull of the support points found so far until every facet is
  certified. The LPs are solved by a batched, warm-started bounded-variable simplex
  (``oracle="fast"``, :mod:`zonotope.mismatch.oracle`), or by scipy-HiGHS (``oracle="highs"``), the
  reference twin used by the tests and the benchmark.

- :func:`metamer_mismatch` (exact): facets are certified to :data:`zonotope._tol.CERTIFY`
  (1e-9 of the target scale): the MMV up to floating point, as a :class:`~zonotope.Polytope`.
- :func:`metamer_mismatch_bounds` (certified to ``eps``): facets within ε·scale of the support
  are accepted, giving a :class:`CertifiedMMV` with ``inner ⊆ MMV ⊆ outer``, volume bounds and a
  centroid error bound. (One function per return type: the type never depends on a value.)

Lower-dimensional MMVs (Ψ = Φ, black, white, responses on the source solid's boundary) are found
by certifying the affine hull first (``affine_dim`` 0, 1 or 2), never by a Qhull failure.

Choosing the noise tolerance δ
------------------------------
Real responses carry noise, and the responses of two cameras to one surface are never exactly
consistent, so Φᵀx = c is often infeasible for stacked cameras. With shot noise (variance ∝
signal, gain g electrons per unit) and read noise σ_r (in response units), the standard deviation of
channel i is σ_i ≈ sqrt(c_i / g + σ_r²) in the normalised units used here (white → 1). Take
δ_i = k·σ_i with k = :data:`zonotope.correct.DELTA_SIGMAS` (3: the true response then lies within δ
with high probability); add the
quantisation step / √12 and any calibration error of the sensitivities (often 1–2 % of the
white, which usually dominates). ``delta`` accepts a scalar or one value per channel. The MMV with
δ > 0 is the union of the MMVs of every response within δ, so it grows with δ.

References
----------
.. [1] Logvinenko, A. D., Funt, B., & Godau, C. (2014). Metamer mismatching. IEEE Trans. Image
   Process. 23(1), 34–43.
.. [2] Mackiewicz, M., Rivertz, H. J., & Finlayson, G. D. (2019). Spherical sampling methods for the
   calculation of metamer mismatch volumes. JOSA A 36(1), 96–104.
.. [3] Lassez, C., & Lassez, J.-L. (1992). Quantifier elimination for conjunctions of linear
   constraints via a convex hull algorithm.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace
from functools import cached_property, partial
from typing import TYPE_CHECKING

import numpy as np

from .._errors import GeometryError, InfeasibleResponseError, OptionError, float_array
from .._tol import CERTIFY, FEASIBLE_ABS, FEASIBLE_REL
from ..geometry.polytope import Polytope
from ..utilities.config import check_bool, check_count, check_nonnegative, with_options
from ..utilities.progress import ProgressCallback
from ..utilities.registry import MethodRegistry
from .oracle import HighsOracle, Infeasible, SimplexOracle
from .refine import Refinement, refine, refine_many
from .walk import WalkOracle

if TYPE_CHECKING:
    from concurrent.futures import Executor

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
]

#: Support oracles selectable with ``oracle=`` (case-insensitive). ``"walk"`` (default): the exact
#: vertex walk over the normal fan of optimal bases (:mod:`zonotope.mismatch.walk`), which falls back to
#: facet refinement with ``"fast"`` where it declines; ``"fast"``: facet refinement with the
#: warm-started simplex (the walk's second twin); ``"highs"``: facet refinement with scipy-HiGHS,
#: the reference twin of both.
ORACLES: MethodRegistry = MethodRegistry("support oracle", argument="oracle")
ORACLES.register("walk", WalkOracle, reference_twin="highs")
ORACLES.register("fast", SimplexOracle, reference_twin="highs")
ORACLES.register("highs", HighsOracle, reference_twin=None)


@dataclass(frozen=True)
class CertifiedMMV:
    """A metamer mismatch volume known to a certified tolerance ε.

    Attributes
    ----------
    inner : Polytope
        Convex hull of support points: ``inner ⊆ MMV``.
    outer : Polytope
        Intersection of the supporting half-spaces asked: ``MMV ⊆ outer``.
    atol : float
        Absolute support-gap tolerance used (target units): ``max(eps × scale, CERTIFY × scale)``
        for the relative ``eps`` asked and the target's scale.
    centroid_error : float
        Bound on ``‖centroid(MMV) − centroid(inner)‖`` (Euclidean, target units).
    lp_calls : int
        Support LPs solved.
    """

    inner: Polytope
    outer: Polytope
    atol: float
    centroid_error: float
    lp_calls: int

    @property
    def affine_dim(self) -> int:
        """Affine dimension of the MMV (certified flat along the complement to 1e-9 of the scale)."""
        return self.inner.affine_dim

    @property
    def volume_bounds(self) -> tuple[float, float]:
        """``(inner volume, outer volume)``: the MMV's volume lies between them."""
        return (self.inner.volume, self.outer.volume)

    @property
    def centroid(self) -> np.ndarray:
        """Volume centroid of ``inner``, ndarray of shape (m,); off by ≤ ``centroid_error``."""
        return self.inner.centroid

    @property
    def vertices(self) -> np.ndarray:
        """Vertices of ``inner``, ndarray of shape (V, m)."""
        return self.inner.vertices


@dataclass(frozen=True)
class MMVBatch:
    """Volumes and centroids of many MMVs (from :meth:`MetamerMismatch.batch`).

    Attributes
    ----------
    centroids : ndarray of shape (..., m)
        Volume centroids (of the certified inner polytope when ``eps > 0``).
    volumes : ndarray of shape (...)
        Exact volumes (``eps = 0``), the midpoint of ``volume_bounds``, or the lower bound when the
        outer bounds were not computed (``outer=False``).
    volume_bounds : ndarray of shape (..., 2)
        Certified lower and upper volume bounds (equal for ``eps = 0``; upper NaN with
        ``outer=False``).
    centroid_errors : ndarray of shape (...)
        Certified bound on each centroid's error (0 for ``eps = 0``, NaN with ``outer=False``).
    affine_dims : ndarray of int, shape (...)
        Affine dimension of each MMV.
    lp_calls : int
        Support LPs solved in all.
    """

    centroids: np.ndarray
    volumes: np.ndarray
    volume_bounds: np.ndarray
    centroid_errors: np.ndarray
    affine_dims: np.ndarray
    lp_calls: int


def _check_generators(Phi, Psi) -> tuple[np.ndarray, np.ndarray]:
    Phi = float_array(getattr(Phi, "values", Phi), "Phi", GeometryError)
    Psi = float_array(getattr(Psi, "values", Psi), "Psi", GeometryError)
    if Phi.ndim != 2 or Psi.ndim != 2 or Phi.shape[0] != Psi.shape[0]:
        raise GeometryError(
            f"Phi and Psi must be (n, k) and (n, m) on one wavelength grid; got {Phi.shape} and "
            f"{Psi.shape}. Build both with zonotope.generators(..., shape=grid)."
        )
    if not (np.all(np.isfinite(Phi)) and np.all(np.isfinite(Psi))):
        raise GeometryError("Phi or Psi contains NaN or inf; check the spectral data.")
    return Phi, Psi


def _check_arrays(Phi, Psi, response) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    Phi, Psi = _check_generators(Phi, Psi)
    c = float_array(response, "response", GeometryError)
    if c.shape != (Phi.shape[1],):
        raise GeometryError(
            f"response must have shape ({Phi.shape[1]},) (one per source channel); got {c.shape}."
        )
    if not np.all(np.isfinite(c)):
        raise GeometryError(f"response contains NaN or inf: {c}.")
    return Phi, Psi, c


def _oracle_for(Phi, Psi, c, delta, oracle: str, on_infeasible: str, *, infeasible: bool = False):
    """Build the support oracle; handle infeasible responses as asked (``infeasible``: already known
    to be, e.g. from the batch's walk, so the oracle is not first built to find it out)."""
    oracle = ORACLES.resolve(oracle)
    if on_infeasible not in ("raise", "nearest"):
        raise OptionError(f"on_infeasible={on_infeasible!r}: choose 'raise' or 'nearest'.")
    cls = ORACLES[oracle]
    if not infeasible:
        try:
            return cls(Phi, Psi, c, delta)
        except Infeasible:
            pass
    exact = _solid_distance(Phi, c[None]) if oracle != "highs" and _EXACT_DISTANCE else None
    if exact is not None:
        dist = float(exact[0])
    else:  # the HiGHS LP: the reference twin's way, and source solids with too many facets
        from ..geometry.lp import distance_to_zonotope

        dist, x = distance_to_zonotope(Phi, np.zeros(Phi.shape[1]), c)
        # HiGHS meets its constraints only to its feasibility tolerance (≈ 1e-7, absolute), so its
        # distance can fall short of the true one by that much, far more than the margin below (a
        # benchmark render pixel: 0.013035654 reported, 0.013035723 reached, and the walk found the
        # δ = reported MMV empty). The residual of its reflectance, clipped to [0, 1], is a distance a
        # reflectance attains.
        dist = max(dist, float(np.abs(np.clip(x, 0.0, 1.0) @ Phi - c).max()))
    d_in = np.broadcast_to(np.asarray(delta, dtype=np.float64), c.shape)
    if on_infeasible == "raise":
        raise InfeasibleResponseError(
            f"no reflectance in [0, 1] gives the response {np.array2string(c, precision=5)} "
            f"within delta={np.array2string(d_in, precision=3)}: it lies {dist:.3g} (max-norm, "
            "response units) outside the source object-colour solid. Pass delta ≥ that distance "
            "(noise tolerance) or on_infeasible='nearest'.",
            distance=dist,
        )
    scale = float(np.abs(Phi).sum(axis=0).max())
    d_eff = np.maximum(d_in, dist * (1 + FEASIBLE_REL) + FEASIBLE_ABS * scale)
    return cls(Phi, Psi, c, d_eff)


#: Whether :func:`_oracle_for` measures how far an infeasible response lies outside the source solid
#: with :func:`_solid_distance` (True) or with one HiGHS LP per response (False: the former path, kept
#: as its reference twin for the tests and ``benchmarks/bench_profile.py``; the ``"highs"`` oracle
#: always takes it).
_EXACT_DISTANCE = True

#: Φ bytes → (unit facet normals U (q, k) of every ``Z ⊕ t·cube``, ``h_Z(U)`` (q,), ``‖U‖₁`` (q,)), or
#: None when the solid has more facet directions than :data:`zonotope._tol.SOLID_DISTANCE_TERMS`.
_DISTANCE_FACETS: dict[bytes, tuple | None] = {}


def _distance_facets(Phi: np.ndarray):
    """The normals, support values and 1-norms of :func:`_solid_distance` for Φ, built once per Φ."""
    from .._tol import SOLID_DISTANCE_TERMS
    from .membership import joint_halfspaces

    n, k = Phi.shape
    key = np.ascontiguousarray(Phi).tobytes() + repr(Phi.shape).encode()
    try:
        return _DISTANCE_FACETS[key]
    except KeyError:
        pass
    facets = None
    if k >= 2 and math.comb(n + k, k - 1) <= SOLID_DISTANCE_TERMS:
        scale = float(np.abs(Phi).max()) or 1.0  # the cube's generators at Φ's scale (rank test)
        U, _ = joint_halfspaces(np.vstack([Phi, scale * np.eye(k)]), max_terms=SOLID_DISTANCE_TERMS)
        facets = (U, np.clip(U @ Phi.T, 0.0, None).sum(axis=1), np.abs(U).sum(axis=1))
    if len(_DISTANCE_FACETS) >= 16:  # a process sees few source solids; threads may race here harmlessly
        _DISTANCE_FACETS.clear()
    _DISTANCE_FACETS[key] = facets
    return facets


def _solid_distance(Phi, responses) -> np.ndarray | None:
    """Max-norm (Chebyshev) distance from each response to the object-colour solid ``{Φᵀx : 0 ≤ x ≤ 1}``,
    exactly, from the solid's geometry; None when the solid has too many facet directions.

    The response ``c`` lies within ``t`` of the solid iff it is in the zonotope ``Z ⊕ t·[−1, 1]ᵏ``,
    whose generators are Φ's rows and ``2t·eᵢ``; its facets are normal to ``(k − 1)``-subsets of those
    generators whatever ``t > 0``, and its support function is ``h_Z(u) + t‖u‖₁``. So the distance is
    ``max(0, max_u (u·c − h_Z(u)) / ‖u‖₁)`` over those normals (built once per Φ,
    :func:`zonotope.mismatch.membership.joint_halfspaces`; 1,122 for 31 wavelengths and k = 3): one
    matrix product per batch instead of one LP per response, and exact where the LP meets its
    constraints to its feasibility tolerance only. Any direction gives a lower bound, so round-off
    can only make it short by ≈ 1e-16 of the scale (the MMV's margin,
    :data:`zonotope._tol.FEASIBLE_ABS`, covers that). The scipy-HiGHS LP
    (:func:`zonotope.geometry.lp.distance_to_zonotope`) is its reference twin in the tests.

    Parameters
    ----------
    Phi : ndarray of shape (n, k)
    responses : ndarray of shape (N, k)

    Returns
    -------
    ndarray of shape (N,) or None
        None for k < 2 or more than :data:`zonotope._tol.SOLID_DISTANCE_TERMS` subsets.
    """
    Phi = np.asarray(Phi, dtype=np.float64)
    facets = _distance_facets(Phi)
    if facets is None:
        return None
    U, h, l1 = facets
    C = np.atleast_2d(np.asarray(responses, dtype=np.float64))
    return np.maximum(((C @ U.T - h) / l1).max(axis=1), 0.0)


def _tolerances(Psi, eps) -> tuple[float, float]:
    """(exact-mode tolerance, certification threshold), both relative to the target's scale."""
    scale = float(np.abs(Psi).sum(axis=0).max()) or 1.0
    tol = CERTIFY * scale
    return tol, max(float(eps) * scale, tol)


def _refinement(
    Phi,
    Psi,
    response,
    *,
    delta=0.0,
    eps=0.0,
    oracle="walk",
    on_infeasible="raise",
    max_rounds: int = 500,
    infeasible: bool = False,
) -> tuple[Refinement, float, float]:
    Phi, Psi, c = _check_arrays(Phi, Psi, response)
    if not (np.isfinite(eps) and eps >= 0):
        raise OptionError(f"eps={eps!r}: give a finite number ≥ 0.")
    tol, thr = _tolerances(Psi, eps)
    orc = _oracle_for(Phi, Psi, c, delta, oracle, on_infeasible, infeasible=infeasible)
    if isinstance(orc, WalkOracle) and orc.status == 0:
        walked = _walked(orc, tol)
        if walked is not None:
            return walked, thr, tol
        # the walk's MMV is thinner than tol (a noisy response near the solid's boundary): refine
    return refine(orc, Psi.shape[1], threshold=thr, atol=tol, max_rounds=max_rounds), thr, tol


def _walked(orc: WalkOracle, atol: float) -> Refinement | None:
    """The exact MMV found by the walk, as a converged :class:`Refinement` (outer = inner); None
    when its vertices are flat at ``atol`` (then facet refinement handles the lower dimension)."""
    tri = orc.triangles
    inner = Polytope._from_triangulation(
        orc.vertices, tri[:, :3], tri[:, 3], atol=atol, volume=orc.volume, centroid=orc.centroid
    )
    if inner is None:
        return None
    o, B = inner.affine_hull
    m = orc.vertices.shape[1]
    return Refinement(inner, np.zeros((0, m)), np.zeros(0), o, B, orc.moves, 0, 0.0, True, exact=True)


def metamer_mismatch(
    Phi, Psi, response, *, delta=0.0, oracle: str = "walk", on_infeasible: str = "raise"
) -> Polytope:
    """Exact metamer mismatch volume of one source response (functional form on arrays).

    Parameters
    ----------
    Phi : array_like of shape (n, k)
        Source generators (rows = wavelengths), e.g. ``zonotope.generators(cams, shape=grid).values``.
    Psi : array_like of shape (n, m)
        Target generators on the same grid.
    response : array_like of shape (k,)
        Source response c = xᵀΦ.
    delta : float or array_like of shape (k,)
        Per-channel tolerance: ``|Φᵀx − c| ≤ δ`` (see the module notes on choosing it). Default 0.
    oracle : {"walk", "fast", "highs"}
        Algorithm (key of :data:`ORACLES`): the exact vertex walk (falls back to facet refinement
        with the simplex where it declines), facet refinement with the batched warm-started
        simplex, or with the scipy-HiGHS reference twin.
    on_infeasible : {"raise", "nearest"}
        What to do when no reflectance gives ``response`` within δ. ``"raise"``:
        :class:`~zonotope.InfeasibleResponseError` with ``.distance``, the max-norm distance d from
        ``response`` to the source solid. ``"nearest"``: use the nearest feasible responses, i.e.
        every response of the solid at max-norm distance d from ``response`` (the set of nearest
        points in that norm), which is the MMV with δ = max(δ, d) (d enlarged by
        :data:`zonotope._tol.FEASIBLE_REL` for round-off). Nothing is clipped silently: the result
        is the MMV of a stated set of responses.

    Returns
    -------
    Polytope
        The exact MMV (facets certified to :data:`zonotope._tol.CERTIFY` × the target scale);
        ``affine_dim`` < m for flat MMVs. For certified inner/outer bounds at a coarser tolerance, which
        cost fewer support LPs, use :func:`metamer_mismatch_bounds`.

    Raises
    ------
    InfeasibleResponseError
        Infeasible response with ``on_infeasible="raise"``.
    GeometryError
        Shapes that do not match, NaN input.
    UnknownMethodError
        Unknown ``oracle``.
    ValueError
        Unknown ``on_infeasible``.

    Examples
    --------
    >>> import numpy as np, zonotope
    >>> grid = np.arange(400, 701, 10.0)
    >>> Phi = zonotope.generators("Nikon 5100 (NPL)", shape=grid).values
    >>> Psi = zonotope.generators("Stockman & Sharpe 2°", shape=grid).values
    >>> mmv = metamer_mismatch(Phi, Psi, np.full(31, 0.5) @ Phi)
    >>> mmv.affine_dim, bool(mmv.contains(np.full(31, 0.5) @ Psi))
    (3, True)
    """
    ref, _, _ = _refinement(
        Phi, Psi, response, delta=delta, eps=0.0, oracle=oracle, on_infeasible=on_infeasible
    )
    if not ref.converged:  # pragma: no cover - safety net
        raise GeometryError("facet refinement did not converge; use metamer_mismatch_bounds(eps > 0).")
    return ref.inner


def metamer_mismatch_bounds(
    Phi, Psi, response, *, eps: float = 1e-3, delta=0.0, oracle: str = "walk", on_infeasible: str = "raise"
) -> CertifiedMMV:
    """Certified inner and outer bounds of the metamer mismatch volume of one source response.

    Parameters
    ----------
    Phi, Psi, response, delta, oracle, on_infeasible
        As in :func:`metamer_mismatch`.
    eps : float
        Certification tolerance (≥ 0): every facet of the bounds is within ``eps ×`` the target
        scale (the largest white-point channel, 1 for normalised generators) of the true support
        function. Default 1e-3; 0 gives the exact polytope as ``inner``.

    Returns
    -------
    CertifiedMMV
        ``inner ⊆ MMV ⊆ outer``, ``volume_bounds``, ``centroid`` (of ``inner``) and
        ``centroid_error``.

    Raises
    ------
    InfeasibleResponseError, GeometryError, UnknownMethodError, ValueError
        As :func:`metamer_mismatch`; ``ValueError`` also for a negative ``eps``.

    Examples
    --------
    >>> import numpy as np, zonotope
    >>> grid = np.arange(400, 701, 10.0)
    >>> Phi = zonotope.generators("Nikon 5100 (NPL)", shape=grid).values
    >>> Psi = zonotope.generators("Stockman & Sharpe 2°", shape=grid).values
    >>> cert = metamer_mismatch_bounds(Phi, Psi, np.full(31, 0.5) @ Phi, eps=1e-3)
    >>> low, high = cert.volume_bounds
    >>> bool(0 < low <= high)
    True
    """
    ref, thr, _ = _refinement(
        Phi, Psi, response, delta=delta, eps=eps, oracle=oracle, on_infeasible=on_infeasible
    )
    return _certified(ref, thr)


def _certified(ref: Refinement, thr: float) -> CertifiedMMV:
    inner = ref.inner
    outer = ref.outer()
    if inner.affine_dim >= 1:
        m_in, m_out = inner.measure, outer.measure
        reach = float(np.linalg.norm(outer.vertices - inner.centroid, axis=1).max())
        frac = (m_out - m_in) / m_out if m_out > 0 else 0.0
        err = max(frac, 0.0) * reach
    else:
        err = float(np.linalg.norm(outer.vertices - inner.centroid, axis=1).max())
    return CertifiedMMV(inner, outer, thr, err, ref.lp_calls)


def channelwise_intersection(
    Phi, Psi, response, *, groups="auto", delta=0.0, oracle: str = "walk"
) -> Polytope:
    """The thesis' construction: intersect one MMV per source channel or per camera (manifold3d).

    Each group g of source channels gives the exact MMV_g(c_g) = {Ψᵀx : Φ_gᵀx = c_g, 0 ≤ x ≤ 1};
    their intersection, computed with manifold3d booleans, always contains the joint MMV and is
    only an OUTER bound of it (the constraints of different groups act on different reflectances).
    Measured on Nikon 5100 + Sigma SD Merrill (ColorChecker, 10 nm): see the project README.

    Parameters
    ----------
    Phi : array_like of shape (n, k)
    Psi : array_like of shape (n, m) with m = 3
    response : array_like of shape (k,)
    groups : {"auto", "channel", "camera"} or sequence of sequences of int
        ``"channel"``: one group per source channel; ``"camera"``: consecutive triples;
        ``"auto"``: cameras when k is a multiple of 3 greater than 3, else channels.
    delta : float or array_like of shape (k,)
    oracle : {"walk", "fast", "highs"}

    Returns
    -------
    Polytope
        The intersection (flat groups are intersected by half-spaces instead of manifold3d).
    """
    Phi, Psi, c = _check_arrays(Phi, Psi, response)
    k = Phi.shape[1]
    if Psi.shape[1] != 3:
        raise GeometryError(f"channelwise_intersection needs a 3-channel target; got {Psi.shape[1]}.")
    if isinstance(groups, str):
        if groups == "auto":
            groups = "camera" if k > 3 and k % 3 == 0 else "channel"
        if groups == "channel":
            idx = [[i] for i in range(k)]
        elif groups == "camera":
            if k % 3:
                raise OptionError(f"groups='camera' needs k a multiple of 3; got k={k}.")
            idx = [list(range(i, i + 3)) for i in range(0, k, 3)]
        else:
            raise OptionError(
                f"groups={groups!r}: use 'auto', 'channel', 'camera' or lists of channel indices."
            )
    else:
        idx = [list(map(int, g)) for g in groups]
    d = np.broadcast_to(np.asarray(delta, dtype=np.float64), (k,))
    parts = [metamer_mismatch(Phi[:, g], Psi, c[g], delta=d[g], oracle=oracle) for g in idx]
    if all(p.affine_dim == 3 for p in parts):
        solid = parts[0].to_manifold()
        for p in parts[1:]:
            solid = solid ^ p.to_manifold()
        if solid.volume() > 0:
            return Polytope.from_manifold(solid, atol=parts[0].atol)
    out = parts[0]
    for p in parts[1:]:
        out = out.intersect(p)
    return out


class MetamerMismatch:
    """Metamer mismatch volumes of one or more source cameras for a target, on one grid.

    Parameters
    ----------
    source : camera, list of cameras or GeneratorPair
        Built-in name, file, colour MSDS, or ``(wavelengths, values)``; a list stacks the channels
        (two cameras give k = 6). A :class:`~zonotope.GeneratorPair` (e.g. a
        :class:`~zonotope.correct.CorrectionProblem`) is used as it is (``target``,
        ``illuminant``, ``target_illuminant`` and ``shape`` are then ignored).
    target : observer or camera
        Default ``"Stockman & Sharpe 2°"`` (LMS).
    illuminant : str or SpectralDistribution
        Default ``"D65"``.
    shape : colour.SpectralShape or array_like of shape (n,), optional
        Wavelength grid; default the common shape of every curve (sources, target, illuminant).
    oracle : {"walk", "fast", "highs"}
    target_illuminant : str or SpectralDistribution, optional
        The light the target sees when it differs from ``illuminant``: the MMV is then every
        colour under that light of a reflectance the sources saw as ``c`` under ``illuminant``
        (observer- and illuminant-induced mismatch combined; see
        :mod:`zonotope.mismatch.illuminant`). Default: the same light.

    Attributes
    ----------
    Phi : ndarray of shape (n, k)
        Source generators, per-channel normalised (white → 1).
    Psi : ndarray of shape (n, m)
        Target generators, per-channel normalised (white under the target's light → 1).
    wavelengths : ndarray of shape (n,)

    Examples
    --------
    >>> import numpy as np
    >>> mm = MetamerMismatch("Nikon 5100 (NPL)", shape=np.arange(400, 701, 10.0))
    >>> grey = mm.source_of(np.full(31, 0.5))
    >>> mmv = mm.bounds(grey, eps=1e-3)
    >>> bool(mmv.outer.contains(mm.target_of(np.full(31, 0.5))))
    True
    """

    def __init__(
        self,
        source,
        target="Stockman & Sharpe 2°",
        illuminant="D65",
        shape=None,
        *,
        oracle: str = "walk",
        target_illuminant=None,
    ) -> None:
        from ..spectra.pair import GeneratorPair, generator_pair

        if isinstance(source, GeneratorPair):  # e.g. a CorrectionProblem: its Φ and Ψ as they are
            pair = source
        else:
            pair = generator_pair(
                list(source) if isinstance(source, list | tuple) else source,
                target,
                illuminant,
                shape,
                target_illuminant=target_illuminant,
            )
        self.generators = pair
        self.Phi, self.Psi, self.wavelengths = pair.Phi, pair.Psi, pair.wavelengths
        self.oracle = ORACLES.resolve(oracle)
        self.source_labels = pair.source_channels
        self.target_labels = pair.target_channels

    def __repr__(self) -> str:
        return (
            f"MetamerMismatch(k={self.k}, m={self.m}, n_wavelengths={self.wavelengths.size}, "
            f"{self.wavelengths[0]:g}–{self.wavelengths[-1]:g} nm)"
        )

    @property
    def k(self) -> int:
        """Number of source channels."""
        return self.Phi.shape[1]

    @property
    def m(self) -> int:
        """Number of target channels."""
        return self.Psi.shape[1]

    @cached_property
    def source_solid(self):
        """Object-colour solid of the source channels (:class:`zonotope.Zonotope`)."""
        from ..geometry.solid import Zonotope

        return Zonotope(self.Phi)

    @cached_property
    def target_solid(self):
        """Object-colour solid of the target (:class:`zonotope.Zonotope`)."""
        from ..geometry.solid import Zonotope

        return Zonotope(self.Psi)

    def _reflectances(self, reflectances) -> np.ndarray:
        R = np.asarray(getattr(reflectances, "values", reflectances), dtype=np.float64)
        if R.shape[-1] != self.wavelengths.size:
            raise GeometryError(
                f"reflectances must have shape (..., {self.wavelengths.size}) on this "
                f"grid; got {R.shape}. Resample with zonotope.resample."
            )
        return R

    def source_of(self, reflectances) -> np.ndarray:
        """Source responses (..., k) of reflectances (..., n) on the grid."""
        return self._reflectances(reflectances) @ self.Phi

    def target_of(self, reflectances) -> np.ndarray:
        """Target responses (..., m) of reflectances (..., n) on the grid."""
        return self._reflectances(reflectances) @ self.Psi

    def __call__(self, response, *, delta=0.0, on_infeasible: str = "raise") -> Polytope:
        """Exact MMV of one response (k,); see :func:`metamer_mismatch`."""
        return metamer_mismatch(
            self.Phi, self.Psi, response, delta=delta, oracle=self.oracle, on_infeasible=on_infeasible
        )

    def bounds(self, response, *, eps: float = 1e-3, delta=0.0, on_infeasible: str = "raise") -> CertifiedMMV:
        """Certified bounds of the MMV of one response (k,); see :func:`metamer_mismatch_bounds`."""
        return metamer_mismatch_bounds(
            self.Phi,
            self.Psi,
            response,
            eps=eps,
            delta=delta,
            oracle=self.oracle,
            on_infeasible=on_infeasible,
        )

    def channelwise(self, response, *, groups="auto", delta=0.0) -> Polytope:
        """The per-channel/per-camera intersection (outer bound); see :func:`channelwise_intersection`."""
        return channelwise_intersection(
            self.Phi, self.Psi, response, groups=groups, delta=delta, oracle=self.oracle
        )

    def batch(
        self,
        responses,
        config: MMVBatchConfig | None = None,
        *,
        progress: ProgressCallback | None = None,
        executor: Executor | None = None,
        **options,
    ) -> MMVBatch:
        """Volumes and centroids of the MMVs of many responses; see :func:`metamer_mismatch_batch`
        (the ``oracle`` is this object's)."""
        if "oracle" in options:
            raise OptionError("MetamerMismatch.batch: the oracle is the MetamerMismatch's (oracle=...).")
        cfg = with_options(MMVBatchConfig, config, options, where="MetamerMismatch.batch")
        return metamer_mismatch_batch(
            self.Phi,
            self.Psi,
            responses,
            replace(cfg, oracle=self.oracle),
            progress=progress,
            executor=executor,
        )


@dataclass(frozen=True)
class MMVBatchConfig:
    """Options of :func:`metamer_mismatch_batch` (checked when made).

    Attributes
    ----------
    eps : float
        Certification tolerance relative to the target's scale (see
        :func:`metamer_mismatch_bounds`); 0 for exact polytopes. Default 1e-3.
    delta : float or tuple of float
        Per-channel tolerance on the source responses (one value, or k values), ≥ 0.
    oracle : str
        Support-LP solver, a key of :data:`ORACLES` (stored resolved: ``"walk"``, ``"fast"`` or ``"highs"``).
    on_infeasible : {"raise", "nearest"}
    chunk : int
        Responses refined side by side: every round of facet refinement asks the support LPs of
        all of them in one batched simplex call, which shares numpy's per-call overhead (≈ 2×
        faster than one by one at 10 nm); memory grows with it. Chunks are also the unit of work
        handed to an executor. ≥ 1, default 256.
    outer : bool
        With ``eps > 0``, also compute each certified outer bound (a half-space intersection and a
        hull: about half the time per response at 10 nm). False when only centroids are
        wanted: the upper volume bounds and the centroid error bounds are then NaN (not
        computed), the lower bounds and the centroids are unchanged. (MMVs found by the exact
        vertex walk, ``oracle="walk"``, have exact volumes, equal bounds and zero centroid error
        either way.)

    Raises
    ------
    OptionError
        A value out of range (named, with what is allowed).
    UnknownMethodError
        Unknown ``oracle``.
    """

    eps: float = 1e-3
    delta: float | tuple[float, ...] = 0.0
    oracle: str = "walk"
    on_infeasible: str = "raise"
    chunk: int = 256
    outer: bool = True

    def __post_init__(self):
        name = "MMVBatchConfig"
        object.__setattr__(self, "eps", check_nonnegative(name, "eps", self.eps))
        d = np.asarray(self.delta, dtype=np.float64) if not isinstance(self.delta, str) else None
        if d is None or d.ndim > 1 or not np.all(np.isfinite(d)) or np.any(d < 0):
            raise OptionError(f"{name}.delta={self.delta!r}: give one finite value ≥ 0 or one per channel.")
        object.__setattr__(self, "delta", float(d) if d.ndim == 0 else tuple(float(v) for v in d))
        object.__setattr__(self, "oracle", ORACLES.resolve(self.oracle))
        if self.on_infeasible not in ("raise", "nearest"):
            raise OptionError(f"{name}.on_infeasible={self.on_infeasible!r}: choose 'raise' or 'nearest'.")
        check_count(name, "chunk", self.chunk, minimum=1)
        check_bool(name, "outer", self.outer)


def metamer_mismatch_batch(
    Phi,
    Psi,
    responses,
    config: MMVBatchConfig | None = None,
    *,
    progress: ProgressCallback | None = None,
    executor: Executor | None = None,
    **options,
) -> MMVBatch:
    """Volumes and centroids of the MMVs of many responses (functional form of
    :meth:`MetamerMismatch.batch`).

    Parameters
    ----------
    Phi : array_like of shape (n, k)
    Psi : array_like of shape (n, m)
    responses : array_like of shape (..., k)
    config : MMVBatchConfig, optional
        ``eps``, ``delta``, ``oracle``, ``on_infeasible``, ``chunk``, ``outer`` (see
        :class:`MMVBatchConfig`); default ``MMVBatchConfig()``.
    progress : callable, optional
        Called as ``progress("metamer mismatch volumes", done, total)`` (responses) after each
        chunk (:class:`~zonotope.utilities.ProgressCallback`); the library draws nothing.
    executor : concurrent.futures.Executor, optional
        Where the chunks run: any object whose ``map(fn, iterable)`` yields the results in the
        order of ``iterable``, as :meth:`concurrent.futures.Executor.map` does (a
        ``ProcessPoolExecutor``, or :func:`zonotope.parallel.executor` for a local or remote Dask
        cluster). None: this process, one chunk after another. The results do not depend on it:
        every chunk is computed by the same code on the same responses.
    **options
        :class:`MMVBatchConfig` fields as keywords (alone, or overriding those of ``config``),
        e.g. ``metamer_mismatch_batch(Phi, Psi, C, eps=0.0, chunk=64)``.

    Returns
    -------
    MMVBatch
        Results in the order and leading shape of ``responses``.

    Raises
    ------
    OptionError
        An unknown option or a value out of range.
    GeometryError
        Shapes that do not match, NaN input.
    InfeasibleResponseError
        An infeasible response with ``on_infeasible="raise"``.
    """
    cfg = with_options(MMVBatchConfig, config, options, where="metamer_mismatch_batch")
    eps, delta, oracle, on_infeasible, chunk, outer = (
        cfg.eps,
        cfg.delta,
        cfg.oracle,
        cfg.on_infeasible,
        cfg.chunk,
        cfg.outer,
    )
    Phi, Psi = _check_generators(Phi, Psi)
    k, m = Phi.shape[1], Psi.shape[1]
    C = float_array(responses, "responses", GeometryError)
    if C.shape[-1:] != (k,):
        raise GeometryError(f"responses must have shape (..., {k}); got {C.shape}.")
    if isinstance(delta, tuple) and len(delta) != k:
        raise OptionError(f"MMVBatchConfig.delta has {len(delta)} values; the source has {k} channels.")
    if executor is not None and not callable(getattr(executor, "map", None)):
        raise OptionError(
            f"executor must have a map(fn, iterable) method (a concurrent.futures.Executor); "
            f"got {executor!r}."
        )
    flat = C.reshape(-1, k)
    if not np.all(np.isfinite(flat)):
        raise GeometryError("responses contain NaN or inf.")
    N = flat.shape[0]
    parts = (flat[s : s + chunk] for s in range(0, N, chunk))  # views, made as the executor asks
    work = partial(
        _batch_chunk, Phi, Psi, eps=eps, delta=delta, oracle=oracle, on_infeasible=on_infeasible, outer=outer
    )
    results: list = []
    done = 0
    for r in map(work, parts) if executor is None else executor.map(work, parts):
        results.append(r)
        done += r[0].shape[0]
        if progress is not None:
            progress("metamer mismatch volumes", done, N)
    lead = C.shape[:-1]
    if results:
        cents, bounds, errs, dims = (np.concatenate([r[j] for r in results]) for j in range(4))
    else:
        cents, bounds, errs, dims = np.zeros((0, m)), np.zeros((0, 2)), np.zeros(0), np.zeros(0, np.int64)
    calls = sum(r[4] for r in results)
    vols = np.where(np.isnan(bounds[:, 1]), bounds[:, 0], bounds.mean(axis=1))
    return MMVBatch(
        cents.reshape(*lead, m),
        vols.reshape(lead),
        bounds.reshape(*lead, 2),
        errs.reshape(lead),
        dims.reshape(lead),
        calls,
    )


def _batch_chunk(Phi, Psi, part, *, eps, delta, oracle, on_infeasible, outer=True):
    """Centroids, volume bounds, centroid errors, dims and LP calls of responses ``part (q, k)``."""
    q, m = part.shape[0], Psi.shape[1]
    refs: list = [None] * q
    cents, bounds = np.empty((q, m)), np.empty((q, 2))
    errs, dims = np.zeros(q), np.empty(q, dtype=np.int64)
    calls = 0
    walked = np.zeros(q, dtype=bool)
    infeasible = np.zeros(q, dtype=bool)  # known so from the walk (status 1: its phase 1 found no point)
    asked = oracle
    if oracle == "walk" and m == 3:
        # exact vertex walks: volume and centroid from the traced faces, no hull needed
        from .oracle import _as_delta
        from .walk import walk_mmv_batch

        # one compiled call for the chunk (the same walk as walk_mmv, per response)
        vols, cens, status, moves = walk_mmv_batch(Phi, Psi, part, _as_delta(delta, Phi.shape[1]))
        walked[:] = status == 0
        infeasible[:] = status == 1
        cents[walked], bounds[walked], dims[walked] = cens[walked], vols[walked, None], 3
        calls += int(moves[walked].sum())
        oracle = "fast"  # for the responses the walk declined
    if oracle == "fast":
        # the feasible responses in lockstep, sharing one multi-response simplex oracle
        tol, thr = _tolerances(Psi, eps)
        orc = SimplexOracle(Phi, Psi, part, delta)
        ok = np.nonzero(orc.feasible & ~walked)[0]
        for r, ref in zip(ok, refine_many(orc, ok, m, threshold=thr, atol=tol, max_rounds=500)):
            refs[r] = (ref, thr)
    for r, c in enumerate(part):
        if refs[r] is None and not walked[r]:  # the reference oracle, or an infeasible response
            ref, thr, _ = _refinement(
                Phi,
                Psi,
                c,
                delta=delta,
                eps=eps,
                oracle=asked,
                on_infeasible=on_infeasible,
                infeasible=bool(infeasible[r]) and _EXACT_DISTANCE,
            )
            refs[r] = (ref, thr)
    for r, item in enumerate(refs):
        if walked[r]:
            continue
        ref, thr = item
        calls += ref.lp_calls
        if eps > 0 and outer:
            res = _certified(ref, thr)
            cents[r], bounds[r], errs[r] = res.centroid, res.volume_bounds, res.centroid_error
            dims[r] = res.affine_dim
        elif eps > 0:  # inner polytope only: a lower volume bound, no certified upper one
            cents[r], bounds[r], errs[r] = ref.inner.centroid, (ref.inner.volume, np.nan), np.nan
            dims[r] = ref.inner.affine_dim
        else:
            if not ref.converged:  # pragma: no cover - safety net
                raise GeometryError("facet refinement did not converge; use eps > 0.")
            cents[r], bounds[r], dims[r] = ref.inner.centroid, ref.inner.volume, ref.inner.affine_dim
    return cents, bounds, errs, dims, calls
