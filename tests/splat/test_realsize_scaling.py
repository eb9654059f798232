"""A real-size run's two linear costs: the render step's sources per view (the photographs that see most
of it, against a closed-form overlap on a plane) and each RAW file decoded once per run (the decode
cache against a fresh decoding, and never reused for another file, camera override or option)."""

from __future__ import annotations

import os

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

# ------------------------------------------------------------------------------ sources per view


def _plane_depth(cam) -> np.ndarray:
    """Closed-form depth (along the optical axis) of the plane z = 0 seen by ``cam``: each pixel's ray
    ``Rᵀ (x, y, 1)`` from the centre ``−Rᵀ t`` meets it at ``t_hit``, which is the depth since the ray's
    camera-frame z is 1 (inf where the ray misses the plane or runs away from it)."""
    R, t = np.asarray(cam.R, float), np.asarray(cam.t, float)
    C = -R.T @ t
    fx, fy = np.asarray(cam.focal, float)
    cx, cy = np.asarray(cam.principal, float)
    x = (np.arange(cam.width) + 0.5 - cx) / fx
    y = (np.arange(cam.height) + 0.5 - cy) / fy
    rays = np.stack(np.broadcast_arrays(x[None, :], y[:, None], np.ones((cam.height, 1))), -1) @ R
    with np.errstate(divide="ignore", invalid="ignore"):
        hit = -C[2] / rays[..., 2]
    return np.where(np.isfinite(hit) & (hit > 0), hit, np.inf)


def _view(eye_x: float, *, away: bool = False, W: int = 64, H: int = 48):
    """A camera 4 m above the plane z = 0 at ``x = eye_x`` looking straight down (or up, ``away``)."""
    from splat import look_at

    target = (eye_x, 0.0, 8.0 if away else 0.0)
    return look_at((eye_x, 0.0, 4.0), target, up=(0.0, 1.0, 0.0), width=W, height=H, fov_deg=50)


@settings(max_examples=25, deadline=None)
@given(
    st.lists(st.integers(1, 15), min_size=2, max_size=7, unique=True),
    st.integers(1, 8),
    st.booleans(),
)
def test_nearest_sources_are_those_that_see_most_of_the_view(shifts, k, with_away):
    """Fronto-parallel cameras shifted sideways over a plane see ``1 − shift / footprint`` of the view
    (closed form): the chosen sources are the ``k`` least shifted, most first; a camera that looks away
    from the plane sees none of it and is never chosen; without ``k`` (or ``k`` ≥ the candidates) all
    are kept in their order, but for the one that sees nothing with ``seen_only``."""
    from splat.capture import nearest_sources

    target = _view(0.0)
    d = _plane_depth(target)
    a = np.where(np.isfinite(d), 1.0, 0.0)
    # metres per shift unit: 4 pixels of the 3.73 m (2 · 4 · tan 25°) footprint, one counted column
    step = 4 * 2 * 4 * np.tan(np.radians(25)) / target.width
    cands = [(f"v{i}", _view(step * s * (-1) ** i), None) for i, s in enumerate(shifts)]
    cands = [(n, c, np.where(np.isfinite(_plane_depth(c)), _plane_depth(c), 0.0)) for n, c, _ in cands]
    if with_away:
        up = _view(0.3, away=True)
        cands.append(("away", up, np.zeros((up.height, up.width))))
    chosen = [c[0] for c in nearest_sources(target, d, a, cands, k)]
    if k >= len(cands):
        assert chosen == [c[0] for c in cands]
    else:
        assert chosen == [f"v{i}" for i in np.argsort(shifts, kind="stable")[:k]]
    assert [c[0] for c in nearest_sources(target, d, a, cands, None)] == [c[0] for c in cands]
    # seen_only (the correct step's full-resolution sources): the same choice, and the photograph that
    # sees nothing left out also when every candidate is kept
    seen = [c[0] for c in cands if c[0] != "away"]
    got = [c[0] for c in nearest_sources(target, d, a, cands, k, seen_only=True)]
    assert got == (seen if k >= len(cands) else chosen)
    assert [c[0] for c in nearest_sources(target, d, a, cands, k, seen_only=True, stride=1)] == got
    assert [c[0] for c in nearest_sources(target, d, a, cands, None, seen_only=True)] == seen


@pytest.mark.parametrize("bad", [0, -1, 2.5, True, "4"])
def test_render_sources_is_checked(bad):
    from splat.capture import PipelineConfig

    with pytest.raises(ValueError, match="render_sources"):
        PipelineConfig(render_sources=bad)
    assert PipelineConfig(render_sources=None).render_sources is None


# ------------------------------------------------------------------------------ decoding once


