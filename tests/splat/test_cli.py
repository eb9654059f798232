"""splat.cli: progress lines on a non-terminal stderr carry an estimate of the time left."""

from __future__ import annotations

import time


def test_progress_lines_estimate_the_time_left(monkeypatch, capsys, tmp_path):
    import splat.capture
    from splat.cli import main

    clock = {"t": 1000.0}
    monkeypatch.setattr(time, "monotonic", lambda: clock["t"])

    def fake_run(capture, out, *, config, steps, progress):
        for done in range(5):
            progress("correct", done, 4)
            clock["t"] += 12.0  # 12 s per view: a line each time
        return {}

    monkeypatch.setattr(splat.capture, "run", fake_run)
    assert main(["correct", str(tmp_path), "-o", str(tmp_path / "out")]) == 0
    lines = [x for x in capsys.readouterr().err.splitlines() if "correct:" in x]
    assert lines[0].endswith("correct: 0/4")
    assert lines[1].endswith("correct: 1/4, about 36 s left")  # 12 s per view, 3 views to go
    assert lines[3].endswith("correct: 3/4, about 12 s left")
    assert lines[4].endswith("correct: 4/4")


def test_no_full_reprojection_reaches_the_config(monkeypatch, tmp_path):
    """``--no-full-reprojection`` sets PipelineConfig.full_reprojection (default True)."""
    import splat.capture
    from splat.cli import main

    seen = []

    def fake_run(capture, out, *, config, steps, progress):
        seen.append(config.full_reprojection)
        return {}

    monkeypatch.setattr(splat.capture, "run", fake_run)
    assert main(["correct", str(tmp_path), "-o", str(tmp_path / "out")]) == 0
    assert main(["correct", str(tmp_path), "-o", str(tmp_path / "o2"), "--no-full-reprojection"]) == 0
    assert seen == [True, False]
