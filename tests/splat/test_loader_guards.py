"""COLMAP binary models whose header counts or ids disagree with their records, transforms.json without
frames or with fractional image sizes, and checkpoints with NaN, wrongly typed leaves or a negative step
are refused with one error naming the file, instead of being read silently."""

from __future__ import annotations

import json
import shutil
import struct

import numpy as np
import pycolmap
import pytest

from splat import DataFormatError, read_colmap, read_transforms


@pytest.fixture(scope="module")
def model_bin(tmp_path_factory):
    """A small synthetic reconstruction written as a binary model by pycolmap."""
    o = pycolmap.SyntheticDatasetOptions()
    o.num_rigs, o.num_cameras_per_rig, o.num_frames_per_rig, o.num_points3D = 1, 2, 2, 8
    o.camera_model_id = pycolmap.CameraModelId.PINHOLE
    o.camera_params, o.camera_width, o.camera_height = [100.0, 110.0, 50.0, 40.0], 100, 80
    root = tmp_path_factory.mktemp("colmap")
    pycolmap.synthesize_dataset(o).write_binary(str(root))
    return root


def _copy(src, dst):
    shutil.copytree(src, dst)
    return dst


@pytest.mark.parametrize("name", ["cameras.bin", "images.bin", "points3D.bin"])
def test_count_one_too_low_is_refused(model_bin, tmp_path, name):
    model = _copy(model_bin, tmp_path / "m")
    data = bytearray((model / name).read_bytes())
    n = struct.unpack_from("<Q", data)[0]
    struct.pack_into("<Q", data, 0, n - 1)
    (model / name).write_bytes(bytes(data))
    with pytest.raises(DataFormatError, match=rf"{name}: \d+ bytes follow the {n - 1} .* declares"):
        read_colmap(model)


@pytest.mark.parametrize("name", ["cameras.bin", "images.bin", "points3D.bin"])
def test_trailing_garbage_is_refused(model_bin, tmp_path, name):
    model = _copy(model_bin, tmp_path / "m")
    with open(model / name, "ab") as fh:
        fh.write(b"\x00garbage")
    with pytest.raises(DataFormatError, match=rf"{name}: 8 bytes follow"):
        read_colmap(model)


def test_a_count_larger_than_the_file_is_refused_before_reading(model_bin, tmp_path):
    model = _copy(model_bin, tmp_path / "m")
    data = bytearray((model / "points3D.bin").read_bytes())
    struct.pack_into("<Q", data, 0, 2**62)
    (model / "points3D.bin").write_bytes(bytes(data))
    with pytest.raises(
        DataFormatError, match=r"points3D\.bin: declares 4611686018427387904 points, more than"
    ):
        read_colmap(model)


