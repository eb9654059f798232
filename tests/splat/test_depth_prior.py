"""Sparse depth from COLMAP tracks: the simulator's tracks, the poses step keeping them, the targets each
view gets (:func:`splat.capture.depth_targets`) and the training term (``TrainConfig.depth_weight``)."""

from __future__ import annotations

import dataclasses

import jax.numpy as jnp
import numpy as np
import pytest

from splat import RenderConfig, TrainConfig, init_state, look_at, render_depth, train, train_step
from splat.capture import PipelineConfig, depth_targets
from splat.colmap import ColmapCamera, ColmapImage, ColmapModel, ColmapPoint3D, read_colmap
from splat.data import Capture, View, capture_from_colmap


def _qvec(R):
    from scipy.spatial.transform import Rotation

    x, y, z, w = Rotation.from_matrix(R).as_quat()
    return np.array([w, x, y, z])


def test_depth_targets_are_the_tracked_points_projected_into_each_view():
    """Two views of 60 points; a point enters a view's targets only if its track holds that view (and it
    lies in the frame): the pixel is the one its projection falls in, the depth its camera z."""
    rng = np.random.default_rng(1)
    xyz = rng.uniform(-1, 1, (60, 3))
    cams = [
        look_at((0, 0, -5), (0, 0, 0), up=(0, 1, 0), width=40, height=30),
        look_at((2, 0, -4), (0, 0, 0), up=(0, 1, 0), width=40, height=30),
    ]
    images = {
        i + 1: ColmapImage(i + 1, _qvec(np.asarray(c.R, float)), np.asarray(c.t, float), 1, f"v{i}")
        for i, c in enumerate(cams)
    }
    f, cx, cy = float(cams[0].focal[0]), float(cams[0].principal[0]), float(cams[0].principal[1])
    model = ColmapModel(
        {1: ColmapCamera(1, "PINHOLE", 40, 30, (f, f, cx, cy))},
        images,
        {
            k + 1: ColmapPoint3D(
                k + 1,
                p,
                np.zeros(3, np.uint8),
                0.0,
                np.array([1, 2] if k % 3 == 0 else [1 + k % 2]),
                np.zeros(0),
            )
            for k, p in enumerate(xyz)
        },
    )
    views = capture_from_colmap(model).views
    pixel, depth, valid = depth_targets(model, views)
    assert pixel.shape == depth.shape == valid.shape and len(pixel) == 2
    for i, v in enumerate(views):
        R, t = np.asarray(v.camera.R, float), np.asarray(v.camera.t, float)
        expect = set()
        for k, p in enumerate(xyz):
            if not (k % 3 == 0 or 1 + k % 2 == i + 1):
                continue
            q = R @ p + t
            u, w = f * q[0] / q[2] + cx, f * q[1] / q[2] + cy
            if q[2] > 0 and 0 <= u < 40 and 0 <= w < 30:
                expect.add((int(w) * 40 + int(u), round(float(q[2]), 4)))
        got = {(int(a), round(float(b), 4)) for a, b in zip(pixel[i][valid[i]], depth[i][valid[i]])}
        assert got == expect and len(got) > 10
    no_tracks = ColmapModel(
        model.cameras,
        images,
        {k: ColmapPoint3D(k, p.xyz, p.rgb, 0.0, np.zeros(0), np.zeros(0)) for k, p in model.points3D.items()},
    )
    assert depth_targets(no_tracks, views) is None


@pytest.fixture(scope="module")
def ci_capture(tmp_path_factory):
    from splat.sim.capture import SimCaptureConfig, write_synthetic_capture

    return write_synthetic_capture(tmp_path_factory.mktemp("depth") / "cap", SimCaptureConfig.ci())


