"""End to end from files: simulated RAW capture (DNG) → `splat run` → outputs, scored against truth/.

The capture is the CI size of :mod:`splat.sim.capture` (3 cameras × (6 + 2 held-out) views, ~128 × 96); the
training is short (the scores are checked against loose bounds that a broken stage would miss by far,
not against the accuracy goals, which the benchmark measures).
"""

from __future__ import annotations

import hashlib
import json
import shutil

import numpy as np
import pytest


def _digest(folder):
    h = hashlib.sha256()
    for p in sorted(folder.rglob("*")):
        if p.is_file():
            h.update(p.relative_to(folder).as_posix().encode())
            h.update(p.read_bytes())
            h.update(str(p.stat().st_mtime_ns).encode())
    return h.hexdigest()


#: Every test here uses the module's simulated capture + `splat run` (50 s on a quiet 2-core machine).
pytestmark = pytest.mark.slow


@pytest.fixture(scope="module")
def ci_run(tmp_path_factory):
    from splat.capture import read_capture
    from splat.cli import main
    from splat.sim.capture import SimCaptureConfig, write_synthetic_capture

    root = tmp_path_factory.mktemp("e2e")
    cap = write_synthetic_capture(root / "capture", SimCaptureConfig.ci())
    before = _digest(cap)
    out = root / "out"
    args = [
        str(cap),
        "-o",
        str(out),
        "--steps",
        "130",
        "--capacity",
        "2048",
        "--quantum",
        "0.02",
        "--threads",
        "2",
        "--views",  # the held-out photographs only: every photograph is the default, and 4× the time
        *read_capture(cap).holdout,
    ]
    status = main(["run", *args])
    return cap, out, before, status, args


def test_run_writes_every_output_and_never_touches_the_capture(ci_run):
    import tifffile

    from splat.capture import read_capture

    cap, out, before, status, _ = ci_run
    assert status == 0
    assert _digest(cap) == before  # the capture (RAW files, capture.toml, truth/) is untouched
    assert read_capture(cap).chart is not None  # the simulator marks its ColorChecker (poses checked it)
    poses = json.loads((out / "poses" / "summary.json").read_text())
    assert poses["source"] == "pycolmap" and poses["registered"] >= 0.5 * poses["views"]
    train = json.loads((out / "train" / "summary.json").read_text())
    assert train["backend"] == "cpu" and train["dropped_per_step"] == 0.0  # the numba back-end drops none
    assert all(c["registered"] >= 4 for c in poses["cameras"].values())
    index = json.loads((out / "render" / "index.json").read_text())
    held = [k for k, v in index.items() if v["kind"] == "holdout"]
    assert len(held) == 6
    name = "nikon/DSC_0002.dng"
    r = tifffile.imread(out / "render" / "nikon" / "DSC_0002" / "render.tiff")
    assert r.dtype == np.float32 and r.shape == (96, 128, 9) and np.all(np.isfinite(r))
    for cam in ("nikon", "sigma", "canon"):
        assert tifffile.imread(out / "render" / "nikon" / "DSC_0002" / f"camera_{cam}.tiff").shape == (
            96,
            128,
            3,
        )
    d = out / "correct" / "nikon" / "DSC_0002"
    srgb = tifffile.imread(d / "Prior_sRGB.tiff")
    assert srgb.dtype == np.uint16 and srgb.shape == (96, 128, 3)
    assert tifffile.imread(d / "Prior_XYZ.tiff").dtype == np.float32
    for f in ("raw_dng_sRGB.png", "dng_nikon_sRGB.png", "dng_sigma_sRGB.png", "dng_canon_sRGB.png"):
        assert (d / f).is_file()
    # a photographed view: also corrected from its own RAW and the other photographs reprojected into it
    assert tifffile.imread(d / "Prior_fused_sRGB.tiff").shape == (96, 128, 3)
    rep = tifffile.imread(out / "render" / "nikon" / "DSC_0002" / "reprojected.tiff")
    count = tifffile.imread(out / "render" / "nikon" / "DSC_0002" / "reprojected_count.tiff")
    assert rep.shape == (96, 128, 9) and count.shape == (96, 128, 3)
    # the other cameras' photographs see part of the view: 24 % after these 130 steps (the depth of an
    # undertrained splat often disagrees between views), 65–92 % of the flat pixels after 1000 steps
    assert (count[..., 1:] > 0).mean() > 0.05
    fusion = json.loads((out / "correct" / "fusion.json").read_text())
    assert set(fusion["views"]) == set(held) and fusion["render_sigma"] > 0
    assert all(s > 0 for s in fusion["reprojected_sigma"])
    html = (out / "report.html").read_text()
    assert "correct/nikon/DSC_0002/Prior_sRGB.png" in html and name in html
    corr = json.loads((out / "correct" / "summary.json").read_text())
    assert corr["fusion"]["views"] == len(held) and corr["fusion"]["novel"] == 0
    # reprojections no surface gives with the photograph, left out: a small share, each other camera
    rej = corr["fusion"]["rejected"]
    assert set(rej) == set(held) and all(
        len(v) == 2 and all(0 <= s < 0.05 for s in v.values()) for v in rej.values()
    )
    tol = corr["noise"]  # δ: 95th percentile of the responses' distances to the object-colour solid
    assert corr["delta"] == tol["delta"] > 0 and tol["beyond_delta"] <= 0.06
    # every photograph also at its RAW file's full size (here the working resolution is the full one)
    full = tifffile.imread(d / "full_XYZ.tiff")
    assert full.dtype == np.float32 and full.shape == (96, 128, 3) and np.all(np.isfinite(full))
    assert corr["full_resolution"]["views"] == len(held)
    assert set(corr["own_noise"]) == set(held)
    # the fused correction's uncertainty per pixel: narrower where both other cameras' photographs see
    # the pixel than where neither does (there their channels are the model's render)
    u = tifffile.imread(d / "Prior_fused_uncertainty.tiff")
    assert u.dtype == np.float32 and u.shape == (96, 128) and np.all(np.isfinite(u)) and (u > 0).all()
    both, neither = (count[..., 1:] > 0).all(-1), ~(count[..., 1:] > 0).any(-1)
    assert both.sum() > 50 and neither.sum() > 50 and np.median(u[both]) < np.median(u[neither])
    assert (d / "Prior_fused_uncertainty.png").is_file() and "Prior_fused_uncertainty.png" in html
    assert set(corr["uncertainty"]["per_view"]) == set(held)
    for step in ("poses", "train", "render", "correct"):  # time and peak memory of every step
        doc = json.loads((out / step / "summary.json").read_text())
        assert doc["duration_s"] > 0 and doc["peak_rss_mib"] > 0
    assert not list(out.rglob("*.tmp*"))  # atomic writes leave no temporary files


