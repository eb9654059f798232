"""White-point preserving estimates (``white_point=True``): a response proportional to the white's maps to
the grey's colour however noisy the responses the estimator was fitted for; near-grey estimates of the MMV
centroid stay inside the δ-widened metamer set; chromatic colours are left alone; the option is a registry
fact and survives a saved correction."""

from __future__ import annotations

import colour
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.optimize import linprog

from zonotope._errors import OptionError
from zonotope._tol import (
    NEUTRAL_CHROMA,
    NEUTRAL_GREY_DE00,
    NEUTRAL_GREY_SOLVED_DE00,
    NEUTRAL_LEVELS,
    NEUTRAL_SHIFT_EXACT,
)
from zonotope.correct import CORRECTION_METHODS, DELTA_SIGMAS, correction_problem, fit_correction

GRID = np.arange(400.0, 701.0, 10.0)
DELTA = 0.13  # the largest tolerance of docs/notes/2026-11-29-neutral-cast.md: the largest bias
SIGMA = DELTA / DELTA_SIGMAS


@pytest.fixture(scope="module")
def problem():
    return correction_problem(["Nikon 5100 (NPL)"], shape=GRID)


@pytest.fixture(scope="module")
def fitted(problem):
    """``(method, white_point) → corrector`` fitted for σ = δ / DELTA_SIGMAS, memoised for the module."""
    cache = {}

    def fit(method, white_point):
        if (method, white_point) not in cache:
            opts = {"delta": DELTA} if method == "Centroid" else {"noise": SIGMA}
            cache[method, white_point] = fit_correction(
                problem, method=method, white_point=white_point, **opts
            )
        return cache[method, white_point]

    return fit


def _grey(problem, s):
    """Response and colour of the spectrally flat grey of reflectance ``s`` (independent of the offsets)."""
    x = np.full((1, GRID.size), s)
    return problem.source_of(x), problem.target_of(x)


@pytest.mark.parametrize("method", ["Cheung 2004", "Finlayson 2015", "Guarded"])
@settings(max_examples=25, deadline=None)
@given(log2_s=st.floats(min_value=-10.0, max_value=0.0))
def test_a_scaled_white_maps_to_the_scaled_white(problem, fitted, method, log2_s):
    c, t = _grey(problem, 2.0**log2_s)
    est = fitted(method, True)(c)
    assert problem.delta_E(est, t)[0] <= NEUTRAL_GREY_DE00


def test_without_the_option_light_greys_are_biased(problem, fitted):
    """The control: fitted for δ = 0.13, the default regression moves the 0.9 grey by far more than the
    tolerance (so the test above can fail), and the option removes it."""
    c, t = _grey(problem, 0.9)
    plain = problem.delta_E(fitted("Finlayson 2015", False)(c), t)[0]
    assert plain > 1e4 * NEUTRAL_GREY_DE00
    assert problem.delta_E(fitted("Finlayson 2015", True)(c), t)[0] <= NEUTRAL_GREY_DE00


def _in_widened_set(problem, c, t, delta) -> bool:
    """HiGHS: is there a reflectance x in [0, 1]ⁿ with |Φᵀx − c| ≤ δ per channel and Ψᵀx = t?"""
    Phi, Psi = problem.Phi, problem.Psi
    res = linprog(
        np.zeros(Phi.shape[0]),
        A_ub=np.vstack([Phi.T, -Phi.T]),
        b_ub=np.concatenate([c + delta, delta - c]),
        A_eq=Psi.T,
        b_eq=t,
        bounds=(0.0, 1.0),
        method="highs",
    )
    return res.status == 0


@settings(max_examples=8, deadline=None)
@given(
    s=st.floats(min_value=0.05, max_value=0.95),
    amplitude=st.floats(min_value=0.0, max_value=0.08),
    cycles=st.floats(min_value=0.5, max_value=3.0),
    phase=st.floats(min_value=0.0, max_value=6.3),
)
def test_near_grey_centroid_estimates_stay_in_the_widened_set(problem, fitted, s, amplitude, cycles, phase):
    x = np.clip(s * (1.0 + amplitude * np.sin(np.pi * cycles * (GRID - 400.0) / 300.0 + phase)), 0.0, 1.0)
    c = problem.source_of(x[None])
    est = fitted("Centroid", True)(c)[0]
    # a centroid certified to eps = 1e-3 in response units: the set is widened by that much more
    assert _in_widened_set(problem, c[0], est, DELTA + 1e-3)


def test_chromatic_colours_keep_their_estimates(problem, fitted):
    cc = colour.SDS_COLOURCHECKERS["ColorChecker N Ohta"]
    shape = colour.SpectralShape(GRID[0], GRID[-1], 10)
    X = np.array([cc[name].copy().interpolate(shape).values for name in list(cc)[:18]])
    c, t = problem.source_of(X), problem.target_of(X)
    chroma = np.hypot(*problem.to_Lab(t)[:, 1:].T)
    far = chroma > 8 * NEUTRAL_CHROMA
    assert far.sum() >= 5
    plain, white = fitted("Finlayson 2015", False)(c[far]), fitted("Finlayson 2015", True)(c[far])
    assert np.max(problem.delta_E(plain, white)) < 1e-6


