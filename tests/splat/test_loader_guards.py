"""COLMAP binary models whose header counts or ids disagree with their records are refused with one
error naming the file, instead of dropping or replacing records silently."""

from __future__ import annotations

import shutil
import struct

import pycolmap
import pytest

from splat import DataFormatError, read_colmap


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
