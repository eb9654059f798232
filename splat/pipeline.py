"""RAW capture on disk → poses → N-channel Gaussians → renders → colour-corrected images → report.

Each step reads the capture (never writes into it) and what earlier steps left in the output
folder ``OUT``, writes its own files atomically (temporary file + ``os.replace``), and is skipped or
resumed when its results are already there and were made from the same inputs and options:
:class:`splat.workspace.Workspace` owns ``OUT`` (a marker file, a settings record per step, every path
inside ``OUT``) and removes a step's results, and its dependents', when what they were made from
changed. :func:`check_run` refuses bad options and captures before any RAW file is read.

=========  ==========================================================================================
step       writes (under ``OUT``)
=========  ==========================================================================================
poses      ``previews/<folder>/<stem>.png`` (8-bit, developed by :mod:`isp`), ``poses/`` (COLMAP text
           model with image names ``<folder>/<file>``), ``poses/summary.json``
train      ``train/checkpoint.npz`` (resumable), ``train/model.npz``, ``train/summary.json``
render     ``render/<folder>/<stem>/`` ``render.tiff`` (float32, H × W × k, exposure 1),
           ``camera_<folder>.tiff`` per camera, ``pca.png``; for views with a RAW file also
           ``reprojected.tiff`` + ``reprojected_count.tiff`` (the photographs reprojected into the view)
correct    ``correct/<folder>/<stem>/`` ``<method>_XYZ.tiff`` (float32 linear XYZ, white Y = 1),
           ``<method>_sRGB.tiff`` (16-bit) + ``.png``, ``dng_<folder>_sRGB.png`` (each camera's own
           DNG-matrix development of the view), ``correct/summary.json``; for views with a RAW file
           also ``<method>_fused_XYZ.tiff`` / ``_sRGB.tiff`` / ``.png`` (:mod:`splat.fusion`: the view's
           own channels and the other cameras' reprojected photographs — the better estimate wherever
           the view was photographed), ``correct/fusion.json`` (their noise levels), and
           ``full_XYZ.tiff`` + ``full_sRGB.png``: the photograph corrected at its RAW file's full size
           (:mod:`splat.strips`)
report     ``report.html`` (:mod:`splat.report`)
=========  ==========================================================================================

Train, render and the working-resolution part of correct run on every photograph binned to a working
resolution (:mod:`splat.resolution`; ``train_size``); the poses step on previews binned to the automatic
one. Each step's ``summary.json`` (render: ``render/summary.json``) records ``duration_s`` and
``peak_rss_mib``.

``<folder>`` is the camera's folder, or ``camera<k>-<name>`` for a folder outside the capture
(:meth:`splat.capture.CaptureSpec.label`). Ground truth (``truth/``) is never read here;
:mod:`splat.scoring` does that.
"""

from __future__ import annotations

import fnmatch
import functools
import itertools
import json
import os
import tempfile
import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, NamedTuple

import numpy as np

from ._errors import SplatError
from ._tol import FEASIBLE_DISTANCE
from .capture import (
    CaptureError,
    CaptureSpec,
    RawView,
    check_white_box,
    load_views,
    read_capture,
    white_scale,
)
from .strips import FULL_METHOD
from .workspace import Workspace, capture_fingerprint, peak_rss_mib, read_json, reset_peak_rss

if TYPE_CHECKING:
    from zonotope.utilities import ProgressCallback

__all__ = [
    "STEPS",
    "PipelineConfig",
    "XYZ_to_sRGB",
    "check_run",
    "correct_step",
    "depth_targets",
    "fit_step",
    "poses_step",
    "render_step",
    "report_step",
    "run",
    "views_to_render",
]

STEPS = ("poses", "train", "render", "correct", "report")


@dataclass(frozen=True)
class PipelineConfig:
    """Options of the pipeline steps.

    Attributes
    ----------
    steps : int
        Training steps.
    capacity : int
        Gaussian buffer size.
    views : tuple of str or None
        The photographs rendered and corrected: ``"<folder>/<file>"`` names or shell patterns
        (``"canon/*"``); None (default) every registered photograph of every camera, held-out ones
        included — each photograph is what a user wants corrected.
    camera : str or None
        Folder of the camera between whose consecutive registered views the novel views lie; default
        the first camera.
    novel : int
        Novel views rendered between consecutive registered views of ``camera`` (0: none).
    method : str
        ``zonotope.correct`` estimator of the correct step (default Prior).
    quantum : float
        Colour deduplication step of :func:`zonotope.correct.image.correct_image`.
    seed, threads : int
    min_registered : float
        Fraction of each camera's views that must register.
    densify_until : int or None
        Last densification step (default 70 % of ``steps``).
    refine_exposure : bool
        Learn a per-view exposure correction in training (one reference view per camera fixed at its
        EXIF exposure); the factors go to ``train/summary.json``. Off by default: on the simulated
        capture, whose EXIF is exact, a 300-step model drifted 4–10 % away from it (the corrections
        absorb model error), so turn it on only for EXIF that is known to be unreliable.
    refine_poses : bool
        Learn a rigid pose correction per training view jointly with the Gaussians (two reference views,
        the farthest apart, keep the recovered poses; see :func:`splat.train`); the corrections go to
        ``train/summary.json`` and the render step uses them for the training views. Held-out views keep
        their recovered poses (they are never fitted, so nothing refines them).
        Off by default: on the CI-size coarse noise-free capture with pycolmap's poses (1000 steps,
        capacity 4096) it changed the three-camera flat-pixel ΔE00 on held-out views by −0.04 and +0.02
        (two seeds, whose own spread is 0.18) and the training views' rotation error 0.51° → 0.40–0.43°
        (centres 0.0134 → 0.0140 in a 5.9 m arc): no measurable gain at that training length.
    depth_weight : float
        λ of the sparse depth term (:attr:`splat.TrainConfig.depth_weight`, whose default it shares):
        each training view's rendered depth is pulled towards the COLMAP points its track says it
        observes (:func:`depth_targets`; a model without tracks gives none, and the term is off). 0 turns
        it off.
    train_size : int or None
        Longer side (pixels) of the working resolution of the train and render steps: every photograph
        is binned (:mod:`splat.resolution`, CFA-aware) until its longer side is at most this; None
        (default) bins each to at most :data:`splat._tol.TRAIN_PIXEL_BUDGET` pixels. Outputs are made
        at full resolution either way.
    noise : str, float or dict
        Noise of the photographs' own channels in the fused correction: ``"auto"`` (default: the RAW
        file's DNG NoiseProfile, else an estimate from the mosaic), a σ (white → 1 units), or
        ``{"shot": .., "read": ..}`` (variance ``shot · x + read`` at the channel's median level
        ``x``): :func:`zonotope.correct.parse_noise` reads the ``--noise`` text.
    """

    steps: int = 3000
    capacity: int = 4096
    camera: str | None = None
    views: tuple[str, ...] | None = None
    novel: int = 0
    method: str = "Prior"
    quantum: float = 5e-3
    seed: int = 0
    threads: int = -1
    min_registered: float = 0.5
    densify_until: int | None = None
    refine_exposure: bool = False
    refine_poses: bool = False
    depth_weight: float = 13.0
    train_size: int | None = None
    noise: str | float | dict = "auto"

    def __post_init__(self):
        positive = {"steps": self.steps, "capacity": self.capacity}
        for name, value in positive.items():
            if not isinstance(value, int) or value < 1:
                raise SplatError(f"{name}={value!r}: must be a positive integer (e.g. --{name} 3000).")
        if self.views is not None and (
            isinstance(self.views, str) or not self.views or not all(isinstance(v, str) for v in self.views)
        ):
            raise SplatError(
                f"views={self.views!r}: must be a non-empty tuple of names or patterns, or None."
            )
        if not isinstance(self.novel, int) or self.novel < 0:
            raise SplatError(f"novel={self.novel!r}: must be a non-negative integer.")
        if not (np.isfinite(self.quantum) and self.quantum > 0):
            raise SplatError(f"quantum={self.quantum!r}: must be a positive number (default 5e-3).")
        if not (0.0 < self.min_registered <= 1.0):
            raise SplatError(f"min_registered={self.min_registered!r}: must be a fraction in (0, 1].")
        if self.densify_until is not None and self.densify_until < 0:
            raise SplatError(f"densify_until={self.densify_until!r}: must be ≥ 0 or None.")
        w = self.depth_weight
        if not isinstance(w, int | float) or not np.isfinite(w) or w < 0:
            raise SplatError(f"depth_weight={w!r}: must be a finite number ≥ 0 (0 turns the depth term off).")
        t = self.train_size
        if t is not None and (isinstance(t, bool) or not isinstance(t, int) or t < 16):
            raise SplatError(f"train_size={t!r}: must be a number of pixels ≥ 16 (e.g. --train-size 640).")
        _noise_of(self.noise)


