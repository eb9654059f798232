"""What a photographer needs from ``isp develop``: a white-balance choice, the Orientation tag honoured
(checked against rawpy), output TIFFs with an sRGB ICC profile and the camera's metadata, a white
balance source that says where it came from, ``--version`` and progress lines when piped."""

from __future__ import annotations

import shutil
import subprocess

import colour
import numpy as np
import pytest
import tifffile

import isp
import zonotope
from isp.cli import main
from isp.dng import camera_neutral_to_xy, xy_to_camera_neutral, xy_to_CCT_DNG
from isp.exif import output_tags, srgb_icc_profile
from isp.simulate import chart_image, simulate_capture, spectral_setup
from isp.whitebalance import describe_white_balance, white_balance_neutral, white_balance_xy

CIE1931 = colour.CCS_ILLUMINANTS["CIE 1931 2 Degree Standard Observer"]
#: Canon EOS 5D Mark II ColorMatrix1 (Std. A) / ColorMatrix2 (D65), from colour-hdri's documentation.
M_A = [[0.5309, -0.0229, -0.0336], [-0.6241, 1.3265, 0.3337], [-0.0817, 0.1215, 0.6664]]
M_D65 = [[0.4716, 0.0603, -0.0830], [-0.7798, 1.5474, 0.2480], [-0.1496, 0.1937, 0.6651]]


@pytest.fixture(scope="module")
def chart():
    """A ColorChecker rendered through the Nikon 5100 under illuminant A (a warm light)."""
    setup = spectral_setup("Nikon 5100 (NPL)", illuminant="A")
    R = zonotope.resample(zonotope.reflectances("ColorChecker N Ohta"), setup.wavelengths).T
    img, labels = chart_image(R, rows=4, cols=6)
    return simulate_capture(img, setup), labels


def _write(path, capture, *, orientation=1, neutral=None, **kw):
    return isp.write_dng(
        path,
        capture.mosaic,
        cfa=capture.cfa,
        black_level=capture.black_level,
        white_level=capture.white_level,
        color_matrix_1=capture.color_matrix,
        as_shot_neutral=capture.neutral if neutral is None else neutral,
        calibration_illuminant_1=17,
        orientation=orientation,
        **kw,
    )


def _patch_box(labels, k, margin=2):
    ys, xs = np.nonzero(labels == k)
    return xs.min() + margin, ys.min() + margin, xs.max() + 1 - margin, ys.max() + 1 - margin


# -- white balance ------------------------------------------------------------------------------


@pytest.mark.parametrize("T", [1800, 2850, 3200, 4500, 5500, 6500, 10000, 20000])
def test_kelvin_on_the_planckian_locus(T):
    xy = white_balance_xy(f"{T}K")
    # the DNG SDK's reading gives T back (colour's Robertson forward and inverse interpolate between
    # isotherms slightly differently: ≤ 3e-6 relative, 0.02 K at 5500 K)
    assert xy_to_CCT_DNG(xy) == pytest.approx(T, rel=5e-6)
    # independent: Ohno (2013) Planckian locus, Duv = 0 (Robertson's isotherms are accurate to ~1e-4)
    ref = colour.UCS_uv_to_xy(colour.temperature.CCT_to_uv_Ohno2013(np.array([T, 0.0])))
    np.testing.assert_allclose(xy, ref, atol=3e-4)


def test_named_whites_and_errors():
    np.testing.assert_array_equal(white_balance_xy("d65"), CIE1931["D65"])
    np.testing.assert_array_equal(white_balance_xy("FL2"), CIE1931["FL2"])
    np.testing.assert_array_equal(white_balance_xy("daylight"), white_balance_xy("5500 K"))
    for bad, what in [
        ("900K", "1667"),
        ("60000K", "25000"),
        ("candle", "not known"),
        ("spot:1,2,3", "spot:"),
        ("spot:5,5,2,9", "x0 < x1"),
    ]:
        with pytest.raises(isp.PipelineError, match=what):
            isp.default_pipeline(white_balance=bad) if bad.startswith("spot") else white_balance_xy(bad)
    with pytest.raises(isp.PipelineError, match="positive"):
        isp.default_pipeline(white_balance=[1, 0, 1])


