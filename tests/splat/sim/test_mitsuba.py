"""The Mitsuba 3 capture: the spectral film against colour-science integrals, and the files on disk.

Independent truth: a flat patch's camera channels under a uniform sky are ``∫ S_c R E dλ`` up to one
geometry factor, so the ratio of two patches' channels is computed from colour-science's ColorChecker
and D65 tables and the camera's measured SSF table (numpy sums on their own 5 nm grid, no library code).
"""

from __future__ import annotations

import shutil
import tomllib
from pathlib import Path

import colour
import numpy as np
import pytest
import tifffile

import zonotope
from splat._errors import SplatError
from splat._tol import MITSUBA_PATCH_RTOL, MITSUBA_TRUTH_Z_MEDIAN
from splat.capture import read_capture, read_linear

mi = pytest.importorskip("mitsuba")

from splat.sim import mitsuba as sm  # noqa: E402
from splat.sim.capture import SimCaptureConfig, build_scene  # noqa: E402


@pytest.fixture(scope="module")
def capture(tmp_path_factory) -> Path:
    """32 × 24-ish images, 2 training + 1 held-out view per camera, 4 samples per pixel; the truth
    rendered on its own at 8."""
    return sm.write_mitsuba_capture(
        tmp_path_factory.mktemp("mi") / "capture", size=0.25, views=2, holdout=1, spp=4, seed=1, truth_spp=8
    )


def _two_patches(curves: np.ndarray, grid: np.ndarray, light: np.ndarray, rows: list) -> np.ndarray:
    """Mean film channels (2, C) of two large flat patches under a uniform sky, seen from straight above."""
    m = sm._mitsuba()
    T = m.ScalarTransform4f
    scene = {
        "type": "scene",
        "integrator": {"type": "path", "max_depth": 4},
        "sensor": {
            "type": "orthographic",
            "to_world": T().look_at(origin=[0, 0, 5], target=[0, 0, 0], up=[0, 1, 0]).scale([2, 2, 1]),
            "sampler": {"type": "independent", "sample_count": 16},
            "film": sm._film(grid, curves, 32, 16),
        },
        "sky": {"type": "constant", "radiance": sm._spectrum(grid, light)},
    }
    for k, (x, row) in enumerate(zip((-1.0, 1.0), rows)):
        scene[f"p{k}"] = {
            "type": "rectangle",
            "to_world": T().translate([x, 0, 0]).scale([1.0, 2.0, 1.0]),
            "bsdf": {"type": "diffuse", "reflectance": sm._spectrum(grid, row)},
        }
    img = np.asarray(m.render(m.load_dict(scene)), float)
    # seen from above with +y up, the patch at x = -1 fills image columns 0..15
    return np.stack([img[2:-2, 2:14].mean((0, 1)), img[2:-2, 18:30].mean((0, 1))])


def test_film_channels_match_the_spectral_integrals():
    """The film curves the capture uses (G_c / (E Δλ)) give patch ratios ∫S R₁ E / ∫S R₂ E."""
    scene = build_scene(SimCaptureConfig.ci())
    grid = scene.wavelengths
    d65 = colour.SDS_ILLUMINANTS["D65"]
    E = np.interp(grid, d65.wavelengths, d65.values)
    E = E / E.max()
    step = grid[1] - grid[0]
    curves = np.asarray(scene.camera_generators[0]) / (E[:, None] * step)
    cc = colour.SDS_COLOURCHECKERS["ColorChecker N Ohta"]
    names = ["orange", "blue"]
    refl = [np.interp(grid, cc[n].wavelengths, cc[n].values) for n in names]
    got = _two_patches(curves, grid, E, refl)
    # independent: the camera's SSF table, colour-science's D65 and reflectances on the table's own grid
    ssf = zonotope.camera("Nikon 5100 (NPL)")
    w = np.asarray(ssf.wavelengths, float)
    w = w[(w >= grid[0]) & (w <= grid[-1])]
    S = np.stack([np.interp(w, ssf.wavelengths, ssf.values[:, j]) for j in range(3)], 1)
    Ew = np.interp(w, d65.wavelengths, d65.values)
    ref = [np.interp(w, cc[n].wavelengths, cc[n].values) @ (S * Ew[:, None]) for n in names]
    want = ref[0] / ref[1]
    ratio = got[0] / got[1]
    np.testing.assert_allclose(ratio, want, rtol=MITSUBA_PATCH_RTOL)


