"""zonotope.evaluate and zonotope.atypical."""

from __future__ import annotations

import numpy as np
import pytest

from zonotope._errors import SpectralDataError
from zonotope.atypical import ATYPICAL_KINDS, atypical_reflectances
from zonotope.evaluate import TestSet, evaluate, natural_test_sets

GRID = np.arange(400.0, 701.0, 10.0)


def test_atypical_seeded_and_valid():
    A, labels = atypical_reflectances(GRID, 40, seed=7)
    B, _ = atypical_reflectances(GRID, 40, seed=7)
    assert np.array_equal(A, B)
    assert A.shape == (40, GRID.size) and A.min() >= 0 and A.max() <= 1
    assert {lab.rsplit(" ", 1)[0] for lab in labels} == set(ATYPICAL_KINDS)
    assert not np.array_equal(A, atypical_reflectances(GRID, 40, seed=8)[0])
    assert atypical_reflectances(GRID, 0)[0].shape == (0, GRID.size)
    with pytest.raises(ValueError, match="band-pass"):
        atypical_reflectances(GRID, 3, kinds=["rainbow"])


def test_evaluate_table():
    A, _ = atypical_reflectances(GRID, 6, seed=1)
    sets = [natural_test_sets(GRID)[0], TestSet("atypical", A, "atypical")]
    ev = evaluate(
        [["Nikon 5100 (NPL)"]], methods=["Finlayson 2015", "idt", "MAP", "Prior"], shape=GRID, test_sets=sets
    )
    methods = {r.method for r in ev.rows}
    assert {"Finlayson 2015", "Dyer 2017", "MAP", "Prior"} <= methods
    rp = next(r for r in ev.rows if r.method == "Finlayson 2015" and r.kind == "natural")
    assert rp.n == 24 and 0 < rp.median <= rp.p95 <= rp.max and rp.inside == 1.0
    assert set(ev.summary("atypical")) == methods
    md = ev.to_markdown()
    assert "| cameras | test set | estimator |" in md and "Prior" in md


def test_evaluate_skips_idt_for_two_cameras_and_rejects_empty_sets():
    sets = [TestSet("one", natural_test_sets(GRID)[0].reflectances[:3])]
    ev = evaluate(
        [["Nikon 5100 (NPL)", "Canon EOS 5D Mark II"]],
        methods=["idt", "least squares"],
        shape=GRID,
        test_sets=sets,
    )
    assert [r.method for r in ev.rows] == ["Cheung 2004"]
    assert any("Dyer 2017 skipped" in n for n in ev.notes)
    with pytest.raises(SpectralDataError, match="empty"):
        evaluate(["Nikon 5100 (NPL)"], shape=GRID, test_sets=[TestSet("none", np.zeros((0, GRID.size)))])


def test_evaluate_with_noise_is_seeded():
    sets = [TestSet("cc", natural_test_sets(GRID)[0].reflectances[:5])]
    a = evaluate(["Nikon 5100 (NPL)"], methods=["Prior"], shape=GRID, test_sets=sets, noise=0.002)
    b = evaluate(["Nikon 5100 (NPL)"], methods=["Prior"], shape=GRID, test_sets=sets, noise=0.002)
    assert a.rows[0].mean == b.rows[0].mean


def test_infeasible_noisy_responses_are_reported():
    sets = [TestSet("dark", np.full((6, GRID.size), 0.01))]
    ev = evaluate(["Nikon 5100 (NPL)"], methods=["least squares"], shape=GRID, test_sets=sets, noise=0.05)
    assert any("outside the camera's object-colour solid" in n for n in ev.notes)


def test_natural_sets_from_shared_data(shared_data):
    sets = natural_test_sets(GRID, data_dir=shared_data, size=20)
    names = " ".join(s.name for s in sets)
    for expected in ("Munsell", "Krinov", "Vrhel", "CIE 224"):
        assert expected in names
    for s in sets:
        assert s.reflectances.shape[1] == GRID.size and 0 <= s.reflectances.min() <= s.reflectances.max() <= 1
