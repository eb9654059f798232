"""zonotope.survey: camera-set scores against independent computations, serial = distributed, CLI."""

from __future__ import annotations

import csv
import math
from dataclasses import replace

import numpy as np
import pytest

from zonotope import SpectralDataError, spectra
from zonotope.survey import REGRESSIONS, best_partners, load_cameras, survey, write_table

BUILTIN = ["Nikon 5100 (NPL)", "Sigma SDMerill (NPL)", "Canon EOS 5D Mark II"]


@pytest.fixture(scope="module")
def gauss_camera(tmp_path_factory):
    """A synthetic camera file (Gaussian R, G, B at 610/540/455 nm), CSV as read_camera reads it."""
    d = tmp_path_factory.mktemp("cams")
    w = np.arange(380.0, 781.0, 5.0)
    S = np.stack([np.exp(-0.5 * ((w - c) / s) ** 2) for c, s in ((610, 30), (540, 35), (455, 25))], axis=1)
    path = d / "Gauss_RGB.csv"
    path.write_text(
        "wavelength,R,G,B\n"
        + "\n".join(f"{x:g},{r:.6f},{g:.6f},{b:.6f}" for x, (r, g, b) in zip(w, S))
        + "\n"
    )
    (d / "notes.json").write_text('{"not": "a camera"}')
    return path


@pytest.fixture(scope="module")
def cams(gauss_camera):
    cams, _ = load_cameras([BUILTIN[0], BUILTIN[2], str(gauss_camera)])  # 3 pairs keep the test short
    return cams


@pytest.fixture(scope="module")
def serial_rows(cams):
    return survey(cams, size=2, scheduler="serial")


def _same(a, b):
    return replace(a, seconds=0.0) == replace(b, seconds=0.0)


def test_load_cameras(gauss_camera):
    cams, skipped = load_cameras(gauss_camera.parent)
    assert list(cams) == ["Gauss_RGB"] and len(skipped) == 1 and "notes.json" in skipped[0]
    named, _ = load_cameras("Nikon 5100 (NPL), Canon EOS 5D Mark II")
    assert list(named) == ["Nikon 5100 (NPL)", "Canon EOS 5D Mark II"]
    # a file given by name gets the same name as in a folder (no "_380_780_5" grid suffix)
    suffixed = gauss_camera.parent / "suffixed" / "Gauss_RGB_380_780_5.csv"
    suffixed.parent.mkdir(exist_ok=True)
    suffixed.write_text(gauss_camera.read_text())
    assert list(load_cameras(str(suffixed))[0]) == list(load_cameras(suffixed.parent)[0]) == ["Gauss_RGB"]
    empty = gauss_camera.parent / "empty"
    empty.mkdir(exist_ok=True)
    with pytest.raises(SpectralDataError, match="no camera file"):
        load_cameras(empty)


def test_scores_match_independent_computations(cams, serial_rows):
    from zonotope.correct import correction_problem, fit_correction
    from zonotope.mismatch import metamer_mismatch_bounds
    from zonotope.vora import vora_value

    assert len(serial_rows) == math.comb(3, 2) and not any(r.error for r in serial_rows)
    medians = [r.mmv_median for r in serial_rows]
    assert medians == sorted(medians)  # ranked by median MMV volume
    row = next(r for r in serial_rows if set(r.cameras) == {"Nikon 5100 (NPL)", "Gauss_RGB"})
    w = np.arange(400.0, 701.0, 10.0)
    assert row.grid == "400–700/10" and row.channels == 6
    problem = correction_problem(
        [cams[n] for n in row.cameras],
        shape=w,
        training=spectra.resample(spectra.reflectances("rawtoaces 190"), w).T,
    )
    assert row.vora == pytest.approx(vora_value(problem.Phi, problem.Psi), abs=1e-12)
    R = np.clip(spectra.resample(spectra.reflectances("ColorChecker N Ohta"), w).T, 0, 1)
    C, T = problem.source_of(R), problem.target_of(R)
    vols = [
        float(
            np.mean(
                metamer_mismatch_bounds(
                    problem.Phi, problem.Psi, c, eps=1e-3, on_infeasible="nearest"
                ).volume_bounds
            )
        )
        for c in C
    ]
    assert row.mmv_median == pytest.approx(np.median(vols), rel=1e-9)
    assert row.mmv_p90 == pytest.approx(np.percentile(vols, 90), rel=1e-9)
    dE = {}
    for m in REGRESSIONS[:2]:  # the ACES IDT (Dyer 2017) takes one RGB camera only
        dE[m] = float(np.mean(problem.delta_E(fit_correction(problem, method=m)(C), T)))
    assert row.best_regression == min(dE, key=dE.get)
    assert row.dE00 == pytest.approx(min(dE.values()), rel=1e-12)
    partners = best_partners(serial_rows, "Gauss_RGB", 2)
    assert len(partners) == 2 and all("Gauss_RGB" in r.cameras for r in partners)
    assert partners == [r for r in serial_rows if "Gauss_RGB" in r.cameras][:2]


@pytest.mark.slow
def test_survey_on_a_cluster_survives_a_killed_worker(cams, serial_rows, dask_cluster):
    dask_cluster.wait_for(2)
    killed = []

    def progress(stage, done, total):
        if done == 1 and not killed:
            dask_cluster.kill_worker()
            killed.append(done)

    rows = survey(cams, size=2, scheduler=dask_cluster.address, progress=progress)
    assert killed and len(rows) == len(serial_rows)
    assert all(_same(a, b) for a, b in zip(rows, serial_rows))  # complete, identical to serial, once each


def test_table_and_options(cams, serial_rows, tmp_path):
    path = write_table(serial_rows, tmp_path / "survey.csv")
    with open(path, newline="") as fh:
        listed = list(csv.DictReader(fh))
    assert [r["cameras"] for r in listed] == [" + ".join(r.cameras) for r in serial_rows]
    assert [int(r["rank"]) for r in listed] == list(range(1, len(serial_rows) + 1))
    assert float(listed[0]["vora"]) == pytest.approx(serial_rows[0].vora, rel=1e-5)
    try:
        import pyarrow  # noqa: F401
    except ImportError:
        with pytest.raises(Exception, match="pyarrow"):
            write_table(serial_rows, tmp_path / "survey.parquet")
    only = survey({BUILTIN[0]: cams[BUILTIN[0]]}, size=1, scheduler="serial")
    assert [r.cameras for r in only] == [(BUILTIN[0],)] and only[0].channels == 3 and not only[0].error
    with pytest.raises(SpectralDataError, match="size"):
        survey(cams, size=4, scheduler="serial")
    with pytest.raises(SpectralDataError, match="containing"):
        survey(cams, size=2, containing=["nope"], scheduler="serial")


def test_cli_survey(gauss_camera, tmp_path, capsys):
    from zonotope.cli import main

    out = tmp_path / "t.csv"
    rc = main(
        [
            "survey",
            "--cameras",
            f"{BUILTIN[0]},{gauss_camera}",
            "--cameras",
            BUILTIN[2],
            "--with",
            "Gauss_RGB",
            "--scheduler",
            "serial",
            "-o",
            str(out),
            "-q",
            "--partners",
            "2",
        ]
    )
    assert rc == 0
    text = capsys.readouterr().out
    assert "best partners of Nikon 5100 (NPL)" in text
    with open(out, newline="") as fh:
        assert len(list(csv.DictReader(fh))) == 2  # only the sets with Gauss_RGB
    assert main(["survey", "--cameras", BUILTIN[0], "--size", "3", "--scheduler", "serial", "-q"]) == 2
