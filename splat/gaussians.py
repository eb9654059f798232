"""The scene model: 3-D Gaussians with one opacity each and N non-negative linear colour channels.

The parameters are stored unconstrained (log-scales, opacity logits, pre-softplus colours) so that
plain gradient descent keeps every derived quantity valid; the properties give the constrained values.
"""

from __future__ import annotations

from dataclasses import dataclass

import jax
import jax.numpy as jnp
import numpy as np

from ._errors import SplatError

__all__ = [
    "Gaussians",
    "covariances_from",
    "depth_colour_params",
    "init_gaussians",
    "inverse_softplus",
    "quat_to_rotmat",
]


@jax.tree_util.register_dataclass
@dataclass(frozen=True)
class Gaussians:
    """N-channel 3-D Gaussians (a pytree; every field is a leaf with the Gaussians on axis 0).

    Attributes
    ----------
    means : Array of shape (G, 3)
        Centres in world coordinates.
    quats : Array of shape (G, 4)
        Rotations as quaternions ``(w, x, y, z)``; they need not be normalised.
    log_scales : Array of shape (G, 3)
        Natural logarithms of the standard deviations along the rotated axes.
    opacity_logits : Array of shape (G,)
        ``opacity = sigmoid(opacity_logits)``: ONE opacity per Gaussian, shared by every channel
        (the geometry is the same for all cameras; only the colours differ).
    colour_params : Array of shape (G, k)
        ``colours = softplus(colour_params)``: linear RAW-space responses, non-negative, any k ≥ 1.
    """

    means: jax.Array
    quats: jax.Array
    log_scales: jax.Array
    opacity_logits: jax.Array
    colour_params: jax.Array

    @property
    def n(self) -> int:
        """Number of Gaussians G (the buffer size, alive or not)."""
        return self.means.shape[0]

    @property
    def n_channels(self) -> int:
        """Number of colour channels k."""
        return self.colour_params.shape[-1]

    @property
    def scales(self) -> jax.Array:  # [G, 3]
        """Standard deviations along the principal axes, ``exp(log_scales)``."""
        return jnp.exp(self.log_scales)

    @property
    def opacities(self) -> jax.Array:  # [G]
        """Opacities in (0, 1), ``sigmoid(opacity_logits)``."""
        return jax.nn.sigmoid(self.opacity_logits)

    @property
    def colours(self) -> jax.Array:  # [G, k]
        """Non-negative N-channel colours, ``softplus(colour_params)``."""
        return jax.nn.softplus(self.colour_params)

    @property
    def rotations(self) -> jax.Array:  # [G, 3, 3]
        """Rotation matrices of the Gaussians' principal axes."""
        return quat_to_rotmat(self.quats)

    def covariances(self) -> jax.Array:  # [G, 3, 3]
        """World-space covariances ``R S Sᵀ Rᵀ``, shape (G, 3, 3)."""
        return covariances_from(self.quats, self.log_scales)

    def to_numpy(self) -> dict[str, np.ndarray]:
        """The raw parameters as a dict of NumPy arrays (for checkpoints and export)."""
        return {k: np.asarray(getattr(self, k)) for k in _FIELDS}

    @classmethod
    def from_numpy(cls, arrays: dict[str, np.ndarray], *, dtype=jnp.float32) -> Gaussians:
        """Inverse of :meth:`to_numpy`."""
        missing = [k for k in _FIELDS if k not in arrays]
        if missing:
            raise SplatError(f"Gaussian parameters are missing the field(s) {missing}; need {list(_FIELDS)}.")
        return cls(**{k: jnp.asarray(arrays[k], dtype=dtype) for k in _FIELDS})


_FIELDS = ("means", "quats", "log_scales", "opacity_logits", "colour_params")


