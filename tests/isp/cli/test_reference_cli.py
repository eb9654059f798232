"""``isp develop --correction metamer --reference LIGHT``: a scene shot under A developed to its colours as
under D65, on a small simulated DNG (few distinct colours: quick fits)."""

from __future__ import annotations

import json

import colour
import numpy as np
import pytest
import tifffile

import zonotope
from isp._tol import REFERENCE_GREY_CHROMA
from isp.cli import main
from isp.simulate import chart_image, simulate_capture, simulate_dng, spectral_setup

CAMERA = "Nikon 5100 (NPL)"
#: ColorChecker patches: dark skin, blue sky, foliage, blue, green, red, yellow; then a flat 0.4 grey.
PATCHES = [0, 2, 3, 12, 13, 14, 15]
D65_xy = colour.CCS_ILLUMINANTS["CIE 1931 2 Degree Standard Observer"]["D65"]
FIT = ["--correction", "metamer", "--camera", CAMERA, "--illuminant", "A", "--method", "root-polynomial"]
COMMON = ["--demosaic", "bilinear", "--tonemap", "none", "--noise", "0", "-q"]


@pytest.fixture(scope="module")
def tungsten(tmp_path_factory):
    """A noise-free 24 × 48 DNG of the chart under A (AsShotNeutral: the camera's white under A), the
    patch labels, the patches' XYZ under D65 (colour-science, CIE 1931 2°, Y_white = 1) and the exposure."""
    setup = spectral_setup(CAMERA, illuminant="A")
    w = setup.wavelengths
    R = zonotope.resample(zonotope.reflectances("ColorChecker N Ohta"), w).T[PATCHES]
    R = np.vstack([R, np.full(w.size, 0.4)])
    image, labels = chart_image(R, rows=2, cols=4, patch=12, gap=0)
    train = zonotope.resample(zonotope.reflectances("rawtoaces 190"), w).T
    cap = simulate_capture(image, setup, training=train, full_well=np.inf, read_noise=0)
    path = simulate_dng(tmp_path_factory.mktemp("tungsten") / "chart.dng", cap, model=CAMERA)
    shape = colour.SpectralShape(w[0], w[-1], w[1] - w[0])
    cmfs = colour.MSDS_CMFS["CIE 1931 2 Degree Standard Observer"].copy().align(shape)
    d65 = colour.SDS_ILLUMINANTS["D65"].copy().align(shape)
    sds = colour.MultiSpectralDistributions(np.column_stack([R.T, np.ones(w.size)]), w)
    XYZ = colour.msds_to_XYZ(sds, cmfs, d65, method="Integration", shape=shape)
    return path, labels, XYZ[:-1] / XYZ[-1, 1], cap.exposure


def _patch_Lab(tif, labels, exposure, n):
    """CIELAB (D65) of the patch interiors of a developed (tonemap none) 16-bit sRGB TIFF."""
    rgb = colour.cctf_decoding(tifffile.imread(tif) / 65535.0, function="sRGB")
    XYZ = colour.RGB_to_XYZ(rgb, "sRGB", illuminant=D65_xy) / exposure
    means = []
    for k in range(n):
        ys, xs = np.nonzero(labels == k)
        means.append(XYZ[ys.min() + 2 : ys.max() - 1, xs.min() + 2 : xs.max() - 1].reshape(-1, 3).mean(0))
    return colour.XYZ_to_Lab(np.array(means), D65_xy)


def test_reference_d65_is_neutral_and_closer_to_the_d65_colours(tungsten, tmp_path, capsys):
    """Under A with ``--reference D65``: the grey stays neutral in the sRGB output and the chart is
    closer to its D65 colours than the default (colours under A, adapted to D65 by the pipeline)."""
    src, labels, truth, exposure = tungsten
    ref, under_a = tmp_path / "ref.tif", tmp_path / "a.tif"
    assert main(["develop", str(src), "-o", str(ref), *FIT, "--reference", "D65", *COMMON[:-1]]) == 0
    assert "colours as under D65" in " ".join(capsys.readouterr().err.split())
    assert main(["develop", str(src), "-o", str(under_a), *FIT, *COMMON]) == 0
    n = len(PATCHES) + 1
    lab_ref, lab_a = (_patch_Lab(p, labels, exposure, n) for p in (ref, under_a))
    lab_true = colour.XYZ_to_Lab(truth, D65_xy)
    chroma = np.hypot(*lab_ref[-1, 1:])
    assert chroma < REFERENCE_GREY_CHROMA, chroma
    dE_ref = colour.delta_E(lab_ref[:-1], lab_true[:-1], method="CIE 2000")
    dE_a = colour.delta_E(lab_a[:-1], lab_true[:-1], method="CIE 2000")
    assert dE_ref.mean() < dE_a.mean(), (dE_ref, dE_a)


def test_folder_settings_record_the_reference(tungsten, tmp_path):
    folder = tmp_path / "in"
    folder.mkdir()
    (folder / "chart.dng").write_bytes(tungsten[0].read_bytes())
    out = tmp_path / "out"
    argv = ["develop", str(folder), "-o", str(out), *FIT, *COMMON, "--scheduler", "serial"]
    assert main([*argv, "--reference", "D65"]) == 0
    settings = json.loads((out / "manifest.settings.json").read_text())
    assert settings["reference"] == "colours as under D65"
    assert main([*argv, "--reference", "D50"]) != 0  # another reference: not resumed into this folder


@pytest.mark.parametrize(
    ("options", "message"),
    [
        ([*FIT, "--reference", "D66"], "--reference D66: unknown illuminant 'D66'"),
        (
            ["--correction", "metamer", "--camera", CAMERA, "--illuminant", "tungsten"],
            "--illuminant tungsten",
        ),
        (["--reference", "D65"], "--reference applies to --correction metamer only"),
    ],
)
def test_bad_lights_are_one_line(tungsten, tmp_path, capsys, options, message):
    assert main(["develop", str(tungsten[0]), "-o", str(tmp_path / "x.tif"), *options, "-q"]) == 2
    err = capsys.readouterr().err.strip()
    assert "\n" not in err and message in err, err
    if "unknown" in message:
        assert "D65" in err and "LED-B1" in err
    assert not (tmp_path / "x.tif").exists()
