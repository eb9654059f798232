"""The capture's lights: ``reference`` and ``illuminant = "estimate"`` in capture.toml (parse-time
checks), the correction problem fitted scene light → reference light, and the scene light estimated
from rendered responses or a marked card (:mod:`splat.capture.illuminant`)."""

from __future__ import annotations

import json
from types import SimpleNamespace

import colour
import numpy as np
import pytest

import zonotope
from splat.capture import CameraSpec, CaptureError, CaptureSpec, WhiteSpec, read_capture
from splat.capture.correct import correction_problem_of
from splat.capture.files import write_tiff
from splat.capture.illuminant import illuminant_of
from zonotope.spectra.illuminant_estimate import white_angle

from .capture_helpers import write_dng_exif

CAMS = ("Nikon 5100 (NPL)", "Canon EOS 5D Mark II")


def _capture(tmp_path, top: str):
    (tmp_path / "a").mkdir(exist_ok=True)
    write_dng_exif(
        tmp_path / "a" / "IMG_0.dng",
        np.full((16, 16), 1000),
        cfa="RGGB",
        black=0,
        white=4095,
        neutral=np.ones(3),
        exposure_time=0.01,
        iso=100,
        fnumber=4.0,
    )
    (tmp_path / "capture.toml").write_text(f'{top}\n[[camera]]\nfolder = "a"\nssf = "{CAMS[0]}"\n')
    return tmp_path


def test_reference_and_estimate_are_read(tmp_path):
    spec = read_capture(_capture(tmp_path, 'illuminant = "estimate"\nreference = "D65"'))
    assert spec.illuminant == "estimate" and spec.estimates_illuminant and spec.reference == "D65"
    np.testing.assert_allclose(spec.load_reference().values, zonotope.illuminant("D65").values)
    spec = read_capture(_capture(tmp_path, 'illuminant = "Planckian 3000 K"'))
    assert spec.reference is None and spec.load_reference() is None  # today's behaviour: the scene light
    np.testing.assert_allclose(spec.load_illuminant().values, colour.sd_blackbody(3000).values)


@pytest.mark.parametrize(
    "top, match",
    [
        ('illuminant = "D66"', r"illuminant = 'D66' names no light.*D65, D75"),
        ('reference = "estimate"', r"reference = 'estimate' names no light"),
        ('reference = "tungsten.csv"', r"reference = 'tungsten.csv'.*SPD CSV"),
        ("reference = 65", "must be a string"),
    ],
)
def test_unknown_lights_are_refused_at_parse_time_in_one_line(tmp_path, top, match):
    with pytest.raises(CaptureError, match=match) as e:
        read_capture(_capture(tmp_path, top))
    assert "\n" not in str(e.value)
    if "D66" in top:
        assert '"estimate"' in str(e.value)  # the valid values are listed


def _spec(tmp_path, illuminant="A", reference=None, white=None):
    cams = tuple(CameraSpec(f"c{k}", ssf) for k, ssf in enumerate(CAMS))
    return CaptureSpec(
        tmp_path,
        illuminant,
        "CIE 1931 2 Degree Standard Observer",
        cams,
        white or WhiteSpec(),
        reference=reference,
    )


def test_correction_problem_is_fitted_to_the_reference_light(tmp_path):
    """Closed form: the problem's white is the reference light's white (colour-science's xy), and the
    cameras still see the scene light."""
    ref = correction_problem_of(_spec(tmp_path, "A", "D65"), [0, 1])
    same = correction_problem_of(_spec(tmp_path, "A"), [0, 1])
    for problem, light in ((ref, "D65"), (same, "A")):
        xy = colour.CCS_ILLUMINANTS["CIE 1931 2 Degree Standard Observer"][light]
        np.testing.assert_allclose(colour.XYZ_to_xy(problem.white_XYZ), xy, atol=2e-3)
    np.testing.assert_allclose(ref.Phi, same.Phi)


