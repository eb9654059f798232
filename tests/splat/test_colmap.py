"""splat.colmap: text and binary models against pycolmap's own reader and writer."""

from __future__ import annotations

import filecmp

import numpy as np
import pycolmap
import pytest

from splat import DataFormatError, SplatError, read_colmap, write_colmap


@pytest.fixture(scope="module")
def pycolmap_model(tmp_path_factory):
    """A synthetic pycolmap reconstruction with a 2-camera rig, written as text and binary."""
    o = pycolmap.SyntheticDatasetOptions()
    o.num_rigs, o.num_cameras_per_rig, o.num_frames_per_rig, o.num_points3D = 2, 2, 2, 12
    o.camera_model_id = pycolmap.CameraModelId.PINHOLE
    o.camera_params, o.camera_width, o.camera_height = [100.0, 110.0, 50.0, 40.0], 100, 80
    rec = pycolmap.synthesize_dataset(o)
    root = tmp_path_factory.mktemp("colmap")
    (root / "txt").mkdir()
    (root / "bin").mkdir()
    rec.write_text(str(root / "txt"))
    rec.write_binary(str(root / "bin"))
    return rec, root


def test_text_and_binary_agree_with_pycolmap(pycolmap_model):
    rec, root = pycolmap_model
    t, b = read_colmap(root / "txt"), read_colmap(root / "bin")
    assert t.cameras == b.cameras and t.rigs == b.rigs and t.frames == b.frames
    assert len(b.images) == rec.num_images() and len(b.points3D) == rec.num_points3D()
    assert len(b.rigs) == 2 and len(b.frames) == 4
    assert any(pose is not None for r in b.rigs.values() for *_, pose in r.sensors)
    for iid, im in b.images.items():
        ref = rec.image(iid)
        np.testing.assert_allclose(t.images[iid].tvec, im.tvec, atol=1e-12)
        np.testing.assert_allclose(ref.cam_from_world().translation, im.tvec, atol=1e-12)
        assert ref.name == im.name == t.images[iid].name
        np.testing.assert_array_equal(im.point3D_ids, t.images[iid].point3D_ids)
    for pid, p in b.points3D.items():
        np.testing.assert_allclose(rec.point3D(pid).xyz, p.xyz)
        np.testing.assert_array_equal(p.image_ids, t.points3D[pid].image_ids)


@pytest.mark.parametrize("binary", [True, False])
def test_round_trip_is_read_back_by_us_and_by_pycolmap(pycolmap_model, tmp_path, binary):
    rec, root = pycolmap_model
    model = read_colmap(root / "bin")
    write_colmap(model, tmp_path, binary=binary)
    again = read_colmap(tmp_path)
    assert again.cameras == model.cameras and again.rigs == model.rigs and again.frames == model.frames
    for iid in model.images:
        np.testing.assert_allclose(again.images[iid].qvec, model.images[iid].qvec, atol=1e-15)
        np.testing.assert_allclose(again.images[iid].xys, model.images[iid].xys, atol=1e-12)
    theirs = pycolmap.Reconstruction(str(tmp_path))
    assert (theirs.num_images(), theirs.num_points3D(), theirs.num_frames(), theirs.num_rigs()) == (
        rec.num_images(),
        rec.num_points3D(),
        rec.num_frames(),
        rec.num_rigs(),
    )
    if binary:
        for name in ("cameras.bin", "images.bin", "points3D.bin", "rigs.bin", "frames.bin"):
            assert filecmp.cmp(root / "bin" / name, tmp_path / name, shallow=False), name


def test_errors(tmp_path, pycolmap_model):
    with pytest.raises(DataFormatError, match="no COLMAP model"):
        read_colmap(tmp_path)
    (tmp_path / "cameras.txt").write_text("1 PINHOLE 10 10 5 5 5\n2 NOT_A_MODEL 1 1 1\n")
    (tmp_path / "images.txt").write_text("")
    with pytest.raises(DataFormatError, match=r"cameras.txt:2"):
        read_colmap(tmp_path)
    _, root = pycolmap_model
    bad = tmp_path / "bad"
    bad.mkdir()
    for name in ("cameras.bin", "images.bin"):
        (bad / name).write_bytes((root / "bin" / name).read_bytes()[:-7])
    with pytest.raises(DataFormatError, match="truncated"):
        read_colmap(bad)
    cam = read_colmap(root / "bin").cameras[1]
    assert cam.pinhole() == (100.0, 110.0, 50.0, 40.0)
    with pytest.raises(SplatError, match="undistort"):
        type(cam)(1, "OPENCV", 10, 10, (1, 1, 5, 5, 0.1, 0, 0, 0)).pinhole()
