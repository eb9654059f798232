"""isp's default brightness: LibRaw's auto-bright (1 % of the pixels to white, no tone curve).

The truth is a brute-force count of the pixels at or above a level per channel (dcraw's rule, read
in ``convert_to_rgb``), and on the real files rawpy's own rendering.
"""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import isp
from isp import PipelineError, auto_bright_white, tonemap_auto_bright


def _brute_white(rgb: np.ndarray, fraction: float) -> float:
    """Per channel the largest value v such that more than fraction·N pixels are ≥ v; max over channels."""
    flat = rgb.reshape(-1, 3)
    allowed = fraction * flat.shape[0]
    best = 0.0
    for ch in flat.T:
        s = np.sort(ch)[::-1]
        best = max(best, float(s[int(np.floor(allowed))]))  # the (⌊allowed⌋+1)-th largest value
    return best


@settings(max_examples=40, deadline=None)
@given(
    seed=st.integers(0, 2**31),
    n=st.integers(50, 3000),
    fraction=st.sampled_from([0.001, 0.01, 0.05, 0.3]),
    scale=st.floats(1e-3, 1e3),
)
def test_white_is_the_level_that_fraction_of_the_pixels_reach(seed, n, fraction, scale):
    rgb = np.random.default_rng(seed).gamma(1.5, 0.2, (n, 3)) * [1.0, 0.7, 0.4] * scale
    white = auto_bright_white(rgb, fraction=fraction)
    truth = _brute_white(rgb, fraction)
    step = rgb.max() / isp._tol.AUTO_BRIGHT_BINS  # the histogram's bin width
    assert truth - step <= white <= truth + 1e-12 * truth


def test_auto_bright_output(monkeypatch):
    rng = np.random.default_rng(1)
    rgb = (rng.gamma(2.0, 0.1, (120, 70, 3)) * [1.0, 0.8, 0.5]).astype(np.float32)
    out = tonemap_auto_bright(rgb)
    assert out.dtype == np.float32 and out.shape == rgb.shape and out.min() >= 0 and out.max() == 1
    white = auto_bright_white(rgb)
    np.testing.assert_allclose(out, np.clip(rgb / white, 0, 1), rtol=1e-6)
    clipped = np.mean(out[..., 0] >= 1)  # the red channel is the brightest: 1 % reach white
    assert 0.009 <= clipped <= 0.011
    # exposure invariant: a photograph two stops under develops to the same image
    np.testing.assert_allclose(tonemap_auto_bright(rgb / 4), out, atol=2e-6)
    np.testing.assert_allclose(
        tonemap_auto_bright(rgb, exposure=-1), np.clip(rgb / white / 2, 0, 1), rtol=1e-6
    )
    monkeypatch.setattr(isp._tol, "CHUNK_PIXELS", 37)  # in chunks: the same
    np.testing.assert_array_equal(tonemap_auto_bright(rgb), out)
    np.testing.assert_array_equal(tonemap_auto_bright(np.zeros((4, 4, 3))), np.zeros((4, 4, 3)))
    for bad in (0, 1, -0.1, float("nan"), True):
        with pytest.raises(PipelineError, match="fraction"):
            tonemap_auto_bright(rgb, fraction=bad)
    with pytest.raises(PipelineError, match="exposure"):
        tonemap_auto_bright(rgb, exposure=1e6)


def test_the_default_rendering_is_auto_bright():
    assert isp.default_method(isp.TONEMAP_METHODS) == "auto-bright"
    assert isp.TONEMAP_METHODS.properties("auto-bright")["reach"] is None  # global: a histogram


@pytest.mark.parametrize("name", ["dng_550d", "crw_d30"])
def test_default_brightness_matches_rawpy(name, request):
    """The issue's bound: isp's default rendering within 0.3 stop of rawpy's default postprocess()
    (median luminance as a viewer shows both, i.e. decoded with the sRGB EOTF)."""
    rawpy = pytest.importorskip("rawpy")
    import colour

    path = request.getfixturevalue(name)
    Y = np.asarray(colour.RGB_COLOURSPACES["sRGB"].matrix_RGB_to_XYZ[1])

    def shown(encoded):
        return np.median(colour.models.eotf_sRGB(np.clip(np.asarray(encoded, np.float64), 0, 1)) @ Y)

    with rawpy.imread(str(path)) as r:
        ref = shown(r.postprocess(user_flip=0) / 255.0)
    ours = shown(isp.develop(path, keep=False).image)
    assert abs(np.log2(ours / ref)) <= 0.3
