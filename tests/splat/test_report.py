"""splat.report: the page built from an output folder written in the step summaries' formats — a section per
view with the corrected image beside the camera's own development, the marked card's ΔE00 from the data
the pipeline had, the summaries collapsed below; and a headless Chromium screenshot of it."""

from __future__ import annotations

import json
import re
import shutil
import subprocess

import numpy as np
import pytest

from .capture_helpers import write_capture

CARD = "nikon/IMG_0001.dng"
BOX = (8, 6, 24, 18)
VIEWS = {  # name → kind; the card photograph held out, one photograph trained on, one novel view
    CARD: "holdout",
    "nikon/IMG_0000.dng": "view",
    "nikon/novel_000": "novel",
}
WHITE_XYZ = np.array([0.95047, 1.0, 1.08883])
TINT = np.array([0.98, 1.0, 1.0])  # the corrected card's XYZ is the known white times this
RADIUS = np.linspace(0.5, 12.0, 36 * 48).reshape(36, 48)  # a per-pixel uncertainty map, ΔE00


@pytest.fixture(scope="module")
def cap(tmp_path_factory):
    root = tmp_path_factory.mktemp("report") / "cap"
    card = f'\n[white]\nmethod = "patch"\nimage = "{CARD}"\nbox = {list(BOX)}\nreflectance = 0.9\n'
    write_capture(root, views=1, holdout=1, extra_toml=card)
    return root


def _pattern(H, W, phase):
    """A colourful test image (H, W, 3) in [0, 1]; ``phase`` makes the two of a pair differ."""
    y, x = np.mgrid[0:H, 0:W] / max(H, W)
    return np.stack([0.5 + 0.5 * np.sin(6 * x + phase), 0.5 + 0.5 * np.cos(5 * y - phase), 0.3 + 0 * x], -1)


def _png(path, rgb):
    from PIL import Image

    path.parent.mkdir(parents=True, exist_ok=True)
    Image.fromarray((np.clip(rgb, 0, 1) * 255).astype(np.uint8)).save(path)


def _tiff(path, a):
    import tifffile

    path.parent.mkdir(parents=True, exist_ok=True)
    tifffile.imwrite(path, np.asarray(a, np.float32), photometric="minisblack")


def _json(path, doc):
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(json.dumps(doc))


