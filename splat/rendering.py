"""Differentiable N-channel Gaussian splatting: 3DGS projection and front-to-back compositing.

One entry point, :func:`render`, over three back-ends with the same inputs and outputs:

- ``"reference"`` — every Gaussian is tested at every pixel, in depth order, with a chunked
  ``lax.scan`` (exact, O(pixels × Gaussians); the slow twin used by the tests);
- ``"tiled"`` — Gaussians are binned into square tiles by the bounding box of their cut-off ellipse
  and each tile composites at most ``tile_capacity`` of them (static shapes for JAX); Gaussians beyond
  the capacity are dropped and *counted* in :attr:`RenderOutput.n_dropped`. When nothing is dropped the
  two back-ends agree up to floating-point rounding (and ``transmittance_min`` times the largest
  colour, where early termination stops at different chunk boundaries);
- ``"cpu"`` — the same tiles and per-pixel termination as ``"tiled"`` without a capacity (nothing is
  dropped), composited and differentiated by hand in numba kernels (:mod:`splat._raster_kernel`) called
  from JAX through ``pure_callback`` with a custom VJP; the projection stays in JAX. On the CPU it is
  many times faster than ``"tiled"`` (``benchmarks/bench_splat.py``); on a GPU use ``"tiled"``, which
  stays on the device (``"auto"``, the training default, picks by JAX's default backend).

The footprint of a Gaussian is cut off sharply where its Mahalanobis distance exceeds
``sigma_cutoff`` (3σ by default) and where its alpha falls below ``alpha_min`` (1/255), in both
back-ends alike, so that the result does not depend on the tiling (3DGS cuts at the tile instead).

References
----------
Kerbl, B., Kopanas, G., Leimkühler, T., Drettakis, G. (2023). 3D Gaussian Splatting for Real-Time
Radiance Field Rendering. ACM TOG 42(4). Eqs. (2)–(6).
Ye, Z., Li, W., Liu, S., Qiao, P., Dou, Y. (2024). AbsGS: Recovering Fine Details for 3D Gaussian
Splatting. ACM Multimedia 2024. Sec. 3.2 (the absolute gradient of ``absgrad_probe``).
Zwicker, M., Pfister, H., van Baar, J., Gross, M. (2002). EWA splatting. IEEE TVCG 8(3). Eq. (31).
"""

from __future__ import annotations

import threading
from dataclasses import dataclass
from functools import partial
from typing import NamedTuple

import jax
import jax.numpy as jnp
import numpy as np

from zonotope.utilities import MethodRegistry

from ._errors import SplatError, SplatMethodError
from .camera import Camera
from .gaussians import Gaussians, covariances_from

__all__ = [
    "RENDER_METHODS",
    "Projected",
    "RenderConfig",
    "RenderOutput",
    "default_method",
    "project",
    "render",
    "render_cpu",
    "render_reference",
    "render_tiled",
]


