"""Config dataclasses (issue 13): one checked object or the same fields as keywords; bad values and
unknown options are project errors that name the option, the value and what is allowed."""

from __future__ import annotations

import numpy as np
import pytest

import zonotope
from zonotope import MMVBatchConfig, OptionError, UnknownMethodError, metamer_mismatch_batch

GRID = np.arange(400, 701, 20.0)


@pytest.fixture(scope="module")
def mm():
    return zonotope.MetamerMismatch("Nikon 5100 (NPL)", shape=GRID)


@pytest.fixture(scope="module")
def pair(mm):
    return mm.Phi, mm.Psi


def test_mmv_batch_config_equals_keywords(pair, mm):
    """A config, the same keywords, and a config with a keyword override give identical results."""
    Phi, Psi = pair
    C = np.random.default_rng(0).uniform(0.1, 0.9, (5, Phi.shape[0])) @ Phi
    cfg = MMVBatchConfig(eps=1e-3, chunk=2, outer=False)
    a = metamer_mismatch_batch(Phi, Psi, C, cfg)
    b = metamer_mismatch_batch(Phi, Psi, C, eps=1e-3, chunk=2, outer=False)
    c = metamer_mismatch_batch(Phi, Psi, C, MMVBatchConfig(eps=0.5, chunk=2, outer=False), eps=1e-3)
    for other in (b, c):
        np.testing.assert_array_equal(a.centroids, other.centroids)
        np.testing.assert_array_equal(a.volume_bounds, other.volume_bounds)
    d = mm.batch(C, cfg)
    np.testing.assert_array_equal(a.centroids, d.centroids)
    with pytest.raises(OptionError, match="oracle is the MetamerMismatch's"):
        mm.batch(C, oracle="highs")


def test_mmv_batch_config_normalises():
    cfg = MMVBatchConfig(delta=np.array([0.01, 0.0, 0.02]), oracle="HiGHS")
    assert cfg.delta == (0.01, 0.0, 0.02) and cfg.oracle == "highs"
    assert hash(cfg) == hash(MMVBatchConfig(delta=[0.01, 0, 0.02], oracle="highs"))
    assert MMVBatchConfig(delta=np.float32(0.5)).delta == 0.5


@pytest.mark.parametrize(
    ("options", "match"),
    [
        ({"eps": -1.0}, "eps=-1.0"),
        ({"eps": float("nan")}, "eps=nan"),
        ({"eps": "small"}, "eps='small'"),
        ({"eps": True}, "eps=True"),
        ({"delta": -0.1}, "delta=-0.1"),
        ({"delta": [[0.1]]}, "delta"),
        ({"delta": "0.1"}, "delta='0.1'"),
        ({"on_infeasible": "ignore"}, "on_infeasible='ignore'"),
        ({"chunk": 0}, "chunk=0"),
        ({"chunk": 2.5}, "chunk=2.5"),
        ({"outer": 1}, "outer=1"),
    ],
)
def test_mmv_batch_config_refuses_bad_values(options, match):
    with pytest.raises(OptionError, match=match):
        MMVBatchConfig(**options)


def test_mmv_batch_option_errors(pair):
    Phi, Psi = pair
    C = np.full((2, Phi.shape[0]), 0.5) @ Phi
    with pytest.raises(OptionError, match=r"unknown option.*epsilon.*the MMVBatchConfig fields are eps"):
        metamer_mismatch_batch(Phi, Psi, C, epsilon=1e-3)
    with pytest.raises(OptionError, match="config must be a MMVBatchConfig"):
        metamer_mismatch_batch(Phi, Psi, C, {"eps": 1e-3})
    with pytest.raises(OptionError, match="delta has 2 values; the source has 3"):
        metamer_mismatch_batch(Phi, Psi, C, delta=[0.1, 0.1])
    with pytest.raises(UnknownMethodError, match="oracle"):
        MMVBatchConfig(oracle="simplex2")
    assert isinstance(OptionError("x"), ValueError)  # callers that caught ValueError still do


@pytest.mark.parametrize(
    ("options", "match"),
    [
        ({"methods": "Prior"}, "methods='Prior'"),
        ({"methods": []}, r"methods=\[\]"),
        ({"atypical": -1}, "atypical=-1"),
        ({"atypical": 1.5}, "atypical=1.5"),
        ({"noise": -0.01}, "noise=-0.01"),
        ({"seed": "zero"}, "seed='zero'"),
        ({"centroid_eps": float("inf")}, "centroid_eps=inf"),
        ({"exclude_within": -1}, "exclude_within=-1"),
        ({"shape": [700, 400]}, "shape"),
        ({"shape": "400-700"}, "shape"),
        ({"test_sets": [np.ones((2, 31))]}, "test_sets"),
        ({"test_sets": 5}, "test_sets"),
    ],
)
def test_evaluation_config_refuses_bad_values(options, match):
    from zonotope import EvaluationConfig

    with pytest.raises(OptionError, match=match):
        EvaluationConfig(**options)


def test_evaluation_config_and_keywords(tmp_path):
    """An unknown method or option fails before any work; config and keywords give the same rows."""
    from zonotope import EvaluationConfig, TestSet
    from zonotope.evaluate import evaluate

    with pytest.raises(UnknownMethodError, match="Centroyd"):
        EvaluationConfig(methods=["Centroyd"])
    with pytest.raises(OptionError, match=r"unknown option.*nosie"):
        evaluate(["Nikon 5100 (NPL)"], nosie=0.01)
    w = np.arange(400, 701, 10.0)
    R = np.random.default_rng(3).uniform(0.05, 0.95, (6, w.size))
    cfg = EvaluationConfig(
        methods=("root-polynomial",), test_sets=(TestSet("random", R),), exclude_within=None
    )
    a = evaluate(["Nikon 5100 (NPL)"], cfg)
    b = evaluate(
        ["Nikon 5100 (NPL)"],
        methods=["root-polynomial"],
        test_sets=[TestSet("random", R)],
        exclude_within=None,
    )
    assert [(r.method, r.mean, r.max) for r in a.rows] == [(r.method, r.mean, r.max) for r in b.rows]
    assert cfg.methods == ("root-polynomial",) and isinstance(cfg.test_sets, tuple)


@pytest.mark.parametrize(
    ("options", "match"),
    [
        ({"shape": np.arange(400, 701, 10)}, "shape"),
        ({"methods": ["Bogus"]}, "Bogus"),
        ({"size": 0}, "size=0"),
        ({"atypical": -3}, "atypical=-3"),
        ({"pictures": "yes"}, "pictures='yes'"),
        ({"volumes": None}, "volumes=None"),
        ({"data_dir": 3}, "data_dir=3"),
    ],
)
def test_report_config_refuses_bad_values(options, match):
    from zonotope import ReportConfig

    with pytest.raises((OptionError, UnknownMethodError), match=match):
        ReportConfig(**options)


def test_write_report_refuses_options_before_writing(tmp_path):
    from zonotope import write_report

    out = tmp_path / "rep"
    with pytest.raises(OptionError, match=r"unknown option.*picture"):
        write_report(["Nikon 5100 (NPL)"], out, picture=False)
    with pytest.raises(OptionError, match="size=0"):
        write_report(["Nikon 5100 (NPL)"], out, size=0)
    assert not out.exists() and list(tmp_path.iterdir()) == []