def _noise_of(noise):
    """The ``noise`` option checked: ``"auto"``, a σ ≥ 0, or shot and read variances ≥ 0."""
    ok = noise == "auto"
    if isinstance(noise, int | float) and not isinstance(noise, bool):
        ok = bool(np.isfinite(noise) and noise >= 0)
    if isinstance(noise, dict):
        vals = [noise.get("shot"), noise.get("read")]
        ok = set(noise) == {"shot", "read"} and all(
            isinstance(v, int | float) and np.isfinite(v) and v >= 0 for v in vals
        )
    if not ok:
        raise SplatError(
            f"noise={noise!r}: give 'auto', a σ such as 0.005, or SHOT:READ such as 2.5e-5:0 (--noise)."
        )
    return noise


def train_size_of(spec: CaptureSpec, config: PipelineConfig) -> int | None:
    """The working resolution's longer side: ``config.train_size`` (``--train-size``), else the capture
    file's ``train_size``, else None (automatic)."""
    return config.train_size if config.train_size is not None else spec.train_size


def working_binning(config: PipelineConfig, spec: CaptureSpec | None = None):
    """``binning(k, shape, full_colour) → f`` of the train, render and correct steps
    (:func:`splat.resolution.working_factor` with :func:`train_size_of`)."""
    from .resolution import working_factor

    size = config.train_size if spec is None else train_size_of(spec, config)
    return lambda k, shape, full: working_factor(shape, full, size=size)


def preview_binning(k, shape, full) -> int:
    """The binning of the poses step's previews: the automatic working resolution (bounded whatever
    ``train_size`` says, so that poses never depend on it)."""
    from .resolution import working_factor

    return working_factor(shape, full)


def working_views(views, raws: dict) -> list:
    """``views`` (:class:`splat.data.View`, full-resolution cameras) with each camera scaled to its
    photograph's working resolution (``raws``: name → :class:`splat.capture.RawView` as read with
    :func:`working_binning`; :func:`splat.resolution.scale_camera`)."""
    import dataclasses

    from .resolution import scale_camera

    out = []
    for v in views:
        r = raws.get(v.name)
        f = 1 if r is None else r.binning
        out.append(v if f == 1 else dataclasses.replace(v, camera=scale_camera(v.camera, f)))
    return out


def working_summary(spec: CaptureSpec, raws) -> dict:
    """Per camera folder: full and working size, binning factor, sites averaged per channel and how much
    that lowers each channel's noise σ (√ of the sites), for the step summaries and stdout."""
    from .resolution import sites_per_block

    doc = {}
    for v in raws:
        c = spec.cameras[v.camera].folder
        if c in doc:
            continue
        f = v.binning
        n = sites_per_block(v.source_cfa, f) if f > 1 else np.ones(3)
        doc[c] = {
            "full": [int(v.size[1]), int(v.size[0])],
            "working": [int(v.shape[1]), int(v.shape[0])],
            "binning": int(f),
            "sites_per_channel": [int(x) for x in n],
            "noise_sigma_divided_by": [round(float(np.sqrt(x)), 2) for x in n],
        }
    return doc


# ---------------------------------------------------------------------------------------------
# small helpers
# ---------------------------------------------------------------------------------------------


def _atomic(path: Path, write: Callable[[Path], object]) -> Path:
    """Write through a temporary sibling and rename (zonotope's shared atomic writer)."""
    from zonotope.utilities import atomic_path

    return atomic_path(path, write)


def _write_json(path: Path, doc) -> Path:
    return _atomic(path, lambda p: p.write_text(json.dumps(doc, indent=1, default=float)))


def _write_tiff(path: Path, a: np.ndarray) -> Path:
    import tifffile

    a = np.asarray(a, np.float32)
    if not np.all(np.isfinite(a)):
        raise SplatError(f"{path}: refusing to write NaN/inf values.")
    return _atomic(
        path, lambda p: tifffile.imwrite(p, a, photometric="minisblack", planarconfig="contig", metadata=None)
    )


def _write_png8(path: Path, rgb: np.ndarray, *, upscale: int = 1) -> Path:
    from PIL import Image

    img = Image.fromarray((np.clip(rgb, 0, 1) * 255 + 0.5).astype(np.uint8))
    if upscale > 1:
        img = img.resize((img.width * upscale, img.height * upscale), Image.Resampling.BICUBIC)
    return _atomic(path, lambda p: img.save(p, format="PNG"))


def preview_upscale(shape: tuple[int, int]) -> int:
    """Integer factor that brings a small image's shorter side to ≥ 400 px for SIFT (1 to 4)."""
    return int(min(4, max(1, np.ceil(400 / min(shape)))))


def check_run(spec: CaptureSpec, config: PipelineConfig) -> None:
    """Everything a run needs that can be checked before any RAW file is read: two or more cameras, the
    observer, the illuminant, every camera's SSF, the correction method and ``config.camera``.

    Why: a run that trains for minutes must not fail on an option it could have refused at once.

    Raises
    ------
    CaptureError, zonotope.UnknownMethodError
        One line naming the value and what is allowed.
    """
    import zonotope
    from zonotope.correct import CORRECTION_METHODS

    if len(spec.cameras) < 2:
        raise CaptureError(
            f"{spec.file}: one camera ({spec.cameras[0].folder!r}); splat fuses the photographs of several "
            "cameras. For one camera's photographs use `isp develop FOLDER -o OUT --correction metamer` "
            "(and `isp profile` for a camera profile)."
        )
    try:
        zonotope.observer(spec.observer)
    except (KeyError, ValueError, OSError) as e:
        raise CaptureError(
            f"{spec.file}: observer = {spec.observer!r} is not a built-in observer "
            f"(e.g. 'CIE 1931 2 Degree Standard Observer'): {' '.join(str(e).split())}"
        ) from e
    spec.load_illuminant()
    for k in range(len(spec.cameras)):
        spec.load_ssf(k)
    CORRECTION_METHODS.resolve(config.method, argument="method")
    if config.camera is not None:
        spec.camera_index(config.camera)
    if config.views is not None:
        names = [f"{c.folder}/{p.name}" for k, c in enumerate(spec.cameras) for p in spec.raw_files(k)]
        for pattern in config.views:
            if not any(fnmatch.fnmatchcase(n, pattern) for n in names):
                raise CaptureError(
                    f"--views {pattern!r} names no photograph of the capture; names are "
                    f'"<folder>/<file>", e.g. {names[:3]}.'
                )


def _workspace(capture, out, config: PipelineConfig, step: str | None = None, settings=None):
    """The checked capture and its :class:`splat.workspace.Workspace`, with ``step`` begun there on
    ``settings(spec)`` when both are given."""
    spec = read_capture(capture)
    check_run(spec, config)
    ws = Workspace(spec, out)
    if step is not None:
        ws.begin(step, settings(spec))
    return spec, ws


def _train_settings(spec: CaptureSpec, config: PipelineConfig) -> dict:
    return {
        "holdout": sorted(spec.holdout),
        "train_size": train_size_of(spec, config),
        **{
            f: getattr(config, f)
            for f in (
                "steps",
                "capacity",
                "seed",
                "densify_until",
                "refine_exposure",
                "refine_poses",
                "depth_weight",
            )
        },
    }


def read_index(spec: CaptureSpec, path: Path) -> dict:
    """``render/index.json``: view name → {camera, kind, dir}, each ``dir`` the view's own folder
    (:meth:`splat.capture.CaptureSpec.out_stem`), so that no path read from the file leads elsewhere."""
    index = read_json(path, what="render index")
    for name, info in index.items():
        try:
            ok = isinstance(info, dict) and info.get("dir") == spec.out_stem(name) and "kind" in info
        except CaptureError:
            ok = False
        if not ok:
            raise CaptureError(
                f"{path}: not a render index of this capture (entry {name!r}); run the render step."
            )
    return index


def XYZ_to_sRGB(XYZ, white_XYZ) -> np.ndarray:
    """XYZ (white ``white_XYZ``, Y = 1) → sRGB-encoded values in [0, 1] (Bradford to D65, clipped).

    Parameters
    ----------
    XYZ : array_like of shape (..., 3)
    white_XYZ : array_like of shape (3,)
    """
    import colour

    srgb = colour.RGB_COLOURSPACES["sRGB"]
    w = np.asarray(white_XYZ, float)
    rgb = colour.XYZ_to_RGB(
        np.asarray(XYZ, float),
        srgb,
        illuminant=colour.XYZ_to_xy(w),
        chromatic_adaptation_transform="Bradford",
    )
    return np.asarray(colour.models.eotf_inverse_sRGB(np.clip(rgb, 0, 1)))


def _preview(v: RawView, white: np.ndarray) -> np.ndarray:
    """8-bit-ready sRGB-ish preview of a linear mosaic: isp bilinear demosaic, SSF white balance,
    exposure normalised, sRGB transfer curve."""
    from isp.stages import demosaic, encode_sRGB

    img = (
        v.values.astype(np.float64)
        if v.full_colour
        else demosaic(v.values.sum(-1), cfa=v.cfa, method="bilinear")
    )
    img = np.maximum(img, 0) / white / max(v.exif, 1e-9)
    img = img / max(np.percentile(img, 99.5), 1e-9)
    return encode_sRGB(np.clip(img, 0, 1))