@dataclass(frozen=True)
class RenderConfig:
    """Options of the renderer (hashable: it is a static argument of the jitted functions).

    Attributes
    ----------
    near : float
        Gaussians whose centre is closer than this (camera z) are culled.
    eps2d : float
        Dilation added to the 2-D covariance, in pixels² (3DGS: 0.3).
    sigma_cutoff : float
        A Gaussian covers the pixels within this Mahalanobis distance (3DGS: 3).
    alpha_min, alpha_max : float
        Alphas below ``alpha_min`` are skipped; alphas are clipped at ``alpha_max`` (3DGS: 1/255, 0.99).
    transmittance_min : float
        A pixel stops accumulating once its transmittance falls below this (3DGS: 1e-4), checked
        every ``chunk`` Gaussians, so the back-ends may differ by up to this times the largest colour;
        0 composites everything (exact and smooth, for gradient checks).
    background : float
        Value of every channel behind all Gaussians.
    tile_size : int
        Side of the square tiles of the tiled back-end, in pixels.
    tile_capacity : int
        Gaussians composited per tile at most (tiled back-end); the excess (the deepest) is dropped and
        counted. 2048 holds what the benchmark capture needs up to ≈ 262 144 Gaussians (its trained
        32 768-Gaussian model has ≤ 826 per tile; at 262 144, 2048 dropped 83 k Gaussian–tile pairs per
        view and scored 32.2 dB held out against 32.4 without drops; 1 M Gaussians dropped 1.4 M and
        scored 29.5).
    chunk : int
        Gaussians composited per scan step (memory ∝ pixels × chunk).
    tile_batch : int or None
        Tiles the tiled back-end composites together in one scan over the chunks: 1 one tile after
        another (least memory), 0 all at once, anything between in batches. A batch skips the chunks past
        its deepest tile's last Gaussian and those after all its pixels saturated. ``None`` (default):
        all at once on a GPU, one at a time on the CPU. On an H200 a benchmark-size training step (one
        510 × 360 view) took 0.024 s with all tiles at once against 1.98 s one at a time (32 768
        Gaussians, ``tile_capacity`` 1024; 0.043 against 3.98 s at 262 144 Gaussians and 2048, 0.078 at
        4096 — measured before batches skipped chunks, when all-at-once cost grew with the capacity).
    """

    near: float = 0.01
    eps2d: float = 0.3
    sigma_cutoff: float = 3.0
    alpha_min: float = 1.0 / 255.0
    alpha_max: float = 0.99
    transmittance_min: float = 1e-4
    background: float = 0.0
    tile_size: int = 16
    tile_capacity: int = 2048
    chunk: int = 32
    tile_batch: int | None = None

    def __post_init__(self):
        for name in ("tile_size", "tile_capacity", "chunk"):
            v = getattr(self, name)
            if not isinstance(v, int) or v < 1:
                raise SplatError(f"RenderConfig.{name} must be a positive int; got {v!r}.")
        if self.tile_batch is not None and (not isinstance(self.tile_batch, int) or self.tile_batch < 0):
            raise SplatError(
                "RenderConfig.tile_batch must be None (by device) or an int ≥ 0 (0: all tiles at once); "
                f"got {self.tile_batch!r}."
            )
        if not 0 <= self.alpha_min < self.alpha_max <= 1:
            raise SplatError(f"need 0 ≤ alpha_min < alpha_max ≤ 1; got {self.alpha_min}, {self.alpha_max}.")
        if not 0 <= self.transmittance_min < 1:
            raise SplatError(f"transmittance_min must lie in [0, 1); got {self.transmittance_min}.")
        if self.sigma_cutoff <= 0 or self.near <= 0 or self.eps2d < 0:
            raise SplatError(
                "RenderConfig needs sigma_cutoff > 0, near > 0 and eps2d ≥ 0; got "
                f"{self.sigma_cutoff}, {self.near}, {self.eps2d}."
            )


class Projected(NamedTuple):
    """Gaussians projected into one view (invalid ones are sanitised: zero opacity, unit conic).

    Attributes
    ----------
    means2d : Array (G, 2)      pixel coordinates of the centres
    conics : Array (G, 3)       ``(a, b, c)`` of the inverse 2-D covariance ``[[a, b], [b, c]]``
    extents : Array (G, 2)      half-width and half-height of the cut-off ellipse's bounding box
    radii : Array (G,)          ``sigma_cutoff · sqrt(largest eigenvalue)``, pixels (3DGS radius)
    depths : Array (G,)         camera-space z
    opacities : Array (G,)
    colours : Array (G, k)
    valid : Array (G,) bool     in front of the near plane, finite, and in ``mask``
    """

    means2d: jax.Array
    conics: jax.Array
    extents: jax.Array
    radii: jax.Array
    depths: jax.Array
    opacities: jax.Array
    colours: jax.Array
    valid: jax.Array


class RenderOutput(NamedTuple):
    """Result of :func:`render`.

    Attributes
    ----------
    image : Array (H, W, k)
        Composited colours (plus ``background · transmittance``).
    alpha : Array (H, W)
        Accumulated opacity ``1 − T``.
    n_dropped : Array () int
        Gaussian–tile pairs the tiled back-end dropped for lack of capacity (0 for the reference).
    max_per_tile : Array () int
        Largest number of Gaussians overlapping one tile (what ``tile_capacity`` must reach so that
        nothing is dropped); the reference back-end reports the number of valid Gaussians.
    """

    image: jax.Array
    alpha: jax.Array
    n_dropped: jax.Array
    max_per_tile: jax.Array


