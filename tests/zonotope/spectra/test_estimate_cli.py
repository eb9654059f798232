"""``zonotope ssf estimate``: rawtoaces JSON out, one-line errors, no file replaced that it did not write."""

from __future__ import annotations

from fractions import Fraction

import colour
import numpy as np
import pytest

import zonotope
from zonotope._tol import SSF_UNIT_SIGMA
from zonotope.cli import main
from zonotope.spectra import builtin as spectra
from zonotope.spectra.estimate import SSF_SHAPE, Chart, estimate_ssf, synthesise_dng_matrices


def _srational(m) -> tuple[int, ...]:
    out = []
    for x in np.ravel(m):
        f = Fraction(float(x)).limit_denominator(10000)
        out += [f.numerator, f.denominator]
    return tuple(out)


def _dng(path, matrices=None) -> str:
    """A tiny DNG (8 × 8 CFA) with the given ColorMatrix1/2 under A and D65 (none: no colour tags)."""
    tifffile = pytest.importorskip("tifffile")
    tags = [(50706, "B", 4, (1, 4, 0, 0), True), (271, "s", 0, "Test", True), (272, "s", 0, "Test Cam", True)]
    if matrices is not None:
        for i, (cm, light) in enumerate(zip(matrices.color_matrices, (17, 21), strict=True)):
            tags += [(50721 + i, "2i", 9, _srational(cm), True), (50778 + i, "H", 1, light, True)]
    tifffile.imwrite(path, np.zeros((8, 8), np.uint16), photometric=32803, extratags=tags)
    return str(path)


def test_estimate_writes_json_that_load_camera_reads(tmp_path, capsys):
    dng = _dng(tmp_path / "cam.dng", synthesise_dng_matrices("Nikon 5100 (NPL)"))
    out = tmp_path / "cam.json"
    assert main(["ssf", "estimate", dng, "-o", str(out)]) == 0
    said = capsys.readouterr().out
    assert "Test Cam" in said and "band calibrated on real DNG matrices" in said
    cam = zonotope.load_camera(out)
    assert cam.values.shape == (len(SSF_SHAPE.wavelengths), 3) and cam.values.min() >= 0
    truth = spectra.resample(zonotope.camera("Nikon 5100 (NPL)"), SSF_SHAPE.wavelengths)
    rmse = np.sqrt(np.mean((cam.values / cam.values.max(0) - truth / truth.max(0)) ** 2, axis=0))
    assert np.all(rmse < 0.06), rmse
    G = zonotope.generators(cam, "D65")  # usable downstream as any camera file
    assert G.values.shape[1] == 3
    # refuses to overwrite without --force; replaces its own output with it
    assert main(["ssf", "estimate", dng, "-o", str(out)]) == 2
    assert "already exists" in capsys.readouterr().err
    assert main(["ssf", "estimate", dng, "-o", str(out), "--force"]) == 0


def test_chart_csv_alone_and_with_the_dng(tmp_path):
    w = SSF_SHAPE.wavelengths
    R = spectra.resample(zonotope.reflectances("ColorChecker N Ohta"), w).T
    E = spectra.resample(zonotope.illuminant("D65"), w)[:, 0]
    C = (R * E) @ spectra.resample(zonotope.camera("Nikon 5100 (NPL)"), w)
    C = 0.8 * C / C.max()
    csv = tmp_path / "chart.csv"
    csv.write_text("R,G,B\n" + "\n".join(",".join(f"{x:.6f}" for x in row) for row in C) + "\n")
    assert main(["ssf", "estimate", "--chart", str(csv), "-o", str(tmp_path / "a.json")]) == 0
    dng = _dng(tmp_path / "cam.dng", synthesise_dng_matrices("Nikon 5100 (NPL)"))
    assert main(["ssf", "estimate", dng, "--chart", str(csv), "-o", str(tmp_path / "b.json")]) == 0
    assert zonotope.load_camera(tmp_path / "b.json").values.shape[1] == 3


