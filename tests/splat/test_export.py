"""splat.export: the trained scene as a 3DGS .ply of its corrected colours (read back by plyfile, an
independent reader, in the reference layout; rendering the re-read file gives the model's image), the
N-channel .ply, and the poses as transforms.json / COLMAP (read back by the project's readers)."""

from __future__ import annotations

import json

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from .conftest import random_gaussians

plyfile = pytest.importorskip("plyfile")

CAMERAS = (
    ("nikon", "Nikon 5100 (NPL)"),
    ("sigma", "Sigma SDMerill (NPL)"),
    ("canon", "Canon EOS 5D Mark II"),
)
SCALE = np.array([[0.61, 0.7, 0.52], [0.4, 0.45, 0.38], [0.66, 0.72, 0.5]])  # each camera's white
WHITE_XYZ = [0.95047, 1.0, 1.08883]
METHOD = "Cheung 2004"  # a regression: fitted in a fraction of a second (Prior takes minutes)
INRIA = (
    "x y z nx ny nz f_dc_0 f_dc_1 f_dc_2 "
    + " ".join(f"f_rest_{i}" for i in range(45))
    + " opacity scale_0 scale_1 scale_2 rot_0 rot_1 rot_2 rot_3"
).split()


def make_run(root, *, G=150, dead=20):
    """A capture (three built-in cameras, RAW files named but empty: nothing here reads them) and an OUT
    as the poses, train and correct steps leave it, with a random 9-channel model (``dead`` Gaussians not
    alive) and two posed views per camera. Returns (capture, out, model arrays, alive mask, views)."""
    from splat import look_at
    from splat.capture import read_capture
    from splat.capture.workspace import Workspace
    from splat.colmap import write_colmap
    from splat.data import Capture, View, colmap_from_capture

    cap, out = root / "cap", root / "out"
    toml = ['illuminant = "D65"', ""]
    for folder, ssf in CAMERAS:
        (cap / folder).mkdir(parents=True)
        for i in range(2):
            (cap / folder / f"IMG_{i:04d}.dng").write_bytes(b"")
        toml += ["[[camera]]", f'folder = "{folder}"', f'ssf = "{ssf}"', ""]
    (cap / "capture.toml").write_text("\n".join(toml))
    spec = read_capture(cap)
    Workspace(spec, out)
    g = random_gaussians(G, 9, seed=3)
    arrays = g.to_numpy()
    arrays["colour_params"] = arrays["colour_params"] + np.log(SCALE.ravel())  # roughly raw units
    r = np.random.default_rng(2)
    aniso = r.uniform(-0.8, 0.3, (G, 3)).astype(np.float32)  # anisotropic: the rotations matter
    arrays["log_scales"] = arrays["log_scales"] + aniso
    alive = np.ones(G, bool)
    alive[np.random.default_rng(1).choice(G, dead, replace=False)] = False
    (out / "train").mkdir()
    np.savez(out / "train" / "model.npz", alive=alive, **arrays)
    views = []
    for k, (folder, _) in enumerate(CAMERAS):
        for i in range(2):
            a = 2.1 * k + 1.3 * i
            cam = look_at((3.5 * np.cos(a), 3.5 * np.sin(a), 0.9), (0, 0, 0), width=40, height=30, fov_deg=50)
            views.append(View(f"{folder}/IMG_{i:04d}.dng", cam, k + 1, 1.0))
    channels = {k + 1: (3 * k, 3 * k + 1, 3 * k + 2) for k in range(3)}
    write_colmap(colmap_from_capture(Capture(tuple(views), channels)), out / "poses" / "model", binary=False)
    (out / "poses" / "summary.json").write_text(json.dumps({"exposures": {v.name: 1.0 for v in views}}))
    (out / "correct").mkdir()
    (out / "correct" / "summary.json").write_text(
        json.dumps(
            {
                "method": METHOD,
                "delta": 0.01,
                "white": {"method": "auto", "scale": SCALE.tolist()},
                "white_XYZ": WHITE_XYZ,
            }
        )
    )
    return cap, out, arrays, alive, views


