"""Batched exact MMV membership against the HiGHS feasibility LP and the exact MMV polytope."""

from __future__ import annotations

import colour
import numpy as np
import pytest
from scipy.optimize import linprog

import zonotope
from zonotope import GeometryError
from zonotope.membership import joint_halfspaces, mmv_contains
from zonotope.mismatch import metamer_mismatch


@pytest.fixture(scope="module")
def cameras():
    grid = colour.SpectralShape(400, 700, 25)
    Phi = zonotope.generators("Nikon 5100 (NPL)", "D65", grid).values
    Psi = zonotope.generators("Stockman & Sharpe 2°", "D65", grid).values
    return Phi, Psi


def feasible(Phi, Psi, c, y):
    A = np.concatenate([Phi, Psi], axis=1).T
    r = linprog(np.zeros(Phi.shape[0]), A_eq=A, b_eq=np.concatenate([c, y]), bounds=(0, 1), method="highs")
    return r.status == 0


def test_matches_the_lp_twin_and_the_exact_mmv(cameras):
    Phi, Psi = cameras
    rng = np.random.default_rng(0)
    x = rng.random((4, Phi.shape[0]))
    hs = joint_halfspaces(np.concatenate([Phi, Psi], axis=1))
    for xi in x:
        c = xi @ Phi
        mmv = metamer_mismatch(Phi, Psi, c)
        lo, hi = mmv.vertices.min(0), mmv.vertices.max(0)
        Y = np.concatenate([lo - 0.1 * (hi - lo) + 1.2 * (hi - lo) * rng.random((40, 3)), [xi @ Psi]])
        got = mmv_contains(Phi, Psi, np.broadcast_to(c, Y.shape), Y, halfspaces=hs)
        assert got[-1]  # the truth is always seeable
        ref = np.array([feasible(Phi, Psi, c, y) for y in Y])
        span = float((hi - lo).max())
        clear = mmv.contains(Y, atol=1e-6 * span) == mmv.contains(Y, atol=-1e-6 * span)
        np.testing.assert_array_equal(got[clear], ref[clear])
        np.testing.assert_array_equal(got[clear], mmv.contains(Y)[clear])
        assert 0 < got.sum() < got.size and clear.sum() >= 35


def test_shapes_and_bad_input(cameras):
    Phi, Psi = cameras
    x = np.random.default_rng(1).random((2, 3, Phi.shape[0]))
    out = mmv_contains(Phi, Psi, x @ Phi, x @ Psi)
    assert out.shape == (2, 3) and out.all()
    with pytest.raises(GeometryError, match="leading shape"):
        mmv_contains(Phi, Psi, np.zeros((2, 3)), np.zeros((3, 3)))
    with pytest.raises(GeometryError, match="NaN"):
        mmv_contains(Phi, Psi, [np.nan, 0, 0], [0, 0, 0])
