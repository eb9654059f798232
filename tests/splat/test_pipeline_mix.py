"""The pipeline's λ for Prior (splat.capture.pipeline_mix): the correct step and the scene export fit
the same estimator for rendered responses, without Prior's cross-validation."""

from __future__ import annotations

import pytest

from splat.capture import pipeline_mix, read_capture

from .capture_helpers import write_capture


@pytest.fixture(scope="module")
def spec(tmp_path_factory):
    cap = tmp_path_factory.mktemp("mix") / "cap"
    write_capture(cap, views=2, holdout=1)
    return read_capture(cap)


def test_pipeline_mix_is_the_map_estimate_for_prior_only():
    assert pipeline_mix("Prior") == pipeline_mix("prior") == 1.0
    assert pipeline_mix("Centroid") is None


def test_scene_corrector_fits_prior_with_the_pipeline_mix(spec, monkeypatch):
    import zonotope.correct.mmv as mmv
    from splat.capture import fit_corrector
    from splat.export import scene_corrector

    calls = []

    def learn_mix(problem, method, cfg, **kw):  # the cross-validation, counted (the real one ~30 s)
        calls.append(1)
        return (0.4, 0.9), {"radius_scale": 1.0, "scores": {}, "best": (0.4, 0.9), "one": (1.0, 1.0)}

    monkeypatch.setattr(mmv, "learn_mix", learn_mix)
    cor = scene_corrector(spec, "Prior", 0.01)
    assert calls == [] and cor.params["mix"] == (1.0, 1.0)
    assert fit_corrector(spec, [0, 1, 2], "Prior", 0.01).params["mix"] == (0.4, 0.9)  # without it: CV
    assert calls == [1]
