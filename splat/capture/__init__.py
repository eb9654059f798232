"""A capture run: RAW capture on disk → poses → N-channel Gaussians → renders → colour-corrected
images → report.

A capture is ``capture.toml`` plus one folder of RAW files per physical camera. Each step reads the
capture (never writes into it) and what earlier steps left in the output folder ``OUT``, writes its
own files atomically (temporary file + ``os.replace``), and is skipped or resumed when its results
are already there and were made from the same inputs and options:
:class:`~splat.capture.workspace.Workspace` owns ``OUT`` (a marker file, a settings record per step,
every path inside ``OUT``) and removes a step's results, and its dependents', when what they were
made from changed. :func:`check_run` refuses bad options and captures before any RAW file is read.

==========  ==========================================================================================
module      contents
==========  ==========================================================================================
spec        ``capture.toml``: :func:`read_capture`, :class:`CaptureSpec`, :class:`CaptureError`
raw         RAW files → linear mosaics: :func:`read_linear`, :func:`load_views`, :class:`RawView`,
            :class:`RawSource`, the white scale (:func:`white_scale`)
workspace   the output folder: :class:`Workspace`, :func:`capture_fingerprint`, :func:`read_json`
config      :class:`PipelineConfig`, :func:`check_run`, the working resolution
files       atomic writes and reads of the steps' files (JSON, float TIFF, 8-bit PNG)
poses       step 1, :func:`poses_step`
train       step 2, :func:`training_inputs`, :func:`fit_step`, readers of its results
render      step 3, :func:`render_step`
correct     step 4, :func:`correct_step`: white, δ and fusion caches, :func:`fused_view`,
            :func:`photographed_view`, the correction fits
illuminant  the scene light of ``illuminant = "estimate"`` (:func:`illuminant_of`), at step 4
report      step 5, :func:`report_step` (the page itself is :mod:`splat.report`)
runner      :func:`run`, every step in order
==========  ==========================================================================================

Every public name of these modules is importable from ``splat.capture``; the submodules load on first
use of a name. ``splat.pipeline`` and ``splat.workspace`` are old paths of this package and of
:mod:`splat.capture.workspace`.

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
           (:mod:`splat.strips`); ``correct/illuminant.json``: the estimated light of an
           ``illuminant = "estimate"`` capture
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

from zonotope.utilities.lazy import lazy_exports

_EXPORTS = {
    "spec": [
        "ESTIMATE",
        "PROVISIONAL_LIGHT",
        "CameraSpec",
        "CaptureError",
        "CaptureSpec",
        "WhiteSpec",
        "maker_warnings",
        "read_capture",
    ],
    "illuminant": ["estimate_scene_light", "illuminant_of"],
    "chart": ["CHART_RECORD", "chart_of", "chart_preview", "check_chart", "recorded_corners"],
    "raw": [
        "RAW_SUFFIXES",
        "RawSource",
        "RawView",
        "brightest_neutral",
        "camera_white",
        "check_white_box",
        "exif_exposure",
        "load_view",
        "load_views",
        "open_raw",
        "read_linear",
        "relative_exposures",
        "white_box",
        "white_patch",
        "white_scale",
    ],
    "workspace": [
        "DECODE_CACHE",
        "MARKER",
        "SETTINGS",
        "STEP_OUTPUTS",
        "Workspace",
        "capture_fingerprint",
        "curves_fingerprint",
        "file_stamp",
        "peak_rss_mib",
        "read_json",
        "release_free_memory",
        "reset_peak_rss",
    ],
    "config": [
        "PipelineConfig",
        "STEPS",
        "TRAIN_OPTIONS",
        "capture_train_config",
        "check_run",
        "read_working",
        "step_workspace",
        "train_size_of",
        "working_binning",
        "working_summary",
        "working_views",
    ],
    "files": ["atomic_write", "read_index", "read_tiff", "write_json", "write_png8", "write_tiff"],
    "poses": ["poses_step", "preview_binning", "preview_upscale"],
    "train": [
        "TrainingInputs",
        "depth_targets",
        "fit_step",
        "load_gaussians",
        "load_model_capture",
        "pose_corrections_of",
        "refined_views",
        "train_config",
        "training_inputs",
    ],
    "render": ["nearest_sources", "render_step", "reprojected_view", "views_to_render"],
    "correct": [
        "WHITE_POINT",
        "XYZ_to_sRGB",
        "capture_generators",
        "choose_delta",
        "correct_fused",
        "correct_step",
        "correction_problem_of",
        "delta_of",
        "dng_matrix_XYZ",
        "curves_white",
        "fit_corrector",
        "fit_fused_corrector",
        "fused_fitter",
        "pipeline_mix",
        "fused_view",
        "fusion_of",
        "levelled_white",
        "noise_sigma",
        "own_noise",
        "photographed_view",
        "reprojected_of",
        "ssf_record",
        "ssf_sigma",
        "white_of",
    ],
    "report": ["report_step"],
    "runner": ["run"],
}

__getattr__, __dir__, __all__ = lazy_exports(__name__, _EXPORTS)
