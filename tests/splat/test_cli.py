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


def test_render_sources_and_workers_reach_the_config(monkeypatch, tmp_path, capsys):
    """``--render-sources K|all`` and ``--workers N`` set PipelineConfig (defaults from splat._tol);
    a bad value is one line naming the option, before any step runs."""
    import splat.capture
    from splat._tol import RENDER_SOURCES
    from splat.cli import main

    seen = []

    def fake_run(capture, out, *, config, steps, progress):
        seen.append((config.render_sources, config.workers))
        return {}

    monkeypatch.setattr(splat.capture, "run", fake_run)
    o = str(tmp_path / "out")
    assert main(["render", str(tmp_path), "-o", o]) == 0
    assert main(["render", str(tmp_path), "-o", o, "--render-sources", "3", "--workers", "2"]) == 0
    assert main(["render", str(tmp_path), "-o", o, "--render-sources", "all"]) == 0
    assert seen == [(RENDER_SOURCES, None), (3, 2), (None, None)]
    capsys.readouterr()
    for bad in (["--render-sources", "many"], ["--render-sources", "0"], ["--workers", "0"]):
        assert main(["render", str(tmp_path), "-o", o, *bad]) == 2
        err = capsys.readouterr().err
        assert err.startswith("splat: error: ") and err.count("\n") == 1 and bad[0].lstrip("-")[:6] in err, (
            err
        )
    assert len(seen) == 3


def test_tile_capacity_reaches_the_training(monkeypatch, tmp_path, capsys):
    """``--tile-capacity N`` sets the training's RenderConfig.tile_capacity (default RenderConfig's); a
    value below 1 is one line naming the option, before any step runs."""
    import splat.capture
    from splat import RenderConfig
    from splat.cli import main

    seen = []

    def fake_run(capture, out, *, config, steps, progress):
        seen.append(config.train.render.tile_capacity)
        return {}

    monkeypatch.setattr(splat.capture, "run", fake_run)
    o = str(tmp_path / "out")
    assert main(["train", str(tmp_path), "-o", o]) == 0
    assert main(["train", str(tmp_path), "-o", o, "--tile-capacity", "4096"]) == 0
    assert seen == [RenderConfig().tile_capacity, 4096]
    capsys.readouterr()
    assert main(["train", str(tmp_path), "-o", o, "--tile-capacity", "0"]) == 2
    err = capsys.readouterr().err
    assert err.startswith("splat: error: --tile-capacity 0") and err.count("\n") == 1
    assert len(seen) == 2