def test_duplicate_camera_id_is_refused(model_bin, tmp_path):
    """Two camera records with one id: the second would silently replace the first."""
    model = _copy(model_bin, tmp_path / "m")
    data = (model / "cameras.bin").read_bytes()
    n = struct.unpack_from("<Q", data)[0]
    record = data[8 : 8 + (len(data) - 8) // n]  # the first record (all cameras are PINHOLE here)
    (model / "cameras.bin").write_bytes(struct.pack("<Q", n + 1) + data[8:] + record)
    with pytest.raises(DataFormatError, match=r"cameras\.bin: camera id \d+ appears twice"):
        read_colmap(model)


def test_duplicate_image_and_point_ids_are_refused(model_bin, tmp_path):
    model = read_colmap(model_bin)
    for name, what in (("images.bin", "image"), ("points3D.bin", "3-D point")):
        folder = _copy(model_bin, tmp_path / name)
        data = (folder / name).read_bytes()
        n = struct.unpack_from("<Q", data)[0]
        # repeat the whole body: every id then appears twice
        (folder / name).write_bytes(struct.pack("<Q", 2 * n) + data[8:] + data[8:])
        with pytest.raises(DataFormatError, match=rf"{name}: {what} id \d+ appears twice"):
            read_colmap(folder)
    assert len(model.images) == 4


# ---- transforms.json --------------------------------------------------------------------------------


def _capture(n: int = 2, size: int = 8):
    from splat import Capture, View, look_at

    views = tuple(
        View(f"v{i}.png", look_at((3 * np.cos(i), 3 * np.sin(i), 0.5), (0, 0, 0), width=size, height=size), 1)
        for i in range(n)
    )
    return Capture(views, {1: (0, 1, 2)})


@pytest.fixture
def transforms(tmp_path):
    from splat import write_transforms

    path = write_transforms(_capture(), tmp_path / "transforms.json")
    return path, json.loads(path.read_text())


@pytest.mark.parametrize(
    ("edit", "match"),
    [
        (lambda d: d.pop("frames"), r"non-empty 'frames' list, got frames = None"),
        (lambda d: d.update(frames=[]), r"non-empty 'frames' list, got frames = \[\]"),
        (lambda d: d["frames"][0].update(w=15.7), r"frame 0 .*w = 15\.7: an image size is a whole number"),
        (lambda d: d["frames"][1].update(h=0), r"frame 1 .*h = 0: an image size"),
        (lambda d: d["frames"][0].update(w=float("inf")), r"frame 0"),
        (lambda d: d["frames"][0].update(w=True), r"frame 0 .*w = True"),
    ],
)
def test_transforms_without_frames_or_with_fractional_sizes_are_refused(transforms, edit, match):
    path, doc = transforms
    edit(doc)
    path.write_text(json.dumps(doc))
    with pytest.raises(DataFormatError, match=rf"transforms\.json: .*{match}"):
        read_transforms(path)


@pytest.mark.parametrize("channels", [[1], {"1": ["a"]}, {"x": [0]}, {"1": [-1]}])
def test_transforms_bad_channels_with_frames_are_refused(transforms, channels):
    path, doc = transforms
    path.write_text(json.dumps({**doc, "channels": channels}))
    with pytest.raises(DataFormatError, match="channel"):
        read_transforms(path)


def test_transforms_whole_float_sizes_still_read(transforms):
    path, doc = transforms
    doc["frames"][0]["w"] = 8.0
    path.write_text(json.dumps(doc))
    assert read_transforms(path).views[0].camera.width == 8


# ---- checkpoints ---------------------------------------------------------------------------------------


@pytest.fixture(scope="module")
def state():
    from splat import TrainConfig, init_state

    return init_state(
        TrainConfig(steps=1, capacity=16), bounds=np.array([[-1.0] * 3, [1.0] * 3]), n_channels=3
    )


def _checkpoint(path, state, **changes):
    from splat import save_checkpoint

    save_checkpoint(state, path)
    with np.load(path) as f:
        arrays = {k: f[k] for k in f.files}
    arrays.update(changes)
    with open(path, "wb") as fh:
        np.savez(fh, **arrays)
    return path


@pytest.mark.parametrize(
    ("change", "match"),
    [
        ({"leaf_0000": np.full((16, 3), np.nan, np.float32)}, r"leaf_0000 contains NaN or inf"),
        ({"leaf_0001": np.full((16, 4), np.inf, np.float32)}, r"leaf_0001 contains NaN or inf"),
        ({"leaf_0000": np.zeros((16, 3), np.int64)}, r"leaf_0000 has dtype int64 where float32 is expected"),
        ({"step": np.array(-5)}, r"step = -5 \(int64\); a checkpoint's step is a non-negative integer"),
        ({"step": np.array(2.5)}, r"step = 2\.5 \(float64\)"),
        ({"step": np.array([1, 2])}, r"step = \[1, 2\]"),
        ({"key": np.zeros(5, np.uint32)}, r"key of shape \(5,\)"),
    ],
)
def test_damaged_checkpoint_is_refused_by_name(tmp_path, state, change, match):
    from splat import SplatError, load_checkpoint

    path = _checkpoint(tmp_path / "ckpt.npz", state, **change)
    with pytest.raises(SplatError, match=rf"ckpt\.npz: {match}"):
        load_checkpoint(path, state)


def test_good_checkpoint_still_loads(tmp_path, state):
    from splat import load_checkpoint

    assert load_checkpoint(_checkpoint(tmp_path / "ckpt.npz", state, step=np.array(7)), state).step == 7
