"""The exact max-norm distance of a response to the source solid (``volume._solid_distance``) against
its reference twin, the HiGHS LP, and the MMVs of responses outside the solid with either."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import zonotope.mismatch.volume as volume
from zonotope.correct import correction_problem
from zonotope.geometry.lp import distance_to_zonotope
from zonotope.mismatch import metamer_mismatch_batch


@settings(max_examples=20, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), n=st.integers(3, 31), k=st.integers(2, 4))
def test_distance_matches_the_lp(seed, n, k):
    """Random generators (some signed, some zero rows) and responses inside and far outside: the facet
    formula equals HiGHS' distance to its feasibility tolerance, and is 0 for responses of reflectances."""
    rng = np.random.default_rng(seed)
    Phi = rng.uniform(-0.2, 1.0, (n, k)) * (rng.random((n, 1)) > 0.1)
    X = rng.random((6, n))
    inside = X @ Phi
    outside = rng.uniform(-1.0, 2.0, (10, k)) * Phi.sum(axis=0).clip(0.5)
    C = np.vstack([inside, outside])
    d = volume._solid_distance(Phi, C)
    ref = np.array([distance_to_zonotope(Phi, np.zeros(k), c)[0] for c in C])
    scale = float(np.abs(Phi).sum(axis=0).max())
    np.testing.assert_allclose(d, ref, atol=1e-7 * scale, rtol=0)
    assert np.all(d[: len(inside)] <= 1e-12 * scale)


def test_too_many_facet_directions_falls_back_to_the_lp():
    """Two stacked cameras (k = 6, C(37, 5) subsets): no facet formula, the LP answers instead."""
    pb = correction_problem(["Nikon 5100 (NPL)", "Canon EOS 5D Mark II"])
    assert volume._solid_distance(pb.Phi, pb.Phi.sum(axis=0)[None]) is None


def test_outside_responses_give_the_mmvs_of_the_lp_distance(monkeypatch):
    """``on_infeasible="nearest"`` with the exact distance: the same MMVs (centroids within 1e-9 of the
    white, volumes within 1e-12) as with the HiGHS distance (``_EXACT_DISTANCE`` off, the former path),
    for responses up to 1.5× the white, most of them outside the solid."""
    pb = correction_problem("Nikon 5100 (NPL)", target="CIE 1931 2°")
    C = np.random.default_rng(0).uniform(0.0, 1.5, (40, 3))
    assert (volume._solid_distance(pb.Phi, C) > 0).mean() > 0.5
    new = metamer_mismatch_batch(pb.Phi, pb.Psi, C, on_infeasible="nearest", outer=False)
    monkeypatch.setattr(volume, "_EXACT_DISTANCE", False)
    old = metamer_mismatch_batch(pb.Phi, pb.Psi, C, on_infeasible="nearest", outer=False)
    np.testing.assert_allclose(new.centroids, old.centroids, atol=1e-9, rtol=0)
    np.testing.assert_allclose(new.volumes, old.volumes, atol=1e-12, rtol=0)
    with pytest.raises(volume.InfeasibleResponseError):
        metamer_mismatch_batch(pb.Phi, pb.Psi, C[:5] + 1.0)
