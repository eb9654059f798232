"""A synthetic multi-camera capture: real reflectances seen through real camera sensitivities.

The ground truth is itself a set of Gaussians (a floor tiled with the 24 ColorChecker patches and a few
blobs painted with other reflectances). Each Gaussian's N-channel colour is its reflectance seen by
every channel of every camera, ``x @ G`` with ``G = zonotope.generators(cameras, illuminant)`` (white
→ 1 per channel). Views are rendered with the exact reference renderer from known poses on an orbit,
camera by camera, and turned into RAW-like data: exposure, Bayer mosaic (or full-colour for Foveon-type
sensors), Poisson–Gaussian noise and clipping at 1.
"""

from __future__ import annotations

from dataclasses import dataclass

import jax.numpy as jnp
import numpy as np

from .._errors import SplatError
from ..camera import look_at
from ..data import Capture, View
from ..gaussians import Gaussians, init_gaussians
from ..rendering import RenderConfig, render_reference

__all__ = ["SceneConfig", "SyntheticScene", "bayer_mask", "synthetic_scene"]


@dataclass(frozen=True)
class SceneConfig:
    """Options of :func:`synthetic_scene`.

    Attributes
    ----------
    cameras : tuple of str
        Built-in camera names of :func:`zonotope.camera` (3 channels each).
    full_colour : tuple of str
        Cameras whose sensor measures every channel at every pixel (Foveon: the Sigma); the others
        are RGGB Bayer mosaics.
    illuminant : str
    reflectances : tuple of str
        Built-in reflectance sets; the first tiles the floor (24 patches), the rest paint the blobs.
    views_per_camera, test_views_per_camera : int
        Training and held-out views of each camera (held-out views sit between training views).
    width, height : int
    exposure_range : (float, float)
        Relative exposures drawn uniformly per view.
    noise : (float, float)
        Poisson–Gaussian noise ``σ² = a·y + b`` as ``(a, b)``.
    seed : int
    """

    cameras: tuple[str, ...] = ("Nikon 5100 (NPL)", "Sigma SDMerill (NPL)", "Canon EOS 5D Mark II")
    full_colour: tuple[str, ...] = ("Sigma SDMerill (NPL)",)
    illuminant: str = "D65"
    reflectances: tuple[str, ...] = ("ColorChecker N Ohta", "rawtoaces 190")
    views_per_camera: int = 12
    test_views_per_camera: int = 2
    width: int = 64
    height: int = 64
    exposure_range: tuple[float, float] = (0.7, 1.2)
    noise: tuple[float, float] = (2e-4, 1e-6)
    seed: int = 0


@dataclass(frozen=True)
class SyntheticScene:
    """Result of :func:`synthetic_scene` (V training views, T held-out views, N channels).

    Attributes
    ----------
    truth : Gaussians
        The ground-truth Gaussians.
    capture : Capture
        Training views (with ``camera_id`` 1, 2, ... per camera and their exposures).
    images : ndarray of shape (V, H, W, k)
        RAW-like measurements placed in the channels they measure (0 elsewhere).
    weights : ndarray of shape (V, H, W, k)
        1 where a channel is measured at a pixel (the mosaic), else 0.
    test : Capture
        Held-out views (exposure 1).
    test_images : ndarray of shape (T, H, W, k)
        Noise-free renders of every channel for the held-out views.
    generators : ndarray of shape (n_wavelengths, k)
    wavelengths : ndarray of shape (n_wavelengths,)
    bounds : ndarray of shape (2, 3)
        Lower and upper corner of a box around the scene (for initialisation).
    """

    truth: Gaussians
    capture: Capture
    images: np.ndarray
    weights: np.ndarray
    test: Capture
    test_images: np.ndarray
    generators: np.ndarray
    wavelengths: np.ndarray
    bounds: np.ndarray


