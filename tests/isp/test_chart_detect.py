"""Automatic ColorChecker detection (``isp profile --chart`` without ``--chart-corners``): synthetic
charts with known patch centres (perspective, rotation, mirror, scale, noise, clutter), charts that
are not ColorCheckers, the real Canon EOS 550D chart against its hand-given corners, and the CLI."""

from __future__ import annotations

import colour
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from isp.profiles.chart import ChartError, chart_reference, fit_chart, read_chart
from isp.profiles.chart_detect import _apply, _fit_grid, _homography, detect_chart, detect_chart_rgb

pytest.importorskip("colour_checker_detection")

BOX = np.array([[-0.4, -0.4], [6.4, -0.4], [6.4, 4.4], [-0.4, 4.4]])  # chart body, patch pitch units
GRID = np.array([(j + 0.5, i + 0.5) for i in range(4) for j in range(6)])  # patch centres, same units


def _pose(rng, pitch, angle, tilt, mirror, size):
    """Homography from chart units to pixels: rotation, scale, mirror and a perspective tilt."""
    H, W = size
    c, s = np.cos(np.radians(angle)), np.sin(np.radians(angle))
    R = pitch * np.array([[c, s], [-s, c]]) @ np.diag([1, -1 if mirror else 1])
    body = (BOX - [3, 2]) @ R.T + [W / 2, H / 2] + rng.uniform(-tilt, tilt, (4, 2)) * 6 * pitch
    return _homography(BOX, body)


def _render(Hm, colours, rng, *, size=(600, 900), noise=0.01, clutter=30, chart=True):
    """An image in the channels of ``colours`` (24, n): a lit background with random flat rectangles,
    the chart (dark body, patches 0.84 pitch wide) drawn through ``Hm`` with 2 × 2 supersampling,
    Gaussian noise."""
    H, W = size
    n = colours.shape[1]
    yy, xx = np.mgrid[0:H, 0:W]
    img = np.ones((H, W, n)) * rng.uniform(0.15, 0.45, n) * (0.6 + 0.4 * xx / W)[..., None]
    for _ in range(clutter):
        x0, y0, w, h = rng.uniform(0, W), rng.uniform(0, H), *rng.uniform(10, 120, 2)
        img[int(y0) : int(y0 + h), int(x0) : int(x0 + w)] = rng.uniform(0.02, 0.9, n)
    if not chart:
        return img + rng.normal(0, noise, img.shape)
    acc = np.zeros_like(img)
    Hi = np.linalg.inv(Hm)
    for dy in (-0.25, 0.25):
        for dx in (-0.25, 0.25):
            u, v = _apply(Hi, np.column_stack([xx.ravel() + dx, yy.ravel() + dy])).T.reshape(2, H, W)
            body = (u > -0.4) & (u < 6.4) & (v > -0.4) & (v < 4.4)
            j, i = np.clip(np.floor(u), 0, 5).astype(int), np.clip(np.floor(v), 0, 3).astype(int)
            patch = body & (np.abs(u - j - 0.5) < 0.42) & (np.abs(v - i - 0.5) < 0.42)
            drawn = np.where(patch[..., None], colours[i * 6 + j], 0.03)
            acc += np.where(body[..., None], drawn, img) / 4
    return acc + rng.normal(0, noise, acc.shape)


def _srgb_chart(illuminant="D65"):
    """The chart's patches in linear sRGB (white 1) under an illuminant, from colour-science."""
    XYZ, _, white = chart_reference("colorchecker", illuminant)
    wxy = colour.XYZ_to_xy(white)
    return colour.XYZ_to_sRGB(XYZ, wxy, chromatic_adaptation_transform="Bradford", apply_cctf_encoding=False)


