"""Pinhole cameras (OpenCV / COLMAP convention: x right, y down, z forward; pixel centres at +0.5)."""

from __future__ import annotations

from dataclasses import dataclass, field

import jax
import jax.numpy as jnp
import numpy as np

from ._errors import SplatError
from ._tol import SO3_TAYLOR_THETA2

__all__ = ["Camera", "look_at", "pose_corrected", "qvec_to_rotmat", "rotmat_to_qvec", "so3_exp"]


@jax.tree_util.register_dataclass
@dataclass(frozen=True)
class Camera:
    """A pinhole view: world-to-camera pose, intrinsics and the (static) image size.

    Attributes
    ----------
    R : Array of shape (3, 3)
        World-to-camera rotation, ``x_cam = R @ x_world + t`` (COLMAP's ``qvec``).
    t : Array of shape (3,)
        World-to-camera translation (COLMAP's ``tvec``).
    focal : Array of shape (2,)
        ``(fx, fy)`` in pixels.
    principal : Array of shape (2,)
        ``(cx, cy)`` in pixels, measured from the top-left corner of the image (so the centre of
        pixel ``(row i, column j)`` is at ``(j + 0.5, i + 0.5)``).
    width, height : int
        Image size in pixels; static (part of the pytree structure), so a change recompiles.
    """

    R: jax.Array
    t: jax.Array
    focal: jax.Array
    principal: jax.Array
    width: int = field(metadata=dict(static=True))
    height: int = field(metadata=dict(static=True))

    @property
    def centre(self) -> jax.Array:  # [3]
        """Camera centre in world coordinates ``-Rᵀ t``."""
        return -self.R.T @ self.t

    @property
    def K(self) -> np.ndarray:  # [3, 3]
        """Intrinsic matrix."""
        fx, fy = np.asarray(self.focal)
        cx, cy = np.asarray(self.principal)
        return np.array([[fx, 0, cx], [0, fy, cy], [0, 0, 1.0]])

    def scaled(self, factor: float) -> Camera:
        """The same view at ``factor`` times the resolution (intrinsics scaled, size rounded)."""
        return Camera(
            self.R,
            self.t,
            self.focal * factor,
            self.principal * factor,
            round(self.width * factor),
            round(self.height * factor),
        )


def _unit(v):
    n = np.linalg.norm(v)
    if n == 0:
        raise SplatError("look_at needs distinct eye and target and an up vector not along the view.")
    return v / n


def look_at(
    eye, target, *, up=(0.0, 0.0, 1.0), width: int, height: int, fov_deg: float = 50.0, dtype=jnp.float32
) -> Camera:
    """A camera at ``eye`` looking at ``target`` (horizontal field of view ``fov_deg``).

    Parameters
    ----------
    eye, target : array_like of shape (3,)
    up : array_like of shape (3,)
        World direction that appears up in the image.
    width, height : int
    fov_deg : float
        Horizontal field of view in degrees.

    Returns
    -------
    Camera
    """
    eye, target, up = (np.asarray(v, dtype=float) for v in (eye, target, up))
    z = _unit(target - eye)
    x = _unit(np.cross(z, up))  # right
    y = np.cross(z, x)  # down
    R = np.stack([x, y, z])
    f = 0.5 * width / np.tan(np.radians(fov_deg) / 2)
    return Camera(
        jnp.asarray(R, dtype),
        jnp.asarray(-R @ eye, dtype),
        jnp.asarray([f, f], dtype),
        jnp.asarray([width / 2, height / 2], dtype),
        int(width),
        int(height),
    )


