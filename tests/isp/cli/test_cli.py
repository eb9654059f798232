"""isp.cli: the ``isp`` command on a crop of the real 550D DNG and on a small simulated DNG (outputs go
to tmp_path)."""

from __future__ import annotations

import subprocess
import sys

import colour
import numpy as np
import pytest
import tifffile

import zonotope
from isp.cli import main
from isp.simulate import chart_image, simulate_capture, simulate_dng, spectral_setup, true_XYZ

CROP = ["--crop", "560", "640", "64", "96"]
CAMERA = "Nikon 5100 (NPL)"
#: ColorChecker patches of the simulated chart: dark skin, blue, green, red, yellow, neutral 5.
PATCHES = [0, 12, 13, 14, 15, 21]
D65_xy = colour.CCS_ILLUMINANTS["CIE 1931 2 Degree Standard Observer"]["D65"]


def test_develop_png_and_stages(dng_550d, tmp_path):
    out = tmp_path / "out.png"
    stages = tmp_path / "stages"
    rc = main(
        [
            "develop",
            str(dng_550d),
            "-o",
            str(out),
            "--demosaic",
            "bilinear",
            *CROP,
            "--save-stages",
            str(stages),
            "-q",
        ]
    )
    assert rc == 0
    assert out.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    names = sorted(p.name for p in stages.iterdir())
    assert names[0] == "00_input.tif" and names[-2:] == ["07_encode_sRGB.tif", "08_orient.tif"]
    demosaiced = tifffile.imread(stages / "03_demosaic.tif")
    assert demosaiced.shape == (64, 96, 3) and demosaiced.dtype == np.float32
    # refuses to overwrite without --overwrite
    assert main(["develop", str(dng_550d), "-o", str(out), *CROP, "-q"]) == 2


def test_develop_tiff_clip(dng_550d, tmp_path):
    out = tmp_path / "out.tif"
    assert (
        main(["develop", str(dng_550d), "-o", str(out), *CROP, "--tonemap", "clip", "--exposure", "1", "-q"])
        == 0
    )
    img = tifffile.imread(out)
    assert img.dtype == np.uint16 and img.shape == (64, 96, 3)
    reinhard = ["--tonemap", "Reinhard 2002", "--exposure", "1", "-q"]  # its exposure is the image's
    assert main(["develop", str(dng_550d), "-o", str(tmp_path / "b.tif"), *reinhard]) == 2
    assert (
        main(["develop", str(dng_550d), "-o", str(tmp_path / "c.tif"), *CROP, "--exposure", "-1", "-q"]) == 0
    )
    darker = tifffile.imread(tmp_path / "c.tif")  # the default auto-bright, one stop under: darker
    default = tmp_path / "d.tif"
    assert main(["develop", str(dng_550d), "-o", str(default), *CROP, "-q"]) == 0
    assert np.median(darker) < np.median(tifffile.imread(default))


def test_errors_exit_2(tmp_path, capsys):
    bad = tmp_path / "notes.dng"
    bad.write_text("not a raw file")
    assert main(["develop", str(bad), "-o", str(tmp_path / "x.png"), "-q"]) == 2
    assert "not a readable RAW file" in capsys.readouterr().err
    assert main(["develop", str(bad), "-o", str(bad), "-q"]) == 2
    assert bad.read_text() == "not a raw file"
    assert main(["develop", str(tmp_path / "missing.dng"), "-o", str(tmp_path / "x.png"), "-q"]) == 2
    with pytest.raises(SystemExit):
        main(["develop"])


