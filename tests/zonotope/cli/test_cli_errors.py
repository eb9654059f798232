"""Command-line paths found broken in the user-path review: each test failed on the code before its fix.

- a reader that closes the pipe early (``zonotope list illuminants | head -1``) made ``zonotope``
  print "zonotope: error: Broken pipe" and exit 2 (now: quiet, 128 + SIGPIPE, as Unix tools; rich
  tables, as ``isp info`` prints, already stopped quietly with status 1);
- ``--data`` naming a missing or unrelated folder was ignored: the evaluation ran on the built-in
  sets only and said nothing;
- ``zonotope correct`` refused two inputs with one output name only after fitting the estimator
  (35 s for Prior on two cameras), without naming them, and read integer TIFFs (16-bit counts) as
  responses with the white at 1: a value of 1000 came out as XYZ ≈ 1000;
- ``isp develop`` printed some bad-option errors through rich, wrapped over several lines at 80
  columns and without the ``isp: error:`` prefix; a folder holding IMG_0001.dng and IMG_0001.CRW
  was refused without naming the files, after creating the output folder.
"""

from __future__ import annotations

import signal
import subprocess
import sys

import numpy as np
import pytest

CAMERAS = ["--camera", "Nikon 5100 (NPL)", "--camera", "Canon EOS 5D Mark II"]


def _closed_pipe_run(argv: list[str]) -> subprocess.CompletedProcess:
    """Run ``python -m argv`` with its stdout a pipe whose reading end is closed before it writes."""
    proc = subprocess.Popen(
        [sys.executable, "-m", *argv], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True
    )
    proc.stdout.close()  # the reader is gone long before the interpreter has imported anything
    _, err = proc.communicate(timeout=300)
    return subprocess.CompletedProcess(argv, proc.returncode, "", err)


def test_zonotope_output_into_a_closed_pipe_is_quiet():
    r = _closed_pipe_run(["zonotope", "list", "illuminants"])
    assert r.stderr == "" and r.returncode == 128 + signal.SIGPIPE, (r.returncode, r.stderr)


@pytest.mark.parametrize("kind", ["missing", "unrelated"])
def test_data_folder_that_holds_no_sets_is_refused(kind, tmp_path, capsys):
    from zonotope.cli import main

    folder = tmp_path / "nope" if kind == "missing" else tmp_path  # tmp_path: a folder, no data sets
    argv = ["--camera", "Nikon 5100 (NPL)", "--data", str(folder), "--method", "matrix", "--atypical", "0"]
    assert main(["evaluate", *argv]) == 2
    err = capsys.readouterr().err.strip()
    assert err.count("\n") == 0 and err.startswith(f"zonotope: error: --data {str(folder)!r}"), err
    assert ("no such folder" if kind == "missing" else "holds none") in err
    out = tmp_path / "report"
    assert main(["report", "--camera", "Nikon 5100 (NPL)", "--data", str(folder), "-o", str(out)]) == 2
    assert "--data" in capsys.readouterr().err and not out.exists()


def test_correct_refuses_clashing_outputs_before_the_fit(tmp_path, capsys):
    import tifffile

    from zonotope.cli import main

    for sub in ("a", "b"):
        (tmp_path / sub).mkdir()
        tifffile.imwrite(
            tmp_path / sub / "x.tif", np.full((2, 3, 6), 0.3, np.float32), photometric="minisblack"
        )
    out = tmp_path / "out"
    assert main(["correct", str(tmp_path / "a"), str(tmp_path / "b"), "-o", str(out), *CAMERAS]) == 2
    err = capsys.readouterr().err
    assert "fitting" not in err and not out.exists(), err  # refused before the estimator is fitted
    assert str(tmp_path / "a" / "x.tif") in err and str(tmp_path / "b" / "x.tif") in err, err
    same = str(tmp_path / "a" / "x.tif")
    assert main(["correct", same, same, "-o", str(out), *CAMERAS]) == 2
    err = capsys.readouterr().err
    assert "given more than once" in err and "fitting" not in err and not out.exists(), err


@pytest.mark.parametrize(
    ("options", "start"),
    [
        (["--tonemap", "Reinhard 2002", "--exposure", "2"], "isp: error: --exposure applies to --tonemap "),
        (["--correction", "metamer"], "isp: error: --correction metamer needs --camera"),
    ],
)
def test_isp_option_errors_are_one_line(options, start, tmp_path, capsys):
    from isp.cli import main

    argv = ["develop", str(tmp_path / "photo.dng"), "-o", str(tmp_path / "photo.tif"), *options]
    assert main(argv) == 2  # refused before the file is read: it need not exist
    err = capsys.readouterr().err
    assert err.endswith("\n") and err.count("\n") == 1 and err.startswith(start), repr(err)