def test_simulated_tracks_are_the_training_views_that_see_each_point(ci_capture):
    """Each point's track names the training views whose keypoint lies where the point projects; every
    point is seen at least by the view it was sampled from, most by many; held-out views observe none."""
    from splat.capture import read_capture

    model = read_colmap(ci_capture / "truth")
    hold = set(read_capture(ci_capture).holdout)
    cams = capture_from_colmap(model).views
    by_id = {iid: v for iid, v in zip(sorted(model.images), cams)}
    lengths = []
    for p in model.points3D.values():
        lengths.append(len(p.image_ids))
        for iid, j in zip(p.image_ids, p.point2D_idxs):
            im, v = model.images[int(iid)], by_id[int(iid)]
            assert im.name not in hold and im.point3D_ids[j] == p.id
            q = np.asarray(v.camera.R, float) @ p.xyz + np.asarray(v.camera.t, float)
            uv = np.asarray(v.camera.focal, float) * q[:2] / q[2] + np.asarray(v.camera.principal, float)
            np.testing.assert_allclose(im.xys[j], uv, atol=1e-4)  # text files: ~7 digits
    assert min(lengths) >= 1 and np.median(lengths) >= 5


def test_poses_step_keeps_the_tracks_and_training_inputs_carry_the_depth(ci_capture, tmp_path):
    """A user-supplied COLMAP model (here the simulator's true one): the poses step renumbers the images,
    and the tracks follow, so each training view's targets are its own observations."""
    import shutil

    from splat.capture import poses_step, read_capture, training_inputs

    cap = tmp_path / "cap"
    shutil.copytree(ci_capture, cap)
    shutil.copytree(cap / "truth", cap / "poses", ignore=shutil.ignore_patterns("xyz"))
    with open(cap / "capture.toml", "a") as fh:
        fh.write('\n[poses]\ncolmap = "poses"\n')
    poses_step(cap, tmp_path / "out")
    truth, ours = read_colmap(cap / "truth"), read_colmap(tmp_path / "out" / "poses" / "model")
    names = {iid: im.name for iid, im in ours.images.items()}
    for pid, p in truth.points3D.items():
        assert sorted(truth.images[int(i)].name for i in p.image_ids) == sorted(
            names[int(i)] for i in ours.points3D[pid].image_ids
        )
    inp = training_inputs(read_capture(cap), tmp_path / "out")
    pixel, depth, valid = inp.depth
    assert len(pixel) == len(inp.views) and valid.sum(1).min() > 100
    H, W = inp.images.shape[1:3]
    assert pixel[valid].max() < H * W and depth[valid].min() > 0


def test_depth_term_pulls_the_drawn_depth_onto_the_points():
    """A sheet of Gaussians at depth 4 and targets saying 5, no data term (all weights 0): with
    ``depth_weight`` the term ``|Σ w z − A z*| / z*`` falls — the sheet moves back and, with nothing to
    draw, fades (the data term is what keeps a real surface opaque) — and without it nothing moves. The
    flatness penalty on top must not switch the depth term off (it once replaced the total loss)."""
    cam = look_at((0, 0, -4), (0, 0, 0), up=(0, 1, 0), width=24, height=24)
    g = np.stack(np.meshgrid(np.linspace(-1, 1, 9), np.linspace(-1, 1, 9), [0.0], indexing="ij"), -1).reshape(
        -1, 3
    )
    capture = Capture((View("v", cam, 1, 1.0),), {1: (0,)}, ("x",))
    images = np.zeros((1, 24, 24, 1), np.float32)
    pix = np.arange(4, 20, 3)
    pixel = (pix[:, None] * 24 + pix[None, :]).reshape(1, -1)
    targets = (pixel, np.full(pixel.shape, 5.0, np.float32), np.ones(pixel.shape, bool))
    bounds = np.array([[-5.0, -5, -5], [5, 5, 5]])

    def drawn(weight, flatten=0.0):
        cfg = TrainConfig(
            steps=60, capacity=len(g), densify_from=10_000, depth_weight=weight, flatten_weight=flatten
        )
        res = train(
            capture,
            images,
            images,
            config=cfg,
            bounds=bounds,
            points=g,
            colours=np.full((len(g), 1), 0.5),
            depth=targets,
        )
        d, a = render_depth(res.gaussians, cam, mask=res.alive)
        at = pixel[0]
        return d.reshape(-1)[at], a.reshape(-1)[at]

    d0, a0 = drawn(0.0)
    np.testing.assert_allclose(d0, 4.0, atol=1e-3)
    d1, a1 = drawn(1.0)
    d2, a2 = drawn(1.0, flatten=1.0)
    assert np.nanmean(d1) > 4.1 and np.nanmean(d2) > 4.1
    term = [np.mean(np.nan_to_num(a * np.abs(d - 5))) / 5 for d, a in ((d0, a0), (d1, a1), (d2, a2))]
    assert term[1] < 0.5 * term[0] and term[2] < 0.5 * term[0]


