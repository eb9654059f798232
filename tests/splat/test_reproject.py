"""Unit tests of :mod:`splat.reproject` (source photographs carried into a target view through depth).

Independent truths: pinhole cameras looking at a world plane, whose depth maps and world points are
ray–plane intersections in closed form (``X = C + s Rᵀ K⁻¹ (j + ½, i + ½, 1)``, camera depth ``s``), and
whose source "photographs" sample a known texture at each source pixel centre; a texture bilinear in the
source's pixel coordinates (reproduced exactly by bilinear interpolation, so the geometry is checked to
rounding) and a smooth world texture ``f(X, Y)`` (checked to the bilinear interpolation error); an
occluder in the source's depth map whose shadow on the plane is a segment–rectangle test; medians by
sorting; Gaussians laid on a plane whose splat depth must be the plane's closed-form depth.
"""

from __future__ import annotations

import re
import warnings

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from splat import SplatError
from splat.camera import Camera, look_at
from splat.gaussians import init_gaussians
from splat.reproject import (
    DEPTH_RTOL,
    MIN_ALPHA,
    SWEEP_RANGE,
    SWEEP_STEPS,
    consistent_depth,
    depth_map,
    reproject,
    reprojected,
)

# ------------------------------------------------------------------------------------ closed forms


def _rotation(eye, target, up=(0.0, 0.0, 1.0)) -> np.ndarray:
    """World-to-camera rotation (rows: right, down, forward) of a camera at eye looking at target."""
    z = np.subtract(target, eye, dtype=float)
    z /= np.linalg.norm(z)
    x = np.cross(z, up)
    x /= np.linalg.norm(x)
    return np.stack([x, np.cross(z, x), z])


def _cam(eye, target, *, size, focal, principal=None, up=(0.0, 0.0, 1.0)) -> Camera:
    """A float64 camera with its own intrinsics (fx ≠ fy and an off-centre principal point allowed)."""
    w, h = size
    R = _rotation(eye, target, up)
    c = (w / 2, h / 2) if principal is None else principal
    return Camera(R, -R @ np.asarray(eye, float), np.asarray(focal, float), np.asarray(c, float), w, h)


def _plane_hit(cam: Camera, normal=(0.0, 0.0, 1.0), offset=0.0):
    """Each pixel centre's ray on the plane ``normal · X = offset``: camera depth s (H, W) (the ray's
    direction has camera z = 1, so s is the camera-space z of the hit; ≤ 0 or inf: no hit in front) and
    the world point (H, W, 3)."""
    R, t = np.asarray(cam.R, float), np.asarray(cam.t, float)
    centre = -R.T @ t
    jj, ii = np.meshgrid(np.arange(cam.width) + 0.5, np.arange(cam.height) + 0.5)
    pix = np.stack([jj, ii, np.ones_like(jj)], -1)
    ray = np.einsum("ab,hwb->hwa", R.T @ np.linalg.inv(cam.K), pix)  # world directions, camera z = 1
    n = np.asarray(normal, float)
    with np.errstate(divide="ignore"):
        s = (offset - n @ centre) / (ray @ n)
    return s, centre + s[..., None] * ray


def _project(cam: Camera, X):
    """Camera z and array coordinates (column, row) of the pixel-centre grid of world points X (..., 3):
    pixel (i, j)'s centre is at image coordinates (j + ½, i + ½), i.e. array coordinates (j, i)."""
    p = (X @ np.asarray(cam.R, float).T + np.asarray(cam.t, float)) @ cam.K.T
    with np.errstate(divide="ignore", invalid="ignore"):
        return p[..., 2], p[..., 0] / p[..., 2] - 0.5, p[..., 1] / p[..., 2] - 0.5


def _depth_alpha(cam: Camera, **plane):
    """Closed-form depth map and opacity (1 where the ray hits the plane in front, else 0) of a view."""
    s, X = _plane_hit(cam, **plane)
    hit = np.isfinite(s) & (s > 0)
    return np.where(hit, s, 0.0), hit.astype(float), X


def _texture(X) -> np.ndarray:
    """A smooth two-channel world texture f(X, Y) (values 1–3), shape (..., 2)."""
    x, y = X[..., 0], X[..., 1]
    return np.stack(
        [
            1.8 + 0.5 * np.sin(1.3 * x + 0.4) * np.cos(0.9 * y - 0.2) + 0.1 * x,
            2.0 + 0.4 * np.cos(0.8 * x + y),
        ],
        -1,
    )


def _photo(cam: Camera, **plane):
    """The camera's closed-form depth map and its photograph of the textured plane (H, W, 2)."""
    d, a, X = _depth_alpha(cam, **plane)
    assert a.all(), "test setup: every source pixel must see the plane"
    return d, _texture(X)


def _bilinear_texture(col, row) -> np.ndarray:
    """A texture bilinear in a source's array coordinates: bilinear interpolation reproduces it exactly."""
    return np.stack([0.7 + 0.013 * col - 0.021 * row + 4e-4 * col * row, 1.1 - 0.005 * col + 0.017 * row], -1)