def test_several_chart_csvs_each_under_its_light(tmp_path, capsys):
    """Two --chart files with one --illuminant each give the API's estimate from both photographs; a
    count of lights that matches neither one nor the charts is one line, before anything is written."""
    w = SSF_SHAPE.wavelengths
    R = spectra.resample(zonotope.reflectances("ColorChecker N Ohta"), w).T
    truth = spectra.resample(zonotope.camera("Nikon 5100 (NPL)"), w)
    csvs, charts = [], []
    for light, top in (("D65", 0.8), ("A", 0.4)):
        C = (R * spectra.resample(zonotope.illuminant(light), w)[:, 0]) @ truth
        C = top * C / C.max()
        csvs.append(tmp_path / f"chart_{light}.csv")
        csvs[-1].write_text("\n".join(",".join(f"{x:.9g}" for x in row) for row in C) + "\n")
        charts.append(Chart(np.loadtxt(csvs[-1], delimiter=","), illuminant=light))
    out = tmp_path / "two.json"
    argv = ["ssf", "estimate", "--chart", str(csvs[0]), "--chart", str(csvs[1]), "-o", str(out)]
    assert main([*argv, "--illuminant", "D65", "--illuminant", "A"]) == 0
    assert "the charts under D65, A" in capsys.readouterr().out
    np.testing.assert_allclose(zonotope.load_camera(out).values, estimate_ssf(chart=charts).values, atol=1e-6)
    three = [*argv[:-1], str(tmp_path / "three.json")]
    assert main([*three, "--illuminant", "D65", "--illuminant", "A", "--illuminant", "A"]) == 2
    assert "3 --illuminant for 2 --chart" in capsys.readouterr().err
    assert not (tmp_path / "three.json").exists()


def test_chart_csv_of_isp_profile_is_read_by_its_raw_columns_and_its_light(tmp_path, capsys):
    """The per-patch report ``isp profile --chart`` writes carries the raw means in columns 3–5, Lab and
    ΔE00 after them and the light last: the estimate reads the raw columns (not the last three cells)
    and takes the light from the file, refusing an --illuminant that contradicts it."""
    from isp.profiles.chart import REPORT_CSV_HEADER

    w = SSF_SHAPE.wavelengths
    R = spectra.resample(zonotope.reflectances("ColorChecker N Ohta"), w).T
    E = spectra.resample(zonotope.illuminant("A"), w)[:, 0]
    C = (R * E) @ spectra.resample(zonotope.camera("Nikon 5100 (NPL)"), w)
    C = 0.8 * C / C.max()
    plain, report = tmp_path / "plain.csv", tmp_path / "chart_patches.csv"
    plain.write_text("\n".join(",".join(f"{x:.6g}" for x in row) for row in C) + "\n")
    rows = [
        f"{k + 1},patch {k + 1},"
        + ",".join(f"{x:.6g}" for x in (*C[k], 50, 3, -4, 51, 2, -5, 1.5, 1.2))
        + ",A"
        for k in range(24)
    ]
    report.write_text(REPORT_CSV_HEADER + "\n" + "\n".join(rows) + "\n")
    assert (
        main(["ssf", "estimate", "--chart", str(plain), "--illuminant", "A", "-o", str(tmp_path / "a.json")])
        == 0
    )
    assert main(["ssf", "estimate", "--chart", str(report), "-o", str(tmp_path / "b.json")]) == 0
    assert "the chart under A" in capsys.readouterr().out
    a, b = (zonotope.load_camera(tmp_path / f"{s}.json").values for s in "ab")
    np.testing.assert_allclose(a, b)  # the same means, the same light
    assert (
        main(
            ["ssf", "estimate", "--chart", str(report), "--illuminant", "D65", "-o", str(tmp_path / "c.json")]
        )
        == 2
    )
    assert "photographed under A (its illuminant column) but --illuminant is D65" in capsys.readouterr().err
    assert not (tmp_path / "c.json").exists()


@pytest.mark.parametrize(
    ("make", "match"),
    [
        (lambda d: _dng(d / "x.dng"), "no usable ColorMatrix1/ColorMatrix2"),
        (lambda d: (d / "x.dng").write_text("text") and str(d / "x.dng"), "not a readable DNG"),
        (lambda d: str(d / "missing.dng"), "no such file"),
    ],
)
def test_errors_are_one_line_and_write_nothing(tmp_path, capsys, make, match):
    src = make(tmp_path)
    out = tmp_path / "cam.json"
    assert main(["ssf", "estimate", src, "-o", str(out)]) == 2
    err = capsys.readouterr().err
    assert match in err and err.count("\n") == 1, err
    assert not out.exists()


