"""``zonotope correct --reference``: colours as under another light than the scene's, on a tiny chart."""

from __future__ import annotations

import colour
import numpy as np
import pytest
import tifffile

import zonotope
from zonotope._tol import REFERENCE_CLI_GREY_CHROMA
from zonotope.cli import main

CAMERA = "Nikon 5100 (NPL)"
GRID = np.arange(400, 701, 10.0)
OBSERVER = "CIE 2015 2 Degree Standard Observer"


@pytest.fixture(scope="module")
def chart(tmp_path_factory):
    """The 24 ColorChecker patches and a spectrally flat grey (last), 4 × 4 pixels each, as the camera
    sees them under A (white-balanced: the white gives 1), and their XYZ under D65 (colour-science)."""
    R = zonotope.resample(zonotope.reflectances("ColorChecker N Ohta"), GRID).T
    R = np.vstack([R, np.full(GRID.size, 0.4)])
    Phi = zonotope.generators(CAMERA, "A", GRID).values
    img = np.repeat(np.repeat((R @ Phi).reshape(5, 5, 3), 4, 0), 4, 1).astype(np.float32)
    folder = tmp_path_factory.mktemp("ref") / "in"
    folder.mkdir()
    tifffile.imwrite(folder / "chart.tif", img, photometric="rgb")
    shape = colour.SpectralShape(400, 700, 10)
    cmfs = colour.MSDS_CMFS[OBSERVER].copy().align(shape)
    d65 = colour.SDS_ILLUMINANTS["D65"].copy().align(shape)
    sds = colour.MultiSpectralDistributions(np.column_stack([R.T, np.ones(GRID.size)]), GRID)
    XYZ = colour.msds_to_XYZ(sds, cmfs, d65, method="Integration", shape=shape) / 100
    return folder, XYZ[:-1], XYZ[-1]


def _run(folder, out, *extra):
    argv = ["correct", str(folder), "-o", str(out), "--camera", CAMERA, "--illuminant", "A"]
    argv += ["--method", "Finlayson 2015", "--noise", "0", "--scheduler", "serial", *extra]
    return main(argv)


def _patches(path) -> np.ndarray:
    return tifffile.imread(path)[2::4, 2::4].reshape(-1, 3).astype(np.float64)


def test_reference_d65_beats_the_scene_light_and_an_adaptation(chart, tmp_path, capsys):
    """Scene lit by A: with ``--reference D65`` the flat grey comes out neutral for D65 (within the
    regression's own error at the white) and the chart is closer to its D65 colours than the default
    output (colours under A) adapted to D65 by CAT02."""
    folder, truth, white = chart
    assert _run(folder, tmp_path / "d65", "--reference", "D65") == 0
    assert "colours as under D65" in capsys.readouterr().err
    assert _run(folder, tmp_path / "a") == 0
    assert "colours as under A" in capsys.readouterr().err
    out = tmp_path / "d65" / "chart_XYZ.tif"
    with tifffile.TiffFile(out) as tif:
        assert "colours as under D65" in tif.pages[0].description
    settings = (tmp_path / "d65" / "manifest.settings.json").read_text()
    assert "colours as under D65" in settings
    assert "reference" not in (tmp_path / "a" / "manifest.settings.json").read_text()

    xy_white = colour.XYZ_to_xy(white)
    lab_true = colour.XYZ_to_Lab(truth, xy_white)
    lab_ref = colour.XYZ_to_Lab(_patches(out), xy_white)
    under_a = _patches(tmp_path / "a" / "chart_XYZ.tif")
    white_a = zonotope.correct.correction_problem(CAMERA, illuminant="A", shape=GRID).white_XYZ
    adapted = colour.chromatic_adaptation(under_a, white_a, white, method="Von Kries", transform="CAT02")
    lab_cat = colour.XYZ_to_Lab(adapted, xy_white)
    chroma = np.hypot(*lab_ref[-1, 1:])  # the grey, in CIELAB relative to D65
    assert chroma < REFERENCE_CLI_GREY_CHROMA, chroma
    assert chroma < np.hypot(*colour.XYZ_to_Lab(under_a[-1], xy_white)[1:]) / 10  # under A: orange
    dE_ref = colour.delta_E(lab_ref[:24], lab_true[:24], method="CIE 2000")
    dE_cat = colour.delta_E(lab_cat[:24], lab_true[:24], method="CIE 2000")
    assert dE_ref.mean() < dE_cat.mean(), (dE_ref.mean(), dE_cat.mean())


def test_a_folder_is_not_resumed_with_another_reference(chart, tmp_path, capsys):
    folder = chart[0]
    assert _run(folder, tmp_path / "o", "--reference", "D65", "-q") == 0
    assert _run(folder, tmp_path / "o", "--reference", "D50", "-q") == 2
    assert "other settings" in capsys.readouterr().err


@pytest.mark.parametrize("flag", ["--reference", "--illuminant"])
def test_unknown_light_is_one_line_listing_the_lights(chart, tmp_path, capsys, flag):
    argv = ["correct", str(chart[0]), "-o", str(tmp_path / "o"), "--camera", CAMERA, flag, "D66"]
    assert main(argv) == 2
    err = capsys.readouterr().err.strip()
    assert "\n" not in err and f"{flag} D66" in err and "D65" in err and "LED-B1" in err
    assert not (tmp_path / "o").exists()
