"""The simulated capture on disk: files, tags, the spectral forward model, truth, poses, SIFT registration.

Independent checks: pixel values are recomputed by hand from the measured reflectance, SSF and D65 tables
(numpy on the source data, no library code), held-out XYZ against colour-science's ``sd_to_XYZ``, pixel
positions from the true COLMAP model read back with :func:`splat.read_colmap`.
"""

from __future__ import annotations

import functools
import tomllib
from dataclasses import replace
from pathlib import Path

import colour
import numpy as np
import pytest

import isp
import splat
from splat.sim.capture import SimCamera, SimCaptureConfig, build_scene, write_synthetic_capture

GRID = np.arange(400.0, 681.0, 5.0)  # the cameras' common range (Sigma SDMerill ends at 680 nm)


@pytest.fixture(scope="module")
def capture(tmp_path_factory) -> Path:
    """The CI-size capture with noise (the default configuration)."""
    return write_synthetic_capture(tmp_path_factory.mktemp("sim") / "capture", SimCaptureConfig.ci())


@pytest.fixture(scope="module")
def clean(tmp_path_factory) -> Path:
    """A noise-free capture: 3 cameras × (3 training + 1 held-out) views."""
    cfg = SimCaptureConfig.ci(noise=False, n_train=3, n_holdout=1, seed=3)
    return write_synthetic_capture(tmp_path_factory.mktemp("sim") / "clean", cfg)


def _toml(path: Path) -> dict:
    return tomllib.loads(path.read_text())


def _exif_product(path: Path) -> float:
    tags = isp.read_dng_tags(path)
    t, n = float(np.ravel(tags["ExposureTime"])[0]), float(np.ravel(tags["FNumber"])[0])
    return t * float(tags["ISOSpeedRatings"]) / n**2


def _relative_exposures(root: Path) -> dict[str, float]:
    P = {f"{f.parent.name}/{f.name}": _exif_product(f) for f in sorted(root.glob("*/*.dng"))}
    med = float(np.median(list(P.values())))
    return {k: v / med for k, v in P.items()}


def _data(msds_or_sd, grid=GRID) -> np.ndarray:
    """Values of a colour spectral table at the grid by linear interpolation of its own samples."""
    w = np.asarray(msds_or_sd.wavelengths, float)
    v = np.asarray(msds_or_sd.values, float).reshape(len(w), -1)
    return np.stack([np.interp(grid, w, v[:, j]) for j in range(v.shape[1])], 1)


def _pixels_inside(model: splat.ColmapModel, name: str, corners: np.ndarray) -> list[tuple[int, int]]:
    """Pixels (row, col) whose whole square lies inside the projection of a flat convex quad (4, 3)."""
    im = next(i for i in model.images.values() if i.name == name)
    cam = model.cameras[im.camera_id]
    fx, fy, cx, cy = cam.pinhole()
    R = splat.qvec_to_rotmat(im.qvec)
    pc = corners @ R.T + im.tvec
    uv = np.stack([fx * pc[:, 0] / pc[:, 2] + cx, fy * pc[:, 1] / pc[:, 2] + cy], 1)
    rows = np.arange(max(0, int(uv[:, 1].min())), min(cam.height, int(uv[:, 1].max()) + 1))
    cols = np.arange(max(0, int(uv[:, 0].min())), min(cam.width, int(uv[:, 0].max()) + 1))
    r, c = (a.ravel() for a in np.meshgrid(rows, cols, indexing="ij"))
    pts = np.stack(
        [np.stack([c, r], 1), np.stack([c + 1, r], 1), np.stack([c + 1, r + 1], 1), np.stack([c, r + 1], 1)],
        1,
    ).astype(float)  # (P, 4 pixel corners, 2)
    e = np.roll(uv, -1, axis=0) - uv  # quad edges (4, 2)
    rel = pts[:, None, :, :] - uv[None, :, None, :]  # (P, 4 edges, 4 corners, 2)
    dist = (e[None, :, None, 0] * rel[..., 1] - e[None, :, None, 1] * rel[..., 0]) / np.hypot(*e.T)[:, None]
    inside = np.all(dist > 0.02, axis=(1, 2)) | np.all(dist < -0.02, axis=(1, 2))  # signed px distances
    return list(zip(r[inside].tolist(), c[inside].tolist()))


