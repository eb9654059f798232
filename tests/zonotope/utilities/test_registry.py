"""MethodRegistry: one case-insensitive pattern for every ``method=`` table, and its project errors."""

from __future__ import annotations

import numpy as np
import pytest

import zonotope
from zonotope import UnknownMethodError
from zonotope.utilities import MethodRegistry


def _registry():
    r = MethodRegistry("shape", argument="kind")
    r.register("Unit Square", len, aliases=("square", "box"), corners=4)
    r.register("Circle", abs, corners=0)
    return r


@pytest.mark.parametrize("name", ["Unit Square", "unit square", "UNIT-SQUARE", "unitsquare", "Box", "square"])
def test_lookup_ignores_case_and_punctuation_and_accepts_aliases(name):
    r = _registry()
    assert r.resolve(name) == "Unit Square" and r[name] is len and name in r
    assert r.properties(name)["corners"] == 4


def test_unknown_name_is_a_project_error_listing_the_valid_ones():
    r = _registry()
    message = (
        r"kind='hexagon' is not a shape method; choose one of "
        r"\['Unit Square', 'Circle'\] \(aliases: \['box', 'square'\]\)"
    )
    with pytest.raises(UnknownMethodError, match=message) as info:
        r["hexagon"]
    assert isinstance(info.value, zonotope.ZonotopeError) and isinstance(info.value, ValueError)
    assert info.value.argument == "kind" and info.value.value == "hexagon"
    assert info.value.valid == ("Unit Square", "Circle")
    assert "hexagon" not in r
    with pytest.raises(UnknownMethodError, match="demosaic='x'"):
        r.resolve("x", argument="demosaic")


def test_mapping_protocol_iterates_canonical_names_in_order():
    r = _registry()
    assert list(r) == ["Unit Square", "Circle"] and len(r) == 2
    assert dict(r) == {"Unit Square": len, "Circle": abs}
    assert r.names(corners=0) == ("Circle",) and r.names() == ("Unit Square", "Circle")


def test_properties_are_read_only_and_names_cannot_collide():
    r = _registry()
    with pytest.raises(TypeError):
        r.properties("circle")["corners"] = 3
    with pytest.raises(ValueError, match="already registered"):
        r.register("BOX", min)


def test_correction_registry_properties_match_the_estimators():
    from zonotope.correct import CORRECTION_METHODS, correction_problem, fit_correction

    assert list(CORRECTION_METHODS) == [
        "Cheung 2004",
        "Finlayson 2015",
        "Dyer 2017",
        "Guarded",
        "Centroid",
        "Projection",
        "MAP",
        "Prior",
    ]
    assert CORRECTION_METHODS.names(centroid=True) == ("Centroid",)
    problem = correction_problem("Nikon 5100 (NPL)", shape=np.arange(400.0, 701.0, 20.0))
    c = problem.source_of(problem.training[:5])
    for name in CORRECTION_METHODS.names(closed_form=True):
        est = fit_correction(problem, method=name.upper())
        if name == "Guarded":  # per response, the root-polynomial it holds or its linear fallback
            root, fb = (
                est.params["root"](c),
                c @ est.params["fallback"].params["M"] if est.params["guard"] else None,
            )
            out = est(c)
            same = np.all(np.isclose(out, root, rtol=1e-12), axis=-1)
            if fb is not None:
                same |= np.all(np.isclose(out, fb, rtol=1e-12), axis=-1)
            assert same.all()
            continue
        # a closed-form regression is linear in its fitted terms: the matrix M reproduces it exactly
        terms = (
            c if name != "Finlayson 2015" else zonotope.root_polynomial_terms(c, degree=est.params["degree"])
        )
        np.testing.assert_allclose(est(c), terms @ est.params["M"], rtol=1e-12)
    assert fit_correction(problem, method="mmv-centroid").method == "Centroid"
    with pytest.raises(UnknownMethodError, match=r"method='bogus' is not a correction method"):
        fit_correction(problem, method="bogus")


def test_isp_and_splat_registries_raise_their_packages_errors():
    import isp

    with pytest.raises(isp.PipelineMethodError, match=r"method='ahd' is not a demosaicing method") as info:
        isp.demosaic(np.zeros((4, 4)), method="ahd")
    assert isinstance(info.value, isp.PipelineError) and isinstance(info.value, UnknownMethodError)
    with pytest.raises(isp.PipelineError, match="tone-mapping"):
        isp.tonemap(np.zeros((2, 2, 3)), method="filmic")
    assert isp.DEMOSAIC_METHODS.resolve("menon2007") == "Menon 2007"


def test_splat_render_registry():
    splat = pytest.importorskip("splat")
    assert splat.RENDER_METHODS.resolve("TILED") == "tiled"
    assert splat.RENDER_METHODS.properties("tiled")["reference_twin"] == "reference"
    with pytest.raises(splat.SplatError, match=r"method='fast' is not a render method"):
        splat.RENDER_METHODS["fast"]


def test_cli_unknown_method_is_one_line_and_exit_2(capsys):
    from zonotope.cli import main

    code = main(["evaluate", "--camera", "Nikon 5100 (NPL)", "--method", "bogus", "--interval", "20"])
    err = capsys.readouterr().err
    assert code == 2 and "method='bogus' is not a correction method" in err
    assert "Traceback" not in err and len(err.strip().splitlines()) == 1
