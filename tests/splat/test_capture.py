"""splat.capture: capture.toml validation, RAW → linear mosaic (no white balance, no demosaicing), EXIF
exposure, saturated/dead pixels, full-colour DNGs, the white → 1 scale."""

from __future__ import annotations

import numpy as np
import pytest

from splat import SplatError
from splat.capture import (
    CameraSpec,
    CaptureError,
    camera_white,
    exif_exposure,
    load_views,
    read_capture,
    read_linear,
    white_scale,
)

from .capture_helpers import write_dng_exif

NEUTRAL = np.array([0.5, 1.0, 0.7])


def _bayer(path, dn, *, cfa="RGGB", black=256, white=4095, t=1 / 100, iso=100, f=4.0):
    write_dng_exif(
        path, dn, cfa=cfa, black=black, white=white, neutral=NEUTRAL, exposure_time=t, iso=iso, fnumber=f
    )


def _toml(root, body):
    (root / "capture.toml").write_text(body)
    return root


def _simple(tmp_path, n=2, size=(32, 40), extra=""):
    (tmp_path / "a").mkdir()
    rng = np.random.default_rng(0)
    for k in range(n):
        _bayer(tmp_path / "a" / f"IMG_{k}.dng", rng.integers(300, 4000, size), t=1 / 100 * (k + 1))
    return _toml(tmp_path, f'illuminant = "D65"\n[[camera]]\nfolder = "a"\nssf = "Nikon 5100 (NPL)"\n{extra}')


def test_linear_mosaic_exact_values_and_masks(tmp_path):
    dn = np.full((32, 40), 1000, np.int64)
    dn[0, 0] = 4095  # saturated R site
    dn[1, 1] = 0  # dead B site (below the black level 256: a defective pixel)
    dn[2, 3] = 2000
    _bayer(tmp_path / "x.dng", dn, cfa="GRBG")
    values, weight, info = read_linear(tmp_path / "x.dng")
    assert info["cfa"] == "GRBG" and not info["full_colour"]
    # channel of each site for GRBG: (0,0) G, (0,1) R, (1,0) B, (1,1) G
    assert weight[0, 1, 0] == 1 and weight[0, 1].sum() == 1
    assert weight[1, 0, 2] == 1 and weight[1, 0].sum() == 1
    assert values[2, 3, 0] == pytest.approx((2000 - 256) / (4095 - 256), abs=1e-7)  # (2,3) is R in GRBG
    assert values[0, 2, 1] == pytest.approx((1000 - 256) / (4095 - 256), abs=1e-7)
    assert weight[0, 0].sum() == 0 and weight[1, 1].sum() == 0  # saturated and dead: weight 0
    assert info["n_saturated"] == 1 and info["n_dead"] == 1
    assert np.all(values[weight == 0][:0] == 0)
    assert weight.sum() == dn.size - 2  # one measured channel per pixel, minus the two bad ones


def test_overrides_black_white_cfa(tmp_path):
    dn = np.full((32, 32), 1100, np.int64)
    _bayer(tmp_path / "x.dng", dn)
    values, weight, info = read_linear(
        tmp_path / "x.dng", CameraSpec("", "", cfa="BGGR", black_level=100, white_level=2100)
    )
    assert info["cfa"] == "BGGR" and weight[0, 0, 2] == 1
    assert values[0, 0, 2] == pytest.approx(0.5)


def test_full_colour_linear_raw(tmp_path):
    data = np.zeros((32, 36, 3), np.int64) + np.array([100, 2000, 4095])
    data[0, 0] = 0
    write_dng_exif(
        tmp_path / "f.dng",
        data,
        cfa=None,
        black=64,
        white=4095,
        neutral=NEUTRAL,
        exposure_time=0.01,
        iso=200,
        fnumber=2.8,
    )
    values, weight, info = read_linear(tmp_path / "f.dng")
    assert info["full_colour"] and values.shape == (32, 36, 3)
    assert values[1, 1, 1] == pytest.approx((2000 - 64) / (4095 - 64), abs=1e-7)
    assert weight[1, 1].sum() == 0  # the blue sample saturates: the whole pixel is dropped
    assert weight[0, 0].sum() == 0 and info["n_dead"] == 1
    assert exif_exposure(tmp_path / "f.dng") == pytest.approx(0.01 * 200 / 2.8**2)


def test_exposure_relative_to_median(tmp_path):
    spec = read_capture(_simple(tmp_path, n=3))
    views = load_views(spec)
    assert [v.exif for v in views] == pytest.approx([0.5, 1.0, 1.5])  # t = 1/100, 2/100, 3/100