@pytest.mark.parametrize("T", [2000, 2850, 4000, 5000, 6500, 9000])
def test_xy_to_camera_neutral_inverts_the_dng_iteration(T):
    profile = isp.DNGProfile(M_A, M_D65, calibration_illuminant_1=17, calibration_illuminant_2=21)
    xy = white_balance_xy(f"{T}K")
    back = camera_neutral_to_xy(xy_to_camera_neutral(xy, profile), profile)
    np.testing.assert_allclose(back, xy, atol=1e-9)


def test_D65_white_balance_matches_libraw_daylight(dng_550d, raw_550d):
    import rawpy

    with rawpy.imread(str(dng_550d)) as r:  # LibRaw's daylight multipliers: D65 under the ColorMatrix
        n = 1.0 / np.asarray(r.daylight_whitebalance[:3])
    np.testing.assert_allclose(white_balance_neutral(raw_550d, "D65"), n / n.max(), atol=2e-4)


def test_illuminant_and_spot_white_balance_neutralise_grey(chart, tmp_path):
    cap, labels = chart
    path = _write(tmp_path / "a.dng", cap, neutral=[1.0, 1.0, 1.0])  # a wrong as-shot white
    raw = isp.read_raw(path)
    # the colour matrix is fitted under A: the A white's camera response is the true neutral
    np.testing.assert_allclose(white_balance_neutral(raw, "A"), cap.neutral / cap.neutral.max(), atol=2e-4)
    box = _patch_box(labels, 21)  # neutral 5
    spot = f"spot:{','.join(map(str, box))}"
    linear = dict(tonemap=None, encode=False, orient=False)
    x0, y0, x1, y1 = box
    for wb, tol in [("as-shot", None), ("A", 0.02), (spot, 0.01)]:
        rgb = isp.develop(raw, demosaic="bilinear", white_balance=wb, **linear).image[y0:y1, x0:x1]
        mean = rgb.reshape(-1, 3).mean(0)
        spread = float(np.ptp(mean / mean[1]))
        if tol is None:
            assert spread > 0.3  # unit gains under a warm light: far from grey
        else:
            assert spread < tol, (wb, mean)
    with pytest.raises(isp.PipelineError, match="outside"):
        isp.develop(raw, white_balance="spot:0,0,500,20", **linear)
    white = _patch_box(labels, 18)
    bright = raw.__class__(**{**raw.__dict__, "mosaic": np.minimum(raw.mosaic * 4, cap.white_level)})
    with pytest.raises(isp.PipelineError, match="saturated"):
        white_balance_neutral(bright, "spot:" + ",".join(map(str, white)))


def test_crw_without_as_shot_white_uses_libraws_automatic_white(crw_d30, tmp_path, capsys):
    """The D30 CRW records no as-shot white; isp took LibRaw's daylight multipliers and developed it
    orange, where rawpy's ``use_camera_wb`` (and RawTherapee) fall back to the automatic grey world.
    The truth is rawpy itself: its output with isp's neutral as ``user_wb`` equals its output with
    ``use_camera_wb=True``."""
    import rawpy

    raw = isp.read_raw(crw_d30, metadata_only=True)
    with rawpy.imread(str(crw_d30)) as r:
        assert r.camera_whitebalance[0] == -1  # LibRaw: no as-shot white balance in this file
        opts = dict(gamma=(1, 1), no_auto_bright=True, output_bps=16, output_color=rawpy.ColorSpace.raw)
        camera = r.postprocess(use_camera_wb=True, **opts).reshape(-1, 3).mean(0)
        g = 1.0 / raw.as_shot_neutral
        ours = r.postprocess(user_wb=[g[0], g[1], g[2], g[1]], **opts).reshape(-1, 3).mean(0)
        daylight = r.postprocess(**opts).reshape(-1, 3).mean(0)
    assert raw.white_balance_source == "auto"
    np.testing.assert_allclose(ours / ours[1], camera / camera[1], rtol=5e-3)
    assert abs(daylight[0] / daylight[1] - camera[0] / camera[1]) > 0.5  # the old choice was far off
    assert "automatic (grey world" in describe_white_balance(raw)
    assert main(["info", str(crw_d30), "--metadata-only"]) == 0
    out = " ".join(capsys.readouterr().out.split())
    assert "white balance source" in out and "automatic" in out and "AsShotNeutral" not in out
    assert raw.capture["iso"] == 100 and raw.capture["datetime"] == "2002:11:24 15:11:22"


