"""Views of a multi-camera capture: poses, intrinsics, which channels each image measures, exposure.

A :class:`Capture` holds the views and the channel map ``camera_id -> channel indices`` (e.g. camera 1
measures channels 0–2 of a 9-channel scene, camera 2 channels 3–5, ...). Captures convert to and from
COLMAP sparse models (:mod:`splat.colmap`) and nerfstudio ``transforms.json`` files.
"""

from __future__ import annotations

import json
from dataclasses import dataclass, field
from pathlib import Path

import jax.numpy as jnp
import numpy as np

from ._errors import DataFormatError, SplatError
from ._tol import ROTATION_ATOL
from .camera import Camera, qvec_to_rotmat, rotmat_to_qvec
from .colmap import ColmapCamera, ColmapImage, ColmapModel

__all__ = [
    "Capture",
    "View",
    "capture_from_colmap",
    "colmap_from_capture",
    "read_transforms",
    "write_transforms",
]

_GL_FROM_CV = np.diag([1.0, -1.0, -1.0, 1.0])


@dataclass(frozen=True)
class View:
    """One image of the capture.

    Attributes
    ----------
    name : str
        Image file name (relative to the image folder).
    camera : Camera
        Pose and intrinsics.
    camera_id : int
        The physical camera that took it (COLMAP ``CAMERA_ID``): selects its channels in the capture.
    exposure : float
        Relative exposure (shutter × gain / ISO ratio); the model's radiance times this is the image.
    """

    name: str
    camera: Camera
    camera_id: int
    exposure: float = 1.0

    def __post_init__(self):
        # a NaN or degenerate pose, focal ≤ 0 or a NaN exposure would train NaN Gaussians silently
        c = self.camera
        R, t = np.asarray(c.R, np.float64), np.asarray(c.t, np.float64)
        f, pp = np.asarray(c.focal, np.float64), np.asarray(c.principal, np.float64)
        what = f"view {self.name!r}"
        if not (np.all(np.isfinite(R)) and np.all(np.isfinite(t))):
            raise SplatError(f"{what}: the pose holds NaN or inf (R={R.tolist()}, t={t.tolist()}).")
        orthonormal = R.shape == (3, 3) and np.allclose(R.T @ R, np.eye(3), atol=ROTATION_ATOL)
        if not orthonormal or np.linalg.det(R) < 0:
            raise SplatError(
                f"{what}: R={R.tolist()} is not a rotation (zero or degenerate pose); give "
                "an orthonormal world-to-camera rotation with determinant +1."
            )
        if not (np.all(np.isfinite(f)) and np.all(f > 0)):
            raise SplatError(f"{what}: focal length {f.tolist()} px must be finite and > 0.")
        if not np.all(np.isfinite(pp)):
            raise SplatError(f"{what}: principal point {pp.tolist()} must be finite.")
        if not (int(c.width) > 0 and int(c.height) > 0):
            raise SplatError(f"{what}: image size {c.width}×{c.height} must be positive.")
        if not (np.isfinite(self.exposure) and self.exposure > 0):
            raise SplatError(f"{what}: exposure={self.exposure} must be finite and > 0.")


@dataclass(frozen=True)
class Capture:
    """Views and the channel map of a multi-camera capture.

    Attributes
    ----------
    views : tuple of View
    channels : dict int -> tuple of int
        For each camera id, the indices of the scene channels its images measure.
    labels : tuple of str, optional
        Names of the k scene channels.
    """

    views: tuple[View, ...]
    channels: dict[int, tuple[int, ...]]
    labels: tuple[str, ...] = field(default=())

    def __post_init__(self):
        for cid, idx in self.channels.items():
            if not all(
                isinstance(i, int | np.integer) and not isinstance(i, bool) and 0 <= i < 4096 for i in idx
            ):
                raise SplatError(f"channels[{cid}]={idx!r}: channel indices must be integers in 0..4095.")
        missing = sorted({v.camera_id for v in self.views} - set(self.channels))
        if missing:
            raise SplatError(
                f"views use camera id(s) {missing} that have no entry in channels "
                f"{self.channels}; give each camera id its channel indices."
            )
        if self.labels and len(self.labels) != self.n_channels:
            raise SplatError(f"{len(self.labels)} labels for {self.n_channels} channels.")

    @property
    def n_channels(self) -> int:
        """k, one more than the largest channel index."""
        return 1 + max((max(c) for c in self.channels.values() if c), default=-1)

    def channel_mask(self, view: View) -> np.ndarray:
        """Boolean mask of shape (k,) of the channels ``view`` measures."""
        m = np.zeros(self.n_channels, bool)
        m[list(self.channels[view.camera_id])] = True
        return m


