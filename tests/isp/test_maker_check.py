"""A metamer correction is right only for the sensor whose curves it is fitted on: a RAW file of another
maker than the one the sensitivities name is flagged, for one file and for a folder (one fit for all)."""

from __future__ import annotations

import json

import numpy as np
import pytest

from isp.cli import main
from isp.metamer import maker_mismatch, sensitivities_maker


@pytest.fixture(scope="module")
def nikon_and_canon(tmp_path_factory):
    """A folder of two simulated Nikon 5100 DNGs and one simulated Canon EOS 5D Mark II DNG (27 × 36 px)."""
    import zonotope
    from isp.simulate import chart_image, simulate_capture, simulate_dng, spectral_setup

    d = tmp_path_factory.mktemp("makers")
    for name, camera in (("a", "Nikon 5100 (NPL)"), ("b", "Nikon 5100 (NPL)"), ("c", "Canon EOS 5D Mark II")):
        setup = spectral_setup(camera)
        R = zonotope.resample(zonotope.reflectances("ColorChecker N Ohta"), setup.wavelengths).T.clip(0, 1)
        image, _ = chart_image(R[:6], rows=2, cols=3, patch=12, gap=0)
        cap = simulate_capture(image, setup, training=R, full_well=np.inf, read_noise=0)
        simulate_dng(d / f"{name}.dng", cap, model=camera)
    return d


def test_makers_compared_by_first_word_with_aliases(tmp_path):
    assert maker_mismatch("Nikon 5100 (NPL)", "NIKON CORPORATION") is None
    assert maker_mismatch("Sigma SDMerill (NPL)", "SIGMA") is None
    said = maker_mismatch("Canon EOS 5D Mark II", "NIKON CORPORATION")
    assert "a Canon camera's" in said and "'NIKON CORPORATION'" in said
    assert maker_mismatch("Canon EOS 5D Mark II", "") is None  # not recorded (non-DNG RAW): no claim
    f = tmp_path / "pentax.json"
    f.write_text(json.dumps({"header": {"manufacturer": "Pentax", "model": "K-1"}}))
    assert sensitivities_maker(f) == "Pentax"
    assert maker_mismatch(f, "RICOH IMAGING COMPANY, LTD.") is None  # Pentax files name Ricoh
    assert maker_mismatch(f, "Canon") is not None
    for unnamed in ("estimated", "unknown"):  # ssf_json of an estimate without a make (a chart alone)
        f.write_text(json.dumps({"header": {"manufacturer": unnamed, "model": "camera"}}))
        assert sensitivities_maker(f) is None and maker_mismatch(f, "Canon") is None
    (tmp_path / "cam.csv").write_text("380,0.1,0.2,0.3\n")
    assert sensitivities_maker(tmp_path / "cam.csv") is None  # a CSV names no maker: never flagged
    assert sensitivities_maker("not a camera") is None


def test_simulated_dng_carries_the_cameras_make(nikon_and_canon):
    from isp.dng import read_dng_tags

    assert read_dng_tags(nikon_and_canon / "a.dng")["Make"] == "Nikon"
    assert read_dng_tags(nikon_and_canon / "c.dng")["Make"] == "Canon"


def _metamer(src, out, camera):
    """``isp develop SRC -o OUT`` with a quick metamer correction for ``camera``'s curves."""
    opts = ["--correction", "metamer", "--camera", camera, "--method", "root-polynomial", "-q"]
    return main(["develop", str(src), "-o", str(out), *opts])


def test_one_file_of_another_maker_warns(nikon_and_canon, tmp_path, capsys):
    assert _metamer(nikon_and_canon / "c.dng", tmp_path / "c.tif", "Nikon 5100 (NPL)") == 0
    err = " ".join(capsys.readouterr().err.split())
    assert "warning: c.dng: the sensitivities 'Nikon 5100 (NPL)' are a Nikon camera's" in err
    assert "from 'Canon'" in err
    assert _metamer(nikon_and_canon / "a.dng", tmp_path / "a.tif", "Nikon 5100 (NPL)") == 0
    assert "sensitivities" not in capsys.readouterr().err  # its own maker: no warning


def test_a_folder_that_mixes_makers_names_the_odd_files(nikon_and_canon, tmp_path, capsys):
    args = ["develop", str(nikon_and_canon), "-o", str(tmp_path / "out"), "--correction", "metamer"]
    args += ["--camera", "Nikon 5100 (NPL)", "--method", "root-polynomial", "--scheduler", "serial", "-q"]
    assert main(args) == 0
    err = " ".join(capsys.readouterr().err.split())
    assert "warning: 1 of 3 DNG files are not from a Nikon camera" in err and "Canon (1: c.dng)" in err
    one = ["develop", str(nikon_and_canon), "-o", str(tmp_path / "out2"), "--correction", "metamer"]
    one += ["--camera", "Canon EOS 5D Mark II", "--method", "root-polynomial", "--scheduler", "serial", "-q"]
    assert main(one) == 0
    assert "2 of 3 DNG files are not from a Canon camera" in " ".join(capsys.readouterr().err.split())
