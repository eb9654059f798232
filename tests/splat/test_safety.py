"""splat data safety: atomic checkpoints (SIGKILL, Ctrl-C), COLMAP and transforms.json readers that
answer damaged files with a DataFormatError only (hypothesis fuzz), views that refuse NaN/degenerate
poses, focal ≤ 0 and NaN exposures, and training that validates first and ignores NaN where nothing
is measured."""

from __future__ import annotations

import json
import signal
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
import pycolmap
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from splat import (
    Capture,
    DataFormatError,
    SplatError,
    TrainConfig,
    View,
    init_state,
    load_checkpoint,
    look_at,
    read_colmap,
    read_transforms,
    save_checkpoint,
    write_colmap,
    write_transforms,
)
from splat.camera import Camera

ROOT = Path(__file__).resolve().parents[2]
BOUNDS = np.array([[-1.0, -1.0, -1.0], [1.0, 1.0, 1.0]])


def _capture(n: int = 2, size: int = 8) -> Capture:
    views = tuple(
        View(
            f"v{i}.png",
            look_at((3 * np.cos(i), 3 * np.sin(i), 0.5), (0, 0, 0), width=size, height=size),
            1 + i % 2,
        )
        for i in range(n)
    )
    return Capture(views, {1: (0, 1, 2), 2: (3, 4, 5)})


# ---- checkpoints ----------------------------------------------------------------------------------


def test_checkpoint_ctrl_c_keeps_the_previous_one(tmp_path, monkeypatch):
    cfg = TrainConfig(steps=1, capacity=64)
    state = init_state(cfg, bounds=BOUNDS, n_channels=6)
    path = tmp_path / "ckpt.npz"
    save_checkpoint(state, path)
    good = path.read_bytes()

    def interrupted(fh, **arrays):
        fh.write(b"PK\x03\x04 half a zip")
        raise KeyboardInterrupt

    monkeypatch.setattr(np, "savez", interrupted)
    with pytest.raises(KeyboardInterrupt):
        save_checkpoint(state._replace(step=5), path)
    monkeypatch.undo()
    assert path.read_bytes() == good and sorted(p.name for p in tmp_path.iterdir()) == ["ckpt.npz"]
    assert load_checkpoint(path, state).step == 0


_SAVER = """
import sys
import numpy as np
from splat import TrainConfig, init_state, save_checkpoint
cfg = TrainConfig(steps=1, capacity=200_000)
state = init_state(cfg, bounds=np.array([[-1.0, -1, -1], [1, 1, 1]]), n_channels=9)
i = 0
while True:
    save_checkpoint(state._replace(step=i), sys.argv[1])
    print(i, flush=True)
    i += 1
"""


@pytest.mark.slow
def test_sigkill_mid_checkpoint_keeps_a_good_checkpoint(tmp_path):
    """3 SIGKILLs of a process saving ~40 MB checkpoints in a loop (each start imports jax: ~10 s
    on 2 busy cores): the file left is always a complete checkpoint, no temporary remains."""
    path = tmp_path / "ckpt.npz"
    like = init_state(TrainConfig(steps=1, capacity=200_000), bounds=BOUNDS, n_channels=9)
    from zonotope.utilities.io import clean_stale_temporaries

    hits = 0
    for delay in (0.0, 0.05, 0.15):
        proc = subprocess.Popen(
            [sys.executable, "-c", _SAVER, str(path)],
            stdout=subprocess.PIPE,
            stderr=subprocess.DEVNULL,
            cwd=ROOT,
            env={**__import__("os").environ, "JAX_PLATFORMS": "cpu"},
        )
        assert proc.stdout.readline()  # one checkpoint complete
        time.sleep(delay)
        proc.send_signal(signal.SIGKILL)
        proc.wait()
        restored = load_checkpoint(path, like)  # never a truncated zip (11/12 before)
        assert restored.step >= 0
        hits += bool(clean_stale_temporaries(path))
        assert sorted(p.name for p in tmp_path.iterdir()) == ["ckpt.npz"]
    print(f"{hits} of 3 kills landed mid-save")


# ---- views and transforms.json ---------------------------------------------------------------------


def _cam(**kw):
    c = look_at((0, -3, 0), (0, 0, 0), width=8, height=8)
    parts = dict(R=c.R, t=c.t, focal=c.focal, principal=c.principal, width=8, height=8)
    parts.update(kw)
    return Camera(**parts)


@pytest.mark.parametrize(
    ("kw", "exposure", "match"),
    [
        (dict(t=np.array([np.nan, 0, 0])), 1.0, "NaN"),
        (dict(R=np.zeros((3, 3))), 1.0, "not a rotation"),
        (dict(R=np.full((3, 3), np.nan)), 1.0, "NaN"),
        (dict(R=-np.eye(3)), 1.0, "not a rotation"),
        (dict(focal=np.array([0.0, 10.0])), 1.0, "focal"),
        (dict(focal=np.array([-5.0, -5.0])), 1.0, "focal"),
        (dict(principal=np.array([np.inf, 4.0])), 1.0, "principal"),
        ({}, float("nan"), "exposure"),
        ({}, 0.0, "exposure"),
    ],
)
def test_view_refuses_what_would_train_nan(kw, exposure, match):
    with pytest.raises(SplatError, match=match):
        View("a.png", _cam(**kw), 1, exposure)


