"""The zonotope command line (summary, evaluate, report)."""

from __future__ import annotations

import pytest

from zonotope.cli import main


def test_summary_still_works(capsys):
    assert (
        main(
            ["summary", "--camera", "Nikon 5100 (NPL)", "--start", "400", "--end", "700", "--interval", "10"]
        )
        == 0
    )
    assert "Nikon 5100" in capsys.readouterr().out


def test_help_lists_every_command_one_per_line(capsys):
    """``zonotope --help`` described four of the six commands, run together into one paragraph."""
    with pytest.raises(SystemExit):
        main(["--help"])
    out = capsys.readouterr().out
    for command in ("summary", "list", "evaluate", "report", "correct", "survey"):
        assert any(line.startswith(f"- ``zonotope {command}") for line in out.splitlines()), command


def test_summary_sets_table_says_how_it_is_ordered(capsys):
    """The sets table is ordered by size first (a 3-camera set with the highest Vora value comes
    last), so its title must not claim one ranking by Vora value."""
    import re

    cams = ["Nikon 5100 (NPL)", "Sigma SDMerill (NPL)", "Canon EOS 5D Mark II"]
    argv = ["summary", *(a for c in cams for a in ("--camera", c)), "--start", "400", "--end", "680"]
    assert main([*argv, "--interval", "20"]) == 0
    out = capsys.readouterr().out
    assert "Camera sets by size, each size ranked by Vora value" in out
    rows = [(int(c), float(v)) for c, v in re.findall(r"│\s*(\d)\s*│\s*(0\.\d{4})\s*│\s*$", out, re.M)]
    assert [c for c, _ in rows] == [6, 6, 6, 9]
    pairs = [v for c, v in rows if c == 6]
    assert pairs == sorted(pairs, reverse=True) and rows[-1][1] > max(pairs)


def test_evaluate_command(tmp_path, capsys):
    md = tmp_path / "table.md"
    assert (
        main(
            [
                "evaluate",
                "--camera",
                "Nikon 5100 (NPL)",
                "--method",
                "root-polynomial",
                "--method",
                "prior",
                "--noise",
                "0",
                "--atypical",
                "4",
                "--markdown",
                str(md),
            ]
        )
        == 0
    )
    out = capsys.readouterr().out
    assert "CIEDE2000" in out and "Prior" in out
    assert "| Nikon 5100 (NPL) |" in md.read_text()


def test_evaluate_unknown_camera_is_a_clear_error(capsys):
    assert main(["evaluate", "--camera", "Nikon 9999", "--atypical", "2"]) == 2
    err = capsys.readouterr().err
    assert "unknown camera" in err and "Built-in cameras" in err


def test_evaluate_duplicated_camera(capsys):
    assert (
        main(["evaluate", "--camera", "Nikon 5100 (NPL)", "--camera", "nikon 5100", "--atypical", "2"]) == 2
    )
    assert "more than once" in capsys.readouterr().err


def test_evaluate_mismatched_grid_hint(capsys):
    # the Sigma data stop at 680 nm: an explicit 400–700 nm grid is refused with a hint ...
    assert main(["evaluate", "--camera", "Sigma SDMerill (NPL)", "--end", "700", "--atypical", "2"]) == 2
    err = capsys.readouterr().err
    assert "680" in err and "--end" in err
    # ... while the default grid narrows itself to the range the cameras share
    assert (
        main(
            [
                "evaluate",
                "--camera",
                "Nikon 5100 (NPL)",
                "--camera",
                "Sigma SDMerill (NPL)",
                "--method",
                "Finlayson 2015",
                "--atypical",
                "2",
            ]
        )
        == 0
    )
    assert "400–680 nm" in capsys.readouterr().out


@pytest.mark.parametrize("argv", [["evaluate"], ["report", "--camera", "x"]])
def test_missing_required_options(argv):
    with pytest.raises(SystemExit):
        main(argv)