def test_exposure_override_and_missing(tmp_path):
    spec = read_capture(_simple(tmp_path, n=2, extra='exposure = {"IMG_0.dng" = 0.08}\n'))
    exif_1 = 2 / 100 * 100 / 4.0**2  # t × ISO / N² of IMG_1; IMG_0 is overridden with 0.08
    med = (0.08 + exif_1) / 2
    assert [v.exif for v in load_views(spec)] == pytest.approx([0.08 / med, exif_1 / med])


def test_mixed_sizes_refused(tmp_path):
    _simple(tmp_path, n=2)
    _bayer(tmp_path / "a" / "odd.dng", np.full((40, 40), 500))
    with pytest.raises(CaptureError, match="mixes image sizes"):
        load_views(read_capture(tmp_path))


def test_unreadable_raw_refused(tmp_path):
    _simple(tmp_path, n=1)
    (tmp_path / "a" / "broken.dng").write_bytes(b"II*\x00garbage")
    with pytest.raises(CaptureError, match=r"broken\.dng"):
        load_views(read_capture(tmp_path))


@pytest.mark.parametrize(
    "body, match",
    [
        ("illuminant = \n", "not valid TOML"),
        ('colour = 1\n[[camera]]\nfolder = "a"\nssf = "x"\n', "unknown key"),
        ('[[camera]]\nssf = "Nikon 5100 (NPL)"\n', "lacks the key 'folder'"),
        ('[[camera]]\nfolder = "nope"\nssf = "Nikon 5100 (NPL)"\n', "does not exist"),
        ('[[camera]]\nfolder = "a"\nssf = "cams/missing.json"\n', "SSF file"),
        ('[[camera]]\nfolder = "a"\nssf = "Nikon 5100 (NPL)"\n[white]\nmethod = "grey-world"\n', "white"),
        (
            '[[camera]]\nfolder = "a"\nssf = "Nikon 5100 (NPL)"\n[white]\nmethod = "patch"\n'
            'image = "a/IMG_0.dng"\n'
            "box = [5, 5, 2, 2]\n",
            "box",
        ),
        (
            '[[camera]]\nfolder = "a"\nssf = "Nikon 5100 (NPL)"\n[holdout]\nimages = ["a/none.dng"]\n',
            "holdout",
        ),
        (
            '[[camera]]\nfolder = "a"\nssf = "Nikon 5100 (NPL)"\n'
            '[[camera]]\nfolder = "a"\nssf = "Nikon 5100 (NPL)"\n',
            "twice",
        ),
        ("", "at least one"),
    ],
)
def test_bad_capture_files(tmp_path, body, match):
    _simple(tmp_path, n=1)
    _toml(tmp_path, body)
    with pytest.raises(CaptureError, match=match):
        read_capture(tmp_path)


CAM = '[[camera]]\nfolder = "a"\nssf = "Nikon 5100 (NPL)"\n'


