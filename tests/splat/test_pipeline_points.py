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
