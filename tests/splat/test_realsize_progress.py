"""Steps on files larger than the working size: the train step says that it is reading each RAW file
(minutes at 12 MP) and its recorded duration covers that reading; the correct step makes every
photograph's full-size output by the strips."""

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
            self.image[:12, :12] = 0.6  # a grey card in every view, for the white

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


def test_the_correct_step_above_binning_one_writes_the_strips(tmp_path):
    """A run whose working size is half the files' (``train_size``): every photograph's full-size
    output is made by the strips, two at once on threads, with the other cameras' photographs and its
    own camera's other photographs reprojected at full resolution (the correct step's whole path above
    binning 1), at its RAW file's size."""
    import json

    import tifffile

    from splat.capture import (
        PipelineConfig,
        correct_step,
        fit_step,
        open_raw,
        poses_step,
        read_capture,
        render_step,
    )

    cap = _capture(tmp_path / "cap")
    out = tmp_path / "out"
    spec = read_capture(cap)
    config = PipelineConfig(steps=2, capacity=256, train_size=24, workers=2)
    for step in (poses_step, fit_step, render_step, correct_step):
        step(cap, out, config=config)
    doc = json.loads((out / "correct" / "summary.json").read_text())["full_resolution"]
    names = [f"{c.folder}/{p.name}" for k, c in enumerate(spec.cameras) for p in spec.raw_files(k)]
    assert doc["views"] == len(names) == 9 and set(doc["per_view"]) == set(names)
    for name in names:
        info = doc["per_view"][name]
        H, W = open_raw(cap / name, spec.cameras[spec.camera_index(name.split("/")[0])]).shape
        assert info["binning"] > 1 and "from" not in info and info["workers"] == 2
        read = info["reprojected_at_full_resolution"]  # the cameras' photographs read at full size
        k = spec.camera_index(name.split("/")[0])
        assert len(read) == 3 and name.split("/")[1] not in read[spec.label(k)]  # its camera's others
        full = tifffile.imread(out / "correct" / spec.out_stem(name) / "full_XYZ.tiff")
        assert full.shape == (H, W, 3) and np.isfinite(full).all()