def _patch_corners(truth: dict, i: int, j: int) -> np.ndarray:
    ch = truth["chart"]
    x0 = ch["x0"] + ch["gap"] + i * (ch["side"] + ch["gap"])
    y0 = ch["y0"] + ch["gap"] + j * (ch["side"] + ch["gap"])
    s = ch["side"]
    return np.array([[x0, y0, 0], [x0 + s, y0, 0], [x0 + s, y0 + s, 0], [x0, y0 + s, 0]], float)


def _card_corners(truth: dict) -> np.ndarray:
    c = truth["white_card"]
    x0, y0, s = c["x0"], c["y0"], c["side"]
    return np.array([[x0, y0, 0], [x0 + s, y0, 0], [x0 + s, y0 + s, 0], [x0, y0 + s, 0]], float)


# ------------------------------------------------------------------------------------- layout, tags
def test_layout_and_capture_toml(capture):
    cfg = _toml(capture / "capture.toml")
    assert cfg["illuminant"] == "D65" and cfg["observer"] == "CIE 1931 2 Degree Standard Observer"
    assert [(c["folder"], c["ssf"]) for c in cfg["camera"]] == [
        ("nikon", "Nikon 5100 (NPL)"),
        ("sigma", "Sigma SDMerill (NPL)"),
        ("canon", "Canon EOS 5D Mark II"),
    ]
    for c in cfg["camera"]:
        files = sorted((capture / c["folder"]).glob("*.dng"))
        assert len(files) == 8
        assert len(list((capture / "truth" / "xyz" / c["folder"]).glob("*.tiff"))) == 2
    assert len(cfg["holdout"]["images"]) == 6
    assert all((capture / name).is_file() for name in cfg["holdout"]["images"])
    assert cfg["white"]["method"] == "patch" and (capture / cfg["white"]["image"]).is_file()
    assert not list(capture.parent.glob(".*"))  # no temporary folder left behind
    truth = _toml(capture / "truth" / "truth.toml")
    assert truth["generator"] == "splat.simcapture" and len(truth["view"]) == 24


