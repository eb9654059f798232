"""splat.capture.workspace and the checks before work: OUT is marked, recorded, never holds paths outside it;
nothing splat did not write is replaced; a changed input or option recomputes the step and its
dependents; foreign or corrupt files get one-line errors naming them; bad options are refused before any
file is read."""

from __future__ import annotations

import json
import os

import numpy as np
import pytest

from splat.capture import CaptureError, read_capture
from splat.capture.workspace import MARKER, SETTINGS, Workspace

from .capture_helpers import write_capture


@pytest.fixture(scope="module")
def cap(tmp_path_factory):
    root = tmp_path_factory.mktemp("ws") / "cap"
    write_capture(root, views=3, holdout=1)
    return root


def _copy(cap, tmp_path):
    import shutil

    shutil.copytree(cap, tmp_path / "cap")
    return tmp_path / "cap"


def _poses(cap, out, **kw):
    from splat.capture import PipelineConfig, poses_step

    return poses_step(cap, out, config=PipelineConfig(**kw))


# ----------------------------------------------------------------------------------- the marker


def test_out_is_marked_and_a_foreign_folder_refused(cap, tmp_path):
    spec = read_capture(cap)
    ws = Workspace(spec, tmp_path / "new")
    assert json.loads((ws.root / MARKER).read_text())["written_by"] == "splat"
    Workspace(spec, tmp_path / "new")  # its own folder again: fine
    (tmp_path / "theirs").mkdir()
    (tmp_path / "theirs" / "holiday.jpg").write_bytes(b"x")
    with pytest.raises(CaptureError, match=f"splat did not write \\(no {MARKER}\\)"):
        Workspace(spec, tmp_path / "theirs")
    assert (tmp_path / "theirs" / "holiday.jpg").read_bytes() == b"x"
    (tmp_path / "f").write_text("x")
    with pytest.raises(CaptureError, match="is a file"):
        Workspace(spec, tmp_path / "f")
    (tmp_path / "fake").mkdir()
    (tmp_path / "fake" / MARKER).write_text('{"written_by": "someone"}')
    with pytest.raises(CaptureError, match="not a splat output marker"):
        Workspace(spec, tmp_path / "fake")


def test_every_output_path_stays_inside_out(cap, tmp_path):
    spec = read_capture(cap)
    ws = Workspace(spec, tmp_path / "out")
    with pytest.raises(CaptureError, match="outside"):
        ws.path("..", "elsewhere.tiff")
    with pytest.raises(CaptureError, match="outside"):
        ws.path("/tmp/abs.tiff")
    assert ws.view_dir("render", "nikon/IMG_0000.dng") == ws.root / "render" / "nikon" / "IMG_0000"
    with pytest.raises(CaptureError, match="not a view of a camera folder"):
        ws.view_dir("render", "../../etc/IMG_0000.dng")


def test_capture_inputs_inside_out_are_refused_and_left_alone(cap, tmp_path):
    """A user's ``[poses] colmap`` model inside OUT (say ``OUT/poses/model``) is never replaced."""
    c = _copy(cap, tmp_path)
    out = tmp_path / "out"
    _poses(c, out)
    model = out / "poses" / "model"
    before = {p.name: p.read_bytes() for p in model.iterdir()}
    toml = (c / "capture.toml").read_text().replace('colmap = "sparse"', f'colmap = "{model}"')
    (c / "capture.toml").write_text(toml)
    with pytest.raises(CaptureError, match=r"\[poses\].colmap lies inside the output folder"):
        _poses(c, out)
    assert {p.name: p.read_bytes() for p in model.iterdir()} == before


def test_a_users_report_is_never_replaced(cap, tmp_path):
    from splat.capture import report_step

    out = tmp_path / "out"
    _poses(cap, out)
    (out / "report.html").write_text("<p>mine</p>")
    with pytest.raises(CaptureError, match=r"report.html: not written by splat's report step"):
        report_step(cap, out)
    assert (out / "report.html").read_text() == "<p>mine</p>"
    (out / "report.html").unlink()
    assert report_step(cap, out).read_text().startswith("<!doctype html>")
    assert report_step(cap, out).is_file()  # its own report: rewritten


# ------------------------------------------------------------------------------ the settings record


