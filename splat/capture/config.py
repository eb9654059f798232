"""The options of a capture run (:class:`PipelineConfig`), the checks made before any RAW file is read
(:func:`check_run`), the working resolution, and the step's :class:`~splat.capture.workspace.Workspace`.
"""

from __future__ import annotations

import fnmatch
from dataclasses import InitVar, dataclass, replace
from typing import TYPE_CHECKING

import numpy as np

from .._errors import SplatError
from .._tol import RENDER_SOURCES

if TYPE_CHECKING:
    from ..training import TrainConfig
from .spec import CaptureError, CaptureSpec, read_capture
from .workspace import Workspace

__all__ = [
    "STEPS",
    "TRAIN_OPTIONS",
    "PipelineConfig",
    "capture_train_config",
    "check_run",
    "read_working",
    "step_workspace",
    "train_size_of",
    "working_binning",
    "working_summary",
    "working_views",
]

#: The steps of a capture run, in the order :func:`splat.capture.run` runs them.
STEPS = ("poses", "train", "render", "correct", "report")


#: The options of :class:`PipelineConfig` that are its training's (:class:`splat.TrainConfig` fields of the
#: same name and meaning): given as keyword arguments they set ``config.train``, read as attributes they
#: read it (``PipelineConfig(steps=300).steps == config.train.steps``), so that callers written against
#: the flat options keep working. ``steps`` also sets the schedule derived from it
#: (:func:`capture_train_config`), except fields of the schedule set otherwise.
TRAIN_OPTIONS = (
    "steps",
    "capacity",
    "seed",
    "densify_until",
    "refine_exposure",
    "refine_poses",
    "depth_weight",
)


class _Unset:
    """The default of a :data:`TRAIN_OPTIONS` keyword: "what ``train`` says"."""

    def __repr__(self) -> str:
        return "<from train>"


_UNSET = _Unset()


def _check_train_options(values: dict) -> None:
    """One-line :class:`SplatError` for a :data:`TRAIN_OPTIONS` value that is out of range (the names are
    the CLI's options)."""
    for name in ("steps", "capacity"):
        v = values.get(name, 1)
        if isinstance(v, bool) or not isinstance(v, int) or v < 1:
            raise SplatError(f"{name}={v!r}: must be a positive integer (e.g. --{name} 3000).")
    d = values.get("densify_until")
    if d is not None and (isinstance(d, bool) or not isinstance(d, int) or d < 0):
        raise SplatError(f"densify_until={d!r}: must be ≥ 0 or None.")
    w = values.get("depth_weight", 0.0)
    if isinstance(w, bool) or not isinstance(w, int | float) or not np.isfinite(w) or w < 0:
        raise SplatError(f"depth_weight={w!r}: must be a finite number ≥ 0 (0 turns the depth term off).")