def test_dng_tags_and_readers(capture):
    import rawpy
    import tifffile

    scene = build_scene(SimCaptureConfig.ci())
    truth = _toml(capture / "truth" / "truth.toml")
    rel = _relative_exposures(capture)
    for ci, cam in enumerate(scene.config.cameras):
        for f in sorted((capture / cam.folder).glob("*.dng")):
            tags = isp.read_dng_tags(f)
            assert tags["Make"] == cam.make and tags["Model"] == cam.model
            assert tags["UniqueCameraModel"] == f"{cam.make} {cam.model}"
            assert (tags["CalibrationIlluminant1"], tags["CalibrationIlluminant2"]) == (17, 21)
            assert np.ravel(tags["WhiteLevel"])[0] == cam.white_level
            np.testing.assert_allclose(tags["AsShotNeutral"], scene.neutrals[ci], atol=1e-6)
            view = next(v for v in truth["view"] if v["image"] == f"{cam.folder}/{f.name}")
            assert float(np.ravel(tags["ExposureTime"])[0]) == pytest.approx(view["exposure_time"], rel=1e-6)
            assert int(tags["ISOSpeedRatings"]) == view["iso"]
            assert float(np.ravel(tags["FNumber"])[0]) == pytest.approx(view["f_number"], rel=1e-6)
            assert rel[view["image"]] == pytest.approx(view["relative_exposure"], rel=1e-6)
            with rawpy.imread(str(f)) as raw:
                data = raw.raw_image.copy()
                assert raw.white_level == cam.white_level
                assert list(raw.black_level_per_channel[:3]) == [cam.black_level] * 3
            pixels = tifffile.imread(f)
            if cam.cfa is None:  # full-colour sensor: LinearRaw, 3 samples per pixel
                assert "CFAPattern" not in tags and pixels.shape == (cam.height, cam.width, 3)
                np.testing.assert_array_equal(data[..., :3], pixels)
            else:
                raw_image = isp.read_raw(f)
                assert raw_image.cfa == cam.cfa and raw_image.shape == (cam.height, cam.width)
                np.testing.assert_array_equal(raw_image.black_level, np.full((2, 2), cam.black_level))
                np.testing.assert_array_equal(raw_image.mosaic, pixels)
                np.testing.assert_array_equal(data, pixels)
                np.testing.assert_allclose(raw_image.profile.color_matrix_2.ravel(), tags["ColorMatrix2"])
    # the DNG colour matrices: the fitted XYZ → camera maps under D65 and A, white held exactly
    from isp.simulate import fit_color_matrix, spectral_setup

    setup = spectral_setup("Nikon 5100 (NPL)", illuminant="D65", shape=GRID)
    M = fit_color_matrix(setup, scene.library[scene.palettes["colorchecker"]])
    tags = isp.read_dng_tags(next((capture / "nikon").glob("*.dng")))
    np.testing.assert_allclose(tags["ColorMatrix2"].reshape(3, 3), M, atol=5e-5)
    # Bayer phases differ between makes; some highlights saturate
    assert scene.config.cameras[0].cfa != scene.config.cameras[2].cfa
    assert any(
        tifffile.imread(f).max() == c.white_level
        for c in scene.config.cameras
        for f in (capture / c.folder).glob("*.dng")
    )


# ------------------------------------------------------------------------------- forward model
@functools.cache
def _ssf_times_d65(ssf: str) -> tuple[np.ndarray, np.ndarray]:
    import zonotope

    S = _data(zonotope.CAMERAS[ssf]())
    E = _data(colour.SDS_ILLUMINANTS["D65"])[:, 0]
    return S, E


def _hand_response(ssf: str, reflectance: np.ndarray) -> np.ndarray:
    """Σ R S E / max_c Σ S E on the grid, from the source tables (no zonotope/isp code)."""
    S, E = _ssf_times_d65(ssf)
    white = (S * E[:, None]).sum(0)
    return (reflectance * E) @ S / white.max()


def test_noise_free_mosaic_is_the_spectral_forward_model(clean):
    """Pixels wholly inside a ColorChecker patch (found by projecting the patch with the true pose):
    DN = round(black + gain · k_EXIF · response · (white − black)), response computed by hand."""
    truth = _toml(clean / "truth" / "truth.toml")
    model = splat.read_colmap(clean / "truth")
    rel = _relative_exposures(clean)
    patches = [_data(sd)[:, 0] for sd in colour.SDS_COLOURCHECKERS["ColorChecker N Ohta"].values()]
    import tifffile

    checked = 0
    for cam in truth["camera"]:
        for f in sorted((clean / cam["folder"]).glob("*.dng")):
            name = f"{cam['folder']}/{f.name}"
            dn = tifffile.imread(f).astype(np.float64)
            span = cam["white_level"] - cam["black_level"]
            for j in range(4):
                for i in range(6):
                    patch = (3 - j) * 6 + i
                    resp = _hand_response(cam["ssf"], patches[patch])
                    expect = cam["black_level"] + truth["gain"] * rel[name] * resp * span
                    for r, c in _pixels_inside(model, name, _patch_corners(truth, i, j)):
                        if "cfa" in cam:
                            ch = "RGB".index(cam["cfa"][2 * (r % 2) + c % 2])
                            got, want = dn[r, c], expect[ch]
                        else:
                            got, want = dn[r, c], expect
                        np.testing.assert_allclose(
                            got,
                            np.clip(np.round(want), 0, cam["white_level"]),
                            atol=1.0,
                            err_msg=f"{name} pixel {(r, c)} patch {patch}",
                        )
                        checked += 1
    assert checked >= 100