def test_rerun_reuses_and_a_changed_capture_recomputes_the_step_and_its_dependents(cap, tmp_path):
    c = _copy(cap, tmp_path)
    out = tmp_path / "out"
    s1 = _poses(c, out)
    stamp = (out / "poses" / "summary.json").stat().st_mtime_ns
    assert _poses(c, out) == s1 and (out / "poses" / "summary.json").stat().st_mtime_ns == stamp
    ws = Workspace(read_capture(c), out)
    ws.begin("train", {"steps": 1})
    (out / "train").mkdir()
    (out / "train" / "model.npz").write_bytes(b"stale")
    # another exposure for one file: the poses (whose summary carries the exposures) and everything after
    toml = (
        (c / "capture.toml")
        .read_text()
        .replace(
            'ssf = "Nikon 5100 (NPL)"\n', 'ssf = "Nikon 5100 (NPL)"\nexposure = {"IMG_0000.dng" = 0.25}\n'
        )
    )
    (c / "capture.toml").write_text(toml)
    s2 = _poses(c, out)
    assert s2["exposures"] != s1["exposures"]
    assert not (out / "train").exists()
    record = json.loads((out / SETTINGS).read_text())
    assert set(record["steps"]) == {"poses"}
    # a replaced RAW file (same name, new time) counts as another input too
    f = c / "nikon" / "IMG_0001.dng"
    os.utime(f, ns=(f.stat().st_atime_ns, f.stat().st_mtime_ns + 10**9))
    _poses(c, out)
    assert (
        json.loads((out / SETTINGS).read_text())["steps"]["poses"]["key"] != record["steps"]["poses"]["key"]
    )


def test_other_curves_or_light_keep_the_poses_and_the_model_and_recompute_the_correction(cap, tmp_path):
    """The curves and the light enter the correct step only (the previews are balanced by the files' own
    as-shot neutral): another ``ssf`` or ``illuminant`` keeps the poses and the trained model, which
    take longest, and changes the correct step's key, so its results are recomputed."""
    from splat.capture.workspace import curves_fingerprint

    c = _copy(cap, tmp_path)
    out = tmp_path / "out"
    s1 = _poses(c, out)
    stamp = (out / "poses" / "summary.json").stat().st_mtime_ns
    Workspace(read_capture(c), out).begin("train", {"steps": 1})
    (out / "train").mkdir()
    (out / "train" / "model.npz").write_bytes(b"kept")
    before = curves_fingerprint(read_capture(c))
    toml = (c / "capture.toml").read_text()
    swapped = toml.replace('ssf = "Nikon 5100 (NPL)"', 'ssf = "Canon EOS 5D Mark II"', 1)
    for edit in (swapped, swapped.replace('illuminant = "D65"', 'illuminant = "A"', 1)):
        assert edit != toml
        (c / "capture.toml").write_text(edit)
        assert _poses(c, out) == s1 and (out / "poses" / "summary.json").stat().st_mtime_ns == stamp
        assert (out / "train" / "model.npz").read_bytes() == b"kept"
        after = curves_fingerprint(read_capture(c))
        assert after != before  # the correct step's key (splat.capture.correct_step) holds it
        before = after


def test_reading_out_checks_it_was_made_from_this_capture(cap, tmp_path):
    """``splat report`` and ``splat export`` read OUT without rerunning the steps: an edited capture (its
    files, camera tables or curves) is refused in one line instead of getting the old results."""
    from splat.capture.workspace import curves_fingerprint

    c = _copy(cap, tmp_path)
    out = tmp_path / "out"
    _poses(c, out)
    ws = Workspace(read_capture(c), out)
    ws.begin("correct", {"curves": curves_fingerprint(read_capture(c))})
    ws.check_made_from(read_capture(c))  # as it was: fine
    toml = (c / "capture.toml").read_text()
    (c / "capture.toml").write_text(
        toml.replace('ssf = "Nikon 5100 (NPL)"', 'ssf = "Canon EOS 5D Mark II"', 1)
    )
    with pytest.raises(CaptureError, match="its curves, lights or white differ"):
        Workspace(read_capture(c), out).check_made_from(read_capture(c))
    (c / "capture.toml").write_text(toml.replace('illuminant = "D65"', 'illuminant = "A"', 1))
    with pytest.raises(CaptureError, match="its curves, lights or white differ"):
        Workspace(read_capture(c), out).check_made_from(read_capture(c))
    (c / "capture.toml").write_text(toml)
    f = c / "nikon" / "IMG_0001.dng"  # a replaced RAW file
    os.utime(f, ns=(f.stat().st_atime_ns, f.stat().st_mtime_ns + 10**9))
    with pytest.raises(CaptureError, match=r"its RAW files or camera tables differ.*splat run"):
        Workspace(read_capture(c), out).check_made_from(read_capture(c))


