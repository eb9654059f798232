"""Every file the ``zonotope`` and ``isp`` commands write gets the user's umask permissions.

Regression (issue 13 item 9): ``isp profile`` wrote its ``.dcp``, ``.cube`` and ``.npz`` files with
mode 0600 (``tempfile.mkstemp`` + rename) while TIFFs got 0644. Every writer now goes through
``zonotope``'s atomic writers (:func:`zonotope.atomic_path`), which give files ``0o666 & ~umask``.
The commands run in this process under umask 027 (so a file must come out 0640 and a folder 0750:
neither tempfile's 0600/0700 nor the default 0644/0755), and every path they leave is checked.
"""

from __future__ import annotations

import os
import stat
from pathlib import Path

import numpy as np
import pytest

import zonotope

UMASK = 0o027
CAMERA = "Nikon 5100 (NPL)"
GRID = ["--start", "400", "--end", "700", "--interval", "10"]


@pytest.fixture
def umask027():
    old = os.umask(UMASK)
    try:
        yield
    finally:
        os.umask(old)


def _modes(root: Path) -> dict[str, int]:
    """Permission bits of every path under ``root`` (``root`` itself excluded)."""
    return {str(p.relative_to(root)): stat.S_IMODE(p.lstat().st_mode) for p in sorted(root.rglob("*"))}


def _check(root: Path, expected_files: set[str]) -> None:
    modes = _modes(root)
    missing = expected_files - set(modes)
    assert not missing, f"not written: {sorted(missing)} (wrote {sorted(modes)})"
    wrong = {
        name: oct(mode)
        for name, mode in modes.items()
        if mode != (0o750 if (root / name).is_dir() else 0o640)
    }
    assert not wrong, f"umask {oct(UMASK)}: files must be 0o640, folders 0o750; got {wrong}"


@pytest.fixture(scope="module")
def simulated_dng(tmp_path_factory):
    """A small noise-free simulated DNG (24 × 36 px, 6 ColorChecker patches), written by isp itself."""
    from isp.simulate import chart_image, simulate_capture, simulate_dng, spectral_setup

    setup = spectral_setup(CAMERA, illuminant="D65")
    R = zonotope.resample(zonotope.reflectances("ColorChecker N Ohta"), setup.wavelengths).T[:6]
    image, _ = chart_image(R, rows=2, cols=3, patch=12, gap=0)
    train = zonotope.resample(zonotope.reflectances("rawtoaces 190"), setup.wavelengths).T
    cap = simulate_capture(image, setup, training=train, full_well=np.inf, read_noise=0)
    old = os.umask(UMASK)
    try:
        return simulate_dng(tmp_path_factory.mktemp("sim") / "chart.dng", cap, model=CAMERA)
    finally:
        os.umask(old)


def test_write_dng_mode(simulated_dng):
    assert stat.S_IMODE(simulated_dng.stat().st_mode) == 0o640  # written under umask 027 (was 0600)


def test_isp_profile_writes_dcp_cube_npz_with_umask_modes(tmp_path, umask027):
    from isp.cli import main

    out = tmp_path / "out"
    argv = ["profile", "--camera", CAMERA, "--method", "root-polynomial", "--matrix-only"]
    argv += ["-o", str(out / "cam.dcp"), "--lut", str(out / "cam.cube"), "--lut-size", "5"]
    argv += ["--save-correction", str(out / "cam.npz")]
    assert main(argv) == 0
    assert main([*argv[:-4], "--lut", str(out / "cam.csp"), "--overwrite"]) == 0
    _check(out, {"cam.dcp", "cam.cube", "cam.csp", "cam.npz"})


def test_isp_develop_writes_tiff_png_and_stages_with_umask_modes(simulated_dng, tmp_path, umask027):
    from isp.cli import main

    out = tmp_path / "out"
    common = ["--demosaic", "bilinear", "--tonemap", "none", "-q"]
    assert main(["develop", str(simulated_dng), "-o", str(out / "a.tif"), *common]) == 0
    argv = ["develop", str(simulated_dng), "-o", str(out / "b.png"), *common]
    assert main([*argv, "--save-stages", str(out / "stages")]) == 0
    batch = ["develop", str(simulated_dng.parent), "-o", str(out / "batch"), *common]
    assert main([*batch, "--scheduler", "serial"]) == 0
    _check(out, {"a.tif", "b.png", "stages", "batch", "batch/chart.tif"})
    assert len(list((out / "stages").iterdir())) >= 3


def test_zonotope_cli_outputs_have_umask_modes(tmp_path, umask027):
    import tifffile

    from zonotope.cli import main

    out = tmp_path / "out"
    argv = ["evaluate", "--camera", CAMERA, "--method", "Finlayson 2015", "--atypical", "2", "--size", "20"]
    assert main([*argv, *GRID, "--markdown", str(out / "eval.md")]) == 0
    survey = ["survey", "--cameras", f"{CAMERA},Canon EOS 5D Mark II", "--scheduler", "serial", "-q"]
    assert main([*survey, "--partners", "0", "-o", str(out / "survey.csv")]) == 0
    images = tmp_path / "images"
    images.mkdir()
    tifffile.imwrite(images / "a.tif", np.full((4, 5, 3), 0.3, np.float32), photometric="rgb")
    correct = ["correct", str(images), "-o", str(out / "xyz"), "--camera", CAMERA, "--method", "matrix"]
    assert main([*correct, "--scheduler", "serial", "-q"]) == 0
    _check(out, {"eval.md", "survey.csv", "xyz", "xyz/a_XYZ.tif", "xyz/manifest.csv"})


def test_report_folder_has_umask_modes(tmp_path, umask027):
    """``zonotope report``'s folder (the CLI adds the 3-D pictures, checked in test_report/test_viz)."""
    import colour

    from zonotope.report import write_report

    out = write_report(
        [CAMERA],
        tmp_path / "report",
        atypical=2,
        size=20,
        pictures=False,
        volumes=False,
        methods=["Finlayson 2015"],
        shape=colour.SpectralShape(400, 700, 10),
    )
    _check(tmp_path, {"report", "report/index.html", "report/report.md"})
    assert out == tmp_path / "report"
