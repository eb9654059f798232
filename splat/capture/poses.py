"""The poses step: previews of every photograph (developed by :mod:`isp`) and a COLMAP model of the
capture's poses (recovered, or read from ``[poses]``, with points triangulated on the previews where
the given model has none). Each RAW file is decoded here for the whole
run: binned to the automatic working resolution and kept in ``OUT/decoded``
(:meth:`splat.capture.Workspace.decode_cache`), from which the later steps read it.
"""

from __future__ import annotations

import os
import tempfile
import time
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from .._errors import SplatError
from .chart import chart_of, check_chart
from .config import PipelineConfig, read_working, step_workspace, working_summary
from .files import write_json, write_png8
from .raw import RawView, check_white_box
from .spec import CaptureError
from .workspace import capture_fingerprint, peak_rss_mib, read_json, reset_peak_rss

if TYPE_CHECKING:
    from zonotope.utilities import ProgressCallback

__all__ = [
    "poses_step",
    "preview_binning",
    "preview_upscale",
]


def preview_binning(k, shape, full) -> int:
    """The binning of the poses step's previews: the automatic working resolution (bounded whatever
    ``train_size`` says, so that poses never depend on it); the step reads its files so binned through
    the run's decode cache (:func:`splat.capture.config.read_working` with ``automatic``)."""
    from ..resolution import working_factor

    return working_factor(shape, full)


def preview_upscale(shape: tuple[int, int]) -> int:
    """Integer factor that brings a small image's shorter side to ≥ 400 px for SIFT (1 to 4)."""
    return int(min(4, max(1, np.ceil(400 / min(shape)))))


def _preview(v: RawView, white: np.ndarray) -> np.ndarray:
    """8-bit-ready sRGB-ish preview of a linear mosaic: isp bilinear demosaic, balanced by ``white``
    (the file's as-shot neutral), exposure normalised, sRGB transfer curve."""
    from isp.stages import demosaic, encode_sRGB

    img = (
        v.values.astype(np.float64)
        if v.full_colour
        else demosaic(v.values.sum(-1), cfa=v.cfa, method="bilinear")
    )
    img = np.maximum(img, 0) / white / max(v.exif, 1e-9)
    img = img / max(np.percentile(img, 99.5), 1e-9)
    return encode_sRGB(np.clip(img, 0, 1))


def _triangulated(spec, views, model, by_name, out: Path, previews, config, progress):
    """``model`` (poses without points) in the previews' pixels with points matched and triangulated
    on the previews (:func:`splat.poses.triangulate_points`), or None where that cannot be done: no
    pycolmap, a camera whose size is not its RAW files' (the caller's check then says so), a distorted
    camera, one camera's views with different intrinsics, or fewer than 8 points triangulated
    (training then starts where the views overlap)."""
    import dataclasses

    from ..colmap import ColmapCamera, ColmapImage, ColmapModel
    from ..poses import triangulate_points

    try:
        import pycolmap  # noqa: F401
    except ImportError:
        return None
    cams, images = {}, {}
    for v in views:
        im = by_name.get(v.name)
        if im is None:
            continue
        c = model.cameras[im.camera_id]
        if (c.width, c.height) != tuple(v.size[::-1]):
            return None
        h, w = v.shape
        u = preview_upscale((h, w))
        try:
            fx, fy, cx, cy = (p * u / v.binning for p in c.pinhole())  # preview pixels
        except SplatError:  # a distorted model: the train step's own check says so
            return None
        cam = ColmapCamera(v.camera + 1, "PINHOLE", w * u, h * u, (fx, fy, cx, cy))
        if cams.setdefault(v.camera + 1, cam) != cam:  # one physical camera, two intrinsics
            return None
        name = f"{spec.out_stem(v.name)}.png"
        images[len(images) + 1] = ColmapImage(len(images) + 1, im.qvec, im.tvec, v.camera + 1, name)
    if len(images) < 2:
        return None
    previews()
    if progress is not None:
        progress("triangulate", 0, 1)
    try:
        tri = triangulate_points(
            out / "previews",
            out / "poses" / "colmap",
            ColmapModel(cams, images, {}),
            config=dataclasses.replace(config, camera_model="PINHOLE"),
        )
    except (RuntimeError, ValueError, SplatError):
        return None
    if progress is not None:
        progress("triangulate", 1, 1)
    return tri if len(tri.points3D) >= 8 else None


