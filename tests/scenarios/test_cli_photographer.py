"""What a user tripped over in the ``zonotope`` CLI and pictures: ``--version``, a command that lists the
built-in cameras, ``summary`` with camera files, one atypical set behind one label in ``evaluate`` and
``report``, progress lines when the output is piped, axis labels on 3-D figures."""

from __future__ import annotations

import colour
import numpy as np
import pytest

import zonotope
from zonotope.cli import main

GRID = np.arange(400.0, 701.0, 10.0)


def test_version(capsys):
    from splat.cli import main as splat_main

    for prog, entry in (("zonotope", main), ("splat", splat_main)):
        with pytest.raises(SystemExit) as exc:
            entry(["--version"])
        assert exc.value.code == 0 and capsys.readouterr().out.strip() == f"{prog} {zonotope.__version__}"


def test_list_builtin(capsys):
    assert main(["cameras"]) == 0
    assert capsys.readouterr().out.splitlines() == zonotope.list_builtin()["cameras"]
    assert main(["list", "illuminants"]) == 0
    assert capsys.readouterr().out.splitlines() == zonotope.list_builtin()["illuminants"]
    assert main(["list"]) == 0
    out = capsys.readouterr().out
    assert all(f"{kind}:" in out for kind in zonotope.list_builtin())
    with pytest.raises(SystemExit):
        main(["list", "lenses"])


def test_summary_accepts_camera_files(tmp_path, capsys):
    cam = zonotope.camera("Nikon 5100 (NPL)")
    path = tmp_path / "nikon.csv"
    rows = ["wavelength,r,g,b"] + [
        f"{w:g},{r!r},{g!r},{b!r}" for w, (r, g, b) in zip(cam.wavelengths, cam.values, strict=True)
    ]
    path.write_text("\n".join(rows) + "\n")
    grid = ["--start", "400", "--end", "700", "--interval", "10"]
    assert main(["summary", "--camera", str(path), *grid]) == 0
    from_file = capsys.readouterr().out
    assert main(["summary", "--camera", "Nikon 5100 (NPL)", *grid]) == 0
    builtin = capsys.readouterr().out

    def vora_and_volume(text):  # the numbers of the camera's row (name and build time differ)
        row = next(line for line in text.splitlines() if "400–700/10" in line and "target" not in line)
        cells = [c.strip() for c in row.split("│")]
        return cells[3:5], cells[7]

    assert vora_and_volume(from_file) == vora_and_volume(builtin)


def test_report_and_evaluate_draw_the_same_atypical_set(tmp_path, capsys):
    from zonotope.evaluate import atypical_test_set
    from zonotope.report import write_report

    md = tmp_path / "eval.md"
    assert (
        main(
            [
                "evaluate",
                "--camera",
                "Nikon 5100 (NPL)",
                "--method",
                "Finlayson 2015",
                "--atypical",
                "5",
                "--noise",
                "0",
                "--markdown",
                str(md),
            ]
        )
        == 0
    )
    err = capsys.readouterr().err
    assert "s] " in err  # plain progress lines: stderr is not a terminal under pytest
    out = write_report(
        ["Nikon 5100 (NPL)"],
        tmp_path / "report",
        atypical=5,
        pictures=False,
        volumes=False,
        methods=["Finlayson 2015"],
        shape=colour.SpectralShape(400, 700, 10),
    )

    def atypical_row(text):
        rows = [line for line in text.splitlines() if "atypical (5)" in line]
        assert len(rows) == 1, rows
        return rows[0]

    assert atypical_row(md.read_text()) == atypical_row((out / "report.md").read_text())
    a, b = atypical_test_set(GRID, 5), atypical_test_set(GRID, 5, seed=3)
    assert a.name == "atypical (5)" and b.name == "atypical (5, seed 3)"
    assert not np.array_equal(a.reflectances, b.reflectances)


def test_3d_figures_have_axis_labels(tmp_path):
    from zonotope import viz
    from zonotope.correct import correction_problem

    xyz = correction_problem(["Nikon 5100 (NPL)"], target="CIE 1931 2°", shape=GRID)
    lms = correction_problem(["Nikon 5100 (NPL)"], target="Stockman & Sharpe 2°", shape=GRID)
    for problem, names in [(xyz, "XYZ"), (lms, "LMS")]:
        p = viz.plot_grey_mmvs(problem, levels=(0.5,), filename=tmp_path / f"{names}.png")
        axes = p.renderer.cube_axes_actor
        assert (axes.GetXTitle(), axes.GetYTitle(), axes.GetZTitle()) == tuple(names)
        # the grey axis ends at the white in the plotted (target) coordinates, also for LMS
        inputs = [a.GetMapper().GetInput() for a in p.renderer.actors.values() if a.GetMapper() is not None]
        line = next(d for d in inputs if d is not None and d.GetNumberOfPoints() == 2)
        np.testing.assert_allclose(line.GetPoint(1), problem.Psi.sum(0), rtol=1e-6)
        p.close()
        assert (tmp_path / f"{names}.png").stat().st_size > 10_000


