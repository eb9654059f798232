"""The render step: N-channel renders of the held-out, photographed or novel views, per-camera splits,
PCA previews and the photographs reprojected into each view.
"""

from __future__ import annotations

import fnmatch
import itertools
import os
import threading
import time
from concurrent.futures import Future, ThreadPoolExecutor
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from .config import PipelineConfig, read_working, step_workspace, working_summary, working_views
from .files import write_json, write_png8, write_tiff
from .spec import CaptureSpec
from .train import load_gaussians, load_model_capture, refined_views
from .workspace import peak_rss_mib, reset_peak_rss

if TYPE_CHECKING:
    from zonotope.utilities import ProgressCallback

__all__ = [
    "nearest_sources",
    "render_step",
    "reprojected_view",
    "views_to_render",
]


def _novel_cameras(views, n: int):
    """``n`` cameras between each pair of consecutive views (centre lerp, rotation slerp)."""
    from scipy.spatial.transform import Rotation, Slerp

    from ..camera import Camera

    out = []
    for a, b in itertools.pairwise(views):
        ca, cb = a.camera, b.camera
        rots = Rotation.from_matrix(np.stack([np.asarray(ca.R, float), np.asarray(cb.R, float)]))
        slerp = Slerp([0, 1], rots)
        for j in range(1, n + 1):
            s = j / (n + 1)
            R = slerp([s]).as_matrix()[0]
            centre = (1 - s) * np.asarray(ca.centre, float) + s * np.asarray(cb.centre, float)
            out.append(
                (
                    f"{Path(a.name).parent.as_posix()}/novel_{Path(a.name).stem}_{j}",
                    Camera(
                        np.asarray(R, np.float32),
                        np.asarray(-R @ centre, np.float32),
                        ca.focal,
                        ca.principal,
                        ca.width,
                        ca.height,
                    ),
                    a.camera_id,
                )
            )
    return out