def _dcraw_auto_wb(m, cfa, black, white):
    """dcraw's scale_colors auto white balance, loop for loop (the reference twin)."""
    from isp.cfa import CHANNEL_INDEX

    H, W = m.shape
    dsum = np.zeros(6)
    for row in range(0, H, 8):
        for col in range(0, W, 8):
            s = np.zeros(6)
            skip = False
            for y in range(row, min(row + 8, H)):
                for x in range(col, min(col + 8, W)):
                    c = CHANNEL_INDEX[cfa[2 * (y % 2) + x % 2]]
                    val = float(m[y, x])
                    if val > white - black - 25:
                        skip = True
                        break
                    s[c] += max(val - black, 0.0)
                    s[c + 3] += 1
                if skip:
                    break
            if not skip:
                dsum += s
    n = dsum[:3] / dsum[3:]
    return n / n.max()


@pytest.mark.parametrize("cfa", ["RGGB", "BGGR", "GRBG", "GBRG"])
@pytest.mark.parametrize("shape", [(40, 56), (45, 61)])
def test_auto_white_balance_equals_dcraws_loop(cfa, shape):
    from isp.raw import auto_white_balance

    rng = np.random.default_rng(len(cfa) + shape[0])
    m = rng.integers(60, 3000, shape).astype(np.uint16)
    m[rng.random(shape) < 0.002] = 4095  # clipped pixels: their blocks are left out
    m[rng.random(shape) < 0.002] = 4040  # above white − black − 25: left out too, as LibRaw does
    got = auto_white_balance(m, cfa, 64.0, 4095.0)
    np.testing.assert_allclose(got, _dcraw_auto_wb(m, cfa, 64.0, 4095.0), rtol=1e-12)
    assert auto_white_balance(np.full(shape, 4095, np.uint16), cfa, 64.0, 4095.0) is None  # all clipped


# -- orientation --------------------------------------------------------------------------------


def test_orient_matches_rawpy(tmp_path):
    import rawpy

    rng = np.random.default_rng(1)
    m = rng.integers(600, 700, size=(48, 80)).astype(np.uint16)
    m[4:16, 6:30] = 3800  # an asymmetric bright block near the top-left corner
    m[30:36, 60:64] = 3000
    for o in range(1, 9):
        p = isp.write_dng(
            tmp_path / f"o{o}.dng",
            m,
            cfa="RGGB",
            black_level=512,
            white_level=4095,
            color_matrix_1=np.eye(3),
            as_shot_neutral=[1, 1, 1],
            orientation=o,
        )
        raw = isp.read_raw(p)
        assert raw.orientation == o
        ours = isp.develop(raw, demosaic="bilinear", tonemap=None, encode=False).image.mean(-1)
        with rawpy.imread(str(p)) as r:
            ref = r.postprocess(
                no_auto_bright=True,
                gamma=(1, 1),
                output_bps=16,
                user_wb=[1, 1, 1, 1],
                output_color=rawpy.ColorSpace.raw,
                demosaic_algorithm=rawpy.DemosaicAlgorithm.LINEAR,
            )
        ref = ref.mean(-1)
        assert ours.shape == ref.shape
        a, b = ours > 0.5 * ours.max(), ref > 0.5 * ref.max()
        assert (a & b).sum() / (a | b).sum() > 0.9, o
    with pytest.raises(isp.PipelineError, match="orientation"):
        isp.write_dng(
            tmp_path / "bad.dng",
            m,
            cfa="RGGB",
            black_level=512,
            white_level=4095,
            color_matrix_1=np.eye(3),
            as_shot_neutral=[1, 1, 1],
            orientation=9,
        )