def test_python_m_isp_info(dng_350d):
    res = subprocess.run(
        [sys.executable, "-m", "isp", "info", str(dng_350d), "--metadata-only"],
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert res.returncode == 0, res.stderr
    assert "350D" in res.stdout and "0.6018" in res.stdout


def test_unknown_output_format_is_refused_before_developing(dng_550d, tmp_path, capsys):
    """``-o x.jpg`` was refused only after the whole development (minutes with a metamer fit)."""
    assert main(["develop", str(dng_550d), "-o", str(tmp_path / "x.jpg")]) == 2
    err = capsys.readouterr().err
    assert "unknown image format '.jpg'" in err and "linearise" not in err  # no stage ran
    assert not list(tmp_path.iterdir())


@pytest.mark.parametrize("option", ["--demosaic", "--tonemap"])
def test_unknown_method_names_are_refused_before_reading(tmp_path, capsys, option):
    """An unknown --demosaic/--tonemap name was refused only when the pipeline was built, after
    the metamer fit (minutes); now before any file is read (this input does not even exist)."""
    assert (
        main(["develop", str(tmp_path / "missing.dng"), "-o", str(tmp_path / "x.tif"), option, "bogus"]) == 2
    )
    err = " ".join(capsys.readouterr().err.split())
    assert option in err and "bogus" in err and "missing.dng" not in err
    assert not list(tmp_path.iterdir())


def test_info_prints_the_make_once_and_names_the_cli_option(dng_550d, dng_350d, capsys):
    """The 550D DNG's Model tag repeats its Make ('Canon' + 'Canon EOS Kiss X4'), which printed as
    'Canon Canon EOS Kiss X4'; a file without pixel data pointed at a Python call, not the option."""
    assert main(["info", str(dng_550d)]) == 0
    out = " ".join(capsys.readouterr().out.split())
    assert "│ Canon EOS Kiss X4 │" in out and "Canon Canon" not in out
    assert main(["info", str(dng_350d)]) == 2
    err = capsys.readouterr().err
    assert "no pixel data" in err and "isp info --metadata-only" in err


# ---------------------------------------------------------------------------------------------
# --correction metamer, on a simulated DNG of a camera whose sensitivities are known
# ---------------------------------------------------------------------------------------------


@pytest.fixture(scope="module")
def simulated(tmp_path_factory):
    """A noise-free 24 × 36 DNG of 6 ColorChecker patches (few distinct colours: quick metamer correction;
    LibRaw refuses images under 22 pixels a side)."""
    setup = spectral_setup(CAMERA, illuminant="D65")
    R = zonotope.resample(zonotope.reflectances("ColorChecker N Ohta"), setup.wavelengths).T[PATCHES]
    image, labels = chart_image(R, rows=2, cols=3, patch=12, gap=0)
    train = zonotope.resample(zonotope.reflectances("rawtoaces 190"), setup.wavelengths).T
    cap = simulate_capture(image, setup, training=train, full_well=np.inf, read_noise=0)
    path = simulate_dng(tmp_path_factory.mktemp("sim") / "chart.dng", cap, model=CAMERA)
    return path, labels, true_XYZ(R, setup), setup.observer.sum(0), cap.exposure


def _patch_Lab(tif, simulated):
    """CIELAB (D65) of the patch interiors of a developed (tonemap none) TIFF, and of the truth."""
    _, labels, truth, white, exposure = simulated
    rgb = colour.cctf_decoding(tifffile.imread(tif) / 65535.0, function="sRGB")
    XYZ = colour.RGB_to_XYZ(rgb, "sRGB", illuminant=D65_xy) / exposure
    means = []
    for k in range(len(PATCHES)):
        ys, xs = np.nonzero(labels == k)
        means.append(XYZ[ys.min() + 2 : ys.max() - 1, xs.min() + 2 : xs.max() - 1].reshape(-1, 3).mean(0))
    D65 = colour.xy_to_XYZ(D65_xy)
    ref = colour.chromatic_adaptation(truth, white, D65, method="Von Kries", transform="Bradford")
    return colour.XYZ_to_Lab(np.array(means), D65_xy), colour.XYZ_to_Lab(ref, D65_xy)


@pytest.mark.slow  # 8 s on a loaded 2-core machine: a metamer fit and a full development
def test_develop_metamer_close_to_truth_and_dng(simulated, tmp_path, capsys):
    src = simulated[0]
    dng, metamer = tmp_path / "dng.tif", tmp_path / "metamer.tif"
    stages = tmp_path / "stages"
    common = ["--demosaic", "bilinear", "--tonemap", "none"]
    assert main(["develop", str(src), "-o", str(dng), *common, "-q"]) == 0
    assert (
        main(
            [
                "develop",
                str(src),
                "-o",
                str(metamer),
                *common,
                "--correction",
                "metamer",
                "--camera",
                CAMERA,
                "--save-stages",
                str(stages),
            ]
        )
        == 0
    )
    err = capsys.readouterr().err
    assert (
        f"metamer correction {zonotope.correct.IMAGE_METHOD}" in err and "warning" not in err
    )  # AsShotNeutral matches D65
    img = tifffile.imread(metamer)
    assert img.dtype == np.uint16 and img.shape == (24, 36, 3)
    assert sorted(p.name for p in stages.iterdir())[3:5] == ["03_demosaic.tif", "04_camera_to_XYZ.tif"]
    (lab_dng, truth), (lab_metamer, _) = _patch_Lab(dng, simulated), _patch_Lab(metamer, simulated)
    dE_metamer = colour.delta_E(lab_metamer, truth, method="CIE 2000")
    assert dE_metamer.mean() < 1.2 and dE_metamer.max() < 2.0, dE_metamer  # measured 0.63 / 1.21
    assert colour.delta_E(lab_dng, truth, method="CIE 2000").max() < 3.5  # measured 2.58 (red)
    # the same picture as the DNG path (both white-balanced on AsShotNeutral, white → D65), up to
    # the difference between the estimators on these saturated patches
    assert colour.delta_E(lab_metamer, lab_dng, method="CIE 2000").max() < 3.0


def test_develop_metamer_other_estimator_and_camera_file(simulated, tmp_path):
    src = simulated[0]
    csv = tmp_path / "nikon.csv"
    cam = zonotope.camera(CAMERA)
    np.savetxt(
        csv,
        np.column_stack([cam.wavelengths, cam.values]),
        delimiter=",",
        header="wavelength,red,green,blue",
        comments="",
    )
    out = tmp_path / "root_poly.png"
    assert (
        main(
            [
                "develop",
                str(src),
                "-o",
                str(out),
                "--correction",
                "metamer",
                "--camera",
                str(csv),
                "--method",
                "root-polynomial",
                "--illuminant",
                "D65",
                "--training",
                "ColorChecker N Ohta",
                "--scene-white",
                "0.8",
                "--quantum",
                "0",
                "-q",
            ]
        )
        == 0
    )
    assert out.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def test_develop_metamer_warns_on_another_illuminant(simulated, tmp_path, capsys):
    """The file was white-balanced for D65: fitting for illuminant A is flagged (and still runs)."""
    assert (
        main(
            [
                "develop",
                str(simulated[0]),
                "-o",
                str(tmp_path / "a.tif"),
                "--correction",
                "metamer",
                "--camera",
                CAMERA,
                "--method",
                "root-polynomial",
                "--illuminant",
                "A",
                "-q",
            ]
        )
        == 0
    )
    err = " ".join(capsys.readouterr().err.split())
    assert "warning: the file's AsShotNeutral differs by" in err and "under A" in err


@pytest.mark.parametrize(
    ("options", "message"),
    [
        (["--correction", "metamer"], "--correction metamer needs --camera"),
        (["--camera", CAMERA], "--camera applies to --correction metamer only"),
        (["--method", "Prior", "--illuminant", "A"], "--method, --illuminant apply to --correction metamer"),
        (["--correction", "metamer", "--camera", "Nikon 9999"], "unknown camera 'Nikon 9999'"),
        (
            ["--correction", "metamer", "--camera", "missing/ssf.json"],
            "camera file missing/ssf.json not found",
        ),
        (["--correction", "metamer", "--camera", CAMERA, "--method", "best"], "not a correction method"),
        (["--correction", "metamer", "--camera", CAMERA, "--illuminant", "D66"], "unknown illuminant 'D66'"),
        (["--correction", "metamer", "--camera", CAMERA, "--training", "nope"], "unknown reflectance set"),
        (
            ["--correction", "metamer", "--camera", CAMERA, "--quantum", "-1"],
            "--quantum -1.0: must be a finite number ≥ 0",
        ),
        (
            ["--correction", "metamer", "--camera", CAMERA, "--scene-white", "0"],
            "--scene-white 0: must be > 0",
        ),
        (["--scene-white", "0.5"], "--scene-white applies to --correction metamer only"),
    ],
)
def test_metamer_errors_exit_2(simulated, tmp_path, capsys, options, message):
    out = tmp_path / "x.tif"
    assert main(["develop", str(simulated[0]), "-o", str(out), "-q", *options]) == 2
    err = capsys.readouterr().err
    assert message in err.replace("\n", " ") and "Traceback" not in err
    assert not out.exists()


def test_metamer_unreadable_camera_file(simulated, tmp_path, capsys):
    bad = tmp_path / "ssf.json"
    bad.write_text("{ not json")
    assert (
        main(
            [
                "develop",
                str(simulated[0]),
                "-o",
                str(tmp_path / "x.tif"),
                "-q",
                "--correction",
                "metamer",
                "--camera",
                str(bad),
            ]
        )
        == 2
    )
    assert "cannot read camera" in capsys.readouterr().err
