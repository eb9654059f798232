"""Training N-channel Gaussians on RAW views: RawNeRF loss, Adam with decaying rates, densify/prune
inside a fixed-capacity buffer (static shapes), checkpoints, resume. The library prints nothing:
progress goes through ``train(..., callback=)``; the command lines and benchmarks draw the bars.

References
----------
Mildenhall, B. et al. (2022). NeRF in the Dark: High Dynamic Range View Synthesis from Noisy Raw
Images. CVPR. Eq. (9); the clipped form follows multinerf's ``internal/train_utils.py``.
Kerbl, B. et al. (2023). 3D Gaussian Splatting. ACM TOG 42(4). Sec. 5.2 (adaptive density control).
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace
from functools import partial
from pathlib import Path
from typing import NamedTuple

import jax
import jax.numpy as jnp
import numpy as np
import optax

from ._errors import SplatError
from .camera import Camera, pose_corrected
from .data import Capture
from .gaussians import Gaussians, depth_colour_params, init_gaussians
from .rendering import RenderConfig, render

__all__ = [
    "TrainConfig",
    "TrainResult",
    "TrainState",
    "init_state",
    "load_checkpoint",
    "rawnerf_loss",
    "read_arrays",
    "save_checkpoint",
    "stack_cameras",
    "train",
    "train_step",
]

_FIELDS = ("means", "quats", "log_scales", "opacity_logits", "colour_params")


def rawnerf_loss(pred: jax.Array, target: jax.Array, weight: jax.Array, *, offset: float = 1e-3) -> jax.Array:
    """RawNeRF's relative L2 on clipped predictions, weighted per pixel and channel.

    ``Σ w ((min(ŷ, 1) − y) / (sg(min(ŷ, 1)) + offset))² / Σ w`` with ``sg`` the stop-gradient
    (Mildenhall et al. 2022, eq. 9; clipping as in multinerf).

    Parameters
    ----------
    pred, target, weight : array_like of shape (..., k)
        Prediction ŷ, RAW measurement y, and weight (e.g. the Bayer mask × the channels measured).
    offset
        RawNeRF's ε in the denominator (white = 1 units): errors in the darkest tones (below ~1e-3
        of the white) are weighted as absolute, not relative, errors.

    Returns
    -------
    Array of shape ()
    """
    clipped = jnp.minimum(pred, 1.0)
    scale = 1.0 / (jax.lax.stop_gradient(clipped) + offset)
    return jnp.sum(weight * ((clipped - target) * scale) ** 2) / jnp.maximum(jnp.sum(weight), 1e-12)


@dataclass(frozen=True)
class TrainConfig:
    """Options of :func:`train` (learning rates are initial values; all decay exponentially).

    Attributes
    ----------
    steps : int
    lr_means : float
        Learning rate of the centres, as a fraction of the scene extent.
    lr_log_scales : float
        Learning rate of the log-scales. Larger than 3DGS's 5e-3 because split copies and
        COLMAP-initialised Gaussians start away from their final size
        (:doc:`/notes/2026-11-28-scale-learning-rate`).
    lr_quats, lr_opacity, lr_colours : float
    lr_final : float
        Final / initial learning rate (the exponential decay over ``steps``; it also sets the decay of
        the exposure and pose corrections). 0.3: a faster decay stops fitting the training views too
        early (:doc:`/notes/2026-11-24-training-learning-rates`).
    lr_means_final : float or None
        Final / initial learning rate of the centres alone (None: ``lr_final``). 0.03: centres still
        moving at the end of a run jitter around their place and blur the texture
        (:doc:`/notes/2026-11-27-centre-rate-and-recycling`).
    capacity : int
        Size of the Gaussian buffer (static); densification fills free slots up to it.
    densify_every, densify_from, densify_until : int
        Densify and prune every ``densify_every`` steps within ``[densify_from, densify_until)``.
    densify_fraction : float
        At each densification, the fraction of alive Gaussians with the largest mean positional
        gradient that are split (large ones) or cloned (small ones), limited by the free slots.
    split_scale : float
        Gaussians larger than this fraction of the extent are split, smaller ones cloned.
    prune_opacity : float
        Alive Gaussians below this opacity are freed.
    recycle_opacity : float
        When the buffer is full, a densification also frees the faintest alive Gaussians below this
        opacity (as many as it would add) for the split/clone copies (0: never), so that a full buffer
        still moves capacity to where the error is (:doc:`/notes/2026-11-27-centre-rate-and-recycling`).
    loss_offset : float
        The ε of :func:`rawnerf_loss` (raw units, saturation = 1): errors are weighted by
        ``1 / (sg(ŷ) + ε)²``, relative where the signal is well above ε. 1e-3 (RawNeRF's value) spends
        the fit evenly in relative error, which colour (ΔE00) follows; a larger ε raises a peak-1 PSNR
        at the cost of dark pixels' colour (:doc:`/notes/2026-11-28-training-options`).
    densify_gradient : {"world", "screen", "absolute"}
        The positional gradient that ranks Gaussians for densification: ``"screen"`` (default) the norm
        of ∂L/∂(the centre's pixel position), as 3DGS ranks them, so that a Gaussian twice as far,
        covering the same pixels, ranks the same; ``"world"`` the norm of ∂L/∂(3-D centre);
        ``"absolute"`` (AbsGS, Ye et al. 2024) the norm of ``Σ_p |∂L_p/∂μ₂ᴅ|`` (``render``'s
        ``absgrad_probe``), which ranks a large Gaussian over texture high where the signed sum cancels
        (:doc:`/notes/2026-11-27-screen-space-densification`).
    flatten_weight : float
        λ of a flatness penalty added to the loss: ``λ · mean over alive Gaussians of min(scales) /
        extent`` (the loss reported is still the data term); it makes the third axis of surface
        Gaussians as thin as the views allow. 0 (off) by default
        (:doc:`/notes/2026-11-28-scale-learning-rate`).
    depth_weight : float
        λ of a sparse depth term added to the loss (0 turns it off; it acts only where ``train(...,
        depth=)`` gives targets, e.g. :func:`splat.capture.depth_targets`): ``λ · Σ_p |Σ_i w_i z_i − A_p
        z*_p| / z*_p / (H W)``, summed over the pixels ``p`` where the view observes a COLMAP point, with
        ``w_i`` the compositing weights, ``z_i`` the Gaussians' depths, ``A_p = Σ_i w_i`` and ``z*_p`` the
        point's depth (relative L1, robust to the odd wrong point), divided by the image's pixel count so
        that each observed point weighs like one pixel of the data term. Why: where few views see a
        region, a faint layer in front of the surface explains them as well as the surface; the term
        pulls it onto the points. Costs one more rendered channel (:doc:`/notes/2026-11-28-depth-term`).
    method : str
        Render back-end during training (``"auto"``: ``"cpu"`` when JAX computes on the CPU, ``"tiled"``
        on a GPU; :func:`splat.rendering.default_method`).
    render : RenderConfig
    checkpoint : path or None
        Where to save a checkpoint (``.npz``) every ``checkpoint_every`` steps and at the end.
    checkpoint_every : int
    seed : int
    init_scale : {"knn", "uniform"}
        Initial size of Gaussians placed at given points: ``"knn"`` (default) the RMS distance to each
        point's 3 nearest neighbours, as 3DGS does (clipped to at most the uniform size); ``"uniform"``
        one size for all, ``0.5 · extent / n^(1/3)``. Random initial centres always get the uniform size.
        With "uniform", COLMAP-initialised Gaussians start so large that nearly all of them overlap every
        16-pixel tile, which makes each step several times slower and fills the tiles' capacity.
    refine_exposure : bool
        Learn a log-exposure correction per view (initialised at 0, i.e. the EXIF exposure), with the
        first view of each camera id in ``reference_views`` held fixed (see :func:`train`).
    lr_exposure : float
        Learning rate of the log-exposure corrections.
    refine_poses : bool
        Learn a rigid correction of each view's pose (axis-angle rotation and translation, initialised
        at 0, applied in camera coordinates by :func:`splat.camera.pose_corrected`), jointly with the
        Gaussians by the same loss, with two reference views held fixed (see :func:`train`).
    lr_pose_rot : float
        Learning rate of the rotation corrections, in radians.
    lr_pose_trans : float
        Learning rate of the translation corrections, as a fraction of the scene extent (the diagonal of
        ``bounds``). Small (2e-5) because a larger rate moves well-registered centres further than their
        error and worsens the colour (:doc:`/notes/2026-11-24-exposure-and-pose-refinement`).
    """

    steps: int = 3000
    lr_means: float = 1e-3
    lr_log_scales: float = 2e-2
    lr_quats: float = 5e-3
    lr_opacity: float = 5e-2
    lr_colours: float = 1e-2
    lr_final: float = 0.3
    lr_means_final: float | None = 0.03
    capacity: int = 1024
    densify_every: int = 100
    densify_from: int = 200
    densify_until: int = 2000
    densify_fraction: float = 0.05
    split_scale: float = 0.02
    prune_opacity: float = 0.005
    recycle_opacity: float = 0.05
    loss_offset: float = 1e-3
    densify_gradient: str = "screen"
    flatten_weight: float = 0.0
    depth_weight: float = 13.0
    method: str = "auto"
    render: RenderConfig = field(default_factory=RenderConfig)
    checkpoint: str | Path | None = None
    checkpoint_every: int = 500
    seed: int = 0
    init_scale: str = "knn"
    refine_exposure: bool = False
    lr_exposure: float = 1e-2
    refine_poses: bool = False
    lr_pose_rot: float = 2e-4
    lr_pose_trans: float = 2e-5

    def __post_init__(self):
        if self.init_scale not in ("knn", "uniform"):
            raise SplatError(f"TrainConfig.init_scale={self.init_scale!r}: choose 'knn' or 'uniform'.")
        for name in ("lr_pose_rot", "lr_pose_trans"):
            v = getattr(self, name)
            if not isinstance(v, int | float) or not np.isfinite(v) or v < 0:
                raise SplatError(f"TrainConfig.{name}={v!r}: must be a finite number ≥ 0 (0 keeps it fixed).")
        f = self.lr_means_final
        if f is not None and (not isinstance(f, int | float) or not 0 < f <= 1):
            raise SplatError(
                f"TrainConfig.lr_means_final={f!r}: must lie in (0, 1] (the final / initial centre rate), "
                "or None to use lr_final."
            )
        o = self.loss_offset
        if not isinstance(o, int | float) or not np.isfinite(o) or o <= 0:
            raise SplatError(
                f"TrainConfig.loss_offset={o!r}: must be a finite number > 0 (rawnerf_loss's ε)."
            )
        if self.densify_gradient not in ("world", "screen", "absolute"):
            raise SplatError(
                f"TrainConfig.densify_gradient={self.densify_gradient!r}: choose 'world', 'screen' or "
                "'absolute'."
            )
        for name in ("flatten_weight", "depth_weight"):
            w = getattr(self, name)
            if not isinstance(w, int | float) or not np.isfinite(w) or w < 0:
                raise SplatError(f"TrainConfig.{name}={w!r}: must be a finite number ≥ 0 (0 turns it off).")
        r = self.recycle_opacity
        if not isinstance(r, int | float) or not 0 <= r < 1:
            raise SplatError(f"TrainConfig.recycle_opacity={r!r}: must lie in [0, 1) (0 never recycles).")


class TrainState(NamedTuple):
    """Everything :func:`train` needs to resume: parameters, optimiser state, buffer mask, statistics."""

    params: Gaussians
    opt_state: optax.OptState
    alive: jax.Array  # [G] bool
    grad_accum: jax.Array  # [G] summed |∂L/∂means|
    grad_count: jax.Array  # [G] steps each Gaussian was visible
    step: int
    key: jax.Array
    log_exposure: jax.Array | None = None  # [V] learned log-exposure corrections (refine_exposure)
    exposure_opt: optax.OptState | None = None
    pose_delta: jax.Array | None = None  # [V, 6] learned pose corrections (ω, τ) (refine_poses)
    pose_opt: optax.OptState | None = None


class TrainResult(NamedTuple):
    """Trained ``gaussians``, their ``alive`` mask (G,), the final ``state``, a ``history`` dict of
    per-step ``loss``, ``n_alive`` and ``n_dropped`` arrays, and ``exposure_factors`` (V,): each view's
    learned exposure correction (the view's exposure is ``EXIF × factor``; all 1 without
    ``refine_exposure``), and ``pose_corrections`` (V, 6): each view's learned pose correction ``(ω, τ)``
    (the view's camera is ``pose_corrected(camera, pose_corrections[v])``; all 0 without ``refine_poses``),
    and ``pose_reference_views``: the views whose poses were held fixed (empty without ``refine_poses``)."""

    gaussians: Gaussians
    alive: np.ndarray
    state: TrainState
    history: dict[str, np.ndarray]
    exposure_factors: np.ndarray | None = None
    pose_corrections: np.ndarray | None = None
    pose_reference_views: tuple[int, ...] = ()


def stack_cameras(cameras) -> Camera:
    """Stack cameras of one image size into one Camera with a leading view axis (for jit/vmap)."""
    cameras = list(cameras)
    if len({(c.width, c.height) for c in cameras}) != 1:
        raise SplatError(
            "all views must share one image size to be trained together; got "
            f"{sorted({(c.width, c.height) for c in cameras})}."
        )
    return jax.tree.map(lambda *x: jnp.stack(x), *cameras)


def _exposure_optimiser(config: TrainConfig) -> optax.GradientTransformation:
    return optax.adam(optax.exponential_decay(config.lr_exposure, config.steps, config.lr_final), eps=1e-15)


def _pose_optimiser(config: TrainConfig, extent: float) -> optax.GradientTransformation:
    """Adam on the (V, 6) pose corrections: radians for ω, ``lr_pose_trans · extent`` for τ."""
    rates = np.array([config.lr_pose_rot] * 3 + [config.lr_pose_trans * extent] * 3, np.float32)
    return optax.chain(
        optax.scale_by_adam(eps=1e-15),
        optax.scale_by_learning_rate(optax.exponential_decay(1.0, config.steps, config.lr_final)),
        optax.stateless(lambda updates, params=None: jax.tree.map(lambda u: u * rates, updates)),
    )


def _optimiser(config: TrainConfig, extent: float) -> optax.GradientTransformation:
    def adam(lr, final):
        return optax.adam(optax.exponential_decay(lr, config.steps, final), eps=1e-15)

    rates = (
        config.lr_means * extent,
        config.lr_quats,
        config.lr_log_scales,
        config.lr_opacity,
        config.lr_colours,
    )
    means_final = config.lr_final if config.lr_means_final is None else config.lr_means_final
    finals = (means_final,) + (config.lr_final,) * 4
    labels = Gaussians(*_FIELDS)
    return optax.multi_transform({k: adam(r, f) for k, r, f in zip(_FIELDS, rates, finals)}, labels)


def init_state(
    config: TrainConfig,
    *,
    bounds,
    n_channels: int,
    points=None,
    colours=None,
    n_init: int | None = None,
    n_views: int | None = None,
) -> TrainState:
    """A fresh training state: ``n_init`` Gaussians alive in a buffer of ``config.capacity``.

    Parameters
    ----------
    config : TrainConfig
    bounds : array_like of shape (2, 3)
        Box around the scene; random initial centres are drawn in it (unless ``points`` is given).
    n_channels : int
    points : array_like of shape (P, 3), optional
        Initial centres (e.g. COLMAP points3D); the first ``capacity`` are used.
    colours : array_like of shape (P, k), optional
        Initial colours (default 0.2 in every channel).
    n_init : int, optional
        Initially alive Gaussians (default: half the capacity, or all the points).
    n_views : int, optional
        Number of views; needed with ``config.refine_exposure`` or ``config.refine_poses`` (their
        log-exposure and pose corrections start at 0).
    """
    G = config.capacity
    bounds = np.asarray(bounds, float)
    rng = np.random.default_rng(config.seed)
    given = points is not None
    if points is None:
        n_init = n_init or G // 2
        points = rng.uniform(bounds[0], bounds[1], (n_init, 3))
    points = np.asarray(points, float)[:G]
    n_init = len(points)
    extent = float(np.linalg.norm(bounds[1] - bounds[0]))
    full = rng.uniform(bounds[0], bounds[1], (G, 3))
    full[:n_init] = points
    col = np.full((G, n_channels), 0.2)
    if colours is not None:
        col[:n_init] = np.asarray(colours)[:n_init]
    scale = np.full(G, 0.5 * extent / max(n_init, 1) ** (1 / 3))
    if given and config.init_scale == "knn" and n_init >= 4:
        from scipy.spatial import cKDTree

        d, _ = cKDTree(points).query(points, k=4)  # itself and its 3 nearest neighbours
        knn = np.sqrt(np.mean(d[:, 1:] ** 2, axis=1))
        scale[:n_init] = np.clip(knn, 1e-4 * extent, scale[0])
    params = init_gaussians(full, col, scales=scale, opacity=0.1, key=jax.random.key(config.seed))
    alive = jnp.arange(G) < n_init
    opt = _optimiser(config, extent)
    log_e = exp_opt = pose = pose_opt = None
    for flag in ("refine_exposure", "refine_poses"):
        if getattr(config, flag) and (not isinstance(n_views, int | np.integer) or n_views < 1):
            raise SplatError(f"n_views={n_views!r}: {flag} needs the number of views (≥ 1).")
    if config.refine_exposure:
        log_e = jnp.zeros(int(n_views))
        exp_opt = _exposure_optimiser(config).init(log_e)
    if config.refine_poses:
        pose = jnp.zeros((int(n_views), 6))
        pose_opt = _pose_optimiser(config, extent).init(pose)
    return TrainState(
        params,
        opt.init(params),
        alive,
        jnp.zeros(G),
        jnp.zeros(G),
        0,
        jax.random.key(config.seed + 1),
        log_e,
        exp_opt,
        pose,
        pose_opt,
    )


@partial(jax.jit, static_argnames=("config", "extent"))
def train_step(
    state: TrainState,
    camera: Camera,
    image,
    weight,
    channel_mask,
    exposure,
    *,
    config: TrainConfig,
    extent: float,
    view=None,
    exposure_mask=None,
    pose_mask=None,
    depth=None,
):
    """One Adam step on one view; returns the new state (step not incremented), loss and drops.

    Parameters
    ----------
    state : TrainState
    camera : Camera
    image, weight : Array of shape (H, W, k)
        Measurement and its weight (zero on channels and pixels not measured).
    channel_mask : Array of shape (k,)
        Channels this view measures (the loss ignores the rest).
    exposure : Array of shape ()
        The view's exposure (EXIF, relative).
    view : Array of shape () int, optional
        The view's index into ``state.log_exposure`` (needed when the state refines exposures: the
        exposure used is ``exposure · exp(log_exposure[view])``).
    exposure_mask : Array of shape (V,), optional
        1 for views whose log-exposure may change, 0 for the fixed reference views.
    pose_mask : Array of shape (V,), optional
        1 for views whose pose may change, 0 for the fixed reference views (with ``state.pose_delta``:
        the camera rendered is ``pose_corrected(camera, pose_delta[view])``).
    depth : tuple of Arrays of shape (D,), optional
        ``(pixel, depth, valid)``: the view's sparse depth (flat pixel index, depth along the optical
        axis, which entries are real); used when ``config.depth_weight > 0``.
    """
    refine = state.log_exposure is not None
    refine_pose = state.pose_delta is not None

    use_depth = depth is not None and config.depth_weight > 0

    def loss_fn(params, log_e, pose, probe):
        cam = pose_corrected(camera, pose[view]) if refine_pose else camera
        g = params
        if use_depth:  # one more channel holding each Gaussian's depth (in units of the extent)
            z = depth_colour_params(params, cam, near=config.render.near, scale=extent)
            g = replace(params, colour_params=jnp.concatenate([params.colour_params, z[:, None]], -1))
        out = render(
            g, cam, method=config.method, config=config.render, mask=state.alive, absgrad_probe=probe
        )
        colour = out.image[..., : params.n_channels]
        e = exposure * jnp.exp(log_e[view]) if refine else exposure
        loss = rawnerf_loss(e * colour, image, weight * channel_mask, offset=config.loss_offset)
        total = loss
        if use_depth:
            pixel, target, valid = depth
            acc = out.alpha.reshape(-1)[pixel]
            zsum = out.image[..., -1].reshape(-1)[pixel] - config.render.background * (1 - acc)
            zt = target / extent
            err = jnp.where(valid, jnp.abs(zsum - acc * zt) / zt, 0.0)
            total = total + config.depth_weight * jnp.sum(err) / (image.shape[0] * image.shape[1])
        if config.flatten_weight:
            # mean over alive Gaussians of the smallest standard deviation, in units of the scene extent
            thin = jnp.exp(jnp.min(params.log_scales, axis=-1)) / extent
            n = jnp.maximum(jnp.sum(state.alive), 1)
            total = total + config.flatten_weight * jnp.sum(jnp.where(state.alive, thin, 0.0)) / n
        return total, (out.n_dropped, loss)

    absolute = config.densify_gradient == "absolute"
    probe = jnp.zeros((state.params.n, 2), state.params.means.dtype) if absolute else None
    (_, (dropped, loss)), (grads, g_exp, g_pose, g_probe) = jax.value_and_grad(
        loss_fn, argnums=(0, 1, 2, 3), has_aux=True
    )(state.params, state.log_exposure, state.pose_delta, probe)
    updates, opt_state = _optimiser(config, extent).update(grads, state.opt_state, state.params)
    params = optax.apply_updates(state.params, updates)
    if config.densify_gradient == "screen":
        # ∂L/∂(pixel position of the centre) from the camera-frame gradient: g_px = g_cam,xy · z / f
        # (the projection's Jacobian at fixed depth; the path through the 2-D covariance is left out)
        g_cam = grads.means @ camera.R.T
        z = jnp.maximum(state.params.means @ camera.R[2] + camera.t[2], 1e-6)  # depth: the third row only
        gnorm = jnp.linalg.norm(g_cam[:, :2] * z[:, None] / camera.focal, axis=-1)
    elif absolute:  # Σ_p |∂L_p/∂μ₂ᴅ| per axis, already in pixels
        gnorm = jnp.linalg.norm(g_probe, axis=-1)
    else:
        gnorm = jnp.linalg.norm(grads.means, axis=-1)
    seen = gnorm > 0
    new = {}
    if refine:
        if exposure_mask is not None:
            g_exp = g_exp * exposure_mask
        upd, exp_opt = _exposure_optimiser(config).update(g_exp, state.exposure_opt, state.log_exposure)
        if exposure_mask is not None:
            upd = upd * exposure_mask  # the reference views stay exactly at their EXIF exposure
        new = {"log_exposure": state.log_exposure + upd, "exposure_opt": exp_opt}
    if refine_pose:
        if pose_mask is not None:
            g_pose = g_pose * pose_mask[:, None]
        upd, pose_opt = _pose_optimiser(config, extent).update(g_pose, state.pose_opt, state.pose_delta)
        if pose_mask is not None:
            upd = upd * pose_mask[:, None]  # the reference views keep their given poses exactly
        new.update(pose_delta=state.pose_delta + upd, pose_opt=pose_opt)
    return (
        state._replace(
            params=params,
            opt_state=opt_state,
            grad_accum=state.grad_accum + gnorm,
            grad_count=state.grad_count + seen,
            **new,
        ),
        loss,
        dropped,
    )


def _reset_rows(tree, rows: np.ndarray, G: int):
    rows = jnp.asarray(rows)
    return jax.tree.map(
        lambda x: x.at[rows].set(0) if getattr(x, "ndim", 0) >= 1 and x.shape[0] == G else x, tree
    )


def _densify(state: TrainState, config: TrainConfig, extent: float) -> TrainState:
    """Prune transparent Gaussians, then split/clone those with the largest positional gradient into
    free slots of the buffer (host-side; shapes never change)."""
    p = {k: np.array(getattr(state.params, k)) for k in _FIELDS}
    alive = np.array(state.alive)
    G = alive.size
    opacity = 1 / (1 + np.exp(-p["opacity_logits"]))
    alive &= opacity >= config.prune_opacity
    grad = np.array(state.grad_accum) / np.maximum(np.array(state.grad_count), 1)
    free = np.flatnonzero(~alive)
    want = int(np.ceil(config.densify_fraction * alive.sum()))
    if config.recycle_opacity > 0 and len(free) < want:
        # a full buffer: free the faintest Gaussians for new ones where the gradient is largest
        weak = np.flatnonzero(alive & (opacity < config.recycle_opacity))
        alive[weak[np.argsort(opacity[weak], kind="stable")][: want - len(free)]] = False
        free = np.flatnonzero(~alive)
    n = min(len(free), want)
    changed = [free[:n]]
    if n:
        cand = np.flatnonzero(alive)
        src = cand[np.argsort(-grad[cand])[:n]]
        src = src[grad[src] > 0]
        dst = free[: len(src)]
        rng = np.random.default_rng(config.seed + state.step)
        scales = np.exp(p["log_scales"][src])
        big = scales.max(1) > config.split_scale * extent
        for k in _FIELDS:
            p[k][dst] = p[k][src]
        # split: both halves sampled inside the parent, shrunk by 1.6 (Kerbl et al. 2023, sec. 5.2)
        from .gaussians import quat_to_rotmat

        R = np.asarray(quat_to_rotmat(p["quats"][src]))
        offs = np.einsum("gij,gj->gi", R, scales * rng.standard_normal(scales.shape))
        p["means"][dst[big]] = p["means"][src[big]] + offs[big]
        p["means"][src[big]] = p["means"][src[big]] - offs[big]
        p["log_scales"][dst[big]] -= np.log(1.6)
        p["log_scales"][src[big]] -= np.log(1.6)
        alive[dst] = True
        changed = [dst, src[big]]
    rows = np.concatenate(changed).astype(np.int64)
    params = Gaussians(**{k: jnp.asarray(v) for k, v in p.items()})
    return state._replace(
        params=params,
        opt_state=_reset_rows(state.opt_state, rows, G),
        alive=jnp.asarray(alive),
        grad_accum=jnp.zeros(G),
        grad_count=jnp.zeros(G),
    )


def save_checkpoint(state: TrainState, path: str | Path) -> Path:
    """Save a :class:`TrainState` as ``.npz`` data at exactly ``path`` (pytree order), atomically."""
    from zonotope.utilities import atomic_path

    leaves = jax.tree.leaves(
        (
            state.params,
            state.opt_state,
            state.alive,
            state.grad_accum,
            state.grad_count,
            state.log_exposure,
            state.exposure_opt,
        )
    )
    arrays = {f"leaf_{i:04d}": np.asarray(x) for i, x in enumerate(leaves)}
    # pose corrections under their own names: checkpoints written before they existed still load
    arrays.update(
        {
            f"pose_{i:04d}": np.asarray(x)
            for i, x in enumerate(jax.tree.leaves((state.pose_delta, state.pose_opt)))
        }
    )
    key = np.asarray(jax.random.key_data(state.key))

    # written to a temporary sibling, synced, then renamed: a kill mid-save leaves the previous
    # checkpoint intact (np.savez in place truncated it first)
    def write(tmp: Path) -> None:
        with open(tmp, "wb") as fh:  # a file object: np.savez appends no suffix
            np.savez(fh, step=state.step, key=key, **arrays)

    return atomic_path(Path(path), write)


def read_arrays(path: str | Path, *, what: str) -> dict[str, np.ndarray]:
    """Every array of an ``.npz`` file written by splat, or a one-line :class:`SplatError` naming the
    file (a foreign, truncated or pickled file is never loaded: object arrays are refused)."""
    import zipfile

    try:
        with np.load(path, allow_pickle=False) as f:
            if not isinstance(f, np.lib.npyio.NpzFile):
                raise TypeError("not an .npz archive")
            return {k: np.asarray(f[k]) for k in f.files}
    except (OSError, ValueError, TypeError, EOFError, KeyError, zipfile.BadZipFile) as e:
        raise SplatError(
            f"{path}: not a readable splat {what} ({type(e).__name__}); remove it or choose a new "
            "output folder."
        ) from e


def _check_values(path, arrays: dict[str, np.ndarray], dtypes: list) -> None:
    """Refuse stored arrays of another dtype than the state's (an int where floats train) or with
    NaN/inf: either would resume training on values no step of it produces."""
    for (name, a), dtype in zip(arrays.items(), dtypes):
        if a.dtype != dtype:
            raise SplatError(
                f"{path}: {name} has dtype {a.dtype} where {dtype} is expected: the file is damaged "
                "or from another program, remove it to train afresh."
            )
        if a.dtype.kind == "f" and not np.all(np.isfinite(a)):
            raise SplatError(
                f"{path}: {name} contains NaN or inf: the training it holds diverged or the file is "
                "damaged, remove it to train afresh (or resume from an earlier checkpoint)."
            )


def load_checkpoint(path: str | Path, like: TrainState) -> TrainState:
    """Load a checkpoint into the structure of ``like`` (a fresh state from :func:`init_state`).

    A checkpoint without pose corrections (written without ``refine_poses``, or before they existed)
    loads into a state that refines poses with the corrections of ``like`` (zero); one with pose
    corrections does not load into a state without them (the Gaussians were fitted to the corrected
    poses).

    Raises
    ------
    SplatError
        Not a splat checkpoint, arrays of another shape or dtype than ``like``'s, NaN or inf
        values, a step that is not a non-negative integer, or a key of another shape.
    """
    like_tree = (
        like.params,
        like.opt_state,
        like.alive,
        like.grad_accum,
        like.grad_count,
        like.log_exposure,
        like.exposure_opt,
    )
    leaves, treedef = jax.tree.flatten(like_tree)
    f = read_arrays(path, what="checkpoint")
    if "step" not in f or "key" not in f:
        raise SplatError(f"{path}: not a splat checkpoint (no step or key); remove it to train afresh.")
    stored = sorted(k for k in f if k.startswith("leaf_"))
    if len(stored) != len(leaves):
        raise SplatError(
            f"checkpoint {path} has {len(stored)} arrays; this configuration needs "
            f"{len(leaves)} (capacity, channels or refine_exposure changed?)."
        )
    for k, b in zip(stored, leaves):
        if f[k].shape != np.shape(b):
            raise SplatError(
                f"checkpoint {path} holds an array of shape {f[k].shape} where {np.shape(b)} "
                "is expected (capacity or channels changed?)."
            )
    _check_values(path, {k: f[k] for k in stored}, [np.asarray(b).dtype for b in leaves])
    new = [jnp.asarray(f[k]) for k in stored]
    step_value, key_data = f["step"], f["key"]
    if step_value.shape != () or step_value.dtype.kind not in "iu" or int(step_value) < 0:
        raise SplatError(
            f"{path}: step = {step_value.tolist()!r} ({step_value.dtype}); a checkpoint's step is a "
            "non-negative integer: the file is damaged, remove it to train afresh."
        )
    like_key = np.asarray(jax.random.key_data(like.key))
    if key_data.shape != like_key.shape or key_data.dtype != like_key.dtype:
        raise SplatError(
            f"{path}: key of shape {key_data.shape} ({key_data.dtype}) where {like_key.shape} "
            f"({like_key.dtype}) is expected: the file is damaged, remove it to train afresh."
        )
    step, key = int(step_value), jax.random.wrap_key_data(jnp.asarray(key_data))
    pose_leaves, pose_def = jax.tree.flatten((like.pose_delta, like.pose_opt))
    stored_pose = sorted(k for k in f if k.startswith("pose_"))
    if stored_pose and not pose_leaves:
        raise SplatError(
            f"checkpoint {path} holds pose corrections but this configuration does not refine poses; "
            "resume it with refine_poses=True (--refine-poses)."
        )
    if stored_pose:
        got = [jnp.asarray(f[k]) for k in stored_pose]
        if len(got) != len(pose_leaves) or any(a.shape != np.shape(b) for a, b in zip(got, pose_leaves)):
            raise SplatError(
                f"checkpoint {path} holds pose corrections for a different number of views; expected "
                f"{np.shape(like.pose_delta)}."
            )
        _check_values(path, {k: f[k] for k in stored_pose}, [np.asarray(b).dtype for b in pose_leaves])
        pose_leaves = got
    params, opt_state, alive, ga, gc, log_e, e_opt = jax.tree.unflatten(treedef, new)
    pose, pose_opt = jax.tree.unflatten(pose_def, pose_leaves)
    return TrainState(params, opt_state, alive, ga, gc, step, key, log_e, e_opt, pose, pose_opt)


def train(
    capture: Capture,
    images,
    weights,
    *,
    config: TrainConfig = TrainConfig(),
    bounds,
    points=None,
    colours=None,
    resume: str | Path | None = None,
    callback=None,
    reference_views=None,
    pose_reference_views=None,
    depth=None,
) -> TrainResult:
    """Fit N-channel Gaussians to the RAW views of a multi-camera capture.

    With ``config.refine_exposure`` each view also gets a learned log-exposure correction ``ε_v``
    (prediction ``= EXIF exposure · exp(ε_v) · render``), starting at 0. Each camera's colours are free,
    so a common factor on all views of one camera is not identifiable from the images: one reference view
    per camera id keeps ``ε = 0`` (by default the view whose EXIF exposure is the median of that camera's
    views), which ties the scale to EXIF as the white → 1 scale assumes.

    With ``config.refine_poses`` each view also gets a learned rigid correction ``ξ_v = (ω, τ)`` of its
    world-to-camera pose (:func:`splat.camera.pose_corrected`), starting at 0 and learnt by the same loss.
    Moving the whole scene and every camera by one similarity (7 degrees of freedom: rotation,
    translation, scale) leaves every image unchanged, so the poses are only identifiable up to it: two
    reference views keep their given poses exactly — one fixes the rotation and translation, the second
    the scale through the distance between the two centres. By default they are the two views whose
    centres lie farthest apart (the longest baseline determines the scale best). Only views that are
    trained on are corrected: a held-out view's pose cannot be refined from images it is never fitted
    to, so it keeps its given pose, which stays consistent with the scene because the reference views
    keep the given poses' frame.

    Parameters
    ----------
    capture : Capture
        V views (one image size) and the channel map; k = ``capture.n_channels``.
    images : array_like of shape (V, H, W, k)
        Measurements in the channels each view measures (anything elsewhere is ignored).
    weights : array_like of shape (V, H, W, k)
        Per-pixel, per-channel weights, e.g. the Bayer mosaic (so mosaiced RAW is used directly).
    config : TrainConfig
    bounds : array_like of shape (2, 3)
        Box around the scene (initialisation and the scale of the learning rate of the centres).
    points, colours : optional
        Initial centres (P, 3) and colours (P, k), see :func:`init_state`.
    resume : path, optional
        A checkpoint written by an earlier run with the same configuration: training continues from
        its step.
    callback : callable, optional
        Called as ``callback(step, state, loss)`` after every step.
    reference_views : sequence of int, optional
        Views whose exposure stays fixed when ``config.refine_exposure`` (default: one per camera id,
        see above). Every camera id needs at least one.
    pose_reference_views : sequence of int, optional
        Views whose pose stays fixed when ``config.refine_poses`` (default: the two views farthest apart,
        see above); at least one. With one, the scale stays free, but a common scaling of the scene and
        the camera centres leaves every image unchanged, so the loss's gradient never points along it.
    depth : tuple of array_like of shape (V, D), optional
        ``(pixel, depth, valid)``: each view's sparse depth, e.g. the COLMAP points it observes
        (:func:`splat.capture.depth_targets`); used when ``config.depth_weight > 0``.

    Returns
    -------
    TrainResult
    """
    images = jnp.asarray(images, jnp.float32)
    weights = jnp.asarray(weights, jnp.float32)
    V, N = len(capture.views), capture.n_channels
    if images.shape != weights.shape or images.ndim != 4 or images.shape[0] != V or images.shape[-1] != N:
        raise SplatError(
            f"images and weights must both have shape (V={V}, H, W, k={N}); got "
            f"{images.shape} and {weights.shape}."
        )
    cams = stack_cameras(v.camera for v in capture.views)
    if (cams.height, cams.width) != images.shape[1:3]:
        raise SplatError(f"views are {cams.height}×{cams.width} pixels but images are {images.shape[1:3]}.")
    masks = jnp.asarray(np.stack([capture.channel_mask(v) for v in capture.views]), jnp.float32)
    exposures = jnp.asarray([v.exposure for v in capture.views], jnp.float32)
    # validate everything before the first step: only values that enter the loss must be finite, and
    # anything elsewhere (NaN in unmeasured channels or at zero weight) is zeroed, since 0 · NaN = NaN
    # would poison the gradients of every Gaussian
    if not bool(jnp.all(jnp.isfinite(weights))) or bool(jnp.any(weights < 0)):
        raise SplatError("weights: must be finite and ≥ 0 (0 where a pixel or channel is not measured).")
    used = (weights * masks[:, None, None, :]) > 0
    if not bool(jnp.all(jnp.isfinite(images) | ~used)):
        v_bad = int(jnp.argmax(jnp.any(~jnp.isfinite(images) & used, axis=(1, 2, 3))))
        raise SplatError(
            f"images: view {v_bad} ({capture.views[v_bad].name!r}) has NaN or inf in channels "
            "it measures with a weight > 0; set their weight to 0 or fix the data."
        )
    images = jnp.where(used, images, 0.0)
    bounds = np.asarray(bounds, float)
    if bounds.shape != (2, 3) or not np.all(np.isfinite(bounds)) or not np.all(bounds[1] > bounds[0]):
        raise SplatError(
            f"bounds: expected a finite (2, 3) box [min, max] with max > min, got {bounds.tolist()}."
        )
    extent = float(np.linalg.norm(bounds[1] - bounds[0]))
    state = init_state(config, bounds=bounds, n_channels=N, points=points, colours=colours, n_views=V)
    exposure_mask = None
    if config.refine_exposure:
        ref = _reference_views(capture) if reference_views is None else [int(i) for i in reference_views]
        if any(not 0 <= i < V for i in ref):
            raise SplatError(f"reference_views={ref}: view indices must lie in [0, {V}).")
        missing = {v.camera_id for v in capture.views} - {capture.views[i].camera_id for i in ref}
        if missing:
            raise SplatError(
                f"reference_views={ref}: camera id(s) {sorted(missing)} have no reference view; their "
                "exposure scale would be unidentifiable. Give one view of every camera."
            )
        exposure_mask = jnp.ones(V).at[jnp.asarray(ref)].set(0.0)
    pose_mask, pref = None, []
    if config.refine_poses:
        pref = (
            _pose_reference_views(cams)
            if pose_reference_views is None
            else [int(i) for i in pose_reference_views]
        )
        if not pref or any(not 0 <= i < V for i in pref):
            raise SplatError(
                f"pose_reference_views={pref}: need at least one view index in [0, {V}) (with none, the "
                "whole scene and its cameras may turn and shift together); two fix the scale as well."
            )
        pose_mask = jnp.ones(V).at[jnp.asarray(pref)].set(0.0)
    if depth is not None and config.depth_weight > 0:
        pixel, target, on = (np.asarray(a) for a in depth)
        H, W = images.shape[1:3]
        if not (pixel.shape == target.shape == on.shape and pixel.ndim == 2 and len(pixel) == V):
            raise SplatError(f"depth: expected (pixel, depth, valid), each of shape (V={V}, D).")
        if np.any(on & ((pixel < 0) | (pixel >= H * W) | ~(target > 0))):
            raise SplatError(
                f"depth: a valid entry has a pixel outside [0, {H * W}) or a depth that is not > 0; mark it "
                "invalid or drop it."
            )
        depth = (
            jnp.asarray(pixel, jnp.int32),
            jnp.asarray(np.where(on, target, 1.0), jnp.float32),
            jnp.asarray(on),
        )
    else:
        depth = None
    if resume is not None:
        state = load_checkpoint(resume, state)

    def order(epoch):  # view order of each epoch, a function of the step only (exact resume)
        return np.random.default_rng((config.seed, epoch)).permutation(V)

    hist = {"loss": [], "n_alive": [], "n_dropped": []}
    while state.step < config.steps:
        step = state.step
        v = int(order(step // V)[step % V])
        cam = jax.tree.map(lambda x, v=v: x[v], cams)
        state, loss, dropped = train_step(
            state,
            cam,
            images[v],
            weights[v],
            masks[v],
            exposures[v],
            config=config,
            extent=extent,
            view=jnp.asarray(v, jnp.int32),
            exposure_mask=exposure_mask,
            pose_mask=pose_mask,
            depth=None if depth is None else tuple(a[v] for a in depth),
        )
        state = state._replace(step=step + 1)
        if config.densify_from <= step + 1 < config.densify_until and (step + 1) % config.densify_every == 0:
            state = _densify(state, config, extent)
        hist["loss"].append(loss)
        hist["n_dropped"].append(dropped)
        hist["n_alive"].append(jnp.sum(state.alive))
        if callback is not None:
            callback(step + 1, state, loss)
        if config.checkpoint and ((step + 1) % config.checkpoint_every == 0 or step + 1 == config.steps):
            save_checkpoint(state, config.checkpoint)
    history = {k: np.asarray(jnp.stack(v)) if v else np.zeros(0) for k, v in hist.items()}
    factors = np.ones(V) if state.log_exposure is None else np.exp(np.asarray(state.log_exposure, float))
    poses = np.zeros((V, 6)) if state.pose_delta is None else np.asarray(state.pose_delta, float)
    return TrainResult(state.params, np.asarray(state.alive), state, history, factors, poses, tuple(pref))


def _pose_reference_views(cams: Camera) -> list[int]:
    """The two views whose camera centres lie farthest apart (the first view alone if there is one)."""
    R, t = np.asarray(cams.R, float), np.asarray(cams.t, float)
    c = -np.einsum("vji,vj->vi", R, t)  # centres −Rᵀ t
    if len(c) < 2:
        return [0]
    d = np.linalg.norm(c[:, None] - c[None], axis=-1)
    i, j = np.unravel_index(np.argmax(d), d.shape)
    return sorted({int(i), int(j)})


def _reference_views(capture: Capture) -> list[int]:
    """Per camera id, the view whose exposure is nearest the median of that camera's views."""
    out = []
    for cid in sorted({v.camera_id for v in capture.views}):
        idx = [i for i, v in enumerate(capture.views) if v.camera_id == cid]
        e = np.log([capture.views[i].exposure for i in idx])
        out.append(idx[int(np.argmin(np.abs(e - np.median(e))))])
    return out