def make_out(cap, out, *, score=False):
    """An output folder as poses → train → render → correct leave it (their file names and summary
    keys), with synthetic images, for the nikon views of :data:`VIEWS` (48 × 36 px)."""
    from splat.capture import read_capture
    from splat.capture.workspace import Workspace

    spec = read_capture(cap)
    Workspace(spec, out)
    H, W = 36, 48
    folders = [c.folder for c in spec.cameras]
    _json(
        out / "poses" / "summary.json",
        {
            "source": "colmap",
            "cameras": {f: {"views": 2, "registered": 2} for f in folders},
            "registered": 6,
            "views": 6,
            "seconds": 4.25,
            "duration_s": 4.25,
            "peak_rss_mib": 512.4,
            "saturated": {"nikon/IMG_0000.dng": 17},
            "dead": {},
            "exposures": {},
        },
    )
    _json(
        out / "train" / "summary.json",
        {
            "steps": 200,
            "views": 3,
            "size": [56, 42],
            "channels": 9,
            "gaussians": 1234,
            "seconds": 754.0,
            "residual_sigma_raw": [0.01] * 9,
        },
    )
    index = {n: {"camera": "nikon", "kind": k, "dir": spec.out_stem(n)} for n, k in VIEWS.items()}
    _json(out / "render" / "index.json", index)
    _json(out / "render" / "summary.json", {"duration_s": 3.0})
    for i, info in enumerate(index.values()):
        r, c = out / "render" / info["dir"], out / "correct" / info["dir"]
        _png(r / "pca.png", _pattern(H, W, 2.0 + i))
        count = np.zeros((H, W, 3), np.float32)
        count[:, : W // 4, 1] = 1  # another camera sees a quarter of the view
        _tiff(r / "reprojected_count.tiff", count)
        _png(c / "Prior_sRGB.png", _pattern(H, W, 1.0 + i))
        _png(c / "dng_nikon_sRGB.png", _pattern(H, W, 3.0 + i))
        _png(c / "Prior_fused_sRGB.png", _pattern(H, W, 0.0 + i))
        xyz = np.broadcast_to(0.5 * WHITE_XYZ, (H, W, 3)).copy()
        xyz[BOX[1] : BOX[3], BOX[0] : BOX[2]] = 0.9 * WHITE_XYZ * TINT
        _tiff(c / "Prior_fused_XYZ.tiff", xyz)
        if info["kind"] != "novel":  # the uncertainty map of the photographs' fused corrections
            _tiff(c / "Prior_fused_uncertainty.tiff", RADIUS)
            _png(c / "Prior_fused_uncertainty.png", np.repeat(RADIUS[..., None], 3, -1) / 10)
            _png(c / "raw_dng_sRGB.png", _pattern(H, W, 4.0 + i)[..., ::-1])
            cam = xyz.copy()
            cam[BOX[1] : BOX[3], BOX[0] : BOX[2]] = 0.9 * WHITE_XYZ
            _tiff(c / "raw_dng_XYZ.tiff", cam)
    _json(
        out / "correct" / "summary.json",
        {
            "method": "Prior",
            "delta": 0.011,
            "noise": {"delta": 0.011, "rule": "95th percentile of the distances of 200 sampled responses"},
            "training_residual": 0.004,
            "white": {
                "method": "patch",
                "from_curves": ["sigma"],
                "levels": [[1.0, 1.0, 1.0], [1.01, 1.0, 0.99], [1.31, 0.99, 1.06]],
            },
            "white_XYZ": WHITE_XYZ.tolist(),
            "ssf": {  # one camera's curves estimated, as splat.capture.ssf_record writes it
                "nikon": {
                    "estimated": "DNG colour matrices",
                    "file": "IMG_0000.dng",
                    "sigma": [0.0074, 0.0029, 0.0025],
                    "calibration": "real DNG matrices",
                },
                "sigma": {"measured": "Sigma SDMerill (NPL)", "exact": False, "sigma": [0.01, 0.004, 0.004]},
                "canon": {"measured": "Canon EOS 5D Mark II", "exact": True, "sigma": [0.0, 0.0, 0.0]},
            },
            "views": list(index),
        },
    )
    _json(
        out / "correct" / "fusion.json",
        {
            "render_sigma": 0.02,
            "reprojected_sigma": [0.011, 0.012, 0.013],
            "views": {n: {"camera": 0, "own_sigma": [0.003, 0.002, 0.004]} for n in list(VIEWS)[:2]},
        },
    )
    if score:
        _json(out / "score.json", {"flat_dE00": 123.456})
    return spec


@pytest.fixture(scope="module")
def page(cap, tmp_path_factory):
    from splat.capture import report_step

    out = tmp_path_factory.mktemp("report_out") / "out"
    make_out(cap, out, score=True)
    path = report_step(cap, out)
    return out, path, path.read_text()


def _sections(html):
    return re.findall(r"<section class='photo'.*?</section>", html, flags=re.S)


def test_a_section_per_view_with_the_pair_of_images(page):
    out, path, html = page
    assert path == out / "report.html" and html.startswith("<!doctype html>")
    sections = _sections(html)
    assert len(sections) == len(VIEWS)
    for (name, kind), sec in zip(VIEWS.items(), sections):
        assert re.search(rf"<h2>{re.escape(name)} ", sec)
        pair = re.search(r"<div class='pair'>(.*?)</div><div class='facts'>", sec, flags=re.S).group(1)
        srcs = re.findall(r"<img[^>]* src='([^']+)'", pair)
        assert len(srcs) == 2 and srcs[0].endswith("Prior_fused_sRGB.png")  # the answer on the left
        right = "raw_dng_sRGB.png" if kind != "novel" else "dng_nikon_sRGB.png"
        assert srcs[1].endswith(right)
        assert all((out / s).is_file() for s in srcs)  # relative to OUT
        for what in ("Accuracy", "What was done", "Time", "Next"):
            assert f"<h3>{what}</h3>" in sec
        assert "Prior_fused_sRGB.tiff" in sec  # which file to use
        if kind == "novel":
            assert "No per-pixel uncertainty map was written for this view" in sec
        else:  # the map, and its median, 90th percentile and share within 2 ΔE00 in words
            umap = re.search(r"<img class='umap' src='([^']+)'", sec).group(1)
            assert umap.endswith("Prior_fused_uncertainty.png") and (out / umap).is_file()
            want = (np.median(RADIUS), np.percentile(RADIUS, 90), np.mean(RADIUS <= 2))
            assert f"Median {want[0]:.2g} ΔE00, 90th percentile {want[1]:.2g}; {want[2]:.0%}" in sec
        assert "poses took 4.2 s, peak 512 MiB" in sec and "train took 12 min 34 s" in sec
        assert "render took 3.0 s ·" in sec and "correct time not recorded" in sec
        assert "--steps 3000" in sec and "48×36 px" in sec and "see 25%" in sec
        assert "The map is of the working answer" not in sec  # no working resolution recorded
        said = re.search(r"Sensitivities not measured: [^;]*;", sec).group(0)  # estimated curves said
        assert "nikon (IMG_0000.dng, response σ 0.007 / 0.003 / 0.003)" in said and "sigma" not in said
        unit = re.search(r"Published sensitivities of [^;]*;[^.]*\.", sec).group(0)  # another unit's
        assert "of sigma:" in unit and "canon" not in unit and "(response σ 0.010 / 0.004 / 0.004)" in unit
        assert "<strong>The white of sigma rests on its sensitivities alone</strong>" in sec
        assert "other cameras' photographs: canon × 1.32 / 1.00 / 1.07 (R / G / B" in sec  # > 3 % only
        assert "sigma × " not in sec
    assert "17 pixels of this photograph are saturated" in sections[1]
    assert "own channels σ = (0.003, 0.002, 0.004)" in sections[0]
    assert "reprojected here σ = 0.011 (nikon), 0.012 (sigma)" in sections[2]  # novel: no own channels


def test_the_marked_card_is_measured_only_where_it_is(page):
    _out, _, html = page
    card, other, _novel = _sections(html)
    assert "<table>" in card and "<table>" not in other
    marks = re.findall(r"<span class='card'[^>]*style='([^']+)'", card)
    assert len(marks) == 2 and "<span class='card'" not in other  # outlined on both images of its pair
    assert marks[0].startswith(f"left:{100 * BOX[0] / 48:.3f}%;top:{100 * BOX[1] / 36:.3f}%")
    assert f"the marked white card is in <code>{CARD}</code>" in other
    rows = dict(re.findall(r"<tr><td>([^<]+)</td><td>[^<]+</td><td>([0-9.]+)</td></tr>", card))
    assert float(rows["camera's development (right)"]) == pytest.approx(0, abs=0.01)
    assert float(rows["corrected (left)"]) > 0.3
    assert "The card set the white of both images" in card and "× the camera's" not in card  # 0: no ratio


def test_the_card_ratio_when_the_camera_misses_it(cap, tmp_path):
    import tifffile

    from splat.report import report_html

    spec = make_out(cap, tmp_path / "out")
    p = tmp_path / "out" / "correct" / spec.out_stem(CARD) / "raw_dng_XYZ.tiff"
    cam = tifffile.imread(p)
    cam[BOX[1] : BOX[3], BOX[0] : BOX[2]] *= TINT**2  # twice the corrected image's tint
    tifffile.imwrite(p, cam, photometric="minisblack")
    index = json.loads((tmp_path / "out" / "render" / "index.json").read_text())
    card = _sections(report_html(spec, tmp_path / "out", index))[0]
    ratio = float(re.search(r"ΔE00 is ([0-9.]+)× the camera's", card).group(1))
    assert 0.4 < ratio < 0.6


def test_next_points_to_the_full_size_photograph_and_the_card_is_read_in_raw_pixels(cap, tmp_path):
    """A photograph corrected at its RAW file's size is the file to keep (named first under "Next",
    with the size); in a run whose images are binned (the RAW file twice their size, as the correct step
    records it) the card's box is scaled from the RAW file's pixels: a finite ΔE00, the outline on it."""
    from splat.report import report_html

    out = tmp_path / "out"
    spec = make_out(cap, out)
    name = "nikon/IMG_0000.dng"
    c = out / "correct" / spec.out_stem(name)
    _tiff(c / "full_XYZ.tiff", np.zeros((4, 4, 3)))
    _png(c / "full_sRGB.png", np.zeros((4, 4, 3)))
    novel = out / "correct" / spec.out_stem("nikon/novel_000")  # a novel view with a map too
    _tiff(novel / "Prior_fused_uncertainty.tiff", RADIUS)
    _png(novel / "Prior_fused_uncertainty.png", np.repeat(RADIUS[..., None], 3, -1) / 10)
    doc = json.loads((out / "correct" / "summary.json").read_text())
    doc["working"] = {"nikon": {"full": [96, 72], "working": [48, 36], "binning": 2}}
    doc["full_resolution"] = {"per_view": {name: {"size": [96, 72]}}}
    _json(out / "correct" / "summary.json", doc)
    index = json.loads((out / "render" / "index.json").read_text())
    card, view, novel_sec = _sections(report_html(spec, out, index))
    first = re.search(r"<h3>Next</h3><ul><li>(.*?)</li>", view, flags=re.S).group(1)
    assert "full size (96 × 72 px, the RAW file's size)" in first and "full_sRGB.png" in first
    assert "full_sRGB.png" not in card  # no full-size file there
    # the uncertainty map is the working answer's, and the page says so where the sizes differ
    assert "The map is of the working answer (48×36 px)" in view and "the 96×72 px photograph" in view
    assert "class='umap'" in novel_sec and "The map is of the working answer" not in novel_sec  # no photo
    marks = re.findall(r"<span class='card'[^>]*style='([^']+)'", card)
    assert marks[0].startswith(f"left:{100 * BOX[0] / 96:.3f}%;top:{100 * BOX[1] / 72:.3f}%")
    rows = dict(re.findall(r"<tr><td>([^<]+)</td><td>[^<]+</td><td>([0-9.]+)</td></tr>", card))
    assert set(rows) == {"corrected (left)", "camera's development (right)"}  # finite, measured


def _tinted_card_dE00() -> float:
    """colour-science's ΔE00 of the card tinted by :data:`TINT` against the known card."""
    import colour

    xy = colour.XYZ_to_xy(WHITE_XYZ)
    lab = [colour.XYZ_to_Lab(0.9 * WHITE_XYZ * t, xy) for t in (TINT, np.ones(3))]
    return float(colour.delta_E(*lab, method="CIE 2000"))


def test_card_check_against_colour_science(cap, tmp_path):
    from splat.report import card_check

    spec = make_out(cap, tmp_path / "out")
    d = tmp_path / "out" / "correct" / spec.out_stem(CARD)
    check = card_check(spec, CARD, d / "Prior_fused_XYZ.tiff", d / "raw_dng_XYZ.tiff", WHITE_XYZ)
    assert check.delta_E["corrected"] == pytest.approx(_tinted_card_dE00(), rel=1e-4)
    assert check.delta_E["camera"] == pytest.approx(0, abs=1e-3)
    assert card_check(spec, "nikon/IMG_0000.dng", d / "x.tiff", d / "y.tiff", WHITE_XYZ) is None


def test_card_box_read_in_the_raw_files_pixels_when_the_images_are_binned(cap, tmp_path):
    """``[white] box`` is in the RAW file's pixels; images at a working resolution (here half the RAW
    file's size) are read in the box scaled to them, and a box outside an image gives no value (no NaN)."""
    from splat.capture import read_capture
    from splat.report import card_check

    spec = read_capture(cap)
    H, W = 36, 48
    x0, y0, x1, y1 = (v // 2 for v in BOX)  # the card in the half-size images
    images = {}
    for name, tint in (("corrected", TINT), ("camera", np.ones(3))):
        a = np.broadcast_to(0.5 * WHITE_XYZ, (H, W, 3)).copy()
        a[y0:y1, x0:x1] = 0.9 * WHITE_XYZ * tint
        _tiff(tmp_path / f"{name}.tiff", a)
        images[name] = tmp_path / f"{name}.tiff"
    check = card_check(spec, CARD, images["corrected"], images["camera"], WHITE_XYZ, raw_size=(2 * H, 2 * W))
    assert check.delta_E["corrected"] == pytest.approx(_tinted_card_dE00(), rel=1e-4)
    assert check.delta_E["camera"] == pytest.approx(0, abs=1e-3)
    far = card_check(spec, CARD, images["corrected"], images["camera"], WHITE_XYZ, raw_size=(3, 4))
    assert far.delta_E == {} and far.Lab == {}


def test_diagnostics_collapsed_and_explained_ground_truth_only_there(page):
    _out, _, html = page
    diag = html[html.index("<section id='diagnostics'>") :]
    for rel in ("poses/summary.json", "train/summary.json", "correct/summary.json", "correct/fusion.json"):
        assert re.search(rf"<details><summary><code>{re.escape(rel)}</code> — \w[^<]+\.</summary><pre>", diag)
    assert "ground truth" in diag and "123.456" in diag
    assert "123.456" not in html[: html.index("<section id='diagnostics'>")]


def test_self_contained(page):
    _out, _, html = page
    assert "<script" not in html  # no model here, so no viewer (and no script of any kind)
    assert "http://" not in html and "https://" not in html
    assert "<link" not in html and "@import" not in html


def test_nothing_rendered_says_so(cap, tmp_path):
    from splat.capture import report_step

    html = report_step(cap, tmp_path / "out").read_text()
    assert "Nothing rendered yet" in html


def _chromium():
    """A Chromium that runs here (a distribution's stub that only points to another installer does not),
    or None."""
    for name in ("chromium", "chromium-browser", "google-chrome", "google-chrome-stable"):
        exe = shutil.which(name)
        if exe is None:
            continue
        try:
            if subprocess.run([exe, "--version"], capture_output=True, timeout=30).returncode == 0:
                return exe
        except (OSError, subprocess.TimeoutExpired):
            continue
    return None


CHROMIUM = _chromium()


@pytest.mark.skipif(CHROMIUM is None, reason="no Chromium on this machine")
def test_screenshot_shows_both_images(page, tmp_path):
    from PIL import Image

    _out, path, _ = page
    shot = tmp_path / "shot.png"
    cmd = [
        CHROMIUM,
        "--headless",
        "--no-sandbox",
        "--disable-gpu",
        "--hide-scrollbars",
        f"--user-data-dir={tmp_path / 'profile'}",
        f"--screenshot={shot}",
        "--window-size=1400,1000",
        path.as_uri(),
    ]
    subprocess.run(cmd, check=False, capture_output=True, timeout=120)
    assert shot.is_file(), "Chromium wrote no screenshot"
    img = np.asarray(Image.open(shot).convert("RGB"), float)
    assert img.shape[:2] == (1000, 1400) and img.std() > 10  # not blank
    # the test images are saturated colours; the page around them is black, grey and white
    chroma = img.max(-1) - img.min(-1) > 60
    left, right = chroma[:, :700], chroma[:, 700:]
    assert left.mean() > 0.08 and right.mean() > 0.08


def test_a_view_corrected_from_the_render_only(cap, tmp_path):
    """Without a fused correction the answer is the render's, with the render's noise tolerance δ."""
    from splat.report import report_html

    spec = make_out(cap, tmp_path / "out")
    name = "nikon/novel_000"
    (tmp_path / "out" / "correct" / spec.out_stem(name) / "Prior_fused_sRGB.png").unlink()
    index = json.loads((tmp_path / "out" / "render" / "index.json").read_text())
    sec = _sections(report_html(spec, tmp_path / "out", index))[2]
    assert re.search(r"<img[^>]* src='correct/nikon/novel_000/Prior_sRGB.png'", sec)
    assert "from the model's render" in sec and "δ = 0.011" in sec


# ------------------------------------------------------------------ the interactive view of the scene


@pytest.fixture(scope="module")
def scene_run(tmp_path_factory):
    """A trained and corrected run (tests/splat/test_export.py's) with its corrected scene prepared, and
    the report written from it."""
    from splat.capture import read_capture
    from splat.export import prepare_scene
    from splat.report import report_html

    from .test_export import make_run

    cap, out, arrays, alive, views = make_run(tmp_path_factory.mktemp("scene"))
    assert prepare_scene(cap, out) == out / "correct" / "scene.npz"
    html = report_html(read_capture(cap), out, {})
    return out, arrays, alive, views, html


def _viewer(html):
    return re.search(r"<figure class='splat-viewer'.*?</script></figure>", html, flags=re.S).group(0)


def test_the_report_embeds_the_viewer_of_the_corrected_scene(scene_run):
    _out, _arrays, alive, views, html = scene_run
    sec = html[html.index("<section id='scene'>") :]
    frag = _viewer(sec)
    assert "src=" not in frag and "http" not in frag.split("<script>", 1)[0]
    from splat.viewer import viewer_script

    assert "</" not in viewer_script()  # nothing in the inline script can close its element
    doc = json.loads(
        re.search(r"<script type='application/json' class='splat-scene'>(.*?)</script>", frag).group(1)
    )
    assert doc["count"] == alive.sum() and len(doc["cameras"]) == len(views)
    assert doc["cameras"][0]["name"] == views[0].name
    import base64

    assert len(base64.b64decode(doc["data"])) == 40 * alive.sum()
    assert f"{alive.sum()} Gaussians of the model" in sec and "Cheung 2004" in sec


def test_the_viewer_waits_for_no_scene(page):
    """Without a trained model and its corrected scene there is no 3-D section."""
    _out, _, html = page
    assert "<section id='scene'>" not in html


def test_a_stale_scene_is_not_shown(scene_run, tmp_path):
    import shutil

    from splat.capture import read_capture
    from splat.report import report_html

    out, *_ = scene_run
    o2 = tmp_path / "out"
    shutil.copytree(out, o2)  # copies keep the files but not the model's stamp (its time)
    (o2 / "train" / "model.npz").touch()
    cap = out.parent / "cap"
    html = report_html(read_capture(cap), o2, {})
    assert "No interactive view yet" in html and "splat-viewer" not in html


@pytest.mark.skipif(CHROMIUM is None, reason="no Chromium on this machine")
def test_viewer_first_frame_matches_the_renderer(scene_run, tmp_path):
    """Headless Chromium (WebGL 2 by SwiftShader) draws the first frame; the screenshot is the renderer's
    image of the same view with the same corrected colours, to 8-bit rounding and per-Gaussian sorting."""
    import jax.numpy as jnp
    from PIL import Image

    from splat import Gaussians, inverse_softplus, render_reference
    from splat.viewer import viewer_page

    out, arrays, alive, views, html = scene_run
    report = tmp_path / "report.html"
    # after the first frame: the next photograph, a drag and a wheel turn, as a user would
    user = (
        "<script>const v = document.querySelector('.splat-viewer'), c = v.querySelector('canvas');"
        "document.body.dataset.first = c.dataset.frames; v.querySelector('.splat-next').click();"
        "document.body.dataset.next = c.dataset.frames;"
        "document.body.dataset.label = v.querySelector('.splat-label').textContent;"
        "c.dispatchEvent(new PointerEvent('pointerdown', {clientX: 100, clientY: 100, pointerId: 1}));"
        "c.dispatchEvent(new PointerEvent('pointermove', {clientX: 160, clientY: 80, pointerId: 1}));"
        "c.dispatchEvent(new WheelEvent('wheel', {deltaY: 200, cancelable: true}));</script>"
    )
    report.write_text(html.replace("</body>", user + "</body>"))
    flags = ["--headless", "--no-sandbox", "--hide-scrollbars", "--use-angle=swiftshader"]
    flags += [
        "--enable-unsafe-swiftshader",
        f"--user-data-dir={tmp_path / 'profile'}",
        "--virtual-time-budget=5000",
    ]
    dom = subprocess.run(
        [CHROMIUM, *flags, "--dump-dom", report.as_uri()], capture_output=True, text=True, timeout=120
    ).stdout
    assert 'data-first="1"' in dom, "the viewer drew no frame in the report"
    assert 'data-next="2"' in dom and f'data-label="2 / {len(views)}: {views[1].name}"' in dom  # ▶
    assert 'data-frames="3"' in dom and "free view" in dom  # drag and wheel: one more frame
    page = tmp_path / "viewer.html"
    page.write_text(viewer_page(_viewer(html)))
    shot = tmp_path / "shot.png"
    subprocess.run(
        [CHROMIUM, *flags, f"--screenshot={shot}", "--window-size=640,520", page.as_uri()],
        capture_output=True,
        timeout=120,
    )
    assert shot.is_file(), "Chromium wrote no screenshot"
    img = np.asarray(Image.open(shot).convert("RGB"), float)[:480, :640] / 255
    assert img.std() > 0.05  # not blank
    with np.load(out / "correct" / "scene.npz") as z:
        rgb = np.asarray(z["sRGB"], float)
    a = {k: v[alive] for k, v in arrays.items()}
    a["colour_params"] = np.asarray(inverse_softplus(rgb))
    g = Gaussians(*(jnp.asarray(a[k], jnp.float32) for k in Gaussians.__dataclass_fields__))
    want = np.clip(np.asarray(render_reference(g, views[0].camera.scaled(16)).image), 0, 1)
    assert want.shape == img.shape

    def down(x):
        return x.reshape(60, 8, 80, 8, 3).mean((1, 3))

    np.testing.assert_allclose(img.mean((0, 1)), want.mean((0, 1)), atol=0.01)  # mean colour
    assert np.corrcoef(down(img).ravel(), down(want).ravel())[0, 1] > 0.98  # structure
    assert np.abs(down(img) - down(want)).mean() < 0.01


CHART_VIEW = "nikon/IMG_0000.dng"
CORNERS = [[6, 6], [41, 6], [41, 29], [6, 29]]  # patch centres, top-left … bottom-left, in its 48 × 36 px


def test_a_marked_chart_is_measured_patch_by_patch(tmp_path):
    """``[chart]``: in the chart's photograph, each of the 24 patches' ΔE00 against its known colour
    (colour-science: the ColorChecker N Ohta reflectances under D65, CIE 1931 2°, 1 nm) in the
    corrected image and the camera's development, painted here with those colours (the camera's
    exactly, the corrected ones tinted); elsewhere the page names the chart's photograph."""
    import colour
    import tifffile

    from isp.profiles.chart import chart_patch_centres
    from splat.capture import report_step

    cap = tmp_path / "cap"
    chart = f'\n[chart]\nimage = "{CHART_VIEW}"\ncorners = {CORNERS}\n'
    write_capture(cap, views=1, holdout=1, extra_toml=chart)
    out = tmp_path / "out"
    spec = make_out(cap, out)
    cmfs = colour.MSDS_CMFS["CIE 1931 2 Degree Standard Observer"]
    d65 = colour.SDS_ILLUMINANTS["D65"]
    sds = colour.SDS_COLOURCHECKERS["ColorChecker N Ohta"]
    white = colour.sd_to_XYZ(colour.sd_ones(), cmfs, d65) / 100
    known = np.array([colour.sd_to_XYZ(sd, cmfs, d65) for sd in sds.values()]) / 100
    tint = np.array([1.04, 1.0, 0.93])
    c = out / "correct" / spec.out_stem(CHART_VIEW)
    images = {}
    for f, xyz in (
        ("Prior_fused_XYZ.tiff", known * tint),
        ("full_XYZ.tiff", known),  # the same correction at full size: here exact
        ("raw_dng_XYZ.tiff", known),
    ):
        img = np.broadcast_to(0.2 * white, (36, 48, 3)).copy()
        for (x, y), v in zip(np.rint(chart_patch_centres(CORNERS, 4, 6)).astype(int), xyz):
            img[y - 2 : y + 3, x - 2 : x + 3] = v
        tifffile.imwrite(c / f, img.astype(np.float32), photometric="rgb")
        images[f] = img
    html = report_step(cap, out).read_text()
    sections = _sections(html)
    sec = next(s_ for s_ in sections if f"<h2>{CHART_VIEW} " in s_)
    xy = colour.XYZ_to_xy(white)
    lab = colour.XYZ_to_Lab(known, xy)
    want = colour.delta_E(colour.XYZ_to_Lab(known * tint, xy), lab, method="CIE 2000")
    every = re.search(r"<details><summary>Every patch.*?</details>", sec, flags=re.S).group(0)
    rows = re.findall(r"<tr><td>([^<]+)</td><td>[^<]+</td>" + "<td>([0-9.]+)</td>" * 3 + "</tr>", every)
    assert [r[0] for r in rows][:3] == ["dark skin", "light skin", "blue sky"] and len(rows) == 24
    corrected = np.array([float(r[1]) for r in rows])
    full = np.array([float(r[2]) for r in rows])
    camera = np.array([float(r[3]) for r in rows])
    assert full.max() < 0.6
    # the 10 nm, 400–700 nm grid of the capture's correction against colour-science at 1 nm, 360–830
    assert camera.max() < 0.6 and np.abs(corrected - want).max() < 0.6 and corrected.mean() > 1.0
    summary = re.search(r"<td>corrected \(left\)</td><td>([0-9.]+)</td><td>([0-9.]+)</td><td>24</td>", sec)
    assert float(summary.group(1)) == pytest.approx(corrected.mean(), abs=0.01)
    assert "The chart took no part in the correction" in sec
    ratio, at_full = re.search(r"mean is ([0-9.]+)× the camera's \(([0-9.]+)× at full size\)", sec).groups()
    assert float(ratio) == pytest.approx(corrected.mean() / camera.mean(), rel=0.02)
    assert float(at_full) == pytest.approx(full.mean() / camera.mean(), rel=0.05)
    # every patch's box is outlined on both images, inside the 48 × 36 frame, around its centre
    spans = re.findall(
        r"<span class='patch' title='ColorChecker patch: ([^']+)' style='left:([0-9.]+)%;top:([0-9.]+)%", sec
    )
    assert len(spans) == 48 and spans[0][0] == "dark skin"
    left, top = float(spans[0][1]) * 48 / 100, float(spans[0][2]) * 36 / 100
    x0, y0 = chart_patch_centres(CORNERS, 4, 6)[0]
    assert x0 + 0.5 - 2 < left < x0 + 0.5 and y0 + 0.5 - 2 < top < y0 + 0.5
    assert "The boxes on the images show where each patch was read" in sec
    assert "worse than the camera's own development" not in sec  # the photograph to keep is exact

    # corners left out and found by the poses step (its record): the same figures, and the page says so
    from splat.capture import CHART_RECORD, file_stamp, write_json

    toml = cap / "capture.toml"
    toml.write_text(toml.read_text().replace(f"corners = {CORNERS}", ""))
    record = {"image": CHART_VIEW, "file": file_stamp(cap / CHART_VIEW), "corners": CORNERS}
    write_json(out / CHART_RECORD, record)
    again = next(s_ for s_ in _sections(report_step(cap, out).read_text()) if f"<h2>{CHART_VIEW} " in s_)
    assert "Its corners were found in the photograph" in again
    assert re.search(r"<details><summary>Every patch.*?</details>", again, flags=re.S).group(0) == every
    other = next(s_ for s_ in sections if f"<h2>{CARD} " in s_)
    assert f"the marked ColorChecker is in <code>{CHART_VIEW}</code>" in other

    # the photograph to keep (full size) further from the chart than the camera's development: the first
    # advice says so, with both means, instead of "keep the corrected photograph"
    tinted = images["Prior_fused_XYZ.tiff"].astype(np.float32)
    tifffile.imwrite(c / "full_XYZ.tiff", tinted, photometric="rgb")
    worse = next(s_ for s_ in _sections(report_step(cap, out).read_text()) if f"<h2>{CHART_VIEW} " in s_)
    first = re.search(r"<h3>Next</h3><ul><li>(.*?)</li>", worse, flags=re.S).group(1)
    assert "worse than the camera's own development" in first and f"isp develop {CHART_VIEW}" in first
    assert "Keep the corrected photograph" not in worse
    assert "The corrected photograph is at full size" in worse
    ours, theirs = (float(x) for x in re.search(r"mean ΔE00 ([0-9.]+) against ([0-9.]+)", first).groups())
    assert ours == pytest.approx(corrected.mean(), abs=0.01)
    assert theirs == pytest.approx(camera.mean(), abs=0.01)