def test_changed_options_recompute_only_what_depends_on_them(cap, tmp_path):
    ws = Workspace(read_capture(cap), tmp_path / "out")
    ws.begin("poses", {"seed": 0})
    ws.begin("train", {"steps": 100})
    ws.begin("render", {})
    ws.begin("correct", {"method": "Prior", "photographed": ["nikon/IMG_0000.dng"]})
    for d in ("train", "render", "correct"):
        (ws.root / d).mkdir()
        (ws.root / d / "x").write_text(d)
    ws.begin("correct", {"method": "Prior", "photographed": ["nikon/IMG_0000.dng"]})  # same: kept
    assert (ws.root / "correct" / "x").is_file()
    # another camera's photographs now rendered: the fusion noise levels and δ change, so correct reruns
    ws.begin("correct", {"method": "Prior", "photographed": ["canon/IMG_0000.dng", "nikon/IMG_0000.dng"]})
    assert not (ws.root / "correct").exists() and (ws.root / "render" / "x").is_file()
    (ws.root / "correct").mkdir()
    ws.begin("train", {"steps": 200})  # training options: train, render and correct go
    assert not any((ws.root / d).exists() for d in ("train", "render", "correct"))
    assert set(json.loads((ws.root / SETTINGS).read_text())["steps"]) == {"poses", "train"}
    again = Workspace(read_capture(cap), tmp_path / "out")  # the record survives the process
    assert again.key("train") == ws.key("train") and again.key("render") is None


# ------------------------------------------------------------------------- foreign and corrupt files


def test_corrupt_summaries_settings_and_checkpoints_are_one_line_errors(cap, tmp_path):
    from splat import TrainConfig, init_state
    from splat.capture import load_gaussians
    from splat.training import load_checkpoint

    out = tmp_path / "out"
    _poses(cap, out)
    (out / "poses" / "summary.json").write_text("{not json")
    with pytest.raises(CaptureError, match=r"poses/summary.json: not a readable splat summary"):
        _poses(cap, out)
    (out / SETTINGS).write_text("[1, 2]")
    with pytest.raises(CaptureError, match=rf"{SETTINGS}: not a splat settings record"):
        Workspace(read_capture(cap), out)
    # a foreign checkpoint holding a pickled object: refused without numpy's advice to load it unsafely
    bad = tmp_path / "checkpoint.npz"
    np.savez(bad, step=np.array(3), key=np.array([{"a": 1}], dtype=object))
    from splat import SplatError

    like = init_state(TrainConfig(capacity=16), bounds=np.array([[-1.0, -1, -1], [1, 1, 1]]), n_channels=3)
    with pytest.raises(SplatError, match=r"checkpoint.npz: not a readable splat checkpoint") as e:
        load_checkpoint(bad, like)
    assert "allow_pickle" not in str(e.value) and "\n" not in str(e.value)
    (tmp_path / "text.npz").write_text("hello")
    with pytest.raises(SplatError, match=r"text.npz: not a readable splat checkpoint"):
        load_checkpoint(tmp_path / "text.npz", like)
    (tmp_path / "o2" / "train").mkdir(parents=True)
    np.savez(tmp_path / "o2" / "train" / "model.npz", other=np.zeros(3))
    with pytest.raises(CaptureError, match=r"model.npz: not a splat model"):
        load_gaussians(tmp_path / "o2")


# ----------------------------------------------------------------------------- checks before work


@pytest.mark.parametrize(
    "options, match",
    [
        ({"method": "Nope"}, "Nope"),
        ({"camera": "leica"}, "no \\[\\[camera\\]\\] has folder 'leica'"),
    ],
)
def test_bad_options_are_refused_before_any_work(cap, tmp_path, options, match):
    from zonotope import ZonotopeError

    with pytest.raises(ZonotopeError, match=match):
        _poses(cap, tmp_path / "out", **options)
    assert not (tmp_path / "out").exists()


