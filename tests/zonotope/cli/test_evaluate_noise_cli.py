"""``zonotope evaluate --noise``: every estimator at several noise levels, given as ``zonotope correct
--noise`` takes them; bad levels are refused in one line before any work."""

from __future__ import annotations

import pytest

from zonotope.cli import main

FAST = ["--camera", "Nikon 5100 (NPL)", "--method", "matrix", "--method", "root-polynomial"]


def test_default_levels_are_noise_free_and_two_shot_noise_levels(tmp_path, capsys):
    md = tmp_path / "table.md"
    assert main(["evaluate", *FAST, "--atypical", "3", "--markdown", str(md)]) == 0
    out = capsys.readouterr().out
    text = md.read_text()
    for level in ("| 0 |", "| shot σw 0.002 |", "| shot σw 0.005 |"):
        assert level in text
    assert "| cameras | test set | kind | noise | Cheung 2004 | Finlayson 2015 |" in text
    assert "noise shot σw 0.005 (pooled mean / p95 / max)" in out


def test_levels_as_sigma_and_shot_read(tmp_path):
    md = tmp_path / "table.md"
    argv = ["evaluate", *FAST, "--atypical", "0", "--markdown", str(md)]
    assert main([*argv, "--noise", "0", "--noise", "0.003", "--noise", "2.5e-5:1e-6"]) == 0
    text = md.read_text()
    assert "| σ 0.003 |" in text and "| 2.5e-05:1e-06 |" in text and "| shot σw" not in text


@pytest.mark.parametrize("bad", ["loud", "1:x", "-1e-4:0", "nan", "-0.01", "auto"])
def test_bad_noise_is_a_one_line_error(bad, tmp_path, capsys):
    md = tmp_path / "table.md"
    argv = ["evaluate", *FAST, "--atypical", "0", "--markdown", str(md), f"--noise={bad}"]
    assert main(argv) == 2
    err = capsys.readouterr().err.strip()
    assert err.count("\n") == 0 and err.startswith("zonotope: error: --noise"), err
    assert not md.exists()


def test_repeated_level_is_refused(capsys):
    assert main(["evaluate", *FAST, "--noise", "0.002", "--noise", "2e-3"]) == 2
    assert "repeat" in capsys.readouterr().err


def test_help_states_the_default_levels(capsys):
    from zonotope.evaluate import DEFAULT_NOISE

    with pytest.raises(SystemExit):
        main(["evaluate", "--help"])
    text = " ".join(capsys.readouterr().out.split())
    assert DEFAULT_NOISE[0] == 0.0 and "default: 0," in text
    for level in DEFAULT_NOISE[1:]:
        assert f"{level.shot[0]:g}:{level.read[0]:g}" in text