def _transforms(tmp_path) -> Path:
    return write_transforms(_capture(3), tmp_path / "transforms.json")


@pytest.mark.parametrize(
    ("frame_edit", "match"),
    [
        ({"fl_x": "wide"}, "fl_x|could not convert|frame 0"),
        ({"fl_x": 0}, "focal"),
        ({"fl_x": -3.0}, "focal"),
        ({"w": "8px"}, "frame 0"),
        ({"exposure": "bright"}, "frame 0"),
        ({"exposure": float("nan")}, "exposure"),
        ({"transform_matrix": [[0] * 4] * 4}, "frame 0"),
        ({"transform_matrix": [[float("nan")] * 4] * 4}, "frame 0"),
        ({"transform_matrix": "identity"}, "frame 0"),
        ({"camera_id": "left"}, "frame 0"),
        ({"camera_id": 10**30}, "camera id"),
    ],
)
def test_transforms_bad_fields(tmp_path, frame_edit, match):
    p = _transforms(tmp_path)
    doc = json.loads(p.read_text())
    doc["frames"][0].update(frame_edit)
    p.write_text(json.dumps(doc))
    with pytest.raises(DataFormatError, match=match):
        read_transforms(p)


@pytest.mark.parametrize(
    "doc",
    [
        [],
        "x",
        {"frames": {}},
        {"frames": [1]},
        {"frames": [], "channels": [1]},
        {"frames": [], "channels": {"1": ["a"]}},
        {"frames": [], "channels": {"x": [0]}},
        {"frames": [], "channels": {"1": [-1]}},
    ],
)
def test_transforms_wrong_shape(tmp_path, doc):
    p = tmp_path / "t.json"
    p.write_text(json.dumps(doc))
    with pytest.raises(DataFormatError):
        read_transforms(p)


FUZZ_COUNT = {"transforms": 0, "colmap": 0}


