"""Full-resolution reprojection and writing in strips (splat.strips, splat.reproject.reproject_rows).

Independent truths: :func:`splat.reproject.reproject` of the whole source image (reading by bands must
give the same values); the closed-form plane of ``test_reproject`` (depth and texture of a world plane);
one whole-image computation (a strip-by-strip result must equal it); Pillow's PNG decoder; tracemalloc's
peak (memory must not grow with the image's height).
"""

from __future__ import annotations

import tracemalloc

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from splat import SplatError
from splat.camera import Camera
from splat.reproject import RowSource, depth_map, reproject, reproject_rows, reprojected
from splat.resolution import scale_camera
from splat.strips import (
    CachedRows,
    FullReprojection,
    Photograph,
    PNGStripWriter,
    WorkingFusion,
    full_resolution_view,
    reprojected_strip,
    strip_camera,
    textured_rows,
    upsample_rows,
    write_full,
)

from .test_reproject import SOURCES, TARGET, _cam, _depth_alpha, _floor, _gaussians, _photo, _texture

# ------------------------------------------------------------------------- reading a source by bands


def _row_source(cam, image, depth, f=1, *, band_log=None):
    def rows(a, b):
        if band_log is not None:
            band_log.append((a, b))
        return image[a:b]

    return RowSource(cam, depth, f, rows, None, image.shape[-1])


@settings(max_examples=15, deadline=None)
@given(band=st.integers(1, 40), k=st.sampled_from([0, 1, 2]))
def test_reproject_rows_equals_whole_image(band, k):
    """Reading only the rows each band needs gives :func:`reproject`'s values and validity."""
    src = SOURCES[k]
    sd, img = _photo(src)
    td, ta, _ = _depth_alpha(TARGET)
    want, ok = reproject(TARGET, td, ta, src, sd, img)
    log = []
    got, ok2 = reproject_rows(TARGET, td, ta, _row_source(src, img, sd, band_log=log), band=band)
    np.testing.assert_array_equal(ok2, ok)
    np.testing.assert_allclose(got, want, rtol=1e-6, atol=1e-6)  # float32 bands
    assert all(b - a <= band + 1 for a, b in log)


def test_reproject_rows_checks_the_depth_size():
    src = SOURCES[0]
    sd, img = _photo(src)
    td, ta, _ = _depth_alpha(TARGET)
    with pytest.raises(SplatError, match="1/2"):
        reproject_rows(TARGET, td, ta, _row_source(src, img, sd, 2))


class _Counted:
    """An image read by rows, counting how often each row is read."""

    def __init__(self, h, w=3):
        self.img = np.arange(h * w, dtype=float).reshape(h, w, 1)
        self.reads = np.zeros(h, int)
        self.calls = []

    def __call__(self, a, b):
        self.calls.append((a, b))
        self.reads[a:b] += 1
        return self.img[a:b].copy()


def test_cached_rows_sweep_reads_each_row_once():
    img = _Counted(100)
    rows = CachedRows(img, 100, rows=32, block=16)
    for a in range(0, 90, 8):
        np.testing.assert_array_equal(rows(a, a + 10), img.img[a : a + 10])
    assert (img.reads == 1).all()
    assert all(a % 16 == 0 and (b % 16 == 0 or b == 100) for a, b in img.calls)


def test_cached_rows_keeps_a_band_longer_than_its_rows():
    # a strip of a rolled view lands on a tall band, read in parts (reproject_rows' bands); the next
    # strip's parts start above the last part's rows: the first parts are still kept
    img = _Counted(400)
    rows = CachedRows(img, 400, rows=96, block=16)
    for a in (10, 30, 50):
        for lo, hi in ((a, a + 48), (a + 48, a + 90)):
            np.testing.assert_array_equal(rows(lo, hi), img.img[lo:hi])
    assert img.reads.max() == 1


