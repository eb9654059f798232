"""zonotope.report: complete, atomic, never overwrites without force."""

from __future__ import annotations

import numpy as np
import pytest

from zonotope._errors import SpectralDataError
from zonotope.report import FILES, ReportExistsError, write_report
from zonotope.utilities.io import MARKER

GRID = np.arange(400.0, 701.0, 10.0)


@pytest.mark.slow
def test_report_written_atomically(tmp_path):
    out = tmp_path / "rep"
    steps = []
    write_report(
        ["Nikon 5100 (NPL)", "Canon EOS 5D Mark II"],
        out,
        atypical=4,
        pictures=False,
        methods=["root-polynomial", "Prior"],
        volumes=False,
        progress=lambda stage, done, total: steps.append((stage, done, total)),
    )
    html = (out / "index.html").read_text()
    md = (out / "report.md").read_text()
    assert "Vora" in html and "Greedy order" in md and "Colour-correction evaluation" in md
    assert "Nikon 5100 (NPL) + Canon EOS 5D Mark II" in md
    assert ("loading cameras", 0, 2) in steps and all(d == 0 for _, d, _ in steps)
    assert [p.name for p in tmp_path.iterdir()] == ["rep"]  # no temp folders left

    with pytest.raises(ReportExistsError, match="force"):
        write_report(["Nikon 5100 (NPL)"], out, pictures=False)
    assert "Canon" in (out / "report.md").read_text()  # the good report is untouched


def test_failed_report_never_replaces_a_good_one(tmp_path, monkeypatch):
    out = tmp_path / "rep"
    out.mkdir()
    (out / "report.md").write_text("good")
    (out / MARKER).write_text("zonotope report\n")  # a previous report: force may replace it
    import zonotope.evaluate

    def boom(*args, **kwargs):
        raise RuntimeError("interrupted")

    monkeypatch.setattr(zonotope.evaluate, "evaluate", boom)
    with pytest.raises(RuntimeError, match="interrupted"):
        write_report(
            ["Nikon 5100 (NPL)"],
            out,
            force=True,
            atypical=0,
            pictures=False,
            methods=["least squares"],
            volumes=False,
        )
    assert (out / "report.md").read_text() == "good"
    assert [p.name for p in tmp_path.iterdir()] == ["rep"]


_QUICK = {"atypical": 0, "pictures": False, "methods": ["least squares"], "volumes": False}


def test_force_replaces_only_what_the_report_wrote(tmp_path):
    """``--force`` deleted every file a user had added inside an earlier report folder; now a report
    lists what it wrote and ``force`` refuses (before the work) a folder holding anything else."""
    out = tmp_path / "rep"
    write_report(["Nikon 5100 (NPL)"], out, **_QUICK)
    first = sorted(p.name for p in out.iterdir())
    assert FILES in first and "index.html" in first
    write_report(["Nikon 5100 (NPL)"], out, force=True, **_QUICK)  # only its own files: replaced
    assert sorted(p.name for p in out.iterdir()) == first
    (out / "notes").mkdir()
    (out / "notes" / "mine.txt").write_text("my notes")
    with pytest.raises(ReportExistsError, match=r"notes: not written by zonotope report.*move it out"):
        write_report(["Nikon 5100 (NPL)"], out, force=True, **_QUICK)
    assert (out / "notes" / "mine.txt").read_text() == "my notes"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["rep"]


def test_force_keeps_a_file_added_during_the_computation(tmp_path, monkeypatch):
    out = tmp_path / "rep"
    write_report(["Nikon 5100 (NPL)"], out, **_QUICK)
    import zonotope.evaluate

    evaluate = zonotope.evaluate.evaluate

    def add_then_evaluate(*args, **kwargs):
        (out / "added.txt").write_text("mine")
        return evaluate(*args, **kwargs)

    monkeypatch.setattr(zonotope.evaluate, "evaluate", add_then_evaluate)
    with pytest.raises(ReportExistsError, match=r"added\.txt: not written by zonotope report"):
        write_report(["Nikon 5100 (NPL)"], out, force=True, **_QUICK)
    assert (out / "added.txt").read_text() == "mine" and (out / "index.html").is_file()
    assert sorted(p.name for p in tmp_path.iterdir()) == ["rep"]  # no temporary left


def test_force_replaces_a_report_written_before_the_file_list(tmp_path):
    out = tmp_path / "rep"
    out.mkdir()
    (out / MARKER).write_text("zonotope report\n")
    (out / "index.html").write_text("<img src='solid.png' alt='x'>")
    (out / "solid.png").write_bytes(b"png")
    (out / "report.md").write_text("old")
    write_report(["Nikon 5100 (NPL)"], out, force=True, **_QUICK)
    assert not (out / "solid.png").exists() and (out / FILES).is_file()
    (out / "stale.txt").write_text("old")
    with pytest.raises(ReportExistsError, match=r"stale\.txt"):
        write_report(["Nikon 5100 (NPL)"], out, force=True, **_QUICK)


def test_report_errors(tmp_path):
    with pytest.raises(SpectralDataError, match="more than once"):
        write_report(["Nikon 5100 (NPL)", "Nikon 5100 (NPL)"], tmp_path / "x", pictures=False)
    with pytest.raises(SpectralDataError, match="at least one camera"):
        write_report([], tmp_path / "y", pictures=False)
    assert not (tmp_path / "x").exists()