@settings(max_examples=80, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(data=st.data())
def test_fuzz_transforms(tmp_path, data):
    p = tmp_path / "transforms.json"
    if not p.exists():
        _transforms(tmp_path)
        (tmp_path / "good.json").write_bytes(p.read_bytes())
    b = bytearray((tmp_path / "good.json").read_bytes())
    for _ in range(data.draw(st.integers(1, 4))):
        i = data.draw(st.integers(0, len(b) - 1))
        op = data.draw(st.sampled_from(["flip", "cut", "insert"]))
        if op == "flip":
            b[i] = data.draw(st.sampled_from([*b'0-.e"[]{},: n9', 0xFF]))
        elif op == "cut":
            del b[i:]
            break
        else:
            b[i:i] = data.draw(st.sampled_from([b"NaN", b"-Infinity", b"1e999", b'"x"', b"null", b"[]"]))
    p.write_bytes(bytes(b))
    FUZZ_COUNT["transforms"] += 1
    try:
        cap = read_transforms(p)
    except DataFormatError:
        return
    for v in cap.views:
        assert np.all(np.isfinite(np.asarray(v.camera.R))) and np.all(np.asarray(v.camera.focal) > 0)


# ---- COLMAP -----------------------------------------------------------------------------------------


@pytest.fixture(scope="module")
def colmap_dirs(tmp_path_factory):
    o = pycolmap.SyntheticDatasetOptions()
    o.num_rigs, o.num_cameras_per_rig, o.num_frames_per_rig, o.num_points3D = 1, 2, 2, 8
    o.camera_model_id = pycolmap.CameraModelId.PINHOLE
    o.camera_params, o.camera_width, o.camera_height = [100.0, 110.0, 50.0, 40.0], 100, 80
    rec = pycolmap.synthesize_dataset(o)
    root = tmp_path_factory.mktemp("colmap")
    (root / "txt").mkdir()
    (root / "bin").mkdir()
    rec.write_text(str(root / "txt"))
    rec.write_binary(str(root / "bin"))
    return root


def test_images_txt_without_final_blank_line_keeps_the_last_image(tmp_path, colmap_dirs):
    model = read_colmap(colmap_dirs / "bin")
    last = max(model.images)
    model.images[last] = type(model.images[last])(
        last,
        model.images[last].qvec,
        model.images[last].tvec,
        model.images[last].camera_id,
        model.images[last].name,
    )
    folder = write_colmap(model, tmp_path / "m", binary=False)
    text = (folder / "images.txt").read_text()
    assert text.endswith("\n\n") or text.endswith("\n")
    (folder / "images.txt").write_text(text.rstrip("\n") + "\n")  # the last (empty) points line gone
    again = read_colmap(folder)
    assert sorted(again.images) == sorted(model.images)  # the last image used to be lost
    assert again.images[last].name == model.images[last].name and again.images[last].xys.shape == (0, 2)
    (folder / "images.txt").write_text(text.rstrip("\n"))  # no final newline at all
    assert sorted(read_colmap(folder).images) == sorted(model.images)


def _mutate(data, blob: bytes) -> bytes:
    b = bytearray(blob)
    if data.draw(st.booleans()):
        del b[data.draw(st.integers(0, len(b) - 1)) :]
    else:
        for _ in range(data.draw(st.integers(1, 6))):
            b[data.draw(st.integers(0, len(b) - 1))] = data.draw(st.integers(0, 255))
    return bytes(b)


@settings(max_examples=80, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(data=st.data())
def test_fuzz_colmap_models(colmap_dirs, tmp_path, data):
    """Truncated and byte-flipped cameras/images/points3D (binary and text): a model with finite
    poses and positive focal lengths, or a DataFormatError; never OverflowError, UnicodeDecodeError,
    struct.error, ..."""
    fmt = data.draw(st.sampled_from(["bin", "txt"]))
    src = colmap_dirs / fmt
    dst = Path(tempfile.mkdtemp(prefix="m", dir=tmp_path))  # unique even when hypothesis replays a case
    target = data.draw(st.sampled_from(sorted(p.name for p in src.iterdir())))
    for p in src.iterdir():
        blob = p.read_bytes()
        (dst / p.name).write_bytes(_mutate(data, blob) if p.name == target else blob)
    FUZZ_COUNT["colmap"] += 1
    try:
        model = read_colmap(dst)
    except DataFormatError:
        return
    for im in model.images.values():
        assert np.all(np.isfinite(im.qvec)) and np.all(np.isfinite(im.tvec))
    for c in model.cameras.values():
        assert c.params[0] > 0 and c.width > 0


def test_binary_out_of_range_values(colmap_dirs, tmp_path):
    """Out-of-range values in a binary model (a camera width of 2⁶³, a NaN focal length) are
    DataFormatErrors, not OverflowErrors later."""
    import shutil
    import struct

    dst = tmp_path / "m"
    shutil.copytree(colmap_dirs / "bin", dst)
    blob = bytearray((dst / "cameras.bin").read_bytes())
    struct.pack_into("<Q", blob, 8 + 8, 2**63 + 5)  # first camera's width
    (dst / "cameras.bin").write_bytes(bytes(blob))
    with pytest.raises(DataFormatError, match="size"):
        read_colmap(dst)
    blob = bytearray((colmap_dirs / "bin" / "cameras.bin").read_bytes())
    struct.pack_into("<d", blob, 8 + 24, float("nan"))  # first camera's fx
    (dst / "cameras.bin").write_bytes(bytes(blob))
    with pytest.raises(DataFormatError, match="finite"):
        read_colmap(dst)


# ---- training validates first ---------------------------------------------------------------------


def test_train_refuses_bad_input_before_the_first_step():
    from splat import train

    cap = _capture(2)
    shape = (2, 8, 8, 6)
    images = np.full(shape, 0.5)
    weights = np.ones(shape)
    cfg = TrainConfig(steps=1, capacity=64)
    bad = images.copy()
    bad[0, 3, 3, 1] = np.nan  # view 0 (camera 1) measures channel 1
    with pytest.raises(SplatError, match="view 0"):
        train(cap, bad, weights, config=cfg, bounds=BOUNDS)
    with pytest.raises(SplatError, match="weights"):
        train(cap, images, np.where(weights > 0, np.nan, 0), config=cfg, bounds=BOUNDS)
    with pytest.raises(SplatError, match="bounds"):
        train(cap, images, weights, config=cfg, bounds=BOUNDS[::-1])
    with pytest.raises(SplatError, match="bounds"):
        train(cap, images, weights, config=cfg, bounds=[[0, 0, 0], [1, 1, np.inf]])


@pytest.mark.slow
def test_nan_in_unmeasured_channels_changes_nothing():
    """NaN where a view measures nothing (its other cameras' channels) or at zero weight used to
    turn every Gaussian into NaN (0 · NaN = NaN in the loss); now the result equals the clean run."""
    from splat import RenderConfig, train

    cap = _capture(2)
    rng = np.random.default_rng(0)
    images = rng.uniform(0.1, 0.9, (2, 8, 8, 6))
    weights = np.ones_like(images)
    weights[1, 0, 0, :] = 0.0
    dirty = images.copy()
    dirty[0, :, :, 3:] = np.nan  # view 0 is camera 1: channels 3–5 are not measured
    dirty[1, 0, 0, :] = np.nan  # zero weight
    cfg = TrainConfig(
        steps=3, capacity=64, densify_from=100, render=RenderConfig(tile_size=8, tile_capacity=64)
    )
    a = train(cap, images, weights, config=cfg, bounds=BOUNDS)
    b = train(cap, dirty, weights, config=cfg, bounds=BOUNDS)
    import jax

    for x, y in zip(jax.tree.leaves(a.gaussians), jax.tree.leaves(b.gaussians)):
        assert np.all(np.isfinite(np.asarray(y)))
        np.testing.assert_array_equal(np.asarray(x), np.asarray(y))