def test_capture_folder_reads_back(capture):
    spec = read_capture(capture)
    assert [c.folder for c in spec.cameras] == ["nikon", "sigma", "canon"]
    truth = tomllib.loads((capture / "truth" / "truth.toml").read_text())
    assert truth["generator"] == "splat.sim.mitsuba" and truth["spp"] == 4
    cfas = {c["folder"]: c.get("cfa") for c in truth["camera"]}
    for folder, cfa in cfas.items():
        files = sorted((capture / folder).glob("*.dng"))
        assert len(files) == 3
        values, weight, info = read_linear(files[0])
        assert info["full_colour"] == (cfa is None)
        if cfa is not None:
            assert info["cfa"] == cfa
            assert np.all(weight.sum(-1) == 1)  # one colour per pixel: a mosaic
        assert np.isfinite(values).all() and 0 < np.nanmean(values) < 1
    # the white card box of capture.toml reads neutral-ish and bright in its raw file
    white = tomllib.loads((capture / "capture.toml").read_text())["white"]
    values, weight, info = read_linear(capture / white["image"])
    x0, y0, x1, y1 = white["box"]
    sums = (values * weight)[y0:y1, x0:x1].sum((0, 1)) / weight[y0:y1, x0:x1].sum((0, 1)).clip(1)
    assert sums.max() > 0.1
    xyz = sorted((capture / "truth" / "xyz").rglob("*.tiff"))
    assert len(xyz) == 3
    assert truth["truth_spp"] == 8
    se = sorted((capture / "truth" / "xyz_se").rglob("*.tiff"))
    assert [f.relative_to(capture / "truth" / "xyz_se") for f in se] == [
        f.relative_to(capture / "truth" / "xyz") for f in xyz
    ]


def test_truth_standard_error_predicts_a_second_render():
    """Two truths of one view with different seeds differ as their standard errors say: the median of
    |difference| / √(se₁² + se₂²) is a normal's 0.67 (a t's with the chunks' few degrees of freedom is
    a little more). Equal seeds would give 0, a standard error not divided by √chunks about 0.34."""
    scene = build_scene(sm.mitsuba_config(size=0.25, seed=3))
    view = next(v for v in scene.views if v.holdout)
    a, sa = sm.truth_xyz(scene, view, 16, scale=1.0, seed=11, chunks=4)
    b, sb = sm.truth_xyz(scene, view, 16, scale=1.0, seed=911, chunks=4)
    assert (
        a.shape
        == sa.shape
        == (scene.config.cameras[view.camera].height, scene.config.cameras[view.camera].width, 3)
    )
    s = np.hypot(sa, sb)
    z = np.abs(a - b)[s > 0] / s[s > 0]
    assert z.size > 1000
    lo, hi = MITSUBA_TRUTH_Z_MEDIAN
    assert lo <= np.median(z) <= hi


def test_write_truth_renders_the_held_out_views_again(capture, tmp_path):
    copy = tmp_path / "capture"
    shutil.copytree(capture, copy)
    before = {f: tifffile.imread(f) for f in sorted((copy / "truth" / "xyz").rglob("*.tiff"))}
    with pytest.raises(SplatError, match="truth_spp"):
        sm.write_truth(copy, 1)
    files = sm.write_truth(copy, 16, chunks=2)
    assert sorted(files) == sorted(before)
    truth = tomllib.loads((copy / "truth" / "truth.toml").read_text())
    assert truth["truth_spp"] == 16 and truth["spp"] == 4
    assert (copy / "truth" / "truth.toml").read_text().count("truth_spp") == 1
    for f, old in before.items():
        new = tifffile.imread(f)
        se = tifffile.imread(copy / "truth" / "xyz_se" / f.relative_to(copy / "truth" / "xyz"))
        assert new.shape == old.shape and not np.array_equal(new, old)
        # the same scene: the mean Y agrees with the 8-spp truth to a few of its standard errors
        assert abs(new[..., 1].mean() - old[..., 1].mean()) < 0.05 * old[..., 1].mean()
        assert np.all(se >= 0)
    read_capture(copy)
    assert not list(copy.rglob("*.tmp"))
    (tmp_path / "other" / "truth").mkdir(parents=True)
    (tmp_path / "other" / "truth" / "truth.toml").write_text('generator = "splat.sim.capture"\n')
    with pytest.raises(SplatError, match="not written by"):
        sm.write_truth(tmp_path / "other", 8)


