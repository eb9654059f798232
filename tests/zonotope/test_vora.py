"""Vora value: closed forms and invariants (hypothesis), real cameras."""

from __future__ import annotations

import itertools

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays

import zonotope
from zonotope import rank_camera_sets, vora_value

mats = arrays(
    np.float64,
    st.tuples(st.just(31), st.integers(1, 6)),
    elements=st.floats(0.0, 1.0, allow_nan=False, width=64),
)
X_LMS = zonotope.generators("lms", "D65", np.arange(400.0, 701.0, 10.0)).values


@settings(max_examples=60, deadline=None)
@given(mats, mats)
def test_value_in_unit_interval_and_monotone_in_channels(Q, extra):
    if np.abs(Q).sum() == 0:
        return
    v = vora_value(Q, X_LMS)
    assert 0.0 <= v <= 1.0
    assert vora_value(np.hstack([Q, extra]), X_LMS) >= v - 1e-12


@settings(max_examples=40, deadline=None)
@given(arrays(np.float64, (3, 3), elements=st.floats(-2, 2, allow_nan=False, width=64)))
def test_invariant_to_invertible_channel_mixing(M):
    if abs(np.linalg.det(M)) < 1e-2:
        return
    Q = zonotope.generators("nikon 5100", "D65", np.arange(400.0, 701.0, 10.0)).values
    assert vora_value(Q @ M, X_LMS) == pytest.approx(vora_value(Q, X_LMS), abs=1e-10)


def test_closed_forms():
    assert vora_value(X_LMS, X_LMS) == pytest.approx(1.0, abs=1e-12)
    # a sensor orthogonal to the eye's span sees nothing of it
    U, _, _ = np.linalg.svd(X_LMS, full_matrices=True)
    assert vora_value(U[:, 3:6], X_LMS) == pytest.approx(0.0, abs=1e-12)
    # one of the eye's own three directions: exactly 1/3
    assert vora_value(U[:, :1], X_LMS) == pytest.approx(1 / 3, abs=1e-12)
    # rank-deficient Q (a duplicated channel) is legal and changes nothing
    Q = X_LMS[:, :2]
    assert vora_value(np.hstack([Q, Q[:, :1]]), X_LMS) == pytest.approx(vora_value(Q, X_LMS))


def test_builtin_cameras_and_sets():
    scores = rank_camera_sets(list(zonotope.CAMERAS), method="pairs")
    assert len(scores) == 3 and scores[0].vora >= scores[-1].vora
    chain = rank_camera_sets(list(zonotope.CAMERAS), method="greedy")
    assert [s.channels for s in chain] == [3, 6, 9]
    assert all(b.vora >= a.vora - 1e-12 for a, b in itertools.pairwise(chain))
    assert all(0.8 < s.vora <= 1.0 for s in chain)
    with pytest.raises(ValueError, match="'pairs' or 'greedy'"):
        rank_camera_sets(list(zonotope.CAMERAS), method="best")


def test_shared_cameras_vora(shared_data):
    paths = sorted((shared_data / "ssf_rawtoaces" / "data" / "camera").glob("*.json"))
    values = []
    for path in paths:
        cam = zonotope.load_camera(path)
        G = zonotope.generators(cam, "D65", np.arange(400.0, 701.0, 10.0)).values
        values.append(vora_value(G, X_LMS))
    assert len(values) == 52 and 0.7 < min(values) and max(values) < 1.0


def test_channels_of_wildly_different_scale_all_count():
    """A channel 1e-226 times weaker than another spans the same space as a unit one (found by
    hypothesis: its squares underflow, and a relative rank cut would drop it)."""
    tiny = np.full((31, 1), 2.97639363e-226)
    e0 = np.eye(31)[:, :1]
    assert vora_value(tiny, X_LMS) == pytest.approx(vora_value(np.ones((31, 1)), X_LMS), rel=1e-12)
    assert vora_value(np.hstack([tiny, e0]), X_LMS) >= vora_value(tiny, X_LMS)
    assert vora_value(np.zeros((31, 2)), X_LMS) == 0.0


def test_vora_value_accepts_what_generators_returns(tmp_path):
    """``generators`` takes a camera file as every entry point does, and ``vora_value`` takes its
    result (a colour MSDS) as it takes arrays."""
    grid = np.arange(400, 701, 10)
    cam = zonotope.load_camera("Nikon 5100 (NPL)")
    path = tmp_path / "nikon.csv"
    np.savetxt(path, np.column_stack([cam.wavelengths, cam.values]), delimiter=",")
    G = zonotope.generators("Nikon 5100 (NPL)", shape=grid)
    for source in (path, str(path)):
        np.testing.assert_allclose(zonotope.generators(source, shape=grid).values, G.values)
    X = zonotope.generators("CIE 1931 2°", shape=grid)
    assert zonotope.vora_value(G, X) == pytest.approx(zonotope.vora_value(G.values, X.values))
    with pytest.raises(zonotope.SpectralDataError, match="grid"):
        zonotope.vora_value(G, zonotope.generators("CIE 1931 2°", shape=np.arange(400, 701, 5)))
    with pytest.raises(zonotope.SpectralDataError, match="not found"):
        zonotope.generators(tmp_path / "missing.csv")
