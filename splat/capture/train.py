"""The train step: the training inputs (working-resolution views, initial points, depth targets), the
fit of the N-channel Gaussians, and readers of its results (model, refined poses).
"""

from __future__ import annotations

import os
import time
from pathlib import Path
from typing import TYPE_CHECKING, NamedTuple

import numpy as np

from .._tol import SEEN_REGION_MIN_DEPTH
from .config import (
    PipelineConfig,
    read_working,
    step_workspace,
    train_size_of,
    working_binning,
    working_summary,
    working_views,
)
from .files import atomic_write, write_json
from .raw import load_views
from .spec import CaptureError, CaptureSpec
from .workspace import Workspace, peak_rss_mib, read_json, reset_peak_rss

if TYPE_CHECKING:
    from zonotope.utilities import ProgressCallback

__all__ = [
    "TrainingInputs",
    "depth_targets",
    "fit_step",
    "load_gaussians",
    "load_model_capture",
    "pose_corrections_of",
    "refined_views",
    "train_config",
    "training_inputs",
]


def load_model_capture(spec: CaptureSpec, out: Path):
    """The registered views as a :class:`Capture` (camera id k + 1 = capture camera k) and the model."""
    from ..colmap import read_colmap
    from ..data import capture_from_colmap

    if not (out / "poses" / "summary.json").is_file():
        raise CaptureError(f"{out}: no poses yet; run the poses step first (splat poses CAPTURE -o OUT).")
    model = read_colmap(out / "poses" / "model")
    n = len(spec.cameras)
    channels = {k + 1: (3 * k, 3 * k + 1, 3 * k + 2) for k in range(n)}
    labels = tuple(f"{c.folder}:{ch}" for c in spec.cameras for ch in "RGB")
    exposures = read_json(out / "poses" / "summary.json").get("exposures")
    if not isinstance(exposures, dict):
        raise CaptureError(f"{out / 'poses' / 'summary.json'}: not a splat poses summary (no exposures).")
    return model, capture_from_colmap(model, channels=channels, exposures=exposures, labels=labels)


def _pad(a: np.ndarray, H: int, W: int) -> np.ndarray:
    return np.pad(a, ((0, H - a.shape[0]), (0, W - a.shape[1]), (0, 0)))


class TrainingInputs(NamedTuple):
    """What the train step fits: the training views (held-out ones excluded, padded to one size, at the
    working resolution), their stacked mosaics (binned ones full-colour) and weights, the scene box and
    the initial points and colours (from COLMAP), and the working resolution per camera."""

    capture: object  # splat.data.Capture of the padded training views
    views: list  # the unpadded training views (splat.data.View)
    images: np.ndarray  # (V, H, W, N)
    weights: np.ndarray  # (V, H, W, N)
    bounds: np.ndarray  # (2, 3)
    points: np.ndarray | None  # (P, 3)
    colours: np.ndarray | None  # (P, N)
    depth: tuple | None = None  # (pixel (V, D), depth (V, D), valid (V, D)): see depth_targets
    working: dict | None = None  # working_summary


