"""``isp profile`` from sensitivities: the LUT's grouped sampling and header, the ICC profile of the
chosen illuminant, the default tone curve."""

from __future__ import annotations

import colour
import numpy as np
import pytest

import isp
from isp.profiles.lut import lut_header, profile_LUT

CAMERA = "Nikon 5100 (NPL)"


@pytest.fixture(scope="module")
def map_correction():
    # a coarse grouping of its own, which profile_LUT's quantum must replace
    return isp.metamer_correction(CAMERA, method="MAP", illuminant="D65", quantum=0.01, target="CIE 1931 2°")


def test_grouped_lut_is_the_exact_lut_on_natural_colours(map_correction):
    """``quantum=0`` is :func:`correction_LUT` of the exact estimator (the reference twin); the
    grouped LUT agrees with it on natural colours."""
    import dataclasses

    import zonotope
    from zonotope.correct.profile import apply_correction_LUT, correction_LUT

    exact = profile_LUT(map_correction, size=7, space="XYZ", quantum=0.0)
    twin = correction_LUT(dataclasses.replace(map_correction, quantum=0.0), size=7, space="XYZ")
    np.testing.assert_array_equal(exact[1].table, twin[1].table)
    grouped = profile_LUT(map_correction, size=7, space="XYZ")
    w = map_correction.corrector.problem.wavelengths
    R = np.clip(zonotope.resample(zonotope.reflectances("CIE 1995 TCS"), w).T, 0, 1)
    c = R @ map_correction.corrector.problem.Phi
    D65 = colour.CCS_ILLUMINANTS["CIE 1931 2 Degree Standard Observer"]["D65"]
    a, b = (colour.XYZ_to_Lab(apply_correction_LUT(lut, c), D65) for lut in (exact, grouped))
    assert colour.delta_E(a, b, method="CIE 2000").max() < 0.5
    with pytest.raises(isp.PipelineError, match="quantum=-1"):
        profile_LUT(map_correction, size=3, quantum=-1)


def test_nodes_no_real_colour_uses_are_grouped_coarser(map_correction):
    """The default groups the lattice nodes whose neighbouring cells cannot meet the object-colour
    solid within LUT_OUTSIDE_QUANTUM: every cell that holds a colour of the solid (random and
    two-transition reflectances, the solid's boundary) has all its corners on the fine side, and at
    17³ and 33³ most nodes are not."""
    import zonotope
    from isp._tol import LUT_OUTSIDE_QUANTUM, LUT_QUANTUM
    from isp.profiles.lut import _near_nodes, _SolidSplit
    from zonotope.correct.profile import LUTConfig, apply_correction_LUT, shaper_encode, white_node_toe

    assert LUT_OUTSIDE_QUANTUM > LUT_QUANTUM
    split = _SolidSplit(map_correction, LUT_QUANTUM, LUT_OUTSIDE_QUANTUM, None)
    Phi = map_correction.corrector.problem.Phi
    n = Phi.shape[0]
    rng = np.random.default_rng(0)
    i, j = np.sort(rng.integers(0, n + 1, (2, 4000)), axis=0)
    band = (np.arange(n) >= i[:, None]) & (np.arange(n) < j[:, None])  # optimal colours and their
    R = np.concatenate([band, ~band, rng.uniform(0, 1, (4000, n))]) * rng.uniform(0.01, 1, (12000, 1))
    colours = R @ Phi  # scaled: the solid's boundary and interior at every exposure
    for size in (17, 33):
        cfg = LUTConfig(size=size, space="XYZ")
        _, fine = _near_nodes(split.solid, cfg, 1.0)
        assert fine.sum() < 0.9 * size**3
        toe = white_node_toe(cfg.headroom, size)
        pos = shaper_encode(colours, headroom=cfg.headroom, shaper=cfg.shaper, toe=toe) * (size - 1)
        cell = np.minimum(np.floor(pos).astype(int), size - 2)
        for corner in np.ndindex(2, 2, 2):
            k = cell + corner
            assert fine[(k[:, 0] * size + k[:, 1]) * size + k[:, 2]].all()
    one = profile_LUT(map_correction, size=7, space="XYZ", outside_quantum=None)
    coarse = profile_LUT(map_correction, size=7, space="XYZ")
    w = map_correction.corrector.problem.wavelengths
    R = np.clip(zonotope.resample(zonotope.reflectances("ColorChecker N Ohta"), w).T, 0, 1)
    D65 = colour.CCS_ILLUMINANTS["CIE 1931 2 Degree Standard Observer"]["D65"]
    a, b = (colour.XYZ_to_Lab(apply_correction_LUT(lut, R @ Phi), D65) for lut in (one, coarse))
    assert colour.delta_E(a, b, method="CIE 2000").max() < 0.5
    with pytest.raises(isp.PipelineError, match="outside_quantum=-1"):
        profile_LUT(map_correction, size=3, outside_quantum=-1)