@pytest.mark.parametrize(
    "body, match",
    [
        # unknown keys in every table, the allowed ones named
        (
            CAM + "[white]\nmethd = 'patch'\n",
            r"\[white\] has unknown key\(s\) \['methd'\]; allowed keys are \['method'",
        ),
        (
            CAM + "[holdout]\nimage = ['a/IMG_0.dng']\n",
            r"\[holdout\] has unknown key\(s\) \['image'\]; allowed keys are \['images'\]",
        ),
        (
            CAM + "[poses]\nholdout = ['a/IMG_0.dng']\n",
            r"\[poses\] has unknown key\(s\) \['holdout'\]; allowed keys are \['colmap'",
        ),
        (CAM + "blacklevel = 3\n", r"unknown key\(s\) \['blacklevel'\]; allowed keys are \['folder'"),
        ("colour = 1\n" + CAM, r"allowed keys are \['illuminant'"),
        # types
        ("observer = 2\n" + CAM, "observer = 2 must be a string"),
        (CAM + "[holdout]\nimages = [5]\n", r"\[holdout\].images = \[5\] must be a list"),
        (CAM + "[holdout]\nimages = 'a/IMG_0.dng'\n", "must be a list"),
        ("white = 3\n" + CAM, "white = 3 must be a table"),
        (CAM + "[white]\nreflectance = true\n", "reflectance = True must be a number"),
        (CAM + "[white]\nimage = 'a/IMG_0.dng'\nbox = [0, 0, 4, 4]\n", "apply only to method"),
        (
            CAM + "[white]\nmethod = 'patch'\nimage = 'a/IMG_0.dng'\nbox = [0, 0, 4.5, 4]\n",
            "integers",
        ),
        # exposures and levels
        (CAM + "exposure = {'IMG_0.dng' = inf}\n", "finite positive number"),
        (CAM + "exposure = {'IMG_0.dng' = true}\n", "finite positive number"),
        (CAM + "exposure = {'IMG_0.dng' = 0}\n", "finite positive number"),
        (CAM + "exposure = {'IMG_9.dng' = 1.0}\n", "not a file"),
        (CAM + "black_level = 4095\nwhite_level = 4095\n", "must be below white_level"),
        (CAM + "black_level = 500\nwhite_level = 300\n", "must be below white_level"),
        (CAM + "white_level = nan\n", "finite number"),
        (CAM + "black_level = -1\n", "finite number"),
        (CAM + "white_level = 'high'\n", "finite number"),
        # a marked ColorChecker
        (
            CAM + "[chart]\nimage = 'a/IMG_0.dng'\ncorner = []\n",
            r"\[chart\] has unknown key\(s\) \['corner'\]",
        ),
        (CAM + "[chart]\ncorners = [[1, 1], [9, 1], [9, 5], [1, 5]]\n", r"\[chart\] lacks the key 'image'"),
        (CAM + "[chart]\nimage = 'a/IMG_0.dng'\ncorners = [[1, 1], [9, 1], [9, 5]]\n", "four \\[x, y\\]"),
        (CAM + "[chart]\nimage = 'a/IMG_0.dng'\ncorners = [[1, 1], [9, 1], [9, -5], [1, 5]]\n", "≥ 0"),
        (CAM + "[chart]\nimage = 'a/IMG_0.dng'\ncorners = [[1, 1], [9, 1], [9, nan], [1, 5]]\n", "≥ 0"),
        (CAM + "[chart]\nimage = 'a/IMG_0.dng'\ncorners = [[1, 1], [5, 1], [9, 1], [1, 5]]\n", "one line"),
        (
            CAM + "[chart]\nimage = 'a/IMG_0.dng'\ncorners = [[1, 1], [9, 5], [9, 1], [1, 5]]\n",
            "out of order",
        ),
        (
            CAM + "[chart]\nimage = 'a/IMG_7.dng'\ncorners = [[1, 1], [9, 1], [9, 5], [1, 5]]\n",
            "does not exist",
        ),
        # poses
        (CAM + "[poses]\ncolmap = 'a'\ntransforms = 'a/IMG_0.dng'\n", "both"),
        (CAM + "[poses]\ncolmap = 3\n", "must be a str"),
    ],
)
def test_every_key_and_type_is_checked(tmp_path, body, match):
    _simple(tmp_path, n=1)
    _toml(tmp_path, body)
    with pytest.raises(CaptureError, match=match) as e:
        read_capture(tmp_path)
    assert "\n" not in str(e.value)


def test_colliding_stems_and_foreign_holdout_are_refused(tmp_path):
    import shutil

    _simple(tmp_path, n=1)
    shutil.copy(tmp_path / "a" / "IMG_0.dng", tmp_path / "a" / "IMG_0.DNG.nef")  # other stem: fine
    read_capture(tmp_path)
    shutil.copy(tmp_path / "a" / "IMG_0.dng", tmp_path / "a" / "IMG_0.nef")
    with pytest.raises(CaptureError, match=r"IMG_0.dng and IMG_0.nef"):
        read_capture(tmp_path)
    (tmp_path / "a" / "IMG_0.nef").unlink()
    (tmp_path / "a" / "IMG_0.DNG.nef").unlink()
    (tmp_path / "b").mkdir()
    shutil.copy(tmp_path / "a" / "IMG_0.dng", tmp_path / "b" / "x.dng")
    _toml(tmp_path, CAM + "[holdout]\nimages = ['b/x.dng']\n")
    with pytest.raises(CaptureError, match="not a file of a camera folder"):
        read_capture(tmp_path)


def test_a_marked_chart_is_read_and_its_patches_must_lie_in_the_photograph(tmp_path):
    from splat.capture import check_chart

    _simple(tmp_path, n=2)  # 40 × 32 px
    body = CAM + "[chart]\nimage = 'a/IMG_1.dng'\ncorners = [[2, 3], [37, 3], [37, 28.5], [2, 28.5]]\n"
    spec = read_capture(_toml(tmp_path, body))
    assert spec.chart.image == "a/IMG_1.dng" and spec.chart.corners[2] == (37.0, 28.5)
    check_chart(spec, load_views(spec))
    spec = read_capture(_toml(tmp_path, body.replace("[37, 28.5]", "[45, 28.5]")))
    with pytest.raises(CaptureError, match=r"put patches outside the 40×32 image") as e:
        check_chart(spec, load_views(spec))
    assert "\n" not in str(e.value)
    assert read_capture(_toml(tmp_path, CAM)).chart is None


