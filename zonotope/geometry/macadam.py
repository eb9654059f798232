"""Exact MacAdam limits, object-colour membership and metamer generation (``invert``).

The object-colour solid of an observer under an illuminant is the zonotope of its generators
(:class:`zonotope.Zonotope`), so the classical questions of colorimetry have exact answers:

- :func:`macadam_limits` — the loci of optimal colours at constant luminance: the section of the
  exact solid by the plane Y = const, a convex polygon whose vertices are where the plane cuts
  the solid's edges (optimal stimuli with at most one fractional wavelength);
- :func:`is_object_colour` — "can a reflectance in [0, 1] produce this XYZ?", exact (closed-form
  half-spaces, no hull of samples, no 2-transition approximation);
- :func:`invert` — a reflectance for any point of the solid (a metamer generator), exact up to
  floating point and checked by re-integration.

colour-science's :func:`colour.is_within_macadam_limits` tests against precomputed MacAdam
tables through a Delaunay hull of sampled optimal colours; under illuminant C it calls 829 of
the 2,734 real Munsell colours impossible (colour-science issue #364); the exact solid keeps all
but a handful (tests/test_macadam.py, benchmarks/bench_macadam.py).

``invert`` uses the centre of symmetry c (reached by x = ½): the ray from c through p leaves the
solid at q = c + (p − c)/t on a facet (t the gauge of p), q has a cube point x_q that is 0/1
except on the facet's two generators (or its zonogon's), and x_p = ½ + (x_q − ½)·t lies in
[0, 1] and integrates to p by linearity.

References
----------
.. [1] MacAdam, D. L. (1935). Maximum visual efficiency of colored materials. JOSA 25(11).
.. [2] Schrödinger, E. (1920). Theorie der Pigmente von größter Leuchtkraft. Ann. Phys. 62.
.. [3] Centore, P. (2013). A zonohedral approach to optimal colours. Color Res. Appl. 38(2).
.. [4] colour-science issue #364, "is_within_macadam_limits" and the Munsell renotation data.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import lru_cache

import numpy as np

from .._errors import GeometryError
from .._tol import BVLS, SECTION_MERGE, SECTION_PLANE
from ..spectra.builtin import float_array
from .solid import Zonotope

__all__ = ["MacAdamLimits", "invert", "is_object_colour", "macadam_limits", "object_colour_solid", "section"]


@lru_cache(maxsize=8)
def _solid_cached(observer: str, illuminant: str, start: float, end: float, interval: float) -> Zonotope:
    import colour

    from ..spectra.builtin import generators

    G = generators(observer, illuminant, colour.SpectralShape(start, end, interval), normalise=1)
    return Zonotope(G)


def object_colour_solid(
    observer: str = "CIE 1931 2°",
    illuminant: str = "D65",
    *,
    start: float = 360.0,
    end: float = 780.0,
    interval: float = 1.0,
) -> Zonotope:
    """The exact object-colour solid in XYZ, scaled so that the perfect white has Y = 1.

    Parameters
    ----------
    observer, illuminant : str
        Names as :func:`zonotope.generators` accepts them (any of colour-science's).
    start, end, interval : float
        Wavelength grid in nm (default 360–780 nm at 1 nm, where every CIE illuminant is
        tabulated). Solids are cached by these arguments.

    Returns
    -------
    Zonotope
    """
    return _solid_cached(str(observer), str(illuminant), float(start), float(end), float(interval))


def _solid(solid, observer, illuminant) -> Zonotope:
    if solid is not None:
        if not isinstance(solid, Zonotope):
            raise GeometryError(f"solid must be a zonotope.Zonotope; got {type(solid).__name__}.")
        return solid
    return object_colour_solid(observer, illuminant)


def is_object_colour(
    XYZ,
    *,
    observer: str = "CIE 1931 2°",
    illuminant: str = "D65",
    solid: Zonotope | None = None,
    atol: float | None = None,
) -> np.ndarray:
    """Whether each XYZ (Y_white = 1) is the colour of some reflectance in [0, 1], exactly.

    Parameters
    ----------
    XYZ : array_like of shape (..., 3)
        Tristimulus values scaled so the perfect white has Y = 1.
    observer, illuminant : str
        Used when ``solid`` is not given (see :func:`object_colour_solid`).
    solid : Zonotope, optional
        Any 3-channel solid instead (e.g. another grid).
    atol : float, optional
        Absolute slack (XYZ units); default ``TOL.contains × scale`` (~1e-9).

    Returns
    -------
    ndarray of bool, shape (...)
    """
    return _solid(solid, observer, illuminant).contains(float_array(XYZ, "XYZ", GeometryError), atol)


def section(solid: Zonotope, normal, value: float) -> np.ndarray:
    """Exact section ``{y ∈ solid : normal · y = value}`` of a 3-D solid: a convex polygon.

    Parameters
    ----------
    solid : Zonotope
        A full-rank 3-channel solid.
    normal : array_like of shape (3,)
    value : float

    Returns
    -------
    ndarray of shape (M, 3)
        The polygon's vertices, counter-clockwise about ``normal``; empty (0, 3) when the plane
        misses the solid, one point when it only touches it.

    Notes
    -----
    The vertices are where the plane cuts the solid's edges (the edges of its parallelogram and
    zonogon facets), computed edge by edge: no hull and no sampling.
    """
    n = float_array(normal, "normal", GeometryError).reshape(-1)
    if n.shape != (3,) or not np.all(np.isfinite(n)) or not np.any(n):
        raise GeometryError(f"normal must be a finite non-zero 3-vector; got {normal!r}.")
    if not np.isfinite(value):
        raise GeometryError(f"value must be finite; got {value!r}.")
    solid._require_3d("section")
    f = solid._facets
    H = solid._reduced[0]
    c2 = 2.0 * solid.centroid
    hi, hj = H[f.pairs[:, 0]], H[f.pairs[:, 1]]
    quads = np.stack([f.bases, f.bases + hi, f.bases + hi + hj, f.bases + hj], axis=1)
    loops = [quads, c2 - quads] + [z[1][None] for z in f.zonogons] + [(c2 - z[1])[None] for z in f.zonogons]
    a = np.concatenate([L.reshape(-1, 3) for L in loops])
    b = np.concatenate([np.roll(L, -1, axis=1).reshape(-1, 3) for L in loops])
    sa, sb = a @ n - value, b @ n - value
    scale = solid.scale * np.linalg.norm(n)
    eps = SECTION_PLANE * scale
    cross = ((sa < -eps) & (sb > eps)) | ((sa > eps) & (sb < -eps))
    pts = a[cross] + (b[cross] - a[cross]) * (sa[cross] / (sa[cross] - sb[cross]))[:, None]
    on = np.concatenate([a[np.abs(sa) <= eps], b[np.abs(sb) <= eps]])
    pts = np.concatenate([pts, on])
    if pts.shape[0] == 0:
        return np.zeros((0, 3))
    key = np.round(pts / (SECTION_MERGE * solid.scale))
    _, first = np.unique(key, axis=0, return_index=True)
    pts = pts[np.sort(first)]
    if pts.shape[0] < 3:
        return pts
    e1 = pts[0] - pts.mean(axis=0)
    nn = n / np.linalg.norm(n)
    e1 = e1 - nn * (nn @ e1)
    e1 /= np.linalg.norm(e1)
    e2 = np.cross(nn, e1)
    rel = pts - pts.mean(axis=0)
    return pts[np.argsort(np.arctan2(rel @ e2, rel @ e1))]


@dataclass(frozen=True)
class MacAdamLimits:
    """Result of :func:`macadam_limits`.

    Attributes
    ----------
    Y : float
        The luminance of the section (perfect white = 1).
    XYZ : ndarray of shape (M, 3)
        Vertices of the section polygon (optimal colours), counter-clockwise seen from +Y.
    xy : ndarray of shape (M, 2)
        Their chromaticities: the MacAdam limit at this luminance.
    """

    Y: float
    XYZ: np.ndarray
    xy: np.ndarray


def macadam_limits(
    Y: float, *, observer: str = "CIE 1931 2°", illuminant: str = "D65", solid: Zonotope | None = None
) -> MacAdamLimits:
    """The exact MacAdam limit: chromaticities of the optimal colours of luminance Y.

    Parameters
    ----------
    Y : float
        Luminance, 0 < Y < 1 (perfect white = 1).
    observer, illuminant : str
        Any of colour-science's, see :func:`object_colour_solid`.
    solid : Zonotope, optional
        A 3-channel XYZ solid to use instead.

    Returns
    -------
    MacAdamLimits

    Raises
    ------
    GeometryError
        If Y is not strictly between 0 and the solid's white luminance.

    Examples
    --------
    >>> lim = macadam_limits(0.5, illuminant="C")
    >>> lim.xy.shape[1], bool(lim.xy.shape[0] > 100)
    (2, True)
    """
    Z = _solid(solid, observer, illuminant)
    Yw = float(Z.white[1])
    lo = float(Z.offset[1] + np.minimum(Z.generators[:, 1], 0).sum())
    if (
        isinstance(Y, bool)
        or not isinstance(Y, int | float | np.number)
        or not np.isfinite(Y)
        or not lo < Y < Yw
    ):
        raise GeometryError(f"Y must lie strictly between {lo:g} and the white's {Yw:g}; got {Y!r}.")
    P = section(Z, [0.0, 1.0, 0.0], float(Y))
    P = P[::-1]  # counter-clockwise seen from +Y
    xy = P[:, :2] / P.sum(axis=1, keepdims=True)
    return MacAdamLimits(float(Y), P, xy)


def invert(
    points,
    *,
    solid: Zonotope | None = None,
    observer: str = "CIE 1931 2°",
    illuminant: str = "D65",
    atol: float | None = None,
    chunk: int | None = None,
) -> np.ndarray:
    """A reflectance in [0, 1] for each point of a 3-D solid (a metamer generator), exactly.

    Parameters
    ----------
    points : array_like of shape (..., 3)
        Responses inside the solid.
    solid : Zonotope, optional
        The solid; default :func:`object_colour_solid` of ``observer`` and ``illuminant``.
    atol : float, optional
        Absolute slack (response units): points whose gauge exceeds ``1 + atol / scale`` are
        refused; default ``TOL.contains × scale`` (~1e-9 relative). Points within it are
        treated as boundary points.
    chunk : int, optional
        Points handled per vectorised block; default so that a block's gauge matrix (points ×
        facets) holds about 2·10⁶ numbers.

    Returns
    -------
    ndarray of shape (..., n)
        Reflectances (one value per input generator/wavelength) with
        ``reflectance @ solid.generators + solid.offset == point`` up to floating point
        (~1e-15 relative; tests re-integrate).

    Raises
    ------
    GeometryError
        If a point lies outside the solid (its gauge, > 1, is named), or is not finite.

    Notes
    -----
    Rays from the centre of symmetry (module docstring): the answer is the reflectance on the
    segment from the flat grey x = ½ to an optimal stimulus with at most two fractional values
    (more on a zonogon facet, solved there by bounded least squares), so it has at most two
    (or r) values outside {½ ± s/2} and is the "least saturated" metamer along that ray.
    """
    from .._tol import TOL

    Z = solid if solid is not None else object_colour_solid(observer, illuminant)
    Z._require_3d("invert")
    P = float_array(points, "points", GeometryError)
    if P.shape[-1:] != (3,):
        raise GeometryError(f"points must have shape (..., 3); got {P.shape}.")
    if not np.all(np.isfinite(P)):
        raise GeometryError("points contain NaN or inf.")
    flat = P.reshape(-1, 3)
    rtol = TOL.contains if atol is None else float(atol) / Z.scale
    H, off, group, flipped = Z._reduction
    f = Z._facets
    A, b = Z.halfspaces
    c = Z.centroid
    h = b - A @ c
    half = A.shape[0] // 2
    npairs = f.pairs.shape[0]
    p = H.shape[0]
    out = np.empty((flat.shape[0], Z.n_generators))
    chunk = chunk or max(1, 4_000_000 // A.shape[0])
    for s in range(0, flat.shape[0], chunk):
        d = flat[s : s + chunk] - c
        sn = d @ A[:half].T  # rows come in ± pairs: one product serves both facets
        gp, gm = sn / h[:half], -sn / h[half:]
        kp, km = np.argmax(gp, axis=1), np.argmax(gm, axis=1)
        rows_ = np.arange(d.shape[0])
        tp, tm = gp[rows_, kp], gm[rows_, km]
        k = np.where(tp >= tm, kp, km + half)
        t = np.maximum(tp, tm)
        bad = t > 1.0 + rtol
        if np.any(bad):
            i = int(np.nonzero(bad)[0][0]) + s
            raise GeometryError(
                f"points[{i}] = {flat[i].tolist()} lies outside the solid (gauge {t[bad].max():.6g} > 1): "
                "no reflectance in [0, 1] produces it. Test with is_object_colour / Zonotope.contains."
            )
        t = np.minimum(t, 1.0)
        safe = np.where(t > 0, t, 1.0)
        minus = k >= half
        kk = np.where(minus, k - half, k)
        q = c + d / safe[:, None]
        q = np.where(minus[:, None], 2.0 * c - q, q)  # the matching point on the + facet
        xq = np.empty((d.shape[0], p))
        par = kk < npairs
        if np.any(par):
            rows = np.nonzero(par)[0]
            i, j = f.pairs[kk[rows], 0], f.pairs[kk[rows], 1]
            side = (f.normals[kk[rows]] @ H.T) > 0.0
            side[np.arange(rows.size), i] = False
            side[np.arange(rows.size), j] = False
            r = q[rows] - off - side @ H
            hi, hj = H[i], H[j]
            a11, a12, a22 = (np.einsum("ij,ij->i", u, v) for u, v in ((hi, hi), (hi, hj), (hj, hj)))
            b1, b2 = np.einsum("ij,ij->i", hi, r), np.einsum("ij,ij->i", hj, r)
            det = a11 * a22 - a12 * a12
            alpha = np.clip((a22 * b1 - a12 * b2) / det, 0.0, 1.0)
            beta = np.clip((a11 * b2 - a12 * b1) / det, 0.0, 1.0)
            x = side.astype(np.float64)
            x[np.arange(rows.size), i] = alpha
            x[np.arange(rows.size), j] = beta
            xq[rows] = x
        for r_ in np.nonzero(~par)[0].tolist():
            xq[r_] = _zonogon_point(H, off, f, kk[r_] - npairs, q[r_])
        xq = np.where(minus[:, None], 1.0 - xq, xq)
        xr = 0.5 + (xq - 0.5) * t[:, None]
        x = np.full((d.shape[0], Z.n_generators), 0.5)
        kept = group >= 0
        x[:, kept] = xr[:, group[kept]]
        x[:, flipped] = 1.0 - x[:, flipped]
        out[s : s + chunk] = x
    return out.reshape((*P.shape[:-1], Z.n_generators))


def _zonogon_point(H, off, f, z, q) -> np.ndarray:
    """Cube point (reduced) of a point q on the + zonogon facet z: 0/1 off the plane, bounded
    least squares over the zonogon's generators in it."""
    from scipy.optimize import lsq_linear

    normal = f.zonogons[z][0]
    S = f.members[z]
    side = (H @ normal) > 0.0
    side[S] = False
    x = side.astype(np.float64)
    r = q - off - side @ H
    sol = lsq_linear(H[S].T, r, bounds=(0.0, 1.0), method="bvls", tol=BVLS)
    x[S] = sol.x
    return x
