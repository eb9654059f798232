"""The options of a capture run (:class:`PipelineConfig`), the checks made before any RAW file is read
(:func:`check_run`), the working resolution, and the step's :class:`~splat.capture.workspace.Workspace`.
"""

from __future__ import annotations

import fnmatch
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from .._errors import SplatError

if TYPE_CHECKING:
    pass
from .spec import CaptureError, CaptureSpec, read_capture
from .workspace import Workspace

__all__ = [
    "STEPS",
    "PipelineConfig",
    "check_run",
    "step_workspace",
    "train_size_of",
    "working_binning",
    "working_summary",
    "working_views",
]

#: The steps of a capture run, in the order :func:`splat.capture.run` runs them.
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
    from ..resolution import working_factor

    size = config.train_size if spec is None else train_size_of(spec, config)
    return lambda k, shape, full: working_factor(shape, full, size=size)


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