def test_spot_coordinates_follow_the_orientation(chart, tmp_path):
    cap, labels = chart
    x0, y0, x1, y1 = _patch_box(labels, 21)
    H, W = labels.shape
    upright = isp.read_raw(_write(tmp_path / "o1.dng", cap))
    turned = isp.read_raw(_write(tmp_path / "o6.dng", cap, orientation=6))  # shown rotated 90° clockwise
    # a stored pixel (r, c) is shown at (row c, column H - 1 - r)
    box6 = f"spot:{H - y1},{x0},{H - y0},{x1}"
    np.testing.assert_allclose(
        white_balance_neutral(turned, box6),
        white_balance_neutral(upright, f"spot:{x0},{y0},{x1},{y1}"),
        rtol=1e-12,
    )
    dev = isp.develop(turned, demosaic="bilinear")
    assert dev.image.shape == (W, H, 3)


# -- output file --------------------------------------------------------------------------------


def test_develop_writes_icc_and_camera_metadata(chart, tmp_path, capsys):
    from PIL import ImageCms

    cap, _ = chart
    src = _write(
        tmp_path / "in.dng",
        cap,
        orientation=8,
        exposure_time=1 / 250,
        iso=400,
        f_number=5.6,
        make="Canon",
        model="EOS test",
    )
    out = tmp_path / "out.tif"
    assert main(["develop", str(src), "-o", str(out), "--wb", "3200K", "--demosaic", "bilinear"]) == 0
    err = capsys.readouterr().err
    assert "[" in err and " s] demosaic" in err  # plain progress lines: stderr is not a terminal here
    assert "3200K" in " ".join(err.split()) and "Orientation 8 applied" in " ".join(err.split())
    with tifffile.TiffFile(out) as tif:
        page = tif.pages[0]
        tags = {t.code: t.value for t in page.tags.values()}
        assert page.shape == (cap.mosaic.shape[1], cap.mosaic.shape[0], 3)
    assert tags[271] == "Canon" and tags[272] == "EOS test" and tags[274] == 1
    assert tuple(tags[33434]) == (1, 250) and tags[34855] == 400
    assert tags[33437][0] / tags[33437][1] == pytest.approx(5.6)
    assert bytes(tags[34675]) == srgb_icc_profile()
    profile = ImageCms.ImageCmsProfile(__import__("io").BytesIO(bytes(tags[34675])))
    assert "sRGB" in ImageCms.getProfileDescription(profile)
    exiftool = shutil.which("exiftool")
    if exiftool:
        text = subprocess.run(
            [
                exiftool,
                "-s",
                "-Make",
                "-Model",
                "-ExposureTime",
                "-ISO",
                "-FNumber",
                "-ProfileDescription",
                str(out),
            ],
            capture_output=True,
            text=True,
            check=True,
        ).stdout
        fields = dict(line.split(":", 1) for line in text.strip().splitlines())
        fields = {k.strip(): v.strip() for k, v in fields.items()}
        assert fields == {
            "Make": "Canon",
            "Model": "EOS test",
            "ExposureTime": "1/250",
            "ISO": "400",
            "FNumber": "5.6",
            "ProfileDescription": "sRGB built-in",
        }


def test_output_tags_of_the_crw(crw_d30):
    raw = isp.read_raw(crw_d30, metadata_only=True)
    tags = {t[0]: t[3] for t in output_tags(raw)}
    assert tags[36867] == "2002:11:24 15:11:22" and tags[34855] == 100
    assert tags[33434][0] / tags[33434][1] == pytest.approx(raw.capture["exposure_time"], rel=0.01)


def test_version_and_bad_white_balance(tmp_path, capsys, dng_550d):
    with pytest.raises(SystemExit) as exc:
        main(["--version"])
    assert exc.value.code == 0 and capsys.readouterr().out.strip() == f"isp {zonotope.__version__}"
    assert main(["develop", str(dng_550d), "-o", str(tmp_path / "x.tif"), "--wb", "purple", "-q"]) == 2
    assert "white balance 'purple' is not known" in capsys.readouterr().err
    assert not (tmp_path / "x.tif").exists()