def capture_train_config(
    *,
    steps: int = 3000,
    capacity: int = 4096,
    seed: int = 0,
    densify_until: int | None = None,
    refine_exposure: bool = False,
    refine_poses: bool = False,
    depth_weight: float | None = None,
):
    """The :class:`splat.TrainConfig` of a capture run: the given options and the schedule that follows
    ``steps`` (densify from ``min(200, steps // 5)`` every ``max(25, min(100, steps // 20))`` steps until
    ``densify_until``, default 70 % of ``steps``; a checkpoint every ``max(50, steps // 10)`` steps) with a
    faster growth than :class:`~splat.TrainConfig`'s default (30 % of the alive Gaussians per
    densification).

    Why the faster growth: :class:`~splat.TrainConfig`'s 5 % filled a 4096 buffer from COLMAP's few hundred
    points only after thousands of steps, and the model underfitted its own training views (flat-pixel
    error 3.5 % on training views, 4 % held out); filling the buffer early took three-camera flat ΔE00 at
    1000 steps from 2.43 to 2.01.

    Parameters
    ----------
    steps, capacity, seed, refine_exposure, refine_poses : as :class:`splat.TrainConfig`
    densify_until : int or None
        Last densification step (None: ``int(0.7 * steps)``).
    depth_weight : float or None
        λ of the sparse depth term (None: :class:`~splat.TrainConfig`'s default).

    Raises
    ------
    SplatError
        A value out of range, named as the CLI option (``steps=-3: must be a positive integer ...``).
    """
    from ..training import TrainConfig

    opts = {"steps": steps, "capacity": capacity, "densify_until": densify_until}
    if depth_weight is not None:
        opts["depth_weight"] = depth_weight
    _check_train_options(opts)
    until = densify_until if densify_until is not None else int(0.7 * steps)
    return TrainConfig(
        steps=steps,
        capacity=capacity,
        seed=seed,
        checkpoint_every=max(50, steps // 10),
        densify_from=min(200, steps // 5),
        densify_until=until,
        densify_every=max(25, min(100, steps // 20)),
        densify_fraction=0.3,
        refine_exposure=refine_exposure,
        refine_poses=refine_poses,
        **({} if depth_weight is None else {"depth_weight": depth_weight}),
    )


#: The fields of :func:`capture_train_config`'s schedule that follow ``steps``.
_SCHEDULE = ("checkpoint_every", "densify_from", "densify_until", "densify_every")


def _with_options(train, given: dict):
    """``train`` with the :data:`TRAIN_OPTIONS` in ``given`` that differ from its own values. A new
    ``steps`` moves each schedule field that followed the old ``steps`` (its :func:`capture_train_config`
    value) to the new one; a field set otherwise (by hand, or in ``given``) is kept."""
    from dataclasses import replace

    changed = {k: v for k, v in given.items() if v != getattr(train, k)}
    if not changed:
        return train
    _check_train_options(changed)
    if "steps" not in changed:
        return replace(train, **changed)
    old = capture_train_config(steps=train.steps)
    new = capture_train_config(steps=changed["steps"])
    follow = {
        k: getattr(new, k) for k in _SCHEDULE if k not in changed and getattr(train, k) == getattr(old, k)
    }
    return replace(train, **follow, **changed)


class _TrainOption:
    """``config.<name>`` is ``config.train.<name>`` (on the class: the default capture schedule's)."""

    def __init__(self, name: str):
        self.name = name

    def __get__(self, obj, owner=None):
        if obj is None:
            return getattr(capture_train_config(), self.name)
        return getattr(obj.train, self.name)


@dataclass(frozen=True)
class PipelineConfig:
    """Options of the pipeline steps.

    Attributes
    ----------
    train : splat.TrainConfig
        The train step's options, passed to :func:`splat.train` as they are (the step adds only its
        checkpoint, ``OUT/train/checkpoint.npz``). Default: :func:`capture_train_config` of the
        :data:`TRAIN_OPTIONS` given (``PipelineConfig(steps=300)``), or of none (3000 steps, 4096
        Gaussians). The options in :data:`TRAIN_OPTIONS` read ``train``'s values as attributes
        (``config.steps``); as keyword arguments, together with ``train`` (as in
        :func:`dataclasses.replace`), they change the ones they differ in.
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
    threads : int
        COLMAP threads (-1: all cores).
    min_registered : float
        Fraction of each camera's views that must register.
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
    full_reprojection : bool
        True (default): where a photograph is binned for work, its full-resolution output carries the
        other cameras' photographs reprojected at their full resolution (:mod:`splat.strips`); False:
        the working-resolution fusion upsampled and sharpened by the photograph instead, about 3× less
        CPU at 24 MP (36 s against 107 s for the full-resolution stage, docs/benchmarks.md) and no
        detail from the other cameras finer than the working resolution.
    render_sources : int or None
        Photographs of each camera reprojected into each rendered view by the render step: the ones
        that see most of it (:func:`splat.capture.render.nearest_sources`); None: every other
        photograph, a cost that grows with the square of the photographs. Default
        :data:`splat._tol.RENDER_SOURCES` (docs/notes/2026-11-29-realsize-scaling.md: held-out ΔE00 with
        it against all, and the time).
    workers : int or None
        Strips of the full-resolution stage computed at once, on threads
        (:func:`splat.strips.full_resolution_view`), and views the render step renders and reprojects
        at once: time and memory only, the images are the same for any number (so it is recorded in the
        correct step's summary, not in the settings that decide reuse); None (default):
        :func:`splat.strips.default_workers`, the cores this process may use, at most
        :data:`splat._tol.FULL_WORKERS`.
    steps, capacity, seed, densify_until, refine_exposure, refine_poses, depth_weight
        :data:`TRAIN_OPTIONS`: ``train``'s fields (the poses step also uses ``seed``). Notes on two of
        them: ``refine_exposure`` is off by default because on the simulated capture, whose EXIF is
        exact, a 300-step model drifted 4–10 % away from it (the corrections absorb model error);
        ``refine_poses`` is off by default because on the CI-size coarse noise-free capture with
        pycolmap's poses (1000 steps, capacity 4096) it changed the three-camera flat-pixel ΔE00 on
        held-out views by −0.04 and +0.02 (two seeds, whose own spread is 0.18): no measurable gain at
        that training length. Held-out views keep their recovered poses (nothing refines them).
    """

    train: TrainConfig | None = None
    camera: str | None = None
    views: tuple[str, ...] | None = None
    novel: int = 0
    method: str = "Prior"
    quantum: float = 5e-3
    threads: int = -1
    min_registered: float = 0.5
    train_size: int | None = None
    noise: str | float | dict = "auto"
    full_reprojection: bool = True
    render_sources: int | None = RENDER_SOURCES
    workers: int | None = None
    steps: InitVar[int] = _UNSET
    capacity: InitVar[int] = _UNSET
    seed: InitVar[int] = _UNSET
    densify_until: InitVar[int | None] = _UNSET
    refine_exposure: InitVar[bool] = _UNSET
    refine_poses: InitVar[bool] = _UNSET
    depth_weight: InitVar[float] = _UNSET

    def __post_init__(
        self, steps, capacity, seed, densify_until, refine_exposure, refine_poses, depth_weight
    ):
        from ..training import TrainConfig

        values = (steps, capacity, seed, densify_until, refine_exposure, refine_poses, depth_weight)
        given = {k: v for k, v in zip(TRAIN_OPTIONS, values) if v is not _UNSET}
        train = self.train
        if train is None:
            train = capture_train_config(**given)
        elif not isinstance(train, TrainConfig):
            raise SplatError(
                f"train={train!r}: must be a splat.TrainConfig (or None for the capture schedule)."
            )
        else:
            train = _with_options(train, given)
        if train.checkpoint is not None:
            raise SplatError(
                f"train.checkpoint={str(train.checkpoint)!r}: the train step keeps its checkpoint in "
                "OUT/train/checkpoint.npz; leave it None."
            )
        _check_train_options({k: getattr(train, k) for k in TRAIN_OPTIONS})
        object.__setattr__(self, "train", train)
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
        k = self.render_sources
        if k is not None and (isinstance(k, bool) or not isinstance(k, int) or k < 1):
            raise SplatError(
                f"render_sources={k!r}: must be a number of photographs ≥ 1 per camera, or None for all."
            )
        t = self.train_size
        if t is not None and (isinstance(t, bool) or not isinstance(t, int) or t < 16):
            raise SplatError(f"train_size={t!r}: must be a number of pixels ≥ 16 (e.g. --train-size 640).")
        _noise_of(self.noise)
        w = self.workers
        if w is not None and (isinstance(w, bool) or not isinstance(w, int) or w < 1):
            raise SplatError(f"workers={w!r}: must be a whole number ≥ 1 (strips computed at once), or None.")


for _name in TRAIN_OPTIONS:  # the options read through to ``train`` (see TRAIN_OPTIONS)
    setattr(PipelineConfig, _name, _TrainOption(_name))
del _name


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
    from ..resolution import working_factor

    size = config.train_size if spec is None else train_size_of(spec, config)
    return lambda k, shape, full: working_factor(shape, full, size=size)


def read_working(
    spec: CaptureSpec, ws: Workspace, config: PipelineConfig, progress=None, *, automatic: bool = False
) -> list:
    """Every RAW file of the capture at the working resolution (:func:`splat.capture.raw.load_views`
    with :func:`working_binning`), each decoded once per run: kept in ``ws``'s decode cache
    (:meth:`Workspace.decode_cache`, keyed by the file and the working-resolution options) and read
    from there by the later steps.

    With ``automatic``, at the automatic working resolution whatever ``train_size`` says: the poses
    step's previews, which never depend on it (with the default ``train_size`` the same entries as the
    later steps', so that the poses step's decoding is the run's only one)."""
    from ..resolution import TRAIN_PIXEL_BUDGET
    from .raw import load_views

    size = None if automatic else train_size_of(spec, config)
    options = {"train_size": size, "budget": TRAIN_PIXEL_BUDGET}
    return load_views(
        spec,
        progress=progress,
        binning=working_binning(replace(config, train_size=size)),
        cache=ws.decode_cache(options),
    )


def working_views(views, raws: dict) -> list:
    """``views`` (:class:`splat.data.View`, full-resolution cameras) with each camera scaled to its
    photograph's working resolution (``raws``: name → :class:`splat.capture.RawView` as read with
    :func:`working_binning`; :func:`splat.resolution.scale_camera`)."""
    import dataclasses

    from ..resolution import scale_camera

    out = []
    for v in views:
        r = raws.get(v.name)
        f = 1 if r is None else r.binning
        out.append(v if f == 1 else dataclasses.replace(v, camera=scale_camera(v.camera, f)))
    return out


def working_summary(spec: CaptureSpec, raws) -> dict:
    """Per camera folder: full and working size, binning factor, sites averaged per channel and how much
    that lowers each channel's noise σ (√ of the sites), for the step summaries and stdout."""
    from ..resolution import sites_per_block

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


def step_workspace(capture, out, config: PipelineConfig, step: str | None = None, settings=None):
    """The checked capture and its :class:`~splat.capture.workspace.Workspace`, with ``step`` begun
    there on ``settings(spec)`` when both are given."""
    spec = read_capture(capture)
    check_run(spec, config)
    ws = Workspace(spec, out)
    if step is not None:
        ws.begin(step, settings(spec))
    return spec, ws
