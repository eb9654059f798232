"""splat — N-channel Gaussian splatting in JAX, trained on RAW images from several cameras.

``import splat`` is cheap: the submodules (and JAX) load on first use of a public name.
"""

from __future__ import annotations

import importlib

_EXPORTS = {
    "_errors": ["DataFormatError", "SplatError"],
    "gaussians": ["Gaussians", "init_gaussians", "inverse_softplus", "quat_to_rotmat"],
    "camera": ["Camera", "look_at", "qvec_to_rotmat", "rotmat_to_qvec"],
    "rendering": ["RENDER_METHODS", "Projected", "RenderConfig", "RenderOutput", "project", "render",
               "render_reference", "render_tiled"],
    "colmap": ["CAMERA_MODELS", "ColmapCamera", "ColmapFrame", "ColmapImage", "ColmapModel",
               "ColmapPoint3D", "ColmapRig", "read_colmap", "write_colmap"],
    "data": ["Capture", "View", "capture_from_colmap", "colmap_from_capture", "read_transforms",
             "write_transforms"],
    "scenes": ["SceneConfig", "SyntheticScene", "bayer_mask", "synthetic_scene"],
    "training": ["TrainConfig", "TrainResult", "TrainState", "init_state", "load_checkpoint", "rawnerf_loss",
              "save_checkpoint", "stack_cameras", "train", "train_step"],
    "outputs": ["pca_false_colour", "psnr", "render_views", "split_cameras"],
    "poses": ["PoseConfig", "recover_poses"],
}
_WHERE = {name: module for module, names in _EXPORTS.items() for name in names}

__all__ = sorted(_WHERE)


def __getattr__(name: str):
    if name in _WHERE:
        value = getattr(importlib.import_module(f".{_WHERE[name]}", __name__), name)
        globals()[name] = value
        return value
    raise AttributeError(f"module 'splat' has no attribute {name!r}")


def __dir__():
    return sorted(set(globals()) | set(__all__))
