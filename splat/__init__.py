"""splat — N-channel Gaussian splatting in JAX, trained on RAW images from several cameras.

Several cameras photograph one scene; each image measures only its camera's channels (and only one
of them per pixel behind a Bayer mosaic). One set of 3-D Gaussians with N = all cameras' channels
is fitted to all the images, then renders pixel-aligned N-channel images from any view, ready for
:mod:`zonotope` (metamer mismatch, colour correction).

- model and renderer: :class:`Gaussians`, :func:`render` (``method="auto"``: ``"cpu"``, numba kernels
  on the CPU, or ``"tiled"``, pure JAX, on a GPU; ``"reference"``, the dense twin);
- data: :func:`read_colmap` / :func:`write_colmap`, :func:`read_transforms` /
  :func:`write_transforms`, :class:`Capture` (views, channel map, exposures), :func:`recover_poses`,
  :func:`triangulate_points`;
- training: :func:`train` with :class:`TrainConfig`; outputs: :func:`render_views`,
  :func:`render_depth`, :func:`split_cameras`, :func:`pca_false_colour`, :func:`correct_image`;
- export: :func:`export_scene` (a 3DGS ``.ply`` of the corrected colours, an N-channel ``.ply``, the
  poses as ``transforms.json`` and COLMAP), :func:`read_ply`;
- a synthetic capture to try it all: :func:`synthetic_scene`.

``import splat`` is cheap: the submodules (and JAX) load on first use of a public name.
"""

from __future__ import annotations

from zonotope.utilities.lazy import install_moved_modules, lazy_exports

_EXPORTS = {
    "_errors": ["DataFormatError", "SplatError", "SplatMethodError"],
    "gaussians": ["Gaussians", "init_gaussians", "inverse_softplus", "quat_to_rotmat"],
    "camera": ["Camera", "look_at", "pose_corrected", "qvec_to_rotmat", "rotmat_to_qvec", "so3_exp"],
    "rendering": [
        "RENDER_METHODS",
        "Projected",
        "RenderConfig",
        "RenderOutput",
        "project",
        "default_method",
        "render",
        "render_cpu",
        "render_reference",
        "render_tiled",
    ],
    "colmap": [
        "CAMERA_MODELS",
        "ColmapCamera",
        "ColmapFrame",
        "ColmapImage",
        "ColmapModel",
        "ColmapPoint3D",
        "ColmapRig",
        "read_colmap",
        "write_colmap",
    ],
    "data": [
        "Capture",
        "View",
        "capture_from_colmap",
        "colmap_from_capture",
        "read_transforms",
        "write_transforms",
    ],
    "sim.scenes": ["SceneConfig", "SyntheticScene", "bayer_mask", "synthetic_scene"],
    "training": [
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
    ],
    "outputs": ["correct_image", "pca_false_colour", "psnr", "render_depth", "render_views", "split_cameras"],
    "poses": ["PoseConfig", "recover_poses", "triangulate_points"],
    "export": ["PlyOptions", "export_scene", "gaussians_from_ply", "prepare_scene", "read_ply", "write_ply"],
    "sim.capture": [
        "SimCamera",
        "SimCaptureConfig",
        "SimScene",
        "SimView",
        "build_scene",
        "write_synthetic_capture",
    ],
}
#: Old module paths that still import, with a DeprecationWarning, as their new module.
_MOVED_MODULES = {
    "splat.scenes": "splat.sim.scenes",
    "splat.simcapture": "splat.sim.capture",
    "splat._simgeometry": "splat.sim.geometry",
    "splat.pipeline": "splat.capture",
    "splat.workspace": "splat.capture.workspace",
}


install_moved_modules(_MOVED_MODULES)

__getattr__, __dir__, __all__ = lazy_exports(__name__, _EXPORTS)
