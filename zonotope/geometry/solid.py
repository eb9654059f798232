"""Exact object-colour solids: zonotopes ``Z = {offset + xᵀG : 0 ≤ x ≤ 1}``.

The object-colour solid of any set of k sensitivities (a camera, an observer, or several
stacked) under an illuminant is the zonotope whose generators are the rows of the
``(n_wavelengths, k)`` matrix made by :func:`zonotope.generators`.

What is exact, and up to which size
-----------------------------------
- ``support`` (boundary point and optimal-stimulus reflectance for a direction): exact, any k.
- 3-D (k = 3): facets, half-spaces, vertices, volume, triangulated surface and ``contains``
  are exact in closed form, with no hull computation, for any number of generators (1 nm grids,
  ~470 generators, take a fraction of a second). Parallel generators are merged, zero ones
  dropped, and coplanar generators give one zonogon facet instead of slivers (tolerances in
  :data:`zonotope.TOL`).
- k ≠ 3: ``contains`` solves one small LP per point (scipy HiGHS); ``volume`` is the exact
  sum over k-subsets of generators of ``|det|``, allowed while C(n, k) ≤ ``max_terms``
  (default 10⁷: e.g. 6 channels on a 10 nm 400–700 nm grid, C(31, 6) ≈ 7.4·10⁵).

References
----------
.. [1] Schrödinger, E. (1920). Theorie der Pigmente von größter Leuchtkraft. Ann. Phys. 62.
.. [2] McMullen, P. (1971). On zonotopes. Trans. AMS 159 — facets of a 3-zonotope come in
   ± pairs, one per pair of generator directions; volume = ``Σ_{i<j<k} |det(g_i, g_j, g_k)|``.
.. [3] Centore, P. (2013). A zonohedral approach to optimal colours. Color Res. Appl. 38(2).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import cached_property
from itertools import combinations

import numpy as np

from .._errors import GeometryError, float_array
from .._tol import MAGNITUDE_MAX, MAGNITUDE_MIN, TOL, Tolerances
from . import zonohedron as _zh
from .lp import distance_to_zonotope

__all__ = ["FACETS_MAX", "Parallelograms", "Support", "VolumeUnderflowError", "Zonotope"]

#: The exact 3-D path builds every facet of the zonohedron: p(p − 1) of them for p distinct
#: generator directions, each with its vertices, so time and memory grow as p² log p. Refused
#: above this count, as :meth:`Zonotope.volume_nd` refuses more than ``max_terms`` determinants:
#: 2,000 directions (a 0.2 nm grid over 380–780 nm) are ≈ 4·10⁶ facets: volume ≈ 10 s at 1 GB on 2 cores;
#: 5,000 ran for minutes at 3.7 GB.
FACETS_MAX = 4_000_000

#: Volumes below this are refused, not returned: each term of the volume is a product of k
#: lengths, and under ``tiny / eps`` (≈ 1e-292) float64 keeps fewer than its 53 bits (down to 0).
_VOLUME_MIN = float(np.finfo(np.float64).tiny / np.finfo(np.float64).eps)


class VolumeUnderflowError(GeometryError):
    """:attr:`Zonotope.volume` of a full-dimensional solid whose volume is below float64's range."""


@dataclass(frozen=True)
class Support:
    """Result of :meth:`Zonotope.support`.

    Attributes
    ----------
    point : ndarray of shape (..., k)
        The boundary point maximising ``direction · y`` over the solid.
    reflectance : ndarray of shape (..., n)
        The optimal stimulus: 1 where ``direction · g_λ > 0``, else 0 (ties → 0).
    transitions : ndarray of shape (...,)
        Number of 0↔1 changes of ``reflectance`` along the wavelength axis.
    value : ndarray of shape (...,)
        The support function ``h(direction) = direction · point``.
    """

    point: np.ndarray
    reflectance: np.ndarray
    transitions: np.ndarray
    value: np.ndarray