@pytest.fixture(scope="module")
def small_capture(tmp_path_factory):
    """The test capture of capture_helpers (real DNG files, Bayer and full colour), its images smooth
    random fields (no renderer to compile: these tests read files)."""
    import splat
    from tests.splat.capture_helpers import write_capture

    class Image:
        def __init__(self, cam):
            yy, xx = np.mgrid[: cam.height, : cam.width]
            ph = np.arange(9)[None, None] * 0.7
            self.image = 0.1 + 0.08 * np.sin(xx[..., None] / 4.0 + ph) * np.cos(yy[..., None] / 5.0 + ph)

    root = tmp_path_factory.mktemp("decode") / "cap"
    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(splat, "render_reference", lambda g, cam: Image(cam))
        write_capture(root, views=2, holdout=1)
    return root


def _same(a, b):
    assert a.name == b.name and a.camera == b.camera and a.exif == b.exif
    np.testing.assert_array_equal(a.values, b.values)
    np.testing.assert_array_equal(a.weight, b.weight)
    assert a.values.dtype == b.values.dtype == np.float32
    for f in ("full_colour", "n_saturated", "n_dead", "binning", "full_shape", "source_cfa", "path"):
        assert getattr(a, f) == getattr(b, f), f
    np.testing.assert_array_equal(a.neutral, b.neutral)
    if a.noise_profile is None:
        assert b.noise_profile is None
    else:
        np.testing.assert_array_equal(a.noise_profile, b.noise_profile)
    if a.profile is None:
        assert b.profile is None
    else:
        for f in ("color_matrix_1", "color_matrix_2", "forward_matrix_1", "analog_balance"):
            x, y = getattr(a.profile, f), getattr(b.profile, f)
            assert (x is None) == (y is None) and (x is None or np.array_equal(x, y)), f
        assert a.profile.calibration_illuminant_1 == b.profile.calibration_illuminant_1


def _counting(monkeypatch):
    import splat.capture.raw as raw

    calls = []
    real = raw.load_view

    def load_view(*a, **k):
        calls.append(a[2].name)
        return real(*a, **k)

    monkeypatch.setattr(raw, "load_view", load_view)
    return calls


@pytest.mark.parametrize("train_size", [None, 24])
def test_decode_cache_gives_the_decoded_views_and_decodes_each_file_once(
    small_capture, tmp_path, monkeypatch, train_size
):
    """Through the run's decode cache the working views equal a fresh decoding field for field (at the
    file's own size and binned); the second read decodes no file; a file whose time changes, another
    working resolution, another camera override or a corrupt entry is decoded again; entries no file
    names any more are removed."""
    import dataclasses

    from splat.capture import PipelineConfig, Workspace, load_views, read_capture, read_working
    from splat.capture.config import working_binning

    spec = read_capture(small_capture)
    ws = Workspace(spec, tmp_path / "out")
    cfg = PipelineConfig(train_size=train_size)
    assert ws.decode_cache({}) is None  # no poses record: the folder is not splat's yet
    ws.begin("poses", {"capture": "x"})
    fresh = load_views(spec, binning=working_binning(cfg, spec))
    calls = _counting(monkeypatch)
    first = read_working(spec, ws, cfg)
    assert len(calls) == len(fresh)
    again = read_working(spec, ws, cfg)
    assert len(calls) == len(fresh)  # nothing decoded again
    for a, b, c in zip(fresh, first, again, strict=True):
        _same(a, b)
        _same(a, c)
    folder = ws.decode_cache({})[0]
    assert folder.parent == ws.root and len(list(folder.glob("*.npz"))) == len(fresh)

    # a file touched: that file alone decoded again
    p = fresh[0].path
    st = p.stat()
    os.utime(p, ns=(st.st_atime_ns, st.st_mtime_ns + 10**9))
    calls.clear()
    read_working(spec, ws, cfg)
    assert calls == [p.name]
    # a corrupt entry: decoded again, and right
    entry = sorted(folder.glob("*.npz"))[0]
    entry.write_bytes(b"not a zip")
    calls.clear()
    for a, b in zip(fresh, read_working(spec, ws, cfg), strict=True):
        _same(a, b)
    assert len(calls) == 1
    # another working resolution: every file decoded again, the old entries removed
    other = PipelineConfig(train_size=16 if train_size else 20)
    ref = load_views(spec, binning=working_binning(other, spec))
    calls.clear()
    for a, b in zip(ref, read_working(spec, ws, other), strict=True):
        _same(a, b)
    assert len(calls) == len(fresh) and len(list(folder.glob("*.npz"))) == len(fresh)
    # another camera override (the white level): decoded again, with it
    cams = list(spec.cameras)
    cams[0] = dataclasses.replace(cams[0], white_level=3000)
    spec2 = dataclasses.replace(spec, cameras=tuple(cams))
    ref = load_views(spec2, binning=working_binning(other, spec2))
    calls.clear()
    got = read_working(spec2, ws, other)
    assert sum(v.camera == 0 for v in got) == len(calls) > 0
    for a, b in zip(ref, got, strict=True):
        _same(a, b)


