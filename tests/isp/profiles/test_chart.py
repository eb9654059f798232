"""Profiles from a photographed chart: patch geometry, patch means, the fit against colour-science's
reference and its per-patch ΔE00, the command line, and the real Canon EOS 550D (Kiss X4) chart."""

from __future__ import annotations

import csv
import dataclasses

import colour
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from isp.profiles.chart import (
    ChartError,
    chart_patch_centres,
    chart_reference,
    fit_chart,
    read_chart,
)
from isp.simulate import chart_image, simulate_capture, simulate_dng, spectral_setup

CAMERA = "Nikon 5100 (NPL)"
PATCH, GAP = 48, 8  # RawTherapee refuses DNGs under ≈ 200 px
CORNERS = [
    (GAP + j * (PATCH + GAP) + PATCH / 2 - 0.5, GAP + i * (PATCH + GAP) + PATCH / 2 - 0.5)
    for i, j in ((0, 0), (0, 5), (3, 5), (3, 0))
]
CORNER_ARGS = [f"{x},{y}" for x, y in CORNERS]


def _capture(exposure: float = 0.8, **options):
    setup = spectral_setup(CAMERA, illuminant="D65", shape=colour.SpectralShape(400, 700, 10))
    import zonotope

    R = zonotope.resample(zonotope.reflectances("BabelColor Average"), setup.wavelengths).T
    img, _ = chart_image(np.clip(R, 0, 1), rows=4, cols=6, patch=PATCH, gap=GAP)
    return setup, R, simulate_capture(img, setup, exposure=exposure, seed=0, **options)


@pytest.fixture(scope="module")
def chart_dng(tmp_path_factory):
    setup, R, cap = _capture(full_well=np.inf, read_noise=0.0)
    path = simulate_dng(tmp_path_factory.mktemp("chart") / "chart.dng", cap, model=CAMERA)
    return path, setup, R, cap


@settings(max_examples=30, deadline=None)
@given(
    st.floats(-0.3, 0.3), st.floats(0.5, 3.0), st.floats(0.5, 3.0), st.floats(-0.2, 0.2), st.floats(0, 500)
)
def test_affine_corners_give_the_affine_grid(angle, sx, sy, shear, offset):
    """An affine chart (no perspective): the homography's centres are the affine images of the grid."""
    A = np.array([[np.cos(angle), -np.sin(angle)], [np.sin(angle), np.cos(angle)]]) @ np.array(
        [[sx * 50, shear * 50], [0, sy * 50]]
    )
    grid = np.array([(j, i) for i in range(4) for j in range(6)], dtype=float)
    pts = grid @ A.T + offset
    corners = pts[[0, 5, 23, 18]]
    np.testing.assert_allclose(chart_patch_centres(corners, 4, 6), pts, atol=1e-6 * (1 + offset))


def test_patch_means_are_the_simulated_responses(chart_dng):
    import isp

    path, setup, R, _ = chart_dng
    raw = isp.read_raw(path)
    reading = read_chart(raw, CORNERS)
    # noise-free capture: each patch's raw response is the camera's white-balanced response to its
    # reflectance (Φ: the white at 1) times the camera neutral, at one exposure for all
    truth = (np.clip(R, 0, 1) @ setup.generators.Phi) * setup.neutral
    ratio = reading.rgb / truth
    np.testing.assert_allclose(ratio / ratio.mean(), 1.0, rtol=2e-3)
    assert reading.camera.endswith(CAMERA)


def test_fit_reaches_the_white_preserving_optimum(chart_dng):
    """The refined matrix minimises Σ ΔE00² over the matrices that keep the white: a BFGS search
    from colour-science's least squares (``matrix_colour_correction``, Cheung 2004, 3 terms,
    projected on the white constraint) finds nothing better; every reported ΔE00 is
    colour-science's CIE 2000 of the reported XYZ."""
    from scipy.optimize import minimize

    import isp

    path, *_ = chart_dng
    reading = read_chart(isp.read_raw(path), CORNERS)
    fit = fit_chart(reading, illuminant="D65")
    ref, _, white = chart_reference("colorchecker", "D65")
    c = reading.rgb / fit.neutral
    wxy = colour.XYZ_to_xy(white)

    def dE(M):
        return colour.delta_E(colour.XYZ_to_Lab(c @ M.T, wxy), colour.XYZ_to_Lab(ref, wxy), method="CIE 2000")

    M0 = colour.characterisation.matrix_colour_correction(c, ref, method="Cheung 2004", terms=3)
    M0 = M0 + np.outer(white - M0 @ np.ones(3), np.ones(3)) / 3  # the nearest matrix keeping the white

    def family(p):
        return M0 + np.column_stack([p.reshape(3, 2), -p.reshape(3, 2).sum(1)])

    best = minimize(lambda p: np.sum(dE(family(p)) ** 2), np.zeros(6), method="BFGS")
    assert np.sum(fit.delta_E**2) <= best.fun * (1 + 1e-3)
    assert fit.delta_E.mean() <= fit.delta_E_linear.mean()
    assert fit.delta_E.mean() < 1.5  # a real camera's sensitivities under the fit illuminant, noise-free
    again = colour.delta_E(colour.XYZ_to_Lab(fit.fitted, wxy), colour.XYZ_to_Lab(ref, wxy), method="CIE 2000")
    np.testing.assert_allclose(fit.delta_E, again, atol=1e-9)
    np.testing.assert_allclose(fit.matrix @ np.ones(3), white, atol=1e-9)  # the white exact
    D50 = colour.xy_to_XYZ(colour.CCS_ILLUMINANTS["CIE 1931 2 Degree Standard Observer"]["D50"])
    np.testing.assert_allclose(fit.forward_matrix @ np.ones(3), D50, atol=1e-12)


