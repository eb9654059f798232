"""Data safety (issue 16) and hardened inputs (issue 13, item 8) of ``zonotope``.

One regression test per reported failure: outputs replaced only when asked and only if they are
outputs of the same command, atomic writes that survive SIGKILL, no temporaries after an
interruption, umask permissions, loaders that never drop rows, no silent NaN, a CLI that answers bad
input in one line, batches in bounded memory. Plus hypothesis fuzzing of the spectra loaders.
"""

from __future__ import annotations

import functools
import json
import os
import signal
import stat
import subprocess
import sys
import time
import tracemalloc
from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import zonotope
from zonotope import GeometryError, SpectralDataError, ZonotopeError
from zonotope.cli import main as zonotope_main
from zonotope.utilities.io import (
    MARKER,
    OutputExistsError,
    atomic_dir,
    atomic_write_bytes,
    atomic_write_text,
    check_output,
    clean_stale_temporaries,
)

ROOT = Path(__file__).resolve().parents[3]


def leftovers(folder: Path, keep: set[str]) -> list[str]:
    return sorted(p.name for p in folder.iterdir() if p.name not in keep)


# ---- zonotope.utilities.io ---------------------------------------------------------------------------------


def test_atomic_write_permissions_follow_umask(tmp_path):
    old = os.umask(0o022)
    try:
        f = atomic_write_text(tmp_path / "a.md", "x")
        with atomic_dir(tmp_path / "rep", signature="test") as d:
            (d / "index.html").write_text("y")
    finally:
        os.umask(old)
    assert stat.S_IMODE(f.stat().st_mode) == 0o644  # not 0600 as tempfile makes them
    assert stat.S_IMODE((tmp_path / "rep").stat().st_mode) == 0o755
    assert (tmp_path / "rep" / MARKER).read_text() == "test\n"


@pytest.mark.parametrize("exchange", [True, False])
def test_atomic_dir_replaces_a_folder_by_exchange_or_two_renames(tmp_path, monkeypatch, exchange):
    """An existing report folder is replaced whole (the old files gone, no temporary left), by the atomic
    exchange where the OS has it (Linux here: asserted) and by the two-rename fallback elsewhere."""
    import zonotope.utilities.io as io

    if exchange:
        a, b = tmp_path / "a", tmp_path / "b"
        a.mkdir(), b.mkdir(), (a / "x").write_text("A")
        assert io._exchange(a, b) and (b / "x").read_text() == "A" and not any(a.iterdir())
        a.rmdir(), (b / "x").unlink(), b.rmdir()
    else:
        monkeypatch.setattr(io, "_exchange", lambda a, b: False)
    dest = tmp_path / "rep"
    for version in ("one", "two"):
        with atomic_dir(dest, signature="test", overwrite=True) as d:
            (d / f"{version}.html").write_text(version)
    assert sorted(p.name for p in dest.iterdir()) == sorted([MARKER, "two.html"])
    assert leftovers(tmp_path, {"rep"}) == []


def test_keyboard_interrupt_leaves_no_temporary_and_keeps_the_old_file(tmp_path):
    dest = tmp_path / "out.txt"
    dest.write_text("good")
    from zonotope.utilities.io import atomic_file

    with pytest.raises(KeyboardInterrupt), atomic_file(dest, mode="w") as fh:
        fh.write("half")
        raise KeyboardInterrupt
    with pytest.raises(KeyboardInterrupt), atomic_dir(tmp_path / "rep", signature="t") as d:
        (d / "a.png").write_bytes(b"1234")
        raise KeyboardInterrupt
    assert dest.read_text() == "good"
    assert leftovers(tmp_path, {"out.txt"}) == []


def test_check_output_replaces_only_marked_outputs(tmp_path):
    user = tmp_path / "photos"
    user.mkdir()
    (user / "holiday.jpg").write_bytes(b"precious")
    with pytest.raises(OutputExistsError, match="already exists"):
        check_output(user, signature="zonotope report")
    with pytest.raises(OutputExistsError, match="not an output of this command"):
        check_output(user, overwrite=True, signature="zonotope report")
    (user / MARKER).write_text("zonotope evaluate\n")  # another command's output: still refused
    with pytest.raises(OutputExistsError, match="not an output"):
        check_output(user, overwrite=True, signature="zonotope report")
    (user / MARKER).write_text("zonotope report\n")
    assert check_output(user, overwrite=True, signature="zonotope report") == user
    cam = tmp_path / "cam.csv"
    cam.write_text("x")
    with pytest.raises(OutputExistsError, match="input"):
        check_output(cam, overwrite=True, signature="x", inputs=[cam])
    link = tmp_path / "link.md"
    link.symlink_to(cam)
    with pytest.raises(OutputExistsError, match="input"):
        check_output(link, overwrite=True, signature="x", inputs=[str(cam)])