# ---------------------------------------------------------------------------------------------
# step 1: poses
# ---------------------------------------------------------------------------------------------


def poses_step(
    capture: str | os.PathLike,
    out: str | os.PathLike,
    *,
    config: PipelineConfig = PipelineConfig(),
    progress: ProgressCallback | None = None,
) -> dict:
    """Recover (or read) the poses of every RAW file; one COLMAP camera per physical camera.

    Returns
    -------
    dict
        The summary written to ``poses/summary.json``: registered views per camera, source.

    Raises
    ------
    CaptureError
        A camera whose views do not register (fewer than ``min_registered`` of them, or fewer than 2).
    """
    from .colmap import ColmapCamera, ColmapImage, ColmapModel, ColmapPoint3D, read_colmap, write_colmap
    from .data import read_transforms
    from .poses import PoseConfig, recover_poses

    spec, ws = _workspace(
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
    # previews of a bounded size: each file read and binned to the automatic working resolution
    views = load_views(spec, progress=progress, binning=preview_binning)
    check_white_box(spec, views)
    names = [v.name for v in views]
    if spec.colmap is not None or spec.transforms is not None:
        source = "colmap" if spec.colmap is not None else "transforms"
        if spec.colmap is not None:
            model = read_colmap(spec.colmap)
        else:
            from .data import colmap_from_capture

            model = colmap_from_capture(read_transforms(spec.transforms))
        by_name = {im.name: im for im in model.images.values()}
    else:
        source = "pycolmap"
        from .capture import camera_white

        whites = [camera_white(spec, k) for k in range(len(spec.cameras))]
        for i, v in enumerate(views):
            path = ws.path("previews", f"{spec.out_stem(v.name)}.png")
            if not path.is_file():
                _write_png8(path, _preview(v, whites[v.camera]), upscale=preview_upscale(v.shape))
            if progress is not None:
                progress("previews", i + 1, len(views))
        if progress is not None:
            progress("colmap", 0, 1)
        work = out / "poses" / "colmap"
        model = recover_poses(
            out / "previews",
            work,
            config=PoseConfig(num_threads=config.threads, seed=config.seed, max_image_size=-1),
        )
        by_name = {}
        for im in model.images.values():
            stem = Path(im.name)
            raw = next(
                (n for n in names if spec.out_stem(n) == f"{stem.parent.as_posix()}/{stem.stem}"), None
            )
            if raw is not None:
                by_name[raw] = im
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
        if source == "pycolmap":  # preview pixels → full-resolution pixels: × binning / upscale
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
        "seconds": time.perf_counter() - t0,
        "folders": [c.folder for c in spec.cameras],
        "exposures": {v.name: v.exif for v in views},
        "saturated": {v.name: v.n_saturated for v in views if v.n_saturated},
        "dead": {v.name: v.n_dead for v in views if v.n_dead},
        "previews": working_summary(spec, views),
        "duration_s": time.perf_counter() - t0,
        "peak_rss_mib": peak_rss_mib(),
    }
    _write_json(done, summary)
    return summary


# ---------------------------------------------------------------------------------------------
# step 2: train
# ---------------------------------------------------------------------------------------------


def _load_model_capture(spec: CaptureSpec, out: Path):
    """The registered views as a :class:`Capture` (camera id k + 1 = capture camera k) and the model."""
    from .colmap import read_colmap
    from .data import capture_from_colmap

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
    spec: CaptureSpec, out: Path, config: PipelineConfig = PipelineConfig()
) -> TrainingInputs:
    """The inputs of the train step, read from the capture and ``OUT/poses`` (no ground truth).

    Views of different sizes are padded (right and bottom, weight 0) to the largest size so that they
    stack; a view's intrinsics are unchanged by the padding.
    """
    from .camera import Camera
    from .data import Capture

    model, cap = _load_model_capture(spec, out)
    # each file read and binned to the working resolution in turn (never all mosaics whole at once)
    raws = {v.name: v for v in load_views(spec, binning=working_binning(config, spec))}
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
    xyz, rgb, bounds = _scene_points(model, [v.camera for v in views])
    valid = weights > 0
    level = float(np.median(images[valid])) if valid.any() else 0.2
    colours = None
    if xyz is not None:
        xyz, colours = _initial_points(xyz, rgb, level, config.capacity, N, seed=config.seed)
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


def _scene_points(model, cameras):
    """The COLMAP points for the initial Gaussians (all of them), their preview colours and the scene's
    bounds: the 2–98th percentile box of each coordinate, padded by 10 % (it sets the scale of the
    centres' learning rate, so a few stray points must not widen it).

    Every point starts a Gaussian, as in 3DGS: the scene's periphery — a backdrop, the far floor — is seen
    by few views, holds few points and lies partly outside the percentile box, and densification cannot
    fill a region where nothing starts (the box used to filter the points too, and on the benchmark
    capture the Gaussians cloned towards the backdrop settled 1–3 m in front of it). With fewer than 8
    points, ``(None, None, bounds)`` around the camera centres."""
    xyz, rgb = model.points()
    if len(xyz) >= 8:
        lo, hi = np.percentile(xyz, 2, axis=0), np.percentile(xyz, 98, axis=0)
        return xyz, rgb, np.stack([lo - 0.1 * (hi - lo), hi + 0.1 * (hi - lo)])
    centres = np.array([np.asarray(c.centre) for c in cameras])
    lo, hi = centres.min(0), centres.max(0)
    return None, None, np.stack([lo - 0.1 * (hi - lo), hi + 0.1 * (hi - lo)])