def test_clipped_and_dark_charts_are_refused(chart_dng):
    import isp

    path, *_ = chart_dng
    raw = isp.read_raw(path)
    clipped = raw.mosaic.copy()
    clipped[clipped > np.percentile(clipped, 90)] = int(raw.white_level)
    with pytest.raises(ChartError, match=r"patch \d+ is clipped"):
        read_chart(dataclasses.replace(raw, mosaic=clipped), CORNERS)
    dark = (raw.mosaic.astype(np.int64) - raw.black_level[0, 0]) // 200 + raw.black_level[0, 0]
    with pytest.raises(ChartError, match="brightest neutral patch"):
        read_chart(dataclasses.replace(raw, mosaic=dark.astype(np.uint16)), CORNERS)
    with pytest.raises(ChartError, match="outside"):
        read_chart(raw, [(x + 10_000, y) for x, y in CORNERS])
    with pytest.raises(ChartError, match="one line"):
        read_chart(raw, [(0, 0), (10, 10), (20, 20), (30, 30)])


def test_cli_chart_profile_and_errors(chart_dng, tmp_path, capsys):
    from isp.cli import main
    from isp.profiles.dcp import read_dcp
    from isp.profiles.icc import ICC_D50, read_icc_matrix

    path, *_ = chart_dng
    out = tmp_path / "out"
    out.mkdir()
    argv = ["profile", "--chart", str(path), "--chart-corners", *CORNER_ARGS, "--illuminant", "D65"]
    assert main([*argv, "-o", str(out / "cam.dcp"), "--icc", str(out / "cam.icc")]) == 0
    err = capsys.readouterr().err
    assert "ΔE00 over 24 patches: mean" in err
    dcp = read_dcp(out / "cam.dcp")
    assert dcp.tone_curve is not None and dcp.calibration_illuminant_1 == 21
    M, _ = read_icc_matrix(out / "cam.icc")
    FM = dcp.forward_matrix_1
    FM = np.diag(ICC_D50 / (FM @ np.ones(3))) @ FM  # the ICC's white is its PCS white, D50 to 4 decimals
    np.testing.assert_allclose(M, FM, atol=1e-4)  # s15Fixed16 and SRATIONAL/10000
    rows = list(csv.DictReader(open(out / "cam_patches.csv")))
    assert len(rows) == 24 and rows[18]["name"] == "white 9.5 (.05 D)"
    assert {r["illuminant"] for r in rows} == {"D65"}  # the light, for zonotope ssf estimate --chart
    assert "<table>" in (out / "cam_patches.html").read_text()
    # rerun with --overwrite replaces our own outputs; a user's file of the same name is kept
    assert main([*argv, "-o", str(out / "cam.dcp"), "--overwrite", "--no-tone-curve"]) == 0
    assert read_dcp(out / "cam.dcp").tone_curve is None
    mine = tmp_path / "mine_patches.csv"
    mine.write_text("my notes\n")
    assert main([*argv, "-o", str(tmp_path / "mine.dcp"), "--overwrite"]) == 2
    assert "not written by isp profile" in capsys.readouterr().err and mine.read_text() == "my notes\n"
    assert not (tmp_path / "mine.dcp").exists()
    # a report of an earlier version (no illuminant column) is still recognised as isp's own
    old = (out / "cam_patches.csv").read_text().splitlines()
    (out / "cam_patches.csv").write_text("\n".join(line.rsplit(",", 1)[0] for line in old) + "\n")
    assert main([*argv, "-o", str(out / "cam.dcp"), "--overwrite"]) == 0
    assert (out / "cam_patches.csv").read_text().splitlines()[0].endswith(",illuminant")
    capsys.readouterr()
    for bad, message in (
        (["--chart-corners", "1,2", "3,4", "5", "6,7"], "--chart-corners 1,2 3,4 5 6,7: give four X,Y"),
        (["--chart-corners", *CORNER_ARGS, "--illuminant", "XYZ"], "illuminant 'XYZ'"),
        (["--chart-corners", *CORNER_ARGS, "--illuminant", "FL2"], "--illuminant FL2: a DCP names"),
        (
            ["--chart-corners", *CORNER_ARGS, "--lut", "x.cube"],
            "--lut applies to a profile from sensitivities",
        ),
    ):
        assert main(["profile", "--chart", str(path), *bad, "-o", str(tmp_path / "bad.dcp")]) == 2
        e = capsys.readouterr().err
        assert e.startswith("isp: error: ") and message in e and e.count("\n") == 1, e
    assert not (tmp_path / "bad.dcp").exists()


