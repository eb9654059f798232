"""DNG camera profiles: our writer ↔ our reader ↔ exiftool, RawTherapee's ~140 DCPs, the SDK's table
maths against a scalar port, malformed files, and the profile stage in the pipeline."""

from __future__ import annotations

import json
import shutil
import subprocess
import warnings
from pathlib import Path

import colour
import numpy as np
import pytest

from isp import PipelineError
from isp.profiles.dcp import (
    DCPError,
    DCPProfile,
    apply_hue_sat_map,
    apply_tone_curve,
    dcp_stage,
    read_dcp,
    write_dcp,
)
from isp.stages import matrix_XYZ_from_balanced

RT_DCP = Path("/usr/share/rawtherapee/dcpprofiles")
CM1 = np.array([[0.6461, -0.1164, -0.0857], [-0.3825, 1.1597, 0.2534], [-0.0416, 0.1540, 0.6039]])
CM2 = np.array([[0.5309, -0.0229, -0.0336], [-0.6241, 1.3265, 0.3337], [-0.0817, 0.1215, 0.6664]])
FM = np.array([[0.7, 0.15, 0.1142], [0.28, 0.7, 0.02], [0.0, 0.05, 0.7749]])


def _profile(rng, *, dims=(12, 5, 1), lut_dims=(8, 4, 3)) -> DCPProfile:
    H, S, V = dims
    hsm = np.stack(
        [rng.normal(0, 4, (V, H, S)), rng.uniform(0.9, 1.1, (V, H, S)), rng.uniform(0.95, 1.05, (V, H, S))],
        axis=-1,
    )
    H2, S2, V2 = lut_dims
    lut = np.stack(
        [
            rng.normal(0, 2, (V2, H2, S2)),
            rng.uniform(0.95, 1.05, (V2, H2, S2)),
            rng.uniform(0.97, 1.03, (V2, H2, S2)),
        ],
        axis=-1,
    )
    return DCPProfile(
        CM1,
        CM2,
        forward_matrix_1=FM,
        forward_matrix_2=FM,
        calibration_illuminant_1=17,
        calibration_illuminant_2=21,
        hue_sat_map_1=hsm,
        hue_sat_map_2=hsm[:, ::-1] * 1.0,
        hue_sat_map_encoding=0,
        look_table=lut,
        look_table_encoding=1,
        tone_curve=np.array([[0, 0], [0.25, 0.3], [0.75, 0.8], [1, 1]]),
        profile_name="test profile",
        unique_camera_model="Canon EOS 550D",
        copyright="CC0 test",
        embed_policy=3,
        baseline_exposure_offset=-0.5,
        default_black_render=1,
    )


def test_round_trip_our_reader(tmp_path):
    p = _profile(np.random.default_rng(0))
    path = write_dcp(tmp_path / "p.dcp", p)
    assert path.read_bytes()[:4] == b"IIRC"
    q = read_dcp(path)
    for name in ("color_matrix_1", "color_matrix_2", "forward_matrix_1", "forward_matrix_2"):
        np.testing.assert_allclose(getattr(q, name), getattr(p, name), atol=5e-5)  # SRATIONAL / 10000
    for name in ("hue_sat_map_1", "hue_sat_map_2", "look_table", "tone_curve"):
        np.testing.assert_allclose(getattr(q, name), getattr(p, name), rtol=1e-6, atol=1e-6)  # float32
    for name in (
        "calibration_illuminant_1",
        "calibration_illuminant_2",
        "hue_sat_map_encoding",
        "look_table_encoding",
        "profile_name",
        "unique_camera_model",
        "copyright",
        "embed_policy",
        "baseline_exposure_offset",
        "default_black_render",
    ):
        assert getattr(q, name) == getattr(p, name), name
    with pytest.raises(DCPError, match="exists"):
        write_dcp(path, p)