def poses_step(
    capture: str | os.PathLike,
    out: str | os.PathLike,
    *,
    config: PipelineConfig = PipelineConfig(),
    progress: ProgressCallback | None = None,
) -> dict:
    """Recover (or read) the poses of every RAW file; one COLMAP camera per physical camera. Given
    poses without points get points triangulated on the previews with the poses held fixed.

    Returns
    -------
    dict
        The summary written to ``poses/summary.json``: registered views per camera, source, points
        (``triangulated``: how many were triangulated from given poses, else None).

    Raises
    ------
    CaptureError
        A camera whose views do not register (fewer than ``min_registered`` of them, or fewer than 2).
    """
    from ..colmap import ColmapCamera, ColmapImage, ColmapModel, ColmapPoint3D, read_colmap, write_colmap
    from ..data import read_transforms
    from ..poses import PoseConfig, recover_poses

    spec, ws = step_workspace(
        capture,
        out,
        config,
        "poses",
        lambda spec: {
            "capture": capture_fingerprint(spec),
            "seed": config.seed,
            "min_registered": config.min_registered,
        },
    )
    out = ws.root
    done = out / "poses" / "summary.json"
    if done.is_file():
        return read_json(done)
    t0 = time.perf_counter()
    reset_peak_rss()
    spec = chart_of(spec, ws)  # [chart] corners searched for (when not given) before the files are decoded
    # previews of a bounded size: each file read and binned to the automatic working resolution
    # (preview_binning) once, and kept in the run's decode cache, from which the later steps read it
    views = read_working(spec, ws, config, progress, automatic=True)
    check_white_box(spec, views)
    check_chart(spec, views)
    names = [v.name for v in views]

    def previews():  # 8-bit previews for SIFT, in OUT/previews/<label>/<stem>.png
        # balanced by each file's own as-shot neutral, not the curves' white: the poses (and so the
        # training) do not depend on the curves or the light, which only the correct step reads
        for i, v in enumerate(views):
            path = ws.path("previews", f"{spec.out_stem(v.name)}.png")
            if not path.is_file():
                white = np.asarray(v.neutral, float) / max(float(np.max(v.neutral)), 1e-12)
                write_png8(path, _preview(v, white), upscale=preview_upscale(v.shape))
            if progress is not None:
                progress("previews", i + 1, len(views))

    def raw_names(m):  # a model of the previews: its images by RAW file name
        by = {}
        for im in m.images.values():
            stem = Path(im.name)
            raw = next(
                (n for n in names if spec.out_stem(n) == f"{stem.parent.as_posix()}/{stem.stem}"), None
            )
            if raw is not None:
                by[raw] = im
        return by

    pose_config = PoseConfig(num_threads=config.threads, seed=config.seed, max_image_size=-1)
    in_previews = False  # whether the model's pixels are the previews' (else the RAW files')
    triangulated = None
    if spec.colmap is not None or spec.transforms is not None:
        source = "colmap" if spec.colmap is not None else "transforms"
        if spec.colmap is not None:
            model = read_colmap(spec.colmap)
        else:
            from ..data import colmap_from_capture

            model = colmap_from_capture(read_transforms(spec.transforms))
        by_name = {im.name: im for im in model.images.values()}
        if len(model.points3D) < 8:  # poses alone: points matched and triangulated on the previews
            found = _triangulated(spec, views, model, by_name, out, previews, pose_config, progress)
            if found is not None:
                model, in_previews = found, True
                by_name = raw_names(model)
                triangulated = len(model.points3D)
    else:
        source = "pycolmap"
        previews()
        if progress is not None:
            progress("colmap", 0, 1)
        model = recover_poses(out / "previews", out / "poses" / "colmap", config=pose_config)
        by_name = raw_names(model)
        in_previews = True
        if progress is not None:
            progress("colmap", 1, 1)
    # one camera id per physical camera, in the capture's order; COLMAP's own ids are remapped
    cams, images, counts, new_id = {}, {}, {}, {}  # new_id: the model's image id → ours
    for k, c in enumerate(spec.cameras):
        mine = [v for v in views if v.camera == k]
        reg = [v for v in mine if v.name in by_name]
        counts[c.folder] = {"views": len(mine), "registered": len(reg)}
        need = max(2, int(np.ceil(config.min_registered * len(mine)))) if len(mine) >= 2 else 1
        if len(reg) < need:
            raise CaptureError(
                f"only {len(reg)} of the {len(mine)} views of camera {c.folder!r} registered "
                f"(need {need}); photograph more overlap with the other cameras, add "
                "texture, or give poses in capture.toml ([poses] colmap = ...)."
            )
        src = model.cameras[by_name[reg[0].name].camera_id]
        H, W = mine[0].size  # the model is stored at full resolution
        if in_previews:  # preview pixels → full-resolution pixels: × binning / upscale
            h, w = mine[0].shape
            u = preview_upscale((h, w))
            expect, f = (w * u, h * u), u / mine[0].binning
        else:
            expect, f = (W, H), 1
        if (src.width, src.height) != expect:
            raise CaptureError(
                f"poses give camera {c.folder!r} the size {src.width}×{src.height}; its RAW "
                f"files are {W}×{H}."
            )
        fx, fy, cx, cy = (x / f for x in src.pinhole())
        cams[k + 1] = ColmapCamera(k + 1, "PINHOLE", W, H, (fx, fy, cx, cy))
        for v in reg:
            im = by_name[v.name]
            new_id[im.id] = len(images) + 1
            images[len(images) + 1] = ColmapImage(
                len(images) + 1,
                np.asarray(im.qvec),
                np.asarray(im.tvec),
                k + 1,
                v.name,
                np.asarray(im.xys, float).reshape(-1, 2) / f,
                np.asarray(im.point3D_ids, np.int64),
            )
    pts = {}  # the tracks follow the renumbered images (the train step's depth targets use them)
    for i, p in model.points3D.items():
        keep = np.array([int(j) in new_id for j in p.image_ids], bool)
        ids = np.array([new_id.get(int(j), 0) for j in p.image_ids], np.int64)
        pts[i] = ColmapPoint3D(
            i, p.xyz, p.rgb, p.error, ids[keep], np.asarray(p.point2D_idxs, np.int64)[keep]
        )
    final = ColmapModel(cams, images, pts)
    tmpdir = Path(tempfile.mkdtemp(dir=out, prefix=".poses"))
    write_colmap(final, tmpdir / "model", binary=False)
    (out / "poses").mkdir(parents=True, exist_ok=True)
    if (out / "poses" / "model").exists():
        import shutil

        shutil.rmtree(out / "poses" / "model")
    os.replace(tmpdir / "model", out / "poses" / "model")
    os.rmdir(tmpdir)
    summary = {
        "source": source,
        "cameras": counts,
        "registered": sum(c["registered"] for c in counts.values()),
        "views": len(views),
        "points": len(pts),
        "triangulated": triangulated,
        "seconds": time.perf_counter() - t0,
        "folders": [c.folder for c in spec.cameras],
        "exposures": {v.name: v.exif for v in views},
        "saturated": {v.name: v.n_saturated for v in views if v.n_saturated},
        "dead": {v.name: v.n_dead for v in views if v.n_dead},
        "previews": working_summary(spec, views),
        "duration_s": time.perf_counter() - t0,
        "peak_rss_mib": peak_rss_mib(),
    }
    write_json(done, summary)
    return summary
