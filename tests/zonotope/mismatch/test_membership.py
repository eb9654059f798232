"""Batched exact MMV membership against the HiGHS feasibility LP and the exact MMV polytope."""

from __future__ import annotations

import colour
import numpy as np
import pytest
from scipy.optimize import linprog

import zonotope
from zonotope import GeometryError
from zonotope.mismatch import metamer_mismatch
from zonotope.mismatch.membership import joint_halfspaces, mmv_contains


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


def l1_lp(Phi, Psi, c, y):
    """HiGHS twin of mmv_distance: min Σ|Ψᵀx − y| s.t. Φᵀx = c, 0 ≤ x ≤ 1 (NaN if infeasible)."""
    n, k, m = Phi.shape[0], Phi.shape[1], Psi.shape[1]
    A = np.vstack([np.hstack([Phi.T, np.zeros((k, 2 * m))]), np.hstack([Psi.T, -np.eye(m), np.eye(m)])])
    r = linprog(
        np.r_[np.zeros(n), np.ones(2 * m)],
        A_eq=A,
        b_eq=np.r_[c, y],
        bounds=[(0, 1)] * n + [(0, None)] * (2 * m),
        method="highs",
    )
    return r.fun if r.status == 0 else np.nan


def test_mmv_distance_matches_the_lp_twin_and_membership(cameras):
    from zonotope.mismatch.membership import mmv_distance, outside_mmv_fraction

    Phi, Psi = cameras
    rng = np.random.default_rng(3)
    x = rng.random((30, Phi.shape[0]))
    C = x @ Phi
    Y = x @ Psi + 0.02 * rng.normal(size=(30, 3))
    Y[:5] = x[:5] @ Psi  # true pairs: distance 0
    d = mmv_distance(Phi, Psi, C, Y)
    ref = np.array([l1_lp(Phi, Psi, c, y) for c, y in zip(C, Y, strict=True)])
    np.testing.assert_allclose(d, ref, rtol=0, atol=1e-12)
    assert np.all(d[:5] <= 1e-12) and np.any(d > 1e-3) and np.any((d > 0) & (d < 1e-3) | (d == 0))
    inside = mmv_contains(Phi, Psi, C, Y)
    clear = (d > 1e-7) | (d == 0)  # away from the boundary the facet test and the distance agree
    np.testing.assert_array_equal(inside[clear], d[clear] <= 1e-9)
    assert outside_mmv_fraction(Phi, Psi, C, Y) == pytest.approx(np.mean(d > 1e-9))
    assert outside_mmv_fraction(Phi, Psi, C, Y, atol=1.0) == 0.0
    # leading axes, an infeasible source response (NaN, left out of the share), bad input
    assert mmv_distance(Phi, Psi, C.reshape(3, 10, 3), Y.reshape(3, 10, 3)).shape == (3, 10)
    bad = np.array([[2.0, 2.0, 2.0]])
    assert np.isnan(mmv_distance(Phi, Psi, bad, Y[:1])).all() and np.isnan(l1_lp(Phi, Psi, bad[0], Y[0]))
    assert np.isnan(outside_mmv_fraction(Phi, Psi, bad, Y[:1]))
    with pytest.raises(GeometryError, match="leading shape"):
        mmv_distance(Phi, Psi, C, Y[:3])
    with pytest.raises(GeometryError, match="NaN"):
        outside_mmv_fraction(Phi, Psi, C, np.full_like(Y, np.nan))
    with pytest.raises(GeometryError, match="atol"):
        outside_mmv_fraction(Phi, Psi, C, Y, atol=-1.0)


def test_solid_distance_matches_an_independent_lp_of_the_joint_solid(cameras):
    """Two cameras' responses of one reflectance lie in their joint solid (distance 0); pairs moved
    off it are as far as HiGHS's L1 LP over the stacked generators says, with no source fixed."""
    from zonotope.mismatch.membership import solid_distance

    Phi, Psi = cameras
    J = np.hstack([Phi, Psi])
    n, k = J.shape
    rng = np.random.default_rng(5)
    x = rng.random((25, n))
    Z = x @ J
    Z[5:] += 0.05 * rng.normal(size=(20, k))
    Z[-1] = [0.03, 0.03, 0.03, 0.45, 0.2, 0.06]  # dark for one camera, bright for the other
    d = solid_distance(J, Z)

    def lp(z):  # min Σ|Jᵀx − z| over 0 ≤ x ≤ 1, slacks s⁺, s⁻ ≥ 0
        A = np.hstack([J.T, -np.eye(k), np.eye(k)])
        r = linprog(
            np.r_[np.zeros(n), np.ones(2 * k)], A_eq=A, b_eq=z, bounds=[(0, 1)] * n + [(0, None)] * 2 * k
        )
        return r.fun

    np.testing.assert_allclose(d, [lp(z) for z in Z], rtol=0, atol=1e-10)
    assert np.all(d[:5] <= 1e-12) and np.all(d >= 0) and d[-1] > 0.1
    assert solid_distance(J, Z.reshape(5, 5, k)).shape == (5, 5)
    with pytest.raises(GeometryError, match="NaN"):
        solid_distance(J, np.full((1, k), np.nan))