def test_bad_input_is_refused_before_rendering(tmp_path):
    (tmp_path / "full").mkdir()
    (tmp_path / "full" / "keep.txt").write_text("mine")
    with pytest.raises(SplatError, match="not empty"):
        sm.write_mitsuba_capture(tmp_path / "full", size=0.25, views=2, spp=1)
    assert (tmp_path / "full" / "keep.txt").read_text() == "mine"
    with pytest.raises(SplatError, match="spp"):
        sm.write_mitsuba_capture(tmp_path / "new", spp=0)
    assert sm.main([str(tmp_path / "full"), "--spp", "1"]) == 2
    with pytest.raises(SplatError, match="truth_spp"):
        sm.write_mitsuba_capture(tmp_path / "new", spp=1, truth_spp=1)
    assert sm.main([str(tmp_path / "new"), "--spp", "1", "--truth-spp", "0"]) == 2
    assert not (tmp_path / "new").exists()


def test_surface_labels_sit_where_the_geometry_projects(capture):
    """The card's and the chart patches' labels against their analytic projection (no Mitsuba)."""
    from splat.sim.geometry import CARD, CHART

    scene = build_scene(sm.mitsuba_config(size=1, seed=1))
    view = next(v for v in scene.views if sm._card_box(scene, v) is not None)
    cam = scene.config.cameras[view.camera]
    labels = sm.surface_labels(scene, view)
    assert labels.shape == (cam.height, cam.width) and labels.dtype == np.uint16

    def pixel(x, y, z):
        p = view.R @ np.array([x, y, z]) + view.t
        u, v = view.f * p[:2] / p[2] + np.array([cam.width, cam.height]) / 2
        return int(v), int(u)

    x0, y0, x1, y1 = sm._card_box(scene, view)
    card = np.unique(labels[y0:y1, x0:x1])
    assert card.size == 1 and sm.LABEL_UNIFORM <= card[0] < sm.LABEL_OTHER
    assert labels[pixel(CARD[0] + CARD[2] / 2, CARD[1] + CARD[2] / 2, 0.0)] == card[0]
    cx0, cy0, side, gap = CHART
    seen = 0
    for i in range(6):
        for j in range(4):
            k = (3 - j) * 6 + i
            r, c = pixel(
                cx0 + gap + i * (side + gap) + side / 2, cy0 + gap + j * (side + gap) + side / 2, 0.0
            )
            if k in (7, 14, 23) or not (0 <= r < cam.height and 0 <= c < cam.width):
                continue  # 7, 14, 23 share their reflectance with a box or the chart body (one shape)
            assert labels[r, c] == sm.LABEL_CHART + k
            seen += 1
    assert seen >= 10
    files = sorted((capture / "truth" / "labels").rglob("*.tiff"))
    assert [f.relative_to(capture / "truth" / "labels") for f in files] == [
        f.relative_to(capture / "truth" / "xyz") for f in sorted((capture / "truth" / "xyz").rglob("*.tiff"))
    ]
    with pytest.raises(SplatError, match="camera sizes"):
        sm.write_surface_labels(capture, size=0.5, views=2, holdout=1, seed=1)


