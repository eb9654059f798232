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

from dataclasses import dataclass, field
from functools import partial
from pathlib import Path
from typing import NamedTuple

import jax
import jax.numpy as jnp
import numpy as np
import optax

from ._errors import SplatError
from .camera import Camera
from .data import Capture
from .gaussians import Gaussians, init_gaussians
from .rendering import RenderConfig, render

__all__ = [
    "TrainConfig",
    "TrainResult",
    "TrainState",
    "init_state",
    "load_checkpoint",
    "rawnerf_loss",
    "save_checkpoint",
    "stack_cameras",
    "train",
    "train_step",
]

_FIELDS = ("means", "quats", "log_scales", "opacity_logits", "colour_params")


def rawnerf_loss(pred: jax.Array, target: jax.Array, weight: jax.Array, *, eps: float = 1e-3) -> jax.Array:
    """RawNeRF's relative L2 on clipped predictions, weighted per pixel and channel.

    ``Σ w ((min(ŷ, 1) − y) / (sg(min(ŷ, 1)) + eps))² / Σ w`` with ``sg`` the stop-gradient
    (Mildenhall et al. 2022, eq. 9; clipping as in multinerf).

    Parameters
    ----------
    pred, target, weight : array_like of shape (..., k)
        Prediction ŷ, RAW measurement y, and weight (e.g. the Bayer mask × the channels measured).

    Returns
    -------
    Array of shape ()
    """
    clipped = jnp.minimum(pred, 1.0)
    scale = 1.0 / (jax.lax.stop_gradient(clipped) + eps)
    return jnp.sum(weight * ((clipped - target) * scale) ** 2) / jnp.maximum(jnp.sum(weight), 1e-12)


@dataclass(frozen=True)
class TrainConfig:
    """Options of :func:`train` (learning rates are initial values; all decay exponentially).

    Attributes
    ----------
    steps : int
    lr_means : float
        Learning rate of the centres, as a fraction of the scene extent.
    lr_log_scales, lr_quats, lr_opacity, lr_colours : float
    lr_final : float
        Final / initial learning rate (the exponential decay over ``steps``).
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
    method : str
        Render back-end during training.
    render : RenderConfig
    checkpoint : path or None
        Where to save a checkpoint (``.npz``) every ``checkpoint_every`` steps and at the end.
    checkpoint_every : int
    seed : int
    """

    steps: int = 3000
    lr_means: float = 1e-3
    lr_log_scales: float = 1e-2
    lr_quats: float = 5e-3
    lr_opacity: float = 5e-2
    lr_colours: float = 1e-2
    lr_final: float = 0.05
    capacity: int = 1024
    densify_every: int = 100
    densify_from: int = 200
    densify_until: int = 2000
    densify_fraction: float = 0.05
    split_scale: float = 0.02
    prune_opacity: float = 0.005
    method: str = "tiled"
    render: RenderConfig = field(default_factory=RenderConfig)
    checkpoint: str | Path | None = None
    checkpoint_every: int = 500
    seed: int = 0


class TrainState(NamedTuple):
    """Everything :func:`train` needs to resume: parameters, optimiser state, buffer mask, statistics."""

    params: Gaussians
    opt_state: optax.OptState
    alive: jax.Array  # [G] bool
    grad_accum: jax.Array  # [G] summed |∂L/∂means|
    grad_count: jax.Array  # [G] steps each Gaussian was visible
    step: int
    key: jax.Array


class TrainResult(NamedTuple):
    """Trained ``gaussians``, their ``alive`` mask (G,), the final ``state`` and a ``history`` dict of
    per-step ``loss``, ``n_alive`` and ``n_dropped`` arrays."""

    gaussians: Gaussians
    alive: np.ndarray
    state: TrainState
    history: dict[str, np.ndarray]


def stack_cameras(cameras) -> Camera:
    """Stack cameras of one image size into one Camera with a leading view axis (for jit/vmap)."""
    cameras = list(cameras)
    if len({(c.width, c.height) for c in cameras}) != 1:
        raise SplatError(
            "all views must share one image size to be trained together; got "
            f"{sorted({(c.width, c.height) for c in cameras})}."
        )
    return jax.tree.map(lambda *x: jnp.stack(x), *cameras)


