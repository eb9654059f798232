"""isp.stages: closed forms, colour-science as reference, and a naive bilinear reference twin."""

from __future__ import annotations

import colour
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as hst

from isp import (
    CFA_PATTERNS,
    DEMOSAIC_METHODS,
    PipelineError,
    XYZ_to_linear_sRGB,
    apply_correction,
    camera_to_XYZ,
    cfa_masks,
    demosaic,
    encode_sRGB,
    linearise,
    mosaic,
    tonemap,
    white_balance,
)
from isp.stages import tonemap_Reinhard2002


def test_linearise_closed_form():
    m = np.array([[100, 200], [300, 4095]] * 2)
    black = np.array([[100, 110], [120, 130]])
    out = linearise(m, black_level=black, white_level=4095)
    expect = (m - np.tile(black, (2, 1))) / (4095 - np.tile(black, (2, 1)))
    np.testing.assert_allclose(out, np.clip(expect, 0, 1))
    table = np.linspace(0, 1000, 11) ** 1.0  # raw value v → 100 v
    np.testing.assert_allclose(
        linearise(np.array([[0, 5], [10, 20]]), black_level=0, white_level=1000, table=table),
        [[0, 0.5], [1, 1]],
    )
    with pytest.raises(PipelineError, match="NaN"):
        linearise(np.full((2, 2), np.nan), black_level=0, white_level=1)
    with pytest.raises(PipelineError, match="exceed"):
        linearise(np.ones((2, 2)), black_level=5, white_level=5)


def test_cfa_masks_partition():
    for cfa in CFA_PATTERNS:
        m = cfa_masks((4, 6), cfa)
        assert np.all(m.sum(-1) == 1)
        assert m[..., 1].sum() == 12  # half the sites are green
        assert m[0, 0, "RGB".index(cfa[0])]


def test_white_balance_mosaic_equals_image():
    rng = np.random.default_rng(0)
    rgb = rng.uniform(0, 0.5, (6, 8, 3))
    n = np.array([0.5, 1.0, 0.8])
    a = white_balance(mosaic(rgb, cfa="BGGR"), neutral=n, cfa="BGGR")
    b = mosaic(white_balance(rgb, neutral=n), cfa="BGGR")
    np.testing.assert_allclose(a, b)
    np.testing.assert_allclose(white_balance(n, neutral=n * 3), [1, 1, 1])
    with pytest.raises(PipelineError, match="neutral"):
        white_balance(rgb, neutral=[1, 0, 1])


@pytest.mark.parametrize("method", list(DEMOSAIC_METHODS))
@pytest.mark.parametrize("cfa", CFA_PATTERNS)
def test_demosaic_flat_field_exact_up_to_the_border(method, cfa):
    colour_ = np.array([0.2, 0.5, 0.3])
    m = mosaic(np.broadcast_to(colour_, (14, 18, 3)), cfa=cfa)
    out = demosaic(m, cfa=cfa, method=method)
    np.testing.assert_allclose(out, np.broadcast_to(colour_, out.shape), atol=1e-12)


def _bilinear_reference(m: np.ndarray, cfa: str) -> np.ndarray:
    """Average of the same-colour samples in the 3 × 3 neighbourhood, mirror-extended (slow twin)."""
    H, W = m.shape
    masks = cfa_masks((H, W), cfa)
    out = np.zeros((H, W, 3))
    for y in range(H):
        for x in range(W):
            for c in range(3):
                if masks[y, x, c]:
                    out[y, x, c] = m[y, x]
                    continue
                vals, wts = [], []
                for dy in (-1, 0, 1):
                    for dx in (-1, 0, 1):
                        yy, xx = abs(y + dy), abs(x + dx)
                        yy = 2 * (H - 1) - yy if yy >= H else yy
                        xx = 2 * (W - 1) - xx if xx >= W else xx
                        if masks[yy, xx, c]:
                            vals.append(m[yy, xx])
                            wts.append(1.0)
                # green at R/B: the 4 direct neighbours; R/B: 2 or 4 nearest
                out[y, x, c] = (
                    np.mean(vals)
                    if c != 1
                    else np.mean(
                        [
                            m[
                                abs(y + dy) if y + dy < H else 2 * (H - 1) - (y + dy),
                                abs(x + dx) if x + dx < W else 2 * (W - 1) - (x + dx),
                            ]
                            for dy, dx in ((-1, 0), (1, 0), (0, -1), (0, 1))
                        ]
                    )
                )
    return out