def bayer_mask(height: int, width: int, pattern: str = "RGGB") -> np.ndarray:
    """Which of 3 channels each pixel of a Bayer mosaic measures, boolean of shape (H, W, 3).

    Parameters
    ----------
    height, width : int
    pattern : {"RGGB", "BGGR", "GRBG", "GBRG"}
    """
    if sorted(pattern) != ["B", "G", "G", "R"]:
        raise SplatError(f"pattern must be one of RGGB, BGGR, GRBG, GBRG; got {pattern!r}.")
    m = np.zeros((height, width, 3), bool)
    for k, ch in enumerate(pattern):
        m[k // 2 :: 2, k % 2 :: 2, "RGB".index(ch)] = True
    return m


def _scene_gaussians(refl_floor: np.ndarray, refl_blobs: np.ndarray, rng) -> tuple[np.ndarray, ...]:
    """Means, log-scales, quats, opacities and reflectance rows of the ground-truth Gaussians."""
    means, scales, refl = [], [], []
    # floor: 6 × 4 patches of 0.3 units, 4 × 4 flat Gaussians each
    for k in range(24):
        i, j = divmod(k, 6)
        cx, cy = (j - 2.5) * 0.32, (i - 1.5) * 0.32
        g = (np.arange(4) - 1.5) * 0.07
        gx, gy = np.meshgrid(cx + g, cy + g)
        means.append(np.stack([gx.ravel(), gy.ravel(), np.zeros(16)], -1))
        scales.append(np.tile([0.045, 0.045, 0.004], (16, 1)))
        refl.append(np.tile(refl_floor[k], (16, 1)))
    # blobs: 4 ellipsoidal clusters standing on the floor, each with a reflectance
    picks = rng.choice(len(refl_blobs), 4, replace=False)
    centres = [(-0.5, -0.15, 0.16), (0.45, 0.2, 0.2), (0.0, 0.3, 0.13), (0.55, -0.35, 0.1)]
    for (x, y, r), p in zip(centres, picks):
        d = rng.normal(size=(120, 3))
        d /= np.linalg.norm(d, axis=1, keepdims=True)
        means.append(np.array([x, y, r]) + r * d * np.array([1, 1, 1.3]))
        scales.append(np.full((120, 3), 0.3 * r))
        refl.append(np.tile(refl_blobs[p], (120, 1)))
    means, scales, refl = (np.concatenate(a) for a in (means, scales, refl))
    return means, np.log(scales), refl


def synthetic_scene(config: SceneConfig = SceneConfig()) -> SyntheticScene:
    """Render a synthetic multi-camera RAW capture of a procedural scene with real reflectances.

    Parameters
    ----------
    config : SceneConfig

    Returns
    -------
    SyntheticScene
        ``k = 3 × len(config.cameras)`` channels; camera ``k`` (id ``k + 1``) measures channels
        ``3k, 3k + 1, 3k + 2``.

    Examples
    --------
    >>> from splat import SceneConfig, synthetic_scene
    >>> s = synthetic_scene(SceneConfig(views_per_camera=2, test_views_per_camera=1, width=16, height=16))
    >>> s.images.shape, s.test_images.shape
    ((6, 16, 16, 9), (3, 16, 16, 9))
    """
    import zonotope  # the spectral layer, only needed here

    if len(config.cameras) < 1 or config.views_per_camera < 1:
        raise SplatError("synthetic_scene needs at least one camera and one view per camera.")
    rng = np.random.default_rng(config.seed)
    cams = [zonotope.camera(c) for c in config.cameras]
    sets = [zonotope.reflectances(r) for r in config.reflectances]
    shape = zonotope.common_shape(*cams, *sets)
    G = zonotope.generators(cams, config.illuminant, shape)
    refl = [zonotope.resample(s, shape).T for s in sets]  # (n_samples, n_λ)
    means, log_scales, rows = _scene_gaussians(refl[0], refl[-1], rng)
    colours = rows @ G.values  # (n_gauss, k)
    truth = init_gaussians(means, colours, opacity=0.95)
    truth = Gaussians(
        truth.means,
        truth.quats,
        jnp.asarray(log_scales, jnp.float32),
        truth.opacity_logits,
        truth.colour_params,
    )
    N = colours.shape[1]
    H, W = config.height, config.width
    ref_cfg = RenderConfig(chunk=64)

    def views(n_per_cam, offset, test):
        out, imgs = [], []
        n_cam = len(config.cameras)
        for k in range(n_per_cam):
            for c in range(n_cam):
                a = 2 * np.pi * (k + (c + offset) / n_cam) / n_per_cam
                elev = 0.55 + 0.25 * np.sin(3 * a + c)
                eye = 3.4 * np.array([np.cos(a) * np.cos(elev), np.sin(a) * np.cos(elev), np.sin(elev)])
                cam = look_at(eye, (0, 0, 0.1), width=W, height=H, fov_deg=45)
                e = 1.0 if test else float(rng.uniform(*config.exposure_range))
                name = f"{'test' if test else 'train'}_{config.cameras[c]}_{k:02d}.raw"
                out.append(View(name, cam, c + 1, e))
                imgs.append(np.asarray(render_reference(truth, cam, config=ref_cfg).image))
        return out, np.stack(imgs)

    channels = {c + 1: (3 * c, 3 * c + 1, 3 * c + 2) for c in range(len(config.cameras))}
    labels = tuple(G.labels)
    train_views, clean = views(config.views_per_camera, 0.0, False)
    test_views, test_images = views(config.test_views_per_camera, 0.5, True)
    images = np.zeros((len(train_views), H, W, N), np.float32)
    weights = np.zeros_like(images)
    a, b = config.noise
    for v, (view, img) in enumerate(zip(train_views, clean)):
        idx = list(channels[view.camera_id])
        m = (
            np.ones((H, W, 3), bool)
            if config.cameras[view.camera_id - 1] in config.full_colour
            else bayer_mask(H, W)
        )
        y = view.exposure * img[..., idx]
        y = y + np.sqrt(a * y + b) * rng.standard_normal(y.shape)
        images[v][..., idx] = np.where(m, np.clip(y, 0, 1), 0)
        weights[v][..., idx] = m
    lo, hi = means.min(0) - 0.1, means.max(0) + 0.1
    return SyntheticScene(
        truth,
        Capture(tuple(train_views), channels, labels),
        images,
        weights,
        Capture(tuple(test_views), channels, labels),
        test_images.astype(np.float32),
        np.asarray(G.values),
        np.asarray(G.wavelengths),
        np.stack([lo, hi]),
    )
