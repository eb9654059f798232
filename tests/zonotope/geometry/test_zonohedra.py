"""Independent checks against the R package zonohedra (Glenn Davis), vignette ``transitions.Rmd``.

The vignette builds the zonohedron of the CIE 1931 2° CMFs at 1 nm (360–830 nm), scaled so that
the centre has Y = 50, and prints (``transitionsdf``): 340 simplified generators (360–699 nm),
340·339 = 115,260 boundary parallelograms, 33110 of 34669 area units (95.5 %) on 2-transition
("coincident") parallelograms, and 1802 parallelograms with 8 transitions, {570, 608} the
largest of them. Nothing below is copied from zonohedra's output except those figures.
"""

from __future__ import annotations

import colour
import numpy as np
import pytest

from zonotope import Tolerances, Zonotope


@pytest.fixture(scope="module")
def cie1931():
    cmfs = colour.MSDS_CMFS["CIE 1931 2 Degree Standard Observer"]
    assert cmfs.shape.start == 360 and cmfs.shape.end == 830 and cmfs.shape.interval == 1
    G = 100.0 * cmfs.values / cmfs.values[:, 1].sum()  # Y of the perfect white = 100
    return cmfs.wavelengths, G


@pytest.fixture(scope="module")
def tiles(cie1931):
    wl, G = cie1931
    Z = Zonotope(colour.MultiSpectralDistributions(G, wl), tol=Tolerances(parallel=1e-6))
    return Z, Z.parallelograms()


def test_simplified_generators_and_parallelograms(tiles):
    Z, t = tiles
    assert Z.centroid[1] == pytest.approx(50.0, abs=1e-12)
    p = Z._reduced[0].shape[0]
    assert p == 340
    assert 2 * t.pairs.shape[0] == 340 * 339 == 115_260
    firsts = np.unique(t.wavelengths)
    assert firsts[0] == 360 and firsts[-1] == 699  # the tail from 699 nm is one generator
    # the tiling covers the boundary: total area = surface of the exact mesh
    assert 2 * t.area.sum() == pytest.approx(Z.to_trimesh().area, rel=1e-9)
    assert round(2 * t.area.sum()) == 34669


def test_default_tolerance_keeps_the_rounded_tail_apart(cie1931):
    """colour-science's 6-digit tail is parallel only to ~5e-7: the default 1e-7 keeps 346."""
    Z = Zonotope(cie1931[1])
    assert Z._reduced[0].shape[0] == 346 and Z.n_generators == 471


def test_transition_table(tiles):
    t = tiles[1]
    tr, area = t.transitions, t.area
    assert np.all(tr % 2 == 0) and tr.min() == 2
    coincident = 2 * area[tr == 2].sum()
    total = 2 * area.sum()
    assert round(coincident) == 33110 and round(100 * coincident / total, 1) == 95.5
    eight = tr == 8
    assert 2 * np.count_nonzero(eight) == 1802
    k = np.argmax(np.where(eight, area, -1.0))
    assert tuple(t.wavelengths[k]) == (570.0, 608.0)


@pytest.mark.parametrize("seed", [3, 4])
def test_transitions_by_brute_force_over_step_functions(seed):
    """Small solids: each tile's count is the fewest circular jumps of a step function whose
    interval means are the tile centre's cube point (each ½ needs a jump inside its interval)."""
    rng = np.random.default_rng(seed)
    G = rng.normal(size=(9, 3)) + np.array([1.0, 0.5, 0.0])  # some generators get flipped by the reduction
    Z = Zonotope(G)
    t = Z.parallelograms()
    for (I, J), tr in zip(t.pairs, t.transitions):
        n = np.cross(Z._reduced[0][I], Z._reduced[0][J])
        x = (G @ n > 0).astype(float)
        free = [I, J]
        # fewest circular transitions over step functions: try x_I, x_J ∈ {0, 1} both ways round,
        # a ½ realised by a jump inside its interval (brute force over the four end values)
        best = 99
        for a in (0, 1):
            for b in (0, 1):
                for a2 in (0, 1):
                    for b2 in (0, 1):
                        y = []
                        for k, v in enumerate(x):
                            if k == free[0]:
                                y += [a, a2]
                            elif k == free[1]:
                                y += [b, b2]
                            else:
                                y += [v, v]
                        y = np.array(y)
                        if y[2 * free[0]] == y[2 * free[0] + 1] or y[2 * free[1]] == y[2 * free[1] + 1]:
                            continue  # a ½ needs a jump inside its interval
                        best = min(best, int(np.count_nonzero(y != np.roll(y, 1))))
        assert tr == best
