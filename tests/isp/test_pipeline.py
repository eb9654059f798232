"""isp.pipeline: editing and running pipelines; end-to-end on a crop of the real 550D DNG."""

from __future__ import annotations

import dataclasses

import colour
import numpy as np
import pytest

from isp import (
    MetamerCorrection,
    Pipeline,
    PipelineError,
    Stage,
    chain,
    correction_stage,
    default_pipeline,
    develop,
    matrix_XYZ_from_balanced,
    metamer_correction,
)

NAMES = (
    "linearise",
    "white_balance",
    "demosaic",
    "camera_to_XYZ",
    "XYZ_to_linear_sRGB",
    "tonemap",
    "encode_sRGB",
    "orient",
)


@pytest.fixture(scope="module")
def crop(raw_550d):
    return raw_550d.crop(560, 640, 96, 128)  # a corner of the ColorChecker


def test_default_names_and_editing():
    p = default_pipeline()
    assert p.names == NAMES
    assert default_pipeline(tonemap=None, encode=False, orient=False).names == NAMES[:5]
    assert default_pipeline(orient=False).names == NAMES[:7]
    assert p.until("demosaic").names == NAMES[:3]
    assert p.remove("tonemap").names == NAMES[:5] + NAMES[6:]
    swapped = p.reorder(["linearise", "demosaic", "white_balance", *NAMES[3:]])
    assert swapped.names[1:3] == ("demosaic", "white_balance")
    ins = p.insert(Stage("gain", lambda x, raw: 2 * x), after="demosaic")
    assert ins.names[3] == "gain"
    assert p.replace("tonemap", lambda x, raw: x)["tonemap"].name == "tonemap"
    assert "→" in repr(p)
    with pytest.raises(PipelineError, match="no stage named 'sharpen'"):
        p.until("sharpen")
    with pytest.raises(PipelineError, match="unique"):
        chain(("a", lambda x, r: x), ("a", lambda x, r: x))
    with pytest.raises(PipelineError, match="exactly once"):
        p.reorder(NAMES[:3])
    with pytest.raises(ValueError, match="bilinear"):
        default_pipeline(demosaic="VNG")
    with pytest.raises(ValueError, match="dng"):
        default_pipeline(correction="metamer")


def test_run_keeps_intermediates(crop):
    dev = default_pipeline(demosaic="bilinear")(crop)
    assert list(dev.intermediates) == ["input", *NAMES]
    assert dev.intermediates["linearise"].shape == (96, 128)
    assert dev.intermediates["demosaic"].shape == (96, 128, 3)
    assert dev.image is dev.intermediates["encode_sRGB"]
    assert 0 <= dev.image.min() and dev.image.max() <= 1
    short = develop(crop, stop_after="camera_to_XYZ", keep=False)
    assert list(short.intermediates) == ["input", "camera_to_XYZ"]
    np.testing.assert_allclose(short.image, dev.intermediates["camera_to_XYZ"], atol=0.05)  # Malvar/bilinear
    seen = []
    notone = develop(crop, progress=lambda *call: seen.append(call), tonemap=None)
    assert tuple(notone.intermediates)[1:] == NAMES[:5] + NAMES[6:]
    n = len(NAMES) - 1
    assert seen == [("develop", i, n) for i in range(n + 1)]  # before each stage, and at the end


def test_stage_errors(crop):
    bad = chain(("nan", lambda x, raw: x * np.nan))
    with pytest.raises(PipelineError, match="'nan' produced NaN"):
        bad(crop)
    with pytest.raises(PipelineError, match="not an ndarray"):
        chain(("list", lambda x, raw: [1]))(crop)
    with pytest.raises(PipelineError, match="default pipeline only"):
        develop(crop, pipeline=default_pipeline(), demosaic="bilinear")
    with pytest.raises(PipelineError, match=r"\(\.\.\., 3\)"):
        default_pipeline().reorder(["linearise", "camera_to_XYZ", "white_balance", "demosaic", *NAMES[4:]])(
            crop
        )


def test_correction_callable_equals_dng_matrix(crop):
    M = matrix_XYZ_from_balanced(crop.profile, crop.as_shot_neutral)
    dng = develop(crop, stop_after="XYZ_to_linear_sRGB")
    p = default_pipeline(correction=lambda c: c @ M.T)
    alt = p(crop, stop_after="XYZ_to_linear_sRGB")
    np.testing.assert_allclose(alt.image, dng.image, atol=1e-3)  # Bradford(D50 → D50) ≈ identity
    # a correction on un-balanced camera RGB: drop the white balance stage (bilinear demosaicing is
    # per-channel linear, so balancing before or after it is the same; Malvar's is not)
    dng = develop(crop, stop_after="XYZ_to_linear_sRGB", demosaic="bilinear")
    Mraw = M @ np.diag(crop.as_shot_neutral.max() / crop.as_shot_neutral)
    p2 = (
        default_pipeline(demosaic="bilinear")
        .remove("white_balance")
        .replace("camera_to_XYZ", correction_stage(lambda c: c @ Mraw.T, balanced=False))
    )
    out = p2(crop, stop_after="XYZ_to_linear_sRGB").image
    unclipped = dng.intermediates["white_balance"].max() < 1  # white balance clips; here nothing clipped
    assert unclipped
    np.testing.assert_allclose(out, dng.image, atol=1e-12)