def test_bad_observer_and_one_camera_captures_are_refused_at_once(cap, tmp_path, capsys):
    from splat.cli import main

    c = _copy(cap, tmp_path)
    toml = (c / "capture.toml").read_text()
    (c / "capture.toml").write_text('observer = "CIE 2031 Martian"\n' + toml)
    assert main(["run", str(c), "-o", str(tmp_path / "o1")]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "observer = 'CIE 2031 Martian' is not a built-in observer" in err[0]
    first = toml.split("[[camera]]")
    (c / "capture.toml").write_text(first[0] + "[[camera]]" + first[1])  # the first camera alone
    (c / "capture.toml").write_text((c / "capture.toml").read_text().split("[holdout]")[0])
    assert main(["run", str(c), "-o", str(tmp_path / "o2")]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "isp develop" in err[0] and "--correction metamer" in err[0]
    assert "isp profile" in err[0]
    assert not (tmp_path / "o1").exists() and not (tmp_path / "o2").exists()


def test_a_white_box_outside_the_image_is_refused_before_the_poses(cap, tmp_path):
    c = _copy(cap, tmp_path)
    toml = (c / "capture.toml").read_text()
    toml = toml.replace(
        "[holdout]",
        '[white]\nmethod = "patch"\nimage = "nikon/IMG_0000.dng"\nbox = [0, 0, 4, 400]\n[holdout]',
    )
    (c / "capture.toml").write_text(toml)
    with pytest.raises(CaptureError, match=r"box \[0, 0, 4, 400\] lies outside the 48×36 image"):
        _poses(c, tmp_path / "out")
    assert not (tmp_path / "out" / "poses").exists()


# --------------------------------------------------------------------------- which views are rendered


def test_every_photograph_is_rendered_by_default_and_views_selects(cap, tmp_path):
    from splat.capture import PipelineConfig, load_model_capture, views_to_render

    out = tmp_path / "out"
    _poses(cap, out)
    spec = read_capture(cap)
    views = load_model_capture(spec, out)[1].views
    every = views_to_render(spec, views, PipelineConfig())
    assert sorted(n for n, *_ in every) == sorted(v.name for v in views) and len(every) == 12
    kinds = [k for *_, k in every]
    assert kinds == ["holdout"] * 3 + ["view"] * 9  # all three cameras, held-out ones first
    some = views_to_render(spec, views, PipelineConfig(views=("canon/*", "nikon/IMG_0001.dng")))
    assert [n for n, *_ in some] == ["canon/IMG_0003.dng", "nikon/IMG_0001.dng"] + [
        f"canon/IMG_000{i}.dng" for i in range(3)
    ]
    novel = views_to_render(
        spec, views, PipelineConfig(views=("nikon/IMG_0000.dng",), novel=2, camera="sigma")
    )
    assert [k for *_, k in novel] == ["view"] + ["novel"] * 4  # 2 between each of sigma's 3 training views
    assert all(n.startswith("sigma/novel_") for n, _, _, k in novel if k == "novel")
    with pytest.raises(CaptureError, match=r"--views 'leica/\*' names no photograph"):
        _poses(cap, out, views=("leica/*",))


def _rss_mib() -> float:
    with open("/proc/self/status") as fh:
        return next(int(line.split()[1]) / 1024 for line in fh if line.startswith("VmRSS:"))


@pytest.mark.skipif(not os.path.exists("/proc/self/status"), reason="reads the resident size from /proc")
def test_release_free_memory_returns_freed_heap_pages():
    """256 MiB of 64 kB arrays (below glibc's mmap threshold, so on the heap) freed all but the last,
    which pins the heap's top: the pages stay resident until the free memory is released."""
    import ctypes.util

    from splat.capture.workspace import release_free_memory

    if ctypes.util.find_library("c") is None or not hasattr(
        ctypes.CDLL(ctypes.util.find_library("c")), "malloc_trim"
    ):
        pytest.skip("no glibc malloc_trim here (release_free_memory is a no-op)")
    blocks = [np.ones(8000) for _ in range(4096)]
    last = blocks[-1]
    del blocks
    held = _rss_mib()
    release_free_memory()
    assert held - _rss_mib() > 128, "freed heap pages stayed resident"
    assert last.sum() == 8000