def test_rerun_resumes_without_redoing(ci_run):
    from splat.cli import main

    _cap, out, _, _, args = ci_run
    stamp = {p: p.stat().st_mtime_ns for p in out.rglob("*.tiff")}
    assert main(["run", *args]) == 0
    assert {p: p.stat().st_mtime_ns for p in out.rglob("*.tiff")} == stamp


def test_novel_views_corrected_from_the_reprojected_photographs(ci_run, tmp_path):
    """`splat render --novel 1` + `splat correct` on a copy of the run: the new views (no RAW file) get
    every camera's photographs reprojected into them and a ``Prior_fused_*`` correction from those;
    what was there is not redone."""
    import tifffile

    from splat.cli import main

    _cap, out, _, _, args = ci_run
    out2 = tmp_path / "out"
    shutil.copytree(out, out2)
    stamp = {p.relative_to(out2): p.stat().st_mtime_ns for p in out2.rglob("*.tiff")}
    rest = [a if a != str(out) else str(out2) for a in args]
    assert main(["render", *rest, "--novel", "1"]) == 0
    assert main(["correct", *rest, "--novel", "1"]) == 0
    assert {p: out2.joinpath(p).stat().st_mtime_ns for p in stamp} == stamp
    index = json.loads((out2 / "render" / "index.json").read_text())
    novel = [v for v in index.values() if v["kind"] == "novel"]
    assert len(novel) == 5  # one between each pair of the first camera's 6 training views
    for v in novel:
        nc = tifffile.imread(out2 / "render" / v["dir"] / "reprojected_count.tiff")
        assert nc.shape == (96, 128, 3) and (nc > 0).any(axis=(0, 1)).all()  # every camera enters
        f = tifffile.imread(out2 / "correct" / v["dir"] / "Prior_fused_sRGB.tiff")
        assert f.dtype == np.uint16 and f.shape == (96, 128, 3)
    corr = json.loads((out2 / "correct" / "summary.json").read_text())
    assert corr["fusion"]["novel"] == 5 and corr["fusion"]["views"] == 6