@pytest.fixture(scope="module")
def run(tmp_path_factory):
    return make_run(tmp_path_factory.mktemp("export"))


@pytest.fixture(scope="module")
def exported(run, tmp_path_factory):
    from splat.export import export_scene

    cap, out, *_ = run
    d = tmp_path_factory.mktemp("exported")
    done = export_scene(
        cap,
        out,
        ply=d / "scene.ply",
        ply_channels=d / "scene_n.ply",
        transforms=d / "transforms.json",
        colmap=d / "colmap",
    )
    return d, done


def _gaussians(ply, channels):
    """Gaussians built here from plyfile's reading of a 3DGS file (the INRIA loader's arithmetic)."""
    import jax.numpy as jnp

    from splat import Gaussians, inverse_softplus

    v = ply["vertex"]
    cols = np.stack([np.asarray(v[c], np.float64) for c in channels], -1)
    if channels[0] == "f_dc_0":
        cols = np.maximum(0.28209479177387814 * cols + 0.5, 0)
    return Gaussians(
        jnp.asarray(np.stack([v["x"], v["y"], v["z"]], -1)),
        jnp.asarray(np.stack([v[f"rot_{i}"] for i in range(4)], -1)),
        jnp.asarray(np.stack([v[f"scale_{i}"] for i in range(3)], -1)),
        jnp.asarray(np.asarray(v["opacity"])),
        jnp.asarray(inverse_softplus(cols), jnp.float32),
    )


def _model(arrays, alive, colours=None):
    import jax.numpy as jnp

    from splat import Gaussians, inverse_softplus

    a = {k: v[alive] for k, v in arrays.items()}
    if colours is not None:
        a["colour_params"] = np.asarray(inverse_softplus(colours))
    return Gaussians(*(jnp.asarray(a[k], jnp.float32) for k in Gaussians.__dataclass_fields__))


def test_the_ply_has_the_reference_layout_and_names_its_colour_spaces(run, exported):
    _cap, _out, arrays, alive, _ = run
    d, done = exported
    ply = plyfile.PlyData.read(str(d / "scene.ply"))
    v = ply["vertex"]
    assert [p.name for p in v.properties] == [*INRIA, "XYZ_X", "XYZ_Y", "XYZ_Z"]
    assert all(p.val_dtype in ("f4", "float32") for p in v.properties) and not ply.text
    assert len(v.data) == alive.sum() == done["ply"]["gaussians"]
    np.testing.assert_array_equal(np.stack([v["x"], v["y"], v["z"]], -1), arrays["means"][alive])
    np.testing.assert_array_equal(v["opacity"], arrays["opacity_logits"][alive])  # a logit
    np.testing.assert_array_equal(v["scale_1"], arrays["log_scales"][alive][:, 1])  # a log
    q = np.stack([v[f"rot_{i}"] for i in range(4)], -1)
    np.testing.assert_allclose(np.linalg.norm(q, axis=-1), 1, atol=1e-6)
    want = arrays["quats"][alive] / np.linalg.norm(arrays["quats"][alive], axis=-1, keepdims=True)
    np.testing.assert_allclose(q, want, atol=1e-6)  # (w, x, y, z) as 3DGS
    assert not any(np.any(v[f"f_rest_{i}"]) for i in range(45))
    text = "\n".join(ply.comments)
    assert "sRGB" in text and "linear CIE XYZ" in text and METHOD in text and "Bradford" in text
    assert d.joinpath("scene.ply").stat().st_size == done["ply"]["bytes"]