@pytest.mark.skipif(shutil.which("exiftool") is None, reason="exiftool not installed")
def test_exiftool_reads_the_same_values(tmp_path):
    p = _profile(np.random.default_rng(1))
    path = write_dcp(tmp_path / "p.dcp", p)
    out = json.loads(
        subprocess.run(
            ["exiftool", "-j", "-n", "-m", str(path)], capture_output=True, text=True, check=True
        ).stdout
    )[0]

    def values(key):
        return np.array(str(out[key]).split(), float)

    assert out["FileType"] == "DCP"
    np.testing.assert_allclose(values("ColorMatrix1").reshape(3, 3), CM1, atol=1e-4)
    np.testing.assert_allclose(values("ForwardMatrix2").reshape(3, 3), FM, atol=1e-4)
    np.testing.assert_allclose(values("ProfileToneCurve").reshape(-1, 2), p.tone_curve, atol=1e-6)
    assert out["ProfileName"] == "test profile" and out["UniqueCameraModel"] == "Canon EOS 550D"
    assert out["ProfileCopyright"] == "CC0 test" and out["ProfileEmbedPolicy"] == 3
    assert out["CalibrationIlluminant1"] == 17 and out["CalibrationIlluminant2"] == 21
    assert [int(v) for v in str(out["ProfileHueSatMapDims"]).split()] == [12, 5, 1]
    assert [int(v) for v in str(out["ProfileLookTableDims"]).split()] == [8, 4, 3]
    for tag, table in (("ProfileHueSatMapData1", p.hue_sat_map_1), ("ProfileLookTableData", p.look_table)):
        text = subprocess.run(
            ["exiftool", "-m", "-b", f"-{tag}", str(path)], capture_output=True, text=True, check=True
        ).stdout
        np.testing.assert_allclose(np.array(text.split(), float), table.ravel(), rtol=1e-5, atol=1e-5)
    assert out["ProfileLookTableEncoding"] == 1 and out["DefaultBlackRender"] == 1
    assert float(out["BaselineExposureOffset"]) == pytest.approx(-0.5)


@pytest.mark.skipif(not RT_DCP.is_dir(), reason="RawTherapee's DCPs not installed")
def test_reads_and_applies_every_rawtherapee_profile():
    files = sorted(RT_DCP.glob("*.dcp"))
    assert len(files) >= 100
    x = np.random.default_rng(2).uniform(0, 1.2, (64, 3))
    white = colour.xy_to_XYZ([0.3324, 0.3474])  # D55
    tables = 0
    for f in files:
        p = read_dcp(f)
        neutral = p.color_matrix_1 @ white
        out = p.apply(x, neutral)
        assert np.all(np.isfinite(out)), f.name
        tables += p.hue_sat_map_1 is not None or p.look_table is not None
        if p.hue_sat_map_1 is None and p.look_table is None and p.tone_curve is None:
            # matrix-only: the same as isp's DNG ColorMatrix path (an independent implementation)
            try:
                M = matrix_XYZ_from_balanced(p.dng_profile(), neutral)
            except ValueError:
                continue  # isp.dng's strict fixed point; our reader uses the SDK's fallback
            np.testing.assert_allclose(out, x @ M.T, atol=1e-9, err_msg=f.name)
    assert tables > 50


def _hsv_sdk(r, g, b):
    v = max(r, g, b)
    gap = v - min(r, g, b)
    if gap > 0:
        if r == v:
            h = (g - b) / gap
            h = h + 6 if h < 0 else h
        elif g == v:
            h = 2 + (b - r) / gap
        else:
            h = 4 + (r - g) / gap
        return h, gap / v, v
    return 0.0, 0.0, v


def _rgb_sdk(h, s, v):
    if s <= 0:
        return v, v, v
    h = h + 6 if h < 0 else h
    h = h - 6 if h >= 6 else h
    i = int(h)
    f = h - i
    p, q, t = v * (1 - s), v * (1 - s * f), v * (1 - s * (1 - f))
    return [(v, t, p), (q, v, p), (p, v, t), (p, q, v), (t, p, v), (v, p, q)][i]


def _hue_sat_map_scalar(rgb, T):
    """Scalar port of the DNG SDK's RefBaselineHueSatMap (linear encoding, 2.5-D or 3-D)."""
    V, H, S, _ = T.shape
    h, s, v = _hsv_sdk(*rgb)
    hs, ss = h * H / 6.0, s * (S - 1)
    h0 = min(int(hs), H - 1)
    h1 = 0 if h0 >= H - 1 else h0 + 1
    s0 = min(int(ss), S - 2)
    fh, fs = hs - h0, ss - s0
    if V > 1:
        vs = v * (V - 1)
        v0 = min(int(vs), V - 2)
        vw = [(v0, 1 - (vs - v0)), (v0 + 1, vs - v0)]
    else:
        vw = [(0, 1.0)]
    mod = np.zeros(3)
    for vi, a in vw:
        mod += a * (
            (1 - fh) * ((1 - fs) * T[vi, h0, s0] + fs * T[vi, h0, s0 + 1])
            + fh * ((1 - fs) * T[vi, h1, s0] + fs * T[vi, h1, s0 + 1])
        )
    return _rgb_sdk(h + mod[0] * 6 / 360, s * mod[1], v * mod[2])


