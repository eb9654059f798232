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


# ---------------------------------------------------------------------------------------------
# isp.metamer_correction / isp.fit_dcp / zonotope.correction_LUT: MetamerConfig, ProfileConfig, LUTConfig
# ---------------------------------------------------------------------------------------------

CAM = "Nikon 5100 (NPL)"


def test_metamer_config_equals_keywords_and_passes_estimator_options():
    import isp
    from zonotope.correct import fit_correction

    c = np.random.default_rng(1).uniform(0.05, 0.9, (7, 3))
    cfg = isp.MetamerConfig(method="root-polynomial", quantum=0, estimator_options={"degree": 3})
    a = isp.metamer_correction(CAM, cfg)
    b = isp.metamer_correction(CAM, method="root-polynomial", quantum=0, estimator_options={"degree": 3})
    d = isp.metamer_correction(CAM, isp.MetamerConfig(method="matrix"), method="root-polynomial", quantum=0)
    np.testing.assert_array_equal(a(c), b(c))
    assert a.corrector.params["degree"] == 3 and d.corrector.params["degree"] == 2
    assert not np.allclose(a(c), d(c))
    # the estimator options reach fit_correction unchanged (same problem, same answer)
    direct = fit_correction(
        CAM, method="root-polynomial", target="CIE 1931 2°", shape=a.corrector.problem.wavelengths, degree=3
    )
    np.testing.assert_allclose(a.corrector.predict(c), direct.predict(c), rtol=1e-12)
    with pytest.raises(isp.PipelineError, match=r"unknown option\(s\) degree.*estimator_options"):
        isp.metamer_correction(CAM, method="root-polynomial", degree=3)
    with pytest.raises(isp.PipelineError, match="expected a MetamerConfig"):
        isp.metamer_correction(CAM, {"method": "matrix"})


@pytest.mark.parametrize(
    ("options", "match"),
    [
        ({"white_level": 0}, "white_level=0"),
        ({"white_level": float("nan")}, "white_level=nan"),
        ({"quantum": -1e-3}, "quantum=-0.001"),
        ({"quantum": float("inf")}, "quantum=inf"),
        ({"quantum": "0"}, "quantum='0'"),
        ({"batch_size": 0}, "batch_size=0"),
        ({"batch_size": True}, "batch_size=True"),
        ({"method": ""}, "method=''"),
        ({"estimator_options": [("noise", 0.1)]}, "estimator_options"),
        ({"estimator_options": {1: 2}}, "estimator_options"),
        ({"estimator_options": {"training": "x"}}, "training are fields of MetamerConfig"),
    ],
)
def test_metamer_config_refuses_bad_values(options, match):
    import isp

    with pytest.raises(isp.PipelineError, match=match):
        isp.MetamerConfig(**options)


@pytest.mark.parametrize(
    ("options", "match"),
    [
        ({"illuminants": ("D65",)}, "exactly two"),
        ({"illuminants": ("A", "moonlight")}, "moonlight"),
        ({"illuminants": ("D65", "D65")}, "two different"),
        ({"dims": (90, 1, 1)}, r"dims=\(90, 1, 1\)"),
        ({"dims": (90, 30)}, "dims"),
        ({"dims": "90x30"}, "dims"),
        ({"look_table_dims": (36, 12, 0)}, "look_table_dims"),
        ({"look_table_encoding": 2}, "look_table_encoding=2"),
        ({"atypical_weight": -1}, "atypical_weight=-1"),
        ({"atypical_weight": float("inf")}, "atypical_weight=inf"),
        ({"embed_policy": 4}, "embed_policy=4"),
        ({"n_random": -5}, "n_random=-5"),
        ({"n_random": 10.5}, "n_random=10.5"),
        ({"smoothness": -1.0}, "smoothness=-1.0"),
        ({"unbiased_saturation": 1.5}, "unbiased_saturation=1.5"),
        ({"unbiased_saturation": float("nan")}, "unbiased_saturation=nan"),
        ({"copyright": None}, "copyright=None"),
        ({"estimator_options": {"method": "MAP"}}, "method are fields"),
    ],
)
def test_profile_config_refuses_bad_values(options, match):
    import isp

    with pytest.raises(isp.PipelineError, match=match):
        isp.ProfileConfig(**options)