def test_a_zero_exif_exposure_is_refused_naming_the_file(tmp_path):
    (tmp_path / "a").mkdir()
    rng = np.random.default_rng(0)
    _bayer(tmp_path / "a" / "IMG_0.dng", rng.integers(300, 4000, (32, 40)), t=0.0)
    _bayer(tmp_path / "a" / "IMG_1.dng", rng.integers(300, 4000, (32, 40)))
    _toml(tmp_path, CAM)
    with pytest.raises(CaptureError, match=r"no EXIF exposure .* in \['a/IMG_0.dng'\]"):
        load_views(read_capture(tmp_path))


def test_output_stems_stay_inside_whatever_the_folder(tmp_path):
    outside = tmp_path / "elsewhere" / "canon"
    outside.mkdir(parents=True)
    cap = tmp_path / "cap"
    cap.mkdir()
    _simple(cap, n=1)
    rng = np.random.default_rng(0)
    _bayer(outside / "IMG_7.dng", rng.integers(300, 4000, (32, 40)))
    _toml(
        cap,
        CAM + f'[[camera]]\nfolder = "{outside}"\nssf = "Nikon 5100 (NPL)"\n'
        '[[camera]]\nfolder = "../elsewhere/canon"\nssf = "Nikon 5100 (NPL)"\n',
    )
    spec = read_capture(cap)
    assert [spec.label(k) for k in range(3)] == ["a", "camera2-canon", "camera3-canon"]
    names = [v.name for v in load_views(spec)]
    stems = [spec.out_stem(n) for n in names]
    assert stems == ["a/IMG_0", "camera2-canon/IMG_7", "camera3-canon/IMG_7"]
    assert all(not s.startswith("/") and ".." not in s.split("/") for s in stems)


def test_missing_capture_file_and_empty_folder(tmp_path):
    with pytest.raises(CaptureError, match="no capture file"):
        read_capture(tmp_path)
    (tmp_path / "a").mkdir()
    _toml(tmp_path, '[[camera]]\nfolder = "a"\nssf = "Nikon 5100 (NPL)"\n')
    with pytest.raises(CaptureError, match="no RAW files"):
        read_capture(tmp_path)


def test_unknown_ssf(tmp_path):
    _simple(tmp_path, n=1)
    _toml(tmp_path, '[[camera]]\nfolder = "a"\nssf = "Kodak Brownie"\n')
    with pytest.raises(CaptureError, match="neither a built-in camera"):
        read_capture(tmp_path).load_ssf(0)


def _white_scene(tmp_path, level, *, n=2, box=None, reflectance=1.0, tilt=1.0):
    """Views with a flat neutral patch at ``level`` × white (raw, exposure 1) and darker coloured noise;
    ``tilt`` (3,) makes the sensor's real white differ from its SSF's."""
    (tmp_path / "a").mkdir()
    _toml(tmp_path, '[[camera]]\nfolder = "a"\nssf = "Nikon 5100 (NPL)"\n')
    import zonotope

    cam, light = zonotope.camera("Nikon 5100 (NPL)"), zonotope.illuminant("D65")
    g = zonotope.generators(cam, light, zonotope.common_shape(cam, light, interval=5), normalise=None).values
    white = g.sum(0) / g.sum(0).max()
    rng = np.random.default_rng(1)
    for k in range(n):
        e = [0.5, 1.0, 2.0][k]
        rgb = rng.uniform(0.05, 0.4, (32, 40, 3)) * white * level * e * tilt
        rgb[4:12, 4:14] = level * e * white * tilt
        from isp.stages import mosaic

        dn = np.round(256 + mosaic(rgb, cfa="RGGB") * (4095 - 256))
        _bayer(tmp_path / "a" / f"IMG_{k}.dng", dn, t=e / 100)
    if box is not None:
        _toml(
            tmp_path,
            '[[camera]]\nfolder = "a"\nssf = "Nikon 5100 (NPL)"\n[white]\nmethod = "patch"\n'
            f'image = "a/IMG_1.dng"\nbox = {list(box)}\nreflectance = {reflectance}\n',
        )
    assert camera_white(read_capture(tmp_path), 0) == pytest.approx(white)
    return white