def test_lut_header_states_illuminant_and_encoding(map_correction, tmp_path):
    from zonotope.correct.profile import write_correction_LUT

    lut = profile_LUT(map_correction, size=3, space="sRGB")
    lut_header(lut, camera=CAMERA, method="MAP", illuminant="D65", space="sRGB", headroom=16, quantum=2e-3)
    text = write_correction_LUT(tmp_path / "x.cube", lut).read_text()
    head = text.split("LUT_3D_SIZE")[0]
    assert "scene illuminant D65" in head and "white-balanced for D65" in head and "linear sRGB" in head
    assert "zonotope:" in head  # the mark --overwrite recognises


def test_cli_icc_lut_and_tone_curve(tmp_path, capsys):
    from isp.cli import main
    from isp.profiles.dcp import read_dcp
    from isp.profiles.icc import ICC_D50, read_icc_matrix

    argv = ["profile", "--camera", CAMERA, "--method", "root-polynomial", "--matrix-only"]
    argv += ["-o", str(tmp_path / "cam.dcp"), "--icc", str(tmp_path / "cam.icc"), "--illuminant", "A"]
    lut = ["--lut", str(tmp_path / "cam.cube"), "--lut-size", "3"]
    assert main([*argv, *lut, "--unique-camera-model", "Canon EOS REBEL T2i"]) == 0
    dcp = read_dcp(tmp_path / "cam.dcp")
    assert dcp.unique_camera_model == "Canon EOS 550D"  # the name raw developers match
    M, chad = read_icc_matrix(tmp_path / "cam.icc")
    FM = np.diag(ICC_D50 / (dcp.forward_matrix_1 @ np.ones(3))) @ dcp.forward_matrix_1  # A: matrix 1
    np.testing.assert_allclose(M, FM, atol=2e-4)  # the DCP stores the matrix to 1e-4
    A = colour.xy_to_XYZ(colour.CCS_ILLUMINANTS["CIE 1931 2 Degree Standard Observer"]["A"])
    # adapts A's white (the estimator's, integrated on the camera's 10 nm range) to D50
    assert chad @ A / (chad @ A)[1] == pytest.approx(ICC_D50, abs=0.02)
    assert not np.allclose(chad, np.eye(3), atol=0.05)
    assert "scene illuminant A" in (tmp_path / "cam.cube").read_text()
    tc = dcp.tone_curve
    assert tc is not None and np.interp(0.18, tc[:, 0], tc[:, 1]) == pytest.approx(0.39, abs=0.01)
    capsys.readouterr()
    assert main([*argv[:-2], "--illuminant", "D50", "--overwrite"]) == 2
    err = capsys.readouterr().err
    assert err.startswith("isp: error: --illuminant D50:") and "fitting" not in err and err.count("\n") == 1
    for bad, message in (
        (["--chart", "x.dng"], "one of the two"),
        (["--report", "r.csv"], "--report and --chart-corners apply to --chart"),
        (["--icc", str(tmp_path / "x.txt")], "an ICC profile is a .icc"),
    ):
        assert main([*argv[:6], *bad, "-o", str(tmp_path / "n.dcp")]) == 2
        assert message in capsys.readouterr().err
    assert not (tmp_path / "n.dcp").exists()


def test_profile_of_an_estimated_camera_is_named_for_its_model(tmp_path):
    """``zonotope ssf estimate`` writes the DNG's make and model into the camera file; a profile fitted
    on it is offered for that camera: its UniqueCameraModel is that model as Adobe names it, not the
    file's name."""
    import zonotope
    from isp.cli import main
    from isp.profiles.dcp import read_dcp
    from zonotope.spectra.estimate import DNGMatrices, synthesise_dng_matrices

    m = synthesise_dng_matrices("Canon EOS 5D Mark II")
    est = zonotope.estimate_ssf(DNGMatrices(m.color_matrices, m.illuminants, name="Canon EOS Kiss X4"))
    zonotope.write_ssf_json(est, tmp_path / "cam.json")
    argv = ["profile", "--camera", str(tmp_path / "cam.json"), "--method", "root-polynomial", "--matrix-only"]
    assert main([*argv, "-o", str(tmp_path / "cam.dcp")]) == 0
    dcp = read_dcp(tmp_path / "cam.dcp")
    assert dcp.unique_camera_model == "Canon EOS 550D"
    assert dcp.profile_name.startswith("Canon EOS Kiss X4 ")