@pytest.mark.slow
def test_report_with_pictures(tmp_path):
    out = tmp_path / "rep"
    write_report(["Nikon 5100 (NPL)"], out, atypical=0, methods=["least squares"], volumes=False)
    assert (out / "solid.png").stat().st_size > 10_000
    assert "solid.png" in (out / "index.html").read_text()
    assert (out / "confidence_map.png").stat().st_size > 10_000  # the credible radii, per patch
    assert "confidence_map.png" in (out / "report.md").read_text()
    assert (out / "illuminant_mmv.png").stat().st_size > 10_000  # next to the observer-induced MMV
    assert "illuminant_mmv.png" in (out / "report.md").read_text()


@pytest.mark.slow
def test_report_mmv_tables(tmp_path):
    out = tmp_path / "rep"
    write_report(["Nikon 5100 (NPL)"], out, atypical=0, methods=["Centroid"], pictures=False)
    md = (out / "report.md").read_text()
    assert "MMV volume along the grey axis" in md and "MMV volume of the ColorChecker" in md
    assert "| Nikon 5100 (NPL) | ColorChecker N Ohta | Centroid |" in md


def test_illuminant_mmv_figure_sets_the_three_cases_side_by_side(monkeypatch, tmp_path):
    """The report's illuminant figure: observer-induced (cameras under the report's light),
    illuminant-induced (the eye under A) and both (the cameras under A), every panel in the same XYZ
    under the report's light (so the three Ψ are one); the eye under one light would be a point."""
    import colour

    from zonotope import report, viz
    from zonotope.correct.methods import correction_problem
    from zonotope.spectra.loading import load_camera

    seen = {}

    class _Done:
        def close(self):
            return None

    def fake(problems, x, *, titles, filename, window_size):
        seen.update(problems=problems, titles=titles)
        return _Done()

    monkeypatch.setattr(viz, "plot_mmv_comparison", fake)
    shape = colour.SpectralShape(400, 700, 10)
    curves = [load_camera("Nikon 5100 (NPL)")]
    full = correction_problem(curves, illuminant="D65", shape=shape)
    x = np.full(31, 0.4)
    assert report._illuminant_mmvs(curves, full, x, tmp_path / "f.png") == ("D65", "A")
    obs, eye, both = seen["problems"]
    np.testing.assert_allclose(eye.Psi, obs.Psi)
    np.testing.assert_allclose(both.Psi, obs.Psi)
    np.testing.assert_allclose(both.Phi, correction_problem(curves, illuminant="A", shape=shape).Phi)
    # the eye under A: its own curves times A (white → 1 per channel), not under D65
    E = colour.SDS_ILLUMINANTS["A"].copy().align(shape).values
    cmfs = colour.MSDS_CMFS["CIE 2015 2 Degree Standard Observer"].copy().align(shape).values
    np.testing.assert_allclose(eye.Phi, cmfs * E[:, None] / (cmfs * E[:, None]).sum(0), atol=1e-3)
    assert seen["titles"][1] == "eye (A) to eye (D65)"
    # under A the second light is D65
    full_a = correction_problem(curves, illuminant="A", shape=shape)
    assert report._illuminant_mmvs(curves, full_a, x, tmp_path / "g.png") == ("A", "D65")


def test_an_estimated_camera_is_said_and_its_band_shaded(tmp_path):
    """A camera file written by ``zonotope ssf estimate`` carries its uncertainty: the report says the
    curves are estimated, and the sensitivity plot shades ± band_k σ around that camera's channels
    only, in the plot's units (each channel's peak 1)."""
    import colour
    import matplotlib

    matplotlib.use("Agg")
    import zonotope
    from zonotope import viz
    from zonotope.correct import correction_problem
    from zonotope.report import _estimated_bands
    from zonotope.spectra.estimate import read_ssf_band, ssf_basis, synthesise_dng_matrices

    est = zonotope.estimate_ssf(synthesise_dng_matrices("Canon EOS 5D Mark II"), name="Canon EOS Kiss X4")
    cam = zonotope.write_ssf_json(est, tmp_path / "cam.json")
    sigma, said = read_ssf_band(cam, GRID)  # the file's σ back on the grid
    np.testing.assert_allclose(sigma, est.uncertainty, atol=1e-6)
    assert "estimated by zonotope.estimate_ssf" in said
    assert read_ssf_band("Nikon 5100 (NPL)", GRID) is None  # measured curves: no band
    out = tmp_path / "rep"
    write_report([str(cam), "Nikon 5100 (NPL)"], out, **_QUICK)
    md = (out / "report.md").read_text()
    assert "Canon EOS Kiss X4: curves estimated, not measured" in md and "Nikon 5100 (NPL): curves" not in md
    cameras = [str(cam), "Nikon 5100 (NPL)"]
    curves = [zonotope.load_camera(cam), zonotope.camera("Nikon 5100 (NPL)")]
    full = correction_problem(curves, shape=colour.SpectralShape(400, 700, 10))
    (bands, band_k) = _estimated_bands(cameras, curves, full, "D65", GRID)
    phi = bands["phi"]
    assert band_k == ssf_basis().band_k and not phi[:, 3:].any()  # only the estimated camera's channels
    peak = np.asarray(full.Phi)[:, :3].max(0)
    rel = (phi[:, :3] / peak).max(0)  # the band relative to the peak, as the plot shows it
    own = band_k * (est.uncertainty / est.values.max(0)).max(0)  # the same, from the estimate itself
    assert np.all(rel > 0.3 * own) and np.all(rel < 3 * own)
    fig = viz.plot_sensitivities(full, bands=phi, band_label="band")
    assert len(fig.axes[0].collections) == 3  # one shaded band per estimated channel