def _inside(cam: Camera, col, row, margin):
    """Projects within the source's pixel-centre grid, ``margin`` pixels in from its hull."""
    return (
        (col >= margin) & (col <= cam.width - 1 - margin) & (row >= margin) & (row <= cam.height - 1 - margin)
    )


def _outside_image(cam: Camera, col, row):
    """Projects outside the source image itself (beyond the outer edge of the border pixels)."""
    return (col < -0.5) | (col > cam.width - 0.5) | (row < -0.5) | (row > cam.height - 0.5)


# The views: a target and three sources with different poses, focal lengths, principal points and sizes,
# all looking down at the plane z = 0 from 3–4 m (the horizon is outside every image).
TARGET = _cam((0.4, -3.0, 2.6), (0.1, 0.2, 0.0), size=(48, 36), focal=(42.0, 44.0))
SOURCES = [
    _cam((-1.5, -2.0, 3.2), (0.0, 0.0, 0.0), size=(160, 120), focal=(150.0, 140.0), principal=(83.0, 57.5)),
    _cam((2.0, 1.0, 2.4), (0.3, -0.2, 0.0), size=(120, 100), focal=(230.0, 230.0)),  # narrow: sees part
    _cam((0.5, 2.5, 3.0), (-0.2, 0.1, 0.0), size=(140, 110), focal=(120.0, 125.0), principal=(69.0, 56.0)),
]

#: Relative error allowed for the smooth world texture: bilinear interpolation over the sources' pixels
#: (1.4–11 cm on the plane, |f''| ≤ 0.85 per m²) gives ≤ 2.7e-4 here; a half-pixel misregistration
#: gives 4e-3–1.1e-2 (so the bound also pins the ½-pixel shift).
TEX_RTOL = 1e-3


# ---------------------------------------------------------------------------------- 1. the plane


@pytest.mark.parametrize("k", range(len(SOURCES)))
def test_plane_world_texture_reproduced(k):
    src = SOURCES[k]
    d, a, X = _depth_alpha(TARGET)
    assert a.all()
    sd, photo = _photo(src)
    values, valid = reproject(TARGET, d, a, src, sd, photo)
    assert values.shape == (TARGET.height, TARGET.width, 2) and valid.dtype == bool
    assert np.isfinite(values).all()

    zs, col, row = _project(src, X)
    must = _inside(src, col, row, 1e-6) & (zs > 0)
    assert must.sum() > 200
    assert valid[must].all()  # every point inside the source (which sees the whole plane) is seen
    assert not valid[_outside_image(src, col, row)].any()
    truth = _texture(X)
    err = np.abs(values - truth) / truth
    assert err[valid].max() < TEX_RTOL, err[valid].max()


def test_plane_narrow_source_sees_part():
    """The narrow source sees only part of the target's plane: the rest is invalid (outside its image)."""
    d, a, X = _depth_alpha(TARGET)
    src = SOURCES[1]
    _, col, row = _project(src, X)
    out = _outside_image(src, col, row)
    assert 100 < out.sum() < out.size - 100
    _, valid = reproject(TARGET, d, a, src, *_photo(src))
    assert not valid[out].any()


@pytest.mark.parametrize("k", range(len(SOURCES)))
def test_plane_exact_for_bilinear_texture(k):
    """A texture bilinear in the source's array coordinates is reproduced to rounding: this pins the
    projection, the pixel-centre convention (½-pixel shift) and the (row, column) order exactly."""
    src = SOURCES[k]
    d, a, X = _depth_alpha(TARGET)
    sd, _ = _photo(src)
    jj, ii = np.meshgrid(np.arange(src.width, dtype=float), np.arange(src.height, dtype=float))
    values, valid = reproject(TARGET, d, a, src, sd, _bilinear_texture(jj, ii))
    _, col, row = _project(src, X)
    assert valid.sum() > 200
    np.testing.assert_allclose(values[valid], _bilinear_texture(col, row)[valid], rtol=1e-10, atol=1e-10)


def test_target_alpha_threshold():
    """Target pixels with opacity below MIN_ALPHA have no depth: invalid; at MIN_ALPHA: valid."""
    src = SOURCES[0]
    d, _, X = _depth_alpha(TARGET)
    rng = np.random.default_rng(3)
    a = rng.uniform(0, 1, d.shape)
    a[::5, ::3] = MIN_ALPHA
    a[1::7, 2::4] = np.nextafter(MIN_ALPHA, 0.0)
    _, col, row = _project(src, X)
    inside = _inside(src, col, row, 1e-6)
    values, valid = reproject(TARGET, d, a, src, *_photo(src))
    np.testing.assert_array_equal(valid[inside], (a >= MIN_ALPHA)[inside])
    assert not valid[a < MIN_ALPHA].any()
    assert (a[inside] == MIN_ALPHA).sum() > 20 and valid[inside & (a == MIN_ALPHA)].all()
    assert np.isfinite(values).all()