def test_decode_cache_is_a_poses_output(small_capture, tmp_path):
    """The cache folder goes with the poses step's results (a new poses key removes it) and a folder of
    that name that splat did not record is refused, never replaced."""
    from splat.capture import CaptureError, PipelineConfig, Workspace, read_capture, read_working

    spec = read_capture(small_capture)
    ws = Workspace(spec, tmp_path / "out")
    ws.begin("poses", {"capture": 1})
    read_working(spec, ws, PipelineConfig(train_size=24))
    folder = ws.decode_cache({})[0]
    assert any(folder.glob("*.npz"))
    ws.begin("poses", {"capture": 2})
    assert not folder.exists()
    ws2 = Workspace(spec, tmp_path / "fresh")  # splat's marker, no poses record
    (ws2.root / "decoded").mkdir()
    (ws2.root / "decoded" / "mine.txt").write_text("x")
    with pytest.raises(CaptureError, match="decoded"):
        ws2.begin("poses", {"capture": 1})


def test_poses_step_decodes_each_file_once_for_the_run(small_capture, tmp_path, monkeypatch):
    """A poses run (previews for COLMAP) followed by the train step's reading decodes each RAW file once:
    the train step reads the poses step's entries. The previews are byte for byte those made from a
    fresh decoding at the automatic working resolution. With another ``train_size`` the train step's
    working views differ from the previews and are decoded (once each)."""
    import dataclasses
    import shutil

    import splat.poses
    from splat.capture import (
        PipelineConfig,
        Workspace,
        camera_white,
        load_views,
        poses_step,
        preview_binning,
        preview_upscale,
        read_capture,
        training_inputs,
    )
    from splat.capture.files import write_png8
    from splat.capture.poses import _preview
    from splat.colmap import ColmapCamera, read_colmap

    cap = tmp_path / "cap"
    shutil.copytree(small_capture, cap)
    toml = cap / "capture.toml"
    toml.write_text(toml.read_text().replace('[poses]\ncolmap = "sparse"', ""))  # poses from previews
    spec = read_capture(cap)
    assert spec.colmap is None
    fresh = load_views(spec, binning=preview_binning)
    truth = read_colmap(small_capture / "sparse")
    seen = {}

    def recover(previews, work, *, config):  # COLMAP stood in for: the true poses at the previews' size
        seen["files"] = sorted(p.relative_to(previews).as_posix() for p in previews.rglob("*.png"))
        cams = {}
        for i, c in truth.cameras.items():
            v = next(v for v in fresh if v.camera == i - 1)
            u = preview_upscale(v.shape) / v.binning
            fx, fy, cx, cy = c.pinhole()
            cams[i] = ColmapCamera(
                i, "PINHOLE", v.shape[1] * u, v.shape[0] * u, (fx * u, fy * u, cx * u, cy * u)
            )
        imgs = {
            i: dataclasses.replace(im, name=im.name.rsplit(".", 1)[0] + ".png")
            for i, im in truth.images.items()
        }
        return dataclasses.replace(truth, cameras=cams, images=imgs)

    monkeypatch.setattr(splat.poses, "recover_poses", recover)
    calls = _counting(monkeypatch)
    out = tmp_path / "out"
    s = poses_step(cap, out, config=PipelineConfig())
    assert s["source"] == "pycolmap" and s["registered"] == len(fresh)
    assert sorted(calls) == sorted(v.path.name for v in fresh)  # each file decoded once
    ws = Workspace(spec, out)
    for v in fresh:
        mine = ws.path("previews", f"{spec.out_stem(v.name)}.png")
        ref = tmp_path / "ref" / f"{spec.out_stem(v.name)}.png"
        write_png8(ref, _preview(v, camera_white(spec, v.camera)), upscale=preview_upscale(v.shape))
        assert mine.read_bytes() == ref.read_bytes(), v.name
    assert len(seen["files"]) == len(fresh)

    calls.clear()
    inp = training_inputs(spec, out, PipelineConfig(), workspace=ws)
    assert calls == [] and len(inp.views) == len(fresh) - len(spec.holdout)  # read, not decoded
    ref = training_inputs(spec, out, PipelineConfig())  # no workspace: decoded afresh
    np.testing.assert_array_equal(inp.images, ref.images)
    np.testing.assert_array_equal(inp.weights, ref.weights)
    calls.clear()
    training_inputs(spec, out, PipelineConfig(train_size=24), workspace=ws)
    assert sorted(calls) == sorted(v.path.name for v in fresh)