def test_scores_against_truth(ci_run):
    from splat.scoring import score

    cap, out, *_ = ci_run
    s = score(cap, out, stride=8, subsets=[(0, 1, 2)], raw_methods=())
    assert len(s["held_out_views"]) == 6
    dE = s["delta_E00"]
    assert {
        "dng:nikon",
        "dng:sigma",
        "dng:canon",
        "Prior:nikon+sigma+canon",
        "Centroid:nikon+sigma+canon",
        "Prior-fused:nikon+sigma+canon",
        "Centroid-fused:nikon+sigma+canon",
        "Prior-photographed:nikon+sigma+canon",
        "Centroid-photographed:nikon+sigma+canon",
    } <= set(dE)
    # 130 training steps cannot reproduce this textured scene (ΔE00 ≈ 30 through the splat at this
    # size): the bound only catches unit or white-scale blunders, the benchmark measures accuracy
    for v in dE.values():
        assert np.isfinite(v["mean"]) and v["mean"] < 60
    # the DNG-matrix development of the RAW files needs no training; at this size its ΔE00 (≈ 15–18 mean)
    # is mostly the simulated shot/read noise of single pixels (a 3 × 3 box filter on both halves it)
    assert max(dE[f"dng:{c}"]["mean"] for c in ("nikon", "sigma", "canon")) < 25
    assert min(s["psnr_db"].values()) > 12
    # normalised to the median exposure: each held-out view's PSNR + 20 log10(its relative exposure), so
    # per camera the two means differ by 20 × the mean log10 exposure of that camera's held-out views
    from splat.capture import load_views, read_capture

    spec = read_capture(cap)
    exif = {v.name: v.exif for v in load_views(spec) if v.name in s["held_out_views"]}
    assert len(exif) == 6
    for k, p in s["psnr_exposure_normalised_db"].items():
        folder = k.split(":")[0]
        shift = 20 * np.mean([np.log10(e) for n, e in exif.items() if n.startswith(folder + "/")])
        assert p - s["psnr_db"][k] == pytest.approx(shift, abs=1e-9)
    assert len({round(p - s["psnr_db"][k], 6) for k, p in s["psnr_exposure_normalised_db"].items()}) > 1
    pose = s["pose"]
    assert pose["registered"] >= 12 and pose["centre_error_mean"] < 0.05 * pose["scene_extent"]