def test_the_chart_is_marked_where_its_patches_are(tmp_path):
    """``[chart]`` names a photograph and the four corner patches of a whole ColorChecker: its raw values
    at the 24 patch centres follow the patches' camera responses computed from colour-science's tables
    (ColorChecker N Ohta × D65 × the camera's measured curves), in every channel; any other order of the
    patches (turned, mirrored) does not."""
    from isp.profiles.chart import chart_patch_centres

    cap = sm.write_mitsuba_capture(tmp_path / "c", size=1, views=4, holdout=0, spp=4, seed=0)
    spec = read_capture(cap)
    assert spec.chart is not None and spec.chart.corners is not None
    values, weight, _ = read_linear(cap / spec.chart.image)
    seen = []
    for x, y in np.rint(chart_patch_centres(spec.chart.corners, 4, 6)).astype(int):
        w = weight[y - 1 : y + 2, x - 1 : x + 2].sum((0, 1))
        seen.append((values * weight)[y - 1 : y + 2, x - 1 : x + 2].sum((0, 1)) / w)
    seen = np.log(np.array(seen))
    grid = np.arange(400, 701, 5.0)
    cam = zonotope.camera(next(c.ssf for c in spec.cameras if spec.chart.image.startswith(c.folder + "/")))
    S = np.stack([np.interp(grid, cam.wavelengths, cam.values[:, c]) for c in range(3)], 1)
    sds = colour.SDS_COLOURCHECKERS["ColorChecker N Ohta"].values()
    R = np.stack([np.interp(grid, sd.wavelengths, sd.values) for sd in sds])
    D65 = colour.SDS_ILLUMINANTS["D65"]
    expected = np.log(R @ (S * np.interp(grid, D65.wavelengths, D65.values)[:, None]))
    k = np.arange(24).reshape(4, 6)
    for order, ok in ((k, True), (k[::-1, ::-1], False), (k[:, ::-1], False), (k[::-1], False)):
        r = [np.corrcoef(seen[order.ravel(), c], expected[:, c])[0, 1] for c in range(3)]
        assert (min(r) > 0.9) if ok else (max(r) < 0.7), (order[0], r)


def test_poses_without_points_get_points_triangulated_on_the_previews(tmp_path, monkeypatch):
    """``[poses] colmap`` with the true poses and no points (as ``truth/`` holds them): the poses step
    matches the previews and triangulates points with the poses held fixed, and keeps them in RAW
    pixels: each point reprojects through the kept cameras onto its track's keypoints (preview pixels
    mapped back by the previews' upscale), and the poses are the given ones."""
    from splat.camera import qvec_to_rotmat
    from splat.capture import poses_step
    from splat.colmap import read_colmap

    cap = sm.write_mitsuba_capture(tmp_path / "c", size=1, views=4, holdout=0, spp=8, seed=0)
    (cap / "poses").mkdir()
    for f in ("cameras.txt", "images.txt", "points3D.txt"):
        shutil.copy(cap / "truth" / f, cap / "poses" / f)
    with open(cap / "capture.toml", "a") as fh:
        fh.write('\n[poses]\ncolmap = "poses"\n')
    summary = poses_step(cap, tmp_path / "out")
    assert summary["registered"] == 12 and summary["triangulated"] >= 50
    model = read_colmap(tmp_path / "out" / "poses" / "model")
    given = read_colmap(cap / "truth")
    assert len(model.points3D) == summary["triangulated"]
    poses = {im.name: im for im in given.images.values()}
    errors = []
    for im in model.images.values():
        np.testing.assert_allclose(im.qvec, poses[im.name].qvec, atol=1e-9)
        np.testing.assert_allclose(im.tvec, poses[im.name].tvec, atol=1e-9)
        assert model.cameras[im.camera_id].params == given.cameras[poses[im.name].camera_id].params
        fx, fy, cx, cy = model.cameras[im.camera_id].pinhole()
        R = qvec_to_rotmat(im.qvec)
        for xy, pid in zip(np.asarray(im.xys).reshape(-1, 2), im.point3D_ids):
            if pid > 0:
                p = R @ model.points3D[int(pid)].xyz + im.tvec
                errors.append(np.hypot(fx * p[0] / p[2] + cx - xy[0], fy * p[1] / p[2] + cy - xy[1]))
    assert len(errors) >= 2 * len(model.points3D) and np.median(errors) < 0.5

    # where pycolmap cannot triangulate, the poses are kept without points (training then starts where
    # the views overlap) and the summary says none were triangulated
    import splat.poses

    def fails(*args, **kwargs):
        raise RuntimeError("no matches")

    monkeypatch.setattr(splat.poses, "triangulate_points", fails)
    summary = poses_step(cap, tmp_path / "out2")
    assert summary["registered"] == 12 and summary["triangulated"] is None and summary["points"] == 0
