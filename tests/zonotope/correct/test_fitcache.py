"""The on-disk cache of a "Prior" fit: a second fit of the same problem skips the costly part and gives
the same estimator; anything the fit depends on changes the key; a damaged file is refitted."""

from __future__ import annotations

import numpy as np
import pytest

from zonotope.correct import NoiseModel, correction_problem, fit_correction, mmv

W = np.arange(400, 701, 20)


@pytest.fixture(scope="module")
def problem():
    return correction_problem(["Nikon 5100 (NPL)"], shape=W)


@pytest.fixture
def calls(monkeypatch):
    """Counts the calls of learn_mix (the part the cache saves)."""
    n = []
    real = mmv.learn_mix

    def counted(*args, **kwargs):
        n.append(1)
        return real(*args, **kwargs)

    monkeypatch.setattr(mmv, "learn_mix", counted)
    return n


def test_second_fit_comes_from_the_cache_and_is_identical(problem, calls, tmp_path):
    opts = {"augment": 20, "folds": 3, "cache_dir": tmp_path}
    first = fit_correction(problem, method="Prior", **opts)
    second = fit_correction(problem, method="Prior", **opts)
    assert len(calls) == 1 and len(list(tmp_path.glob("prior-*.json"))) == 1
    assert second.params["mix"] == first.params["mix"]
    assert second.params["radius_scale"] == first.params["radius_scale"]
    assert second.params["mix_cv"]["scores"] == first.params["mix_cv"]["scores"]
    C = problem.source_of(np.random.default_rng(0).uniform(0.05, 0.9, (20, W.size)))
    np.testing.assert_array_equal(second(C), first(C))


def test_the_key_follows_the_noise_and_options_and_damage_is_refitted(problem, calls, tmp_path):
    base = {"augment": 20, "folds": 3, "cache_dir": tmp_path}
    fit_correction(problem, method="Prior", **base)
    fit_correction(problem, method="Prior", noise=NoiseModel.shot_limited(0.005, 3), **base)
    fit_correction(problem, method="Prior", **{**base, "odds": 10.0})
    assert len(calls) == 3 and len(list(tmp_path.glob("prior-*.json"))) == 3
    for path in tmp_path.glob("prior-*.json"):
        path.write_text("{not json")
    fit_correction(problem, method="Prior", **base)
    assert len(calls) == 4