@pytest.mark.parametrize("cfa", ["RGGB", "GBRG"])
def test_bilinear_matches_reference_twin(cfa):
    rng = np.random.default_rng(3)
    m = rng.uniform(size=(8, 10))
    np.testing.assert_allclose(
        demosaic(m, cfa=cfa, method="bilinear"), _bilinear_reference(m, cfa), atol=1e-12
    )


@pytest.mark.parametrize("method", list(DEMOSAIC_METHODS))
def test_demosaic_keeps_green_samples(method):
    rng = np.random.default_rng(4)
    m = rng.uniform(size=(12, 12))
    out = demosaic(m, cfa="RGGB", method=method)
    g = cfa_masks(m.shape, "RGGB")[..., 1]
    np.testing.assert_allclose(out[..., 1][g], m[g], atol=1e-12)


def test_demosaic_bad_method_lists_valid():
    with pytest.raises(ValueError, match="Malvar 2004"):
        demosaic(np.zeros((4, 4)), method="AHD")
    assert demosaic(np.zeros((4, 4)), method="menon2007").shape == (4, 4, 3)
    with pytest.raises(PipelineError, match=r"\(H, W\)"):
        demosaic(np.zeros((4, 4, 3)))


def test_camera_to_XYZ_and_sRGB_against_colour():
    M = np.array([[0.6, 0.3, 0.1], [0.25, 0.7, 0.05], [0.0, 0.1, 0.9]])
    rgb = np.random.default_rng(5).uniform(size=(3, 4, 3))
    XYZ = camera_to_XYZ(rgb, matrix=M)
    np.testing.assert_allclose(XYZ, np.einsum("ij,...j->...i", M, rgb))
    D50 = colour.CCS_ILLUMINANTS["CIE 1931 2 Degree Standard Observer"]["D50"]
    D65 = colour.CCS_ILLUMINANTS["CIE 1931 2 Degree Standard Observer"]["D65"]
    ref = colour.XYZ_to_RGB(XYZ, "sRGB", D50, chromatic_adaptation_transform="Bradford")
    np.testing.assert_allclose(XYZ_to_linear_sRGB(XYZ), ref)
    # the D50 white (Y = 1) is the sRGB white after Bradford; a D65 white needs no adaptation
    np.testing.assert_allclose(XYZ_to_linear_sRGB(colour.xy_to_XYZ(D50)), [1, 1, 1], atol=2e-4)
    np.testing.assert_allclose(XYZ_to_linear_sRGB(colour.xy_to_XYZ(D65), white_xy=D65), [1, 1, 1], atol=2e-4)
    with pytest.raises(PipelineError, match="3, 3"):
        camera_to_XYZ(rgb, matrix=np.eye(2))


def test_encode_sRGB_piecewise_closed_form():
    x = np.linspace(-0.1, 1.1, 121)[:, None].repeat(3, 1)
    c = np.clip(x, 0, 1)
    expect = np.where(c <= 0.0031308, 12.92 * c, 1.055 * c ** (1 / 2.4) - 0.055)
    np.testing.assert_allclose(encode_sRGB(x), expect, atol=1e-12)