def test_heldout_xyz_matches_colour_science(clean, capture):
    """A pixel wholly on the flat 0.9 white card and on a chart patch: XYZ = colour.sd_to_XYZ / 100."""
    import tifffile

    shape = colour.SpectralShape(400, 680, 5)
    cmfs = colour.MSDS_CMFS["CIE 1931 2 Degree Standard Observer"].copy().align(shape)
    d65 = colour.SDS_ILLUMINANTS["D65"].copy().align(shape)
    cc = colour.SDS_COLOURCHECKERS["ColorChecker N Ohta"]
    for root in (clean, capture):
        truth = _toml(root / "truth" / "truth.toml")
        model = splat.read_colmap(root / "truth")
        flat = colour.SpectralDistribution(np.full(GRID.size, 0.9), GRID)
        white = colour.sd_to_XYZ(flat, cmfs, d65, method="Integration") / 100
        n = 0
        for tiff in sorted((root / "truth" / "xyz").glob("*/*.tiff")):
            XYZ = tifffile.imread(tiff)
            assert XYZ.dtype == np.float32 and XYZ.ndim == 3 and XYZ.shape[2] == 3
            name = f"{tiff.parent.name}/{tiff.stem}.dng"
            for r, c in _pixels_inside(model, name, _card_corners(truth)):
                np.testing.assert_allclose(XYZ[r, c], white, rtol=2e-6)
                n += 1
            sd = colour.SpectralDistribution(_data(list(cc.values())[18 + 3])[:, 0], GRID)  # neutral 5
            want = colour.sd_to_XYZ(sd, cmfs, d65, method="Integration") / 100
            for r, c in _pixels_inside(model, name, _patch_corners(truth, 3, 0)):
                np.testing.assert_allclose(XYZ[r, c], want, rtol=2e-6)
                n += 1
        assert n >= 10


def test_exif_exposure_matches_brightness(capture):
    """Noisy capture: on the white card, (DN − black) / (white − black) ≈ gain · k_EXIF · 0.9 · neutral."""
    import tifffile

    truth = _toml(capture / "truth" / "truth.toml")
    model = splat.read_colmap(capture / "truth")
    rel = _relative_exposures(capture)
    ratios = []
    for cam in truth["camera"]:
        neutral = np.asarray(cam["as_shot_neutral"])
        for f in sorted((capture / cam["folder"]).glob("*.dng")):
            name = f"{cam['folder']}/{f.name}"
            pix = _pixels_inside(model, name, _card_corners(truth))
            if len(pix) < 12:
                continue
            dn = tifffile.imread(f).astype(np.float64)
            frac = (dn - cam["black_level"]) / (cam["white_level"] - cam["black_level"])
            vals, want = [], []
            for r, c in pix:
                ch = "RGB".index(cam["cfa"][2 * (r % 2) + c % 2]) if "cfa" in cam else slice(None)
                vals.append(np.ravel(frac[r, c]))
                want.append(np.ravel(truth["gain"] * rel[name] * 0.9 * neutral[ch]))
            vals, want = np.concatenate(vals), np.concatenate(want)
            unsat = want < 0.95
            if unsat.sum() >= 12:
                ratios.append(np.mean(vals[unsat]) / np.mean(want[unsat]))
            else:  # over-exposed: the card clips at the white level
                assert np.all(dn[tuple(np.array(pix).T)] == cam["white_level"])
    assert len(ratios) >= 10
    np.testing.assert_allclose(ratios, 1.0, atol=0.02)