def _initial_points(xyz, rgb, level: float, capacity: int, n_channels: int, *, seed: int = 0):
    """The Gaussians' starting centres and colours: a seeded random half-capacity subset of the COLMAP
    points, each grey at the median measured value ``level`` scaled by its preview luminance relative to
    the subset's median. Returns ``(xyz (P, 3), colours (P, n_channels))``."""
    take = np.random.default_rng(seed).permutation(len(xyz))[: capacity // 2]
    lum = (np.asarray(rgb)[take].astype(float) / 255) ** 2.2
    lum = lum.mean(1) / max(np.median(lum.mean(1)), 1e-6)
    return np.asarray(xyz)[take], np.clip(level * lum, 1e-3, 1)[:, None] * np.ones(n_channels)


def train_config(config: PipelineConfig, checkpoint: Path | None = None):
    """The :class:`splat.training.TrainConfig` of the train step for a pipeline configuration."""
    from .training import TrainConfig

    until = config.densify_until if config.densify_until is not None else int(0.7 * config.steps)
    return TrainConfig(
        steps=config.steps,
        capacity=config.capacity,
        checkpoint=checkpoint,
        checkpoint_every=max(50, config.steps // 10),
        seed=config.seed,
        densify_from=min(200, config.steps // 5),
        densify_until=until,
        densify_every=max(25, min(100, config.steps // 20)),
        # grow by up to 30 % of the alive Gaussians per densification (TrainConfig's 5 % filled a 4096
        # buffer from COLMAP's few hundred points only after thousands of steps): the trained model
        # underfits its own training views (flat-pixel error 3.5 % on training views, 4 % held out), and
        # filling the buffer early took three-camera flat ΔE00 at 1000 steps from 2.43 to 2.01
        densify_fraction=0.3,
        refine_exposure=config.refine_exposure,
        refine_poses=config.refine_poses,
        depth_weight=config.depth_weight,
    )


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

    from .training import train

    spec, ws = _workspace(capture, out, config, "train", lambda spec: _train_settings(spec, config))
    out = ws.root
    done = out / "train" / "summary.json"
    if done.is_file() and (out / "train" / "model.npz").is_file():
        return read_json(done)
    inp = training_inputs(spec, out, config)
    train_cap, images, weights = inp.capture, inp.images, inp.weights
    bounds, xyz, colours = inp.bounds, inp.points, inp.colours
    views, padded, N = inp.views, list(train_cap.views), train_cap.n_channels
    tc = train_config(config, out / "train" / "checkpoint.npz")
    resume = tc.checkpoint if Path(tc.checkpoint).is_file() else None
    t0 = time.perf_counter()
    reset_peak_rss()

    def cb(step, state, loss):
        if progress is not None and (step % 10 == 0 or step == config.steps):
            progress("train", step, config.steps)

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
    from .camera import pose_corrected
    from .outputs import render_views

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
    _atomic(out / "train" / "model.npz", lambda p: np.savez(p, alive=np.asarray(res.alive), **params))
    loss = np.asarray(res.history["loss"], float)
    summary = {
        "steps": config.steps,
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
    summary["duration_s"] = time.perf_counter() - t0
    summary["peak_rss_mib"] = peak_rss_mib()
    _write_json(done, summary)
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

    from .camera import Camera, pose_corrected

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
    from .gaussians import Gaussians

    path = Path(out) / "train" / "model.npz"
    if not path.is_file():
        raise CaptureError(f"{path}: no trained model; run the train step first.")
    from .training import read_arrays

    arrays = read_arrays(path, what="model")
    try:
        return Gaussians.from_numpy(arrays), arrays["alive"]
    except (KeyError, ValueError, TypeError) as e:
        raise CaptureError(
            f"{path}: not a splat model ({type(e).__name__}); run the train step again."
        ) from e


# ---------------------------------------------------------------------------------------------
# step 3: render
# ---------------------------------------------------------------------------------------------


def _novel_cameras(views, n: int):
    """``n`` cameras between each pair of consecutive views (centre lerp, rotation slerp)."""
    from scipy.spatial.transform import Rotation, Slerp

    from .camera import Camera

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


def _reprojected_view(name, cam, views, raws, g, alive, depths: dict, n: int):
    """Every camera's photographs (other than ``name`` itself) reprojected into the view through the
    splat's depth, moved along each ray to where the photographs agree
    (:func:`splat.reproject.consistent_depth`), and combined by :func:`splat.reproject.reprojected`
    with each photograph's noise variance (:func:`splat.fusion.photo_variance`): values (H, W, 3n) at
    exposure 1 (0 where no photograph of that camera sees the pixel) and the number of photographs that
    see it (H, W, n)."""
    from .fusion import measured, photo_variance
    from .reproject import MIN_ALPHA, consistent_depth, depth_map, reprojected

    def depth(v_name, c):  # the cache also holds each photograph, demosaiced, at exposure 1
        if v_name not in depths:
            r = raws.get(v_name)
            # bilinear, not Malvar: a source is read near its own edges, where Malvar overshoots
            # (three cameras fused, CI coarse capture, flat held-out pixels: 0.497 → 0.460 ΔE00 noise-free,
            # 1.392 → 1.368 noisy)
            ok = r is not None and r.exif is not None
            photo = measured(r, np.ones(3), method="bilinear") if ok else None
            var = photo_variance(r, photo) if ok else None
            dep, alpha = depth_map(g, c, mask=alive)
            # as a source, a pixel without a reliable depth vouches for nothing (0 never agrees)
            depths[v_name] = (dep, alpha, photo, np.where(alpha >= MIN_ALPHA, dep, 0.0), var)
        return depths[v_name]

    d, a, *_ = depth(name, cam)
    groups = []  # each camera's photographs (but the view's own), as reprojection sources
    for k in range(n):
        groups.append([])
        for v in views:
            r = raws.get(v.name)
            if v.name != name and r is not None and r.camera == k and r.exif is not None:
                _, _, photo, seen_depth, var = depth(v.name, v.camera)
                groups[k].append((v.camera, seen_depth, photo, var))
    if any(len(g) >= 2 for g in groups):  # the splat's depth moved to where the photographs agree
        d, _ = consistent_depth(cam, d, a, groups)
    values = np.zeros((cam.height, cam.width, 3 * n), np.float32)
    count = np.zeros((cam.height, cam.width, n), np.float32)
    for k, sources in enumerate(groups):
        if sources:
            values[..., 3 * k : 3 * k + 3], count[..., k] = reprojected(cam, d, a, sources)
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
    reproject every camera's photographs (but the view's own) into each of them through the splat's depth
    (``reprojected.tiff``, 0 where none sees a pixel, and ``reprojected_count.tiff``, how many see it;
    :mod:`splat.reproject`).

    Returns
    -------
    dict
        ``views``: name → {camera folder, kind ("holdout" / "view" / "novel"), files}.
    """
    from .outputs import pca_false_colour, render_views, split_cameras

    spec, ws = _workspace(capture, out, config, "render", lambda spec: {})
    out = ws.root
    t0 = time.perf_counter()
    reset_peak_rss()
    _, cap = _load_model_capture(spec, out)
    g, alive = load_gaussians(out)
    raws = {v.name: v for v in load_views(spec, binning=working_binning(config, spec))}
    # at the working resolution; training views with their learned pose corrections, if any
    views = refined_views(working_views(cap.views, raws), out)
    todo = views_to_render(spec, views, config)
    n = len(spec.cameras)
    depths: dict = {}  # view name → (depth, alpha, photograph, source depth, variance), computed once
    index = {}
    rendered = 0  # views rendered or reprojected by this call
    for i, (name, cam, cid, kind) in enumerate(todo):
        d = ws.view_dir("render", name)
        files = {"render": d / "render.tiff", "pca": d / "pca.png"}
        rendered += not all(p.is_file() for p in [*files.values(), d / "reprojected_count.tiff"])
        if not all(p.is_file() for p in files.values()):
            img = render_views(g, [cam], mask=alive)[0]
            _write_tiff(files["render"], img)
            for cid2, part in split_cameras(img, cap).items():
                _write_tiff(d / f"camera_{spec.label(cid2 - 1)}.tiff", part)
            _write_png8(files["pca"], pca_false_colour(img))
        if not (d / "reprojected_count.tiff").is_file():
            rep, count = _reprojected_view(name, cam, views, raws, g, alive, depths, n)
            _write_tiff(d / "reprojected.tiff", rep)
            _write_tiff(d / "reprojected_count.tiff", count)  # written last: marks the pair complete
        index[name] = {"camera": spec.cameras[cid - 1].folder, "kind": kind, "dir": spec.out_stem(name)}
        if progress is not None:
            progress("render", i + 1, len(todo))
    _write_json(out / "render" / "index.json", index)
    if rendered or not (out / "render" / "summary.json").is_file():  # a call that reused every view
        _write_json(  # keeps the summary of the call that did the work
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


# ---------------------------------------------------------------------------------------------
# step 4: correct
# ---------------------------------------------------------------------------------------------


def _read_tiff(path: Path) -> np.ndarray:
    import tifffile

    return np.asarray(tifffile.imread(path), np.float64)


def white_of(spec: CaptureSpec, out: Path, views: list[RawView] | None = None) -> dict:
    """The white → 1 scale (:func:`splat.capture.white_scale`), cached in ``OUT/correct/white.json``."""
    path = out / "correct" / "white.json"
    if path.is_file():
        d = read_json(path, what="white scale")
        d["scale"] = [np.asarray(s) for s in d["scale"]]
        return d
    d = white_scale(spec, views if views is not None else load_views(spec))
    _write_json(
        path, {k: [np.asarray(x).tolist() for x in v] if isinstance(v, list) else v for k, v in d.items()}
    )
    d["scale"] = [np.asarray(s) for s in d["scale"]]
    return d


def correction_problem_of(spec: CaptureSpec, cameras: list[int]):
    """``zonotope.correct.CorrectionProblem`` of a subset of the capture's cameras (10 nm grid,
    400–700 nm narrowed to the curves' common range, training set rawtoaces 190)."""
    import zonotope
    from zonotope.correct import correction_problem

    curves = [spec.load_ssf(k) for k in cameras]
    light = spec.load_illuminant()
    obs = zonotope.observer(spec.observer)
    common = zonotope.common_shape(*curves, obs, light, interval=10)
    shape = np.arange(max(common.start, 400.0), min(common.end, 700.0) + 5, 10.0)
    return correction_problem(
        curves, target=spec.observer, illuminant=light, shape=shape, training="rawtoaces 190"
    )


def noise_sigma(out: Path, scale: np.ndarray) -> float:
    """RMS training residual on the white → 1 scale, median over channels (for the report)."""
    s = read_json(out / "train" / "summary.json").get("residual_sigma_raw")
    if s is None:
        raise CaptureError(
            f"{out / 'train' / 'summary.json'}: not a splat train summary (no residual_sigma_raw)."
        )
    return float(np.median(np.asarray(s) / scale))


def choose_delta(
    problem,
    responses: np.ndarray,
    *,
    n: int = 200,
    percentile: float = 95.0,
    floor: float = 1e-3,
    seed: int = 0,
) -> dict:
    """The MMV noise tolerance δ: the ``percentile`` of the max-norm distances from a sample of the
    responses to the object-colour solid (at least ``floor``).

    Stacked cameras' rendered responses are rarely exactly consistent (sensor noise averaged over views,
    model error, SSF calibration); δ is the smallest tolerance that makes ``percentile`` % of them
    feasible. The rest (counted in ``beyond_delta``) go to zonotope's ``on_infeasible="nearest"``.

    Parameters
    ----------
    problem : zonotope.correct.CorrectionProblem
    responses : array_like of shape (..., k)
        White → 1 responses.

    Returns
    -------
    dict
        ``delta``, ``sampled``, ``outside`` (share off the solid), ``beyond_delta``, ``max_distance``.
    """
    from zonotope import distance_to_zonotope

    flat = np.asarray(responses, float).reshape(-1, problem.k)
    rng = np.random.default_rng(seed)
    pick = flat[rng.choice(len(flat), min(n, len(flat)), replace=False)]
    d = np.array([distance_to_zonotope(problem.Phi, np.zeros(problem.k), c)[0] for c in pick])
    delta = max(float(np.percentile(d, percentile)), floor) if d.size else floor
    return {
        "delta": delta,
        "sampled": len(pick),
        "outside": float(np.mean(d > FEASIBLE_DISTANCE)),
        "beyond_delta": float(np.mean(d > delta)),
        "max_distance": float(d.max()) if d.size else 0.0,
        "rule": f"{percentile:g}th percentile of the distances of {len(pick)} sampled responses to the "
        f"object-colour solid (max-norm, white = 1), at least {floor:g}",
    }


def delta_of(spec: CaptureSpec, out: Path, index: dict, scale: np.ndarray) -> dict:
    """δ of :func:`choose_delta` on responses pooled from every rendered view, cached in
    ``OUT/correct/delta.json`` (so resumed runs and scoring use the same δ)."""
    path = out / "correct" / "delta.json"
    if path.is_file():
        return read_json(path, what="noise tolerance")
    rng = np.random.default_rng(0)
    pool = []
    for info in index.values():
        img = np.maximum(_read_tiff(out / "render" / info["dir"] / "render.tiff") / scale, 0).reshape(
            -1, scale.size
        )
        pool.append(img[rng.choice(len(img), min(len(img), 2000), replace=False)])
    tol = choose_delta(correction_problem_of(spec, list(range(len(spec.cameras)))), np.concatenate(pool))
    _write_json(path, tol)
    return tol


def fusion_of(spec: CaptureSpec, out: Path, index: dict, raws: dict, scale: np.ndarray) -> dict:
    """The noise levels of the fused correction (:mod:`splat.fusion`), in ``OUT/correct/fusion.json``.

    Cached, so that resumed runs and scoring use the same; white → 1 units:

    - ``render_sigma``: the render's error after anchoring (:func:`splat.fusion.render_noise` over every
      rendered view that has a RAW file);
    - ``reprojected_sigma``: per camera, the error of its photographs reprojected into another of its
      views (``render/<view>/reprojected.tiff``) against that view's measured sites (the mosaic itself,
      not demosaiced) where the view's render is smooth (:func:`splat.fusion.smooth`), each site's own
      noise removed (:func:`splat.fusion.reprojection_noise` with :func:`splat.fusion.site_noise`),
      pooled over the camera's rendered views; at least :data:`splat.fusion.OWN_NOISE_FLOOR`; a camera
      without such a view gets the largest of the others; ``reprojected_sites``: how many residuals
      each estimate rests on (1 300–3 400 per camera on the CI coarse captures);
    - per view with a RAW file, ``own_sigma``: its sensor noise per channel
      (:func:`splat.fusion.sensor_noise`, at least :data:`splat.fusion.OWN_NOISE_FLOOR`).

    Each to two significant digits (:func:`_two_digits`).

    Empty ``views`` when no rendered view has a RAW file.
    """
    from .fusion import (
        OWN_NOISE_FLOOR,
        measured,
        render_noise,
        reprojection_noise,
        sensor_noise,
        site_noise,
        sites,
        smooth,
    )

    path = out / "correct" / "fusion.json"
    if path.is_file():
        return read_json(path, what="fusion record")
    n = len(spec.cameras)
    pairs, views, resid = [], {}, {}
    for name, info in index.items():
        v = raws.get(name)
        if v is None or v.exif is None:
            continue
        k = v.camera
        ws = scale[3 * k : 3 * k + 3]
        d = out / "render" / info["dir"]
        img = _read_tiff(d / "render.tiff") / scale
        m = measured(v, ws)
        pairs.append((img[..., 3 * k : 3 * k + 3], m))
        own = np.maximum(sensor_noise(v, ws), OWN_NOISE_FLOOR)
        views[name] = {"camera": k, "own_sigma": [_two_digits(x) for x in own]}
        if (d / "reprojected_count.tiff").is_file():
            seen = _read_tiff(d / "reprojected_count.tiff")[..., k] > 0
            rep = _read_tiff(d / "reprojected.tiff")[..., 3 * k : 3 * k + 3] / ws
            # at the measured sites themselves (no demosaicing), where the render is smooth
            mosaic, at = sites(v, ws)
            at &= (seen & smooth(img))[..., None]
            resid.setdefault(k, []).append(((rep - mosaic)[at], site_noise(v, ws)[at]))
    rep_sigma = {
        k: _two_digits(
            max(
                reprojection_noise(np.concatenate([a for a, _ in r]), np.concatenate([b for _, b in r])),
                OWN_NOISE_FLOOR,
            )
        )
        for k, r in resid.items()
    }
    worst = max(rep_sigma.values(), default=None)
    doc = {
        "render_sigma": _two_digits(render_noise(pairs)) if pairs else None,
        "reprojected_sigma": [rep_sigma.get(k, worst) for k in range(n)] if rep_sigma else None,
        "reprojected_sites": [int(sum(a.size for a, _ in resid.get(k, []))) for k in range(n)],
        "own_noise_floor": OWN_NOISE_FLOOR,
        "channels": 3 * n,
        "views": views,
        "rule": "own channels: the RAW file's sensor noise (at least own_noise_floor); reprojected "
        "photographs: their error against the measured sites of each camera's own views where the "
        "render is smooth, less the sites' own noise; rendered channels: the render's "
        "leave-one-channel-out error after anchoring, pooled over views and cameras",
    }
    _write_json(path, doc)
    return doc


def _two_digits(x: float) -> float:
    """``x`` to two significant digits: the noise estimates are no better, and views whose noise agrees
    to that share one fitted estimator (each fit costs seconds)."""
    return float(f"{float(x):.2g}")


def fused_view(
    fusion: dict,
    name: str,
    render: np.ndarray,
    view: RawView,
    scale: np.ndarray,
    cameras,
    reprojected=None,
    *,
    texture_rtol: float | None = None,
):
    """Fused responses of a view with a RAW file, restricted to ``cameras`` (which must include the
    view's own), and their per-channel noise.

    The own channels are measured (where the camera's other photographs see the pixel, the
    inverse-variance mean of the measurement and their reprojection: noise is averaged, a noise-free
    photograph keeps most of its weight); another camera's channels are its photographs reprojected into
    the view where any sees the pixel (``reprojected``: values (H, W, 3n) white → 1 and counts (H, W, n),
    all cameras, as the render step writes them), else the render anchored to the photograph. Every
    camera's reprojection (the view's own camera's too) is first re-read by
    :func:`splat.fusion.guided`, guided by the view's photograph. Its σ stays the unfiltered
    reprojection's (``fusion_of``): an upper bound, as the filter averages noise.

    Where the photograph is **textured** (:func:`splat.fusion.textured`, with the view's ``own_sigma``
    as the noise) none of that holds: a reprojection misplaced by a fraction of a pixel, or a channel
    demosaiced across a 1–2 px border, is off by the step itself, not by its σ. There the responses
    are the render anchored to the pixel's own measured site (:func:`splat.fusion.anchor` with the
    mosaic's sites: no demosaicing, no reprojection), σ the sensor's for the measured channel(s) and
    the render's for all others. On the benchmark capture this took the all-pixel ΔE00 of three
    cameras from 8.08 to 3.90 (README).

    Parameters
    ----------
    texture_rtol : float, optional
        :func:`splat.fusion.textured`'s threshold (default :data:`splat._tol.TEXTURE_RTOL`);
        ``float("inf")`` turns the texture test off.

    Returns
    -------
    fused : ndarray of shape (H, W, 3·len(cameras))
    code : ndarray of shape (H, W), int
        Below ``2**m`` (``m = len(cameras)``): bit ``i`` set where ``cameras[i]``'s reprojected
        photographs enter (for the view's own camera: are averaged with its measurement). A textured
        pixel has bit ``m`` set and, from bit ``m + 1``, which of the own camera's three channels its
        site measured.
    sigma : dict
        ``code`` → σ per channel (3·len(cameras),).
    """
    from .fusion import TEXTURE_RTOL, anchor, guided, guided_demosaic, measured, sites, textured

    k = view.camera
    cameras = list(cameras)
    if k not in cameras:
        raise SplatError(f"{name}: its camera is not among the cameras {cameras} to fuse.")
    idx = [3 * c + j for c in cameras for j in range(3)]
    pos = 3 * cameras.index(k)
    own = slice(pos, pos + 3)
    valid = np.asarray(view.weight).sum(-1) > 0  # the pixel's own site is neither saturated nor dead
    ws = scale[3 * k : 3 * k + 3]
    photo = measured(view, ws)
    rep_sigma = fusion.get("reprojected_sigma")
    use = reprojected is not None and rep_sigma is not None
    own_photo = photo
    if use:
        raw_values, count = reprojected
        raw_values = np.asarray(raw_values, float)

        seen_by = {c: count[..., c] > 0 for c in cameras if (count[..., c] > 0).any()}

        def reread(c, guide):  # camera c's reprojection re-read where the view's photograph puts it
            return guided(raw_values[..., 3 * c : 3 * c + 3], seen_by[c], guide)

        others = [c for c in seen_by if c != k]
        if others and not view.full_colour:  # the own mosaic demosaiced with the other cameras' help
            seen = np.stack([seen_by[c] for c in others])
            trip = np.stack([reread(c, photo) for c in others])
            n_seen = seen.sum(0)[..., None]
            mean = np.where(n_seen > 0, (trip * seen[..., None]).sum(0) / np.maximum(n_seen, 1), photo)
            own_photo = guided_demosaic(view, ws, np.concatenate([mean, photo], -1))
        values = raw_values.copy()  # re-read with the sharpest photograph of the view as the guide
        for c in seen_by:
            values[..., 3 * c : 3 * c + 3] = reread(c, own_photo)
    fused = anchor(render[..., idx], own_photo, own, valid)
    code = np.zeros(fused.shape[:2], int)
    if use:
        m_own = fused[..., own].copy()
        s_own = np.asarray(fusion["views"][name]["own_sigma"], float)
        s_rep = float(rep_sigma[k])
        for i, c in enumerate(cameras):
            seen = count[..., c] > 0
            if c == k:  # inverse-variance mean of the measurement and the camera's other photographs
                wm, wr = 1 / s_own**2, 1 / s_rep**2
                comb = (wm * m_own + wr * np.maximum(values[..., 3 * c : 3 * c + 3], 0)) / (wm + wr)
                fused[..., own] = np.where(seen[..., None] & valid[..., None], comb, m_own)
                code |= (seen & valid).astype(int) << i
                continue
            fused[..., 3 * i : 3 * i + 3] = np.where(
                seen[..., None], np.maximum(values[..., 3 * c : 3 * c + 3], 0), fused[..., 3 * i : 3 * i + 3]
            )
            code |= seen.astype(int) << i
    rtol = TEXTURE_RTOL if texture_rtol is None else texture_rtol
    m = len(cameras)
    so = np.asarray(fusion["views"][name]["own_sigma"], float)
    tex = textured(view, ws, rtol=rtol, noise=so) & valid if np.isfinite(rtol) else np.zeros_like(valid)
    if tex.any():  # the render anchored to the pixel's own site(s): no demosaicing, no reprojection
        mosaic, at = sites(view, ws)
        fused[tex] = anchor(render[..., idx], mosaic, own, at)[tex]
        bits = (at * (1 << np.arange(3))).sum(-1)
        code = np.where(tex, (1 << m) | (bits << (m + 1)), code)
    sigma = _sigma_by_code(fusion, code[code < 1 << m], cameras)
    for cd, s_ in sigma.items():  # the own channels: measured, or averaged with their reprojection
        s_[own] = 1 / np.sqrt(1 / so**2 + 1 / float(rep_sigma[k]) ** 2) if cd >> (pos // 3) & 1 else so
    for cd in np.unique(code[code >= 1 << m]):  # textured: the site's channel(s) measured, the rest rendered
        s_ = np.full(3 * m, float(fusion["render_sigma"]))
        s_[own] = np.where((cd >> (m + 1)) >> np.arange(3) & 1, so, s_[own])
        sigma[int(cd)] = s_
    return fused, code, sigma


def _sigma_by_code(fusion: dict, code: np.ndarray, cameras: list) -> dict:
    """σ per channel of ``cameras`` for each pattern in ``code``: a camera's ``reprojected_sigma`` where
    its bit is set, ``render_sigma`` elsewhere."""
    sigma = {}
    for cd in np.unique(code):
        s_ = np.full(3 * len(cameras), fusion["render_sigma"], float)
        for i, c in enumerate(cameras):
            if cd >> i & 1:
                s_[3 * i : 3 * i + 3] = fusion["reprojected_sigma"][c]
        sigma[int(cd)] = s_
    return sigma


def photographed_view(
    fusion: dict, render: np.ndarray, reprojected, cameras, *, texture_rtol: float | None = None
):
    """Responses of a view from the photographs alone, for a view without a RAW file (a novel view):
    each camera's channels are its photographs reprojected into the view where any sees the pixel
    (re-read by :func:`splat.fusion.guided`, guided by the mean of the cameras' channel triples); where
    none of a camera's does, its rendered channels anchored (Brovey, :func:`splat.fusion.anchor`'s rule)
    to the sum of the channels that were reprojected there, or the render itself where no photograph
    sees the pixel. Where that picture of the view is **textured** — not :func:`splat.fusion.smooth`
    over the 3 × 3 neighbourhood at ``texture_rtol`` (default :data:`splat._tol.TEXTURE_RTOL`;
    ``float("inf")`` turns the test off), before the re-reading — the render itself, as if no
    photograph saw the pixel: at a 1–2 px border the reprojections are off by the step (as in
    :func:`fused_view`), and with no photograph of the view there is no site to anchor to. Three
    cameras, Prior, held-out views as novel views, all | flat pixels ΔE00 without → with the test:
    benchmark capture (every 4th pixel) 8.68 | 0.726 → 5.83 | 0.594; CI coarse capture (1000 steps,
    every 2nd) 4.90 | 0.449 → 4.03 | 0.425; CI fine 11.98 | 1.365 → 10.44 | 1.423. The 5 × 5 window of
    :func:`fused_view`'s test flagged more flat pixels here (the reprojections blur a cell's border into
    its neighbours): 5.44 | 0.707, 4.41 | 0.472, 10.70 | 1.838.

    Parameters
    ----------
    fusion : dict
        :func:`fusion_of`.
    render : ndarray of shape (H, W, 3n)
        The view's render, white → 1.
    reprojected : tuple
        Values (H, W, 3n) white → 1 and counts (H, W, n), as the render step writes them.
    cameras : sequence of int

    Returns
    -------
    fused, code, sigma
        As :func:`fused_view`; bit ``i`` of ``code`` set where ``cameras[i]``'s photographs enter; σ is
        the camera's ``reprojected_sigma`` there, ``render_sigma`` elsewhere.
    """
    from .fusion import ANCHOR_EPS, TEXTURE_RTOL, guided, smooth

    cameras = list(cameras)
    values, count = reprojected
    idx = [3 * c + j for c in cameras for j in range(3)]
    render = np.maximum(np.asarray(render, np.float64)[..., idx], 0)
    values = np.maximum(np.asarray(values, np.float64)[..., idx], 0)
    seen = np.stack([count[..., c] > 0 for c in cameras], -1)  # (H, W, m)
    code = (seen.astype(int) << np.arange(len(cameras))).sum(-1)
    chan = np.repeat(seen, 3, -1)

    def assemble(values):  # Brovey per pixel over the channels reprojected there; 1 where none was
        num = np.where(chan, values, 0).sum(-1) + ANCHOR_EPS
        den = np.where(chan, render, 0).sum(-1) + ANCHOR_EPS
        ratio = np.divide(num, den, out=np.ones_like(num), where=chan.any(-1) & (den > 0))
        return np.where(chan, values, render * ratio[..., None])

    # No photograph of the view itself to guide splat.fusion.guided: the guide is the mean of the
    # cameras' channel triples (a picture of the view from all photographs, its noise averaged)
    guide = assemble(values).reshape(*values.shape[:2], len(cameras), 3).mean(-2)
    for i in range(len(cameras)):
        if seen[..., i].any():
            values[..., 3 * i : 3 * i + 3] = guided(values[..., 3 * i : 3 * i + 3], seen[..., i], guide)
    fused = assemble(values)
    rtol = TEXTURE_RTOL if texture_rtol is None else texture_rtol
    if np.isfinite(rtol):  # textured: the render, no photograph
        tex = ~smooth(guide, rtol=rtol, size=3)
        fused[tex] = render[tex]
        code = np.where(tex, 0, code)
    return fused, code, _sigma_by_code(fusion, code, cameras)


def fused_fitter(spec: CaptureSpec, cameras: list[int], method: str):
    """``fit(σ) → (corrector, scale)`` for :func:`correct_fused`: :func:`fit_fused_corrector` with
    :func:`fused_mix`, once per distinct noise pattern (cached)."""
    mix = fused_mix(method)
    cache: dict = {}
    # the unwhitened problem, built once when first needed (0.04–0.15 s each, ~50 noise patterns a run)
    problem = functools.cache(lambda: correction_problem_of(spec, list(cameras)))

    def fit(sigma):
        key = tuple(np.round(sigma, 6))
        if key not in cache:
            cache[key] = fit_fused_corrector(spec, list(cameras), method, sigma, mix=mix, problem=problem())
        return cache[key]

    return fit


def _write_corrected(o: Path, stem: str, XYZ: np.ndarray, white_XYZ) -> None:
    """``<stem>_XYZ.tiff`` (float32), ``<stem>_sRGB.tiff`` (16-bit) and ``<stem>_sRGB.png`` of a view."""
    from isp import write_image

    _write_tiff(o / f"{stem}_XYZ.tiff", XYZ)
    rgb = XYZ_to_sRGB(XYZ, white_XYZ)
    write_image(o / f"{stem}_sRGB.tiff", rgb, overwrite=True)
    _write_png8(o / f"{stem}_sRGB.png", rgb)


def reprojected_of(d: Path, scale: np.ndarray):
    """A rendered view's reprojected photographs (white → 1) and counts, or None (not written)."""
    if not (d / "reprojected_count.tiff").is_file():
        return None
    return _read_tiff(d / "reprojected.tiff") / scale, _read_tiff(d / "reprojected_count.tiff")


def correct_fused(fused, code, sigma: dict, fit, quantum: float) -> np.ndarray:
    """Correct fused responses pixel group by pixel group (one noise pattern each): ``fit(σ)`` gives
    ``(corrector, scale)`` (:func:`fused_fitter`); returns XYZ (..., 3)."""
    from zonotope.correct.image import correct_image

    out = np.zeros((*fused.shape[:-1], 3))
    for cd, s_ in sigma.items():
        sel = code == cd
        if sel.any():
            cor, w = fit(s_)
            # whitened units: no channel is quantised more coarsely than ``quantum``
            out[sel] = correct_image((fused[sel] * w)[:, None], cor, quantum=quantum)[:, 0]
    return out


def fit_corrector(spec: CaptureSpec, cameras: list[int], method: str, delta: float):
    """A fitted estimator with the noise tolerance δ, i.e. responses of noise σ = δ / ``DELTA_SIGMAS``,
    passed as :func:`zonotope.correct.noise_options` says (Prior and the regressions get ``noise=σ``,
    Centroid ``delta=δ``)."""
    return _fit_on(correction_problem_of(spec, cameras), method, delta)


def fit_fused_corrector(spec: CaptureSpec, cameras: list[int], method: str, noise, *, mix=None, problem=None):
    """An estimator for fused responses with per-channel noise ``noise`` (σ per channel of ``cameras``):
    fitted by :func:`fit_corrector`'s rule on the channel-whitened problem
    (:func:`splat.fusion.whitened`, δ = ``DELTA_SIGMAS`` · σ_ref); returns it and the scale to apply to
    responses.
    ``mix``: Prior's atypical-branch weight (:func:`fused_mix`); without it Prior chooses it by its own
    cross-validation for every noise pattern (~3–5 s each). ``problem``: the cameras'
    :func:`correction_problem_of`, when the caller already has it."""
    from .fusion import whitened

    if problem is None:
        problem = correction_problem_of(spec, cameras)
    problem, scale, ref = whitened(problem, noise)
    from zonotope.correct import DELTA_SIGMAS

    return _fit_on(problem, method, DELTA_SIGMAS * ref, mix=mix), scale


def fused_mix(method: str):
    """Prior's atypical-branch weight λ for fused responses: 1, the MAP estimate alone (None for other
    methods). The measured channels' small σ makes the fused MMV thin (δ_k ∝ σ_k), so its centroid
    adds little to the MAP and cost three quarters of the time: on the CI coarse captures (1000 steps,
    three cameras, flat held-out pixels) λ chosen by Prior's cross-validation gave 0.500 ΔE00 noise-free
    and 1.399 noisy, λ = 1 0.497 and 1.392, and a noisy view took 31 s against 7.9 s."""
    from zonotope.correct import CORRECTION_METHODS

    if CORRECTION_METHODS.resolve(method, argument="method") != "Prior":
        return None
    return 1.0


def _fit_on(problem, method: str, delta: float, *, mix=None):
    """``method`` fitted on ``problem`` with the noise of tolerance ``delta`` (σ = δ / DELTA_SIGMAS), told
    to it as its registry entry says (:func:`zonotope.correct.noise_options`)."""
    from zonotope.correct import CORRECTION_METHODS, DELTA_SIGMAS, fit_correction, noise_options

    name = CORRECTION_METHODS.resolve(method, argument="method")  # unknown names: a project error
    opts = noise_options(name, delta / DELTA_SIGMAS)
    if name == "Prior" and mix is not None:
        opts["mix"] = mix
    return fit_correction(problem, method=name, **opts)


def dng_matrix_XYZ(balanced: np.ndarray, profile, neutral, white_XYZ) -> np.ndarray:
    """A camera's DNG development: white-balanced responses (white → 1) → XYZ of the scene white
    ``white_XYZ`` (Y = 1): ColorMatrix → XYZ D50 (isp), Bradford back to the scene white."""
    import colour

    from isp.dng import D50_xy
    from isp.stages import matrix_XYZ_from_balanced

    M = matrix_XYZ_from_balanced(profile, neutral)
    cat = colour.adaptation.matrix_chromatic_adaptation_VonKries(
        colour.xy_to_XYZ(D50_xy), np.asarray(white_XYZ) / white_XYZ[1], transform="Bradford"
    )
    return balanced @ (cat @ M).T


def correct_step(
    capture: str | os.PathLike,
    out: str | os.PathLike,
    *,
    config: PipelineConfig = PipelineConfig(),
    progress: ProgressCallback | None = None,
) -> dict:
    """Colour-correct every rendered view with all cameras (``config.method``), and develop each
    camera's channels with its own DNG matrix; held-out RAW files are also developed by isp.

    Returns
    -------
    dict
        The summary written to ``correct/summary.json``: method, σ and δ, infeasible shares.
    """
    from zonotope.correct import CORRECTION_METHODS
    from zonotope.correct.image import correct_image

    from .fusion import measured

    spec, ws = _workspace(capture, out, config)
    out = ws.root
    index_path = out / "render" / "index.json"
    if not index_path.is_file():
        raise CaptureError(f"{out}: nothing rendered yet; run the render step first.")
    index = read_index(spec, index_path)
    t0 = time.perf_counter()
    reset_peak_rss()
    raws = {v.name: v for v in load_views(spec, binning=working_binning(config, spec))}
    # white, δ and the fusion noise levels are functions of these (δ pools the photographed views only,
    # so that novel views rendered later do not change it): a change recomputes every corrected image
    photographed = {k: v for k, v in index.items() if k in raws}
    ws.begin(
        "correct",
        {
            "white": [spec.white.method, spec.white.image, spec.white.box, spec.white.reflectance],
            "observer": spec.observer,
            "method": CORRECTION_METHODS.resolve(config.method, argument="method"),
            "quantum": config.quantum,
            "photographed": sorted(photographed),
            "noise": config.noise,
            "full_resolution": FULL_METHOD,
        },
    )
    white = white_of(spec, out, list(raws.values()))
    scale = np.concatenate(white["scale"])
    n = len(spec.cameras)
    tol = delta_of(spec, out, photographed or index, scale)
    corrector = fit_corrector(spec, list(range(n)), config.method, tol["delta"])
    problem = corrector.problem
    wXYZ = problem.white_XYZ
    mname = corrector.method.replace(" ", "")
    profiles = {}
    for v in raws.values():
        profiles.setdefault(v.camera, (v.profile, v.neutral))
    fusion = fusion_of(spec, out, index, raws, scale)
    noise_used = own_noise(fusion, raws, scale, config.noise)
    fusion = dict(
        fusion, views={m: dict(d, own_sigma=noise_used[m]["sigma"]) for m, d in fusion["views"].items()}
    )
    fit = fused_fitter(spec, list(range(n)), config.method)
    fit_full = fused_fitter(spec, list(range(n)), FULL_METHOD)
    n_fused = {"views": 0, "novel": 0, "full_resolution": 0}
    full_info = {}
    # one progress bar over the rows of every photograph still to correct at full resolution
    todo_rows = {
        m: raws[m].size[0]
        for m, info in index.items()
        if m in fusion["views"] and not (out / "correct" / info["dir"] / "full_XYZ.tiff").is_file()
    }
    rows_done = [0]

    def full_progress(what, done, total, _name=None):
        if progress is not None:
            progress("full resolution rows", rows_done[0] + done, sum(todo_rows.values()))

    for i, (name, info) in enumerate(index.items()):
        d = out / "render" / info["dir"]
        o = out / "correct" / info["dir"]
        img = _read_tiff(d / "render.tiff") / scale
        if not (o / f"{mname}_XYZ.tiff").is_file():
            XYZ = correct_image(np.maximum(img, 0), corrector, quantum=config.quantum)
            _write_corrected(o, mname, XYZ, wXYZ)
        for k in range(n):
            prof, neutral = profiles[k]
            f = o / f"dng_{spec.label(k)}_XYZ.tiff"
            if prof is None or f.is_file():
                continue
            X = dng_matrix_XYZ(np.maximum(img[..., 3 * k : 3 * k + 3], 0), prof, neutral, wXYZ)
            _write_tiff(f, X)
            _write_png8(o / f"dng_{spec.label(k)}_sRGB.png", XYZ_to_sRGB(X, wXYZ))
        r = raws.get(name)
        rep = reprojected_of(d, scale)
        novel = name not in fusion["views"] and rep is not None and fusion["reprojected_sigma"] is not None
        want_fused = (name in fusion["views"] or novel) and not (o / f"{mname}_fused_XYZ.tiff").is_file()
        want_full = name in fusion["views"] and not (o / "full_XYZ.tiff").is_file()
        if want_fused or want_full:
            if novel:  # no RAW file here: the photographs reprojected into the view, the render elsewhere
                fused, code, sigma = photographed_view(fusion, img, rep, list(range(n)))
            else:  # a photograph: its RAW file, the others reprojected into it, the render anchored to it
                fused, code, sigma = fused_view(fusion, name, img, r, scale, list(range(n)), rep)
            if want_fused:
                XYZ = correct_fused(fused, code, sigma, fit, config.quantum)
                _write_corrected(o, f"{mname}_fused", XYZ, wXYZ)
            if want_full:  # at the photograph's own size, strip by strip (splat.strips)
                full_info[name] = _full_resolution(
                    spec,
                    o,
                    r,
                    fused,
                    code,
                    sigma,
                    white["scale"][r.camera],
                    noise_used[name],
                    fit_full,
                    wXYZ,
                    full_progress,
                )
                rows_done[0] += todo_rows.get(name, 0)
        if (o / f"{mname}_fused_XYZ.tiff").is_file():
            n_fused["views" if name in fusion["views"] else "novel"] += 1
        if (o / "full_XYZ.tiff").is_file():
            n_fused["full_resolution"] += 1
        if r is not None and r.profile is not None and not (o / "raw_dng_XYZ.tiff").is_file():
            bal = np.maximum(measured(r, white["scale"][r.camera]), 0)
            X = dng_matrix_XYZ(bal, r.profile, r.neutral, wXYZ)
            _write_tiff(o / "raw_dng_XYZ.tiff", X)
            _write_png8(o / "raw_dng_sRGB.png", XYZ_to_sRGB(X, wXYZ))
        if progress is not None:
            progress("correct", i + 1, len(index))
    summary = {
        "method": corrector.method,
        "delta": tol["delta"],
        "noise": tol,
        "training_residual": noise_sigma(out, scale),
        "fusion": {
            "render_sigma": fusion["render_sigma"],
            "views": n_fused["views"],
            "novel": n_fused["novel"],
            "files": f"{mname}_fused_XYZ.tiff / _sRGB.tiff / .png next to {mname}_XYZ.tiff",
        },
        "full_resolution": {
            "views": n_fused["full_resolution"],
            "method": FULL_METHOD,
            "files": "full_XYZ.tiff (float32) / full_sRGB.png, each photograph at its RAW file's size",
            "how": "own channels: the RAW file demosaiced (Malvar 2004) strip by strip; other cameras' "
            "channels: the working-resolution fused responses (their photographs reprojected through "
            "the splat's depth, the render where none sees a pixel) upsampled bilinearly and sharpened "
            "by the photograph (Brovey ratio of its own channels at full to working resolution); "
            f"{FULL_METHOD} fitted per noise pattern on the channel-whitened problem",
            "per_view": full_info,
        },
        "own_noise": {
            m: {"sigma": d["sigma"], "sigma_full": d["sigma_full"], "source": d["source"]}
            for m, d in noise_used.items()
        },
        "working": working_summary(spec, list(raws.values())),
        "white": {"method": white["method"], "scale": [np.asarray(s).tolist() for s in white["scale"]]},
        "white_XYZ": np.asarray(wXYZ).tolist(),
        "views": list(index),
        "duration_s": time.perf_counter() - t0,
        "peak_rss_mib": peak_rss_mib(),
    }
    _write_json(out / "correct" / "summary.json", summary)
    return summary


def own_noise(fusion: dict, raws: dict, scale: np.ndarray, noise) -> dict:
    """The noise σ of each photographed view's own channels (white → 1, exposure 1) and where it came
    from: ``noise = "auto"`` the full-resolution sensor noise of the RAW file (its DNG NoiseProfile at
    the channel's median level, else the mosaic's own estimate: :func:`splat.fusion.sensor_noise`,
    at least :data:`splat.fusion.OWN_NOISE_FLOOR`), a σ as given, or ``{"shot", "read"}`` as
    ``sqrt(shot · x + read)`` at the channel's median level ``x``.

    Returns
    -------
    dict
        View name → ``{"sigma": [3 floats], "sigma_full": [3 floats], "source": str}``: ``sigma`` at the
        working resolution (what the fused correction uses; ``"auto"`` keeps ``fusion.json``'s),
        ``sigma_full`` at the photograph's full resolution (binning divides σ by the √ of the sites
        averaged).
    """
    from .fusion import OWN_NOISE_FLOOR
    from .resolution import sites_per_block

    out = {}
    for name, d in fusion["views"].items():
        v = raws[name]
        k = v.camera
        ws = scale[3 * k : 3 * k + 3]
        root = np.sqrt(sites_per_block(v.source_cfa, v.binning)) if v.binning > 1 else np.ones(3)
        if noise == "auto":
            sigma = np.asarray(d["own_sigma"], float)
            full = np.maximum(sigma * root, OWN_NOISE_FLOOR)
            source = "DNG NoiseProfile" if v.noise_profile is not None else "estimated from the mosaic"
        else:
            if isinstance(noise, dict):
                vals, w = np.asarray(v.values, float) / v.exif / ws, np.asarray(v.weight) > 0
                x = np.array(
                    [np.median(vals[..., j][w[..., j]]) if w[..., j].any() else 0.0 for j in range(3)]
                )
                full = np.sqrt(noise["shot"] * np.maximum(x, 0) + noise["read"]) * np.ones(3)
            else:
                full = np.full(3, float(noise))
            full = np.maximum(full, OWN_NOISE_FLOOR)
            sigma = np.maximum(full / root, OWN_NOISE_FLOOR)
            source = "--noise"
        out[name] = {
            "sigma": [_two_digits(x) for x in sigma],
            "sigma_full": [_two_digits(x) for x in full],
            "source": source,
        }
    return out


def _full_resolution(
    spec: CaptureSpec, o: Path, view: RawView, fused, code, sigma, own_scale, noise: dict, fit, wXYZ, progress
):
    """Write ``full_XYZ.tiff`` and ``full_sRGB.png`` of a photographed view at its RAW file's size
    (:func:`splat.strips.full_resolution_view`); returns what was done, how long it took and the peak
    memory."""
    from . import strips as _strips
    from .capture import open_raw

    t = time.perf_counter()
    k = view.camera
    source = open_raw(view.path, spec.cameras[k])
    H, W = source.shape
    rows = _strips.STRIP_ROWS
    strips = _strips.full_resolution_view(
        _strips.Photograph(
            source, view.exif, np.asarray(own_scale, float), np.asarray(noise["sigma_full"], float)
        ),
        _strips.WorkingFusion(fused, code, sigma, slice(3 * k, 3 * k + 3), view.binning),
        fit,
        strip_rows=rows,
        progress=progress,
    )
    _strips.write_full(
        o / "full_XYZ.tiff", o / "full_sRGB.png", strips, (H, W), _strips.sRGB8_encoder(wXYZ), rows=rows
    )
    return {"size": [W, H], "binning": view.binning, "seconds": time.perf_counter() - t}


# ---------------------------------------------------------------------------------------------
# step 5: report
# ---------------------------------------------------------------------------------------------


def report_step(
    capture: str | os.PathLike,
    out: str | os.PathLike,
    *,
    config: PipelineConfig = PipelineConfig(),
    progress: ProgressCallback | None = None,
) -> Path:
    """Write ``OUT/report.html`` (:mod:`splat.report`): per photograph the corrected image beside the
    camera's own development, the marked card's ΔE00 where there is one, what was done, how long it took
    and what to do next; the step summaries collapsed below."""
    from .report import write_report

    spec, ws = _workspace(capture, out, config, "report", lambda spec: {})
    out = ws.root
    index = (
        read_index(spec, out / "render" / "index.json") if (out / "render" / "index.json").is_file() else {}
    )
    return write_report(spec, out, index, default_steps=PipelineConfig.steps)


def run(
    capture: str | os.PathLike,
    out: str | os.PathLike,
    *,
    config: PipelineConfig = PipelineConfig(),
    steps=STEPS,
    progress: ProgressCallback | None = None,
) -> dict:
    """Run the steps in order (each skipped or resumed when its results exist); returns their results."""
    fns = {
        "poses": poses_step,
        "train": fit_step,
        "render": render_step,
        "correct": correct_step,
        "report": report_step,
    }
    bad = [s for s in steps if s not in fns]
    if bad:
        raise SplatError(f"unknown step(s) {bad}; steps are {list(STEPS)}.")
    return {s: fns[s](capture, out, config=config, progress=progress) for s in steps}