def test_displayed_colours_are_the_srgb_encoding_of_the_linear_xyz(exported):
    """f_dc = (sRGB − 0.5)/C0 of the XYZ properties, by colour-science's own sRGB encoding."""
    import colour

    d, _ = exported
    v = plyfile.PlyData.read(str(d / "scene.ply"))["vertex"]
    XYZ = np.stack([v["XYZ_X"], v["XYZ_Y"], v["XYZ_Z"]], -1).astype(float)
    rgb = colour.XYZ_to_sRGB(
        XYZ, illuminant=colour.XYZ_to_xy(WHITE_XYZ), chromatic_adaptation_transform="Bradford"
    )
    dc = np.stack([v[f"f_dc_{i}"] for i in range(3)], -1)
    np.testing.assert_allclose(dc, (np.clip(rgb, 0, 1) - 0.5) / 0.28209479177387814, atol=2e-5)
    assert XYZ[:, 1].std() > 0.02 and np.ptp(dc) > 0.5  # the colours vary


def test_colours_are_the_estimators_correction_of_each_gaussian(run, exported):
    """XYZ = the estimator fitted with zonotope's public API on the white-balanced N-channel colours."""
    import jax

    import zonotope
    from zonotope.correct import correction_problem, fit_correction, noise_options

    _cap, _out, arrays, alive, _ = run
    d, _ = exported
    v = plyfile.PlyData.read(str(d / "scene.ply"))["vertex"]
    cams = [zonotope.load_camera(c[1]) for c in CAMERAS]
    common = zonotope.common_shape(
        *cams, zonotope.observer("CIE 1931 2 Degree Standard Observer"), interval=10
    )
    shape = np.arange(max(common.start, 400.0), min(common.end, 700.0) + 5, 10.0)
    problem = correction_problem(
        cams,
        target="CIE 1931 2 Degree Standard Observer",
        illuminant="D65",
        shape=shape,
        training="rawtoaces 190",
    )
    from zonotope.correct import DELTA_SIGMAS

    sigma = np.hypot(0.01 / DELTA_SIGMAS, zonotope.unit_sigma(3))  # published curves: the units' spread
    est = fit_correction(problem, method=METHOD, **noise_options(METHOD, sigma))
    balanced = np.asarray(jax.nn.softplus(arrays["colour_params"][alive]), float) / SCALE.ravel()
    want = est(balanced)
    got = np.stack([v["XYZ_X"], v["XYZ_Y"], v["XYZ_Z"]], -1)
    np.testing.assert_allclose(got, want, atol=0.01)  # the correct step's 5e-3 deduplication step


def test_the_reread_file_renders_as_the_model(run, exported):
    """Rendered at a view, the plyfile-read model equals the model with its corrected colours (the .ply)
    and the model itself (the N-channel .ply, all nine channels)."""
    import jax

    from splat import render_reference

    _cap, _out, arrays, alive, views = run
    d, _ = exported
    cam = views[2].camera
    ply = plyfile.PlyData.read(str(d / "scene.ply"))
    rgb = np.maximum(
        0.28209479177387814 * np.stack([ply["vertex"][f"f_dc_{i}"] for i in range(3)], -1) + 0.5, 0
    )
    a = np.asarray(render_reference(_gaussians(ply, ["f_dc_0", "f_dc_1", "f_dc_2"]), cam).image)
    b = np.asarray(render_reference(_model(arrays, alive, rgb), cam).image)
    assert a.std() > 0.05
    np.testing.assert_allclose(a, b, atol=1e-5)
    plyn = plyfile.PlyData.read(str(d / "scene_n.ply"))
    names = [p.name for p in plyn["vertex"].properties]
    ch = [n for n in names if n.startswith("f_") and not n.startswith(("f_dc", "f_rest"))]
    assert ch == [f"f_{c}_{x}" for c, _ in CAMERAS for x in "RGB"]
    assert names[: len(INRIA) + 3] == [*INRIA, "XYZ_X", "XYZ_Y", "XYZ_Z"]  # opens in viewers too
    a = np.asarray(render_reference(_gaussians(plyn, ch), cam).image)
    b = np.asarray(render_reference(_model(arrays, alive), cam).image)
    assert a.shape[-1] == 9
    np.testing.assert_allclose(a, b, atol=1e-5 * np.abs(b).max())
    white = next(c for c in plyn.comments if c.startswith("channels white"))
    assert f"f_sigma_G={SCALE[1, 1]:.6g}" in white
    _ = jax