def quat_to_rotmat(q: jax.Array) -> jax.Array:
    """Rotation matrices of quaternions ``(w, x, y, z)`` (normalised here).

    Parameters
    ----------
    q : array_like of shape (..., 4)

    Returns
    -------
    Array of shape (..., 3, 3)
    """
    q = jnp.asarray(q)
    q = q / jnp.linalg.norm(q, axis=-1, keepdims=True)
    w, x, y, z = q[..., 0], q[..., 1], q[..., 2], q[..., 3]
    rows = [
        [1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
        [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
        [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)],
    ]
    return jnp.stack([jnp.stack(r, axis=-1) for r in rows], axis=-2)


def covariances_from(quats: jax.Array, log_scales: jax.Array) -> jax.Array:
    """Covariances ``Σ = R S Sᵀ Rᵀ`` (Kerbl et al. 2023, eq. 6).

    Parameters
    ----------
    quats : array_like of shape (..., 4)
    log_scales : array_like of shape (..., 3)

    Returns
    -------
    Array of shape (..., 3, 3)
    """
    M = quat_to_rotmat(quats) * jnp.exp(log_scales)[..., None, :]
    return M @ jnp.swapaxes(M, -1, -2)


def inverse_softplus(y: np.ndarray | jax.Array, *, floor: float = 1e-6) -> jax.Array:
    """``x`` with ``softplus(x) = y`` (``y`` clipped at ``floor`` so the result is finite), same shape."""
    y = jnp.maximum(jnp.asarray(y), floor)
    return y + jnp.log(-jnp.expm1(-y))


def depth_colour_params(gaussians: Gaussians, camera, *, near: float, scale: float = 1.0) -> jax.Array:
    """``colour_params`` (G,) of one channel that holds each Gaussian's camera depth ``max(z, near) / scale``
    (``softplus⁻¹``): rendered, it composites to ``Σ_i w_i z_i / scale`` (``render_depth`` and the training
    depth term). Gaussians behind ``near`` are never drawn; the clip only keeps the inverse finite."""
    R = jnp.asarray(camera.R, gaussians.means.dtype)
    z = gaussians.means @ R[2] + jnp.asarray(camera.t, gaussians.means.dtype)[2]
    return inverse_softplus(jnp.maximum(z, near) / scale)


def init_gaussians(
    means, colours, *, scales=0.05, opacity: float = 0.1, key: jax.Array | None = None, dtype=jnp.float32
) -> Gaussians:
    """Isotropic Gaussians at given points with given colours.

    Parameters
    ----------
    means : array_like of shape (G, 3)
    colours : array_like of shape (G, k)
        Initial non-negative colours (k channels).
    scales : float or array_like of shape (G,)
        Standard deviation of each Gaussian, in world units.
    opacity : float
        Initial opacity in (0, 1), the same for all.
    key : jax.random key, optional
        If given, the rotations are random (otherwise identity).
    dtype
        Floating dtype of the parameters.

    Returns
    -------
    Gaussians
    """
    means = jnp.asarray(means, dtype=dtype)
    colours = jnp.asarray(colours, dtype=dtype)
    if means.ndim != 2 or means.shape[1] != 3:
        raise SplatError(f"means must have shape (G, 3); got {means.shape}.")
    if colours.ndim != 2 or colours.shape[0] != means.shape[0] or colours.shape[1] < 1:
        raise SplatError(
            f"colours must have shape (G, k) with G = {means.shape[0]} and k ≥ 1; got {colours.shape}."
        )
    if not 0 < opacity < 1:
        raise SplatError(f"opacity must lie in (0, 1); got {opacity}.")
    G = means.shape[0]
    s = jnp.broadcast_to(jnp.asarray(scales, dtype=dtype), (G,))
    if key is None:
        quats = jnp.tile(jnp.asarray([1, 0, 0, 0], dtype=dtype), (G, 1))
    else:
        quats = jax.random.normal(key, (G, 4), dtype=dtype)
    return Gaussians(
        means=means,
        quats=quats,
        log_scales=jnp.tile(jnp.log(s)[:, None], (1, 3)),
        opacity_logits=jnp.full((G,), np.log(opacity / (1 - opacity)), dtype=dtype),
        colour_params=inverse_softplus(colours).astype(dtype),
    )