def project(
    gaussians: Gaussians,
    camera: Camera,
    *,
    config: RenderConfig = RenderConfig(),
    mask: jax.Array | None = None,
) -> Projected:
    """EWA projection of 3-D Gaussians into a pinhole view (Kerbl et al. 2023, eq. 5).

    ``Σ' = J W Σ Wᵀ Jᵀ + eps2d·I`` with ``W`` the world-to-camera rotation and ``J`` the Jacobian of
    the perspective map at the centre (its x/z, y/z clamped a little outside the frustum, as in 3DGS).

    Parameters
    ----------
    gaussians : Gaussians with G Gaussians and k channels
    camera : Camera
    config : RenderConfig
    mask : array_like of bool, shape (G,), optional
        Gaussians to render (the alive part of a fixed-capacity buffer); the others get zero
        opacity and receive exactly zero gradient.

    Returns
    -------
    Projected
    """
    R, t = camera.R, camera.t
    fx, fy = camera.focal[0], camera.focal[1]
    cx, cy = camera.principal[0], camera.principal[1]
    p = gaussians.means @ R.T + t  # [G, 3]
    z = p[:, 2]
    valid = z > config.near
    if mask is not None:
        valid = valid & mask
    zs = jnp.where(valid, z, 1.0)
    # clamp x/z, y/z to 1.3× the frustum (gsplat's off-centre form of 3DGS' limit)
    lim = 0.3
    tx = zs * jnp.clip(
        p[:, 0] / zs,
        -(cx / fx) - lim * camera.width / fx / 2,
        (camera.width - cx) / fx + lim * camera.width / fx / 2,
    )
    ty = zs * jnp.clip(
        p[:, 1] / zs,
        -(cy / fy) - lim * camera.height / fy / 2,
        (camera.height - cy) / fy + lim * camera.height / fy / 2,
    )
    zero = jnp.zeros_like(zs)
    J = jnp.stack(
        [jnp.stack([fx / zs, zero, -fx * tx / zs**2], -1), jnp.stack([zero, fy / zs, -fy * ty / zs**2], -1)],
        -2,
    )  # [G, 2, 3]
    T = J @ R  # [G, 2, 3]
    cov = T @ covariances_from(gaussians.quats, gaussians.log_scales) @ jnp.swapaxes(T, -1, -2)
    a = cov[:, 0, 0] + config.eps2d
    b = cov[:, 0, 1]
    c = cov[:, 1, 1] + config.eps2d
    det = a * c - b * b
    valid = valid & (det > 0) & jnp.all(jnp.isfinite(p), axis=-1)
    det = jnp.where(valid, det, 1.0)
    a, b, c = (jnp.where(valid, v, d) for v, d in ((a, 1.0), (b, 0.0), (c, 1.0)))
    conics = jnp.stack([c / det, -b / det, a / det], axis=-1)
    mid = 0.5 * (a + c)
    lam = mid + jnp.sqrt(jnp.maximum(mid * mid - det, 0.0))
    radii = config.sigma_cutoff * jnp.sqrt(lam)
    extents = config.sigma_cutoff * jnp.sqrt(jnp.stack([a, c], axis=-1))
    means2d = jnp.stack([fx * p[:, 0] / zs + cx, fy * p[:, 1] / zs + cy], axis=-1)
    means2d = jnp.where(valid[:, None], means2d, -1e6)
    opac = jnp.where(valid, gaussians.opacities, 0.0)
    return Projected(
        means2d, conics, extents, jnp.where(valid, radii, 0.0), z, opac, gaussians.colours, valid
    )


@jax.custom_vjp
def _abs_tap(d, probe):
    """``d`` unchanged; the gradient reaching ``probe`` (``d``'s shape with the pixel axis −3 of size 1)
    is the sum over pixels of the absolute gradient of ``d`` (AbsGS' statistic, see :func:`render`)."""
    return d


_abs_tap.defvjp(lambda d, probe: (d, None), lambda _, g: (g, jnp.sum(jnp.abs(g), axis=-3, keepdims=True)))