def test_bad_depth_targets_are_refused():
    from splat import SplatError

    cam = look_at((0, 0, -4), (0, 0, 0), up=(0, 1, 0), width=8, height=8)
    capture = Capture((View("v", cam, 1, 1.0),), {1: (0,)}, ("x",))
    im = np.zeros((1, 8, 8, 1), np.float32)
    cfg = TrainConfig(steps=1, capacity=8, depth_weight=1.0)
    bounds = np.array([[-1.0, -1, -1], [1, 1, 1]])
    bad = {
        "pixel outside": (np.array([[64]]), np.array([[2.0]]), np.array([[True]])),  # 8 × 8 = 64 pixels
        "shape": (np.array([1]), np.array([2.0]), np.array([True])),  # not (V, D)
    }
    for message, depth in bad.items():
        with pytest.raises(SplatError, match=message):
            train(capture, im, im, config=cfg, bounds=bounds, depth=depth)
    with pytest.raises(SplatError, match="depth_weight"):
        TrainConfig(depth_weight=-1)


def test_pipeline_and_training_share_the_depth_weight_default():
    """``PipelineConfig``'s depth weight is its ``TrainConfig``'s, whose default it keeps."""
    assert PipelineConfig().depth_weight == TrainConfig().depth_weight > 0


def test_depth_term_is_the_same_on_every_back_end():
    """The depth term renders each Gaussian's depth as one more colour channel, so every back-end must
    carry it: the GPU's ``"tiled"`` one (which CI never trains with) gives the same gradient of the
    term as the CPU's and the dense reference. With the data term off (zero weights) the centres' screen
    gradient that one ``train_step`` accumulates is the depth term's alone."""
    cam = look_at((0, 0, -4), (0.1, 0, 0), up=(0, 1, 0), width=24, height=16)
    rng = np.random.default_rng(2)
    xyz = np.column_stack([rng.uniform(-1, 1, (40, 2)), rng.uniform(-0.3, 0.3, 40)])
    pix = rng.choice(24 * 16, 30, replace=False)
    depth = (jnp.asarray(pix), jnp.asarray(rng.uniform(4.5, 5.0, 30), jnp.float32), jnp.ones(30, bool))
    zero = jnp.zeros((16, 24, 2))
    accum = {}
    for method in ("cpu", "tiled", "reference"):
        cfg = TrainConfig(
            steps=2,
            capacity=40,
            depth_weight=13.0,
            method=method,
            render=RenderConfig(tile_size=8, tile_capacity=64),
        )
        st = init_state(cfg, bounds=np.array([[-2.0, -2, -2], [2, 2, 2]]), n_channels=2, points=xyz)
        st = st._replace(params=dataclasses.replace(st.params, opacity_logits=jnp.full(40, 1.0)))
        new, loss, dropped = train_step(
            st, cam, zero, zero, jnp.ones(2), 1.0, config=cfg, extent=4.0, depth=depth
        )
        assert float(loss) == 0.0 and int(dropped) == 0
        accum[method] = np.asarray(new.grad_accum)
    assert np.count_nonzero(accum["cpu"]) > 10
    np.testing.assert_allclose(accum["tiled"], accum["reference"], rtol=1e-4, atol=1e-9)
    np.testing.assert_allclose(accum["cpu"], accum["reference"], rtol=1e-4, atol=1e-9)