def test_fit_dcp_config_equals_keywords_and_refuses_options_before_fitting():
    import isp

    cfg = isp.ProfileConfig(method="matrix", dims=None, look_table_dims=None, n_random=20)
    a = isp.fit_dcp(CAM, cfg).profile
    b = isp.fit_dcp(CAM, method="matrix", dims=None, look_table_dims=None, n_random=20).profile
    c = isp.fit_dcp(
        CAM,
        isp.ProfileConfig(method="root-polynomial"),
        corrections=None,
        **{"method": "matrix", "dims": None, "look_table_dims": None, "n_random": 20},
    )
    for other in (b, c.profile):
        for name in ("color_matrix_1", "color_matrix_2", "forward_matrix_1", "forward_matrix_2"):
            np.testing.assert_array_equal(getattr(a, name), getattr(other, name))
    assert a.hue_sat_map_1 is None and a.look_table is None
    assert cfg.illuminants == ("A", "D65") and cfg.estimator_options == {}
    with pytest.raises(isp.PipelineError, match=r"unknown option\(s\) degree.*estimator_options"):
        isp.fit_dcp(CAM, degree=2)
    with pytest.raises(isp.PipelineError, match="n_random=-1"):
        isp.fit_dcp(CAM, n_random=-1)


def test_lut_config_equals_keywords_and_refuses_bad_values():
    from zonotope import LUTConfig
    from zonotope.correct.profile import correction_LUT

    M = np.array([[0.6, 0.3, 0.1], [0.25, 0.7, 0.05], [0.05, 0.1, 0.9]])

    def f(c):
        return c @ M.T

    a = correction_LUT(f, LUTConfig(size=5, space="linear srgb", shaper_size=64))
    b = correction_LUT(f, size=5, space="sRGB", shaper_size=64)
    c = correction_LUT(f, LUTConfig(size=9), size=5, space="sRGB", shaper_size=64)
    for other in (b, c):
        np.testing.assert_array_equal(a[1].table, other[1].table)
        np.testing.assert_array_equal(a[0].table, other[0].table)
    assert LUTConfig(space="aces2065-1").space == "ACES2065-1"
    bad = [
        ({"size": 130}, "size=130"),
        ({"size": True}, "size=True"),
        ({"headroom": 0.5}, "headroom=0.5"),
        ({"headroom": "16"}, "headroom='16'"),
        ({"shaper": "gamma"}, "shaper='gamma'"),
        ({"space": "Lab"}, "space='Lab'"),
        ({"shaper_size": 1}, "shaper_size=1"),
        ({"batch": 0}, "batch=0"),
        ({"name": 3}, "name=3"),
        ({"white_XYZ": [1, 0, 1]}, "white_XYZ"),
        ({"white_XYZ": "D65"}, "white_XYZ"),
    ]
    for options, match in bad:
        with pytest.raises(zonotope.ZonotopeError, match=match):
            LUTConfig(**options)
    with pytest.raises(OptionError, match=r"unknown option\(s\) lattice"):
        correction_LUT(f, lattice=5)


def test_isp_refuses_estimators_fitted_to_another_observer():
    """isp's XYZ is CIE 1931; zonotope.correct defaults to CIE 2015 (issue 13 item 9: mixed silently)."""
    import isp
    from zonotope.correct import fit_correction

    with pytest.raises(isp.PipelineError, match=r"MetamerConfig.target.*not CIE 1931"):
        isp.MetamerConfig(target="CIE 2015 2°")
    assert isp.MetamerConfig(target="cie 1931").target == "cie 1931"
    w = np.arange(400, 701, 10.0)
    default = fit_correction(CAM, method="matrix", shape=w)  # CIE 2015 2°
    with pytest.raises(isp.PipelineError, match="MetamerCorrection: target 'CIE 2015 2°'"):
        isp.MetamerCorrection(default)
    ok = isp.MetamerCorrection(fit_correction(CAM, method="matrix", shape=w, target="CIE 1931 2°"))
    assert ok(np.ones((1, 3))).shape == (1, 3)
