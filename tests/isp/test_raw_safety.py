"""isp data safety: RAW reading never hands back uninitialised memory; damaged RAW/DNG files give a
RawFormatError and nothing else (hypothesis: truncated and byte-flipped copies); image writes are
atomic, leave no temporary after Ctrl-C or SIGKILL and get umask permissions; the CLI answers in one
line."""

from __future__ import annotations

import os
import shutil
import signal
import stat
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest
import tifffile
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from isp import RawFormatError, read_raw, write_image
from isp.dng import write_dng

ROOT = Path(__file__).resolve().parents[2]
CM = np.array([[0.8, -0.2, -0.05], [-0.3, 1.1, 0.2], [-0.05, 0.15, 0.6]])


@pytest.fixture(scope="module")
def sim_dng(tmp_path_factory) -> Path:
    """A small uncompressed DNG written by isp (runs without the shared data)."""
    m = np.random.default_rng(0).integers(200, 3900, (48, 64)).astype(np.uint16)
    return write_dng(
        tmp_path_factory.mktemp("sim") / "sim.dng",
        m,
        cfa="RGGB",
        black_level=128,
        white_level=4000,
        color_matrix_1=CM,
        as_shot_neutral=[0.5, 1.0, 0.7],
    )


def _set_compression(src: Path, dst: Path, value: int) -> Path:
    shutil.copyfile(src, dst)
    with tifffile.TiffFile(dst) as tif:
        pages = [tif.pages[0], *(getattr(tif.pages[0], "pages", None) or [])]
        offsets = [p.tags[259].valueoffset for p in pages if 259 in p.tags]
        order = tif.byteorder
    with open(dst, "r+b") as fh:
        for off in offsets:
            fh.seek(off)
            fh.write(value.to_bytes(2, "little" if order == "<" else "big"))
    return dst


def _compression7_never_returns_garbage(src: Path, tmp_path: Path) -> None:
    bad = _set_compression(src, tmp_path / "c7.dng", 7)
    read_raw(src)  # leaves LibRaw's freed buffer with real pixels in the heap
    for _ in range(3):  # used to raise only the first time, then return leftover heap memory
        with pytest.raises(RawFormatError, match="JPEG marker"):
            read_raw(bad)
    assert read_raw(bad, metadata_only=True).mosaic.shape  # metadata stay readable


def test_compression_7_real_550d(dng_550d, tmp_path):
    _compression7_never_returns_garbage(dng_550d, tmp_path)


def test_compression_7_simulated(sim_dng, tmp_path):
    _compression7_never_returns_garbage(sim_dng, tmp_path)


@pytest.mark.parametrize("value", [2, 5, 8, 34713, 65535])
def test_unknown_or_mismatched_compression(sim_dng, tmp_path, value):
    bad = _set_compression(sim_dng, tmp_path / "c.dng", value)
    with pytest.raises(RawFormatError):
        read_raw(bad)


FUZZ_COUNT = {"raw": 0}


def _fuzz(src: Path, data, tmp: Path) -> None:
    blob = src.read_bytes()
    ref = read_raw(src).mosaic
    b = bytearray(blob)
    truncated = data.draw(st.booleans())
    if truncated:
        del b[data.draw(st.integers(0, len(b) - 1)) :]
    else:
        header = data.draw(st.booleans())  # mostly the IFDs and tags, sometimes the pixels
        for _ in range(data.draw(st.integers(1, 8))):
            i = data.draw(st.integers(0, min(len(b), 4096) - 1 if header else len(b) - 1))
            b[i] = data.draw(st.integers(0, 255))
    p = tmp / "f.dng"
    p.write_bytes(bytes(b))
    FUZZ_COUNT["raw"] += 1
    try:
        raw = read_raw(p)
    except RawFormatError:
        return
    assert raw.mosaic.dtype == np.uint16 and raw.mosaic.ndim == 2
    if truncated and raw.mosaic.shape == ref.shape:
        # whatever a truncated file still yields must be its own pixels, never stale memory
        np.testing.assert_array_equal(raw.mosaic, ref)


def test_damaged_photometric_tag_is_a_format_error(sim_dng, tmp_path):
    """The fuzz test below found it: byte 74 of this DNG set to 0 gives PhotometricInterpretation a
    tuple value, and int() raised a raw TypeError out of read_dng_tags."""
    b = bytearray(sim_dng.read_bytes())
    b[74] = 0
    bad = tmp_path / "bad.dng"
    bad.write_bytes(bytes(b))
    with pytest.raises(RawFormatError, match=r"bad\.dng"):  # a project error naming the file
        read_raw(bad)


@settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(data=st.data())
def test_fuzz_simulated_dng(sim_dng, tmp_path, data):
    _fuzz(sim_dng, data, tmp_path)