# the writer imports only zonotope.utilities.io (a bare package object skips zonotope/__init__):
# starts in ~50 ms
_WRITER = """
import sys, types
pkg = types.ModuleType("zonotope")
pkg.__path__ = ["zonotope"]
sys.modules["zonotope"] = pkg
from zonotope.utilities.io import atomic_write_bytes
dest, n = sys.argv[1], int(sys.argv[2])
i = 0
while True:
    i += 1
    atomic_write_bytes(dest, bytes([i % 251]) * n)
    print(i, flush=True)
"""


def _kill_while_writing(code: str, args: list[str], delay: float) -> None:
    proc = subprocess.Popen(
        [sys.executable, "-c", code, *args], stdout=subprocess.PIPE, stderr=subprocess.DEVNULL, cwd=ROOT
    )
    proc.stdout.readline()  # one complete write done
    time.sleep(delay)
    proc.send_signal(signal.SIGKILL)
    proc.wait()


KILL_DELAYS = (0.0, 0.003, 0.01, 0.02, 0.05, 0.08, 0.13, 0.2)


def test_sigkill_mid_write_keeps_a_complete_file(tmp_path):
    """8 SIGKILLs of a process rewriting a 4 MB file: the file is always one complete version, and
    the next write removes the dead writer's temporary (no orphans)."""
    dest = tmp_path / "out.bin"
    n = 4_000_000
    mid_write = 0
    for delay in KILL_DELAYS:
        _kill_while_writing(_WRITER, [str(dest), str(n)], delay)
        data = dest.read_bytes()
        assert len(data) == n and data == data[:1] * n, delay
        mid_write += bool(clean_stale_temporaries(dest))  # the kill hit a write: its temporary removed
        assert leftovers(tmp_path, {"out.bin"}) == []
    print(f"{mid_write} of {len(KILL_DELAYS)} kills landed mid-write")
    assert leftovers(tmp_path, {"out.bin"}) == []
    atomic_write_bytes(dest, b"ok")
    assert leftovers(tmp_path, {"out.bin"}) == [] and dest.read_bytes() == b"ok"


_DIR_WRITER = """
import sys, types
pkg = types.ModuleType("zonotope")
pkg.__path__ = ["zonotope"]
sys.modules["zonotope"] = pkg
from zonotope.utilities.io import atomic_dir
dest = sys.argv[1]
i = 0
while True:
    i += 1
    with atomic_dir(dest, signature="zonotope report", overwrite=True) as d:
        for name in ("index.html", "report.md", "solid.png", "grey_mmvs.png"):
            (d / name).write_bytes(bytes([i % 251]) * 1_000_000)
    print(i, flush=True)
"""


def test_sigkill_mid_report_folder_keeps_a_complete_report(tmp_path):
    """6 SIGKILLs of a process replacing a report folder (4 MB) in a loop: the folder is always one
    complete report with its marker, and the next write removes the dead writer's partial folders."""
    dest = tmp_path / "rep"
    mid_write = 0
    for delay in KILL_DELAYS[:6]:
        _kill_while_writing(_DIR_WRITER, [str(dest)], delay)
        files = {p.name: p.read_bytes() for p in dest.iterdir()}
        assert sorted(files) == sorted([MARKER, "index.html", "report.md", "solid.png", "grey_mmvs.png"])
        data = {v for k, v in files.items() if k != MARKER}
        assert len(data) == 1 and len(next(iter(data))) == 1_000_000
        mid_write += bool(clean_stale_temporaries(dest))
        assert leftovers(tmp_path, {"rep"}) == []  # no .partial-* folder survives
    print(f"{mid_write} of 6 kills landed mid-write")


def test_output_under_a_file_is_a_project_error(tmp_path):
    blocker = tmp_path / "results"
    blocker.write_text("a file, not a folder")
    with pytest.raises(OutputExistsError, match="is a file"):
        check_output(blocker / "sub" / "table.md")
    with pytest.raises(OutputExistsError, match="in the way"):
        atomic_write_text(blocker / "table.md", "x")
    assert blocker.read_text() == "a file, not a folder"