def test_poses_round_trip_through_transforms_and_colmap(run, exported):
    from splat import read_colmap, read_transforms, rotmat_to_qvec

    _cap, _out, _, _, views = run
    d, done = exported
    cap = read_transforms(d / "transforms.json")
    assert json.loads((d / "transforms.json").read_text())["written_by"] == "written by splat export"
    assert [v.name for v in cap.views] == [v.name for v in views] and done["transforms"]["views"] == 6
    model = read_colmap(d / "colmap")
    assert (d / "colmap" / "images.bin").is_file()
    for v, w in zip(cap.views, views):
        np.testing.assert_allclose(np.asarray(v.camera.R), np.asarray(w.camera.R), atol=1e-5)
        np.testing.assert_allclose(np.asarray(v.camera.t), np.asarray(w.camera.t), atol=1e-5)
        np.testing.assert_allclose(np.asarray(v.camera.focal), np.asarray(w.camera.focal), rtol=1e-6)
        assert v.camera_id == w.camera_id and (v.camera.width, v.camera.height) == (40, 30)
        im = next(i for i in model.images.values() if i.name == w.name)
        q = rotmat_to_qvec(np.asarray(w.camera.R, float))
        assert np.allclose(im.qvec, q, atol=1e-5) or np.allclose(im.qvec, -q, atol=1e-5)
        np.testing.assert_allclose(im.tvec, np.asarray(w.camera.t), atol=1e-5)
    assert cap.channels == {1: (0, 1, 2), 2: (3, 4, 5), 3: (6, 7, 8)}


@settings(suppress_health_check=[HealthCheck.too_slow])  # generation is timed on a shared machine
@given(st.lists(st.floats(-0.5, 1.5), min_size=3, max_size=3))
def test_sh_dc_round_trip(rgb):
    from splat.export import SH_C0, rgb_from_sh_dc, sh_dc_from_rgb

    assert SH_C0 == pytest.approx(1 / (2 * np.sqrt(np.pi)), rel=1e-15)
    np.testing.assert_allclose(rgb_from_sh_dc(sh_dc_from_rgb(rgb)), rgb, atol=1e-12)


def test_sh_degree_zero_and_no_xyz(run, tmp_path):
    from splat.export import PlyOptions, export_scene

    cap, out, *_ = run
    export_scene(cap, out, ply=tmp_path / "s.ply", options=PlyOptions(sh_degree=0, xyz=False))
    v = plyfile.PlyData.read(str(tmp_path / "s.ply"))["vertex"]
    assert [p.name for p in v.properties] == [n for n in INRIA if not n.startswith("f_rest")]
    assert (tmp_path / "s.ply").stat().st_size - len(v.data) * 17 * 4 < 2000  # 68 bytes a Gaussian + header


def test_refusals_before_work(run, tmp_path):
    from splat.export import PlyOptions, export_scene
    from zonotope import ZonotopeError

    cap, out, *_ = run
    mine = tmp_path / "user.ply"
    mine.write_text("a user's file")
    with pytest.raises(ZonotopeError, match="already exists"):
        export_scene(cap, out, ply=mine)
    with pytest.raises(ZonotopeError, match="not written by splat export"):
        export_scene(cap, out, ply=mine, force=True)
    assert mine.read_text() == "a user's file"
    with pytest.raises(ZonotopeError, match="inside the capture"):
        export_scene(cap, out, ply=cap / "scene.ply")
    with pytest.raises(ZonotopeError, match="nothing to export"):
        export_scene(cap, out)
    with pytest.raises(ZonotopeError, match=r"no \.splat-output\.json"):
        export_scene(cap, tmp_path, ply=tmp_path / "x.ply")
    assert not (cap / "scene.ply").exists() and not (tmp_path / "x.ply").exists()
    ours = tmp_path / "ours.ply"
    export_scene(cap, out, ply=ours, options=PlyOptions(sh_degree=0))
    export_scene(cap, out, ply=ours, force=True)  # a previous export is replaced when asked
    assert len(plyfile.PlyData.read(str(ours))["vertex"].properties) == len(INRIA) + 3


