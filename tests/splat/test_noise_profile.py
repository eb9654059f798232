"""The simulated capture's DNG NoiseProfile, read onto :class:`splat.capture.RawView` and used by
:func:`splat.fusion.sensor_noise`.

Independent truth: the realised noise of the simulated files, noisy file minus its noise-free twin
(same seed: same scene, exposures and poses), site by site. The model is checked per site (the
residuals divided by ``sqrt(S·x + O)`` at the noise-free value ``x`` have unit variance; a least-squares
fit of the squared residuals on ``x`` gives back ``S``), and ``sensor_noise``'s one σ per channel against
the realised σ of the sites whose noise-free value lies near the channel's median.
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

import splat
from splat.capture import CameraSpec, CaptureError, load_views, read_capture, read_linear
from splat.fusion import sensor_noise


@pytest.fixture(scope="module")
def twins(tmp_path_factory):
    """The default (fine, pixel-scale) texture, 2 views per camera, with noise and its noise-free twin."""
    from splat.sim.capture import SimCaptureConfig, write_synthetic_capture

    cfg = SimCaptureConfig.ci(n_train=2, n_holdout=0)
    root = tmp_path_factory.mktemp("noise_profile")
    noisy = write_synthetic_capture(root / "noisy", cfg)
    clean = write_synthetic_capture(root / "clean", dataclasses.replace(cfg, noise=False))
    return {
        "cfg": cfg,
        "root": noisy,
        "noisy": load_views(read_capture(noisy)),
        "clean": load_views(read_capture(clean)),
    }


def _pairs(twins):
    for v, c in zip(twins["noisy"], twins["clean"], strict=True):
        assert v.name == c.name and v.exif == c.exif
        yield v, c


def test_the_simulator_writes_the_exact_profile(twins):
    """S = ISO / (100 · full_well), O = (read_noise² + 1/12) / span², one pair for every colour; the
    noise-free files carry none."""
    import tomllib

    truth = tomllib.loads((twins["root"] / "truth" / "truth.toml").read_text())
    iso = {row["image"]: row["iso"] for row in truth["view"]}
    cams = twins["cfg"].cameras
    for v, c in _pairs(twins):
        cam = cams[v.camera]
        span = cam.white_level - cam.black_level
        want = [iso[v.name] / (100 * cam.full_well), (cam.read_noise**2 + 1 / 12) / span**2]
        assert v.noise_profile.shape == (3, 2)
        np.testing.assert_allclose(v.noise_profile, [want] * 3, rtol=1e-15)
        assert c.noise_profile is None


def test_the_profile_is_the_realised_noise_site_by_site(twins):
    """For each view and channel (Bayer and full colour): the residuals over sqrt(S·x + O) have unit
    σ (±4 %; 0.98-1.02 measured), and the weighted least-squares slope of residual² against x is S
    (±10 %; 0.93-1.03 measured)."""
    seen = set()
    for v, c in _pairs(twins):
        seen.add(v.full_colour)
        w = v.weight > 0
        n = v.values.astype(float) - c.values.astype(float)
        for j in range(3):
            x = c.values[..., j][w[..., j]].astype(float)
            r = n[..., j][w[..., j]]
            S, O = v.noise_profile[j]
            var = S * np.maximum(x, 0) + O
            z = r / np.sqrt(var)
            assert abs(np.std(z) - 1) < 0.04, (v.name, j, np.std(z))
            # r² has variance 2·var²: weighted least squares with weights 1 / var²
            A = np.stack([x, np.ones_like(x)], axis=1) / var[:, None]
            slope = np.linalg.lstsq(A, r**2 / var, rcond=None)[0][0]
            assert slope == pytest.approx(S, rel=0.10), (v.name, j, slope / S)
    assert seen == {True, False}


def test_sensor_noise_is_the_realised_noise_at_the_median_signal(twins):
    """sensor_noise (white scale 1, times the exposure) against the realised σ of the sites whose
    noise-free value is within ±15 % of the channel's median: within 10 % for every view and channel of
    the three cameras (two Bayer, one full colour). The image-based estimate (no profile) is 3-27 × on
    this texture."""
    for v, c in _pairs(twins):
        w = v.weight > 0
        n = v.values.astype(float) - c.values.astype(float)
        est = sensor_noise(v, np.ones(3)) * v.exif
        for j in range(3):
            vals = v.values[..., j][w[..., j]].astype(float)
            x0 = c.values[..., j][w[..., j]].astype(float)
            near = np.abs(x0 / np.median(vals) - 1) < 0.15
            assert near.sum() > 200
            truth = np.std(n[..., j][w[..., j]][near])
            assert est[j] == pytest.approx(truth, rel=0.10), (v.name, j, est[j] / truth)


def test_sensor_noise_scales_with_exposure_and_white(twins):
    v = twins["noisy"][0]
    white = np.array([0.4, 0.6, 0.5])
    a = sensor_noise(dataclasses.replace(v, exif=1.0), np.ones(3))
    b = sensor_noise(dataclasses.replace(v, exif=4.0), white)
    np.testing.assert_allclose(b, a / 4.0 / white, rtol=1e-14)
    with pytest.raises(splat.SplatError, match="exposure"):
        sensor_noise(dataclasses.replace(v, exif=None), white)


def _rewrite(src, dst, noise_profile):
    """The same pixels and tags as a simulated DNG, with another NoiseProfile (None: none)."""
    import isp

    tags = isp.read_dng_tags(src)
    raw = isp.read_raw(src)
    isp.write_dng(
        dst,
        raw.mosaic,
        cfa=raw.cfa,
        black_level=raw.black_level,
        white_level=int(raw.white_level),
        color_matrix_1=raw.profile.color_matrix_1,
        as_shot_neutral=tags["AsShotNeutral"],
        exposure_time=raw.capture["exposure_time"],
        iso=raw.capture["iso"],
        f_number=raw.capture["f_number"],
        noise_profile=noise_profile,
    )
    return dst


def test_a_file_without_the_tag_falls_back_to_the_image_estimate(twins, tmp_path):
    src = twins["root"] / "nikon" / "DSC_0001.dng"
    with_tag = read_linear(src)
    without = read_linear(_rewrite(src, tmp_path / "no_tag.dng", None))
    assert without[2]["noise_profile"] is None
    np.testing.assert_array_equal(without[0], with_tag[0])  # same pixels
    v = next(v for v in twins["noisy"] if v.name == "nikon/DSC_0001.dng")
    fallback = sensor_noise(dataclasses.replace(v, noise_profile=None), np.ones(3))
    # the image-based estimate: many times the profile's σ on this pixel-scale texture
    assert np.all(fallback > 2.5 * sensor_noise(v, np.ones(3)))


@pytest.mark.parametrize("pairs", [[[1e-4, 2e-8]], [[1e-4, 2e-8], [2e-4, 0.0], [3e-4, 1e-7]]])
def test_one_pair_or_three_per_colour(twins, tmp_path, pairs):
    src = twins["root"] / "canon" / "IMG_0001.dng"
    _, _, info = read_linear(_rewrite(src, tmp_path / "p.dng", pairs))
    np.testing.assert_array_equal(info["noise_profile"], np.broadcast_to(pairs, (3, 2)))


def test_level_overrides_re_express_the_profile(twins):
    """With the capture file's black/white overrides the values change scale; the profile follows so
    that the variance in DN at each DN is unchanged: var_new(x_new) · new_span² = var_file(x_file) · span²."""
    src = twins["root"] / "sigma" / "SDIM0001.dng"  # LinearRaw: black 64, white 4095
    _, _, base = read_linear(src)
    _, _, over = read_linear(src, CameraSpec("sigma", "x", black_level=80, white_level=4000))
    S, O = base["noise_profile"][0]
    S2, O2 = over["noise_profile"][0]
    for dn in (100.0, 1000.0, 3500.0):
        var_dn = (S * (dn - 64) / 4031 + O) * 4031**2
        assert (S2 * (dn - 80) / 3920 + O2) * 3920**2 == pytest.approx(var_dn, rel=1e-12)


def test_a_malformed_tag_is_a_capture_error_naming_file_and_tag(twins, tmp_path):
    import struct

    src = twins["root"] / "nikon" / "DSC_0001.dng"
    data = bytearray(src.read_bytes())
    i = data.find(struct.pack("<HH", 51041, 12))
    offset = struct.unpack("<I", data[i + 8 : i + 12])[0]
    data[offset : offset + 8] = struct.pack("<d", -1.0)  # S < 0
    bad = tmp_path / "bad.dng"
    bad.write_bytes(bytes(data))
    with pytest.raises(CaptureError) as e:
        read_linear(bad)
    assert str(bad) in str(e.value) and "NoiseProfile (tag 51041)" in str(e.value)