def test_pipeline_accepts_pairs():
    p = Pipeline([("double", lambda x, raw: 2 * x)])
    assert p.names == ("double",) and len(p) == 1
    with pytest.raises(PipelineError, match="Stage"):
        Pipeline([42])


def test_metamer_correction_fit_and_white():
    m = metamer_correction("Nikon 5100 (NPL)", method="root-polynomial")
    assert m.method == "Finlayson 2015"
    w = m.corrector.problem.wavelengths
    assert (w[0], w[-1], w[1] - w[0]) == (400, 700, 10)
    # CIE 1931 2° XYZ under D65 with Y_white = 1: the white balanced responses map to D65's white
    D65 = colour.CCS_ILLUMINANTS["CIE 1931 2 Degree Standard Observer"]["D65"]
    np.testing.assert_allclose(colour.XYZ_to_xy(m(np.ones((1, 3)))[0]), D65, atol=2e-3)
    assert m.neutral.max() == pytest.approx(1.0) and m.neutral_mismatch(m.neutral * 3) == pytest.approx(0)
    assert m.neutral_mismatch(m.neutral * [1.2, 1, 1]) == pytest.approx(0.2)
    # a camera measured on a shorter range: the grid is narrowed to it, never extrapolated
    sigma = metamer_correction("Sigma SDMerill (NPL)", method="matrix")
    assert sigma.corrector.problem.wavelengths[-1] == 680
    # negative responses (noise, demosaicing overshoot) count as 0
    np.testing.assert_array_equal(m(np.array([[-0.2, 0.3, 0.4]])), m(np.array([[0.0, 0.3, 0.4]])))


def test_metamer_correction_exposure():
    """white_level: the estimate at exposure e with white_level e is e × the one at exposure 1, and
    responses brighter than the white (the saturation white (1, 1, 1) among them) scale linearly."""
    m1 = metamer_correction("Nikon 5100 (NPL)", method="MAP", quantum=0)
    half = metamer_correction("Nikon 5100 (NPL)", method="MAP", quantum=0, white_level=0.5)
    c = np.random.default_rng(2).uniform(0.02, 0.5, (10, 3))
    np.testing.assert_allclose(half(0.5 * c), 0.5 * m1(c), rtol=1e-9, atol=1e-12)
    white = m1(np.ones((1, 3)))
    np.testing.assert_allclose(half(np.ones((1, 3))), white, rtol=1e-12)
    np.testing.assert_allclose(m1(np.array([[2.0, 2.0, 2.0]])), 2 * white, rtol=1e-12)
    with pytest.raises(ValueError, match="white_level"):
        metamer_correction("Nikon 5100 (NPL)", method="matrix", white_level=0)


def test_metamer_correction_errors(tmp_path):
    with pytest.raises(ValueError, match="unknown camera"):
        metamer_correction("Nikon 9999")
    with pytest.raises(FileNotFoundError, match="not found"):
        metamer_correction(str(tmp_path / "ssf.json"))
    with pytest.raises(ValueError, match="not a correction method"):
        metamer_correction("Nikon 5100 (NPL)", method="best")
    cam = colour.MultiSpectralDistributions(
        np.abs(np.random.default_rng(0).normal(size=(31, 4))), np.arange(400, 701, 10), name="four-channel"
    )
    with pytest.raises(ValueError, match="has 4 channels"):
        metamer_correction(cam, method="matrix")


def test_metamer_correction_falls_back_per_colour():
    """A colour whose estimate raises (Qhull on a degenerate MMV) gets the regression; the others don't."""
    base = metamer_correction("Nikon 5100 (NPL)", method="MAP")

    def fragile(c):
        if np.any(c[:, 0] > 0.5):
            raise RuntimeError("QH6023 qhull input error")
        return base.corrector.predict(c)

    seen = []
    m = MetamerCorrection(
        dataclasses.replace(base.corrector, predict=fragile),
        quantum=0,
        batch_size=4,
        progress=lambda stage, done, total: seen.append((stage, done, total)),
    )
    c = np.random.default_rng(1).uniform(0.05, 0.6, (20, 3))
    out = m(c)
    bad = c[:, 0] > 0.5
    assert m.fallbacks == bad.sum() > 0
    np.testing.assert_allclose(out[~bad], base(c[~bad]), atol=1e-9)
    np.testing.assert_allclose(out[bad], m._regression(c[bad]), atol=1e-12)
    assert seen[-1] == ("distinct colours", 20, 20) and len(seen) == 5  # per batch, distinct colours only
    m(np.ones((1, 3)))  # the white alone: no progress report
    assert len(seen) == 5


def test_metamer_correction_in_pipeline(crop):
    """The real 550D crop through a metamer correction (Canon 5D Mark II sensitivities stand in)."""
    m = metamer_correction("Canon EOS 5D Mark II", method="root-polynomial")
    out = default_pipeline(correction=m)(crop, stop_after="XYZ_to_linear_sRGB").image
    dng = develop(crop, stop_after="XYZ_to_linear_sRGB").image
    assert out.shape == dng.shape and np.all(np.isfinite(out))
    # same white balance and exposure: the grey levels agree, the colours roughly
    assert abs(np.median(out) / np.median(dng) - 1) < 0.1
