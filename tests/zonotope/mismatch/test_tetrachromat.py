"""Four target channels (a tetrachromat observer, camera → camera): solids and exact MMVs in 4-D."""

from __future__ import annotations

import itertools

import colour
import numpy as np
import pytest
from scipy.optimize import linprog
from scipy.spatial import ConvexHull

import zonotope
from zonotope import Zonotope
from zonotope.mismatch import metamer_mismatch, metamer_mismatch_bounds


@pytest.fixture(scope="module")
def problem():
    """Nikon 5100 (3 channels) → a tetrachromat: Stockman & Sharpe LMS plus a fourth cone, the M
    cone shifted by 30 nm (between M and L, as in heterozygous carriers of anomalous trichromacy)."""
    grid = colour.SpectralShape(400, 700, 30)
    Phi = zonotope.generators("Nikon 5100 (NPL)", "D65", grid).values
    lms = zonotope.generators("Stockman & Sharpe 2°", "D65", grid).values
    extra = np.roll(lms[:, 1], 1)  # 30 nm
    Psi = np.column_stack([lms, extra / extra.sum()])
    return Phi, Psi


def test_four_channel_solid_against_brute_force(problem):
    _, Psi = problem
    G = Psi[:9]  # 9 generators: 512 corners
    Z = Zonotope(G)
    P = np.array(list(itertools.product([0.0, 1.0], repeat=G.shape[0]))) @ G
    hull = ConvexHull(P)
    assert Z.ambient_dim == 4 and Z.affine_dim == 4
    assert Z.volume == pytest.approx(hull.volume, rel=1e-9)
    rng = np.random.default_rng(0)
    U = rng.normal(size=(50, 4))
    np.testing.assert_allclose(Z.support(U).value, (U @ P.T).max(axis=1), rtol=1e-12)
    Q = P.min(0) + (P.max(0) - P.min(0)) * rng.random((40, 4))
    margin = (Q @ hull.equations[:, :4].T + hull.equations[:, 4]).max(axis=1)
    clear = np.abs(margin) > 1e-6
    np.testing.assert_array_equal(Z.contains(Q)[clear], (margin <= 0)[clear])


@pytest.mark.slow
@pytest.mark.parametrize("seed", [1])
def test_four_channel_mmv_exact_vs_highs_twin(problem, seed):
    Phi, Psi = problem
    x = np.random.default_rng(seed).random(Phi.shape[0])
    c = x @ Phi
    fast = metamer_mismatch(Phi, Psi, c)
    ref = metamer_mismatch(Phi, Psi, c, oracle="highs")
    assert fast.affine_dim == 4 and fast.ambient_dim == 4
    assert fast.volume == pytest.approx(ref.volume, rel=1e-9)
    assert bool(fast.contains(x @ Psi))
    # support in random directions = the LP max over the fibre (independent of both oracles)
    for u in np.random.default_rng(seed + 5).normal(size=(6, 4)):
        lp = linprog(-(Psi @ u), A_eq=Phi.T, b_eq=c, bounds=(0, 1), method="highs")
        assert (fast.vertices @ u).max() == pytest.approx(-lp.fun, abs=1e-9)
    b = metamer_mismatch_bounds(Phi, Psi, c, eps=1e-3)
    assert b.inner.volume <= fast.volume * (1 + 1e-9) and fast.volume <= b.outer.volume * (1 + 1e-9)


def test_camera_to_camera_four_channels(problem):
    """A 4-channel source (camera + a fourth filter) to the 4-channel target: still exact."""
    Phi, Psi = problem
    Phi4 = np.column_stack([Phi, Psi[:, 3]])
    x = np.random.default_rng(3).random(Phi.shape[0])
    mmv = metamer_mismatch(Phi4, Psi, x @ Phi4)
    # the fourth target channel is measured by the source: the MMV is flat along it
    assert mmv.affine_dim == 3
    assert np.allclose(mmv.vertices[:, 3], x @ Psi[:, 3], atol=1e-9)
    assert bool(mmv.contains(x @ Psi))