def training_inputs(
    spec: CaptureSpec,
    out: Path,
    config: PipelineConfig = PipelineConfig(),
    progress: ProgressCallback | None = None,
    *,
    workspace: Workspace | None = None,
) -> TrainingInputs:
    """The inputs of the train step, read from the capture and ``OUT/poses`` (no ground truth).

    Views of different sizes are padded (right and bottom, weight 0) to the largest size so that they
    stack; a view's intrinsics are unchanged by the padding. ``progress("read", done, total)`` after
    each RAW file (reading 36 files of 12 MP takes minutes). With the run's ``workspace``, the files
    are read from its decode cache (:func:`splat.capture.config.read_working`), where the poses step
    kept them (a file or option the cache has no entry for is decoded and kept for the later steps).
    """
    from ..camera import Camera
    from ..data import Capture

    model, cap = load_model_capture(spec, out)
    # each file read and binned to the working resolution in turn (never all mosaics whole at once)
    if workspace is not None:
        raws = {v.name: v for v in read_working(spec, workspace, config, progress)}
    else:
        raws = {v.name: v for v in load_views(spec, progress=progress, binning=working_binning(config, spec))}
    hold = set(spec.holdout)
    views = [v for v in working_views(cap.views, raws) if v.name not in hold]
    if not views:
        raise CaptureError("every registered view is held out; nothing to train on.")
    H = max(v.camera.height for v in views)
    W = max(v.camera.width for v in views)
    N = cap.n_channels
    images = np.zeros((len(views), H, W, N), np.float32)
    weights = np.zeros_like(images)
    padded = []
    for i, v in enumerate(views):
        r = raws[v.name]
        idx = list(cap.channels[v.camera_id])
        images[i, : r.shape[0], : r.shape[1], idx] = np.moveaxis(r.values, -1, 0)
        weights[i, : r.shape[0], : r.shape[1], idx] = np.moveaxis(r.weight, -1, 0)
        c = v.camera
        padded.append(type(v)(v.name, Camera(c.R, c.t, c.focal, c.principal, W, H), v.camera_id, v.exposure))
    train_cap = Capture(tuple(padded), cap.channels, cap.labels)
    xyz, rgb, bounds = _scene_points(model, [v.camera for v in views], seed=config.train.seed)
    valid = weights > 0
    level = float(np.median(images[valid])) if valid.any() else 0.2
    xyz, colours = _initial_points(xyz, rgb, level, config.train.capacity, N, seed=config.train.seed)
    depth = depth_targets(model, padded)
    working = working_summary(spec, list(raws.values()))
    return TrainingInputs(train_cap, views, images, weights, bounds, xyz, colours, depth, working)


def depth_targets(model, views) -> tuple[np.ndarray, np.ndarray, np.ndarray] | None:
    """Sparse depth of each view from the COLMAP points it observes (their tracks).

    For view ``i`` (a :class:`splat.data.View` named as its COLMAP image), every point whose track holds
    that image is projected with the view's camera; those in front of it and inside its frame give the
    flat pixel index ``row · W + col`` and the point's depth along the optical axis. Views observe
    different numbers of points, so the result is padded: ``(pixel, depth, valid)``, each (V, D) with D
    the largest count. ``None`` when no view observes a point (a model without tracks, e.g. points
    converted from another format).
    """
    ids = {im.name: iid for iid, im in model.images.items()}
    pts = list(model.points3D.values())
    if not pts:
        return None
    xyz = np.array([p.xyz for p in pts], float)
    seen_by: dict[int, list[int]] = {}
    for k, p in enumerate(pts):
        for iid in np.unique(np.asarray(p.image_ids, np.int64)):
            seen_by.setdefault(int(iid), []).append(k)
    rows = []
    for v in views:
        sel = np.asarray(seen_by.get(ids.get(v.name, -1), []), np.int64)
        c = v.camera
        p = xyz[sel] @ np.asarray(c.R, float).T + np.asarray(c.t, float)
        z = p[:, 2]
        ok = z > 0
        u = np.full(len(sel), -1.0)
        w = np.full(len(sel), -1.0)
        u[ok] = c.focal[0] * p[ok, 0] / z[ok] + c.principal[0]
        w[ok] = c.focal[1] * p[ok, 1] / z[ok] + c.principal[1]
        ok &= (u >= 0) & (u < c.width) & (w >= 0) & (w < c.height)
        rows.append((np.floor(w[ok]).astype(np.int64) * c.width + np.floor(u[ok]).astype(np.int64), z[ok]))
    D = max(len(r[0]) for r in rows)
    if D == 0:
        return None
    pixel = np.zeros((len(views), D), np.int32)
    depth = np.ones((len(views), D), np.float32)
    valid = np.zeros((len(views), D), bool)
    for i, (px, z) in enumerate(rows):
        pixel[i, : len(px)], depth[i, : len(px)], valid[i, : len(px)] = px, z, True
    return pixel, depth, valid