def test_batch_commands_print_plain_progress_when_piped(tmp_path, capsys):
    """``zonotope correct`` / ``survey`` drew only rich bars, which print nothing live when stderr is
    not a terminal (piped into a file, as under pytest): now plain timed lines."""
    import numpy as np
    import tifffile

    images = tmp_path / "in"
    images.mkdir()
    for name in ("a", "b"):
        tifffile.imwrite(images / f"{name}.tif", np.full((3, 4, 3), 0.3, np.float32), photometric="rgb")
    argv = ["correct", str(images), "-o", str(tmp_path / "out"), "--camera", "Nikon 5100 (NPL)"]
    assert main([*argv, "--method", "matrix", "--scheduler", "serial"]) == 0
    err = capsys.readouterr().err
    assert "s] correcting (serial): 2/2" in err and "━" not in err
    assert err.index("fitting matrix for Nikon 5100 (NPL)…") < err.index("correcting")  # said before the fit
    assert main([*argv, "--method", "matrix", "--scheduler", "serial", "-q"]) == 0  # quiet: no lines
    err = capsys.readouterr().err
    assert "s] correcting" not in err and "fitting" not in err


def test_correct_rerun_with_every_output_present_skips_the_fit(tmp_path, capsys, monkeypatch):
    """A resumed ``zonotope correct`` whose outputs all exist used to refit the estimator (minutes for
    Prior) only to skip every file; now it fits nothing and reports them as done."""
    import numpy as np
    import tifffile

    from zonotope import correct

    images = tmp_path / "in"
    images.mkdir()
    tifffile.imwrite(images / "a.tif", np.full((3, 4, 3), 0.3, np.float32), photometric="rgb")
    argv = ["correct", str(images), "-o", str(tmp_path / "out"), "--camera", "Nikon 5100 (NPL)"]
    argv += ["--method", "matrix", "--scheduler", "serial"]
    assert main(argv) == 0
    first = (tmp_path / "out" / "a_XYZ.tif").read_bytes()
    fits = []
    real = correct.fit_correction
    monkeypatch.setattr(correct, "fit_correction", lambda *a, **k: fits.append(1) or real(*a, **k))
    capsys.readouterr()
    assert main(argv) == 0
    err = capsys.readouterr().err
    assert fits == [] and "fitting" not in err and "0 corrected, 1 already done, 0 failed" in err
    assert (tmp_path / "out" / "a_XYZ.tif").read_bytes() == first
    (tmp_path / "out" / "a_XYZ.tif").unlink()  # one missing output: fitted again and written
    assert main(argv) == 0
    assert fits == [1] and (tmp_path / "out" / "a_XYZ.tif").read_bytes() == first


def test_correct_noise_reaches_the_estimator(tmp_path, capsys):
    """``zonotope correct --noise σ`` fits the estimator with the noise model, as ``fit_correction(...,
    noise=σ)`` does (without it, `Prior` on a noisy two-camera chart from disk scored 5.5 ΔE00 mean
    instead of 1.9); a negative σ is one line and exit 2."""
    import tifffile

    from zonotope.correct import fit_correction

    images = tmp_path / "in"
    images.mkdir()
    img = np.random.default_rng(0).uniform(0.05, 0.6, (3, 4, 3)).astype(np.float32)
    tifffile.imwrite(images / "a.tif", img, photometric="rgb")
    argv = ["correct", str(images), "-o", str(tmp_path / "out"), "--camera", "Nikon 5100 (NPL)"]
    argv += ["--method", "Finlayson 2015", "--scheduler", "serial", "--noise", "0.02"]
    assert main(argv) == 0
    got = tifffile.imread(tmp_path / "out" / "a_XYZ.tif")
    noisy = fit_correction("Nikon 5100 (NPL)", method="Finlayson 2015", noise=0.02)(img.astype(float))
    exact = fit_correction("Nikon 5100 (NPL)", method="Finlayson 2015")(img.astype(float))
    np.testing.assert_allclose(got, noisy, rtol=1e-6)
    assert np.abs(noisy - exact).max() > 1e-4  # the option changes the fit
    capsys.readouterr()
    assert main([*argv[:-1], "-1"]) == 2
    assert capsys.readouterr().err.strip().splitlines() == [
        "zonotope: error: --noise -1.0: the response noise σ must be finite and ≥ 0."
    ]


def test_survey_size_is_checked_before_any_progress(capsys):
    assert main(["survey", "--cameras", "Nikon 5100 (NPL)", "--size", "3"]) == 2
    err = capsys.readouterr().err
    assert err.strip().splitlines() == [
        "zonotope: error: --size 3: sets of 1…1 cameras (the number of cameras loaded)."
    ]