@settings(max_examples=60, deadline=None)
@given(
    st.floats(20, 80),
    st.floats(-180, 180),
    st.floats(0, 0.12),
    st.booleans(),
    st.integers(6, 24),
    st.integers(0, 2**32 - 1),
)
def test_grid_fit_recovers_the_homography(pitch, angle, tilt, mirror, n, seed):
    """From the exact centres of any ≥ 6 patches (three columns, two rows) and a rough outline (10 %
    of a pitch of error per corner, started at any of its corners) the grid fit assigns every square
    to its patch and finds every centre; with 2 % of a pitch of noise on ≥ 12 squares, within a
    tenth of the pitch."""
    rng = np.random.default_rng(seed)
    Hm = _pose(rng, pitch, angle, tilt, mirror, (600, 900))
    truth = _apply(Hm, GRID)
    seen = rng.choice(24, n, replace=False)
    if len({int(k % 6) for k in seen}) < 3 or len({int(k // 6) for k in seen}) < 2:
        return  # too few columns or rows for a homography: refused by design
    outline = _apply(Hm, np.array([[0, 0], [6, 0], [6, 4], [0, 4]]) + rng.uniform(-0.1, 0.1, (4, 2)))
    outline = np.roll(outline, int(rng.integers(4)), axis=0)
    for noise, tol in ((0.0, 1e-6), (0.02, 0.1)):
        if noise and n < 12:
            continue
        squares = truth[seen] + rng.normal(0, noise * pitch, (n, 2))
        H, used = _fit_grid(outline, squares, 4, 6)
        assert used == n
        # the grid found may be any of the 4×6 grid's symmetries of the truth: compare as sets
        d = np.linalg.norm(_apply(H, GRID)[:, None] - truth[None], axis=2).min(1)
        assert d.max() < tol * pitch


@settings(max_examples=3, deadline=None)
@given(st.floats(30, 65), st.floats(-180, 180), st.floats(0, 0.1), st.booleans(), st.integers(0, 2**32 - 1))
def test_synthetic_charts_are_found(pitch, angle, tilt, mirror, seed):
    """A ColorChecker rendered in perspective at any angle, scale and side, among clutter, with noise:
    every patch centre is found within 2.5 px, patch 1 first, and a mirror image is said to be one."""
    rng = np.random.default_rng(seed)
    Hm = _pose(rng, pitch, angle, tilt, mirror, (600, 900))
    image = _render(Hm, _srgb_chart(), rng)
    d = detect_chart_rgb(image, illuminant="D65")
    err = np.linalg.norm(d.centres - _apply(Hm, GRID), axis=1)
    assert err.max() < 2.5, err
    assert d.mirrored == mirror
    np.testing.assert_allclose(d.corners, d.centres[[0, 5, 23, 18]])
    assert d.delta_E < 2.0  # linear sRGB of the reference: only noise and the patch edges


def test_not_a_colorchecker_is_refused():
    """A 4 × 6 grid of the chart's own colours, its neutral row in place but the 18 colours shuffled
    (the neutral-order check passes; the colour fit must refuse it) is refused with the one-line
    error that asks for the corners (a scene without any chart: the CLI and real-photo tests)."""
    rng = np.random.default_rng(3)
    Hm = _pose(rng, 50, 10, 0.05, False, (600, 900))
    image = _render(Hm, _srgb_chart()[np.r_[rng.permutation(18), 18:24]], rng)
    with pytest.raises(ChartError, match=r"no ColorChecker found \(the best grid's colours are") as e:
        detect_chart_rgb(image, illuminant="D65", path="scene.png")
    assert str(e.value).startswith("scene.png: ") and "--chart-corners" in str(e.value)
    assert "\n" not in str(e.value)


@pytest.mark.parametrize(
    ("image", "message"),
    [
        (np.zeros((40, 60, 3)), "no ColorChecker found"),
        (np.full((40, 60, 3), np.nan), "no ColorChecker found"),
        (np.random.default_rng(0).random((300, 200, 3)), "no ColorChecker found"),
        (np.zeros((40, 60)), r"expected an RGB image \(H, W, 3\)"),
        (np.ones((5, 5, 3)), "at least 8 × 8 pixels"),
    ],
)
def test_hostile_images_give_the_one_line_error(image, message):
    """Flat, NaN, noise, 2-D and tiny images: the one-line error, no traceback and no warning from
    isp (the project's warning filters make one an error)."""
    with pytest.raises(ChartError, match=message) as e:
        detect_chart_rgb(image, path="x.png")
    assert str(e.value).startswith("x.png: ") and "\n" not in str(e.value)


def test_missing_package_is_one_line(monkeypatch, tmp_path, capsys):
    """Without colour-checker-detection: the library and the command say how to install it or to
    give the corners, in one line, before the RAW file is read (here it does not even exist)."""
    import sys

    from isp.cli import main

    monkeypatch.setitem(sys.modules, "colour_checker_detection", None)
    with pytest.raises(ChartError, match=r"pip install 'zonotope\[chart\]', or give --chart-corners"):
        detect_chart_rgb(np.zeros((20, 30, 3)))
    assert main(["profile", "--chart", str(tmp_path / "none.dng"), "-o", str(tmp_path / "a.dcp")]) == 2
    err = capsys.readouterr().err
    assert err.startswith("isp: error: ") and err.count("\n") == 1 and "zonotope[chart]" in err, err


def test_real_550d_chart_is_found_where_the_hand_put_it(raw_550d):
    """The Canon EOS Kiss X4 (550D) DNG, a ColorChecker Passport (its other side, another chart of
    coloured squares, in the same frame): the chart is found where the existing tests' hand-given
    corners put it (within 0.15 of the 108 px pitch: the hand's are a rectangle rounded to whole
    pixels, the chart is turned by 1.3°, 12 px over its width), and the patch means and the fitted
    profile are the same."""
    manual = np.array([(712, 624), (1250, 624), (1250, 930), (712, 930)], dtype=float)
    d = detect_chart(raw_550d, illuminant="A")
    assert np.abs(d.corners - manual).max() < 0.15 * 538 / 5
    assert not d.mirrored and abs(d.angle) < 5
    ours, hand = read_chart(raw_550d, d.corners), read_chart(raw_550d, manual)
    np.testing.assert_allclose(ours.rgb, hand.rgb, rtol=0.03, atol=2e-4)
    f_ours, f_hand = fit_chart(ours, illuminant="A"), fit_chart(hand, illuminant="A")
    assert abs(f_ours.delta_E.mean() - f_hand.delta_E.mean()) < 0.1
    np.testing.assert_allclose(f_ours.forward_matrix, f_hand.forward_matrix, atol=0.02)


def test_real_photo_without_a_chart_is_refused(crw_d30):
    if not crw_d30.is_file():
        pytest.skip(f"{crw_d30} not present")
    with pytest.raises(ChartError, match=r"RAW_CANON_D30_SRGB.CRW: no ColorChecker found"):
        detect_chart(crw_d30)


@pytest.fixture(scope="module")
def scene_dngs(tmp_path_factory):
    """Two simulated DNGs of a cluttered scene, one with a ColorChecker (tilted, turned by 8°), one
    without; and the true (x, y) patch centres in the mosaic."""
    import zonotope
    from isp.simulate import simulate_capture, simulate_dng, spectral_setup

    setup = spectral_setup("Nikon 5100 (NPL)", illuminant="D65", shape=colour.SpectralShape(400, 700, 20))
    R = np.clip(zonotope.resample(zonotope.reflectances("BabelColor Average"), setup.wavelengths).T, 0, 1)
    size = (320, 480)
    Hm = _pose(np.random.default_rng(7), 48, 8, 0.04, False, size)
    out = tmp_path_factory.mktemp("scene")
    paths = []
    for chart in (True, False):
        refl = np.clip(_render(Hm, R, np.random.default_rng(11), size=size, noise=0.0, chart=chart), 0, 1)
        cap = simulate_capture(refl, setup, exposure=0.8, seed=0)
        paths.append(
            simulate_dng(out / f"{'chart' if chart else 'nochart'}.dng", cap, model="Nikon 5100 (NPL)")
        )
    return paths[0], paths[1], _apply(Hm, GRID)


def test_cli_profile_finds_the_chart(scene_dngs, tmp_path, capsys):
    """``isp profile --chart DNG`` without corners: the chart is found (corners printed, within 2 px
    of the truth), and the profile is the one the true corners give; a scene without a chart is
    refused in one line that asks for the corners, and nothing is written."""
    from isp.cli import main
    from isp.profiles.dcp import read_dcp

    chart, nochart, truth = scene_dngs
    assert main(["profile", "--chart", str(chart), "--illuminant", "D65", "-o", str(tmp_path / "a.dcp")]) == 0
    err = capsys.readouterr().err
    line = next(x for x in err.splitlines() if x.startswith("chart found: --chart-corners "))
    corners = np.array([[float(v) for v in p.split(",")] for p in line.split()[3:7]])
    np.testing.assert_allclose(corners, truth[[0, 5, 23, 18]], atol=2.0)  # the pitch is 48 px
    given_corners = [f"{x},{y}" for x, y in truth[[0, 5, 23, 18]]]
    argv = ["profile", "--chart", str(chart), "--chart-corners", *given_corners, "--illuminant", "D65"]
    assert main([*argv, "-o", str(tmp_path / "b.dcp")]) == 0
    assert "chart found" not in capsys.readouterr().err
    a, b = read_dcp(tmp_path / "a.dcp"), read_dcp(tmp_path / "b.dcp")
    np.testing.assert_allclose(a.forward_matrix_1, b.forward_matrix_1, atol=2e-3)
    assert main(["profile", "--chart", str(nochart), "-o", str(tmp_path / "c.dcp")]) == 2
    err = capsys.readouterr().err.splitlines()  # a progress line, then the error
    assert err[-1].startswith("isp: error: ") and sum("error" in x for x in err) == 1, err
    assert "no ColorChecker found" in err[-1] and "--chart-corners" in err[-1]
    assert not (tmp_path / "c.dcp").exists() and not (tmp_path / "c_patches.csv").exists()