def _scene_points(model, cameras, *, seed: int = 0):
    """The COLMAP points for the initial Gaussians (all of them), their preview colours and the scene's
    bounds: the 2–98th percentile box of each coordinate, padded by 10 % (it sets the scale of the
    centres' learning rate, so a few stray points must not widen it).

    Every point starts a Gaussian, as in 3DGS: the scene's periphery — a backdrop, the far floor — is seen
    by few views, holds few points and lies partly outside the percentile box, and densification cannot
    fill a region where nothing starts (the box used to filter the points too, and on the benchmark
    capture the Gaussians cloned towards the backdrop settled 1–3 m in front of it). With fewer than 8
    points (a poses-only model), points drawn where the cameras' views overlap
    (:func:`_seen_region`), grey."""
    xyz, rgb = model.points()
    if len(xyz) < 8:
        xyz = _seen_region(cameras, seed=seed)
        rgb = np.full((len(xyz), 3), 128, np.uint8)
    lo, hi = np.percentile(xyz, 2, axis=0), np.percentile(xyz, 98, axis=0)
    return xyz, rgb, np.stack([lo - 0.1 * (hi - lo), hi + 0.1 * (hi - lo)])


def _seen_region(cameras, n: int = 8192, *, seed: int = 0) -> np.ndarray:
    """``n`` points (or fewer) where the cameras' views overlap: each camera's pixels back-projected at
    random depths between 0.2 and 2 times its distance to the point nearest every optical axis (least
    squares; the cameras' spread where the axes are parallel), kept where at least half of the
    cameras (two at least) see them in front of them and inside their images.

    Why: a model without points gave the Gaussians a box around the camera centres, where nothing of
    the scene is, and training made the loss worse (a three-camera capture from poses alone: 0.65 → 0.82
    in 200 steps)."""
    rng = np.random.default_rng(seed)
    R = np.array([np.asarray(c.R, float) for c in cameras])
    t = np.array([np.asarray(c.t, float) for c in cameras])
    o = -np.einsum("kji,kj->ki", R, t)  # centres −Rᵀt
    a = R[:, 2]  # optical axes in the world (the camera's +z)
    P = np.eye(3) - a[:, :, None] * a[:, None, :]  # projectors onto each axis's normal plane
    focus = np.linalg.lstsq(P.sum(0), np.einsum("kij,kj->i", P, o), rcond=None)[0]
    depth = np.einsum("ki,ki->k", focus - o, a)
    spread = float(np.linalg.norm(o.max(0) - o.min(0))) or 1.0
    depth = np.where(np.isfinite(depth) & (depth > SEEN_REGION_MIN_DEPTH * spread), depth, spread)
    K = np.array([np.asarray(c.K, float) for c in cameras])
    size = np.array([(c.width, c.height) for c in cameras], float)
    m = -(-4 * n // len(cameras))
    pts = []
    for k in range(len(cameras)):
        uv = rng.uniform(0, 1, (m, 2)) * size[k]
        ray = np.linalg.solve(K[k], np.c_[uv, np.ones(m)].T).T  # camera coordinates at z = 1
        z = depth[k] * rng.uniform(0.2, 2.0, (m, 1))
        pts.append((ray * z - t[k]) @ R[k])  # world: Rᵀ(x_cam − t)
    X = np.concatenate(pts)
    seen = np.zeros(len(X), int)
    for k in range(len(cameras)):  # one camera at a time: memory of the points, not points × cameras
        p = X @ R[k].T + t[k]
        z = np.where(p[:, 2] > 0, p[:, 2], 1.0)[:, None]
        uv = p[:, :2] / z @ K[k][:2, :2].T + K[k][:2, 2]
        seen += (p[:, 2] > 0) & (uv >= 0).all(1) & (uv < size[k]).all(1)
    keep = seen >= max(2, -(-len(cameras) // 2))
    X = X[keep] if keep.sum() >= 8 else X
    return X[rng.permutation(len(X))[:n]]


def _initial_points(xyz, rgb, level: float, capacity: int, n_channels: int, *, seed: int = 0):
    """The Gaussians' starting centres and colours: a seeded random half-capacity subset of the COLMAP
    points, each grey at the median measured value ``level`` scaled by its preview luminance relative to
    the subset's median. Returns ``(xyz (P, 3), colours (P, n_channels))``."""
    take = np.random.default_rng(seed).permutation(len(xyz))[: capacity // 2]
    lum = (np.asarray(rgb)[take].astype(float) / 255) ** 2.2
    lum = lum.mean(1) / max(np.median(lum.mean(1)), 1e-6)
    return np.asarray(xyz)[take], np.clip(level * lum, 1e-3, 1)[:, None] * np.ones(n_channels)


def train_config(config: PipelineConfig, checkpoint: Path | None = None):
    """The :class:`splat.training.TrainConfig` the train step passes to :func:`splat.train`:
    ``config.train`` with ``checkpoint`` (the step's ``OUT/train/checkpoint.npz``) and nothing else
    changed."""
    from dataclasses import replace

    return replace(config.train, checkpoint=checkpoint)


def _train_settings(spec: CaptureSpec, config: PipelineConfig) -> dict:
    """The train step's key: the held-out views, the working resolution and every field of
    ``config.train`` but the checkpoint's path (any of them changes the model)."""
    from dataclasses import asdict

    train = {k: v for k, v in asdict(config.train).items() if k != "checkpoint"}
    return {"holdout": sorted(spec.holdout), "train_size": train_size_of(spec, config), "train": train}


def fit_step(
    capture: str | os.PathLike,
    out: str | os.PathLike,
    *,
    config: PipelineConfig = PipelineConfig(),
    progress: ProgressCallback | None = None,
) -> dict:
    """Train the N-channel Gaussians on every camera's RAW mosaics (held-out views excluded).

    Views of different sizes are padded (right and bottom, weight 0) to the largest size so that
    they stack; a view's intrinsics are unchanged by the padding. Resumes from
    ``train/checkpoint.npz`` when present.

    Returns
    -------
    dict
        The summary written to ``train/summary.json``.
    """
    import jax
    import jax.numpy as jnp

    from ..training import train

    spec, ws = step_workspace(capture, out, config, "train", lambda spec: _train_settings(spec, config))
    out = ws.root
    done = out / "train" / "summary.json"
    if done.is_file() and (out / "train" / "model.npz").is_file():
        return read_json(done)
    t_step = time.perf_counter()  # the step's duration includes reading the RAW files
    reset_peak_rss()
    inp = training_inputs(spec, out, config, progress, workspace=ws)
    train_cap, images, weights = inp.capture, inp.images, inp.weights
    bounds, xyz, colours = inp.bounds, inp.points, inp.colours
    views, padded, N = inp.views, list(train_cap.views), train_cap.n_channels
    tc = train_config(config, out / "train" / "checkpoint.npz")
    resume = tc.checkpoint if Path(tc.checkpoint).is_file() else None
    t0 = time.perf_counter()

    def cb(step, state, loss):
        if progress is not None and (step % 10 == 0 or step == tc.steps):
            progress("train", step, tc.steps)

    res = train(
        train_cap,
        images,
        weights,
        config=tc,
        bounds=bounds,
        points=xyz,
        colours=colours,
        resume=resume,
        callback=cb,
        depth=inp.depth,
    )
    seconds = time.perf_counter() - t0
    # residual noise per channel (raw units at exposure 1) on up to 6 training views → δ of correct
    from ..camera import pose_corrected
    from ..outputs import render_views

    alive = jnp.asarray(res.alive)
    sq, cnt = np.zeros(N), np.zeros(N)
    for i in np.linspace(0, len(padded) - 1, min(6, len(padded))).astype(int):
        v = padded[i]
        cam = pose_corrected(v.camera, res.pose_corrections[i]) if tc.refine_poses else v.camera
        pred = render_views(res.gaussians, [cam], mask=alive)[0] * v.exposure * res.exposure_factors[i]
        w = weights[i] * (pred < 1)
        e = v.exposure * res.exposure_factors[i]
        sq += np.sum(w * ((pred - images[i]) / e) ** 2, axis=(0, 1))
        cnt += w.sum((0, 1))
    sigma = np.sqrt(sq / np.maximum(cnt, 1))
    params = res.gaussians.to_numpy()
    atomic_write(out / "train" / "model.npz", lambda p: np.savez(p, alive=np.asarray(res.alive), **params))
    loss = np.asarray(res.history["loss"], float)
    summary = {
        "steps": tc.steps,
        "resumed_from": None if resume is None else int(res.state.step - len(loss)),
        "views": len(views),
        "size": [images.shape[2], images.shape[1]],
        "channels": N,
        "gaussians": int(np.sum(res.alive)),
        "seconds": seconds,
        "loss_first": float(loss[:20].mean()) if loss.size else None,
        "loss_last": float(loss[-20:].mean()) if loss.size else None,
        "residual_sigma_raw": sigma.tolist(),
        "bounds": bounds.tolist(),
        "init_points": 0 if xyz is None else len(xyz),
        "exposure_factors": {v.name: float(f) for v, f in zip(views, res.exposure_factors)},
        "backend": jax.default_backend(),
        # Gaussian–tile pairs the "tiled" back-end (on a GPU) left out per step, mean of the last 100
        # steps (0 with the CPU back-end): above 0, RenderConfig.tile_capacity is too small for the model
        "dropped_per_step": float(np.mean(res.history["n_dropped"][-100:])) if loss.size else 0.0,
        "working": inp.working,
        "train_size": train_size_of(spec, config),
    }
    if tc.refine_poses:
        summary.update(_pose_summary(train_cap, res, float(np.linalg.norm(bounds[1] - bounds[0]))))
    summary["duration_s"] = time.perf_counter() - t_step
    summary["peak_rss_mib"] = peak_rss_mib()
    write_json(done, summary)
    return summary


def _pose_summary(capture, res, extent: float) -> dict:
    """The learned pose corrections of a :class:`splat.training.TrainResult` for ``train/summary.json``:
    per view ``(ω, τ)`` (radians, scene units; :func:`splat.camera.pose_corrected`), the reference views
    training held fixed, and the size of the corrections."""
    names = [v.name for v in capture.views]
    corrections = res.pose_corrections
    rot = np.degrees(np.linalg.norm(corrections[:, :3], axis=1))
    trans = np.linalg.norm(corrections[:, 3:], axis=1)
    return {
        "pose_corrections": {n: [float(x) for x in c] for n, c in zip(names, corrections)},
        "pose_reference_views": [names[i] for i in res.pose_reference_views],
        "pose_correction_size": {
            "rotation_deg_mean": float(rot.mean()),
            "rotation_deg_max": float(rot.max()),
            "translation_mean": float(trans.mean()),
            "translation_max": float(trans.max()),
            "scene_extent": extent,
        },
    }


def pose_corrections_of(out: str | os.PathLike) -> dict[str, np.ndarray]:
    """The training views' learned pose corrections (name → ``(ω, τ)``, shape (6,)) from
    ``OUT/train/summary.json``; empty when the model was trained without ``refine_poses``."""
    path = Path(out) / "train" / "summary.json"
    if not path.is_file():
        return {}
    doc = read_json(path).get("pose_corrections", {})
    return {k: np.asarray(v, float) for k, v in doc.items()}


def refined_views(views, out: str | os.PathLike) -> list:
    """``views`` (:class:`splat.data.View`) with the learned pose correction applied to each training
    view (:func:`pose_corrections_of`); the others (held-out views) unchanged."""
    import dataclasses

    from ..camera import Camera, pose_corrected

    corr = pose_corrections_of(out)
    outv = []
    for v in views:
        if v.name in corr:
            c = pose_corrected(v.camera, np.asarray(corr[v.name], np.float32))
            cam = Camera(np.asarray(c.R), np.asarray(c.t), c.focal, c.principal, c.width, c.height)
            v = dataclasses.replace(v, camera=cam)
        outv.append(v)
    return outv


def load_gaussians(out: str | os.PathLike):
    """The trained :class:`Gaussians` and their alive mask from ``OUT/train/model.npz``."""
    from ..gaussians import Gaussians

    path = Path(out) / "train" / "model.npz"
    if not path.is_file():
        raise CaptureError(f"{path}: no trained model; run the train step first.")
    from ..training import read_arrays

    arrays = read_arrays(path, what="model")
    try:
        return Gaussians.from_numpy(arrays), arrays["alive"]
    except (KeyError, ValueError, TypeError) as e:
        raise CaptureError(
            f"{path}: not a splat model ({type(e).__name__}); run the train step again."
        ) from e
