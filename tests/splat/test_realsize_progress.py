"""The train step on real-size files: it says that it is reading each RAW file (minutes at 12 MP), and
its recorded duration covers that reading."""

from __future__ import annotations

import numpy as np


def _capture(root):
    import pytest

    import splat
    from tests.splat.capture_helpers import write_capture

    class Image:  # smooth fields instead of renders: no renderer to compile, the test reads files
        def __init__(self, cam):
            yy, xx = np.mgrid[: cam.height, : cam.width]
            ph = np.arange(9)[None, None] * 0.7
            self.image = 0.1 + 0.08 * np.sin(xx[..., None] / 4.0 + ph) * np.cos(yy[..., None] / 5.0 + ph)

    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(splat, "render_reference", lambda g, cam: Image(cam))
        write_capture(root, views=2, holdout=1)
    return root


def test_training_inputs_report_every_file_read(tmp_path, monkeypatch):
    """One ("read", done, total) per RAW file, in order; and fit_step's duration_s is at least the time
    spent reading (a clock that jumps at every file read shows it)."""
    import time

    import splat.capture.raw as raw
    from splat.capture import PipelineConfig, poses_step, read_capture, training_inputs

    cap = _capture(tmp_path / "cap")
    out = tmp_path / "out"
    poses_step(cap, out, config=PipelineConfig())
    spec = read_capture(cap)
    n = sum(len(spec.raw_files(k)) for k in range(len(spec.cameras)))
    calls = []
    training_inputs(spec, out, PipelineConfig(train_size=24), lambda *a: calls.append(a))
    assert [c for c in calls if c[0] == "read"] == [("read", i + 1, n) for i in range(n)]

    from splat.capture import fit_step

    # a clock that jumps an hour whenever a RAW file is read: the step's duration must contain the jumps
    real_clock, real_load = time.perf_counter, raw.load_view
    jump = [0.0]

    def load_view(*a, **k):
        jump[0] += 3600.0
        return real_load(*a, **k)

    monkeypatch.setattr(raw, "load_view", load_view)
    monkeypatch.setattr(time, "perf_counter", lambda: real_clock() + jump[0])
    s = fit_step(cap, out, config=PipelineConfig(steps=2, capacity=64, train_size=24))
    assert s["duration_s"] >= 3600.0 * n
