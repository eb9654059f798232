"""The honest baselines and region means of :mod:`splat.scoring`."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st


@pytest.fixture(scope="module")
def spec(tmp_path_factory):
    from splat.capture import read_capture

    root = tmp_path_factory.mktemp("scoring")
    (root / "capture.toml").write_text(
        'illuminant = "D65"\nobserver = "CIE 1931 2 Degree Standard Observer"\n\n'
        '[[camera]]\nfolder = "nikon"\nssf = "Nikon 5100 (NPL)"\n\n'
        '[[camera]]\nfolder = "canon"\nssf = "Canon EOS 5D Mark II"\n'
    )
    for f in ("nikon", "canon"):  # read_capture lists the files; nothing here reads them
        (root / f).mkdir()
        (root / f / "a.dng").write_bytes(b"")
    return read_capture(root)


@settings(deadline=None)
@given(widths=st.lists(st.integers(1, 9), min_size=1, max_size=6), height=st.integers(3, 9))
def test_region_labels_find_every_stripe_wide_enough(widths, height):
    """Vertical stripes of distinct colours: a stripe is one region iff it keeps a column whose 5 × 5
    neighbourhood lies inside it (borders extended), and it has at least REGION_MIN_PIXELS pixels."""
    from splat._tol import REGION_MIN_PIXELS
    from splat.scoring import region_labels

    cols = np.concatenate([np.full(w, i) for i, w in enumerate(widths)])
    colours = 0.1 + 0.8 * np.arange(len(widths))[:, None] / len(widths) * np.array([1.0, 0.9, 0.7])
    img = np.broadcast_to(colours[cols][None], (height, len(cols), 3)).copy()
    labels, chart = region_labels(img)
    expected = 0
    x = 0
    for i, w in enumerate(widths):
        inner = w - 2 * (i > 0) - 2 * (i < len(widths) - 1)  # columns two pixels from another stripe
        if inner > 0 and inner * height >= REGION_MIN_PIXELS:
            expected += 1
            region = labels[:, x : x + w]
            assert len(np.unique(region[region > 0])) == 1
        x += w
    assert len(np.unique(labels[labels > 0])) == expected
    assert chart == {}


def test_region_means_average_the_noise_and_name_the_chart_patch(spec):
    """An estimate off by zero-mean noise within each region scores ≈ 0 per region mean but not per
    pixel; a region whose true colour is a chart patch's counts as chart, the other as uniform."""
    from splat.capture import correction_problem_of
    from splat.scoring import _chart_XYZ, _dE_all, _region_dE, region_labels

    C = _chart_XYZ(spec)
    ref = np.zeros((8, 20, 3))
    ref[:, :10] = C[7]  # a chart patch
    ref[:, 10:] = [0.3, 0.2, 0.1]  # a uniform surface of no chart colour
    labels, chart = region_labels(ref, C)
    assert sorted(chart.values()) == [7] and len(np.unique(labels[labels > 0])) == 2
    noise = np.where(np.arange(8)[:, None, None] % 2, 0.02, -0.02) * np.ones((1, 20, 3))  # rows: all in
    problem = correction_problem_of(spec, [0])
    assert _dE_all(problem, ref + noise, ref).mean() > 1
    ch, un = _region_dE(problem, ref + noise, ref, labels, chart)
    assert len(ch) == len(un) == 1 and max(ch + un) < 1e-6
    ch, un = _region_dE(problem, ref * [1.05, 1, 1], ref, labels, chart)
    assert min(ch + un) > 1  # a colour shift is not averaged away


def test_chart_xyz_against_colour_science(spec):
    """The chart's XYZ under D65 as colour-science integrates it (Y of the perfect white = 1)."""
    import colour

    from splat.scoring import _chart_XYZ

    C = _chart_XYZ(spec)
    sds = colour.SDS_COLOURCHECKERS["ColorChecker N Ohta"]
    cmfs = colour.MSDS_CMFS["CIE 1931 2 Degree Standard Observer"]
    ref = np.array(
        [
            colour.sd_to_XYZ(sd, cmfs, colour.SDS_ILLUMINANTS["D65"], method="Integration")
            for sd in sds.values()
        ]
    )
    assert np.allclose(C, ref / 100, rtol=2e-3, atol=2e-4)


def test_chart_matrix_is_the_least_squares_fit(spec):
    """Normal equations hold on the chart (independently integrated); it develops the chart well."""
    import zonotope
    from splat.capture import correction_problem_of
    from splat.scoring import _dE_all, chart_matrix

    M = chart_matrix(spec, 1)
    p = correction_problem_of(spec, [1])
    R = np.asarray(zonotope.resample(zonotope.reflectances("ColorChecker N Ohta"), p.wavelengths)).T
    c, X = R @ p.Phi, R @ p.Psi
    assert np.allclose(c.T @ (c @ M - X), 0, atol=1e-10)
    d = _dE_all(p, c @ M, X)
    assert d.mean() < 3  # a 3 × 3 matrix's typical chart error, far from a units blunder
    assert np.allclose(np.ones(3) @ M, p.white_XYZ, rtol=0.03)  # white → 1 develops near the white


def test_develop_does_not_clip_before_the_matrix(spec):
    """A full-colour view with a negative (noisy black) response keeps it through the matrix."""
    from types import SimpleNamespace

    from splat.scoring import chart_matrix, develop

    M = chart_matrix(spec, 0)
    vals = np.array([[[0.5, 0.5, 0.5], [-0.01, 0.2, 0.1]]])
    view = SimpleNamespace(values=vals, full_colour=True, exif=2.0, name="v", cfa=None)
    out = develop(view, np.array([0.5, 1.0, 0.8]), M)
    expect = (vals / 2.0 / [0.5, 1.0, 0.8]) @ M
    assert np.allclose(out, expect)