def test_true_poses_round_trip(capture):
    scene = build_scene(SimCaptureConfig.ci())
    model = splat.read_colmap(capture / "truth")
    assert len(model.cameras) == 3 and len(model.images) == 24
    by_name = {im.name: im for im in model.images.values()}
    for v in scene.views:
        cam = scene.config.cameras[v.camera]
        im = by_name[f"{cam.folder}/{v.stem}.dng"]
        assert (capture / im.name).is_file()
        np.testing.assert_allclose(splat.qvec_to_rotmat(im.qvec), v.R, atol=1e-9)
        np.testing.assert_allclose(im.tvec, v.t, atol=1e-9)
        c = model.cameras[im.camera_id]
        assert (c.model, c.width, c.height) == ("PINHOLE", cam.width, cam.height)
        np.testing.assert_allclose(c.pinhole(), (v.f, v.f, cam.width / 2, cam.height / 2), rtol=1e-12)
    assert len(model.points3D) > 1000


# ------------------------------------------------------------------------------------ bad input
def _tiny(**changes) -> SimCaptureConfig:
    cam = SimCamera(
        "cam",
        "Nikon 5100 (NPL)",
        "NIKON CORPORATION",
        "NIKON D5100",
        "DSC_",
        32,
        24,
        60.0,
        "RGGB",
        0,
        16383,
        radius=3.0,
        eye_height=2.0,
    )
    return SimCaptureConfig.ci(cameras=(cam,), n_train=2, n_holdout=1, **changes)


def test_refuses_to_overwrite(tmp_path):
    other = tmp_path / "photos"
    other.mkdir()
    (other / "IMG_0001.CR2").write_bytes(b"precious")
    for overwrite in (False, True):
        with pytest.raises(splat.SplatError, match="not empty"):
            write_synthetic_capture(other, _tiny(), overwrite=overwrite)
    assert (other / "IMG_0001.CR2").read_bytes() == b"precious"
    out = write_synthetic_capture(tmp_path / "sim", _tiny())
    with pytest.raises(splat.SplatError, match="overwrite=True"):
        write_synthetic_capture(out, _tiny())
    write_synthetic_capture(out, _tiny(seed=5), overwrite=True)
    assert _toml(out / "truth" / "truth.toml")["seed"] == 5
    assert sorted(p.name for p in tmp_path.iterdir()) == ["photos", "sim"]


@pytest.mark.parametrize(
    "changes, match",
    [
        ({"n_train": 1}, "n_train"),
        ({"n_holdout": 2}, "n_holdout"),
        ({"supersample": 0}, "supersample"),
        ({"gain": 1.5}, "gain"),
        ({"texture": "smooth"}, "texture"),
        ({"cell": 0.0}, "cell"),
    ],
)
def test_bad_config(tmp_path, changes, match):
    with pytest.raises(splat.SplatError, match=match):
        write_synthetic_capture(tmp_path / "x", replace(_tiny(), **changes))
    assert not (tmp_path / "x").exists()


@pytest.mark.parametrize(
    "camera, match",
    [
        ({"width": 20}, "22 px"),
        ({"height": 25}, "even"),
        ({"ssf": "Nikon D9"}, "built-in camera"),
        ({"black_level": 20000}, "black_level"),
    ],
)
def test_bad_camera(tmp_path, camera, match):
    cfg = _tiny()
    cfg = replace(cfg, cameras=(replace(cfg.cameras[0], **camera),))
    with pytest.raises(splat.SplatError, match=match):
        write_synthetic_capture(tmp_path / "x", cfg)