def test_reinhard_closed_form_and_identity():
    rgb = np.random.default_rng(6).uniform(0, 4, size=(5, 6, 3))
    Y = rgb @ colour.RGB_COLOURSPACES["sRGB"].matrix_RGB_to_XYZ[1]
    Lbar = np.exp(np.mean(np.log(1e-6 + Y)))
    L = 0.18 / Lbar * Y
    Ld = L * (1 + L / 2.0**2) / (1 + L)
    np.testing.assert_allclose(tonemap(rgb, method="Reinhard 2002", white=2.0), rgb * (Ld / Y)[..., None])
    # key=None, white=1 on [0, 1] luminance: L(1 + L)/(1 + L) = L, the identity
    small = rgb / rgb.max()
    np.testing.assert_allclose(tonemap_Reinhard2002(small, key=None, white=1.0), small, atol=1e-12)
    np.testing.assert_allclose(tonemap(rgb, method="clip", exposure=-2), np.clip(rgb / 4, 0, 1))
    with pytest.raises(ValueError, match="Reinhard 2002"):
        tonemap(rgb, method="ACES")


@settings(max_examples=30, deadline=None)
@given(hst.lists(hst.floats(0, 50), min_size=2, max_size=20))
def test_reinhard_monotonic_in_luminance(values):
    grey = np.sort(np.asarray(values))[:, None].repeat(3, 1)
    out = tonemap_Reinhard2002(grey)[:, 0]
    assert np.all(np.diff(out) >= -1e-12)
    assert out.max() <= 1 + 1e-12


def test_reinhard_subnormal_image_stays_finite():
    """Found by hypothesis: an all-subnormal image overflowed Ld / Y (its brightest pixel → 1)."""
    out = tonemap_Reinhard2002(np.array([[0.0] * 3, [2.2250738585e-313] * 3]))
    assert np.all(np.isfinite(out)) and out.max() <= 1 + 1e-12


def test_apply_correction_matrix_callable():
    M = np.array([[0.6, 0.3, 0.1], [0.25, 0.7, 0.05], [0.0, 0.1, 0.9]])
    rgb = np.random.default_rng(7).uniform(size=(4, 5, 3))
    out = apply_correction(rgb, XYZ_from_responses=lambda c: c @ M.T)
    white = M.sum(1)
    D50 = colour.CCS_ILLUMINANTS["CIE 1931 2 Degree Standard Observer"]["D50"]
    cat = colour.adaptation.matrix_chromatic_adaptation_VonKries(
        white / white[1], colour.xy_to_XYZ(D50), transform="Bradford"
    )
    np.testing.assert_allclose(out, rgb @ (cat @ M / white[1]).T)
    with pytest.raises(PipelineError, match=r"\(N, 3\)"):
        apply_correction(rgb, XYZ_from_responses=lambda c: c[:, :2])
    with pytest.raises(PipelineError, match="NaN"):
        apply_correction(rgb, XYZ_from_responses=lambda c: c * np.nan)


def test_demosaic_and_tonemap_facts_live_on_the_registry_entries():
    import inspect

    from isp import TONEMAP_METHODS, default_method, default_pipeline
    from isp.cli import _parser

    pads = {name: DEMOSAIC_METHODS.properties(name)["pad"] for name in DEMOSAIC_METHODS}
    assert pads == {"bilinear": 2, "Malvar 2004": 4, "Menon 2007": 8}
    assert all(p % 2 == 0 for p in pads.values())  # even: the CFA phase survives the padding
    assert default_method(DEMOSAIC_METHODS) == "Malvar 2004"
    assert default_method(TONEMAP_METHODS) == "auto-bright"
    args = _parser().parse_args(["develop", "in.dng", "-o", "out.tif"])
    defaults = inspect.signature(default_pipeline).parameters
    for table, used in (
        (DEMOSAIC_METHODS, [inspect.signature(demosaic).parameters["method"].default, args.demosaic]),
        (TONEMAP_METHODS, [inspect.signature(tonemap).parameters["method"].default, args.tonemap]),
    ):
        assert used == [default_method(table)] * 2
    assert defaults["demosaic"].default == default_method(DEMOSAIC_METHODS)
    assert defaults["tonemap"].default == default_method(TONEMAP_METHODS)