def nearest_sources(
    cam,
    depth,
    alpha,
    candidates,
    k: int | None,
    *,
    seen_only: bool = False,
    stride: int | None = None,
    min_alpha: float | None = None,
) -> list:
    """The ``k`` of ``candidates`` (``(name, camera, source depth)``, one camera's photographs) that see
    most of the view ``cam`` through its ``depth`` and ``alpha``, most first (ties by name); all of them,
    in their order, when ``k`` is None or not fewer than the candidates. A photograph that sees none of
    the view is never chosen by rank; with ``seen_only`` it is left out in every case (then ``k`` None
    or not fewer than the candidates keeps the others in their order).

    Counted on every ``stride``-th pixel of the view in each direction (default
    :data:`splat._tol.RENDER_SOURCE_STRIDE`; :func:`splat.reproject.visibility`): the ranking needs the
    share of the view a photograph sees, not its pixels, and so costs a small fraction of one
    reprojection.

    Why: reprojecting every other photograph into every view grows as the square of the photographs;
    the nearest few carry the view's measurement (the farther ones see less of it, at a slant, and
    mostly add noise averaging the fusion already has). ``seen_only``, ``stride`` and ``min_alpha`` (the
    view's opacity that gives a pixel a depth; default :data:`splat.reproject.MIN_ALPHA`) are for the
    correct step, which reads each chosen photograph at full resolution and counts it in the reprojected
    noise (:data:`splat._tol.FULL_SOURCE_STRIDE`)."""
    from .._tol import RENDER_SOURCE_STRIDE
    from ..reproject import MIN_ALPHA, visibility
    from ..resolution import scale_camera

    everything = k is None or len(candidates) <= k
    if everything and not seen_only:
        return list(candidates)
    s = RENDER_SOURCE_STRIDE if stride is None else int(stride)
    coarse = scale_camera(cam, s)
    h, w = coarse.height, coarse.width
    d = np.asarray(depth)[s // 2 :: s, s // 2 :: s][:h, :w]
    a = np.asarray(alpha)[s // 2 :: s, s // 2 :: s][:h, :w]
    t = MIN_ALPHA if min_alpha is None else float(min_alpha)
    seen = [(int(visibility(coarse, d, a, c, sd, min_alpha=t).sum()), name) for name, c, sd in candidates]
    if everything:
        return [c for c, (n, _) in zip(candidates, seen, strict=True) if n > 0]
    order = sorted(range(len(candidates)), key=lambda i: (-seen[i][0], seen[i][1]))
    return [candidates[i] for i in order[:k] if seen[i][0] > 0]


_ONCE_LOCK = threading.Lock()


def _once(cache: dict, key, make):
    """``cache[key]``, made by ``make()`` by the first caller only: callers on other threads asking for
    the same key wait for it (a failure reaches each of them) instead of computing it again."""
    with _ONCE_LOCK:
        entry = cache.get(key)
        mine = entry is None
        if mine:
            entry = cache[key] = Future()
    if mine:
        try:
            entry.set_result(make())
        except BaseException as e:
            entry.set_exception(e)
            with _ONCE_LOCK:  # not kept: a later call tries again
                cache.pop(key, None)
            raise
    return entry.result()


def reprojected_view(name, cam, views, raws, model: tuple, cache: dict, n: int, k: int | None = None):
    """Every camera's photographs (other than ``name`` itself; with ``k``, only each camera's ``k`` that
    see most of the view, :func:`nearest_sources`) reprojected into the view through the
    splat's depth, moved along each ray to where the photographs agree
    (:func:`splat.reproject.consistent_depth`), and combined by :func:`splat.reproject.reprojected`
    with each photograph's noise variance (:func:`splat.fusion.photo_variance`): values (H, W, 3n) at
    exposure 1 (0 where no photograph of that camera sees the pixel) and the number of photographs that
    see it (H, W, n). ``model``: the splat's ``(gaussians, alive)``
    (:func:`splat.capture.load_gaussians`); ``cache`` keeps each view's depth maps and photograph for the
    next call, each computed once even when calls on several threads share it."""
    from ..fusion import measured, photo_variance
    from ..reproject import MIN_ALPHA, depth_map, reprojected
    from ..reproject import consistent_depth as agree

    g, alive = model

    def depth(v_name, c):  # (depth, alpha, source depth), computed once per view
        def make():
            dep, alpha = depth_map(g, c, mask=alive)
            # as a source, a pixel without a reliable depth vouches for nothing (0 never agrees)
            return dep, alpha, np.where(alpha >= MIN_ALPHA, dep, 0.0)

        return _once(cache, ("depth", v_name), make)

    def photo(v_name):  # the photograph demosaiced at exposure 1 and its variance, once per view
        def make():
            r = raws[v_name]
            # bilinear, not Malvar: a source is read near its own edges, where Malvar overshoots
            # (three cameras fused, CI coarse capture, flat held-out pixels: 0.497 → 0.460 ΔE00 noise-free,
            # 1.392 → 1.368 noisy)
            p = measured(r, np.ones(3), method="bilinear")
            return p, photo_variance(r, p)

        return _once(cache, ("photo", v_name), make)

    d, a, _ = depth(name, cam)
    groups = []  # each camera's photographs (but the view's own), as reprojection sources
    for c in range(n):
        candidates = []
        for v in views:
            r = raws.get(v.name)
            if v.name != name and r is not None and r.camera == c and r.exif is not None:
                candidates.append((v.name, v.camera, depth(v.name, v.camera)[2]))
        chosen = nearest_sources(cam, d, a, candidates, k)
        groups.append([(vc, sd, *photo(v_name)) for v_name, vc, sd in chosen])
    if any(len(g) >= 2 for g in groups):  # the splat's depth moved to where the photographs agree
        d, _ = agree(cam, d, a, groups)
    values = np.zeros((cam.height, cam.width, 3 * n), np.float32)
    count = np.zeros((cam.height, cam.width, n), np.float32)
    for c, sources in enumerate(groups):
        if sources:
            values[..., 3 * c : 3 * c + 3], count[..., c] = reprojected(cam, d, a, sources)
    return values, count


def views_to_render(spec: CaptureSpec, views, config: PipelineConfig) -> list[tuple]:
    """``(name, camera, camera id, kind)`` of every view the render step renders: the registered
    photographs ``config.views`` selects (all by default; held-out ones first, kind ``"holdout"``, then
    kind ``"view"``), then ``config.novel`` novel views between consecutive registered training views of
    ``config.camera`` (kind ``"novel"``).

    Parameters
    ----------
    views : list of splat.View
        The registered views (:func:`refined_views` of the model's capture).
    """
    k = spec.camera_index(config.camera or spec.cameras[0].folder)
    hold = set(spec.holdout)
    chosen = [
        v for v in views if config.views is None or any(fnmatch.fnmatchcase(v.name, p) for p in config.views)
    ]
    todo = [(v.name, v.camera, v.camera_id, "holdout") for v in chosen if v.name in hold]
    todo += [(v.name, v.camera, v.camera_id, "view") for v in chosen if v.name not in hold]
    if config.novel:
        mine = [v for v in views if v.camera_id == k + 1 and v.name not in hold]
        todo += [(n, c, cid, "novel") for n, c, cid in _novel_cameras(mine, config.novel)]
    return todo


def render_step(
    capture: str | os.PathLike,
    out: str | os.PathLike,
    *,
    config: PipelineConfig = PipelineConfig(),
    progress: ProgressCallback | None = None,
) -> dict:
    """Render the photographs ``config.views`` selects (default all) and ``config.novel`` novel views
    (N channels, exposure 1), and
    reproject each camera's ``config.render_sources`` photographs that see most of each view (all but
    the view's own with None; :func:`nearest_sources`) into it through the splat's depth
    (``reprojected.tiff``, 0 where none sees a pixel, and ``reprojected_count.tiff``, how many see it;
    :mod:`splat.reproject`).

    Returns
    -------
    dict
        ``views``: name → {camera folder, kind ("holdout" / "view" / "novel"), files}.
    """
    from .. import strips as _strips
    from ..outputs import pca_false_colour, render_views, split_cameras

    spec, ws = step_workspace(
        capture, out, config, "render", lambda spec: {"render_sources": config.render_sources}
    )
    out = ws.root
    t0 = time.perf_counter()
    reset_peak_rss()
    _, cap = load_model_capture(spec, out)
    g, alive = load_gaussians(out)
    raws = {v.name: v for v in read_working(spec, ws, config, progress)}
    # at the working resolution; training views with their learned pose corrections, if any
    views = refined_views(working_views(cap.views, raws), out)
    todo = views_to_render(spec, views, config)
    n = len(spec.cameras)
    depths: dict = {}  # each view's depths and photograph, computed once
    workers = _strips.default_workers() if config.workers is None else config.workers

    def one(item) -> bool:  # render and reproject one view; True if it did any work
        name, cam = item[:2]
        d = ws.view_dir("render", name)
        files = {"render": d / "render.tiff", "pca": d / "pca.png"}
        did = not all(p.is_file() for p in [*files.values(), d / "reprojected_count.tiff"])
        if not all(p.is_file() for p in files.values()):
            img = render_views(g, [cam], mask=alive)[0]
            write_tiff(files["render"], img)
            for cid2, part in split_cameras(img, cap).items():
                write_tiff(d / f"camera_{spec.label(cid2 - 1)}.tiff", part)
            write_png8(files["pca"], pca_false_colour(img))
        if not (d / "reprojected_count.tiff").is_file():
            rep, count = reprojected_view(
                name, cam, views, raws, (g, alive), depths, n, config.render_sources
            )
            write_tiff(d / "reprojected.tiff", rep)
            write_tiff(d / "reprojected_count.tiff", count)  # written last: marks the pair complete
        return did

    index = {}
    rendered = 0  # views rendered or reprojected by this call
    # views on threads (the renders and the reprojection's array work release the GIL), each view's
    # files written by its own thread; the progress and the index follow the views' order
    pool = ThreadPoolExecutor(max_workers=workers, thread_name_prefix="render")
    try:
        for i, ((name, _, cid, kind), did) in enumerate(zip(todo, pool.map(one, todo), strict=True)):
            rendered += did
            index[name] = {"camera": spec.cameras[cid - 1].folder, "kind": kind, "dir": spec.out_stem(name)}
            if progress is not None:
                progress("render", i + 1, len(todo))
    finally:  # after a failure, the views not started are dropped
        pool.shutdown(wait=True, cancel_futures=True)
    write_json(out / "render" / "index.json", index)
    if rendered or not (out / "render" / "summary.json").is_file():  # a call that reused every view
        write_json(  # keeps the summary of the call that did the work
            out / "render" / "summary.json",
            {
                "views": len(index),
                "rendered": rendered,
                "working": working_summary(spec, list(raws.values())),
                "duration_s": time.perf_counter() - t0,
                "peak_rss_mib": peak_rss_mib(),
            },
        )
    return index