# --------------------------------------------------------------------------------- registration
@pytest.mark.slow
def test_sift_registers_every_view(capture, tmp_path):
    """pycolmap SIFT + incremental mapping on 8-bit previews (LibRaw development) of all 24 views."""
    import imageio.v3 as iio
    import rawpy

    for f in sorted(capture.glob("*/*.dng")):
        with rawpy.imread(str(f)) as raw:
            rgb = raw.postprocess(output_bps=8, use_camera_wb=True, no_auto_bright=True)
        (tmp_path / "previews" / f.parent.name).mkdir(parents=True, exist_ok=True)
        iio.imwrite(tmp_path / "previews" / f.parent.name / f"{f.stem}.png", rgb)
    model = splat.recover_poses(
        tmp_path / "previews", tmp_path / "colmap", config=splat.PoseConfig(num_threads=2)
    )
    names = {im.name for im in model.images.values()}
    for folder in ("nikon", "sigma", "canon"):
        assert sum(n.startswith(folder + "/") for n in names) == 8, sorted(names)
    assert len(model.cameras) == 3
    # camera centres agree with the true ones after a similarity transform (Umeyama 1991)
    true = splat.read_colmap(capture / "truth")

    def centres(m):
        return {
            Path(im.name).with_suffix("").as_posix(): -splat.qvec_to_rotmat(im.qvec).T @ im.tvec
            for im in m.images.values()
        }

    T, C = centres(true), centres(model)
    A = np.array([C[n] for n in sorted(T)])
    B = np.array([T[n] for n in sorted(T)])
    A0, B0 = A - A.mean(0), B - B.mean(0)
    U, S, Vt = np.linalg.svd(B0.T @ A0)
    D = np.diag([1.0, 1.0, np.sign(np.linalg.det(U @ Vt))])
    scale = (S * np.diag(D)).sum() / (A0**2).sum()
    err = np.linalg.norm(scale * A0 @ (U @ D @ Vt).T - B0, axis=1)
    assert np.sqrt(np.mean(err**2)) < 0.1  # metres, on orbits of radius 3–3.6 m (measured 0.02)


def test_extra_reflectances(shared_data):
    import zonotope

    path = shared_data / "reflectance_munsell_matte_joensuu_5nm" / "munsell_matte_1269_380_780_5nm.csv"
    base = build_scene(_tiny())
    scene = build_scene(_tiny(extra_reflectances=(str(path),)))
    K = len(base.library)
    np.testing.assert_array_equal(scene.library[:K], base.library)
    munsell = zonotope.load_reflectances(path)
    np.testing.assert_allclose(scene.library[K:], np.clip(_data(munsell, scene.wavelengths).T, 0, 1))
    idx, wts = scene.trace(scene.views[0])
    assert np.any((idx >= K) & (wts > 0))  # the floor and backdrop now carry Munsell samples
    with pytest.raises(splat.SplatError, match="extra_reflectances"):
        build_scene(_tiny(extra_reflectances=(str(shared_data / "no such file.csv"),)))


def test_main(tmp_path, capsys):
    from splat.sim.capture import main

    assert main([str(tmp_path / "c"), "--size", "ci", "--seed", "2", "--no-noise"]) == 0
    assert "24 DNG files" in capsys.readouterr().out
    assert _toml(tmp_path / "c" / "truth" / "truth.toml")["noise"] is False
    assert main([str(tmp_path / "c")]) == 2
    assert "overwrite=True" in capsys.readouterr().err


def test_coarse_texture_is_flat_over_several_bayer_periods():
    """The coarse texture exists so that colour, not demosaicing, can be measured: far more pixels lie
    inside a patch of constant true colour (5 × 5 neighbourhood) than with the fine texture, on the same
    view, and each flat pixel's spectrum is one measured reflectance (with shading), not a mix."""
    from splat.scoring import flat_mask

    fine = build_scene(SimCaptureConfig.ci())
    coarse = build_scene(SimCaptureConfig.ci(texture="coarse"))
    assert coarse.config.cell_size == 0.5 and fine.config.cell_size == 0.2
    view = next(v for v in coarse.views if v.holdout)
    f_fine = flat_mask(fine.XYZ(view)).mean()
    f_coarse = flat_mask(coarse.XYZ(view)).mean()
    assert f_fine < 0.05 and f_coarse > 0.2, (f_fine, f_coarse)
    idx, wts = coarse.trace(view)
    single = np.all((wts[..., 1:] == 0) | (idx[..., 1:] == 1), axis=-1)  # one reflectance (+ border black)
    assert single.mean() > 0.99