def _camera(R, t, fx, fy, cx, cy, w, h) -> Camera:
    f32 = jnp.float32
    return Camera(
        jnp.asarray(R, f32),
        jnp.asarray(t, f32),
        jnp.asarray([fx, fy], f32),
        jnp.asarray([cx, cy], f32),
        int(w),
        int(h),
    )


def capture_from_colmap(
    model: ColmapModel,
    *,
    channels: dict[int, tuple[int, ...]] | None = None,
    exposures: dict[str, float] | None = None,
    labels=(),
) -> Capture:
    """A :class:`Capture` from a COLMAP model.

    Parameters
    ----------
    model : ColmapModel
    channels : dict, optional
        ``camera_id -> channel indices``; default: 3 consecutive channels per camera id, in id order.
    exposures : dict, optional
        ``image name -> exposure`` (default 1).
    labels : sequence of str, optional

    Returns
    -------
    Capture
        Views in image-id order.
    """
    if channels is None:
        channels = {cid: (3 * k, 3 * k + 1, 3 * k + 2) for k, cid in enumerate(sorted(model.cameras))}
    exposures = exposures or {}
    views = []
    for iid in sorted(model.images):
        im = model.images[iid]
        if im.camera_id not in model.cameras:
            raise DataFormatError(
                f"image {im.name!r} refers to camera {im.camera_id}, which the model does not have."
            )
        c = model.cameras[im.camera_id]
        views.append(
            View(
                im.name,
                _camera(qvec_to_rotmat(im.qvec), im.tvec, *c.pinhole(), c.width, c.height),
                im.camera_id,
                float(exposures.get(im.name, 1.0)),
            )
        )
    return Capture(tuple(views), {int(k): tuple(v) for k, v in channels.items()}, tuple(labels))


def colmap_from_capture(capture: Capture) -> ColmapModel:
    """A COLMAP model (PINHOLE cameras, no points) of a capture's views; intrinsics per camera id.

    Raises
    ------
    SplatError
        Two views of one camera id with different intrinsics (COLMAP shares them per camera).
    """
    cameras, images = {}, {}
    for k, v in enumerate(capture.views, 1):
        c = v.camera
        params = (*map(float, np.asarray(c.focal)), *map(float, np.asarray(c.principal)))
        cam = ColmapCamera(v.camera_id, "PINHOLE", c.width, c.height, params)
        if cameras.setdefault(v.camera_id, cam) != cam:
            raise SplatError(
                f"views of camera {v.camera_id} have different intrinsics "
                f"({cameras[v.camera_id].params} vs {params}); give them separate camera ids."
            )
        images[k] = ColmapImage(
            k, rotmat_to_qvec(np.asarray(c.R, float)), np.asarray(c.t, float), v.camera_id, v.name
        )
    return ColmapModel(cameras, images)


def write_transforms(capture: Capture, path: str | Path) -> Path:
    """Write a nerfstudio ``transforms.json`` (OpenGL camera-to-world, per-frame intrinsics).

    Besides nerfstudio's keys, each frame stores ``camera_id`` and ``exposure``, and the top level
    ``channels`` (the channel map) and ``channel_labels``; nerfstudio ignores keys it does not know.
    """
    frames = []
    for v in capture.views:
        c = v.camera
        w2c = np.eye(4)
        w2c[:3, :3], w2c[:3, 3] = np.asarray(c.R, float), np.asarray(c.t, float)
        c2w = np.linalg.inv(w2c) @ _GL_FROM_CV
        (fx, fy), (cx, cy) = np.asarray(c.focal, float), np.asarray(c.principal, float)
        frames.append(
            {
                "file_path": v.name,
                "transform_matrix": c2w.tolist(),
                "fl_x": fx,
                "fl_y": fy,
                "cx": cx,
                "cy": cy,
                "w": c.width,
                "h": c.height,
                "camera_id": v.camera_id,
                "exposure": v.exposure,
            }
        )
    doc = {
        "camera_model": "OPENCV",
        "channels": {str(k): list(v) for k, v in capture.channels.items()},
        "channel_labels": list(capture.labels),
        "frames": frames,
    }
    from zonotope.utilities import atomic_write_text

    return atomic_write_text(path, json.dumps(doc, indent=1))


