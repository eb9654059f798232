"""splat.data: captures from COLMAP and transforms.json, channel maps, projection conventions."""

from __future__ import annotations

import json

import numpy as np
import pycolmap
import pytest

from splat import (
    Capture,
    DataFormatError,
    SplatError,
    View,
    capture_from_colmap,
    colmap_from_capture,
    look_at,
    read_colmap,
    read_transforms,
    write_colmap,
    write_transforms,
)


@pytest.fixture(scope="module")
def model(tmp_path_factory):
    o = pycolmap.SyntheticDatasetOptions()
    o.num_rigs, o.num_cameras_per_rig, o.num_frames_per_rig, o.num_points3D = 2, 1, 3, 10
    o.camera_model_id = pycolmap.CameraModelId.PINHOLE
    o.camera_params, o.camera_width, o.camera_height = [100.0, 110.0, 50.0, 40.0], 100, 80
    rec = pycolmap.synthesize_dataset(o)
    root = tmp_path_factory.mktemp("model")
    rec.write_binary(str(root))
    return read_colmap(root)


def test_views_project_points_onto_their_keypoints(model):
    capture = capture_from_colmap(model, exposures={model.images[1].name: 2.0})
    assert capture.channels == {1: (0, 1, 2), 2: (3, 4, 5)} and capture.n_channels == 6
    assert capture.views[0].exposure == 2.0 and capture.views[1].exposure == 1.0
    for view, im in zip(capture.views, (model.images[k] for k in sorted(model.images))):
        c = view.camera
        for xy, pid in zip(im.xys, im.point3D_ids):
            if pid < 0:
                continue
            p = np.asarray(c.R) @ model.points3D[pid].xyz + np.asarray(c.t)
            uv = np.asarray(c.focal) * p[:2] / p[2] + np.asarray(c.principal)
            np.testing.assert_allclose(uv, xy, atol=1e-3)
    mask = capture.channel_mask(capture.views[-1])
    assert mask.tolist() == [False] * 3 + [True] * 3


def test_transforms_and_colmap_round_trips(tmp_path, model):
    capture = capture_from_colmap(model, channels={1: (0, 2), 2: (1, 3, 4)}, labels="abcde")
    back = read_transforms(write_transforms(capture, tmp_path / "transforms.json"))
    assert back.channels == capture.channels and back.labels == tuple("abcde")
    again = capture_from_colmap(
        read_colmap(write_colmap(colmap_from_capture(back), tmp_path / "sparse")), channels=back.channels
    )
    for a, b, c in zip(capture.views, back.views, again.views):
        assert a.name == b.name == c.name and a.camera_id == b.camera_id == c.camera_id
        for other in (b, c):
            np.testing.assert_allclose(other.camera.R, a.camera.R, atol=1e-5)
            np.testing.assert_allclose(other.camera.t, a.camera.t, atol=1e-4)
            np.testing.assert_allclose(other.camera.focal, a.camera.focal)
            assert (other.camera.width, other.camera.height) == (100, 80)
    # nerfstudio's convention: camera-to-world, OpenGL axes (the camera looks down its −z)
    frame = json.loads((tmp_path / "transforms.json").read_text())["frames"][0]
    c2w = np.asarray(frame["transform_matrix"])
    cam = capture.views[0].camera
    np.testing.assert_allclose(c2w[:3, 3], np.asarray(cam.centre), atol=1e-4)
    np.testing.assert_allclose(-c2w[:3, 2], np.asarray(cam.R)[2], atol=1e-5)


def test_errors(tmp_path):
    cam = look_at((0, -3, 0), (0, 0, 0), width=8, height=8)
    with pytest.raises(SplatError, match="camera id"):
        Capture((View("a", cam, 7),), {1: (0, 1, 2)})
    other = look_at((0, -3, 0), (0, 0, 0), width=8, height=8, fov_deg=20)
    with pytest.raises(SplatError, match="intrinsics"):
        colmap_from_capture(Capture((View("a", cam, 1), View("b", other, 1)), {1: (0,)}))
    (tmp_path / "t.json").write_text("{not json")
    with pytest.raises(DataFormatError, match="JSON"):
        read_transforms(tmp_path / "t.json")
    (tmp_path / "t.json").write_text(json.dumps({"frames": [{"file_path": "x.png"}]}))
    with pytest.raises(DataFormatError, match="frame 0"):
        read_transforms(tmp_path / "t.json")