def test_target_alpha_threshold_given():
    """``min_alpha``: the same rule at another threshold, in :func:`reproject`, :func:`reprojected` and
    :func:`visibility` alike; a source's depth of 0 still does not vouch."""
    from splat.reproject import visibility

    src = SOURCES[0]
    d, _, X = _depth_alpha(TARGET)
    a = np.random.default_rng(4).uniform(0, 1, d.shape)
    _, col, row = _project(src, X)
    inside = _inside(src, col, row, 1e-6)
    depth, image = _photo(src)
    for t in (0.2, 0.3):
        _, valid = reproject(TARGET, d, a, src, depth, image, min_alpha=t)
        np.testing.assert_array_equal(valid[inside], (a >= t)[inside])
        np.testing.assert_array_equal(visibility(TARGET, d, a, src, depth, min_alpha=t), valid)
        _, n = reprojected(TARGET, d, a, [(src, depth, image)], min_alpha=t)
        np.testing.assert_array_equal(n, valid)
    assert (inside & (a >= 0.2) & (a < 0.3)).sum() > 20
    _, valid = reproject(TARGET, d, a, src, np.zeros_like(depth), image, min_alpha=0.2)
    assert not valid.any()


# ------------------------------------------------------------------------------------ 2. occlusion


def _with_occluder(src: Camera, height=0.8, box=((-0.3, 0.7), (-0.4, 0.4))):
    """The source's depth map with a rectangle {z = height, x in box[0], y in box[1]} in front of the
    plane, and which source pixels see the rectangle."""
    sd, photo = _photo(src)
    s, X = _plane_hit(src, offset=height)
    (x0, x1), (y0, y1) = box
    occ = (s > 0) & (X[..., 0] > x0) & (X[..., 0] < x1) & (X[..., 1] > y0) & (X[..., 1] < y1)
    assert (s[occ] < (1 - 5 * DEPTH_RTOL) * sd[occ]).all()  # clearly nearer than the plane behind
    return np.where(occ, s, sd), photo, occ


def _shadowed(src: Camera, X, height=0.8, box=((-0.3, 0.7), (-0.4, 0.4))):
    """Whether the segment from the source's centre to the world point X crosses the rectangle."""
    C = np.asarray(src.centre, float)
    lam = (height - C[2]) / (X[..., 2] - C[2])
    Q = C + lam[..., None] * (X - C)
    (x0, x1), (y0, y1) = box
    return (lam > 0) & (lam < 1) & (Q[..., 0] > x0) & (Q[..., 0] < x1) & (Q[..., 1] > y0) & (Q[..., 1] < y1)


@pytest.mark.parametrize("k", [0, 2])
def test_occluder_in_source_depth(k):
    src = SOURCES[k]
    d, a, X = _depth_alpha(TARGET)
    sd, photo, occ = _with_occluder(src)
    values, valid = reproject(TARGET, d, a, src, sd, photo)
    _, col, row = _project(src, X)
    inside = _inside(src, col, row, 1e-6)
    shadow = _shadowed(src, X)
    # away from the occluder's silhouette: all four source pixels around the projected point agree
    c0 = np.clip(np.floor(col), 0, src.width - 2).astype(int)
    r0 = np.clip(np.floor(row), 0, src.height - 2).astype(int)
    around = np.stack([occ[r0, c0], occ[r0, c0 + 1], occ[r0 + 1, c0], occ[r0 + 1, c0 + 1]])
    hidden = inside & shadow & around.all(0)
    visible = inside & ~shadow & ~around.any(0)
    assert hidden.sum() > 20 and visible.sum() > 200
    assert not valid[hidden].any()
    assert valid[visible].all()
    truth = _texture(X)
    assert (np.abs(values - truth) / truth)[valid].max() < TEX_RTOL


@pytest.mark.parametrize(
    "factor", [1 - 1.1 * DEPTH_RTOL, 1 - 0.9 * DEPTH_RTOL, 1 + 0.9 * DEPTH_RTOL, 1 + 1.1 * DEPTH_RTOL]
)
@pytest.mark.parametrize("k", [0, 2])
def test_depth_tolerance_is_relative(k, factor):
    """The source's depth map scaled by a factor: the point is seen while |factor − 1| ≤ DEPTH_RTOL (a
    tolerance relative to the point's depth in the source, either side), not beyond."""
    src = SOURCES[k]
    d, a, X = _depth_alpha(TARGET)
    sd, photo = _photo(src)
    _, valid = reproject(TARGET, d, a, src, sd * factor, photo)
    _, col, row = _project(src, X)
    inside = _inside(src, col, row, 1e-6)
    assert inside.sum() > 200
    assert (valid[inside] == (abs(factor - 1) <= DEPTH_RTOL)).all()