def _pixels(value, name: str) -> int:
    """An image size in pixels: a whole number (``16`` or ``16.0``), never rounded from ``15.7``."""
    if isinstance(value, bool) or not isinstance(value, int | float) or value != int(value) or value < 1:
        raise ValueError(f"{name} = {value!r}: an image size is a whole number of pixels ≥ 1")
    return int(value)


def read_transforms(path: str | Path, *, channels: dict[int, tuple[int, ...]] | None = None) -> Capture:
    """Read a nerfstudio ``transforms.json`` (global intrinsics with per-frame overrides).

    Parameters
    ----------
    path : path
    channels : dict, optional
        Channel map, overriding the file's ``channels`` key; without either, every camera id gets
        channels (0, 1, 2).

    Returns
    -------
    Capture

    Raises
    ------
    DataFormatError
        Invalid JSON, a missing or empty ``frames`` list, a frame without a pose or intrinsics, or
        an image size (``w``, ``h``) that is not a whole number of pixels.
    """
    path = Path(path)
    try:
        doc = json.loads(path.read_bytes().decode("utf-8"))
    except (json.JSONDecodeError, UnicodeDecodeError, RecursionError) as e:
        raise DataFormatError(f"{path}: not valid JSON ({e}).") from None
    except OSError as e:
        raise DataFormatError(f"{path}: cannot read ({e.strerror or e}).") from None
    if not isinstance(doc, dict) or not isinstance(doc.get("frames"), list) or not doc["frames"]:
        got = type(doc).__name__ if not isinstance(doc, dict) else f"frames = {doc.get('frames')!r:.40}"
        raise DataFormatError(f"{path}: expected a JSON object with a non-empty 'frames' list, got {got}.")
    views = []
    for k, fr in enumerate(doc.get("frames", [])):
        if not isinstance(fr, dict):
            raise DataFormatError(f"{path}: frame {k} is a {type(fr).__name__}, not an object.")
        get = lambda key, fr=fr: fr.get(key, doc.get(key))  # noqa: E731
        try:
            c2w = np.asarray(fr["transform_matrix"], float)
            if c2w.shape not in ((4, 4), (3, 4)) or not np.all(np.isfinite(c2w)):
                raise ValueError(f"transform_matrix must be a finite 4×4 (or 3×4) matrix, got {c2w.tolist()}")
            c2w = np.vstack([c2w[:3], [0.0, 0.0, 0.0, 1.0]]) @ _GL_FROM_CV
            w2c = np.linalg.inv(c2w)
            cam = _camera(
                w2c[:3, :3],
                w2c[:3, 3],
                float(get("fl_x")),
                float(get("fl_y") or get("fl_x")),
                float(get("cx")),
                float(get("cy")),
                _pixels(get("w"), "w"),
                _pixels(get("h"), "h"),
            )
            view = View(
                str(fr.get("file_path", f"frame_{k}")),
                cam,
                int(fr.get("camera_id", 1)),
                float(fr.get("exposure", 1.0)),
            )
        except SplatError as e:
            raise DataFormatError(f"{path}: frame {k}: {e}") from None
        except (KeyError, TypeError, ValueError, OverflowError, np.linalg.LinAlgError) as e:
            raise DataFormatError(f"{path}: frame {k} lacks a usable pose or intrinsics ({e!r}).") from None
        views.append(view)
    try:
        if channels is None:
            if "channels" in doc:
                channels = {int(k): tuple(int(i) for i in v) for k, v in doc["channels"].items()}
            else:
                channels = {cid: (0, 1, 2) for cid in {v.camera_id for v in views}}
        labels = tuple(str(x) for x in doc.get("channel_labels", ()))
        return Capture(tuple(views), channels, labels)
    except SplatError as e:
        raise DataFormatError(f"{path}: {e}") from None
    except (AttributeError, TypeError, ValueError, OverflowError) as e:
        raise DataFormatError(
            f"{path}: 'channels' must map camera ids to lists of channel indices and "
            f"'channel_labels' be a list of names ({e!r})."
        ) from None