# ---- report and evaluate outputs --------------------------------------------------------------------


def test_report_force_never_deletes_a_user_folder(tmp_path, capsys):
    folder = tmp_path / "my photos"
    folder.mkdir()
    (folder / "holiday.jpg").write_bytes(b"precious")
    t0 = time.perf_counter()
    rc = zonotope_main(["report", "--camera", "Nikon 5100 (NPL)", "-o", str(folder), "--force"])
    err = capsys.readouterr().err
    assert rc == 2 and "not an output of this command" in err and len(err.strip().splitlines()) == 1
    assert (folder / "holiday.jpg").read_bytes() == b"precious"
    assert time.perf_counter() - t0 < 30  # refused before the long run (it takes minutes)
    from zonotope.report import ReportExistsError, write_report

    with pytest.raises(ReportExistsError):
        write_report(["Nikon 5100 (NPL)"], folder, force=True)
    assert sorted(p.name for p in folder.iterdir()) == ["holiday.jpg"]


def test_evaluate_markdown_never_overwrites_an_input(tmp_path, capsys):
    cam = tmp_path / "cam.csv"
    npl = zonotope.camera("Nikon 5100 (NPL)")
    rows = ["wavelength,R,G,B"] + [
        f"{w:g},{r:.6g},{g:.6g},{b:.6g}" for w, (r, g, b) in zip(npl.wavelengths, npl.values)
    ]
    cam.write_text("\n".join(rows) + "\n")
    before = cam.read_bytes()
    for extra in ([], ["--force"]):
        rc = zonotope_main(["evaluate", "--camera", str(cam), "--markdown", str(cam), *extra])
        err = capsys.readouterr().err
        assert rc == 2 and "input" in err and "Traceback" not in err
    assert cam.read_bytes() == before
    other = tmp_path / "notes.md"  # an existing file that evaluate did not write
    other.write_text("# my notes\n")
    rc = zonotope_main(["evaluate", "--camera", "Nikon 5100 (NPL)", "--markdown", str(other), "--force"])
    assert rc == 2 and other.read_text() == "# my notes\n"
    assert "not an output" in capsys.readouterr().err


def test_evaluate_test_set_percent_data_refused(tmp_path, capsys):
    w = np.arange(380, 781, 10)
    pct = tmp_path / "percent.csv"
    rows = "".join(f"s{i}," + ",".join(f"{40 + i + 0.05 * x:.2f}" for x in w) + "\n" for i in range(3))
    pct.write_text("name," + ",".join(map(str, w)) + "\n" + rows)
    rc = zonotope_main(
        [
            "evaluate",
            "--camera",
            "Nikon 5100 (NPL)",
            "--test-set",
            str(pct),
            "--atypical",
            "0",
            "--size",
            "5",
        ]
    )
    err = capsys.readouterr().err
    assert rc == 2 and "percent" in err and "100" in err


BAD_CLI = [
    ["evaluate", "--camera", "Nikon 5100 (NPL)", "--interval", "-5"],
    ["evaluate", "--camera", "Nikon 5100 (NPL)", "--interval", "0"],
    ["evaluate", "--camera", "Nikon 5100 (NPL)", "--interval", "nan"],
    ["evaluate", "--camera", "Nikon 5100 (NPL)", "--start", "inf"],
    ["evaluate", "--camera", "Nikon 5100 (NPL)", "--start", "-400"],
    ["evaluate", "--camera", "Nikon 5100 (NPL)", "--start", "700", "--end", "400"],
    ["report", "--camera", "Nikon 5100 (NPL)", "-o", "x", "--end", "inf"],
    ["summary", "--camera", "Nikon 5100 (NPL)", "--start", "400", "--interval", "-1"],
    ["evaluate", "--camera", "Nikon 5100 (NPL)", "--atypical", "-3"],
    ["evaluate", "--camera", "Nikon 5100 (NPL)", "--size", "0"],
    ["evaluate", "--camera", "Nikon 5100 (NPL)", "--noise", "-1"],
    ["evaluate", "--camera", "nope.png"],
    ["summary", "--camera", "bogus"],
]