def _renders(tmp_path, light, gains, *, n=400, seed=0):
    """A fake OUT: two rendered views of natural surfaces under ``light`` (raw units, a gain per camera)."""
    grid = np.arange(400.0, 701.0, 10.0)
    X = np.concatenate(
        [zonotope.resample(zonotope.reflectances(s), grid).T for s in ("CIE 1995 TCS", "NIST CQS 9.0")]
    )
    G = np.asarray(zonotope.generators(list(CAMS), light, grid, normalise=None).values)
    G = G / G.sum(0).mean() * np.repeat(gains, 3)
    rng = np.random.default_rng(seed)
    out, index = tmp_path / "out", {}
    for v in range(2):
        img = np.clip(X[rng.integers(0, len(X), n)], 0, 1) @ G
        write_tiff(out / "render" / f"c{v}" / "v" / "render.tiff", img.reshape(20, n // 20, 6))
        index[f"c{v}/v.dng"] = {"dir": f"c{v}/v"}
    return out, index, G


@pytest.mark.parametrize("light", ["FL11", "LED-B3"])
def test_estimate_from_the_renders_is_recorded_and_reused(tmp_path, light):
    spec = _spec(tmp_path, "estimate", "D65")
    out, index, _ = _renders(tmp_path, light, gains=[0.4, 1.7])  # cameras of different raw gains
    resolved, rec = illuminant_of(spec, out, index, {})
    assert resolved.illuminant == light == rec["light"] and rec["method"] == "likelihood"
    assert resolved.reference == "D65" and not resolved.estimates_illuminant
    assert 0 <= rec["angular_uncertainty_deg"] < 5 and 0 < rec["agreement"] <= 1
    saved = json.loads((out / "correct" / "illuminant.json").read_text())
    assert saved == rec
    # the second call reads the record, not the renders
    for p in (out / "render").rglob("render.tiff"):
        p.unlink()
    assert illuminant_of(spec, out, index, {})[1] == rec
    # a named light passes through untouched
    assert illuminant_of(_spec(tmp_path, "A"), out) == (_spec(tmp_path, "A"), None)


def test_estimate_needs_the_correct_step_and_usable_pixels(tmp_path):
    with pytest.raises(CaptureError, match="run it first"):
        illuminant_of(_spec(tmp_path, "estimate"), tmp_path / "out")
    out, index, _ = _renders(tmp_path, "A", gains=[1, 1], n=20)
    with pytest.raises(CaptureError, match="usable rendered pixels"):
        illuminant_of(_spec(tmp_path, "estimate"), out, index, {})


def test_marked_card_gives_the_light(tmp_path):
    """A white card in the render (every camera's channels at the box): the candidate whose white
    points the way the card's response does."""
    white = WhiteSpec("patch", "c0/v.dng", (2, 3, 8, 9), 0.9)
    spec = _spec(tmp_path, "estimate", white=white)
    out, index, G = _renders(tmp_path, "FL2", gains=[0.5, 1.5])
    img = np.full((20, 20, 6), 0.1)
    img[3:9, 2:8] = 0.9 * G.sum(0)
    write_tiff(out / "render" / "c0" / "v" / "render.tiff", img)
    resolved, rec = illuminant_of(spec, out, index, {"c0/v.dng": SimpleNamespace(binning=1)})
    assert rec["method"] == "grey card" and resolved.illuminant == "FL2"
    assert rec["angular_uncertainty_deg"] < 0.01  # the card's response is the light's white exactly
    truth = G.sum(0)[:3]
    assert white_angle(np.asarray(rec["white"])[:3], truth) < 0.01


def test_marked_card_in_a_view_not_rendered_is_read_in_the_photograph(tmp_path):
    """The card's own camera's channels from the RAW view (valid sites only; a saturated site is left
    out) when its view was not rendered."""
    white = WhiteSpec("patch", "c1/p.dng", (0, 0, 4, 4), 1.0)
    spec = _spec(tmp_path, "estimate", white=white)
    out, index, _ = _renders(tmp_path, "A", gains=[1, 1])
    grid = np.arange(400.0, 701.0, 10.0)
    w = np.asarray(zonotope.generators(CAMS[1], "LED-B3", grid, normalise=None).values).sum(0)
    values = np.tile(0.2 * w, (6, 6, 1))
    weight = np.ones((6, 6, 3))
    values[1, 1] = [9.0, 0.0, 0.0]  # a clipped site, weight 0
    weight[1, 1] = 0
    view = SimpleNamespace(binning=1, camera=1, values=values, weight=weight)
    resolved, rec = illuminant_of(spec, out, index, {"c1/p.dng": view})
    assert rec["method"] == "grey card" and resolved.illuminant == "LED-B3"
    assert "photograph" in rec["source"] and rec["angular_uncertainty_deg"] < 0.01


def test_a_light_that_went_missing_is_a_capture_error(tmp_path):
    (tmp_path / "tungsten.csv").write_text("wavelength,value\n400,1\n500,2\n600,3\n700,4\n")
    spec = read_capture(_capture(tmp_path, 'illuminant = "A"\nreference = "tungsten.csv"'))
    assert spec.load_reference().values[-1] == 4
    (tmp_path / "tungsten.csv").unlink()  # removed after the file was read
    with pytest.raises(CaptureError, match=r"reference = 'tungsten\.csv' is neither"):
        spec.load_reference()