@settings(max_examples=30, deadline=None)
@given(
    st.lists(st.tuples(st.integers(0, 119), st.integers(1, 60)), min_size=1, max_size=12),
    st.integers(1, 40),
    st.integers(1, 70),
)
def test_cached_rows_any_requests_give_the_rows_with_bounded_memory(requests, block, keep):
    img = _Counted(120)
    rows = CachedRows(img, 120, rows=keep, block=block)
    for a, n in requests:
        b = min(120, a + n)
        np.testing.assert_array_equal(rows(a, b), img.img[a:b])
        need = (b - 1) // block - a // block + 1
        assert len(rows.blocks) <= max(keep // block, need)


# ------------------------------------------------- full resolution against the working resolution


def test_full_resolution_agrees_with_working_where_smooth():
    """A plane with a smooth texture, photographed at 3× the working resolution: reprojected at full
    resolution (sources read by bands, their depth at the working resolution) against reprojected at the
    working resolution and upsampled, they agree to the interpolation error of the smooth texture."""
    f = 3
    full_t = _cam((0.4, -3.0, 2.6), (0.1, 0.2, 0.0), size=(144, 108), focal=(126.0, 132.0))
    work_t = scale_camera(full_t, f)
    sources_full = [
        _cam(
            (-1.5, -2.0, 3.2),
            (0.0, 0.0, 0.0),
            size=(240, 180),
            focal=(225.0, 210.0),
            principal=(124.5, 86.25),
        ),
        _cam(
            (0.5, 2.5, 3.0), (-0.2, 0.1, 0.0), size=(210, 165), focal=(180.0, 187.5), principal=(103.5, 84.0)
        ),
    ]
    srcs_work, srcs_rows = [], []
    for s in sources_full:
        sw = scale_camera(s, f)
        dw, _ = _photo(sw)
        _, img_full = _photo(s)
        srcs_work.append((sw, dw, _photo(sw)[1]))
        srcs_rows.append(_row_source(s, img_full, dw, f))
    dw, aw, _ = _depth_alpha(work_t)
    df, af, X = _depth_alpha(full_t)
    work, cw = reprojected(work_t, dw, aw, srcs_work)
    full, cf = reprojected(full_t, df, af, srcs_rows)
    up = upsample_rows(work, f, 0, full_t.height, full_t.width)
    seen = (cf == 2) & (
        upsample_rows(cw[..., None].astype(float), f, 0, full_t.height, full_t.width)[..., 0] == 2
    )
    assert seen.sum() > 0.5 * seen.size
    # full resolution is the texture itself to interpolation error; the working path is blurred by
    # its coarser sampling, both within 1 %
    truth = _texture(X)
    assert np.abs(full - truth)[seen].max() < 1e-3 * np.abs(truth).max()
    np.testing.assert_allclose(up[seen], full[seen], rtol=1e-2)
    assert np.abs(up - truth)[seen].max() > np.abs(full - truth)[seen].max()


# --------------------------------------------------------------- strips against the whole image

_SIZE = (40, 24)  # full resolution (W, H) of the rendered target


@pytest.fixture(scope="module")
def splat_scene():
    """Gaussians on the floor, a target view at full resolution 2× its working one, and two source
    photographs (the floor's texture) at full resolution with working-resolution depths."""
    from splat.camera import look_at

    g = _gaussians(_floor(), lambda m: np.ones((len(m), 2)))
    full_t = look_at((0.6, -2.2, 2.4), (0.0, 0.0, 0.0), width=_SIZE[0], height=_SIZE[1], fov_deg=60)
    f = 2
    groups = {}
    for i, eye in ((1, (-1.2, -2.0, 2.2)), (2, (1.5, -1.8, 2.6))):
        s = look_at(eye, (0.1, 0.1, 0.0), width=48, height=32, fov_deg=70)
        sw = scale_camera(s, f)
        d, a = depth_map(g, sw)
        _, _, X = _depth_alpha(s)
        img = np.concatenate([_texture(X), _texture(X)[..., :1]], -1)
        groups[i] = [RowSource(s, np.where(a >= 0.5, d, 0.0), f, lambda a_, b_, img=img: img[a_:b_])]
    return g, full_t, groups


def test_strip_camera_is_rows_of_the_view(splat_scene):
    """A strip rendered on its own is the view's rows, to float32 rounding (its principal point is
    shifted), when its height is a multiple of the renderer's 16-pixel tiles (as ``STRIP_ROWS`` is):
    the same tiles cull the same Gaussians."""
    g, cam, _ = splat_scene
    d, a = depth_map(g, cam)
    for r0, r1 in ((0, 16), (16, 24)):
        ds, as_ = depth_map(g, strip_camera(cam, r0, r1))
        np.testing.assert_allclose(ds[as_ > 0.5], d[r0:r1][as_ > 0.5], rtol=1e-5)
        np.testing.assert_allclose(as_, a[r0:r1], atol=1e-4)


def test_working_footprint_renders_the_working_view_at_full_resolution():
    """At ``f = 3`` full-resolution pixel ``3 i + 1`` has working pixel ``i``'s centre: rendered with
    :func:`splat.resolution.working_footprint`, the full-size depth and opacity there are the working
    render's; with the renderer's own 2-D dilation the small Gaussians cover less of the floor."""
    from splat import init_gaussians
    from splat.camera import look_at
    from splat.resolution import working_footprint

    means = _floor(step=0.04)
    g = init_gaussians(means, np.ones((len(means), 2)), scales=0.008, opacity=0.7)
    full = look_at((0.6, -2.2, 2.4), (0.0, 0.0, 0.0), width=96, height=72, fov_deg=60)
    d, a = depth_map(g, scale_camera(full, 3))
    d3, a3 = depth_map(g, full, config=working_footprint(3))
    on = a > 0.5
    assert on.mean() > 0.3
    np.testing.assert_allclose(a3[1::3, 1::3], a, atol=1e-4)
    np.testing.assert_allclose(d3[1::3, 1::3][on], d[on], rtol=1e-5)
    _, a1 = depth_map(g, full)
    assert a1[1::3, 1::3][on].mean() < a[on].mean() - 0.1
    assert working_footprint(1).eps2d == 0.3 and working_footprint(3).eps2d == pytest.approx(2.7)


def test_reprojected_strip_renders_with_the_working_footprint(splat_scene):
    """``FullReprojection.binning``: the strip's depth, render and opacity are those of
    :func:`splat.resolution.working_footprint` at that factor."""
    from splat.resolution import working_footprint

    g, cam, groups = splat_scene
    for f in (1, 3):
        rep = FullReprojection(g, None, cam, groups, np.full(9, 0.01), binning=f)
        *_, render, opacity = reprojected_strip(rep, 0, 16, colour=True)
        _, a, col = depth_map(g, strip_camera(cam, 0, 16), colour=True, config=working_footprint(f))
        np.testing.assert_allclose(opacity, a, atol=1e-6)
        np.testing.assert_allclose(render, col, rtol=1e-5, atol=1e-6)
    assert np.abs(opacity - depth_map(g, strip_camera(cam, 0, 16))[1]).max() > 1e-2


def test_reprojected_strip_lifts_a_half_transparent_splat(splat_scene):
    """A splat of faint Gaussians (opacity 0.06 each, nowhere 0.5 in all): the strip lifts and reads
    the pixels whose opacity reaches ``rep.min_alpha`` (default ``MIN_ALPHA``), as
    :func:`splat.reproject.reprojected` does with that threshold; none below it, none at all from 0.5."""
    from splat import init_gaussians
    from splat.reproject import MIN_ALPHA

    from .test_reproject import _SIGMA

    _, cam, groups = splat_scene
    means = _floor()
    faint = init_gaussians(means, np.ones((len(means), 2)), scales=_SIGMA, opacity=0.06)
    d, a = depth_map(faint, cam)
    assert not (a >= 0.5).any() and ((a >= MIN_ALPHA) & (a < 0.5)).mean() > 0.3
    values, counts = reprojected_strip(FullReprojection(faint, None, cam, groups, np.ones(9)), 0, cam.height)
    for sources, v, n in zip(groups.values(), values, counts, strict=True):
        want_v, want_n = reprojected(cam, d, a, sources, min_alpha=MIN_ALPHA)
        np.testing.assert_array_equal(n, want_n)
        np.testing.assert_allclose(v, want_v, rtol=1e-6, atol=1e-7)
        assert (n > 0).sum() > 20 and not n[a < MIN_ALPHA].any()
    rep = FullReprojection(faint, None, cam, groups, np.ones(9), min_alpha=0.5)
    assert not any(n.any() for n in reprojected_strip(rep, 0, cam.height)[1])


def test_reprojected_strip_equals_whole(splat_scene):
    g, cam, groups = splat_scene
    rep = FullReprojection(g, None, cam, groups, np.full(9, 0.01))
    whole_v, whole_n = reprojected_strip(rep, 0, cam.height)
    parts = [reprojected_strip(rep, r0, min(r0 + 16, cam.height)) for r0 in range(0, cam.height, 16)]
    for j in range(2):
        assert whole_n[j].sum() > 0.15 * whole_n[j].size
        np.testing.assert_array_equal(np.concatenate([p[1][j] for p in parts]), whole_n[j])
        np.testing.assert_allclose(np.concatenate([p[0][j] for p in parts]), whole_v[j], rtol=1e-6, atol=1e-7)


class _Linear:
    """A closed-form corrector stand-in: XYZ = the responses' first three channels + 0.1 × the rest."""

    def predict(self, r):
        return r[:, :3] + 0.1 * r[:, 3:6] + 0.05 * r[:, 6:9]


EDGE = 20


class _Source:
    """A full-colour RAW stand-in (:class:`splat.capture.RawSource`'s ``rows``): a smooth image."""

    cfa = None
    full_colour = True

    def __init__(self, H, W):
        jj, ii = np.meshgrid(np.arange(W), np.arange(H))
        self.img = np.stack([0.3 + 0.002 * jj, 0.4 + 0.003 * ii, 0.5 - 0.001 * (ii + jj)], -1)
        self.img[:, EDGE:] *= 2.5  # a step: textured within 2 columns of it
        self.shape = (H, W)

    def rows(self, a, b):
        return self.img[a:b].astype(np.float32), np.ones((b - a, self.shape[1], 3), np.float32)


def test_full_resolution_view_strips_equal_whole_and_use_full_res_photographs(splat_scene):
    g, cam, groups = splat_scene
    W, H = _SIZE
    f = 2
    fused = np.full((H // f, W // f, 9), 0.2)
    code = np.zeros((H // f, W // f), int)
    code[0, 0] = 1 << 3  # a textured working pixel: its own σ pattern, reprojected all the same
    sigma = {0: np.full(9, 0.02), 8: np.full(9, 0.03)}
    fits = []

    def fit(s):
        fits.append(np.array(s))
        return _Linear(), np.ones(9)

    rep = FullReprojection(g, None, cam, groups, np.full(9, 0.05))
    photo = Photograph(_Source(H, W), 1.0, np.ones(3), np.full(3, 0.01))
    work = WorkingFusion(fused, code, sigma, slice(0, 3), f)
    outs = {
        rows: np.concatenate(list(full_resolution_view(photo, work, fit, strip_rows=rows, reprojection=rep)))
        for rows in (16, H)
    }
    np.testing.assert_allclose(outs[16], outs[H], rtol=1e-6, atol=1e-7)
    plain = np.concatenate(list(full_resolution_view(photo, work, fit, strip_rows=H)))
    values, seen = reprojected_strip(rep, 0, H)
    tex = np.zeros((H, W), bool)
    tex[:, EDGE - 2 : EDGE + 2] = True  # the step's 5 × 5 windows: textured at full resolution
    np.testing.assert_array_equal(textured_rows(photo.source, 0, H, 1.0, np.ones(3), np.full(3, 0.01)), tex)
    both = (seen[0] > 0) & (seen[1] > 0) & ~tex
    # where both cameras' photographs see a pixel, XYZ = own + 0.1 × camera 1 + 0.05 × camera 2 at full res
    want = _Source(H, W).img + 0.1 * values[0] + 0.05 * values[1]
    np.testing.assert_allclose(outs[H][both], want[both], rtol=1e-5)
    assert np.abs(outs[H] - plain)[both].max() > 0.01  # the previous path used the working responses
    np.testing.assert_allclose(outs[H][tex], plain[tex], rtol=1e-6)  # textured: the previous path
    # σ of the reprojected channels replaces the working pattern's where they enter
    assert any(np.allclose(s[3:], 0.05) and np.allclose(s[:3], 0.01) for s in fits)


def test_full_resolution_view_skips_a_camera_rejected_at_the_working_resolution(splat_scene):
    """Where the working fusion rejected camera 1's reprojection (``splat.fusion.rejected_bit``: no
    surface gives it with the own channels), its full-resolution photographs are not read either: its
    channels are the working responses upsampled and anchored there, camera 2's still reprojected."""
    from splat.fusion import rejected_bit

    g, cam, groups = splat_scene
    W, H = _SIZE
    f = 2
    fused = np.full((H // f, W // f, 9), 0.2)
    code = np.zeros((H // f, W // f), int)
    code[:, : W // f // 2] = rejected_bit(3, 1)  # camera 1 rejected in the left half
    sigma = {0: np.full(9, 0.02), rejected_bit(3, 1): np.full(9, 0.02)}
    rep = FullReprojection(g, None, cam, groups, np.full(9, 0.05))
    photo = Photograph(_Source(H, W), 1.0, np.ones(3), np.full(3, 0.01))
    work = WorkingFusion(fused, code, sigma, slice(0, 3), f)
    fit = lambda s: (_Linear(), np.ones(9))  # noqa: E731
    out = np.concatenate(list(full_resolution_view(photo, work, fit, strip_rows=H, reprojection=rep)))
    plain = np.concatenate(
        list(
            full_resolution_view(
                photo,
                WorkingFusion(fused, np.zeros_like(code), {0: sigma[0]}, slice(0, 3), f),
                fit,
                strip_rows=H,
            )
        )
    )
    values, seen = reprojected_strip(rep, 0, H)
    tex = textured_rows(photo.source, 0, H, 1.0, np.ones(3), np.full(3, 0.01))
    both = (seen[0] > 0) & (seen[1] > 0) & ~tex
    left = np.zeros((H, W), bool)
    left[:, : W // 2] = True
    own = _Source(H, W).img
    anchored = (plain - own) / 0.15  # the working 0.2 anchored: the same in cameras 1 and 2
    want = np.where(
        left[..., None], own + 0.1 * anchored + 0.05 * values[1], own + 0.1 * values[0] + 0.05 * values[1]
    )
    assert (both & left).sum() > 50 and (both & ~left).sum() > 20
    np.testing.assert_allclose(out[both], want[both], rtol=1e-5, atol=1e-6)


class _Given(_Source):
    """A full-colour RAW stand-in showing a given image."""

    def __init__(self, img):
        self.img, self.shape = img, img.shape[:2]


def test_full_resolution_view_averages_the_own_cameras_other_photographs(splat_scene):
    """A group at the photograph's own position is its camera's other photographs: where one sees a
    plain pixel and agrees with the measurement (σ 0.01) within ``JOINT_NSIGMA`` times the sum of the
    two σ, the own channels are the inverse-variance mean of the measurement and their reprojection
    (σ 0.02), and the fit is told the two σ combined; where it is farther, the measurement alone; another
    camera's group replaces its channels as before."""
    g, cam, groups = splat_scene
    W, H = _SIZE
    f = 2
    own = slice(3, 6)
    work = WorkingFusion(
        np.full((H // f, W // f, 9), 0.2), np.zeros((H // f, W // f), int), {0: np.full(9, 0.03)}, own, f
    )
    fits = []

    def fit(s):
        fits.append(np.array(s))
        return _Linear(), np.ones(9)

    rep_sigma = np.array([0.05, 0.05, 0.05, 0.02, 0.02, 0.02, 0.04, 0.04, 0.04])
    rep = FullReprojection(g, None, cam, groups, rep_sigma)
    values, seen = reprojected_strip(rep, 0, H)
    # the photograph: what the camera's other photographs show, off by 0.01 (top) or 0.5 (bottom)
    top = (np.arange(H) < 17)[:, None, None]  # the two groups see rows 10–23 together
    measured = np.where(seen[0][..., None] > 0, values[0], 0.3) + np.where(top, 0.01, 0.5)
    photo = Photograph(_Given(measured.astype(float)), 1.0, np.ones(3), np.full(3, 0.01))
    out = np.concatenate(list(full_resolution_view(photo, work, fit, strip_rows=16, reprojection=rep)))
    tex = textured_rows(photo.source, 0, H, 1.0, np.ones(3), np.full(3, 0.01))
    both = (seen[0] > 0) & (seen[1] > 0) & ~tex
    near = both & top[..., 0]
    assert near.sum() > 20 and (both & ~top[..., 0]).sum() > 20
    mean = (measured / 0.01**2 + values[0] / 0.02**2) / (1 / 0.01**2 + 1 / 0.02**2)
    plain = np.concatenate(list(full_resolution_view(photo, work, fit, strip_rows=H)))
    # cameras 0 and 2 without reprojection: the working 0.2 upsampled and anchored, alike in both
    anchored = (plain - 0.1 * measured) / 1.05
    own_now = np.where(near[..., None], mean, measured)
    want = anchored + 0.1 * own_now + 0.05 * values[1]  # camera 0 still anchored, camera 2 reprojected
    np.testing.assert_allclose(out[both], want[both], rtol=1e-5, atol=1e-6)
    assert np.abs(mean - measured)[near].max() > 1e-3  # the average moved the measurement
    combined = 1 / np.sqrt(1 / 0.01**2 + 1 / 0.02**2)
    assert any(np.allclose(s[3:6], combined) and np.allclose(s[6:], 0.04) for s in fits)
    assert any(np.allclose(s[3:6], 0.01) and np.allclose(s[6:], 0.04) for s in fits)  # far: measured


def test_full_resolution_flags_do_not_read_as_working_rejections(splat_scene):
    """A working code that carries the own camera's rejection bit widens the patterns; the cameras'
    full-resolution flags then sit where other cameras' rejection bits are, and must not be taken for
    them: every other pixel is as without that bit (camera 2 still reprojected where camera 1 is)."""
    from splat.fusion import rejected_bit

    g, cam, groups = splat_scene
    W, H = _SIZE
    f = 2
    own = slice(0, 3)
    fit = lambda s: (_Linear(), np.ones(9))  # noqa: E731
    photo = Photograph(_Source(H, W), 1.0, np.ones(3), np.full(3, 0.01))
    rep = FullReprojection(g, None, cam, groups, np.full(9, 0.05))
    outs = []
    for bit in (0, rejected_bit(3, 0)):
        code = np.zeros((H // f, W // f), int)
        code[0, 0] = bit
        work = WorkingFusion(
            np.full((H // f, W // f, 9), 0.2), code, {0: np.full(9, 0.03), bit: np.full(9, 0.03)}, own, f
        )
        outs.append(
            np.concatenate(list(full_resolution_view(photo, work, fit, strip_rows=16, reprojection=rep)))
        )
    _, seen = reprojected_strip(rep, 0, H)
    assert ((seen[0] > 0) & (seen[1] > 0)).sum() > 50
    np.testing.assert_array_equal(outs[1][f:], outs[0][f:])


def test_depth_map_with_colour_is_the_depth_and_the_render_of_one_pass(splat_scene):
    """``depth_map(colour=True)``: the same depth and opacity as without, and the colours
    :func:`splat.outputs.render_views` renders for the view."""
    from splat.outputs import render_views

    _, cam, _ = splat_scene
    g = _gaussians(_floor(), lambda m: 0.2 + 0.1 * np.abs(np.concatenate([m, m, m], 1)))
    d, a = depth_map(g, cam)
    d2, a2, col = depth_map(g, cam, colour=True)
    np.testing.assert_allclose(a2, a, atol=1e-6)
    np.testing.assert_allclose(d2[a > 0.5], d[a > 0.5], rtol=1e-5)
    np.testing.assert_allclose(col, render_views(g, [cam])[0], rtol=1e-5, atol=1e-6)
    assert col.shape == (cam.height, cam.width, 9) and col[a > 0.5].std(0).min() > 1e-3


def test_full_resolution_view_anchors_the_render_at_textured_pixels(splat_scene):
    """With ``render_scale`` at binning 2: a textured pixel the splat covers (opacity ≥
    ``RENDER_ANCHOR_ALPHA``) has the splat's render at full resolution (÷ render_scale) anchored to the
    photograph's own sites (:func:`splat.fusion.anchor`), not the working responses upsampled; other
    pixels do not change. At binning 8 nothing changes."""
    from splat._tol import RENDER_ANCHOR_ALPHA
    from splat.fusion import anchor
    from splat.outputs import render_views

    _, cam, groups = splat_scene
    g = _gaussians(_floor(), lambda m: 0.2 + 0.1 * np.abs(np.concatenate([m, m, m], 1)))
    W, H = _SIZE
    f = 2
    own = slice(0, 3)
    work = WorkingFusion(
        np.full((H // f, W // f, 9), 0.2), np.zeros((H // f, W // f), int), {0: np.full(9, 0.03)}, own, f
    )
    fit = lambda s: (_Linear(), np.ones(9))  # noqa: E731
    photo = Photograph(_Source(H, W), 1.0, np.ones(3), np.full(3, 0.01))
    scale = np.full(9, 2.0)
    outs = {
        key: np.concatenate(
            list(
                full_resolution_view(
                    photo,
                    work,
                    fit,
                    strip_rows=16,
                    reprojection=FullReprojection(g, None, cam, groups, np.full(9, 0.05), rs),
                )
            )
        )
        for key, rs in (("plain", None), ("anchored", scale))
    }
    _, alpha = depth_map(g, cam)
    tex = textured_rows(photo.source, 0, H, 1.0, np.ones(3), np.full(3, 0.01)) & (
        alpha >= RENDER_ANCHOR_ALPHA
    )
    assert tex.sum() > 20 and (~tex).sum() > 20
    np.testing.assert_allclose(outs["anchored"][~tex], outs["plain"][~tex], rtol=1e-6)
    render = render_views(g, [cam])[0] / scale
    want = anchor(render, _Source(H, W).img, own)
    x = want.reshape(-1, 9)
    want_xyz = _Linear().predict(x).reshape(H, W, 3)
    np.testing.assert_allclose(outs["anchored"][tex], want_xyz[tex], rtol=2e-5, atol=1e-6)
    assert np.abs(outs["anchored"] - outs["plain"])[tex].max() > 1e-2
    # above RENDER_ANCHOR_BINNING the render is too blurred at an edge: the photograph is kept
    f = 8
    work = WorkingFusion(
        np.full((H // f, W // f, 9), 0.2), np.zeros((H // f, W // f), int), {0: np.full(9, 0.03)}, own, f
    )
    coarse = [
        np.concatenate(
            list(
                full_resolution_view(
                    photo,
                    work,
                    fit,
                    reprojection=FullReprojection(g, None, cam, groups, np.full(9, 0.05), rs),
                )
            )
        )
        for rs in (None, scale)
    ]
    np.testing.assert_array_equal(coarse[1], coarse[0])


def test_full_resolution_view_refuses_a_group_outside_the_cameras(splat_scene):
    g, cam, groups = splat_scene
    W, H = _SIZE
    work = WorkingFusion(
        np.zeros((H // 2, W // 2, 9)), np.zeros((H // 2, W // 2), int), {0: np.ones(9)}, slice(3, 6), 2
    )
    rep = FullReprojection(g, None, cam, {**groups, 3: groups[1]}, np.ones(9))
    with pytest.raises(SplatError, match="positions among 3"):
        next(
            full_resolution_view(
                Photograph(_Source(H, W), 1.0, np.ones(3), np.ones(3)), work, None, reprojection=rep
            )
        )


# ------------------------------------------------------------------------------- writing in strips


@settings(max_examples=8, deadline=None)
@given(h=st.integers(1, 40), w=st.integers(1, 30), rows=st.integers(1, 16), seed=st.integers(0, 99))
def test_png_strip_writer_round_trips_through_pillow(tmp_path_factory, h, w, rows, seed):
    from PIL import Image

    img = np.random.default_rng(seed).integers(0, 256, (h, w, 3), dtype=np.uint8)
    p = tmp_path_factory.mktemp("png") / "x.png"
    with open(p, "wb") as fh:
        png = PNGStripWriter(fh, w, h)
        for a in range(0, h, rows):
            png.write(img[a : a + rows])
        png.close()
    with Image.open(p) as im:
        assert im.mode == "RGB"
        np.testing.assert_array_equal(np.asarray(im), img)


def test_png_strip_writer_refuses_missing_rows(tmp_path):
    with open(tmp_path / "x.png", "wb") as fh:
        png = PNGStripWriter(fh, 4, 3)
        png.write(np.zeros((2, 4, 3), np.uint8))
        with pytest.raises(SplatError, match="2 of 3"):
            png.close()
        with pytest.raises(SplatError, match="uint8"):
            png.write(np.zeros((1, 4, 3)))


def _encode(XYZ):
    return (np.clip(XYZ, 0, 1) * 255 + 0.5).astype(np.uint8)


def test_write_full_round_trip_and_atomic(tmp_path):
    import tifffile
    from PIL import Image

    H, W = 37, 11
    img = np.random.default_rng(0).random((H, W, 3)).astype(np.float32)
    write_full(
        tmp_path / "a.tiff",
        tmp_path / "a.png",
        (img[a : a + 8] for a in range(0, H, 8)),
        (H, W),
        _encode,
        rows=8,
    )
    np.testing.assert_array_equal(tifffile.imread(tmp_path / "a.tiff"), img)
    with Image.open(tmp_path / "a.png") as im:
        np.testing.assert_array_equal(np.asarray(im), _encode(img))

    def broken():
        yield img[:8]
        yield np.full((8, W, 3), np.nan, np.float32)

    with pytest.raises(SplatError, match="NaN"):
        write_full(tmp_path / "b.tiff", tmp_path / "b.png", broken(), (H, W), _encode, rows=8)
    with pytest.raises(SplatError, match="8 of 37"):
        write_full(tmp_path / "b.tiff", tmp_path / "b.png", iter([img[:8]]), (H, W), _encode, rows=8)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["a.png", "a.tiff"]


def test_write_full_memory_does_not_grow_with_height(tmp_path):
    """tracemalloc's peak while writing 64 and 1024 rows of 512 pixels in strips of 32: the same to a
    strip's worth (the whole 8-bit image of 1024 rows alone would be 1.5 MB)."""
    W, rows = 512, 32
    strip = np.random.default_rng(1).random((rows, W, 3)).astype(np.float32)
    peaks = []
    for H in (64, 1024):
        tracemalloc.start()
        write_full(
            tmp_path / f"{H}.tiff",
            tmp_path / f"{H}.png",
            (strip for _ in range(H // rows)),
            (H, W),
            _encode,
            rows=rows,
        )
        peaks.append(tracemalloc.get_traced_memory()[1])
        tracemalloc.stop()
    assert peaks[1] < peaks[0] + 3 * strip.nbytes, peaks
    assert peaks[1] < 1024 * W * 3


def test_strip_camera_shifts_the_principal_point():
    cam = Camera(np.eye(3), np.zeros(3), np.array([10.0, 11.0]), np.array([5.0, 6.0]), 10, 12)
    s = strip_camera(cam, 4, 9)
    assert (s.width, s.height) == (10, 5)
    np.testing.assert_allclose(np.asarray(s.principal), [5.0, 2.0])


@settings(max_examples=20, deadline=None)
@given(h=st.integers(1, 9), w=st.integers(1, 9), c=st.integers(1, 4), seed=st.integers(0, 999))
def test_bilinear_sample_is_map_coordinates(h, w, c, seed):
    """The one-gather bilinear read equals scipy's ``map_coordinates(order=1, mode="nearest")`` per
    channel, inside the image and clamped beyond it."""
    from scipy.ndimage import map_coordinates

    from splat.reproject import _sample

    rng = np.random.default_rng(seed)
    img = rng.random((h, w, c))
    v, u = rng.uniform(-1.5, h + 0.5, 50), rng.uniform(-1.5, w + 0.5, 50)
    want = np.stack([map_coordinates(img[..., j], [v, u], order=1, mode="nearest") for j in range(c)], -1)
    np.testing.assert_allclose(_sample(img, v, u), want, rtol=1e-12, atol=1e-12)


def test_reprojected_strip_reads_only_the_pixels_needed(splat_scene):
    g, cam, groups = splat_scene
    rep = FullReprojection(g, None, cam, groups, np.full(9, 0.01))
    H, W = cam.height, cam.width
    all_v, all_n = reprojected_strip(rep, 0, H)
    need = np.random.default_rng(0).random((H, W)) < 0.5
    v, n = reprojected_strip(rep, 0, H, need=need)
    for j in range(2):
        assert (all_n[j][need] > 0).any()
        np.testing.assert_array_equal(n[j][need], all_n[j][need])
        assert (n[j][~need] == 0).all()
        np.testing.assert_allclose(v[j][need], all_v[j][need], rtol=1e-6, atol=1e-7)
    none_v, none_n = reprojected_strip(rep, 0, 16, need=np.zeros((16, W), bool))
    assert all(x.shape == (16, W) and not x.any() for x in none_n)
    assert all(x.shape == (16, W, 3) and not x.any() for x in none_v)


def test_full_resolution_view_demosaics_each_source_row_once(splat_scene):
    g, cam, groups = splat_scene
    W, H = _SIZE
    counted, cached = {}, {}
    for i, (src,) in groups.items():
        img = src.rows(0, src.camera.height)
        counted[i] = _Counted(src.camera.height, img.shape[1])
        counted[i].img = img
        cached[i] = [src._replace(rows=CachedRows(counted[i], src.camera.height, rows=16, block=8))]
    rep = FullReprojection(g, None, cam, cached, np.full(9, 0.05))
    work = WorkingFusion(
        np.full((H // 2, W // 2, 9), 0.2),
        np.zeros((H // 2, W // 2), int),
        {0: np.full(9, 0.02)},
        slice(0, 3),
        2,
    )
    photo = Photograph(_Source(H, W), 1.0, np.ones(3), np.full(3, 0.01))
    list(
        full_resolution_view(photo, work, lambda s: (_Linear(), np.ones(9)), strip_rows=16, reprojection=rep)
    )
    for c in counted.values():
        assert c.reads.sum() > 0 and c.reads.max() == 1


@settings(max_examples=10, deadline=None)
@given(st.integers(0, 2**32 - 1), st.sampled_from(["RGGB", "BGGR", "GRBG"]))
def test_raw_row_source_reads_the_demosaiced_rows(seed, cfa):
    from splat.capture.raw import RawSource
    from splat.strips import _mosaic_rows, demosaic_rows, raw_row_source

    rng = np.random.default_rng(seed)
    H, W = 40, 30
    data = rng.integers(0, 4096, (H, W)).astype(np.uint16)
    data[rng.random((H, W)) < 0.05] = 4095  # saturated
    data[rng.random((H, W)) < 0.05] = 0  # below black
    black = np.array([[300.0, 310.0], [305.0, 295.0]])  # 0 DN: clipped at −0.05
    src = RawSource(None, data, black, 4095.0, cfa, {"noise_profile": None})
    for a, b in ((0, H), (4, 18), (10, 40)):
        np.testing.assert_array_equal(_mosaic_rows(src, a, b), src.rows(a, b)[0].sum(-1))
    ws = np.array([0.5, 1.0, 0.8])
    cam = _cam((0.0, -2.0, 1.0), (0.0, 0.0, 0.0), size=(W, H), focal=(30.0, 30.0))
    rs = raw_row_source(src, cam, np.ones((H // 2, W // 2)), 2, 2.0, ws, np.full(3, 0.01))
    for a, b in ((0, 12), (7, 33), (30, 40)):
        want = demosaic_rows(src, a, b, method="bilinear")[0] / (2.0 * ws)
        np.testing.assert_allclose(rs.rows(a, b), want, rtol=1e-6, atol=1e-7)


# ------------------------------------------------------------------------------- strips on threads


def test_full_resolution_view_on_threads_equals_one_after_the_other(splat_scene):
    """Strips computed at once on threads (``workers``) give the very same numbers, in order, as one
    strip after the other; each noise pattern is fitted once, and no source row is demosaiced twice
    (two strips needing a block at once: one reads it, the other waits for it)."""
    g, cam, groups = splat_scene
    W, H = _SIZE
    f = 2
    code = np.zeros((H // f, W // f), int)
    code[: H // (2 * f)] = 1  # two working patterns, so that strips meet both
    fused = np.random.default_rng(3).uniform(0.1, 0.3, (H // f, W // f, 9))
    sigma = {0: np.full(9, 0.02), 1: np.full(9, 0.03)}
    photo = Photograph(_Source(H, W), 1.0, np.ones(3), np.full(3, 0.01))
    work = WorkingFusion(fused, code, sigma, slice(0, 3), f)
    outs, fits, reads = {}, {}, {}
    for workers in (1, 3):
        counted, cached = {}, {}
        for i, (src,) in groups.items():
            counted[i] = _Counted(src.camera.height, W)
            counted[i].img = src.rows(0, src.camera.height)
            # a cache that holds every strip in flight (strips on threads run ahead of one another)
            kept = src.camera.height
            cached[i] = [src._replace(rows=CachedRows(counted[i], src.camera.height, rows=kept, block=8))]
        rep = FullReprojection(g, None, cam, cached, np.full(9, 0.05))
        fits[workers] = []

        def fit(s, log=fits[workers]):
            log.append(tuple(np.round(s, 9)))
            return _Linear(), np.ones(9)

        done: list = []
        strips = list(
            full_resolution_view(
                photo,
                work,
                fit,
                strip_rows=8,
                reprojection=rep,
                workers=workers,
                progress=lambda _, r, n, done=done: done.append(r),
            )
        )
        assert [len(s) for s in strips] == [8] * (H // 8) and done == list(range(8, H + 1, 8))
        outs[workers] = np.concatenate(strips)
        reads[workers] = [c.reads for c in counted.values()]
    np.testing.assert_array_equal(outs[3], outs[1])
    assert sorted(fits[3]) == sorted(fits[1]) and len(fits[1]) >= 2  # each pattern fitted once
    for r1, r3 in zip(reads[1], reads[3], strict=True):
        assert r3.max() == 1 and (r3 > 0).sum() == (r1 > 0).sum()


def test_full_resolution_view_on_threads_raises_a_strips_failure_in_order():
    W, H = _SIZE
    work = WorkingFusion(
        np.full((H // 2, W // 2, 9), 0.2), np.zeros((H // 2, W // 2), int), {0: np.ones(9)}, slice(0, 3), 2
    )
    photo = Photograph(_Source(H, W), 1.0, np.ones(3), np.full(3, 0.01))
    calls = []

    def fit(s):
        calls.append(1)
        raise ValueError("no fit")

    gen = full_resolution_view(photo, work, fit, strip_rows=8, workers=2)
    with pytest.raises(ValueError, match="no fit"):
        next(gen)
    with pytest.raises(SplatError, match="workers"):
        next(full_resolution_view(photo, work, fit, workers=0))


@settings(max_examples=10, deadline=None)
@given(
    st.lists(st.tuples(st.integers(0, 119), st.integers(1, 60)), min_size=2, max_size=16),
    st.integers(1, 40),
    st.integers(1, 70),
)
def test_cached_rows_from_threads_give_the_rows_each_block_read_once_at_a_time(requests, block, keep):
    """Requests from four threads at once: every answer is its rows, and no block is read by two
    callers at the same time (a block being read is waited for)."""
    import threading
    from concurrent.futures import ThreadPoolExecutor

    img = _Counted(120)
    inflight, clash = set(), []
    lock = threading.Lock()

    def read(a, b):
        ks = set(range(a // block, (b - 1) // block + 1))
        with lock:
            clash.extend(ks & inflight)
            inflight.update(ks)
        out = img(a, b)
        threading.Event().wait(0.001)  # a slow read, so that callers overlap
        with lock:
            inflight.difference_update(ks)
        return out

    rows = CachedRows(read, 120, rows=keep, block=block)

    def ask(req):
        a, n = req
        b = min(120, a + n)
        return rows(a, b), img.img[a:b]

    with ThreadPoolExecutor(4) as pool:
        for got, want in pool.map(ask, requests):
            np.testing.assert_array_equal(got, want)
    assert not clash


@settings(max_examples=15, deadline=None)
@given(st.integers(0, 2**32 - 1), st.sampled_from(["RGGB", "BGGR", "GRBG", "GBRG"]), st.integers(0, 39))
def test_demosaic_rows_from_samples_equals_the_rows_reader(seed, cfa, r0):
    """The Bayer shortcut (mosaic and validity straight from the samples) gives what demosaicing
    :meth:`RawSource.rows` gives: the same values, and valid where the own site's weight is not 0."""
    from isp.stages import demosaic
    from splat.capture.raw import RawSource
    from splat.strips import HALO, demosaic_rows

    rng = np.random.default_rng(seed)
    H, W = 40, 30
    data = rng.integers(0, 4096, (H, W)).astype(np.uint16)
    data[rng.random((H, W)) < 0.05] = 4095  # saturated
    data[rng.random((H, W)) < 0.05] = 0  # dead below black
    src = RawSource(None, data, np.array([[300.0, 310.0], [0.0, 295.0]]), 4095.0, cfa, {})
    r1 = min(H, r0 + 1 + int(rng.integers(0, 20)))
    lin, valid = demosaic_rows(src, r0, r1)
    a = max(0, r0 - HALO) // 2 * 2
    values, weight = src.rows(a, min(H, r1 + HALO))
    want = demosaic(values.sum(-1), cfa=cfa, method="Malvar 2004")[r0 - a : r1 - a]
    np.testing.assert_array_equal(lin, want)
    np.testing.assert_array_equal(valid, weight[r0 - a : r1 - a].sum(-1) > 0)


@pytest.mark.parametrize("bad", [0, -1, True, 1.5, "2"])
def test_pipeline_config_refuses_bad_workers(bad):
    from splat.capture import PipelineConfig

    with pytest.raises(SplatError, match="workers"):
        PipelineConfig(workers=bad)


def test_default_workers_is_the_usable_cores_capped():
    import os

    from splat._tol import FULL_WORKERS
    from splat.capture import PipelineConfig
    from splat.strips import default_workers

    cores = len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else os.cpu_count()
    assert default_workers() == max(1, min(cores, FULL_WORKERS))
    assert PipelineConfig().workers is None and PipelineConfig(workers=3).workers == 3


class _LazySource(_Source):
    """:class:`_Source`'s image made row by row when asked (nothing held whole)."""

    def __init__(self, H, W):
        self.shape = (H, W)

    def rows(self, a, b):
        jj, ii = np.meshgrid(np.arange(self.shape[1]), np.arange(a, b))
        img = np.stack([0.3 + 0.002 * jj, 0.4 + 0.003 * ii % 0.5, 0.5 - 0.001 * (ii + jj) % 0.4], -1)
        return img.astype(np.float32), np.ones((b - a, self.shape[1], 3), np.float32)


def test_full_resolution_view_on_threads_memory_does_not_grow_with_height():
    """tracemalloc's peak while strips 2… of 256 and of 2048 rows (256 pixels wide, strips of 16) are
    computed on 2 threads for a slow consumer: the same to a few strips' worth (which strips'
    temporaries coincide varies with the threads' timing), far below the image: the strips computed
    ahead are bounded by the threads, not by the image (the working fusion, allocated before the first
    strip, is not counted)."""
    import time

    W, rows = 256, 16
    peaks = []
    for H in (256, 2048):
        work = WorkingFusion(
            np.full((H // 2, W // 2, 9), 0.2),
            np.zeros((H // 2, W // 2), int),
            {0: np.ones(9)},
            slice(0, 3),
            2,
        )
        photo = Photograph(_LazySource(H, W), 1.0, np.ones(3), np.full(3, 0.01))
        strips = full_resolution_view(
            photo, work, lambda s: (_Linear(), np.ones(9)), strip_rows=rows, workers=2
        )
        next(strips)
        tracemalloc.start()
        for _ in strips:
            time.sleep(0.02)  # the writer: slower than the threads
        peaks.append(tracemalloc.get_traced_memory()[1])
        tracemalloc.stop()
    strip = rows * W * 9 * 8  # one strip's responses in float64
    assert peaks[1] < peaks[0] + 6 * strip, peaks
    assert peaks[1] < H * W * 9 * 8 / 10, peaks  # the whole image's responses: 10× more


_CONCURRENT_DEPTHS = """
import numpy as np
from concurrent.futures import ThreadPoolExecutor
from splat import init_gaussians
from splat.camera import look_at
from splat.reproject import depth_map
from splat.strips import strip_camera

rng = np.random.default_rng(0)
means = rng.uniform(-1, 1, (16384, 3)) * [1, 1, 0.3]
g = init_gaussians(means, np.ones((len(means), 2)), scales=0.05, opacity=0.9)
cams = [look_at((2.5 * np.cos(t), 2.5 * np.sin(t), 2.0), (0, 0, 0), width=480, height=320, fov_deg=60)
        for t in np.linspace(0, 5, 4)]


def strip(i):
    r0 = (16 * i) % 288
    return depth_map(g, strip_camera(cams[i % 4], r0, r0 + 32))


with ThreadPoolExecutor(2) as ex:  # as full_resolution_view(workers=2) renders its strips
    n = sum(1 for _ in ex.map(strip, range(60)))
print("rendered", n)
"""


def test_depth_maps_rendered_from_several_threads_at_once_do_not_hang(tmp_path):
    """The strips render their depth maps on ``workers`` threads: 60 strip renders of 16,384 Gaussians
    issued from two threads at once all finish (~5 s); without the renders' lock
    (``splat.outputs._RENDER_LOCK``) they deadlock on XLA's intra-op threads (hung in 2 of 2 runs).
    Run in a child process, so that a deadlock fails the test after its timeout instead of stopping
    the suite."""
    import os
    import subprocess
    import sys

    env = dict(os.environ, JAX_PLATFORMS="cpu")
    script = tmp_path / "depths.py"
    script.write_text(_CONCURRENT_DEPTHS)
    try:
        done = subprocess.run(
            [sys.executable, str(script)], env=env, capture_output=True, text=True, timeout=120
        )
    except subprocess.TimeoutExpired:
        pytest.fail("60 depth maps rendered on 2 threads did not finish in 120 s (deadlock)")
    assert done.returncode == 0 and "rendered 60" in done.stdout, done.stderr[-2000:]
