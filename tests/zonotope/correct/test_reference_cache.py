"""A reference light in the caches and in ``correct_image``: fits for two references never share a cache
entry (the Prior fit cache and correct_image's per-colour cache), and the scene light as its own
reference is the same fit as no reference."""

from __future__ import annotations

import numpy as np
import pytest

from zonotope import OptionError
from zonotope.correct import correction_problem, fit_correction, mmv
from zonotope.correct.fitcache import prior_fit_key
from zonotope.correct.image import _fingerprint, correct_image

CAM = "Nikon 5100 (NPL)"
W = np.arange(400, 701, 20)


@pytest.fixture
def calls(monkeypatch):
    """Counts the calls of learn_mix (the part the fit cache saves)."""
    n = []
    real = mmv.learn_mix

    def counted(*args, **kwargs):
        n.append(1)
        return real(*args, **kwargs)

    monkeypatch.setattr(mmv, "learn_mix", counted)
    return n


def test_two_references_do_not_share_a_fit_cache_entry(calls, tmp_path):
    opts = {"augment": 20, "folds": 3, "cache_dir": tmp_path}
    problems = {r: correction_problem(CAM, illuminant="A", reference=r, shape=W) for r in ("D65", "D50")}
    fits = {r: fit_correction(p, method="Prior", **opts) for r, p in problems.items()}
    assert len(calls) == 2 and len(list(tmp_path.glob("prior-*.json"))) == 2
    again = fit_correction(problems["D50"], method="Prior", **opts)  # served from its own entry
    assert len(calls) == 2
    c = np.full((1, 3), 0.5)
    np.testing.assert_array_equal(again(c), fits["D50"](c))
    assert not np.allclose(fits["D65"](c), fits["D50"](c), rtol=1e-3)  # the other reference's white
    # the scene light as its own reference is the same problem: the same entry is right
    same = correction_problem(CAM, illuminant="A", reference="A", shape=W)
    none = correction_problem(CAM, illuminant="A", shape=W)
    cfg = mmv.PriorConfig(augment=20, folds=3)
    assert prior_fit_key(same, cfg) == prior_fit_key(none, cfg)


def test_two_references_do_not_share_a_per_colour_cache(tmp_path):
    ests = [
        fit_correction(CAM, method="Finlayson 2015", illuminant="A", reference=r, shape=W)
        for r in ("D65", "D50")
    ]
    assert _fingerprint(ests[0], 2e-3) != _fingerprint(ests[1], 2e-3)
    img = np.full((2, 3, 3), 0.3)
    out = [correct_image(img, e, cache_dir=tmp_path) for e in ests]
    assert not np.allclose(out[0], out[1], rtol=1e-3)


def test_correct_image_takes_the_reference_with_cameras_only():
    img = np.full((2, 2, 3), 0.4)
    by_name = correct_image(img, CAM, method="Finlayson 2015", illuminant="A", reference="D65", shape=W)
    est = fit_correction(CAM, method="Finlayson 2015", illuminant="A", reference="D65", shape=W)
    np.testing.assert_allclose(by_name, est(img.reshape(-1, 3)).reshape(img.shape), rtol=1e-12)
    with pytest.raises(OptionError, match="reference"):
        correct_image(img, est, reference="D65")
