"""isp at real sizes: strip-wise development gives the whole-image result with bounded memory.

A 60 MP ``isp develop`` ran every stage on the whole image in float64 (a demosaicing kernel holding
≈ 10 full planes) and ended in a MemoryError past 7 GB; runs of row-local stages now go strip by
strip. The truth here is the whole-image run of the same stages (``keep=True``).
"""

from __future__ import annotations

import numpy as np
import pytest

import isp
from isp import PipelineError, Stage, chain, default_pipeline
from isp.dng import write_dng
from isp.raw import read_raw


@pytest.fixture(scope="module")
def textured(tmp_path_factory):
    """A 62 × 90 DNG of smooth colour ramps with sharp edges and noise (demosaicing sees every case)."""
    rng = np.random.default_rng(3)
    H, W = 62, 90
    y, x = np.mgrid[0:H, 0:W]
    m = 200 + 2500 * (0.5 + 0.4 * np.sin(x / 5.0) * np.cos(y / 7.0)) + 600 * ((x // 9 + y // 11) % 2)
    m = np.clip(m + rng.normal(0, 30, m.shape), 0, 4095).astype(np.uint16)
    path = tmp_path_factory.mktemp("mem") / "textured.dng"
    cm = np.array([[0.9, -0.3, -0.1], [-0.4, 1.2, 0.2], [-0.1, 0.2, 0.6]])
    write_dng(
        path,
        m,
        cfa="GRBG",
        black_level=128,
        white_level=4095,
        color_matrix_1=cm,
        as_shot_neutral=[0.5, 1, 0.7],
    )
    return read_raw(path)


@pytest.fixture
def small_strips(monkeypatch):
    """Strips of 6 rows (of 90 px): many strip borders in a small image."""
    monkeypatch.setattr(isp._tol, "STRIP_PIXELS", 6 * 90)


@pytest.mark.parametrize("demosaic", list(isp.DEMOSAIC_METHODS.names()))
@pytest.mark.parametrize("tonemap", ["auto-bright", "Reinhard 2002", "clip"])
def test_strips_give_the_whole_image_result(textured, small_strips, demosaic, tonemap):
    p = default_pipeline(demosaic=demosaic, tonemap=tonemap)
    whole = p(textured, keep=True)  # every stage on the whole image, float64
    strips = p(textured, keep=False)
    assert strips.image.shape == whole.image.shape and strips.image.dtype == np.float32
    np.testing.assert_allclose(strips.image, whole.image, rtol=0, atol=2e-6)  # float32 between runs
    short = p(textured, keep=False, stop_after="demosaic")  # the halo covers the kernel's reach
    np.testing.assert_allclose(short.image, whole.intermediates["demosaic"], rtol=0, atol=1e-6)


def test_strips_shorter_than_the_reach(textured, monkeypatch):
    monkeypatch.setattr(isp._tol, "STRIP_PIXELS", 1)  # 2-row strips, halo 8 rows: still exact
    p = default_pipeline(demosaic="Menon 2007")
    np.testing.assert_allclose(p(textured, keep=False).image, p(textured).image, rtol=0, atol=2e-6)


def test_a_stage_without_reach_sees_the_whole_image(textured, small_strips):
    seen = []

    def whole(x, raw):
        seen.append(x.shape)
        return x - x.mean()

    p = chain(
        Stage("lin", lambda x, raw: x / 4095.0, reach=0),
        Stage("centre", whole),
        Stage("double", lambda x, raw: 2 * x, reach=0),
    )
    dev = p(textured, keep=False)
    assert seen == [(62, 90)]
    m = textured.mosaic / 4095.0
    np.testing.assert_allclose(dev.image, 2 * (m - m.mean()), atol=1e-6)


def test_a_local_stage_that_changes_the_rows_is_an_error(textured, small_strips):
    p = chain(Stage("crop", lambda x, raw: x[1:], reach=0))
    with pytest.raises(PipelineError, match=r"'crop' has reach=0 but changed the number of rows"):
        p(textured, keep=False)
    with pytest.raises(PipelineError, match="reach=3 must be None or an even int"):
        Stage("odd", lambda x, raw: x, reach=3)


def test_reinhard_in_chunks_equals_the_formula(monkeypatch):
    """tonemap_Reinhard2002 works in chunks; the truth is eq. 1, 2 and 4 written out on the whole image."""
    monkeypatch.setattr(isp._tol, "CHUNK_PIXELS", 7)
    rgb = np.random.default_rng(0).random((13, 11, 3)) * 3
    Y = rgb @ isp.stages._Y_sRGB
    L = 0.18 / np.exp(np.mean(np.log(1e-6 + Y))) * Y
    Ld = L * (1 + L / L.max() ** 2) / (1 + L)
    np.testing.assert_allclose(isp.tonemap_Reinhard2002(rgb), rgb / Y[..., None] * Ld[..., None], rtol=1e-12)
    f32 = isp.tonemap_Reinhard2002(rgb.astype(np.float32))
    assert f32.dtype == np.float32
    np.testing.assert_allclose(f32, rgb / Y[..., None] * Ld[..., None], rtol=1e-5)


def test_to_uint16_in_chunks(monkeypatch):
    from isp.io import to_uint16

    monkeypatch.setattr(isp._tol, "CHUNK_PIXELS", 5)
    a = np.random.default_rng(1).uniform(-0.2, 1.2, (9, 7, 3))
    np.testing.assert_array_equal(to_uint16(a), np.round(np.clip(a, 0, 1) * 65535).astype(np.uint16))
    a[4, 6, 2] = np.nan
    with pytest.raises(PipelineError, match="NaN or inf"):
        to_uint16(a)


def test_a_correction_sees_the_whole_image_unless_it_says_it_is_per_pixel(textured, small_strips):
    """An estimator that corrects each distinct colour once must not be called once per strip (it
    would correct a colour again in every strip); a per-pixel one may opt in with reach=0."""
    from isp import correction_stage

    calls = []

    def estimator(rgb):
        calls.append(rgb.shape[0])
        return rgb @ np.diag([0.9, 1.0, 1.1])

    p = default_pipeline().replace("camera_to_XYZ", correction_stage(estimator))
    whole = p(textured, keep=False).image
    assert calls[0] == 62 * 90  # one call: the whole image
    calls.clear()
    strips = default_pipeline().replace("camera_to_XYZ", correction_stage(estimator, reach=0))
    np.testing.assert_allclose(strips(textured, keep=False).image, whole, rtol=0, atol=2e-6)
    assert max(calls) < 62 * 90


def test_the_metamer_correction_goes_strip_by_strip(textured, small_strips):
    """``isp develop --correction metamer``: the estimator says it is per pixel, so the pipeline calls
    it once per strip (not on the whole 60 MP image); a closed-form estimator gives the whole-image
    result, and the progress of the distinct colours counts on across the strips."""
    from isp import correction_stage, metamer_correction

    m = metamer_correction("Nikon 5100 (NPL)", method="root-polynomial")
    stage = correction_stage(m)
    assert stage.reach == 0 and correction_stage(m, reach=None).reach is None
    calls = []
    m.corrector = _counting(m.corrector, calls)
    m.__post_init__()
    p = default_pipeline().replace("camera_to_XYZ", stage)
    whole = p(textured, keep=True)
    assert max(calls) == 62 * 90
    calls.clear()
    strips = p(textured, keep=False)
    np.testing.assert_allclose(strips.image, whole.image, rtol=0, atol=2e-6)
    assert max(calls) < 62 * 90 and sum(n for n in calls if n > 1) >= 62 * 90  # halos counted too
    with pytest.raises(PipelineError, match="reach='pixel'"):
        correction_stage(m, reach="pixel")


def _counting(corrector, calls):
    import dataclasses

    def predict(c):
        calls.append(c.shape[0])
        return corrector.predict(c)

    return dataclasses.replace(corrector, predict=predict)


def test_metamer_progress_counts_over_strips(textured, small_strips):
    from isp import correction_stage, metamer_correction

    seen = []
    m = metamer_correction("Nikon 5100 (NPL)", method="MAP", quantum=0.2, batch_size=4096)
    m.progress = lambda stage, done, total: seen.append((done, total))
    default_pipeline().replace("camera_to_XYZ", correction_stage(m))(textured, keep=False)
    done, total = np.array(seen).T
    assert len(seen) > 2 and np.all(np.diff(done) >= 0) and np.all(np.diff(total) >= 0)
    assert done[-1] == total[-1] > max(np.diff(total, prepend=0))  # several strips' counts added


def test_a_dcp_profile_goes_strip_by_strip(textured, small_strips, tmp_path, monkeypatch):
    """``isp develop --profile``: matrices, HueSatMap, LookTable and tone curve per pixel, strip-wise
    = whole image; the profile file is read once per image, not once per strip."""
    from isp.profiles import dcp
    from isp.profiles.tone import camera_tone_curve

    rng = np.random.default_rng(0)

    def table(V, H, S):
        t = np.ones((V, H, S, 3))
        t[..., 0] = rng.normal(0, 5, (V, H, S))
        t[..., 1:] += rng.normal(0, 0.05, (V, H, S, 2))
        return t

    cm = np.array([[0.9, -0.3, -0.1], [-0.4, 1.2, 0.2], [-0.1, 0.2, 0.6]])
    fm = np.array([[0.6, 0.25, 0.1], [0.25, 0.7, 0.05], [0.0, 0.1, 0.72]])
    prof = dcp.DCPProfile(
        cm,
        forward_matrix_1=fm,
        calibration_illuminant_1=21,
        hue_sat_map_1=table(1, 12, 6),
        look_table=table(4, 12, 6),
        look_table_encoding=1,
        tone_curve=camera_tone_curve(),
    )
    path = dcp.write_dcp(tmp_path / "p.dcp", prof)
    p = dcp.profile_pipeline(default_pipeline(), path, white_balance="D50")
    assert p["camera_to_XYZ"].reach == 0
    whole = p(textured, keep=True)
    reads = []
    real = dcp.read_dcp
    monkeypatch.setattr(dcp, "read_dcp", lambda f: reads.append(f) or real(f))
    embedded = dcp.profile_pipeline(default_pipeline(), "embedded")
    strips = p(textured, keep=False)
    np.testing.assert_allclose(strips.image, whole.image, rtol=0, atol=2e-6)
    np.testing.assert_allclose(
        embedded(textured, keep=False).image, default_pipeline()(textured).image, rtol=0, atol=2e-6
    )
    assert reads == [textured.path]  # once for the image, not once per strip
