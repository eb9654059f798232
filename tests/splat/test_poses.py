"""splat.poses: COLMAP (pycolmap, CPU SIFT) recovers the poses of rendered 8-bit previews."""

from __future__ import annotations

import numpy as np
import pytest
from PIL import Image

from splat import PoseConfig, SplatError, capture_from_colmap, init_gaussians, look_at, recover_poses, render


def similarity(X, Y):
    """Umeyama (1991): s, R, t minimising |s R X + t − Y|."""
    mx, my = X.mean(0), Y.mean(0)
    U, S, Vt = np.linalg.svd((Y - my).T @ (X - mx) / len(X))
    D = np.eye(3)
    D[2, 2] = np.sign(np.linalg.det(U @ Vt))
    R = U @ D @ Vt
    s = np.trace(np.diag(S) @ D) / (X - mx).var(0).sum()
    return s, R, my - s * R @ mx


def test_recovers_rendered_poses_up_to_similarity(tmp_path):
    rng = np.random.default_rng(0)
    n = 2500  # confetti on a floor and two walls: texture for SIFT
    pts = np.concatenate(
        [
            np.c_[rng.uniform(-1, 1, (n, 2)), np.zeros(n)],
            np.c_[rng.uniform(-1, 1, n), np.ones(n), rng.uniform(0, 1.2, n)],
            np.c_[-np.ones(n), rng.uniform(-1, 1, n), rng.uniform(0, 1.2, n)],
        ]
    )
    g = init_gaussians(
        pts, rng.uniform(0, 1, (3 * n, 3)), scales=rng.uniform(0.01, 0.03, 3 * n), opacity=0.95
    )
    truth = {}
    for k in range(12):
        a = -np.pi / 2 - 1.7 + 1.4 * k / 11
        cam = look_at(
            (2.8 * np.cos(a), 2.8 * np.sin(a), 1.6), (-0.3, 0.3, 0.3), width=160, height=160, fov_deg=55
        )
        folder = tmp_path / "images" / f"cam{k % 3 + 1}"
        folder.mkdir(parents=True, exist_ok=True)
        img = np.clip(np.asarray(render(g, cam).image), 0, 1) ** (1 / 2.2)
        Image.fromarray((255 * img).astype(np.uint8)).save(folder / f"{k:02d}.png")
        truth[f"cam{k % 3 + 1}/{k:02d}.png"] = cam
    model = recover_poses(tmp_path / "images", tmp_path / "work", config=PoseConfig(num_threads=2))
    assert len(model.cameras) == 3  # one COLMAP camera per folder
    capture = capture_from_colmap(model)
    assert len(capture.views) >= 10
    est = np.array([np.asarray(v.camera.centre) for v in capture.views])
    ref = np.array([np.asarray(truth[v.name].centre) for v in capture.views])
    s, R, t = similarity(est, ref)
    assert np.abs(s * est @ R.T + t - ref).max() < 0.05
    f = np.asarray(truth["cam1/00.png"].focal)[0]
    for v in capture.views:
        assert abs(float(v.camera.focal[0]) / f - 1) < 0.08


def test_no_images(tmp_path):
    with pytest.raises(SplatError, match="sub-folders"):
        recover_poses(tmp_path, tmp_path / "work")