@pytest.mark.parametrize("dims", [(90, 30, 1), (7, 3, 4)])
def test_hue_sat_map_matches_scalar_sdk_port(dims):
    rng = np.random.default_rng(3)
    H, S, V = dims
    T = np.stack(
        [rng.normal(0, 10, (V, H, S)), rng.uniform(0.8, 1.2, (V, H, S)), rng.uniform(0.9, 1.1, (V, H, S))],
        axis=-1,
    )
    rgb = rng.uniform(0, 1, (200, 3))
    rgb[:5] = [[0.5, 0.5, 0.5], [1, 0, 0], [0, 1, 0], [0.2, 0.2, 0.9], [0.9, 0.9, 0.1]]
    got = apply_hue_sat_map(rgb, T)
    ref = np.array([_hue_sat_map_scalar(p, T) for p in rgb])
    np.testing.assert_allclose(got, ref, atol=1e-12)


def test_identity_tables_and_curve_change_nothing():
    rng = np.random.default_rng(4)
    rgb = rng.uniform(0, 1, (500, 3))
    ident = np.zeros((1, 36, 8, 3))
    ident[..., 1:] = 1.0
    np.testing.assert_allclose(apply_hue_sat_map(rgb, ident), rgb, atol=1e-12)
    np.testing.assert_allclose(apply_tone_curve(rgb, [[0, 0], [1, 1]]), rgb, atol=1e-12)
    # HSV of the SDK is colour-science's HSV with hue × 6
    h, s, v = np.array([_hsv_sdk(*p) for p in rgb]).T
    np.testing.assert_allclose(np.stack([h / 6, s, v], -1), colour.RGB_to_HSV(rgb), atol=1e-12)


def test_tone_curve_is_the_sdk_rgb_tone():
    curve = np.array([[0, 0], [0.5, 0.7], [1, 1]])  # piecewise linear (2 segments: np.interp-free check)
    f = np.poly1d(np.polyfit(curve[:, 0], curve[:, 1], 2))  # three points: the natural spline is not this
    rgb = np.array([[0.8, 0.4, 0.2], [0.2, 0.4, 0.8], [0.3, 0.3, 0.3]])
    out = apply_tone_curve(rgb, curve)
    from scipy.interpolate import CubicSpline

    T = CubicSpline(curve[:, 0], curve[:, 1], bc_type="natural")
    hi, lo = T(0.8), T(0.2)
    np.testing.assert_allclose(out[0], [hi, lo + (hi - lo) * (0.4 - 0.2) / 0.6, lo], atol=1e-12)
    np.testing.assert_allclose(out[1], out[0][::-1], atol=1e-12)
    np.testing.assert_allclose(out[2], T(0.3), atol=1e-12)
    assert not np.allclose(out[2], f(0.3))


