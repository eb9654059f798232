"""The run's fit cache (splat.capture.Workspace.fit_cache): the scene export reuses the correct step's
costly Prior fit only for the settings record and capture inputs it was made from."""

from __future__ import annotations

import os

import pytest

from splat.capture import read_capture
from splat.capture.workspace import FIT_CACHE, Workspace, capture_fingerprint

from .capture_helpers import write_capture


@pytest.fixture(scope="module")
def capture(tmp_path_factory):
    cap = tmp_path_factory.mktemp("fitcache") / "cap"
    write_capture(cap, views=2, holdout=1)
    return cap


@pytest.fixture()
def run(capture, tmp_path):
    """A capture and an OUT whose settings record has every step up to correct (no results needed)."""
    import shutil

    cap = shutil.copytree(capture, tmp_path / "cap")
    spec = read_capture(cap)
    ws = Workspace(spec, tmp_path / "out")
    ws.begin("poses", {"capture": capture_fingerprint(spec), "seed": 0, "min_registered": 0.5})
    for step in ("train", "render"):
        ws.begin(step, {})
    ws.begin("correct", {"method": "Prior", "quantum": 0.005})
    return cap, spec, ws


@pytest.fixture()
def cv_calls(monkeypatch):
    """Prior's cross-validation replaced by a counted stub (the real one takes ~30 s)."""
    import zonotope.correct.mmv as mmv

    calls = []

    def learn_mix(problem, method, cfg, **kw):
        calls.append(1)
        cv = {"radius_scale": 1.25, "scores": {(0.4, 0.9): 1.0}, "best": (0.4, 0.9), "one": (1.0, 1.0)}
        return (0.4, 0.9), cv

    monkeypatch.setattr(mmv, "learn_mix", learn_mix)
    return calls


def test_fit_cache_lies_in_the_correct_step_and_follows_its_key(run):
    _cap, spec, ws = run
    folder = ws.fit_cache()
    assert folder == ws.root.joinpath(*FIT_CACHE, ws.key("correct")[:16])
    ws.begin("correct", {"method": "Prior", "quantum": 0.02})  # other options: another folder
    assert ws.fit_cache() != folder and ws.fit_cache().parent == folder.parent
    assert Workspace(spec, ws.root).fit_cache() == ws.fit_cache()  # read back from the record


def test_no_fit_cache_without_a_correct_record_or_for_changed_inputs(run, tmp_path):
    cap, spec, ws = run
    assert Workspace(spec, tmp_path / "fresh").fit_cache() is None
    raw = next((cap / "nikon").glob("*.dng"))
    st = raw.stat()
    os.utime(raw, ns=(st.st_atime_ns, st.st_mtime_ns + 10**9))  # a RAW file replaced after the run
    assert Workspace(read_capture(cap), ws.root).fit_cache() is None


def test_scene_corrector_reuses_the_fit_only_when_current(run, cv_calls):
    from splat.export import scene_corrector

    cap, spec, ws = run
    a = scene_corrector(spec, ws.root, "Prior", 0.01)  # as the correct step fits it, into the cache
    assert len(cv_calls) == 1 and any(ws.fit_cache().iterdir())
    b = scene_corrector(spec, ws.root, "Prior", 0.01)
    assert len(cv_calls) == 1  # reused: no cross-validation
    assert b.params["mix"] == a.params["mix"] == (0.4, 0.9)
    assert b.params["radius_scale"] == a.params["radius_scale"] == 1.25
    raw = next((cap / "canon").glob("*.dng"))
    st = raw.stat()
    os.utime(raw, ns=(st.st_atime_ns, st.st_mtime_ns + 10**9))
    scene_corrector(read_capture(cap), ws.root, "Prior", 0.01)  # inputs changed since the run
    assert len(cv_calls) == 2