def test_not_corrected_yet(tmp_path):
    from splat.capture import CaptureError
    from splat.export import export_scene, prepare_scene

    cap, out, *_ = make_run(tmp_path, G=10, dead=0)
    calls = []
    assert prepare_scene(cap, out, progress=lambda *a: calls.append(a)) == out / "correct" / "scene.npz"
    assert calls[0] == ("scene", 0, 10) and calls[-1] == ("scene", 10, 10)
    (out / "correct" / "summary.json").unlink()
    assert prepare_scene(cap, out) is None  # not that far: nothing to prepare
    with pytest.raises(CaptureError, match="run the correct step first"):
        export_scene(cap, out, ply=tmp_path / "s.ply")
    assert not (tmp_path / "s.ply").exists()


def test_cli(run, tmp_path, capsys):
    from splat.cli import main

    cap, out, *_ = run
    assert main(["export", str(out), "--capture", str(cap), "--ply", str(tmp_path / "a.ply")]) == 0
    assert "a.ply" in capsys.readouterr().out and (tmp_path / "a.ply").is_file()
    assert main(["export", str(out), "--capture", str(cap), "--ply", str(tmp_path / "a.ply")]) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith("splat: error:") and "already exists" in err and "\n" not in err


def test_read_ply_and_gaussians_from_ply_agree_with_plyfile(run, exported, tmp_path):
    from splat import DataFormatError, render_reference
    from splat.export import gaussians_from_ply, read_ply

    _cap, _out, _, _, views = run
    d, _ = exported
    props, comments = read_ply(d / "scene_n.ply")
    ply = plyfile.PlyData.read(str(d / "scene_n.ply"))
    assert list(props) == [p.name for p in ply["vertex"].properties] and comments == list(ply.comments)
    for p in ply["vertex"].properties:
        np.testing.assert_array_equal(props[p.name], ply["vertex"][p.name])
    cam = views[0].camera
    for channels in (["f_dc_0", "f_dc_1", "f_dc_2"], ["f_sigma_R", "f_canon_B"]):
        a = render_reference(
            gaussians_from_ply(props, channels=None if channels[0] == "f_dc_0" else channels), cam
        )
        b = render_reference(_gaussians(ply, channels), cam)
        np.testing.assert_allclose(np.asarray(a.image), np.asarray(b.image), atol=1e-6)
    bad = tmp_path / "bad.ply"
    bad.write_bytes(b"not a ply")
    with pytest.raises(DataFormatError, match=r"bad\.ply: not a PLY file"):
        read_ply(bad)
    with pytest.raises(DataFormatError, match="no property 'f_dc_0'"):
        gaussians_from_ply({"y": np.zeros(1)})


@settings(max_examples=20, suppress_health_check=[HealthCheck.too_slow])
@given(
    st.lists(
        st.from_regex(r"[A-Za-z][A-Za-z0-9_]{0,8}", fullmatch=True), min_size=1, max_size=5, unique=True
    ),
    st.integers(0, 6),
    st.integers(0, 2**32 - 1),
)
def test_write_ply_read_ply_round_trip(names, n, seed):
    import tempfile
    from pathlib import Path

    from splat.export import read_ply, write_ply

    r = np.random.default_rng(seed)
    props = {k: r.normal(size=n).astype(np.float32) for k in names}
    with tempfile.TemporaryDirectory() as d:
        p = write_ply(Path(d) / "a.ply", props, comments=["hello world"])
        back, comments = read_ply(p)
        ply = plyfile.PlyData.read(str(p))
    assert list(back) == names and comments[1:] == ["hello world"]
    assert len(ply["vertex"].data) == n
    for k in names:
        np.testing.assert_array_equal(back[k], props[k])
        np.testing.assert_array_equal(ply["vertex"][k], props[k])