def test_malformed_profiles_give_clear_errors(tmp_path):
    import tifffile

    bad = tmp_path / "bad.dcp"
    bad.write_bytes(b"not a profile at all")
    with pytest.raises(DCPError, match="not a DNG camera profile"):
        read_dcp(bad)
    good = write_dcp(tmp_path / "good.dcp", _profile(np.random.default_rng(5)))
    trunc = tmp_path / "trunc.dcp"
    trunc.write_bytes(good.read_bytes()[:200])
    with pytest.raises(DCPError):
        read_dcp(trunc)
    with pytest.raises(FileNotFoundError):
        read_dcp(tmp_path / "missing.dcp")

    def raw_dcp(name, tags):
        p = tmp_path / name
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")  # tifffile: "writing zero-size array"
            tifffile.imwrite(p, shape=(0, 0), dtype=np.uint8, extratags=tags, metadata=None)
        data = bytearray(p.read_bytes())
        data[2:4] = b"RC"
        p.write_bytes(bytes(data))
        return p

    cm = (50721, 10, 9, tuple(v for x in CM1.ravel() for v in (round(x * 10000), 10000)), True)
    with pytest.raises(DCPError, match="do not fit the dimensions"):
        read_dcp(
            raw_dcp(
                "dims.dcp", [cm, (50937, "I", 3, (4, 3, 1), True), (50938, "f", 30, tuple([0.0] * 30), True)]
            )
        )
    with pytest.raises(DCPError, match="ProfileHueSatMapDims is missing"):
        read_dcp(raw_dcp("nodims.dcp", [cm, (50938, "f", 36, tuple([0.0] * 36), True)]))
    with pytest.raises(DCPError, match="ColorMatrix1"):
        read_dcp(raw_dcp("nocm.dcp", [(50936, "s", 0, "x", True)]))
    with pytest.raises(DCPError, match="ASCII"):
        write_dcp(tmp_path / "u.dcp", DCPProfile(CM1, profile_name="Ünïcode"))
    assert not (tmp_path / "u.dcp").exists()
    with pytest.raises(DCPError, match="increasing x"):
        DCPProfile(CM1, tone_curve=[[0, 0], [0.5, 0.2], [0.4, 1]])


def test_profile_stage_in_pipeline(tmp_path):
    import zonotope
    from isp import default_pipeline, develop
    from isp.simulate import chart_image, simulate_capture, simulate_dng, spectral_setup

    setup = spectral_setup("Nikon 5100 (NPL)", illuminant="D65")
    cc = np.clip(zonotope.resample(zonotope.reflectances("ColorChecker N Ohta"), setup.wavelengths).T, 0, 1)
    img, _ = chart_image(cc[:6], rows=2, cols=3, patch=8, gap=2)
    path = simulate_dng(tmp_path / "c.dng", simulate_capture(img, setup))
    base = default_pipeline(tonemap=None, encode=False)
    ref = develop(path, pipeline=base, stop_after="camera_to_XYZ").image
    emb = develop(
        path, pipeline=base.replace("camera_to_XYZ", dcp_stage(None)), stop_after="camera_to_XYZ"
    ).image
    np.testing.assert_allclose(emb, ref, atol=1e-12)  # embedded matrix-only profile = ColorMatrix path
    prof = _profile(np.random.default_rng(6)).with_options(tone_curve=None)
    dcp = write_dcp(tmp_path / "p.dcp", prof)
    out = develop(path, pipeline=base.replace("camera_to_XYZ", dcp_stage(dcp)), stop_after="camera_to_XYZ")
    bal = out.intermediates["demosaic"]
    raw = out.raw
    np.testing.assert_allclose(out.image, read_dcp(dcp).apply(bal, raw.as_shot_neutral), atol=1e-12)


def test_isp_develop_profile_cli(tmp_path):
    from isp.cli import main
    from isp.simulate import simulate_capture, simulate_dng, spectral_setup

    setup = spectral_setup("Nikon 5100 (NPL)", illuminant="D65")
    img = np.full((64, 64, setup.wavelengths.size), 0.4)
    path = simulate_dng(tmp_path / "g.dng", simulate_capture(img, setup))
    dcp = write_dcp(tmp_path / "p.dcp", _profile(np.random.default_rng(7)))
    assert main(["develop", str(path), "-o", str(tmp_path / "o.tif"), "--profile", str(dcp), "-q"]) == 0
    assert main(["develop", str(path), "-o", str(tmp_path / "e.tif"), "--profile", "embedded", "-q"]) == 0
    assert (
        main(
            [
                "develop",
                str(path),
                "-o",
                str(tmp_path / "x.tif"),
                "--profile",
                str(path.with_suffix(".x")),
                "-q",
            ]
        )
        == 2
    )
    assert not (tmp_path / "x.tif").exists()