def test_points_behind_source_invalid():
    """A source looking straight up, away from the plane, sees every plane point mirrored through its
    centre (camera z = −1.5, projecting inside its image) and is handed a depth map that agrees with that
    z: nothing is valid. The same source turned to look down (depth +1.5) sees the same pixels."""
    d, a, X = _depth_alpha(TARGET)
    eye = np.array([0.2, 0.1, 1.5])
    kw = dict(size=(60, 40), focal=(30.0, 30.0), up=(0.0, 1.0, 0.0))
    up_cam = _cam(eye, eye + np.array([0.0, 0.0, 1.0]), **kw)
    down_cam = _cam(eye, eye - np.array([0.0, 0.0, 1.0]), **kw)
    img = np.ones((40, 60, 1))
    zs, col, row = _project(up_cam, X)
    np.testing.assert_allclose(zs, -1.5, rtol=1e-12)
    mirrored = _inside(up_cam, col, row, 1e-6)
    assert mirrored.sum() > 100
    _, valid = reproject(TARGET, d, a, up_cam, np.full((40, 60), -1.5), img)
    assert not valid.any()
    _, valid_down = reproject(TARGET, d, a, down_cam, np.full((40, 60), 1.5), img)
    assert valid_down[mirrored].all()


# ---------------------------------------------------------------------------------- 3. reprojected