def test_cli_errors_are_one_line(tmp_path, ci_run, capsys):
    from splat.cli import main

    cap, *_ = ci_run
    bad = tmp_path / "bad"
    shutil.copytree(cap, bad, ignore=shutil.ignore_patterns("truth"))
    toml = (bad / "capture.toml").read_text().replace('ssf = "Nikon 5100 (NPL)"', 'ssf = "nikon.json"')
    (bad / "capture.toml").write_text(toml)
    assert main(["poses", str(bad), "-o", str(tmp_path / "o1")]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "SSF file" in err[0]
    assert main(["poses", str(cap), "-o", str(cap / "out")]) == 2  # output inside the capture
    assert "outside" in capsys.readouterr().err
    assert main(["train", str(cap), "-o", str(tmp_path / "o2")]) == 2  # no poses yet
    assert "run the poses step first" in capsys.readouterr().err


def test_training_inputs_exclude_held_out_views_and_pad_with_zero_weight(ci_run, tmp_path):
    """What the train step fits: only registered, non-held-out views; each view's pixels in its own
    camera's three channels only; smaller views padded right/bottom with weight 0 and unchanged
    intrinsics; and the same arrays when truth/ is absent (the pipeline never reads it)."""
    from splat.capture import load_model_capture, read_capture, training_inputs

    cap, out, *_ = ci_run
    spec = read_capture(cap)
    inp = training_inputs(spec, out)
    names = [v.name for v in inp.views]
    assert not set(names) & set(spec.holdout) and len(names) == len(set(names)) >= 12
    V, H, W, N = inp.images.shape
    assert (V, H, W, N) == (len(names), 96, 136, 9) and inp.weights.shape == inp.images.shape
    _, model = load_model_capture(spec, out)
    orig = {v.name: v.camera for v in model.views}
    for i, (v, p) in enumerate(zip(inp.views, inp.capture.views)):
        k = v.camera_id - 1
        others = [c for c in range(9) if c // 3 != k]
        assert not inp.weights[i][..., others].any()  # other cameras' channels are not measured here
        h, w = orig[v.name].height, orig[v.name].width
        assert inp.weights[i, :h, :w, 3 * k : 3 * k + 3].any()
        assert not inp.weights[i, h:].any() and not inp.weights[i, :, w:].any()  # padding: weight 0
        np.testing.assert_array_equal(np.asarray(p.camera.focal), np.asarray(orig[v.name].focal))
        np.testing.assert_array_equal(np.asarray(p.camera.principal), np.asarray(orig[v.name].principal))
        assert (p.camera.width, p.camera.height) == (W, H)
    blind = tmp_path / "capture"
    shutil.copytree(cap, blind, ignore=shutil.ignore_patterns("truth"))
    again = training_inputs(read_capture(blind), out)
    np.testing.assert_array_equal(again.images, inp.images)
    np.testing.assert_array_equal(again.weights, inp.weights)
    np.testing.assert_array_equal(again.points, inp.points)


def test_depth_error_against_the_simulated_geometry(ci_run):
    """benchmarks/depth_error.py on the run: the model's depth (``splat.render_depth``) lies near the
    simulator's ray-cast depth in the middle of every view, and a scene rebuilt at the wrong size is
    refused rather than compared."""
    from benchmarks.depth_error import depth_error

    cap, out, *_ = ci_run
    res = depth_error(cap, out, size="ci", model=None, views=None)
    assert len(res) >= 12
    middles = []
    for fifths in res.values():
        assert len(fifths) == 5
        for median, off, front in fifths[1:4]:
            # 130 steps leave a rough model: one fifth may be ~10 % off, the run as a whole is not
            assert 0 <= median < 0.3 and 0 <= off <= 1 and 0 <= front <= 1
            middles.append(median)
    assert np.median(middles) < 0.05
    with pytest.raises(SystemExit, match="does not match"):
        depth_error(cap, out, size="benchmark", model=None, views=None)


def test_ladder_puts_the_true_responses_in_place_of_the_fused(ci_run):
    """benchmarks/bench_capture_accuracy.py's ladder on the run: the true responses are on the fused
    ones' scale (each own channel's median level within 5 %), corrected they stay far below the pipeline's
    error of a 130-step model on the scene's uniform surfaces, every camera's held-out views have every
    row, and a scene rebuilt from another configuration is refused."""
    from benchmarks.bench_capture_accuracy import ladder, ladder_table
    from splat.sim.capture import SimCaptureConfig

    cap, out, *_ = ci_run
    res = ladder(cap, out, SimCaptureConfig.ci(), stride=4)
    rows = res["rows"]
    labels = {"true, δ", "true, pipeline σ", "own fused", "others fused", "pipeline"}
    for g in (*res["folders"], "all views"):
        assert labels <= {lb for (g_, who, lb) in rows if g_ == g and who == "three"}
        assert {"true, δ", "pipeline"} <= {lb for (g_, who, lb) in rows if g_ == g and who == "one"}
    uniform = {lb: np.mean(rows[("all views", "three", lb)][1]) for lb in labels}
    assert len(rows[("all views", "three", "pipeline")][1]) >= 10
    assert all(np.isfinite(v) for v in uniform.values())
    assert uniform["true, pipeline σ"] < 1.5 and uniform["true, pipeline σ"] < 0.5 * uniform["pipeline"]
    for folder, lv in res["levels"].items():  # the view's own channels (the others: a rough model's)
        k = res["folders"].index(folder)
        assert np.all(np.abs(np.median(lv[:, 3 * k : 3 * k + 3], 0) - 1) < 0.05)
    assert "| all views | three | pipeline |" in ladder_table(res)
    with pytest.raises(SystemExit, match="does not match"):
        ladder(cap, out, SimCaptureConfig.ci(seed=1), stride=4)


def test_render_step_on_threads_writes_the_same_files(ci_run, tmp_path):
    """`splat render --workers 2` renders views at once and writes byte-identical files to one at a
    time, in the same index order."""
    from splat.cli import main

    _cap, out, _, _, args = ci_run
    files = {}
    for workers in ("1", "2"):
        o = tmp_path / f"out{workers}"
        shutil.copytree(out, o)
        shutil.rmtree(o / "render")  # only this step's results go: the model stays
        rest = [a if a != str(out) else str(o) for a in args]
        assert main(["render", *rest, "--workers", workers]) == 0
        files[workers] = {p.relative_to(o): p.read_bytes() for p in sorted((o / "render").rglob("*.tiff"))}
        files[workers]["index"] = (o / "render" / "index.json").read_bytes()
    assert files["1"].keys() == files["2"].keys() and len(files["1"]) > 6
    assert files["1"] == files["2"]


def test_shared_view_cache_computes_each_entry_once():
    """The render step's cache of depths and photographs, shared by threads: each key is made once
    whoever asks; a failure reaches every caller waiting for it and is not kept."""
    import threading
    import time
    from concurrent.futures import ThreadPoolExecutor

    from splat.capture.render import _once

    cache, made = {}, []
    lock = threading.Lock()

    def make():
        with lock:
            made.append(1)
        time.sleep(0.05)  # long enough for the other callers to arrive while it is being made
        return np.arange(3)

    with ThreadPoolExecutor(8) as pool:
        got = list(pool.map(lambda _: _once(cache, "k", make), range(8)))
    assert len(made) == 1 and all(g is got[0] for g in got)

    def boom():
        time.sleep(0.05)
        raise ValueError("bad view")

    with ThreadPoolExecutor(4) as pool:
        futs = [pool.submit(_once, cache, "bad", boom) for _ in range(4)]
    assert all(isinstance(f.exception(), ValueError) for f in futs)
    assert "bad" not in cache
    assert _once(cache, "bad", lambda: 7) == 7


def test_photographed_views_skip_the_render_corrected_alone(ci_run, tmp_path):
    """The correct step corrects the render alone only for held-out and novel views: a photographed
    (training) view gets its fused and full-resolution corrections and no ``Prior_XYZ.tiff``."""
    from splat.cli import main

    _cap, out, _, _, args = ci_run
    o = tmp_path / "out"
    shutil.copytree(out, o)
    index_path = o / "render" / "index.json"
    index = json.loads(index_path.read_text())
    name = next(iter(index))
    index[name]["kind"] = "view"  # as if it had been a training photograph
    index_path.write_text(json.dumps(index))
    d = o / "correct" / index[name]["dir"]
    shutil.rmtree(d)
    rest = [a if a != str(out) else str(o) for a in args]
    assert main(["correct", *rest]) == 0
    assert (d / "Prior_fused_XYZ.tiff").is_file() and (d / "full_XYZ.tiff").is_file()
    assert not (d / "Prior_XYZ.tiff").exists() and not (d / "Prior_sRGB.png").exists()
    other = o / "correct" / index[list(index)[1]]["dir"]
    assert (other / "Prior_XYZ.tiff").is_file()  # the held-out views keep it


def test_a_curves_white_off_per_channel_is_measured_against_the_other_cameras(ci_run, tmp_path):
    """The Nikon named by its curves with red × 0.8 and blue × 1.1 (as far apart as two published
    measurements of one model put a camera's channels) and no ``ssf_exact``: its white from those
    curves is 20 % / 10 % off, and its level per channel, measured where the other cameras' photographs
    are reprojected into its views (textured pixels too: the CI capture has few plain ones), brings
    the white it is corrected with back within 3 % of its true white per channel."""
    import zonotope
    from splat.capture import read_capture
    from splat.capture.raw import camera_white
    from splat.scoring import correction_inputs

    cap, out, *_ = ci_run
    truth = read_capture(cap)
    k = next(i for i, c in enumerate(truth.cameras) if c.folder == "nikon")
    nikon = zonotope.camera(truth.cameras[k].ssf)
    gain = np.array([0.8, 1.0, 1.1])
    rows = np.column_stack([nikon.wavelengths, np.asarray(nikon.values) * gain])
    copy = tmp_path / "capture"
    copy.mkdir()
    np.savetxt(copy / "nikon_off.csv", rows, delimiter=",", header="wavelength,red,green,blue", comments="")
    for c in truth.cameras:
        (copy / c.folder).symlink_to(cap / c.folder)
    text = (cap / "capture.toml").read_text()
    table = f'folder = "nikon"\nssf = "{truth.cameras[k].ssf}"\nssf_exact = true\n'
    assert table in text
    (copy / "capture.toml").write_text(text.replace(table, 'folder = "nikon"\nssf = "nikon_off.csv"\n'))
    spec = read_capture(copy)
    assert not spec.cameras[k].ssf_exact and all(c.ssf_exact for i, c in enumerate(spec.cameras) if i != k)
    out2 = tmp_path / "out"
    (out2 / "correct").mkdir(parents=True)
    (out2 / "render").symlink_to(out / "render")
    _, _, white, _ = correction_inputs(spec, out2)
    want = camera_white(truth, k)
    before = camera_white(spec, k)
    assert np.max(np.abs(before / before[1] / (want / want[1]) - 1)) > 0.09  # the curves' white is off
    got = np.asarray(white["scale"][k])
    np.testing.assert_allclose(got / got[1], want / want[1], rtol=0.03)
    assert k in white["levels_measured"]