def qvec_to_rotmat(qvec) -> np.ndarray:
    """Rotation matrix of a unit quaternion ``(w, x, y, z)`` (COLMAP convention), shape (3, 3)."""
    w, x, y, z = np.asarray(qvec, dtype=float) / np.linalg.norm(qvec)
    return np.array(
        [
            [1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
            [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
            [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)],
        ]
    )


def rotmat_to_qvec(R) -> np.ndarray:
    """Unit quaternion ``(w, x, y, z)`` with ``w ≥ 0`` of a rotation matrix (3, 3), shape (4,)."""
    R = np.asarray(R, dtype=float)
    K = (
        np.array(
            [
                [R[0, 0] - R[1, 1] - R[2, 2], 0, 0, 0],
                [R[1, 0] + R[0, 1], R[1, 1] - R[0, 0] - R[2, 2], 0, 0],
                [R[2, 0] + R[0, 2], R[2, 1] + R[1, 2], R[2, 2] - R[0, 0] - R[1, 1], 0],
                [R[2, 1] - R[1, 2], R[0, 2] - R[2, 0], R[1, 0] - R[0, 1], R[0, 0] + R[1, 1] + R[2, 2]],
            ]
        )
        / 3.0
    )
    vals, vecs = np.linalg.eigh(K)
    q = vecs[[3, 0, 1, 2], np.argmax(vals)]
    return -q if q[0] < 0 else q


def so3_exp(omega) -> jax.Array:
    """Rotation matrices ``exp([ω]×)`` of axis-angle vectors (Rodrigues' formula), differentiable at 0.

    ``R = I + A [ω]× + B [ω]×²`` with ``A = sin θ / θ``, ``B = (1 − cos θ) / θ²``, ``θ = |ω|``; below
    ``θ² = 1e-4`` (``splat._tol.SO3_TAYLOR_THETA2``) both come from their Taylor series (to θ⁴, exact
    to rounding), so neither the value nor the gradient has a 0/0 at ω = 0.

    Parameters
    ----------
    omega : array_like of shape (..., 3)
        Rotation axis times angle (radians).

    Returns
    -------
    Array of shape (..., 3, 3)
    """
    return _so3_exp(jnp.asarray(omega))


@jax.jit
def _so3_exp(omega: jax.Array) -> jax.Array:  # one compilation per shape, not one per operation
    x, y, z = omega[..., 0], omega[..., 1], omega[..., 2]
    th2 = x * x + y * y + z * z
    small = th2 < SO3_TAYLOR_THETA2
    th = jnp.sqrt(jnp.where(small, 1.0, th2))
    A = jnp.where(small, 1 - th2 / 6 * (1 - th2 / 20), jnp.sin(th) / th)
    B = jnp.where(small, 0.5 - th2 / 24 * (1 - th2 / 30), (1 - jnp.cos(th)) / jnp.where(small, 1.0, th2))
    zero = jnp.zeros_like(x)
    K = jnp.stack(
        [jnp.stack([zero, -z, y], -1), jnp.stack([z, zero, -x], -1), jnp.stack([-y, x, zero], -1)], -2
    )
    eye = jnp.eye(3, dtype=omega.dtype)
    return eye + A[..., None, None] * K + B[..., None, None] * (K @ K)


def pose_corrected(camera: Camera, correction) -> Camera:
    """The camera with a small rigid correction of its world-to-camera pose, applied in camera coordinates.

    ``x_cam' = exp([ω]×) x_cam + τ``, i.e. ``R' = exp([ω]×) R`` and ``t' = exp([ω]×) t + τ``: ``ω``
    turns the camera about its own centre (so a rotation does not move the centre, which keeps the
    rotation and translation parts apart), and the centre moves by ``−R'ᵀ τ``. Differentiable in
    ``correction`` (this is how :func:`splat.train` refines poses).

    Parameters
    ----------
    camera : Camera
    correction : array_like of shape (6,)
        ``(ω, τ)``: axis-angle rotation (radians) and translation (world units, camera axes).

    Returns
    -------
    Camera
        Same intrinsics and image size; ``pose_corrected(camera, 0)`` has exactly the same pose.
    """
    xi = jnp.asarray(correction, camera.R.dtype)
    if xi.shape != (6,):
        raise SplatError(f"correction: expected a 6-vector (ω, τ), got shape {xi.shape}.")
    dR = so3_exp(xi[:3])
    return Camera(
        dR @ camera.R, dR @ camera.t + xi[3:], camera.focal, camera.principal, camera.width, camera.height
    )