@pytest.mark.parametrize("argv", BAD_CLI, ids=[" ".join(a[2:]) for a in BAD_CLI])
def test_cli_bad_options_one_line_exit_2(argv, capsys, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    assert zonotope_main(argv) == 2
    err = capsys.readouterr().err
    assert err.startswith("zonotope: error: ") and len(err.strip().splitlines()) == 1, err


def test_cli_binary_camera_file_one_line(tmp_path, capsys):
    png = tmp_path / "camera.csv"
    png.write_bytes(b"\x89PNG\r\n\x1a\n\x00\x00\x00\rIHDR" + bytes(range(256)))
    assert zonotope_main(["evaluate", "--camera", str(png)]) == 2
    err = capsys.readouterr().err
    assert "not a text file" in err and len(err.strip().splitlines()) == 1


# ---- loaders: nothing dropped, nothing mislabelled --------------------------------------------------


def _csv(rows: list[str]) -> str:
    return "wavelength,R,G,B\n" + "\n".join(rows) + "\n"


GOOD_ROWS = [f"{w},{0.1 + w / 1e4:.4f},{0.2:.4f},{0.3 + w / 2e4:.4f}" for w in range(400, 701, 5)]


def test_malformed_csv_row_raises_instead_of_changing_the_grid(tmp_path):
    rows = list(GOOD_ROWS)
    rows[3] = "415,0.1,0.2"  # a missing cell: this row used to vanish (grid 5 → 10 nm here)
    p = tmp_path / "cam.csv"
    p.write_text(_csv(rows))
    with pytest.raises(SpectralDataError, match="line 5 has 3 values"):
        zonotope.load_camera(p)
    rows[3] = "415,0.1,0.2,abc"
    p.write_text(_csv(rows))
    with pytest.raises(SpectralDataError, match="not a number"):
        zonotope.load_camera(p)
    p.write_text(_csv(GOOD_ROWS))
    assert np.all(np.diff(zonotope.load_camera(p).wavelengths) == 5)


def test_dcamprof_labels_follow_the_keys(tmp_path):
    p = tmp_path / "cam.json"
    p.write_text(
        json.dumps(
            {
                "camera_name": "x",
                "ssf_bands": [400, 410, 420],
                "red_ssf": [1, 0.5, 0.1],
                "blue_ssf": [0.1, 0.5, 1],
            }
        )
    )
    cam = zonotope.load_camera(p)
    assert list(cam.labels) == ["red", "blue"]  # blue was labelled "green"
    np.testing.assert_array_equal(cam.values[:, 1], [0.1, 0.5, 1])


@pytest.mark.parametrize(
    "doc",
    [
        [1, 2],
        "text",
        3,
        None,
        {"spectral_data": {}},
        {"spectral_data": {"data": {"main": {"400": [1]}}}},
        {"spectral_data": {"index": {"main": ["a"]}, "data": {"main": {"400": [1, 2]}}}},
        {"spectral_data": {"index": {"main": ["a"]}, "data": {"main": {"x": [1]}}}},
        {"spectral_data": {"index": {"main": ["a"]}, "data": {"main": [1, 2]}}},
        {"spectral_data": {"index": {"main": ["a", "b"]}, "data": {"main": {"400": [1, 2], "410": [1]}}}},
        {"ssf_bands": [400, 410], "red_ssf": [1]},
        {"ssf_bands": "abc", "red_ssf": [1, 2, 3]},
        {"ssf_bands": [400, 410]},
        {"ssf_bands": [400, 410], "red_ssf": {"a": 1}},
    ],
)
def test_json_of_the_wrong_shape(tmp_path, doc):
    p = tmp_path / "x.json"
    p.write_text(json.dumps(doc))
    with pytest.raises(SpectralDataError):
        zonotope.load_camera(p)
    with pytest.raises(SpectralDataError):
        zonotope.load_reflectances(p)


@pytest.mark.parametrize("name", ["cam.csv", "cam.json", "cam.png", "refl.reflect"])
def test_binary_file_given_as_spectra(tmp_path, name):
    p = tmp_path / name
    p.write_bytes(b"\x89PNG\r\n\x1a\n\x00\x00\x00\rIHDR" + bytes(range(256)) * 4)
    with pytest.raises(SpectralDataError, match="not a text file"):
        zonotope.load_camera(p)
    with pytest.raises(SpectralDataError, match="not a text file"):
        zonotope.load_reflectances(p)


_BASE = _csv(GOOD_ROWS[:20]).encode()
FUZZ_COUNT = {"spectra": 0}


@settings(max_examples=150, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(st.data())
def test_fuzz_spectra_loaders(tmp_path_factory, data):
    """Byte edits, truncations and insertions of a valid table (CSV, JSON, SFU): every outcome is a
    curve with a strictly increasing grid and finite values, or a SpectralDataError."""
    kind = data.draw(st.sampled_from(["csv", "json", "reflect"]))
    if kind == "csv":
        base = _BASE
    elif kind == "json":
        base = json.dumps(
            {
                "ssf_bands": list(range(400, 460, 10)),
                "red_ssf": [0.1] * 6,
                "green_ssf": [0.2] * 6,
                "blue_ssf": [0.3] * 6,
            }
        ).encode()
    else:
        base = (
            b"\n".join(b"%.3f" % (0.1 + i / 100) for i in range(101))
            + b"\n\n"
            + b"\n".join(b"%.3f" % (0.5 - i / 1000) for i in range(101))
            + b"\n"
        )
    b = bytearray(base)
    for _ in range(data.draw(st.integers(1, 4))):
        op = data.draw(st.sampled_from(["flip", "cut", "insert", "delete"]))
        i = data.draw(st.integers(0, max(len(b) - 1, 0)))
        if op == "flip" and b:
            b[i] = data.draw(st.sampled_from([*b",.-e\n\x00 9a\xc3\xa9#;", data.draw(st.integers(0, 255))]))
        elif op == "cut":
            del b[i:]
        elif op == "insert":
            b[i:i] = data.draw(
                st.sampled_from([b",", b"\n", b"nan", b"inf", b"-1", b"1e400", b"\xff\xfe", b'"', b"{", b"]"])
            )
        elif b:
            del b[i]
    p = tmp_path_factory.mktemp("fz") / f"f.{kind}"
    p.write_bytes(bytes(b))
    FUZZ_COUNT["spectra"] += 1
    for load in (zonotope.load_camera, zonotope.load_reflectances):
        try:
            curve = load(p)
        except SpectralDataError:
            continue
        w = np.asarray(curve.wavelengths)
        assert np.all(np.diff(w) > 0) and np.all(np.isfinite(curve.values))


# ---- silent wrong numbers --------------------------------------------------------------------------


def test_vora_nan_channel_raises():
    X = np.random.default_rng(0).random((31, 3))
    Q = np.concatenate([X, X[:, :1]], axis=1)
    Q[4, 3] = np.nan  # used to be dropped: a value was returned as if the channel did not exist
    with pytest.raises(SpectralDataError, match=r"channels \[3\]"):
        zonotope.vora_value(Q, X)
    with pytest.raises(SpectralDataError, match="NaN or inf"):
        zonotope.vora_value(X, np.where(X > 0.5, np.inf, X))


@pytest.mark.parametrize(("scale", "k"), [(1e100, 3), (1e90, 4), (1e60, 6), (1e149, 3)])
def test_huge_generators_refused_not_inf_volume(scale, k):
    G = np.random.default_rng(0).random((40, k)) * scale
    with pytest.raises(GeometryError, match="overflow"):
        zonotope.Zonotope(G)


def test_large_but_representable_generators_keep_a_finite_volume():
    G = np.random.default_rng(0).random((40, 3)) * 1e90
    v = zonotope.Zonotope(G).volume
    assert np.isfinite(v) and v == pytest.approx(zonotope.Zonotope(G / 1e90).volume * 1e270, rel=1e-9)


# ---- bounded memory --------------------------------------------------------------------------------


def test_mmv_batch_streams_in_bounded_memory():
    """A batch's working memory does not grow with its size: the batch is aborted after its first
    chunk (progress raising) and the peak of Python-tracked allocations compared for 10³ and 10⁶
    responses (the 10⁶ input alone is 24 MB; it was allocated all at once: 78.5 GiB at 10⁷)."""
    from zonotope.mismatch import metamer_mismatch_batch

    grid = np.arange(400.0, 701.0, 30.0)
    Phi = zonotope.generators("Nikon 5100 (NPL)", "D65", grid).values
    Psi = zonotope.generators("CIE 1931 2 Degree Standard Observer", "D65", grid).values

    class Stop(Exception):
        pass

    def stop(stage, done, total):
        raise Stop

    with pytest.raises(Stop):  # compile the numba kernels first: tracing the JIT takes ~100 s
        metamer_mismatch_batch(Phi, Psi, np.tile(0.4 * Phi.sum(axis=0), (4, 1)), chunk=2, progress=stop)
    peaks = []
    for n in (1_000, 1_000_000):
        C = np.tile(0.4 * Phi.sum(axis=0), (n, 1))
        tracemalloc.start()
        with pytest.raises(Stop):
            metamer_mismatch_batch(Phi, Psi, C, chunk=2, outer=False, progress=stop)
        peaks.append(tracemalloc.get_traced_memory()[1])
        tracemalloc.stop()
    assert peaks[1] < 4 * peaks[0] + 8e6, peaks  # (the finiteness check reads 3 MB of booleans)


def test_every_error_is_a_zonotope_error():
    for exc in (SpectralDataError, GeometryError, OutputExistsError):
        assert issubclass(exc, ZonotopeError)


def test_correct_image_cache_path_problems(tmp_path):
    """A cache_dir that is a file is a project error (was FileExistsError); a damaged cache file is
    rebuilt, not trusted; saving leaves no temporary."""
    from zonotope.correct import correction_problem, fit_correction
    from zonotope.correct.image import correct_image

    grid = np.arange(400.0, 701.0, 20.0)
    problem = correction_problem("Nikon 5100 (NPL)", shape=grid)
    est = fit_correction(problem, method="least squares")
    img = np.random.default_rng(0).uniform(0.05, 0.3, (3, 4, 3))
    blocker = tmp_path / "cache"
    blocker.write_text("a file")
    with pytest.raises(OutputExistsError, match="is a file"):
        correct_image(img, est, cache_dir=blocker)
    est = fit_correction(problem, method="MAP")  # not closed-form: results go through the cache
    folder = tmp_path / "c"
    first = correct_image(img, est, cache_dir=folder)
    (npz,) = folder.iterdir()
    npz.write_bytes(npz.read_bytes()[:50])  # a damaged cache
    np.testing.assert_array_equal(correct_image(img, est, cache_dir=folder), first)
    assert [p.name for p in folder.iterdir()] == [npz.name]


# ---------------------------------------------------------------------------------------------
# Bad arguments to the public functions of spectra, vora, macadam, profile, survey (issue 13
# item 8): a project error naming the argument, never numpy's raw ValueError/TypeError/
# AttributeError or a FileNotFoundError that is not a project error.
# ---------------------------------------------------------------------------------------------


CAM = "Nikon 5100 (NPL)"
GRID = np.arange(400.0, 701.0, 10.0)


def _lut():
    return zonotope.correction_LUT(lambda c: c, size=3, space="XYZ")


@functools.cache
def _problem():
    return zonotope.correction_problem(CAM, shape=GRID)


def _matrix():
    return zonotope.fit_correction(_problem(), method="matrix")


BAD_CALLS = {
    "resample(str)": (
        lambda: zonotope.resample("nonsense", np.arange(400, 701, 10.0)),
        "SpectralDistribution",
    ),
    "vora_value(ragged)": (lambda: zonotope.vora_value([[1, 2], [3]], np.eye(3)), "Q: expected an array"),
    "projector(str)": (lambda: zonotope.vora.projector("ab"), "A: expected an array"),
    "macadam_limits(str)": (lambda: zonotope.macadam_limits("a"), "Y must lie"),
    "macadam_limits(True)": (lambda: zonotope.macadam_limits(True), "Y must lie"),
    "is_object_colour(str)": (lambda: zonotope.is_object_colour("abc"), "XYZ: expected an array"),
    "invert(str)": (lambda: zonotope.invert("abc"), "points: expected an array"),
    "section(str normal)": (
        lambda: zonotope.section(zonotope.object_colour_solid(), "ab", 0.5),
        "normal: expected an array",
    ),
    "load_correction(missing)": (lambda: zonotope.load_correction("/nonexistent/x.npz"), "not found"),
    "correction_LUT(text output)": (lambda: zonotope.correction_LUT(lambda c: "x", size=3), "output"),
    "correction_LUT(wrong shape)": (lambda: zonotope.correction_LUT(lambda c: c[:, :2], size=3), "(N, 3)"),
    "correction_LUT(not callable)": (lambda: zonotope.correction_LUT(3, size=3), "callable"),
    "apply_correction_LUT(str)": (lambda: zonotope.apply_correction_LUT(_lut(), "abc"), "rgb"),
    "apply_correction_LUT(2 channels)": (lambda: zonotope.apply_correction_LUT(_lut(), [[1, 2]]), "rgb"),
    "fit_correction(text training)": (
        lambda: zonotope.fit_correction(CAM, method="matrix", shape=GRID, training=[["a"]]),
        "training: expected an array",
    ),
    "fit_correction(problem + training)": (  # was silently ignored
        lambda: zonotope.fit_correction(_problem(), method="matrix", training="CIE 1995 TCS"),
        "training given with a CorrectionProblem",
    ),
    "correct_image(str)": (lambda: zonotope.correct_image("abc", _matrix()), "image: expected an array"),
    "correct_image(ragged)": (
        lambda: zonotope.correct_image([[1, 2, 3], [1, 2]], _matrix()),
        "image: expected an array",
    ),
    "Zonotope(str)": (lambda: zonotope.Zonotope("abc"), "generators: expected an array"),
    "Zonotope(ragged)": (lambda: zonotope.Zonotope([[1, 2, 3], [1, 2]]), "generators: expected an array"),
    "Zonotope.contains(str)": (lambda: zonotope.Zonotope(np.eye(3)).contains("abc"), "points: expected"),
    "Polytope(ragged)": (lambda: zonotope.Polytope([[1, 2, 3], [1, 2]]), "points: expected an array"),
    "metamer_mismatch(ragged Phi)": (
        lambda: zonotope.metamer_mismatch([[1, 2], [1]], np.eye(2), [0.5, 0.5]),
        "Phi: expected an array",
    ),
    "metamer_mismatch(str response)": (
        lambda: zonotope.metamer_mismatch(np.eye(3), np.eye(3), "ab"),
        "response: expected an array",
    ),
    "metamer_mismatch_batch(str)": (
        lambda: zonotope.metamer_mismatch_batch(np.eye(3), np.eye(3), "ab"),
        "responses: expected an array",
    ),
    "mmv_contains(str)": (
        lambda: zonotope.mmv_contains(np.eye(3), np.eye(3), "ab", [0.1, 0.1, 0.1]),
        "responses: expected an array",
    ),
    "correct_image(quantum < 0)": (
        lambda: zonotope.correct_image(np.zeros((2, 2, 3)), _matrix(), quantum=-1),
        "quantum=-1",
    ),
}


@pytest.mark.parametrize("name", list(BAD_CALLS))
def test_bad_arguments_raise_project_errors(name):
    call, match = BAD_CALLS[name]
    with pytest.raises(ZonotopeError, match=match):
        call()


def test_missing_saved_correction_is_still_a_file_not_found_error():
    with pytest.raises(FileNotFoundError):
        zonotope.load_correction("/nonexistent/x.npz")


def test_survey_table_formats_and_outputs_are_checked_before_the_work(tmp_path, capsys):
    from zonotope.survey import write_table

    with pytest.raises(ZonotopeError, match=r"\.csv or \.parquet"):
        write_table([], tmp_path / "t.xlsx")  # was written as CSV under the .xlsx name
    assert list(tmp_path.iterdir()) == []
    cams = "Nikon 5100 (NPL),Canon EOS 5D Mark II"
    base = ["survey", "--cameras", cams, "--scheduler", "serial", "-q", "--partners", "0"]
    assert zonotope_main([*base, "-o", str(tmp_path / "t.xlsx")]) == 2
    other = tmp_path / "notes.csv"
    other.write_text("my,own\n1,2\n")
    t0 = time.perf_counter()
    assert zonotope_main([*base, "-o", str(other), "--force"]) == 2  # never a file it did not write
    assert time.perf_counter() - t0 < 5 and other.read_text() == "my,own\n1,2\n"
    err = capsys.readouterr().err
    assert "not an output of this command" in err and "Traceback" not in err
    table = tmp_path / "t.csv"
    assert zonotope_main([*base, "-o", str(table)]) == 0
    before = table.read_text()
    assert zonotope_main([*base, "-o", str(table)]) == 2  # a previous table only with --force
    assert table.read_text() == before and "--force" in capsys.readouterr().err
    assert zonotope_main([*base, "-o", str(table), "--force"]) == 0  # a previous table is replaced
    assert table.read_text().startswith("rank,cameras,")