@settings(max_examples=25, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(data=st.data())
def test_fuzz_real_550d_dng(dng_550d, tmp_path, data):
    _fuzz(dng_550d, data, tmp_path)


# ---- image output ---------------------------------------------------------------------------------


def test_write_image_ctrl_c_leaves_no_temporary(tmp_path, monkeypatch):
    import isp.io

    dest = tmp_path / "out.png"
    write_image(dest, np.full((4, 5, 3), 0.5))
    good = dest.read_bytes()

    def interrupted(img):
        raise KeyboardInterrupt

    monkeypatch.setattr(isp.io, "_png_bytes", interrupted)
    with pytest.raises(KeyboardInterrupt):
        write_image(dest, np.zeros((4, 5, 3)), overwrite=True)
    assert dest.read_bytes() == good
    assert sorted(p.name for p in tmp_path.iterdir()) == ["out.png"]  # no *.png.tmp orphan


def test_write_image_permissions_follow_umask(tmp_path):
    old = os.umask(0o022)
    try:
        for name in ("a.png", "a.tif"):
            write_image(tmp_path / name, np.full((4, 5, 3), 0.25))
            assert stat.S_IMODE((tmp_path / name).stat().st_mode) == 0o644  # was 0600
    finally:
        os.umask(old)


# bare package objects skip the package __init__s (isp, zonotope): the writer starts in ~0.2 s
_WRITER = """
import sys, types
for name in ("zonotope", "isp"):
    pkg = types.ModuleType(name)
    pkg.__path__ = [name]
    sys.modules[name] = pkg
    if name == "zonotope":
        import zonotope._errors
        import zonotope.utilities.io
        vars(pkg).update({k: v for k, v in vars(zonotope._errors).items() if k.endswith("Error")})
        vars(pkg).update({k: getattr(zonotope.utilities.io, k) for k in zonotope.utilities.io.__all__})
import numpy as np
from isp.io import write_image
dest = sys.argv[1]
img = np.random.default_rng(0).random((600, 800, 3))
i = 0
while True:
    i += 1
    write_image(dest, img * (i % 2), overwrite=True)
    print(i, flush=True)
"""


IMAGE_KILL_DELAYS = (0.0, 0.01, 0.03, 0.06, 0.1, 0.15)


def test_sigkill_mid_image_write(tmp_path):
    """6 SIGKILLs of a process rewriting a 16-bit PNG: the file always decodes to one of the two
    images, and the next write removes the dead writer's temporary."""
    dest = tmp_path / "out.png"
    hits = 0
    for delay in IMAGE_KILL_DELAYS:
        proc = subprocess.Popen(
            [sys.executable, "-c", _WRITER, str(dest)],
            stdout=subprocess.PIPE,
            stderr=subprocess.DEVNULL,
            cwd=ROOT,
        )
        assert proc.stdout.readline()
        time.sleep(delay)
        proc.send_signal(signal.SIGKILL)
        proc.wait()
        import zlib

        data = dest.read_bytes()
        assert data[:8] == b"\x89PNG\r\n\x1a\n" and data.endswith(b"IEND\xaeB`\x82")
        idat = data[data.index(b"IDAT") + 4 : data.rindex(b"IEND") - 8]
        assert len(zlib.decompress(idat)) == 600 * (1 + 800 * 6)
        from zonotope.utilities.io import clean_stale_temporaries

        hits += bool(clean_stale_temporaries(dest))
        assert sorted(p.name for p in tmp_path.iterdir()) == ["out.png"]
    print(f"{hits} of {len(IMAGE_KILL_DELAYS)} kills landed mid-write")


def test_isp_cli_errors_are_one_line(tmp_path, capsys, sim_dng):
    from isp.cli import main

    bad = _set_compression(sim_dng, tmp_path / "bad.dng", 7)
    cases = [
        ["develop", str(bad), "-o", str(tmp_path / "o.tif")],
        ["develop", str(tmp_path / "missing.dng"), "-o", str(tmp_path / "o.tif")],
        ["develop", str(sim_dng), "-o", str(sim_dng), "--overwrite"],
    ]
    for argv in cases:
        assert main(argv) == 2, argv
        err = capsys.readouterr().err
        errors = [line for line in err.splitlines() if not line.startswith("[")]  # progress lines
        assert len(errors) == 1 and errors[0].startswith("isp: error: ") and "Traceback" not in err, err
    assert not (tmp_path / "o.tif").exists()


def test_isp_develop_checks_the_output_before_the_work(tmp_path, capsys, sim_dng):
    from isp.cli import main

    bad = _set_compression(sim_dng, tmp_path / "bad.dng", 7)
    out = tmp_path / "out.tif"
    out.write_bytes(b"my earlier edit")
    assert main(["develop", str(bad), "-o", str(out), "-q"]) == 2
    err = capsys.readouterr().err
    assert "exists" in err and "JPEG" not in err  # refused before the RAW was even read
    assert out.read_bytes() == b"my earlier edit"


def test_full_colour_linear_raw_is_a_project_error(tmp_path):
    rgb = np.full((24, 32, 3), 1000, dtype=np.uint16)
    path = write_dng(
        tmp_path / "foveon.dng",
        rgb,
        cfa="RGGB",
        black_level=0,
        white_level=4095,
        color_matrix_1=CM,
        as_shot_neutral=[0.5, 1.0, 0.7],
    )
    with pytest.raises(RawFormatError, match="no CFA mosaic"):
        read_raw(path)


@pytest.mark.parametrize("suffix", [".png", ".tif"])
def test_overwrite_replaces_only_a_previous_isp_output(tmp_path, suffix):
    from isp import PipelineError

    img = np.full((4, 5, 3), 0.5)
    ours = write_image(tmp_path / f"ours{suffix}", img)
    write_image(ours, np.zeros_like(img), overwrite=True)  # a previous output of ours: replaced when asked
    if suffix == ".tif":
        assert not np.any(tifffile.imread(ours))
    magic = b"\x89PNG\r\n\x1a\n" if suffix == ".png" else b"II*\x00"
    user = tmp_path / f"user{suffix}"
    user.write_bytes(magic + bytes(64))  # the user's own file (not written by isp)
    with pytest.raises(PipelineError, match="not written by isp"):
        write_image(user, img, overwrite=True)
    assert user.read_bytes() == magic + bytes(64)