def _optimiser(config: TrainConfig, extent: float) -> optax.GradientTransformation:
    def adam(lr):
        return optax.adam(optax.exponential_decay(lr, config.steps, config.lr_final), eps=1e-15)

    rates = (
        config.lr_means * extent,
        config.lr_quats,
        config.lr_log_scales,
        config.lr_opacity,
        config.lr_colours,
    )
    labels = Gaussians(*_FIELDS)
    return optax.multi_transform({k: adam(r) for k, r in zip(_FIELDS, rates)}, labels)


def init_state(
    config: TrainConfig, *, bounds, n_channels: int, points=None, colours=None, n_init: int | None = None
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
    """
    G = config.capacity
    bounds = np.asarray(bounds, float)
    rng = np.random.default_rng(config.seed)
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
    scale = 0.5 * extent / max(n_init, 1) ** (1 / 3)
    params = init_gaussians(full, col, scales=scale, opacity=0.1, key=jax.random.key(config.seed))
    alive = jnp.arange(G) < n_init
    opt = _optimiser(config, extent)
    return TrainState(
        params, opt.init(params), alive, jnp.zeros(G), jnp.zeros(G), 0, jax.random.key(config.seed + 1)
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
    """

    def loss_fn(params):
        out = render(params, camera, method=config.method, config=config.render, mask=state.alive)
        pred = exposure * out.image
        return rawnerf_loss(pred, image, weight * channel_mask), out.n_dropped

    (loss, dropped), grads = jax.value_and_grad(loss_fn, has_aux=True)(state.params)
    updates, opt_state = _optimiser(config, extent).update(grads, state.opt_state, state.params)
    params = optax.apply_updates(state.params, updates)
    gnorm = jnp.linalg.norm(grads.means, axis=-1)
    seen = gnorm > 0
    return (
        state._replace(
            params=params,
            opt_state=opt_state,
            grad_accum=state.grad_accum + gnorm,
            grad_count=state.grad_count + seen,
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
    n = min(len(free), int(np.ceil(config.densify_fraction * alive.sum())))
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
    from zonotope import atomic_path

    leaves = jax.tree.leaves((state.params, state.opt_state, state.alive, state.grad_accum, state.grad_count))
    arrays = {f"leaf_{i:04d}": np.asarray(x) for i, x in enumerate(leaves)}
    key = np.asarray(jax.random.key_data(state.key))

    # written to a temporary sibling, synced, then renamed: a kill mid-save leaves the previous
    # checkpoint intact (np.savez in place truncated it first)
    def write(tmp: Path) -> None:
        with open(tmp, "wb") as fh:  # a file object: np.savez appends no suffix
            np.savez(fh, step=state.step, key=key, **arrays)

    return atomic_path(Path(path), write)


def load_checkpoint(path: str | Path, like: TrainState) -> TrainState:
    """Load a checkpoint into the structure of ``like`` (a fresh state from :func:`init_state`)."""
    like_tree = (like.params, like.opt_state, like.alive, like.grad_accum, like.grad_count)
    leaves, treedef = jax.tree.flatten(like_tree)
    with np.load(path) as f:
        stored = sorted(k for k in f.files if k.startswith("leaf_"))
        if len(stored) != len(leaves):
            raise SplatError(
                f"checkpoint {path} has {len(stored)} arrays; this configuration needs "
                f"{len(leaves)} (capacity or channels changed?)."
            )
        new = [jnp.asarray(f[k]) for k in stored]
        for a, b in zip(new, leaves):
            if a.shape != np.shape(b):
                raise SplatError(
                    f"checkpoint {path} holds an array of shape {a.shape} where {np.shape(b)} "
                    "is expected (capacity or channels changed?)."
                )
        step, key = int(f["step"]), jax.random.wrap_key_data(jnp.asarray(f["key"]))
    params, opt_state, alive, ga, gc = jax.tree.unflatten(treedef, new)
    return TrainState(params, opt_state, alive, ga, gc, step, key)


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
) -> TrainResult:
    """Fit N-channel Gaussians to the RAW views of a multi-camera capture.

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
    state = init_state(config, bounds=bounds, n_channels=N, points=points, colours=colours)
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
            state, cam, images[v], weights[v], masks[v], exposures[v], config=config, extent=extent
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
    return TrainResult(state.params, np.asarray(state.alive), state, history)