def _alpha(px: jax.Array, means2d, conics, opacities, config: RenderConfig, probe=None) -> jax.Array:
    """Alpha of K Gaussians at P pixels, shape (..., P, K) (px (..., P, 2); means2d (..., K, 2); conics
    (..., K, 3); opacities (..., K); the leading axes, e.g. tiles, broadcast). ``probe`` (..., K, 2),
    if given, receives the absolute per-pixel gradients of the centres (:func:`_abs_tap`)."""
    d = px[..., :, None, :] - means2d[..., None, :, :]  # [..., P, K, 2]
    if probe is not None:
        d = _abs_tap(d, probe[..., None, :, :])
    dx, dy = d[..., 0], d[..., 1]
    c = conics[..., None, :, :]
    q = c[..., 0] * dx * dx + 2 * c[..., 1] * dx * dy + c[..., 2] * dy * dy  # [..., P, K]
    inside = q <= config.sigma_cutoff**2
    qs = jnp.where(inside, q, 0.0)
    alpha = jnp.minimum(config.alpha_max, opacities[..., None, :] * jnp.exp(-0.5 * qs))
    return jnp.where(inside & (alpha >= config.alpha_min), alpha, 0.0)


def _composite(px, means2d, conics, opacities, colours, config: RenderConfig, n_used=None, probe=None):
    """Front-to-back compositing of K depth-ordered Gaussians at P pixels, chunk by chunk.

    Parameters: px (..., P, 2); means2d (..., K, 2); conics (..., K, 3); opacities (..., K); colours
    (..., K, k); n_used (...) or None; probe (..., K, 2) or None (see :func:`_alpha`); the leading
    axes (a batch of tiles) share one scan over the chunks. K must be a multiple of ``config.chunk``.
    Returns colour (..., P, k) and transmittance (..., P). ``C = Σ_i c_i α_i Π_{j<i} (1 − α_j)``
    (Kerbl et al. 2023, eq. 3), products kept as sums of logs. A chunk is skipped when every pixel of
    the batch is saturated or every tile is past its last Gaussian.
    """
    *lead, K, N = colours.shape
    ch = config.chunk

    def chunks(x):  # [..., K, *rest] -> [K // ch, ..., ch, *rest]
        return jnp.moveaxis(x.reshape(*lead, K // ch, ch, *x.shape[len(lead) + 1 :]), len(lead), 0)

    xs = (chunks(means2d), chunks(conics), chunks(opacities), chunks(colours))
    if probe is not None:
        xs = (*xs, chunks(probe))
    log_tmin = float(np.log(config.transmittance_min)) if config.transmittance_min > 0 else -np.inf
    last = None if n_used is None else jnp.max(n_used)

    def blend(carry, g):
        logT, C = carry
        alpha = _alpha(px, g[0], g[1], g[2], config, probe=g[4] if len(g) > 4 else None)  # [..., P, ch]
        if config.transmittance_min > 0:  # saturated pixels stop (per chunk), as 3DGS does
            alpha = jnp.where((logT > log_tmin)[..., None], alpha, 0.0)
        l1m = jnp.log1p(-alpha)
        cum = jnp.cumsum(l1m, axis=-1)
        w = alpha * jnp.exp(logT[..., None] + cum - l1m)
        return logT + cum[..., -1], C + w @ g[3]

    @jax.checkpoint
    def step(carry, g):
        if n_used is None and config.transmittance_min <= 0:
            return blend(carry, g[1:]), None
        # a real branch under scan and lax.map (one predicate for the whole batch of tiles; under an
        # outer vmap it turns into a select)
        go = jnp.any(carry[0] > log_tmin)
        if last is not None:
            go = go & (g[0] * ch < last)
        return jax.lax.cond(go, blend, lambda c, _: c, carry, g[1:]), None

    P = px.shape[-2]
    init = (jnp.zeros((*lead, P), colours.dtype), jnp.zeros((*lead, P, N), colours.dtype))
    (logT, C), _ = jax.lax.scan(step, init, (jnp.arange(K // ch), *xs))
    return C, jnp.exp(logT)


def _pad(x, n, value=0.0):
    pad = [(0, n - x.shape[0])] + [(0, 0)] * (x.ndim - 1)
    return jnp.pad(x, pad, constant_values=value)


def _sorted(pj: Projected, probe=None) -> tuple[Projected, jax.Array | None]:
    order = jnp.argsort(jnp.where(pj.valid, pj.depths, jnp.inf))
    return Projected(*(x[order] for x in pj)), None if probe is None else probe[order]


@partial(jax.jit, static_argnames=("config",))
def render_reference(
    gaussians: Gaussians,
    camera: Camera,
    *,
    config: RenderConfig = RenderConfig(),
    mask: jax.Array | None = None,
    absgrad_probe: jax.Array | None = None,
) -> RenderOutput:
    """Exact reference back-end: all Gaussians at every pixel (slow twin of :func:`render_tiled`).

    Same parameters and result as :func:`render`.
    """
    pj, probe = _sorted(project(gaussians, camera, config=config, mask=mask), absgrad_probe)
    H, W = camera.height, camera.width
    G = gaussians.n
    K = -(-G // config.chunk) * config.chunk
    yy, xx = jnp.meshgrid(jnp.arange(H), jnp.arange(W), indexing="ij")
    px = jnp.stack([xx, yy], -1).reshape(-1, 2).astype(pj.means2d.dtype) + 0.5
    C, T = _composite(
        px,
        _pad(pj.means2d, K, -1e6),
        _pad(pj.conics, K),
        _pad(pj.opacities, K),
        _pad(pj.colours, K),
        config,
        probe=None if probe is None else _pad(probe, K),
    )
    image = (C + config.background * T[:, None]).reshape(H, W, -1)
    n_valid = jnp.sum(pj.valid)
    return RenderOutput(image, (1 - T).reshape(H, W), jnp.zeros((), jnp.int32), n_valid.astype(jnp.int32))


@partial(jax.jit, static_argnames=("config",))
def render_tiled(
    gaussians: Gaussians,
    camera: Camera,
    *,
    config: RenderConfig = RenderConfig(),
    mask: jax.Array | None = None,
    absgrad_probe: jax.Array | None = None,
) -> RenderOutput:
    """Tiled back-end with a static per-tile capacity that counts what it drops.

    Same parameters and result as :func:`render`.
    """
    pj, probe = _sorted(project(gaussians, camera, config=config, mask=mask), absgrad_probe)
    H, W, s = camera.height, camera.width, config.tile_size
    ny, nx = -(-H // s), -(-W // s)
    G = gaussians.n
    K = min(config.tile_capacity, G)
    K = -(-K // config.chunk) * config.chunk
    # tile bounds in pixel-centre coordinates
    ty, tx = jnp.meshgrid(jnp.arange(ny), jnp.arange(nx), indexing="ij")
    x0 = (tx.reshape(-1) * s + 0.5)[:, None]
    y0 = (ty.reshape(-1) * s + 0.5)[:, None]
    mx, my = pj.means2d[None, :, 0], pj.means2d[None, :, 1]
    ex, ey = pj.extents[None, :, 0], pj.extents[None, :, 1]
    hits = (
        pj.valid[None, :]
        & (mx + ex >= x0)
        & (mx - ex <= x0 + s - 1)
        & (my + ey >= y0)
        & (my - ey <= y0 + s - 1)
    )  # [n_tiles, G]
    # the first K hits of each tile, in depth order: the j-th is where the running count of hits first
    # reaches j + 1 (a binary search per slot; a top_k over [n_tiles, G] sorts on a GPU)
    cum = jnp.cumsum(hits, axis=1, dtype=jnp.int32)  # [n_tiles, G]
    counts = cum[:, -1]
    slots = jnp.arange(1, K + 1, dtype=jnp.int32)
    idx = jnp.minimum(jax.vmap(lambda c: jnp.searchsorted(c, slots, side="left"))(cum), G - 1)
    keep = slots[None, :] <= counts[:, None]  # [n_tiles, K]
    means2d = jnp.where(keep[..., None], pj.means2d[idx], -1e6)
    opac = jnp.where(keep, pj.opacities[idx], 0.0)
    conics, colours = pj.conics[idx], pj.colours[idx]
    tiled = [means2d, conics, opac, colours] + ([] if probe is None else [probe[idx]])
    # pixel centres of each tile
    oy, ox = jnp.meshgrid(jnp.arange(s), jnp.arange(s), indexing="ij")
    off = jnp.stack([ox, oy], -1).reshape(-1, 2).astype(means2d.dtype)
    px = off[None] + jnp.stack([x0[:, 0], y0[:, 0]], -1)[:, None, :]  # [n_tiles, s*s, 2]
    used = jnp.minimum(counts, K)
    batch = config.tile_batch
    if batch is None:  # a GPU runs one vectorised scan far faster; the CPU skips chunks tile by tile
        batch = 1 if jax.default_backend() == "cpu" else 0
    n = px.shape[0]
    batch = n if batch == 0 else min(batch, n)
    nb = -(-n // batch)  # batches of tiles, composited together; the last padded with empty tiles
    xs = tuple(_pad(x, nb * batch).reshape(nb, batch, *x.shape[1:]) for x in (px, used, *tiled))
    C, T = jax.lax.map(
        lambda a: _composite(a[0], *a[2:6], config, n_used=a[1], probe=a[6] if len(a) > 6 else None), xs
    )
    C, T = (
        C.reshape(nb * batch, *C.shape[2:])[:n],
        T.reshape(nb * batch, -1)[:n],
    )  # [n_tiles, s*s, k], [n_tiles, s*s]
    C = C + config.background * T[..., None]

    def untile(x):
        x = x.reshape(ny, nx, s, s, *x.shape[2:])
        x = jnp.swapaxes(x, 1, 2).reshape(ny * s, nx * s, *x.shape[4:])
        return x[:H, :W]

    n_dropped = jnp.sum(jnp.maximum(counts - config.tile_capacity, 0)).astype(jnp.int32)
    return RenderOutput(untile(C), untile(1 - T), n_dropped, jnp.max(counts).astype(jnp.int32))


# ------------------------------------------------------------------------------------------------
# "cpu": numba compositing with a hand-written backward pass (gsplat's split of the work)
# ------------------------------------------------------------------------------------------------
# numba's default (workqueue) threading layer runs one parallel kernel at a time
_KERNEL_LOCK = threading.Lock()


def _host_bins(means2d, aux, H, W, s):
    """Contiguous extents and the tile lists of :func:`splat._raster_kernel.bin_tiles`."""
    from . import _raster_kernel as kern

    extents = np.ascontiguousarray(aux[:, :2])
    valid = aux[:, 3] > 0
    order = np.argsort(np.where(valid, aux[:, 2], np.inf), kind="stable")  # as jnp.argsort (stable)
    return (extents, *kern.bin_tiles(means2d, extents, order, int(valid.sum()), H, W, s))


def _cutoffs(config: RenderConfig) -> tuple:
    """``(cut², alpha_min, alpha_max)`` as the kernels take them (float32, as the JAX back-ends)."""
    return tuple(np.float32(v) for v in (config.sigma_cutoff**2, config.alpha_min, config.alpha_max))


def _as(dtype, *xs):
    """The callback's operands as contiguous arrays of the traced ``dtype``; refuses operands that JAX
    narrowed on the way (float64 traced under ``with jax.enable_x64():``, whose setting is per thread,
    arrives as float32 when the callback runs on another thread: digits would be lost silently)."""
    for x in xs:
        if np.asarray(x).dtype.itemsize < np.dtype(dtype).itemsize:
            raise SplatError(
                f"the 'cpu' render back-end received {np.asarray(x).dtype} operands for a {dtype} render: "
                "the `jax.enable_x64` context manager does not reach JAX's callback thread; turn float64 "
                "on globally (jax.config.update('jax_enable_x64', True)) or use method='tiled'."
            )
    return [np.ascontiguousarray(x, dtype=dtype) for x in xs]


def _host_forward(means2d, conics, opac, colours, aux, *, H, W, config, dtype):
    from . import _raster_kernel as kern

    means2d, conics, opac, colours, aux = _as(dtype, means2d, conics, opac, colours, aux)
    s = config.tile_size
    with _KERNEL_LOCK:
        extents, offsets, ids, max_per_tile = _host_bins(means2d, aux, H, W, s)
        tmin = np.float32(config.transmittance_min)
        gaussians = (means2d, conics, opac, colours, extents)
        C, T, n_done = kern.forward(*gaussians, offsets, ids, H, W, s, *_cutoffs(config), tmin, config.chunk)
    return C, T, n_done, np.int32(max_per_tile)


def _host_backward(means2d, conics, opac, colours, aux, T, n_done, gC, gT, *, H, W, config, dtype, absgrad):
    from . import _raster_kernel as kern

    arrays = _as(dtype, means2d, conics, opac, colours, aux, T, gC, gT)
    means2d, conics, opac, colours, aux, T, gC, gT = arrays
    n_done = np.ascontiguousarray(n_done)
    s = config.tile_size
    with _KERNEL_LOCK:
        extents, offsets, ids, _ = _host_bins(means2d, aux, H, W, s)
        gaussians = (means2d, conics, opac, colours, extents)
        d = kern.backward(*gaussians, offsets, ids, T, n_done, gC, gT, H, W, s, *_cutoffs(config), absgrad)
    k = colours.shape[1]
    probe = d[:, 6 + k :] if absgrad else np.zeros((len(d), 2))
    return tuple(x.astype(dtype) for x in (d[:, 0:2], d[:, 2:5], d[:, 5], d[:, 6 : 6 + k], probe))


@partial(jax.custom_vjp, nondiff_argnums=(0, 1, 2, 3))
def _rasterize(H, W, config, absgrad, means2d, conics, opac, colours, probe, aux):
    """Composite on the host; ``probe`` (G, 2) is not used, its gradient is the absolute one of the
    centres when ``absgrad`` (else zero)."""
    return _rasterize_fwd(H, W, config, absgrad, means2d, conics, opac, colours, probe, aux)[0]


def _rasterize_fwd(H, W, config, absgrad, means2d, conics, opac, colours, probe, aux):
    k, dtype = colours.shape[1], colours.dtype
    shapes = (
        jax.ShapeDtypeStruct((H, W, k), dtype),
        jax.ShapeDtypeStruct((H, W), dtype),
        jax.ShapeDtypeStruct((H, W), jnp.int32),
        jax.ShapeDtypeStruct((), jnp.int32),
    )
    C, T, n_done, max_per_tile = jax.pure_callback(
        partial(_host_forward, H=H, W=W, config=config, dtype=np.dtype(dtype)),
        shapes,
        means2d,
        conics,
        opac,
        colours,
        aux,
        vmap_method="sequential",
    )
    return (C, T, max_per_tile), (means2d, conics, opac, colours, aux, T, n_done)


def _rasterize_bwd(H, W, config, absgrad, res, cotangents):
    gC, gT, _ = cotangents
    means2d, conics, opac, colours, aux, T, n_done = res
    shapes = tuple(
        jax.ShapeDtypeStruct(x.shape, colours.dtype) for x in (means2d, conics, opac, colours, means2d)
    )
    grads = jax.pure_callback(
        partial(_host_backward, H=H, W=W, config=config, dtype=np.dtype(colours.dtype), absgrad=absgrad),
        shapes,
        means2d,
        conics,
        opac,
        colours,
        aux,
        T,
        n_done,
        gC,
        gT,
        vmap_method="sequential",
    )
    return (*grads, jnp.zeros_like(aux))


_rasterize.defvjp(_rasterize_fwd, _rasterize_bwd)


@partial(jax.jit, static_argnames=("config",))
def render_cpu(
    gaussians: Gaussians,
    camera: Camera,
    *,
    config: RenderConfig = RenderConfig(),
    mask: jax.Array | None = None,
    absgrad_probe: jax.Array | None = None,
) -> RenderOutput:
    """CPU back-end: the tiled back-end's tiles and termination, no capacity, numba kernels.

    Same parameters and result as :func:`render`; ``n_dropped`` is always 0 (``tile_capacity`` is not
    used). The projection is JAX's (so gradients reach poses and 3-D parameters as in the other
    back-ends); compositing and its exact backward pass run on the host (:mod:`splat._raster_kernel`).
    """
    pj = project(gaussians, camera, config=config, mask=mask)
    aux = jax.lax.stop_gradient(
        jnp.concatenate([pj.extents, pj.depths[:, None], pj.valid[:, None].astype(pj.extents.dtype)], -1)
    )
    absgrad = absgrad_probe is not None
    probe = absgrad_probe if absgrad else jnp.zeros_like(pj.means2d)
    C, T, max_per_tile = _rasterize(
        camera.height,
        camera.width,
        config,
        absgrad,
        pj.means2d,
        pj.conics,
        pj.opacities,
        pj.colours,
        probe,
        aux,
    )
    image = C + config.background * T[..., None]
    return RenderOutput(image, 1 - T, jnp.zeros((), jnp.int32), max_per_tile)


def default_method() -> str:
    """The back-end ``method="auto"`` picks: ``"cpu"`` when JAX computes on the CPU, else ``"tiled"``."""
    return "cpu" if jax.default_backend() == "cpu" else "tiled"


#: Rendering back-ends by name (``render(..., method=name)``); ``"reference"`` is the dense
#: reference twin of the tiled renderer.
RENDER_METHODS: MethodRegistry = MethodRegistry("render", error=SplatMethodError)
RENDER_METHODS.register("tiled", render_tiled, reference_twin="reference")
RENDER_METHODS.register("reference", render_reference, reference_twin=None)
RENDER_METHODS.register("cpu", render_cpu, reference_twin="tiled")


def render(
    gaussians: Gaussians,
    camera: Camera,
    *,
    method: str = "auto",
    config: RenderConfig = RenderConfig(),
    mask: jax.Array | None = None,
    absgrad_probe: jax.Array | None = None,
) -> RenderOutput:
    """Render an (H, W, k) image of N-channel Gaussians from one camera (differentiable).

    Parameters
    ----------
    gaussians : Gaussians
        G Gaussians with k channels.
    camera : Camera
        The view (its ``width`` and ``height`` are static: a new size compiles anew).
    method : {"auto", "cpu", "tiled", "reference"}
        Back-end, see :data:`RENDER_METHODS`; ``"auto"`` is :func:`default_method` (``"cpu"`` when JAX
        computes on the CPU, ``"tiled"`` on a GPU).
    config : RenderConfig
        Projection, cut-off and tiling options.
    mask : array_like of bool, shape (G,), optional
        Gaussians to render; the others are ignored (zero gradient).
    absgrad_probe : Array of shape (G, 2), optional
        Zeros (their value is not used and the image does not depend on them) whose gradient is, per
        Gaussian and axis, the sum over pixels of the absolute gradient of each pixel's loss with
        respect to the centre's pixel position, ``Σ_p |∂L_p/∂μ₂ᴅ|`` — AbsGS' densification statistic
        (Ye et al. 2024), which, unlike ``∂L/∂μ₂ᴅ = Σ_p ∂L_p/∂μ₂ᴅ``, does not cancel where a large
        Gaussian covers texture that pulls its centre both ways. Supported by the built-in back-ends.

    Returns
    -------
    RenderOutput
        ``image`` (H, W, k), ``alpha`` (H, W), ``n_dropped`` and ``max_per_tile``.

    Raises
    ------
    SplatMethodError
        Unknown ``method`` (a :class:`SplatError`; the message lists the valid ones).

    Examples
    --------
    >>> import jax.numpy as jnp
    >>> from splat import init_gaussians, look_at, render
    >>> g = init_gaussians(jnp.zeros((1, 3)), jnp.ones((1, 5)), scales=0.1, opacity=0.5)
    >>> cam = look_at((0, -3, 0), (0, 0, 0), width=16, height=16)
    >>> out = render(g, cam)
    >>> out.image.shape, int(out.n_dropped)
    ((16, 16, 5), 0)
    """
    if isinstance(method, str) and method.lower() == "auto":
        method = default_method()
    fn = RENDER_METHODS[method]
    if absgrad_probe is None:  # back-ends registered by users need not know the probe
        return fn(gaussians, camera, config=config, mask=mask)
    return fn(gaussians, camera, config=config, mask=mask, absgrad_probe=absgrad_probe)
