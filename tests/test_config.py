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