@pytest.mark.parametrize("encoding", [0, 1])
def test_fit_recovers_a_known_3d_look_table(encoding):
    """fit_hue_sat_map with value divisions: the equations are exact, so colours made by a known
    smooth 3-D table give that table back (grey nodes at identity, as the fit holds them)."""
    from isp.profiles.fitting import fit_hue_sat_map

    V, H, S = 4, 12, 5
    v = np.linspace(0, 1, V)[:, None, None] * np.ones((V, H, S))
    h = np.linspace(0, 2 * np.pi, H, endpoint=False)[None, :, None] * np.ones((V, H, S))
    s = np.linspace(0, 1, S)[None, None, :] * np.ones((V, H, S))
    T = np.stack(
        [8 * s * (v - 0.5) * np.cos(h), 1 + 0.15 * s * (1 - s) * (1 + v), 1 + 0.1 * s * v * np.sin(h)], -1
    )
    hsv = np.random.default_rng(7).uniform([0, 0, 0.02], [1, 1, 0.97], (6000, 3))  # every cell
    if encoding == 1:
        hsv[:, 2] = colour.models.eotf_sRGB(hsv[:, 2])
    rgb = colour.HSV_to_RGB(hsv)
    out = apply_hue_sat_map(rgb, T, encoding=encoding)
    fitted = fit_hue_sat_map(rgb, out, dims=(H, S, V), smoothness=1e-9, encoding=encoding)
    np.testing.assert_allclose(fitted, T, atol=2e-4)
    flat = fit_hue_sat_map(rgb, out, dims=(H, S, 1), smoothness=1e-9)  # 2.5-D cannot say it
    assert (
        np.abs(apply_hue_sat_map(rgb, flat) - out).max()
        > 50 * np.abs(apply_hue_sat_map(rgb, fitted, encoding=encoding) - out).max()
    )
    with pytest.raises(PipelineError, match="encoding"):
        fit_hue_sat_map(rgb, out, dims=(H, S, V), encoding=2)
    with pytest.raises(PipelineError, match="unbiased_saturation"):
        fit_hue_sat_map(rgb, out, dims=(H, S, V), unbiased_saturation=float("nan"))
    with pytest.raises(PipelineError, match="weights"):
        fit_hue_sat_map(rgb, out, dims=(H, S, V), weights=-np.ones(6000))


def test_unbiased_rings_keep_the_mean_of_noisy_greys():
    """unbiased_saturation: the rings near grey have identity hue-means and no first hue harmonic,
    so a noise cloud around a grey keeps its mean, where the free fit follows a table that rotates
    and scales low saturations hue by hue."""
    from isp.profiles.fitting import fit_hue_sat_map

    H, S = 24, 11
    h = np.linspace(0, 2 * np.pi, H, endpoint=False)[:, None] * np.ones((H, S))
    s = np.linspace(0, 1, S)[None, :] * np.ones((H, S))
    T = np.stack([30 * s * np.cos(h), 1 + 0.5 * s * np.cos(h), 1 + 0.2 * s * (1 + np.sin(h))], -1)[None]
    rng = np.random.default_rng(5)
    rgb = colour.HSV_to_RGB(rng.uniform([0, 0, 0.05], [1, 1, 0.95], (5000, 3)))
    out = apply_hue_sat_map(rgb, T)
    free = fit_hue_sat_map(rgb, out, dims=(H, S, 1), smoothness=1e-6)
    ub = fit_hue_sat_map(rgb, out, dims=(H, S, 1), smoothness=1e-6, unbiased_saturation=0.4)
    rings = slice(1, 5)  # saturation nodes 0.1 … 0.4
    ang = 2 * np.pi * np.arange(H) / H
    np.testing.assert_allclose(ub[0, :, rings].mean(0), [[0, 1, 1]] * 4, atol=1e-3)  # a 10³ penalty
    for f in (np.cos(ang), np.sin(ang)):
        np.testing.assert_allclose(np.einsum("h,hjk->jk", f, ub[0, :, rings]) / H, 0, atol=1e-3)
    assert np.abs(np.cos(ang) @ free[0, :, 4, 0]) / H > 5  # the free fit has the 6° first harmonic
    far = ub[0, :, 6:] - T[0, :, 6:]  # farther out (saturation ≥ 0.6): still the data's
    assert np.abs(far[..., 0]).max() < 1.5 and np.abs(far[..., 1:]).max() < 0.05
    grey = 0.3 * (1 + 0.03 * rng.normal(size=(200_000, 3)))  # noise spreads saturations to ~0.1
    bias_free = np.abs(apply_hue_sat_map(grey, free).mean(0) - grey.mean(0)).max()
    bias_ub = np.abs(apply_hue_sat_map(grey, ub).mean(0) - grey.mean(0)).max()
    assert bias_ub < 0.1 * bias_free, (bias_ub, bias_free)