def test_a_foreign_file_is_never_replaced(tmp_path, capsys):
    dng = _dng(tmp_path / "cam.dng", synthesise_dng_matrices("Nikon 5100 (NPL)"))
    foreign = tmp_path / "notes.json"
    foreign.write_text("{}\n")
    assert main(["ssf", "estimate", dng, "-o", str(foreign), "--force"]) == 2
    assert "never replaced" in capsys.readouterr().err
    assert foreign.read_text() == "{}\n"
    assert main(["ssf", "estimate", dng, "-o", dng, "--force"]) == 2  # the input itself
    assert main(["ssf", "estimate", "-o", str(tmp_path / "y.json")]) == 2  # nothing to estimate from


def test_capture_toml_ssf_estimate_uses_the_first_dng(tmp_path):
    """``ssf = "estimate"`` in capture.toml: the camera's curves from its folder's first DNG."""
    capture = pytest.importorskip("splat.capture")
    (tmp_path / "cam").mkdir()
    _dng(tmp_path / "cam" / "a.dng", synthesise_dng_matrices("Nikon 5100 (NPL)"))
    (tmp_path / "empty").mkdir()
    (tmp_path / "empty" / "b.nef").write_bytes(b"not read here")  # a RAW file, but no DNG
    (tmp_path / "capture.toml").write_text(
        'illuminant = "D65"\n[[camera]]\nfolder = "cam"\nssf = "estimate"\n'
        '[[camera]]\nfolder = "empty"\nssf = "estimate"\n'
    )
    spec = capture.read_capture(tmp_path / "capture.toml")
    cam = spec.load_ssf(0)
    assert cam.values.shape == (len(SSF_SHAPE.wavelengths), 3) and cam.values.min() >= 0
    with pytest.raises(capture.CaptureError, match="needs a DNG file"):
        spec.load_ssf(1)


def test_capture_adds_the_estimate_band_to_the_noise(tmp_path):
    """A camera with estimated curves carries their response σ into the correct step's fits; a measured
    camera in the stack the spread between units of one model, none with ``ssf_exact = true``; the
    fused fit is told the band in quadrature with the sensor noise."""
    capture = pytest.importorskip("splat.capture")
    from splat.fusion import whitened

    (tmp_path / "cam").mkdir()
    _dng(tmp_path / "cam" / "a.dng", synthesise_dng_matrices("Nikon 5100 (NPL)"))
    (tmp_path / "meas").mkdir()
    (tmp_path / "meas" / "b.nef").write_bytes(b"not read here")
    (tmp_path / "capture.toml").write_text(
        'illuminant = "D65"\n[[camera]]\nfolder = "cam"\nssf = "estimate"\n'
        '[[camera]]\nfolder = "meas"\nssf = "Nikon 5100 (NPL)"\n'
    )
    spec = capture.read_capture(tmp_path / "capture.toml")
    band = capture.ssf_sigma(spec, [0, 1])
    expected = spec.ssf_estimate(0).response_sigma(spec.load_illuminant())
    np.testing.assert_allclose(band[:3], expected)
    assert (band[:3] > 0).all() and np.array_equal(band[3:], zonotope.unit_sigma(2)[3:])
    assert spec.ssf_estimate(1) is None
    record = capture.ssf_record(spec, [0, 1])  # what the correct summary (and the report) says
    assert record["meas"] == {"measured": "Nikon 5100 (NPL)", "exact": False, "sigma": list(SSF_UNIT_SIGMA)}
    assert record["cam"]["file"] == "a.dng" and record["cam"]["estimated"] == "DNG colour matrices"
    np.testing.assert_allclose(record["cam"]["sigma"], expected, atol=1e-6)

    noise = np.full(6, 0.002)
    _, scale = capture.fit_fused_corrector(spec, [0, 1], "least squares", noise)
    _, told, _ = whitened(capture.correction_problem_of(spec, [0, 1]), np.hypot(noise, band))
    np.testing.assert_allclose(scale, told)  # the band joined the noise before whitening

    # the render corrected alone: the pipeline's default method told σ per channel (it raised before)
    prior = capture.fit_corrector(spec, [0, 1], "Prior", 0.012, mix=capture.pipeline_mix("Prior"))
    assert np.all(np.isfinite(prior(np.full((2, 6), 0.3))))

    (tmp_path / "capture.toml").write_text(  # curves measured on this very camera: nothing added
        (tmp_path / "capture.toml").read_text() + "ssf_exact = true\n"
    )
    exact = capture.read_capture(tmp_path / "capture.toml")
    assert exact.cameras[1].ssf_exact and not capture.ssf_sigma(exact, [0, 1])[3:].any()
    assert capture.ssf_record(exact, [0, 1])["meas"] == {
        "measured": "Nikon 5100 (NPL)",
        "exact": True,
        "sigma": [0, 0, 0],
    }
    assert capture.curves_fingerprint(exact) != capture.curves_fingerprint(spec)  # the correct step reruns
    assert not capture.ssf_sigma(exact, [1]).any() and not capture.ssf_sigma(spec, [1]).any()  # alone