def _sorted_median(x):
    s = sorted(x)
    n = len(s)
    return s[n // 2] if n % 2 else 0.5 * (s[n // 2 - 1] + s[n // 2])


def test_reprojected_median_rejects_one_outlier_and_counts():
    d, a, X = _depth_alpha(TARGET)
    a = a.copy()
    a[:4] = 0.03  # the top rows have no depth: nobody sees them
    sources, bad_any = [], np.zeros(d.shape, bool)
    for k, src in enumerate(SOURCES):
        sd, photo = _photo(src)
        if k == 1:  # outliers on the left half of this source's photograph
            photo = photo.copy()
            photo[:, : src.width // 2] += 10.0
            _, col, _ = _project(src, X)
            bad_any = col < src.width // 2 - 1
        sources.append((src, sd, photo))
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        values, count = reprojected(TARGET, d, a, iter(sources))
    singles = [reproject(TARGET, d, a, *s) for s in sources]
    np.testing.assert_array_equal(count, sum(ok.astype(int) for _, ok in singles))
    assert np.issubdtype(count.dtype, np.integer)
    assert set(np.unique(count)) == {0, 1, 2, 3}

    # count against the closed form, away from the sources' rims
    expected = np.zeros(d.shape, int)
    for src in SOURCES:
        zs, col, row = _project(src, X)
        expected += _inside(src, col, row, 1e-6) & (zs > 0)
    firm = a >= MIN_ALPHA
    for src in SOURCES:
        _, col, row = _project(src, X)
        firm &= _inside(src, col, row, 1e-6) | _outside_image(src, col, row)
    np.testing.assert_array_equal(count[firm], expected[firm])

    # the median of three rejects the one outlier; with fewer, it is the sorted median of what is seen
    truth = _texture(X)
    three = (count == 3) & bad_any
    assert three.sum() > 50
    assert (np.abs(values - truth) / truth)[three].max() < TEX_RTOL
    for i, j in zip(*np.nonzero(count > 0), strict=True):
        seen = [v[i, j] for v, ok in singles if ok[i, j]]
        for c in range(2):
            assert values[i, j, c] == pytest.approx(_sorted_median([s[c] for s in seen]), rel=1e-12)
    assert (values[count == 0] == 0).all() and (count[:4] == 0).all()
    assert np.isfinite(values).all()


def test_reprojected_nobody_sees_anything():
    """No target pixel has a depth: count 0 and values 0 everywhere, without a warning."""
    d, a, _ = _depth_alpha(TARGET)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        values, count = reprojected(TARGET, d, np.zeros_like(a), [(s, *_photo(s)) for s in SOURCES[:2]])
    assert values.shape == (*d.shape, 2) and (values == 0).all() and (count == 0).all()


def test_reprojected_errors():
    d, a, _ = _depth_alpha(TARGET)
    with pytest.raises(SplatError, match="no source"):
        reprojected(TARGET, d, a, [])
    with pytest.raises(SplatError, match="no source"):
        reprojected(TARGET, d, a, iter(()))
    src = SOURCES[0]
    sd, photo = _photo(src)
    with pytest.raises(SplatError, match=re.escape("(120, 160)") + ".*" + re.escape("(119, 160)")):
        reprojected(TARGET, d, a, [(src, sd[:-1], photo)])
    with pytest.raises(SplatError, match=re.escape("(120, 159)") + ".*" + re.escape("(120, 160)")):
        reproject(TARGET, d, a, src, sd, photo[:, 1:])
    with pytest.raises(SplatError, match="target depth"):
        reproject(TARGET, d[1:], a, src, sd, photo)


def test_reprojected_mixed_channel_counts_is_a_splat_error():
    d, a, _ = _depth_alpha(TARGET)
    (s0, s1) = SOURCES[:2]
    d0, p0 = _photo(s0)
    d1, p1 = _photo(s1)
    with pytest.raises(SplatError, match="channel"):
        reprojected(TARGET, d, a, [(s0, d0, p0), (s1, d1, p1[..., :1])])


def test_reproject_target_alpha_shape_is_a_splat_error():
    d, _, _ = _depth_alpha(TARGET)
    src = SOURCES[0]
    with pytest.raises(SplatError, match="alpha"):
        reproject(TARGET, d, np.ones((TARGET.height, TARGET.width + 1)), src, *_photo(src))


def test_reproject_two_dimensional_source_image_is_a_splat_error():
    d, a, _ = _depth_alpha(TARGET)
    src = SOURCES[0]
    sd, photo = _photo(src)
    with pytest.raises(SplatError, match="source image"):
        reproject(TARGET, d, a, src, sd, photo[..., 0])


# ------------------------------------------------------------------------- hypothesis: random poses


def _random_cam(el, az, dist, aim, f, size):
    eye = np.array([np.cos(el) * np.cos(az), np.cos(el) * np.sin(az), np.sin(el)]) * dist
    return _cam(eye, (aim[0], aim[1], 0.0), size=size, focal=(f[0] * size[0], f[1] * size[0]))


_pose = st.tuples(
    st.floats(np.radians(40), np.radians(80)),  # elevation above the plane
    st.floats(-np.pi, np.pi),  # azimuth
    st.floats(2.0, 5.0),  # distance
    st.tuples(st.floats(-0.5, 0.5), st.floats(-0.5, 0.5)),  # aim point on the plane
    st.tuples(st.floats(0.8, 1.6), st.floats(0.8, 1.6)),  # focal lengths / width
    st.sampled_from([(40, 30), (64, 48), (50, 50)]),
)


@settings(max_examples=25, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(_pose, _pose)
def test_random_poses_reproduce_texture(tp, sp):
    """Random target and source views of the plane: wherever valid the bilinear-in-source texture comes
    back to rounding; every point well inside the source is valid; none outside its image is."""
    tgt, src = _random_cam(*tp), _random_cam(*sp)
    d, a, X = _depth_alpha(tgt)
    sd, sa, _ = _depth_alpha(src)
    assert sa.all()  # elevation ≥ 40° and fov < 65°: the horizon is outside the image
    jj, ii = np.meshgrid(np.arange(src.width, dtype=float), np.arange(src.height, dtype=float))
    values, valid = reproject(tgt, d, a, src, sd, _bilinear_texture(jj, ii))
    zs, col, row = _project(src, X)
    assert valid.any()  # the views are aimed near the origin: they always overlap
    np.testing.assert_allclose(values[valid], _bilinear_texture(col, row)[valid], rtol=1e-9, atol=1e-9)
    assert valid[(a > 0) & (zs > 0) & _inside(src, col, row, 1e-6)].all()
    assert not valid[(a == 0) | _outside_image(src, col, row)].any()


# ------------------------------------------------------------------------------ 4. depth_map (JAX)

_W, _H = 32, 24
_SIGMA = 0.06  # the Gaussians' standard deviation (world units)
_DM_CAM = look_at((0.6, -2.2, 2.4), (0.0, 0.0, 0.0), width=_W, height=_H, fov_deg=60)


def _grid(half, step):
    xs = np.arange(-half, half + 1e-9, step)
    return [a.ravel() for a in np.meshgrid(xs, xs)]


def _gaussians(means, colours=None):
    col = np.ones((len(means), 2)) if colours is None else colours(means)
    return init_gaussians(means, col, scales=_SIGMA, opacity=0.99)


def _facing_plane(cam, z0, *, half=0.8, step=0.1):
    """Gaussian centres on the plane at camera depth z0 facing the camera (camera z = z0 for all), over
    [−half, half]² in its x/y axes; world coordinates through the camera's (generic) pose."""
    R, t = np.asarray(cam.R, float), np.asarray(cam.t, float)
    a, b = _grid(half, step)
    return (np.stack([a, b, np.full(a.size, z0)], 1) - t) @ R  # Rᵀ (x_cam − t)


def _floor(z0=0.0, *, half=1.0, step=0.1):
    """Gaussian centres on a grid over [−half, half]² of the world plane z = z0 (seen obliquely)."""
    a, b = _grid(half, step)
    return np.stack([a, b, np.full(a.size, z0)], 1)


@pytest.fixture(scope="module")
def facing_depths():
    """depth_map of Gaussians on planes facing the (rotated) camera at depths 2.5 and 3.4 m (the same
    number of Gaussians and image size: one compilation)."""
    return {z0: depth_map(_gaussians(_facing_plane(_DM_CAM, z0)), _DM_CAM) for z0 in (2.5, 3.4)}


@pytest.mark.parametrize("z0", [2.5, 3.4])
def test_depth_map_of_facing_plane(facing_depths, z0):
    """Every centre has camera z = z0, so the composited depth is z0 wherever the splat is opaque
    (float32 rounding only), whatever the camera's rotation; far from the Gaussians alpha is 0."""
    depth, alpha = facing_depths[z0]
    assert depth.shape == alpha.shape == (_H, _W)
    s, X = _plane_hit(_DM_CAM, normal=np.asarray(_DM_CAM.R, float)[2], offset=z0 - float(_DM_CAM.t[2]))
    np.testing.assert_allclose(s, z0, rtol=1e-6)  # the facing plane in closed form: depth z0 everywhere
    xc = (X - np.asarray(_DM_CAM.centre, float)) @ np.asarray(_DM_CAM.R, float).T  # camera coordinates
    ax, ay = np.abs(xc[..., 0]), np.abs(xc[..., 1])
    opaque = alpha >= MIN_ALPHA
    assert opaque[(ax < 0.7) & (ay < 0.7)].all() and opaque.sum() > 40
    np.testing.assert_allclose(depth[opaque], z0, rtol=1e-4)
    far = (ax > 0.8 + 5 * _SIGMA) | (ay > 0.8 + 5 * _SIGMA)
    assert far.sum() > 50 and alpha[far].max() < 1e-6


def test_depth_map_moves_with_the_plane(facing_depths):
    (d0, a0), (d1, a1) = facing_depths[2.5], facing_depths[3.4]
    both = (a0 >= MIN_ALPHA) & (a1 >= MIN_ALPHA)
    assert both.sum() > 40
    np.testing.assert_allclose((d1 - d0)[both], 0.9, rtol=1e-3)


@pytest.mark.parametrize("z0", [0.0, -0.6])
def test_depth_map_of_oblique_floor(z0):
    """Gaussians on the floor z = z0 seen at ~45°: the depth of an opaque pixel is a convex combination
    of camera depths of centres inside the 3σ cut-off around its ray's hit point, so it lies within
    s ± 4σ |∇s| of the closed-form depth s (the front-to-back compositing pulls it towards the near side:
    ~3 % at this 32 × 24 size); alpha is 0 in pixels far from every projected centre."""
    means = _floor(z0)
    depth, alpha = depth_map(_gaussians(means), _DM_CAM)
    s, X = _plane_hit(_DM_CAM, offset=z0)
    grad = np.hypot(*np.asarray(_DM_CAM.R, float)[2, :2])  # |∇ camera z| along the floor
    on = (s > 0) & (np.abs(X[..., 0]) < 0.9) & (np.abs(X[..., 1]) < 0.9)
    # far: ≥ 5 px from every projected centre (a Gaussian's 3σ cut-off reaches < 3 px here)
    _, col, row = _project(_DM_CAM, means)
    jj, ii = np.meshgrid(np.arange(_W), np.arange(_H))
    gap = np.hypot(jj[..., None] - col, ii[..., None] - row).min(-1)
    far = gap > 5
    opaque = alpha >= MIN_ALPHA
    assert opaque[on].sum() > 100 and far.sum() > 100
    assert (np.abs(depth - s)[opaque & on] <= 4 * _SIGMA * grad).all()
    assert (np.abs(depth - s) / s)[opaque & on].max() < 0.06
    assert alpha[far].max() < 1e-6


def test_depth_map_reproject_round_trip_with_renders():
    """A Gaussian plane with a smooth 2-channel colour (the depth's channel count: no new compilation),
    rendered in two views: view A's render reprojected into view B through both depth maps agrees with
    B's own render where valid and away from the plane's edges."""
    from splat.outputs import render_views

    def colours(m):
        return np.stack([0.5 + 0.3 * np.sin(1.2 * m[:, 0] + 0.3), 0.6 + 0.25 * m[:, 1]], 1)

    g = _gaussians(_floor(), colours)
    cam_a = _DM_CAM
    cam_b = look_at((-1.2, -2.0, 2.2), (0.1, 0.1, 0.0), width=_W, height=_H, fov_deg=55)
    img_a, img_b = render_views(g, [cam_a, cam_b]).astype(np.float64)
    da, aa = depth_map(g, cam_a)
    db, ab = depth_map(g, cam_b)
    values, valid = reproject(cam_b, db, ab, cam_a, da, img_a / np.maximum(aa, 1e-6)[..., None])
    _, X = _plane_hit(cam_b)
    interior = (np.abs(X[..., 0]) < 0.8) & (np.abs(X[..., 1]) < 0.8)
    assert (valid & interior).sum() > 80
    truth = img_b / np.maximum(ab, 1e-6)[..., None]
    err = np.abs(values - truth)[valid & interior]
    assert err.max() < 0.03, err.max()
    assert np.ptp(truth[valid & interior], 0).min() > 0.2  # while the colours vary 7× more than that


# ------------------------------------------------------------- reprojected: with the sources' noise


def test_reprojected_with_variances_is_a_trimmed_inverse_variance_mean():
    """Three sources of constant colours 0.5, 0.51 and 10.5 (variances 1e-4, 4e-4, 1e-4; the last a
    gross outlier): where all three see a pixel the median is 0.51 and the band 3σ + 1 % of it keeps
    the first two, whose inverse-variance mean is 0.5 + 0.01 · 2500 / 12500 = 0.502 exactly; where only
    the first and the outlier see, neither is within its band of their median 5.5, which is returned;
    where one source sees, its value; without variances, the median (as before)."""
    from splat.reproject import TRIM_RTOL, TRIM_SIGMA

    assert (TRIM_SIGMA, TRIM_RTOL) == (3.0, 0.01)  # the closed forms below assume these
    d, a, _ = _depth_alpha(TARGET)
    level, var = (0.5, 0.51, 10.5), (1e-4, 4e-4, 1e-4)
    sources, oks = [], []
    for src, c, v in zip(SOURCES, level, var):
        sd, photo = _photo(src)
        img = np.full(photo.shape, c)
        sources.append((src, sd, img, np.full(photo.shape, v)))
        oks.append(reproject(TARGET, d, a, src, sd, img)[1])
    values, count = reprojected(TARGET, d, a, sources)
    s0, s1, s2 = oks
    want = np.zeros(d.shape)
    want[s0 & ~s1 & ~s2], want[s1 & ~s0 & ~s2], want[s2 & ~s0 & ~s1] = 0.5, 0.51, 10.5
    want[s0 & s1] = 0.502
    want[s0 & s2 & ~s1] = 5.5
    want[s1 & s2 & ~s0] = 5.505
    for sel in (s0 & s1 & s2, s0 & s2 & ~s1, s0 & ~s1 & ~s2, s2 & ~s0 & ~s1):
        assert sel.sum() > 100  # these cases occur (the middle source sees only where both others do)
    np.testing.assert_allclose(values[..., 0], want, rtol=0, atol=1e-12)
    np.testing.assert_array_equal(count, s0.astype(int) + s1 + s2)
    plain, _ = reprojected(TARGET, d, a, [s[:3] for s in sources])
    np.testing.assert_allclose(plain[s0 & s1 & s2, 0], 0.51, rtol=0, atol=1e-12)


@settings(max_examples=60, deadline=None)
@given(
    n=st.integers(1, 4),
    shape=st.tuples(st.integers(1, 17), st.integers(1, 9), st.integers(1, 3)),
    rows=st.integers(1, 20),
    f32=st.booleans(),
    seed=st.integers(0, 2**31 - 1),
)
def test_combine_matches_a_per_pixel_reference(n, shape, rows, f32, seed):
    """The strip-wise combination against a plain per-pixel loop (median of the sources that see the
    pixel; with variances, the inverse-variance mean of those within 3σ + 1 % of it, else the median;
    0 where none sees), and the same numbers whatever the rows worked through at a time."""
    from splat.reproject import TRIM_RTOL, TRIM_SIGMA, _combine

    rng = np.random.default_rng(seed)
    H, W, c = shape
    dt = np.float32 if f32 else np.float64
    ok = rng.random((n, H, W)) < 0.7
    base = rng.random((H, W, c))
    outlier = rng.random((n, H, W, 1)) < 0.2  # some sources far off, some within their noise
    vals = [
        np.where(ok[s][..., None], base + rng.normal(0, 0.01, (H, W, c)) + 0.3 * outlier[s], 0).astype(dt)
        for s in range(n)
    ]
    var = [np.where(ok[s][..., None], rng.uniform(1e-6, 1e-4, (H, W, c)), 0.5).astype(dt) for s in range(n)]
    for v in (None, var):
        got, count = _combine(vals, ok, v, rows=rows)
        np.testing.assert_array_equal(count, ok.sum(0))
        np.testing.assert_array_equal(got, _combine(vals, ok, v, rows=H)[0])
        want = np.zeros((H, W, c))
        for i, j, k in np.ndindex(H, W, c):
            x = np.array([vals[s][i, j, k] for s in range(n) if ok[s, i, j]], float)
            if not x.size:
                continue
            med = np.median(x)
            want[i, j, k] = med
            if v is not None:
                s2 = np.array([v[s][i, j, k] for s in range(n) if ok[s, i, j]], float)
                kept = np.abs(x - med) <= TRIM_SIGMA * np.sqrt(s2) + TRIM_RTOL * abs(med)
                if kept.any():
                    want[i, j, k] = np.sum(x[kept] / s2[kept]) / np.sum(1 / s2[kept])
        np.testing.assert_allclose(got, want, rtol=2e-6 if f32 else 1e-12, atol=1e-6 if f32 else 1e-12)


def test_reprojected_variance_errors():
    d, a, _ = _depth_alpha(TARGET)
    src = SOURCES[0]
    sd, photo = _photo(src)
    good = np.full(photo.shape, 1e-4)
    for bad in (good[:, 1:], np.full(photo.shape, -1e-4), np.full(photo.shape, np.nan)):
        with pytest.raises(SplatError, match="variance"):
            reprojected(TARGET, d, a, [(src, sd, photo, bad)])
    with pytest.raises(SplatError, match="every source or for none"):
        reprojected(TARGET, d, a, [(src, sd, photo, good), (src, sd, photo)])
    with pytest.raises(SplatError, match=r"camera, depth, image\[, variance\]"):
        reprojected(TARGET, d, a, [(src, sd, photo, good, good)])


# ------------------------------------------------------ consistent_depth: the photographs' plane sweep


def _fine_texture(X) -> np.ndarray:
    """A world texture with ~0.5 m detail (≈ 20 source pixels a period), values 0.5–2.5: a depth off by
    one sweep step (1 %, ≈ 3.5 cm here) misregisters the sources by ~0.3 rad of its phase."""
    x, y = X[..., 0], X[..., 1]
    return np.stack([1.5 + np.sin(12 * x) * np.cos(10 * y), 1.5 + np.cos(11 * x + 7 * y)], -1)


def _fine_sources(texture=_fine_texture):
    """The three sources' closed-form depth maps and photographs of the finely textured plane."""
    out = []
    for src in SOURCES:
        sd, a, Xs = _depth_alpha(src)
        assert a.all()
        out.append((src, sd, texture(Xs)))
    return out


#: The sweep's scales: exp(k · STEP), k = −6 … 6.
STEP = np.log1p(SWEEP_RANGE) / (SWEEP_STEPS // 2)


def _pairs_see(d, a, sources):
    """Target pixels that at least two sources see through the depth d."""
    return sum(reproject(TARGET, d, a, *s)[1].astype(int) for s in sources) >= 2


@settings(max_examples=8, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(st.integers(-2, 2), st.floats(-0.4, 0.4))
def test_consistent_depth_undoes_a_depth_error(k, frac):
    """The target's depth off by a factor exp((k + frac) · STEP) (≤ 2.4 %, so that the sources still see
    the wrongly lifted points: DEPTH_RTOL is 3 %): the sweep returns the plane's closed-form depth to
    within half a step wherever two sources see the pixel (interior of the 5 × 5 window), and the
    reprojected texture error is then no larger, and halved when the depth was off by ≥ 1.5 steps."""
    assert abs(np.exp(2.4 * STEP) - 1) < DEPTH_RTOL
    d, a, X = _depth_alpha(TARGET)
    sources = _fine_sources()
    wrong = d * np.exp((k + frac) * STEP)
    got, scale = consistent_depth(TARGET, wrong, a, [sources])
    inner = _pairs_see(d, a, sources) & _pairs_see(wrong, a, sources)
    inner[:2], inner[-2:], inner[:, :2], inner[:, -2:] = False, False, False, False
    assert inner.sum() > 500
    ratio = got[inner] / d[inner]
    assert np.mean(np.abs(np.log(ratio)) <= 0.5 * STEP + 1e-12) > 0.97, np.percentile(
        np.abs(np.log(ratio)), 95
    )
    np.testing.assert_allclose(got, wrong * scale, rtol=1e-15)
    # the scales are the sweep's grid values
    np.testing.assert_allclose(np.round(np.log(scale) / STEP), np.log(scale) / STEP, atol=1e-9)
    before, _ = reprojected(TARGET, wrong, a, sources)
    after, _ = reprojected(TARGET, got, a, sources)
    truth = _fine_texture(X)
    err_before = np.abs(before - truth)[inner].mean()
    err_after = np.abs(after - truth)[inner].mean()
    if abs(k + frac) >= 1.5:  # then the half step left is at most a third of the error given
        assert err_after < 0.5 * err_before, (err_after, err_before)
    else:  # never worse than where it started
        assert err_after <= err_before * (1 + 1e-9) + 1e-12, (err_after, err_before)


def test_consistent_depth_keeps_an_exact_depth_and_textureless_planes():
    """With the plane's exact depth every pixel keeps it (scale 1: the sources agree best there and the
    prior favours it); with a constant texture the sources agree at every scale, and the prior keeps the
    given depth bit for bit, even a wrong one (a textureless patch cannot tell, and needs no better)."""
    d, a, _ = _depth_alpha(TARGET)
    got, scale = consistent_depth(TARGET, d, a, [_fine_sources()])
    assert np.mean(scale == 1.0) > 0.99
    flat = _fine_sources(lambda X: np.full((*X.shape[:-1], 2), 0.7))
    wrong = d * 1.02  # within DEPTH_RTOL: the sources see the points it lifts, so it is judged
    got, scale = consistent_depth(TARGET, wrong, a, [flat])
    assert _pairs_see(wrong, a, flat).mean() > 0.5
    np.testing.assert_array_equal(scale, 1.0)
    np.testing.assert_array_equal(got, wrong)


def test_consistent_depth_needs_two_photographs_of_a_group():
    """A pixel that no two photographs of one group see at its given depth keeps it, even where a
    different scale would bring a second one into view (one source per group is no comparison: two
    groups of one source each are an error, as is nothing to compare at all)."""
    d, a, _ = _depth_alpha(TARGET)
    sources = _fine_sources()
    pair = sources[:2]
    wrong = d * 1.02
    _, scale = consistent_depth(TARGET, wrong, a, [pair, sources[2:]])
    nobody = ~_pairs_see(wrong, a, pair)  # at the given depth: not judged, so not moved
    assert nobody.sum() > 50 and (scale[nobody] == 1.0).all()
    assert (scale[~nobody] != 1.0).mean() > 0.9  # the others are
    for groups in ([sources[:1], sources[1:2]], [], [[]]):
        with pytest.raises(SplatError, match="two photographs"):
            consistent_depth(TARGET, d, a, groups)
    with pytest.raises(SplatError, match="list of groups"):
        consistent_depth(TARGET, d, a, sources)  # the sources themselves, not grouped
    for bad in (
        {"window": 4},
        {"window": 0},
        {"prior": -1.0},
        {"steps": 0},
        {"steps": 12},
        {"span": 1.5},
        {"span": 0.0},
    ):
        with pytest.raises(SplatError, match="consistent_depth"):
            consistent_depth(TARGET, d, a, [sources], **bad)
