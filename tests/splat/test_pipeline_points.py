"""splat.capture's initial points: every COLMAP point starts a Gaussian; the bounds ignore the periphery."""

from __future__ import annotations

import numpy as np

from splat.capture.train import _scene_points
from splat.colmap import ColmapModel, ColmapPoint3D


def _model(xyz):
    grey = np.array([128, 128, 128], np.uint8)
    pts = {
        i + 1: ColmapPoint3D(i + 1, p, grey, 0.0, np.zeros(0, int), np.zeros(0, int))
        for i, p in enumerate(np.asarray(xyz, float))
    }
    return ColmapModel(cameras={}, images={}, points3D=pts)


def test_every_point_starts_a_gaussian_and_the_bounds_are_the_percentile_box():
    """A backdrop seen by few views holds few points, which fall outside the 2–98th percentile box; they
    must still start Gaussians (filtering them by that box left the benchmark capture's backdrop to
    Gaussians cloned from nearer ones, which settled 1–3 m in front of it). The box of each coordinate's
    2nd and 98th percentiles (padded by 10 %) stays the bounds: neither the backdrop nor a far stray
    point widens it (it sets the centres' learning rate)."""
    rng = np.random.default_rng(0)
    core = rng.uniform(0, 1, (2000, 3))
    backdrop = np.c_[rng.uniform(1.2, 1.5, 30), rng.uniform(0, 1, (30, 2))]  # 1.5 % of the points
    stray = np.array([[0.5, 0.5, 1e4]])
    xyz = np.concatenate([core, backdrop, stray])
    kept, rgb, bounds = _scene_points(_model(xyz), [])
    np.testing.assert_array_equal(kept, xyz)
    assert rgb.shape == (len(xyz), 3)
    lo, hi = np.percentile(xyz, 2, axis=0), np.percentile(xyz, 98, axis=0)
    np.testing.assert_allclose(bounds, [lo - 0.1 * (hi - lo), hi + 0.1 * (hi - lo)])
    assert bounds[1, 0] < 1.2 and bounds[1, 2] < 2  # not widened by the backdrop or the stray


def _ring(n: int, radius: float, height: float, target=(0.0, 0.0, 0.0)):
    """``n`` cameras on a ring, each looking at ``target`` (64 × 48 px, focal 60 px)."""
    from splat.camera import Camera

    cams = []
    for a in np.linspace(0, 2 * np.pi, n, endpoint=False):
        o = np.array([radius * np.cos(a), radius * np.sin(a), height])
        z = np.asarray(target) - o
        z /= np.linalg.norm(z)
        x = np.cross(z, [0.0, 0.0, 1.0])
        x /= np.linalg.norm(x)
        R = np.stack([x, np.cross(z, x), z])  # rows: the camera's axes in the world
        cams.append(Camera(R, -R @ o, np.array([60.0, 60.0]), np.array([32.0, 24.0]), 64, 48))
    return cams


def test_a_model_without_points_starts_where_the_cameras_look():
    """A poses-only model (no points): the Gaussians start where the views overlap, around the point the
    cameras look at, not in the box of the camera centres (where nothing of the scene is; training from
    there made a three-camera capture's loss rise). Every point is in front of at least half of the
    cameras and inside their images, their median is near the looked-at point, and the bounds hold it
    (a box around these camera centres is flat at their height)."""
    target = np.array([0.3, -0.2, 0.1])
    cams = _ring(8, 4.0, 2.0, target)
    xyz, rgb, bounds = _scene_points(_model(np.zeros((0, 3))), cams)
    assert len(xyz) > 1000 and rgb.shape == (len(xyz), 3)
    assert ((target > bounds[0]) & (target < bounds[1])).all()
    seen = np.zeros(len(xyz), int)
    for c in cams:
        p = xyz @ np.asarray(c.R).T + np.asarray(c.t)
        uv = p[:, :2] / p[:, 2:] * 60 + [32, 24]
        seen += (p[:, 2] > 0) & (uv >= 0).all(1) & (uv < [64, 48]).all(1)
    assert (seen >= 4).all()
    np.testing.assert_allclose(np.median(xyz, 0), target, atol=0.5)


def test_parallel_cameras_without_points_still_get_points_in_front():
    """Forward-facing cameras (parallel axes: no point nearest every axis) fall back on their spread as
    the depth scale: finite points in front of every camera."""
    from splat.camera import Camera

    cams = [
        Camera(np.eye(3), np.array([-x, 0.0, 0.0]), np.array([60.0, 60.0]), np.array([32.0, 24.0]), 64, 48)
        for x in (0.0, 0.5, 1.0)
    ]
    xyz, _, bounds = _scene_points(_model(np.zeros((0, 3))), cams)
    assert len(xyz) > 100 and np.isfinite(xyz).all() and np.isfinite(bounds).all()
    assert (xyz[:, 2] > 0).all()