def test_white_point_is_a_registry_fact(problem):
    for name in CORRECTION_METHODS:
        assert isinstance(CORRECTION_METHODS.properties(name)["white_point"], bool)
    with pytest.raises(OptionError, match="white_point"):
        fit_correction(problem, method="Cheung 2004", white_point="yes")
    cor = fit_correction(problem, method="Cheung 2004", white_point=True)
    assert cor.params["white_point"] is True
    assert cor.params["neutral_levels"].tolist() == list(NEUTRAL_LEVELS)
    assert fit_correction(problem, method="Cheung 2004", white_point=False).params["white_point"] is False


def test_saved_white_point_correction_reloads_the_same(problem, fitted, tmp_path):
    from zonotope.correct import load_correction, save_correction

    cor = fitted("Finlayson 2015", True)
    c = problem.source_of(np.vstack([np.full(GRID.size, 0.9), np.linspace(0.1, 0.8, GRID.size)]))
    back = load_correction(save_correction(tmp_path / "wp.npz", cor))
    assert back.params["white_point"] is True
    np.testing.assert_allclose(back(c), cor(c), rtol=1e-12, atol=1e-14)
    plain = load_correction(save_correction(tmp_path / "plain.npz", fitted("Finlayson 2015", False)))
    assert plain.params["white_point"] is False


def test_prior_image_path_and_radii_follow_the_offset(problem):
    """Prior's closed-form pass (used by ``correct_image``) and its credible radii get the same offset as
    its estimates: greys at the tabulated levels come out as the grey's colour on every path."""
    from zonotope.correct import correct_image

    prior = fit_correction(problem, method="Prior", noise=SIGMA, mix=1.0, white_point=True)
    s = np.array([v for v in NEUTRAL_LEVELS if v >= 0.05])
    x = s[:, None] * np.ones(GRID.size)
    c, t = problem.source_of(x), problem.target_of(x)
    image = correct_image(c[:, None], prior, quantum=0.0)[:, 0]
    with_radius, radius = prior.with_uncertainty(c)
    for est in (prior(c), image, with_radius):
        assert np.max(problem.delta_E(est, t)) <= NEUTRAL_GREY_SOLVED_DE00
    assert np.all(np.isfinite(radius))
    plain = fit_correction(problem, method="Prior", noise=SIGMA, mix=1.0)
    assert np.max(problem.delta_E(plain(c), t)) > 100 * NEUTRAL_GREY_SOLVED_DE00


@settings(max_examples=50, deadline=None)
@given(
    XYZ=st.lists(st.floats(min_value=-0.05, max_value=1.5, allow_nan=False), min_size=3, max_size=3).map(
        np.array
    ),
    dim=st.floats(min_value=-6.0, max_value=0.0),
)
def test_lab_chroma_terms_match_colour_science(problem, XYZ, dim):
    """``_lab_f`` (``np.cbrt`` above the floor) gives colour.XYZ_to_Lab's a*, b* for any XYZ, dark ones
    (the linear branch, negative values) included."""
    from zonotope.correct.neutral import _lab_f

    white = problem.white_XYZ
    XYZ = XYZ * 10.0**dim
    f = _lab_f(XYZ / white)
    lab = colour.XYZ_to_Lab(XYZ / white[1], colour.XYZ_to_xy(white))
    np.testing.assert_allclose(500.0 * (f[0] - f[1]), lab[1], rtol=0, atol=NEUTRAL_SHIFT_EXACT)
    np.testing.assert_allclose(200.0 * (f[1] - f[2]), lab[2], rtol=0, atol=NEUTRAL_SHIFT_EXACT)


@pytest.mark.parametrize("method", ["Finlayson 2015", "Prior"])
@settings(max_examples=10, deadline=None)
@given(seed=st.integers(min_value=0, max_value=2**31 - 1), spread=st.floats(min_value=0.0, max_value=0.5))
def test_the_offset_is_its_definition(problem, fitted, prior, method, seed, spread):
    """The offset estimate equals its definition evaluated the plain way: ``β`` by ``np.interp`` per
    channel, the fade weight from ``colour.XYZ_to_Lab``'s chroma of ``t̂(c) + s·β(s)`` (near-grey,
    chromatic, dark, negative and beyond-the-table responses)."""
    from zonotope.correct.neutral import white_point_preserving

    base = fitted("Finlayson 2015", False) if method == "Finlayson 2015" else prior
    rng = np.random.default_rng(seed)
    c_w = problem.Phi.sum(axis=0)
    s = 2.0 ** rng.uniform(-14.0, 0.5, 256)
    c = s[:, None] * c_w * (1.0 + spread * rng.normal(size=(256, c_w.size)))
    c = np.vstack([c, -0.01 * c_w, 0.0 * c_w]).astype(np.float32)
    t = base(c).astype(np.float64)
    wp = white_point_preserving(base)
    levels, beta, chroma = (
        wp.params["neutral_levels"],
        wp.params["neutral_offsets"],
        wp.params["neutral_chroma"],
    )
    g_s = (c.astype(np.float64) @ c_w) / (c_w @ c_w)
    ls = np.log(np.clip(g_s, levels[0], levels[-1]))
    b = (
        np.stack([np.interp(ls, np.log(levels), beta[:, j]) for j in range(3)], -1)
        * np.maximum(g_s, 0)[:, None]
    )
    lab = problem.to_Lab(t + b)
    g = np.nan_to_num(np.exp(-0.5 * (np.hypot(lab[:, 1], lab[:, 2]) / chroma) ** 2))
    np.testing.assert_allclose(wp(c), t + g[:, None] * b, rtol=0, atol=NEUTRAL_SHIFT_EXACT)


@pytest.fixture(scope="module")
def prior(problem):
    return fit_correction(problem, method="Prior", noise=SIGMA, mix=1.0)