def test_a_capture_naming_an_estimate_file_treats_it_as_estimated(tmp_path):
    """A file ``zonotope ssf estimate`` wrote (here from a DNG and a chart), named by ``ssf``: its own
    band is told to the fits and the record says what it was estimated from, not "measured" (it got
    the units' spread and the report called it published curves); ``ssf_exact = true`` with it is one
    line."""
    capture = pytest.importorskip("splat.capture")
    w = SSF_SHAPE.wavelengths
    R = spectra.resample(zonotope.reflectances("ColorChecker N Ohta"), w).T
    C = (R * spectra.resample(zonotope.illuminant("D65"), w)[:, 0]) @ spectra.resample(
        zonotope.camera("Nikon 5100 (NPL)"), w
    )
    (tmp_path / "chart.csv").write_text("\n".join(",".join(f"{x:.9g}" for x in r) for r in 0.8 * C / C.max()))
    dng = _dng(tmp_path / "a.dng", synthesise_dng_matrices("Nikon 5100 (NPL)"))
    for d in ("cam", "meas"):
        (tmp_path / d).mkdir()
        (tmp_path / d / "x.nef").write_bytes(b"not read here")
    out = str(tmp_path / "cam.json")
    assert main(["ssf", "estimate", dng, "--chart", str(tmp_path / "chart.csv"), "-o", out]) == 0
    toml = 'illuminant = "D65"\n[[camera]]\nfolder = "cam"\nssf = "cam.json"\n'
    toml += '[[camera]]\nfolder = "meas"\nssf = "Nikon 5100 (NPL)"\n'
    (tmp_path / "capture.toml").write_text(toml)
    spec = capture.read_capture(tmp_path / "capture.toml")
    est = spec.ssf_estimate(0)
    assert est is not None and est.sources == ("dng", "chart") and spec.ssf_estimate(1) is None
    band = capture.ssf_sigma(spec, [0, 1])
    np.testing.assert_allclose(band[:3], est.response_sigma(spec.load_illuminant()))
    record = capture.ssf_record(spec, [0, 1])["cam"]
    assert record["estimated"] == "DNG colour matrices + chart photographs" and record["file"] == "cam.json"
    (tmp_path / "capture.toml").write_text(
        toml.replace('ssf = "cam.json"\n', 'ssf = "cam.json"\nssf_exact = true\n')
    )
    with pytest.raises(capture.CaptureError, match=r"not for cam\.json, which zonotope ssf estimate wrote"):
        capture.read_capture(tmp_path / "capture.toml")


def test_a_foveon_dng_says_it_fell_back_to_the_exact_matrix_calibration(tmp_path, capsys):
    """The Sigma's (Foveon) matrices fit worse than any real-DNG calibration camera's: the message says
    which calibration the band is from and why."""
    sigma = colour.MultiSpectralDistributions(
        zonotope.camera("Sigma SDMerill (NPL)").copy().align(SSF_SHAPE).values,
        SSF_SHAPE.wavelengths,
        name="sigma",
    )
    dng = _dng(tmp_path / "sigma.dng", synthesise_dng_matrices(sigma))
    assert main(["ssf", "estimate", dng, "-o", str(tmp_path / "sigma.json")]) == 0
    said = capsys.readouterr().out
    assert "band calibrated on synthesised matrices (misfit" in said and "any calibration camera's" in said


def test_illuminant_without_a_chart_is_refused(tmp_path, capsys):
    """``--illuminant`` is the light of a chart photograph: given without ``--chart`` it would be ignored."""
    dng = _dng(tmp_path / "cam.dng", synthesise_dng_matrices("Nikon 5100 (NPL)"))
    assert main(["ssf", "estimate", dng, "--illuminant", "A", "-o", str(tmp_path / "x.json")]) == 2
    assert "applies to --chart only" in capsys.readouterr().err and not (tmp_path / "x.json").exists()