def test_brightest_neutral_finds_the_white_level(tmp_path):
    white = _white_scene(tmp_path, 0.3)
    spec = read_capture(tmp_path)
    views = load_views(spec)  # exposures 0.5 / 1 around the median 0.75
    s = white_scale(spec, views)
    # relative exposure 1 ↔ absolute 0.75: the white's raw level there is 0.3 × 0.75 (DN rounding ≤ 1e-3)
    assert s["scale"][0] == pytest.approx(0.3 * 0.75 * white, rel=3e-3)


def test_patch_camera_white_is_measured_per_channel(tmp_path):
    """The patch camera's white comes from the patch per channel, not from its SSF's white: a camera
    whose real white is 1 % off its SSF's in red and blue is put on the real white → 1 scale."""
    tilt = np.array([1.01, 1.0, 0.99])
    white = _white_scene(tmp_path, 0.3, box=(4, 4, 14, 12), reflectance=0.5, tilt=tilt)
    spec = read_capture(tmp_path)
    s = white_scale(spec, load_views(spec))
    np.testing.assert_allclose(s["scale"][0], 2 * 0.3 * 0.75 * white * tilt, rtol=3e-3)


def test_patch_scale_with_reflectance(tmp_path):
    white = _white_scene(tmp_path, 0.3, box=(4, 4, 14, 12), reflectance=0.5)
    spec = read_capture(tmp_path)
    s = white_scale(spec, load_views(spec))
    # the marked patch has reflectance 0.5: a perfect white would be twice as bright
    assert s["method"] == "patch"
    assert s["scale"][0] == pytest.approx(2 * 0.3 * 0.75 * white, rel=3e-3)


@pytest.mark.parametrize(
    "bad",
    [
        {"steps": 0},
        {"steps": -3},
        {"capacity": 0},
        {"novel": -1},
        {"quantum": float("nan")},
        {"quantum": 0.0},
        {"min_registered": 0.0},
        {"min_registered": 1.5},
        {"densify_until": -1},
    ],
)
def test_pipeline_config_refuses_bad_values(bad):
    from splat.capture import PipelineConfig

    with pytest.raises(SplatError, match=next(iter(bad))):
        PipelineConfig(**bad)


def test_cli_bad_option_is_one_line(capsys, tmp_path):
    from splat.cli import main

    assert main(["run", str(tmp_path), "-o", str(tmp_path / "out"), "--steps", "-3"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "steps=-3" in err[0]
    assert not (tmp_path / "out").exists()  # refused before any work


def test_curves_of_another_maker_are_named_before_the_run(tmp_path, capsys):
    """Two [[camera]] tables with their ssf lines swapped: each camera's named curves are another
    maker's than its DNG files' Make; ``splat run`` says so, camera by camera, before any work."""
    from splat.capture import maker_warnings
    from splat.cli import main

    rng = np.random.default_rng(0)
    for folder, make in (("nik", "NIKON CORPORATION"), ("can", "Canon")):
        (tmp_path / folder).mkdir()
        for k in range(2):
            write_dng_exif(
                tmp_path / folder / f"IMG_{k}.dng",
                rng.integers(300, 4000, (32, 40)),
                cfa="RGGB",
                black=256,
                white=4095,
                neutral=NEUTRAL,
                exposure_time=1 / 100,
                iso=100,
                fnumber=4.0,
                make=make,
            )
    body = (
        'illuminant = "D65"\n[[camera]]\nfolder = "nik"\nssf = "{}"\n[[camera]]\nfolder = "can"\nssf = "{}"\n'
    )
    _toml(tmp_path, body.format("Nikon 5100 (NPL)", "Canon EOS 5D Mark II"))
    assert maker_warnings(read_capture(tmp_path)) == []
    _toml(tmp_path, body.format("Canon EOS 5D Mark II", "Nikon 5100 (NPL)"))
    said = maker_warnings(read_capture(tmp_path))
    assert len(said) == 2 and "camera 'nik' (IMG_0.dng)" in said[0] and "from 'NIKON CORPORATION'" in said[0]
    assert "'Nikon 5100 (NPL)' are a Nikon camera's" in said[1]
    assert main(["run", str(tmp_path), "-o", str(tmp_path / "out")]) == 2  # OUT inside: refused, after
    lines = capsys.readouterr().err.splitlines()
    assert [x.startswith("splat: warning:") for x in lines] == [True, True, False]
    assert "lies inside the capture" in lines[2]
