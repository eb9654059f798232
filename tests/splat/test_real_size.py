"""Working resolution (CFA-aware binning, intrinsics) and full-resolution outputs in strips, on tiny
images: binned channel means and noise against brute force, a 3-D point projected by the binned and the
full camera, strip processing against the whole image, the output at the RAW file's size."""

from __future__ import annotations

import types

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from splat.resolution import (
    bin_mosaic,
    binned_noise_profile,
    scale_camera,
    sites_per_block,
    working_factor,
)


def _mosaic(rng, H, W, cfa):
    """Linear values and weights as RawSource.rows gives them: one colour per site, some sites invalid."""
    from isp.cfa import cfa_masks

    m = cfa_masks((H, W), cfa)
    x = rng.uniform(0.05, 0.9, (H, W))
    w = m & (rng.uniform(size=(H, W, 1)) > 0.1)
    return (x[..., None] * m).astype(np.float32), w.astype(np.float32)


def _rows_of(values, weight):
    return lambda r0, r1: (values[r0:r1], weight[r0:r1])


@given(
    st.sampled_from(["RGGB", "GRBG", "BGGR", "GBRG"]),
    st.sampled_from([2, 4, 6]),
    st.integers(0, 5),
    st.integers(0, 5),
    st.integers(0, 2**31 - 1),
)
@settings(max_examples=25, deadline=None)
def test_binning_is_the_mean_of_each_colours_valid_sites(cfa, f, dh, dw, seed):
    """Brute force: every block and channel, the mean of the channel's valid sites; the weight their
    valid fraction; rows beyond the last whole block are left out; the strip height does not matter."""
    rng = np.random.default_rng(seed)
    H, W = 3 * f + dh, 2 * f + dw
    values, weight = _mosaic(rng, H, W, cfa)
    v, w = bin_mosaic(_rows_of(values, weight), (H, W), f, cfa=cfa, strip_rows=f)
    assert v.shape == w.shape == (H // f, W // f, 3)
    n_sites = sites_per_block(cfa, f)
    for i in range(H // f):
        for j in range(W // f):
            blk_v = values[i * f : (i + 1) * f, j * f : (j + 1) * f].reshape(-1, 3)
            blk_w = weight[i * f : (i + 1) * f, j * f : (j + 1) * f].reshape(-1, 3) > 0
            for c in range(3):
                sel = blk_v[blk_w[:, c], c]
                want = sel.mean() if sel.size else 0.0
                assert v[i, j, c] == pytest.approx(want, rel=1e-5)
                assert w[i, j, c] == pytest.approx(sel.size / n_sites[c])
    v2, w2 = bin_mosaic(_rows_of(values, weight), (H, W), f, cfa=cfa, strip_rows=10 * f)
    np.testing.assert_array_equal(v, v2)
    np.testing.assert_array_equal(w, w2)


def test_binned_noise_variance_scales_with_the_sites_averaged():
    """A flat mosaic with Gaussian noise of variance S·x + O: the binned channels' variance is the
    site's divided by the sites averaged per block (R, B f²/4, G f²/2), as the binned profile says."""
    from isp.cfa import cfa_masks

    rng = np.random.default_rng(3)
    H = W = 768
    f = 4
    x = np.array([0.2, 0.5, 0.3])
    P = np.array([[1e-3, 1e-5], [5e-4, 2e-5], [8e-4, 1e-5]])
    m = cfa_masks((H, W), "GRBG")
    mean = (m * x).sum(-1)
    var = (m * (P[:, 0] * x + P[:, 1])).sum(-1)
    noisy = mean + rng.normal(size=(H, W)) * np.sqrt(var)
    v, _ = bin_mosaic(
        _rows_of((noisy[..., None] * m).astype(np.float32), m.astype(np.float32)), (H, W), f, cfa="GRBG"
    )
    got = v.reshape(-1, 3).var(0, ddof=1)
    Pb = binned_noise_profile(P, "GRBG", f)
    want = Pb[:, 0] * x + Pb[:, 1]
    # 36 864 blocks: the sample variance is within ~1.5 % (3 standard errors) of the truth
    np.testing.assert_allclose(got, want, rtol=0.03)
    np.testing.assert_allclose(v.reshape(-1, 3).mean(0), x, atol=3e-4)
    assert (want[1] < want[0]) and sites_per_block("GRBG", f).tolist() == [4, 8, 4]


def test_working_factor_budget_size_and_cfa_period():
    assert working_factor((96, 128), False) == 1  # within the budget: the mosaic itself
    f = working_factor((4000, 6000), False)
    assert f % 2 == 0 and (4000 // f) * (6000 // f) <= 2**18 < (4000 // (f - 2)) * (6000 // (f - 2))
    assert working_factor((4000, 6000), True, budget=10**6) == 5  # full colour: any integer
    assert working_factor((4000, 6000), False, budget=10**6) == 6  # Bayer: whole quads
    assert working_factor((96, 128), False, size=64) == 2
    assert working_factor((96, 128), False, size=50) == 4  # ceil(128/50) = 3 → the next even
    with pytest.raises(ValueError, match="train_size"):
        working_factor((96, 128), False, size=0)


@pytest.mark.parametrize("f", [2, 3, 8])
def test_a_binned_camera_projects_a_point_to_the_same_place(f):
    """A 3-D point's pixel position in the binned view is its full-resolution position divided by f
    (pixel edges at integers, centres at + ½), so it lands in the block of the full pixel it hits."""
    from splat import look_at

    cam = look_at((0.3, -3.0, 1.1), (0, 0, 0), width=97, height=70, fov_deg=55)
    small = scale_camera(cam, f)
    assert (small.width, small.height) == (97 // f, 70 // f)
    rng = np.random.default_rng(0)
    P = rng.uniform(-0.6, 0.6, (50, 3))

    def project(c):
        p = P @ np.asarray(c.R, float).T + np.asarray(c.t, float)
        return p[:, :2] / p[:, 2:] * np.asarray(c.focal, float) + np.asarray(c.principal, float)

    full, binned = project(cam), project(small)
    np.testing.assert_allclose(binned * f, full, rtol=1e-5, atol=1e-4)
    inside = (full[:, 0] < small.width * f) & (full[:, 1] < small.height * f) & (full >= 0).all(1)
    np.testing.assert_array_equal(np.floor(binned[inside]), np.floor(full[inside]) // f)


# ---------------------------------------------------------------------------------------------
# strips
# ---------------------------------------------------------------------------------------------


@pytest.fixture(scope="module")
def raw_file(tmp_path_factory):
    """A 52 × 70 RGGB DNG with a NoiseProfile-free mosaic and a few saturated sites."""
    from tests.splat.capture_helpers import write_dng_exif

    rng = np.random.default_rng(1)
    H, W = 52, 70
    yy, xx = np.mgrid[:H, :W]
    scene = 0.3 + 0.2 * np.sin(xx / 5.0) * np.cos(yy / 7.0) + 0.2 * (xx > 33)
    dn = np.clip(np.round(256 + scene * 3000 + rng.normal(0, 8, (H, W))), 0, 4095)
    dn[10, 10] = 4095
    path = tmp_path_factory.mktemp("raw") / "IMG_0001.dng"
    write_dng_exif(
        path,
        dn,
        cfa="RGGB",
        black=256,
        white=4095,
        neutral=np.ones(3),
        exposure_time=0.01,
        iso=100,
        fnumber=4.0,
    )
    return path


def test_demosaiced_strips_equal_the_whole_image(raw_file):
    from isp.stages import demosaic
    from splat.capture import open_raw
    from splat.strips import demosaic_rows

    src = open_raw(raw_file)
    H = src.shape[0]
    values, weight = src.rows(0, H)
    whole = demosaic(values.sum(-1), cfa=src.cfa, method="Malvar 2004")
    for rows in (2, 6, 16):
        parts = [demosaic_rows(src, a, min(H, a + rows)) for a in range(0, H, rows)]
        np.testing.assert_array_equal(np.concatenate([p[0] for p in parts]), whole)
        np.testing.assert_array_equal(np.concatenate([p[1] for p in parts]), weight.sum(-1) > 0)


def test_upsampling_is_strip_independent_and_exact_on_a_ramp():
    from splat.strips import upsample_rows

    f, h, w = 4, 6, 7
    yy, xx = np.mgrid[:h, :w].astype(float)
    img = np.stack([yy, xx], -1)
    H, W = h * f + 3, w * f + 2
    whole = upsample_rows(img, f, 0, H, W)
    parts = np.concatenate([upsample_rows(img, f, a, min(H, a + 5), W) for a in range(0, H, 5)])
    np.testing.assert_array_equal(parts, whole)
    # away from the clamped borders, a linear ramp is reproduced at the full-resolution centres
    i = np.arange(H)[:, None]
    j = np.arange(W)[None, :]
    ok = ((i + 0.5) / f - 0.5 >= 0) & ((i + 0.5) / f - 0.5 <= h - 1)
    ok = ok & ((j + 0.5) / f - 0.5 >= 0) & ((j + 0.5) / f - 0.5 <= w - 1)
    np.testing.assert_allclose(whole[..., 0][ok], (((i + 0.5) / f - 0.5) * np.ones((1, W)))[ok])
    np.testing.assert_allclose(whole[..., 1][ok], (np.ones((H, 1)) * ((j + 0.5) / f - 0.5))[ok])


def _full_inputs(raw_file, f=2, k=6):
    from splat.capture import open_raw

    src = open_raw(raw_file)
    H, W = src.shape
    rng = np.random.default_rng(2)
    h, w = H // f, W // f
    fused = rng.uniform(0.1, 0.6, (h, w, k))
    code = (rng.uniform(size=(h, w)) > 0.5).astype(int)
    sigma = {0: np.full(k, 0.02), 1: np.full(k, 0.01)}
    calls = []

    class Linear:
        def __init__(self, s):
            self.M = np.random.default_rng(int(1000 * s.sum())).uniform(0, 1, (3, k))

        def predict(self, c):
            return c @ self.M.T

    def fit(s):
        calls.append(tuple(s))
        return Linear(s), np.ones(k)

    return src, fused, code, sigma, fit, calls


def test_full_resolution_strips_give_the_same_image_at_any_strip_height(raw_file, tmp_path, monkeypatch):
    """Output at the RAW file's size; strips of 2, 8 and 128 rows give bit-identical XYZ (also through
    the TIFF writer), and a tiny strip height (the memory bound) changes nothing."""
    import tifffile

    from splat import strips

    src, fused, code, sigma, fit, calls = _full_inputs(raw_file)
    H, W = src.shape
    own = slice(0, 3)
    outs = []
    for rows in (2, 8, 128):
        gen = strips.full_resolution_view(
            strips.Photograph(src, 1.3, np.array([0.5, 0.6, 0.7]), np.full(3, 0.01)),
            strips.WorkingFusion(fused, code, sigma, own, 2),
            fit,
            strip_rows=rows,
        )
        outs.append(np.concatenate(list(gen)))
    assert outs[0].shape == (H, W, 3) and outs[0].dtype == np.float32
    np.testing.assert_array_equal(outs[0], outs[1])
    np.testing.assert_array_equal(outs[0], outs[2])
    assert len(set(calls)) == 2  # one fit per noise pattern
    monkeypatch.setattr(strips, "STRIP_ROWS", 4)
    gen = strips.full_resolution_view(
        strips.Photograph(src, 1.3, np.array([0.5, 0.6, 0.7]), np.full(3, 0.01)),
        strips.WorkingFusion(fused, code, sigma, own, 2),
        fit,
        strip_rows=4,
    )
    strips.write_full(
        tmp_path / "x.tiff",
        tmp_path / "x.png",
        gen,
        (H, W),
        lambda X: (np.clip(X, 0, 1) * 255).astype(np.uint8),
        rows=4,
    )
    np.testing.assert_array_equal(tifffile.imread(tmp_path / "x.tiff"), outs[0])
    from PIL import Image

    assert Image.open(tmp_path / "x.png").size == (W, H)


def test_full_resolution_own_channels_are_the_photograph(raw_file):
    """Where the pixel's own site is valid, the responses' own channels are the demosaiced photograph
    (exposure and white scale removed) and the others the upsampled fused values times the Brovey ratio:
    checked through an identity 'corrector' that returns the responses' first three channels."""
    from isp.stages import demosaic
    from splat import strips

    src, fused, code, sigma, _, _ = _full_inputs(raw_file, k=3)

    class First3:
        def predict(self, c):
            return c[:, :3]

    e, ws = 1.3, np.array([0.5, 0.6, 0.7])
    XYZ = np.concatenate(
        list(
            strips.full_resolution_view(
                strips.Photograph(src, e, ws, np.full(3, 0.01)),
                strips.WorkingFusion(fused, code, sigma, slice(0, 3), 2),
                lambda s: (First3(), np.ones(3)),
            )
        )
    )
    values, weight = src.rows(0, src.shape[0])
    photo = np.maximum(demosaic(values.sum(-1), cfa=src.cfa, method="Malvar 2004") / e / ws, 0)
    valid = weight.sum(-1) > 0
    np.testing.assert_allclose(XYZ[valid], photo[valid].astype(np.float32), rtol=1e-6)
    assert not valid[10, 10]  # the saturated site keeps the upsampled fused values
    up = strips.upsample_rows(fused, 2, 10, 11, src.shape[1])[0, 10]
    np.testing.assert_allclose(XYZ[10, 10], up, rtol=1e-6)


# ---------------------------------------------------------------------------------------------
# the pipeline at a working resolution
# ---------------------------------------------------------------------------------------------


@pytest.fixture(scope="module")
def small_capture(tmp_path_factory):
    """The test capture of capture_helpers (real DNG files, a COLMAP model), its images smooth random
    fields instead of renders of the Gaussian scene (no renderer to compile: these tests read files)."""
    import splat
    from tests.splat.capture_helpers import write_capture

    class Image:
        def __init__(self, cam):
            yy, xx = np.mgrid[: cam.height, : cam.width]
            ph = np.arange(9)[None, None] * 0.7
            self.image = 0.1 + 0.08 * np.sin(xx[..., None] / 4.0 + ph) * np.cos(yy[..., None] / 5.0 + ph)

    root = tmp_path_factory.mktemp("rs") / "cap"
    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(splat, "render_reference", lambda g, cam: Image(cam))
        write_capture(root, views=2, holdout=1)
    return root


def test_training_inputs_are_binned_and_their_cameras_scaled(small_capture, tmp_path):
    """train_size 24: every camera binned (Bayer by an even factor, whole quads), the training cameras'
    intrinsics divided by the factor, the poses model kept at full resolution; the poses summary says
    how long it took and its peak memory."""
    from splat.capture import (
        PipelineConfig,
        load_model_capture,
        load_views,
        poses_step,
        read_capture,
        training_inputs,
    )

    out = tmp_path / "out"
    s = poses_step(small_capture, out, config=PipelineConfig())
    assert s["duration_s"] > 0 and s["peak_rss_mib"] > 0
    spec = read_capture(small_capture)
    _, cap = load_model_capture(spec, out)
    full = {v.name: v.camera for v in cap.views}
    raws = {v.name: v for v in load_views(spec)}
    assert all((c.height, c.width) == raws[n].shape for n, c in full.items())  # model at full size
    inp = training_inputs(spec, out, PipelineConfig(train_size=24))
    for v in inp.views:
        f = inp.working[spec.cameras[v.camera_id - 1].folder]["binning"]
        assert f > 1 and (f % 2 == 0 or raws[v.name].full_colour)
        c = full[v.name]
        np.testing.assert_allclose(np.asarray(v.camera.focal) * f, np.asarray(c.focal), rtol=1e-6)
        np.testing.assert_allclose(np.asarray(v.camera.principal) * f, np.asarray(c.principal), rtol=1e-6)
        assert (v.camera.height, v.camera.width) == (c.height // f, c.width // f)
        assert max(v.camera.width, v.camera.height) <= 24
    # binned views are full colour: each of the view's own channels measured at (nearly) every pixel
    for i, v in enumerate(inp.views):
        k, h, w = v.camera_id - 1, v.camera.height, v.camera.width
        assert (inp.weights[i, :h, :w, 3 * k : 3 * k + 3] > 0).mean() > 0.9
        assert not inp.weights[i, h:].any() and not inp.weights[i, :, w:].any()


def test_the_white_patch_does_not_depend_on_the_binning(small_capture):
    """A box whose edges are not on the blocks' grid: the binned view's white is the mean of the box's
    own sites, as at full resolution, never of the blocks it straddles (which average in sites beyond
    its edges); the rendered card is read on the blocks wholly inside it."""
    from dataclasses import replace

    from splat.capture import (
        PipelineConfig,
        WhiteSpec,
        load_views,
        read_capture,
        white_box,
        white_patch,
    )
    from splat.capture.config import working_binning

    spec = read_capture(small_capture)
    full = load_views(spec)
    name = full[0].name
    H, W = full[0].shape
    box = (3, 5, W // 2 + 1, H // 2 + 3)  # odd edges
    spec = replace(spec, white=WhiteSpec("patch", name, box, 0.9))
    binned = load_views(spec, binning=working_binning(PipelineConfig(train_size=16), spec))
    v1, vb = full[0], next(v for v in binned if v.name == name)
    f = vb.binning
    assert f >= 2
    m1, n1 = white_patch(spec, v1)
    mb, nb = white_patch(spec, vb)
    np.testing.assert_allclose(mb, m1, rtol=1e-6)
    np.testing.assert_array_equal(nb, n1)
    # the straddling blocks give another white on this field, so the test can tell them apart
    x0, y0, x1, y1 = box
    touched = vb.values[y0 // f : -(-y1 // f), x0 // f : -(-x1 // f)].reshape(-1, 3).mean(0)
    assert np.max(np.abs(touched / m1 - 1)) > 1e-3
    a0, b0, a1, b1 = white_box(spec, vb)
    assert (a0 * f, b0 * f) >= (x0, y0) and (a1 * f, b1 * f) <= (x1, y1) and a1 > a0 and b1 > b0


def test_train_size_and_noise_are_checked_before_work(small_capture, tmp_path, capsys):
    from splat.capture import CaptureError, PipelineConfig, read_capture
    from splat.cli import main

    for bad in (0, 8, 3.5, True):
        with pytest.raises(ValueError, match="train_size"):
            PipelineConfig(train_size=bad)
    for bad in ("loud", -1.0, {"shot": 1.0}):
        with pytest.raises(ValueError, match="noise"):
            PipelineConfig(noise=bad)
    PipelineConfig(noise={"shot": 2e-5, "read": 0.0})
    toml = small_capture / "capture.toml"
    text = toml.read_text()
    import shutil

    c = tmp_path / "cap"
    shutil.copytree(small_capture, c)
    (c / "capture.toml").write_text('train_size = "big"\n' + text)
    with pytest.raises(CaptureError, match="train_size"):
        read_capture(c)
    (c / "capture.toml").write_text("train_size = 32\n" + text)
    assert read_capture(c).train_size == 32
    assert main(["poses", str(c), "-o", str(tmp_path / "o"), "--noise", "1e-3:x"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "--noise" in err[0]
    assert not (tmp_path / "o").exists()


def test_the_8_bit_encoder_is_XYZ_to_sRGB_rounded():
    """The table-driven 8-bit sRGB of the full-resolution PNG against colour-science's exact conversion
    (``pipeline.XYZ_to_sRGB``): within one level everywhere, equal on most pixels."""
    from splat.capture import XYZ_to_sRGB
    from splat.strips import sRGB8_encoder

    rng = np.random.default_rng(5)
    XYZ = rng.uniform(0, 1.1, (4000, 3)) * np.array([0.95, 1.0, 1.09])
    white = np.array([0.9505, 1.0, 1.089])
    exact = np.round(XYZ_to_sRGB(XYZ, white) * 255)
    got = sRGB8_encoder(white)(XYZ).astype(float)
    assert got.dtype == float and np.abs(got - exact).max() <= 1 and (got == exact).mean() > 0.95


@pytest.mark.parametrize("cfa", ["RGGB", "GBRG", None])
def test_raw_rows_against_the_per_site_formula(cfa):
    """RawSource.rows: each measured channel (the pixel's CFA site, or all three) clipped to
    [−0.05, 1] of (DN − black) / (white − black), 0 elsewhere; weight 1 where measured, not saturated
    and not dead (DN ≤ 0 with a black level above 0); the counts of such pixels."""
    from pathlib import Path

    from isp.cfa import cfa_masks
    from splat.capture.raw import RawSource

    rng = np.random.default_rng(3)
    shape = (12, 9) if cfa else (12, 9, 3)
    dn = rng.integers(0, 4096, shape).astype(np.uint16)
    dn.flat[::7], dn.flat[::11] = 4095, 0
    dn[3, 4] = 0  # dead in every channel (a full-colour pixel is dead only so)
    black = np.array([[64.0, 60.0], [62.0, 66.0]]) if cfa else np.array([64.0, 60.0, 62.0])
    src = RawSource(Path("x.dng"), dn, black, 4000.0, cfa, {})
    values, weight, n_sat, n_dead = src.rows(2, 10, counts=True)
    d = dn[2:10].astype(float)
    if cfa:
        site = cfa_masks(d.shape, cfa)
        b = np.tile(black, (4, 5))[:8, :9]
        x = np.clip((d - b) / (4000.0 - b), -0.05, 1.0)[..., None] * site
        sat, dead = d >= 4000.0, (d <= 0) & (b > 0)
    else:
        site = np.ones(d.shape, bool)
        x = np.clip((d - black) / (4000.0 - black), -0.05, 1.0)
        sat, dead = (d >= 4000.0).any(-1), (d <= 0).all(-1)
    assert values.dtype == weight.dtype == np.float32
    np.testing.assert_array_equal(values, np.where(site, x, 0).astype(np.float32))
    np.testing.assert_array_equal(weight, (site & ~(sat | dead)[..., None]).astype(np.float32))
    assert (n_sat, n_dead) == (int(sat.sum()), int(dead.sum())) and n_sat > 0 and n_dead > 0


@pytest.mark.parametrize("f", [1, 2])
def test_full_resolution_at_binning_one_is_the_working_fusion_corrected(raw_file, tmp_path, f):
    """Where the working grid is the RAW file's (binning 1) the full-size output is the working fused
    responses corrected pattern by pattern (they know more than the strips: the other cameras' help in
    demosaicing, the camera's other photographs averaged in); at binning 2 it is the strips'."""
    import tifffile

    from splat import strips
    from splat.capture import CameraSpec
    from splat.capture.correct import _full_resolution

    src, fused, code, sigma, fit, _ = _full_inputs(raw_file, f=f)
    H, W = src.shape
    view = types.SimpleNamespace(camera=0, path=raw_file, binning=f, exif=1.3)
    spec = types.SimpleNamespace(cameras=[CameraSpec("a", "Nikon 5100 (NPL)")], label=lambda k: "a")
    noise = {"sigma_full": np.full(3, 0.01)}
    scale = np.array([0.5, 0.6, 0.7])
    info = _full_resolution(
        spec, tmp_path, view, fused, code, sigma, scale, noise, fit, np.array([0.95, 1.0, 1.09]), None
    )
    got = tifffile.imread(tmp_path / "full_XYZ.tiff")
    assert got.shape == (H, W, 3) and info["size"] == [W, H]
    if f == 1:
        want = np.zeros((H, W, 3))  # each pattern's corrector on its pixels, by hand
        for c, s_ in sigma.items():
            want[code == c] = fit(s_)[0].predict(fused[code == c])
        np.testing.assert_allclose(got, want, rtol=1e-5, atol=1e-6)
        assert info["from"].startswith("the working fusion")
    else:
        photo = strips.Photograph(src, 1.3, scale, noise["sigma_full"])
        work = strips.WorkingFusion(fused, code, sigma, slice(0, 3), 2)
        whole = np.concatenate(list(strips.full_resolution_view(photo, work, fit)))
        np.testing.assert_array_equal(got, whole)
        assert "from" not in info