@dataclass(frozen=True)
class Parallelograms:
    """Result of :meth:`Zonotope.parallelograms`: the boundary tiled by parallelograms.

    Each row stands for a ± pair (the point reflection has the same count and area), one per
    pair of reduced generators: ``p(p − 1)/2`` rows for ``p`` reduced generators.

    Attributes
    ----------
    pairs : ndarray of shape (P, 2)
        Reduced generator indices I < J.
    generators : ndarray of shape (P, 2)
        First input generator (row of ``Zonotope.generators``) of I and of J.
    wavelengths : ndarray of shape (P, 2) or None
        Their wavelengths, when the solid was made from spectral data.
    transitions : ndarray of shape (P,)
        Fewest 0↔1 transitions (circular) of the optimal stimuli on the parallelogram: 2 where
        the boundary coincides with the 2-transition (Schrödinger) surface, more where it
        does not (Burns 2021).
    area : ndarray of shape (P,)
        Area of one parallelogram, ``|h_I × h_J|``.
    """

    pairs: np.ndarray
    generators: np.ndarray
    wavelengths: np.ndarray | None
    transitions: np.ndarray
    area: np.ndarray


class Zonotope:
    """The zonotope ``{offset + xᵀG : x ∈ [0, 1]ⁿ}`` of a generator matrix.

    Parameters
    ----------
    generators : array_like of shape (n, k) or colour.MultiSpectralDistributions
        One generator per row (per wavelength). A colour MSDS keeps its wavelengths.
    offset : array_like of shape (k,), optional
        Translation; default the origin (black).
    tol : Tolerances, optional
        Relative tolerances of the combinatorics (zero, parallel, coplanar generators, rank,
        default slack of :meth:`contains`), default :data:`zonotope.TOL`. Absolute slacks are
        called ``atol`` (e.g. ``contains(points, atol=...)``).

    Attributes
    ----------
    ambient_dim : int
        k, the number of channels (columns of ``generators``).
    affine_dim : int
        Dimension of the solid's affine hull (the rank of ``generators``), ≤ ``ambient_dim``.

    Examples
    --------
    >>> import numpy as np
    >>> Z = Zonotope(np.eye(3))            # the unit cube
    >>> float(Z.volume), Z.vertices.shape
    (1.0, (8, 3))
    >>> bool(Z.contains([0.5, 0.5, 0.5])), bool(Z.contains([1.5, 0.5, 0.5]))
    (True, False)
    """

    def __init__(self, generators, *, offset=None, tol: Tolerances = TOL) -> None:
        wavelengths = getattr(generators, "wavelengths", None)
        values = getattr(generators, "values", generators)
        G = float_array(values, "generators", GeometryError, copy=True)
        if G.ndim == 1:
            G = G[:, None]
        if G.ndim != 2 or G.shape[0] < 1 or G.shape[1] < 1:
            raise GeometryError(
                f"generators must be a 2-D array of shape (n, k) with n, k ≥ 1; got shape {G.shape}."
            )
        if not np.all(np.isfinite(G)):
            raise GeometryError("generators contain NaN or inf; check the spectral data.")
        peak = float(np.abs(G).max())
        if peak > 0 and not MAGNITUDE_MIN <= peak <= MAGNITUDE_MAX:
            raise GeometryError(
                f"generators of magnitude {peak:.3g}: products of two (cross products, volumes) would "
                "underflow or overflow in float64. Rescale them, e.g. generators(..., normalise=1)."
            )
        k = G.shape[1]
        # the solid lies in a cube of side Σ‖g‖, so its volume (a product of k lengths) stays below
        # (Σ‖g‖)^k: refuse where that bound leaves float64, instead of an inf or NaN volume later
        if peak > 0 and k * np.log10(np.linalg.norm(G / peak, axis=1).sum() * peak) > 300:
            raise GeometryError(
                f"generators of magnitude {peak:.3g} in {k} dimensions: the volume (up to "
                f"(Σ‖g‖)^{k}) would overflow float64. Rescale them, e.g. generators(..., normalise=1)."
            )
        off = (
            np.zeros(k)
            if offset is None
            else float_array(offset, "offset", GeometryError, copy=True).reshape(-1)
        )
        if off.shape != (k,) or not np.all(np.isfinite(off)):
            raise GeometryError(f"offset must be a finite vector of length {k}; got {offset!r}.")
        G.flags.writeable = False
        off.flags.writeable = False
        self.generators = G
        self.offset = off
        self.wavelengths = None if wavelengths is None else np.asarray(wavelengths, dtype=float)
        self.tol = tol

    def __repr__(self) -> str:
        return f"Zonotope(n_generators={self.n_generators}, ambient_dim={self.ambient_dim})"

    # -- basic quantities ---------------------------------------------------------------------

    @property
    def ambient_dim(self) -> int:
        """Ambient dimension k (number of channels, columns of ``generators``)."""
        return self.generators.shape[1]

    @property
    def n_generators(self) -> int:
        """Number of generators n (before zero ones are dropped and parallel ones merged)."""
        return self.generators.shape[0]

    @property
    def centroid(self) -> np.ndarray:
        """Centre of symmetry = volume centroid = half the white point (plus offset)."""
        return self.offset + 0.5 * self.generators.sum(axis=0)

    @property
    def white(self) -> np.ndarray:
        """Response to the perfect white reflector (x = 1 everywhere)."""
        return self.offset + self.generators.sum(axis=0)

    @cached_property
    def scale(self) -> float:
        """Natural length scale: the largest per-channel extent of the solid."""
        return float(np.abs(self.generators).sum(axis=0).max()) or 1.0

    @cached_property
    def affine_dim(self) -> int:
        """Dimension of the affine hull = rank of ``generators`` (< k for flat solids, e.g.
        duplicated channels); singular values below ``tol.rank ×`` the largest count as zero."""
        s = np.linalg.svd(self.generators, compute_uv=False)
        return int(np.sum(s > self.tol.rank * (s[0] if s.size else 0.0))) if s.size else 0

    @cached_property
    def _reduced(self) -> tuple[np.ndarray, np.ndarray]:
        """(H, offset'): zero generators dropped, all oriented to one half-space, parallels merged.

        Z(G) = offset' + Z(H) exactly, since {t·g} = g + {t·(−g)} for t ∈ [0, 1].
        """
        return self._reduction[:2]

    @cached_property
    def _reduction(self):
        """(H, offset', group (n,), flipped (n,)): see :func:`.zonohedron.reduce_with_groups`."""
        return _zh.reduce_with_groups(self.generators, self.offset, self.tol)

    # -- support / optimal stimuli ------------------------------------------------------------

    def support(self, directions) -> Support:
        """Boundary point and optimal-stimulus reflectance maximising ``u · y`` over the solid.

        Parameters
        ----------
        directions : array_like of shape (..., k)

        Returns
        -------
        Support
            ``point`` (..., k), ``reflectance`` (..., n) of 0/1, ``transitions`` (...,),
            ``value`` (...,). For directions normal to a face the point is one of its vertices
            (wavelengths with ``u · g = 0`` get reflectance 0).
        """
        u = float_array(directions, "directions", GeometryError)
        if u.shape[-1:] != (self.ambient_dim,):
            raise GeometryError(f"directions must have shape (..., {self.ambient_dim}); got {u.shape}.")
        if not np.all(np.isfinite(u)):
            raise GeometryError("directions contain NaN or inf; give finite direction vectors.")
        x = (u @ self.generators.T > 0).astype(np.float64)
        point = self.offset + x @ self.generators
        transitions = np.count_nonzero(np.diff(x, axis=-1), axis=-1)
        return Support(point, x, transitions, np.einsum("...k,...k->...", u, point))

    # -- 3-D exact facets ---------------------------------------------------------------------

    def _require_3d(self, what: str) -> None:
        if self.ambient_dim != 3:
            raise GeometryError(
                f"{what} is computed in closed form for 3 channels only (k={self.ambient_dim})."
            )
        if self.affine_dim < 3:
            raise GeometryError(
                f"{what}: the solid is flat (affine dimension {self.affine_dim} < 3), so it has no "
                "3-D facets; its channels are linearly dependent."
            )

    @cached_property
    def _facets(self) -> _zh.Facets3:
        """Facets of the zonohedron (+ side of each ± pair), see :func:`.zonohedron.facets`."""
        self._require_3d("facets")
        H, off = self._reduced
        p = H.shape[0]
        if p * (p - 1) > FACETS_MAX:
            raise GeometryError(
                f"the exact 3-D solid of {p} generator directions has {p * (p - 1):.3g} facets "
                f"(> FACETS_MAX = {FACETS_MAX:.3g}); resample the spectra to a coarser grid "
                "(1–5 nm is enough for any measured sensitivity)."
            )
        s = np.linalg.svd(H, compute_uv=False) if H.size else np.zeros(0)
        if s.size < 3 or s[2] <= self.tol.rank * s[0]:
            raise GeometryError(
                f"facets: after merging generators closer than tol.parallel={self.tol.parallel:g} "
                f"({H.shape[0]} distinct directions remain) the solid is flat, although its generators "
                f"have rank {self.affine_dim}; they differ only at the scale of that tolerance. Rescale "
                "the generators or pass Zonotope(..., tol=Tolerances(parallel=<smaller>))."
            )
        return _zh.facets(H, off, self._keys_r, coplanar=self.tol.coplanar)

    @cached_property
    def halfspaces(self) -> tuple[np.ndarray, np.ndarray]:
        """H-representation ``A y ≤ b`` with unit rows, one row per facet (3-D only).

        Returns
        -------
        A : ndarray of shape (m, 3)
        b : ndarray of shape (m,)
        """
        return _zh.halfspaces(self._facets, self.centroid)

    @cached_property
    def _mesh(self) -> tuple[np.ndarray, np.ndarray]:
        # Nearly coplanar generators can make the combinatorics of neighbouring facets disagree;
        # the surface is then rebuilt as the Qhull hull of the vertices (mesh_method "qhull").
        V, F, self.mesh_method = _zh.mesh(self._facets, self._reduced[0], self._keys_r, self.centroid)
        return V, F

    @cached_property
    def _keys_r(self) -> np.ndarray:
        p = self._reduced[0].shape[0]
        rng = np.random.default_rng(2024)
        return rng.integers(np.iinfo(np.int64).min, np.iinfo(np.int64).max, size=p, dtype=np.int64)

    @cached_property
    def _key_all(self) -> np.int64:
        return self._keys_r.sum(dtype=np.int64)

    @cached_property
    def vertices(self) -> np.ndarray:
        """Exact vertices, ndarray of shape (V, 3): n(n−1)+2 for n generators in general position.

        Each vertex is found once, without sorting or hashing (see :meth:`_vertices_sweep`); when
        the data are too degenerate for that, every facet corner is listed and duplicates are
        removed by their generator-set keys.
        """
        if "_mesh" in self.__dict__:
            return self._mesh[0]
        fast = self._vertices_sweep()
        return fast if fast is not None else self._vertices_by_keys()

    def _vertices_by_keys(self) -> np.ndarray:
        """Every facet's lowest and highest corner and their reflections, repeats dropped by key."""
        return _zh.vertices_by_keys(self._facets, self._reduced[0], self._keys_r, self.centroid)

    def _vertices_sweep(self) -> np.ndarray | None:
        """Each vertex exactly once from the great-circle arrangement, or None (see
        :func:`.zonohedron.vertices_sweep`)."""
        H, off = self._reduced
        return _zh.vertices_sweep(self._facets, H, off, self._keys_r, self.centroid)

    def parallelograms(self) -> Parallelograms:
        """Boundary parallelograms of the standard tiling and their transition counts (3-D).

        Returns
        -------
        Parallelograms
            One row per pair of reduced generators: indices, first input generators (and their
            wavelengths), transition counts and areas.

        Notes
        -----
        The boundary of a 3-zonotope with p generators (zero ones dropped, parallel ones merged)
        is tiled by p(p − 1) parallelograms, ± pairs; zonogon facets are tiled too. The centre of
        the tile {I, J} is reached by the cube point x = ½ on I and J and x = [n · g > 0]
        elsewhere; its circular transition count is that of zonohedra's ``transitionsdf``
        (Davis, vignette "The 2-Transition Subcomplex and the 2-Transition Surface"). For the CIE
        1931 2° CMFs at 1 nm with ``Tolerances(parallel=1e-6)`` both give 340 generators, 1802
        tiles with 8 transitions and 95.5 % of the area with 2 (tests/test_zonohedra.py).

        References
        ----------
        .. [1] Burns, S. A. (2021). The location of optimal object colors with more than two
           transitions. JOSA A 38(2), 202–215.
        .. [2] Davis, G. zonohedra (R package), ``transitionsdf``, ``boundarypgramdata``.
        """
        self._require_3d("parallelograms")
        H, _, group, _ = self._reduction
        pairs, reps, tr = _zh.pgram_transitions(self.generators, H, group, self._facets)
        area = np.linalg.norm(np.cross(H[pairs[:, 0]], H[pairs[:, 1]]), axis=1)
        wl = None if self.wavelengths is None else self.wavelengths[reps]
        return Parallelograms(pairs, reps, wl, tr, area)

    def triangles(self) -> tuple[np.ndarray, np.ndarray]:
        """Watertight triangulated surface: ``(vertices (V, 3), faces (F, 3))``, outward CCW."""
        return self._mesh

    @cached_property
    def n_facets(self) -> int:
        """Number of facets (± pairs counted twice; a zonogon facet counts once)."""
        return int(self.halfspaces[0].shape[0])

    def volume_nd(self, *, max_terms: int = 10_000_000) -> float:
        """Exact k-volume Σ over k-subsets of ``|det|`` (any k); refuses when C(n, k) > max_terms."""
        H, _ = self._reduced
        k = self.ambient_dim
        if H.shape[0] < k or self.affine_dim < k:
            return 0.0
        terms = math.comb(H.shape[0], k)
        if terms > max_terms:
            raise GeometryError(
                f"exact {k}-volume needs C({H.shape[0]}, {k}) = {terms:.3g} determinants "
                f"(> max_terms={max_terms:.3g}). Use a coarser wavelength grid or raise max_terms."
            )
        total = 0.0
        it = combinations(range(H.shape[0]), k)
        while True:
            chunk = np.fromiter(
                (c for c in (next(it, None) for _ in range(200_000)) if c is not None), dtype=(int, k)
            )
            if chunk.size == 0:
                break
            total += float(np.abs(np.linalg.det(H[chunk])).sum())
        return total

    @property
    def volume(self) -> float:
        """Exact volume (k-dimensional measure); 0 for flat solids.

        3-D: ``(1/3) Σ_{i<j} n_ij · (2 B⁺_ij − T)`` from the facets, which equals
        ``Σ_{i<j<k} |det(h_i, h_j, h_k)|`` (McMullen) in O(p² log p). Other k: :meth:`volume_nd`.
        """
        if self.affine_dim < self.ambient_dim:
            return 0.0
        volume = self._facets.volume if self.ambient_dim == 3 else self.volume_nd()
        if volume < _VOLUME_MIN:  # full-dimensional, so the true volume is > 0: it left float64
            peak = float(np.abs(self.generators).max())
            raise VolumeUnderflowError(
                f"the volume of generators of magnitude {peak:.3g} in {self.ambient_dim} dimensions "
                f"is below float64's range (< {_VOLUME_MIN:.0e}); rescale the generators (e.g. "
                "generators(..., normalise=1)) and multiply the volume by the scale's power."
            )
        return volume

    # -- inside test --------------------------------------------------------------------------

    def contains(self, points, atol: float | None = None) -> np.ndarray:
        """Whether each point lies in the solid (within ``atol``), vectorised.

        Parameters
        ----------
        points : array_like of shape (..., k)
        atol : float, optional
            Absolute slack in response units; default ``self.tol.contains × scale`` (the solid's
            own :class:`Tolerances`).

        Returns
        -------
        ndarray of bool, shape (...)

        Notes
        -----
        3-D full-rank solids use the exact H-representation with a cube-map of candidate facets
        around the centre (only the facets whose radial shadow can meet a point's direction are
        tested; points within ``atol`` of the boundary are re-tested against every facet), built on
        the first call with at least as many points as the map has cells (before that, every
        facet is tested: same answer, cheaper for a few thousand points). Other
        solids solve one HiGHS LP per point for the ∞-norm distance.
        """
        P = float_array(points, "points", GeometryError)
        if P.shape[-1:] != (self.ambient_dim,):
            raise GeometryError(f"points must have shape (..., {self.ambient_dim}); got {P.shape}.")
        if not np.all(np.isfinite(P)):
            raise GeometryError("points contain NaN or inf.")
        atol = self.tol.contains * self.scale if atol is None else float(atol)
        flat = P.reshape(-1, self.ambient_dim)
        if self.ambient_dim == 3 and self.affine_dim == 3:
            m = self.halfspaces[0].shape[0]
            K = int(np.clip(np.sqrt(m / 12.0), 4, 48))
            if "_cubemap" in self.__dict__ or flat.shape[0] >= 6 * K * K:
                inside = self._cubemap.contains(flat, atol)
            else:  # building the cube map costs ~6K² facet sweeps: test few points densely
                inside = self.contains_reference(flat, atol)
        else:
            H, off = self._reduced
            inside = np.array([distance_to_zonotope(H, off, q)[0] <= atol for q in flat], dtype=bool)
        return inside.reshape(P.shape[:-1])

    def contains_reference(self, points, atol: float | None = None) -> np.ndarray:
        """Slow twin of :meth:`contains` for 3-D: every facet for every point (tests use it)."""
        P = float_array(points, "points", GeometryError)
        atol = self.tol.contains * self.scale if atol is None else float(atol)
        A, b = self.halfspaces
        flat = P.reshape(-1, 3)
        out = np.empty(flat.shape[0], dtype=bool)
        half = A.shape[0] // 2  # rows come in ± pairs (A = [N; −N]): one product serves both
        N, bp, bm = A[:half], b[:half], b[half:]
        step = max(1, 2_000_000 // max(half, 1))
        for s in range(0, flat.shape[0], step):
            v = flat[s : s + step] @ N.T
            out[s : s + step] = np.maximum((v - bp).max(axis=1), (-v - bm).max(axis=1)) <= atol
        return out.reshape(P.shape[:-1])

    @cached_property
    def _cubemap(self):
        from .cubemap import CubeMap

        A, b = self.halfspaces
        f = self._facets
        H, _ = self._reduced
        c = self.centroid
        hi, hj = H[f.pairs[:, 0]], H[f.pairs[:, 1]]
        quads = np.stack([f.bases, f.bases + hi, f.bases + hi + hj, f.bases + hj], axis=1)
        corners = [quads] + [z[1][None] for z in f.zonogons]
        return CubeMap(A, b, c, corners)

    # -- conversions --------------------------------------------------------------------------

    def to_trimesh(self):
        """The surface as a watertight :class:`trimesh.Trimesh` (3-D only)."""
        import trimesh

        V, F = self.triangles()
        return trimesh.Trimesh(vertices=V, faces=F, process=False)

    def to_pyvista(self):
        """The surface as :class:`pyvista.PolyData` (3-D only)."""
        import pyvista as pv

        V, F = self.triangles()
        return pv.PolyData(V, np.hstack([np.full((F.shape[0], 1), 3), F]).ravel())

    def to_manifold(self):
        """The solid as a :class:`manifold3d.Manifold` (float64 mesh) for booleans."""
        import manifold3d as m3d

        V, F = self.triangles()
        mesh = m3d.Mesh64(
            vert_properties=np.ascontiguousarray(V), tri_verts=np.ascontiguousarray(F, dtype=np.uint64)
        )
        return m3d.Manifold(mesh)
