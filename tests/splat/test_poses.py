"""splat.poses: COLMAP (pycolmap, CPU SIFT) recovers the poses of rendered 8-bit previews."""

from __future__ import annotations

import numpy as np
import pytest
from PIL import Image

from splat import PoseConfig, SplatError, capture_from_colmap, init_gaussians, look_at, recover_poses, render
from splat.camera import qvec_to_rotmat


def similarity(X, Y):
    """Umeyama (1991): s, R, t minimising |s R X + t − Y|."""
    mx, my = X.mean(0), Y.mean(0)
    U, S, Vt = np.linalg.svd((Y - my).T @ (X - mx) / len(X))
    D = np.eye(3)
    D[2, 2] = np.sign(np.linalg.det(U @ Vt))
    R = U @ D @ Vt
    s = np.trace(np.diag(S) @ D) / (X - mx).var(0).sum()
    return s, R, my - s * R @ mx


def _confetti_views(tmp_path, views: int = 12):
    """8-bit renders of confetti on a floor (z = 0) and two walls (y = 1, x = −1) in three camera
    folders; returns the true cameras by image name."""
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
    for k in range(views):
        a = -np.pi / 2 - 1.7 + 1.4 * k / (views - 1)
        cam = look_at(
            (2.8 * np.cos(a), 2.8 * np.sin(a), 1.6), (-0.3, 0.3, 0.3), width=160, height=160, fov_deg=55
        )
        folder = tmp_path / "images" / f"cam{k % 3 + 1}"
        folder.mkdir(parents=True, exist_ok=True)
        img = np.clip(np.asarray(render(g, cam).image), 0, 1) ** (1 / 2.2)
        Image.fromarray((255 * img).astype(np.uint8)).save(folder / f"{k:02d}.png")
        truth[f"cam{k % 3 + 1}/{k:02d}.png"] = cam
    return truth


def test_recovers_rendered_poses_up_to_similarity(tmp_path):
    truth = _confetti_views(tmp_path)
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


def test_points_triangulated_from_known_poses_lie_on_the_scene(tmp_path):
    """Known poses (the renders' true cameras, no points): the triangulated points lie on the floor and
    walls the confetti were rendered on, within the confetti's own thickness (Gaussians of 1–3 cm
    scale on a scene 2 m across: median 2 cm, 95 % within 6 cm; the focal lengths 10 % off give 3 / 10
    cm); the poses and intrinsics come back unchanged, and each point is seen by at least two
    photographs."""
    from splat.camera import rotmat_to_qvec
    from splat.colmap import ColmapCamera, ColmapImage, ColmapModel
    from splat.poses import triangulate_points

    truth = _confetti_views(tmp_path, views=9)
    cams, images = {}, {}
    for i, (name, c) in enumerate(sorted(truth.items())):
        k = int(name[3])
        fx, fy = np.asarray(c.focal, float)
        cx, cy = np.asarray(c.principal, float)
        cams[k] = ColmapCamera(k, "PINHOLE", c.width, c.height, (fx, fy, cx, cy))
        R, t = np.asarray(c.R, float), np.asarray(c.t, float)
        images[i + 1] = ColmapImage(i + 1, rotmat_to_qvec(R), t, k, name)
    given = ColmapModel(cams, images, {})
    got = triangulate_points(tmp_path / "images", tmp_path / "work", given, config=PoseConfig(num_threads=2))
    xyz = np.array([p.xyz for p in got.points3D.values()])
    assert len(xyz) > 200
    planes = np.stack([np.abs(xyz[:, 2]), np.abs(xyz[:, 1] - 1), np.abs(xyz[:, 0] + 1)], 1)
    assert np.median(planes.min(1)) < 0.03 and np.quantile(planes.min(1), 0.95) < 0.08
    assert all(len(p.image_ids) >= 2 for p in got.points3D.values())
    for im in got.images.values():
        c = truth[im.name]
        np.testing.assert_allclose(qvec_to_rotmat(im.qvec), np.asarray(c.R), atol=1e-6)  # float32 cameras
        np.testing.assert_allclose(im.tvec, np.asarray(c.t), atol=1e-6)
        np.testing.assert_allclose(got.cameras[im.camera_id].pinhole()[0], float(c.focal[0]), rtol=1e-6)


def test_triangulating_an_image_that_is_not_there_is_refused(tmp_path):
    from splat.colmap import ColmapCamera, ColmapImage, ColmapModel
    from splat.poses import triangulate_points

    _confetti_views(tmp_path, views=3)
    model = ColmapModel(
        {1: ColmapCamera(1, "PINHOLE", 160, 160, (150.0, 150.0, 80.0, 80.0))},
        {1: ColmapImage(1, np.array([1.0, 0, 0, 0]), np.zeros(3), 1, "cam1/missing.png")},
        {},
    )
    with pytest.raises(SplatError, match=r"missing\.png"):
        triangulate_points(tmp_path / "images", tmp_path / "work", model, config=PoseConfig(num_threads=2))