def test_real_550d_chart(dng_550d, tmp_path, capsys):
    """The Canon EOS Kiss X4 DNG of ../shared/data: the profile is named for the EOS 550D (the same
    camera) and the fit reproduces BabelColor's chart within a few ΔE00."""
    if not dng_550d.is_file():
        pytest.skip(f"{dng_550d} not present")
    from isp.cli import main
    from isp.profiles.dcp import read_dcp

    corners = ["712,624", "1250,624", "1250,930", "712,930"]  # patch centres in the file's active area
    argv = ["profile", "--chart", str(dng_550d), "--chart-corners", *corners, "--illuminant", "A"]
    assert main([*argv, "-o", str(tmp_path / "x4.dcp")]) == 0
    capsys.readouterr()
    assert read_dcp(tmp_path / "x4.dcp").unique_camera_model == "Canon EOS 550D"
    rows = list(csv.DictReader(open(tmp_path / "x4_patches.csv")))
    lab = np.array(
        [[float(r[k]) for k in ("ref_L", "ref_a", "ref_b", "fit_L", "fit_a", "fit_b")] for r in rows]
    )
    dE = colour.delta_E(lab[:, :3], lab[:, 3:], method="CIE 2000")
    np.testing.assert_allclose(dE, [float(r["dE00"]) for r in rows], atol=1e-3)
    assert dE.mean() < 4.0  # measured 2.4 under A (flare lifts the black patch to 8.5)


def test_rawtherapee_applies_our_icc_and_dcp_as_isp_does(chart_dng, tmp_path, capsys):
    """RawTherapee (an independent ICC and DCP reader) develops the chart with our ICC profile and
    with our DCP as ``isp develop --profile`` does with the DCP; an ICC with another matrix changes
    its colours (the profile is used, not ignored)."""
    from isp.profiles.rawtherapee import develop_rawtherapee, rawtherapee_cli

    if rawtherapee_cli() is None:
        pytest.skip("rawtherapee-cli not installed")
    import isp
    from isp.cli import main
    from isp.profiles.dcp import dcp_stage, read_dcp
    from isp.profiles.icc import icc_profile, read_icc_matrix, write_icc

    path, *_ = chart_dng
    argv = ["profile", "--chart", str(path), "--chart-corners", *CORNER_ARGS, "--illuminant", "D65"]
    argv += ["--no-tone-curve", "-o", str(tmp_path / "c.dcp"), "--icc", str(tmp_path / "c.icc")]
    assert main(argv) == 0
    capsys.readouterr()
    centres = chart_patch_centres(CORNERS, 4, 6).round().astype(int)

    def boxes(X, off=(0, 0)):
        m = np.array(
            [
                X[y - off[0] - 6 : y - off[0] + 6, x - off[1] - 6 : x - off[1] + 6].mean((0, 1))
                for x, y in centres
            ]
        )
        return colour.XYZ_to_Lab(
            m / m[18, 1], colour.CCS_ILLUMINANTS["CIE 1931 2 Degree Standard Observer"]["D50"]
        )

    pipeline = isp.default_pipeline(tonemap=None, encode=False)
    pipeline = pipeline.replace("camera_to_XYZ", dcp_stage(read_dcp(tmp_path / "c.dcp")))
    ours = boxes(isp.develop(path, pipeline=pipeline, stop_after="camera_to_XYZ").image)
    for prof in (tmp_path / "c.icc", tmp_path / "c.dcp"):
        rt = develop_rawtherapee(path, profile=prof)
        assert colour.delta_E(boxes(rt.XYZ, rt.offset), ours, method="CIE 2000").mean() < 0.5
    M, _ = read_icc_matrix(tmp_path / "c.icc")  # a desaturating matrix (white kept) desaturates
    write_icc(tmp_path / "other.icc", icc_profile(M @ (0.7 * np.eye(3) + 0.1), description="other"))
    other = develop_rawtherapee(path, profile=tmp_path / "other.icc")
    assert colour.delta_E(boxes(other.XYZ, other.offset), ours, method="CIE 2000").mean() > 2.0
