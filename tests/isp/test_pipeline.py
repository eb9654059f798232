"""isp.pipeline: editing and running pipelines; end-to-end on a crop of the real 550D DNG."""

from __future__ import annotations

import numpy as np
import pytest

from isp import (
    Pipeline,
    PipelineError,
    Stage,
    chain,
    correction_stage,
    default_pipeline,
    develop,
    matrix_XYZ_from_balanced,
)

NAMES = ("linearise", "white_balance", "demosaic", "camera_to_XYZ", "XYZ_to_linear_sRGB", "tonemap",
         "encode_sRGB")


@pytest.fixture(scope="module")
def crop(raw_550d):
    return raw_550d.crop(560, 640, 96, 128)  # a corner of the ColorChecker


def test_default_names_and_editing():
    p = default_pipeline()
    assert p.names == NAMES
    assert default_pipeline(tonemap=None, encode=False).names == NAMES[:5]
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
    develop(crop, on_stage=lambda i, n: seen.append(n), tonemap=None)
    assert tuple(seen) == NAMES[:5] + NAMES[6:]


def test_stage_errors(crop):
    bad = chain(("nan", lambda x, raw: x * np.nan))
    with pytest.raises(PipelineError, match="'nan' produced NaN"):
        bad(crop)
    with pytest.raises(PipelineError, match="not an ndarray"):
        chain(("list", lambda x, raw: [1]))(crop)
    with pytest.raises(PipelineError, match="default pipeline only"):
        develop(crop, pipeline=default_pipeline(), demosaic="bilinear")
    with pytest.raises(PipelineError, match=r"\(\.\.\., 3\)"):
        default_pipeline().reorder(["linearise", "camera_to_XYZ", "white_balance", "demosaic",
                                    *NAMES[4:]])(crop)


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
    p2 = default_pipeline(demosaic="bilinear").remove("white_balance").replace(
        "camera_to_XYZ", correction_stage(lambda c: c @ Mraw.T, balanced=False))
    out = p2(crop, stop_after="XYZ_to_linear_sRGB").image
    unclipped = dng.intermediates["white_balance"].max() < 1  # white balance clips; here nothing clipped
    assert unclipped
    np.testing.assert_allclose(out, dng.image, atol=1e-12)


def test_pipeline_accepts_pairs():
    p = Pipeline([("double", lambda x, raw: 2 * x)])
    assert p.names == ("double",) and len(p) == 1
    with pytest.raises(PipelineError, match="Stage"):
        Pipeline([42])