def test_isp_folder_with_one_stem_twice_names_both_files(tmp_path, capsys):
    from isp.cli import main

    raws = tmp_path / "raws"
    raws.mkdir()
    for name in ("IMG_0001.dng", "IMG_0001.CRW"):  # refused before any file is read
        (raws / name).write_bytes(b"\x00" * 16)
    out = tmp_path / "developed"
    assert main(["develop", str(raws), "-o", str(out), "--scheduler", "serial"]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and err.startswith("isp: error: "), repr(err)
    assert "IMG_0001.dng" in err and "IMG_0001.CRW" in err and not out.exists(), err


def test_correct_refuses_integer_tiffs(tmp_path, capsys):
    import tifffile

    from zonotope.cli import main

    src = tmp_path / "in"
    src.mkdir()
    tifffile.imwrite(src / "counts.tif", np.full((4, 4, 6), 1000, np.uint16), photometric="minisblack")
    tifffile.imwrite(src / "float.tif", np.full((4, 4, 6), 0.3, np.float32), photometric="minisblack")
    out = tmp_path / "out"
    argv = ["correct", str(src), "-o", str(out), *CAMERAS, "--method", "matrix", "--scheduler", "serial"]
    assert main(argv) == 1  # the bad file is reported, the good one corrected
    err = capsys.readouterr().err
    assert "counts.tif: uint16 pixels" in err and "float" in err, err
    assert not (out / "counts_XYZ.tif").exists() and (out / "float_XYZ.tif").exists()


@pytest.mark.parametrize(
    ("options", "start"),
    [
        (["--camera", "No Such Camera"], "isp: error: unknown camera 'No Such Camera'"),
        (["--camera", "Nikon 5100 (NPL)", "--hue-sat-size", "0", "5"], "isp: error: --hue-sat-size 0 5: "),
        (["--camera", "Nikon 5100 (NPL)", "--lut", "x.cube", "--lut-size", "1"], "isp: error: --lut-size: "),
        (["--camera", "Nikon 5100 (NPL)", "--lut", "x.cube", "--headroom", "0"], "isp: error: --headroom: "),
        (
            ["--camera", "Nikon 5100 (NPL)", "--illuminants", "D65", "d65"],
            "isp: error: --illuminants D65 d65: ",
        ),
    ],
)
def test_isp_profile_errors_name_the_option_before_fitting(options, start, tmp_path, capsys):
    """Were ``ProfileConfig.dims=(0, 5, 1)``, ``size=1`` (the API's names), and an unknown camera was
    reported after 'fitting Prior for No Such Camera under A and D65…'."""
    from isp.cli import main

    assert main(["profile", "-o", str(tmp_path / "p.dcp"), *options]) == 2
    err = capsys.readouterr().err
    assert err.startswith(start) and err.count("\n") == 1 and "fitting" not in err, repr(err)
    assert list(tmp_path.iterdir()) == []


@pytest.mark.parametrize("command", ["zonotope", "isp"])
def test_bad_scheduler_is_refused_before_any_work_and_says_where_it_came_from(
    command, tmp_path, capsys, monkeypatch
):
    """A bad ``ZONOTOPE_SCHEDULER`` was reported as "scheduler 'bogus' is neither …" (not naming the
    variable the user may have forgotten), by ``zonotope correct`` after the fit and by ``isp develop``
    after creating the output folder."""
    import tifffile

    src = tmp_path / "in"
    src.mkdir()
    out = tmp_path / "out"
    monkeypatch.setenv("ZONOTOPE_SCHEDULER", "bogus")
    if command == "zonotope":
        from zonotope.cli import main

        tifffile.imwrite(src / "a.tif", np.full((2, 3, 6), 0.3, np.float32), photometric="minisblack")
        assert main(["correct", str(src), "-o", str(out), *CAMERAS]) == 2
    else:
        from isp.cli import main

        (src / "a.dng").write_bytes(b"\x00" * 16)  # never read: refused first
        assert main(["develop", str(src), "-o", str(out)]) == 2
    err = capsys.readouterr().err
    assert "ZONOTOPE_SCHEDULER='bogus' (environment variable)" in err and "fitting" not in err, err
    assert not out.exists()


@pytest.mark.parametrize("command", ["zonotope", "isp"])
def test_rerun_into_a_folder_with_other_settings_is_refused(command, tmp_path, capsys):
    """A rerun skips the outputs that exist: with other options it silently kept the old outputs
    (``zonotope correct`` with another --method, ``isp develop`` with another --demosaic)."""
    import tifffile

    src = tmp_path / "in"
    src.mkdir()
    out = tmp_path / "out"
    if command == "zonotope":
        from zonotope.cli import main

        tifffile.imwrite(src / "a.tif", np.full((2, 3, 6), 0.3, np.float32), photometric="minisblack")
        first = ["correct", str(src), "-o", str(out), *CAMERAS, "--scheduler", "serial", "-q"]
        assert main([*first, "--method", "matrix"]) == 0
        assert main([*first, "--method", "Cheung 2004"]) == 0  # an alias of the same method: resumes
        capsys.readouterr()
        assert main([*first, "--method", "Finlayson 2015"]) == 2
        expected = "method: 'Cheung 2004' then, 'Finlayson 2015' now"
    else:
        from isp.cli import main

        (src / "a.dng").write_bytes(b"\x00" * 16)  # fails (reported in the manifest), quickly
        first = ["develop", str(src), "-o", str(out), "--scheduler", "serial", "-q"]
        assert main(first) == 1
        assert main(first) == 1  # same settings: resumes (and reports the bad file again)
        capsys.readouterr()
        assert main([*first, "--demosaic", "Menon 2007"]) == 2
        expected = "demosaic: 'Malvar 2004' then, 'Menon 2007' now"
    err = capsys.readouterr().err
    assert expected in err and "fitting" not in err and err.count("\n") == 1, err


@pytest.mark.parametrize(("made_for", "warned"), [("Nikon D5100", True), ("canon eos  kiss x4", False)])
def test_isp_develop_warns_when_the_profile_is_for_another_camera(
    made_for, warned, shared_data, tmp_path, capsys
):
    """``--profile FILE`` applied a Nikon profile to a Canon DNG without a word."""
    from isp import read_raw
    from isp.cli import main
    from isp.profiles.dcp import DCPProfile, write_dcp

    dng = shared_data / "raw_samples" / "tinydng_colorchart_Canon_EOS_Kiss_X4_MagicLantern.dng"
    if not dng.is_file():
        pytest.skip(f"{dng} not present")
    raw = read_raw(dng)
    dcp = write_dcp(
        tmp_path / "p.dcp",
        DCPProfile(raw.profile.color_matrix_1, calibration_illuminant_1=21, unique_camera_model=made_for),
    )
    out = tmp_path / "x.tif"
    assert (
        main(["develop", str(dng), "-o", str(out), "--profile", str(dcp), "--crop", "0", "0", "64", "64"])
        == 0
    )
    err = capsys.readouterr().err
    expected = f"warning: {dcp} is a profile for {made_for!r} (its UniqueCameraModel) but this file is from"
    assert (expected in err) == warned, err
    assert out.exists()


def test_isp_profile_overwrite_replaces_only_its_own_outputs(tmp_path, capsys):
    """``isp profile --overwrite`` replaced any existing file: a third-party DCP, the user's own
    .cube; a --save-correction without .npz was refused only after the fit, with the DCP written."""
    from isp.cli import main
    from isp.profiles.dcp import DCPProfile, write_dcp

    theirs = tmp_path / "theirs.dcp"  # a DCP from elsewhere (no isp Software tag): as RawTherapee's
    theirs.write_bytes(b"IIRC" + b"\x00" * 60)
    own_lut = tmp_path / "grade.cube"
    own_lut.write_text("TITLE my grade\nLUT_3D_SIZE 2\n")
    before = {p.name: p.read_bytes() for p in (theirs, own_lut)}
    cam = ["--camera", "Nikon 5100 (NPL)", "--matrix-only", "--overwrite"]
    assert main(["profile", *cam, "-o", str(theirs)]) == 2
    assert "theirs.dcp exists and was not written by isp profile" in capsys.readouterr().err
    assert main(["profile", *cam, "-o", str(tmp_path / "new.dcp"), "--lut", str(own_lut)]) == 2
    assert "grade.cube exists and was not written by isp profile" in capsys.readouterr().err
    assert main(["profile", *cam, "-o", str(tmp_path / "new.dcp"), "--save-correction", "c.json"]) == 2
    err = capsys.readouterr().err
    assert err.startswith("isp: error: --save-correction c.json") and "fitting" not in err, err
    assert {p.name: p.read_bytes() for p in (theirs, own_lut)} == before
    assert not (tmp_path / "new.dcp").exists()
    ours = write_dcp(tmp_path / "ours.dcp", DCPProfile(np.eye(3), calibration_illuminant_1=21))
    from isp.cli.profile import _written_by_isp_profile

    assert _written_by_isp_profile(ours) and not _written_by_isp_profile(theirs)
