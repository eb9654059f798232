"""``isp develop DIR -o OUTDIR``: folder batches (serial and on a real Dask cluster with a killed worker).

The RAW files are simulated DNGs (isp.simulate), so these tests need no shared data; each output
must equal, byte for byte, what the single-file command writes for that file.
"""

from __future__ import annotations

import csv
import hashlib
from pathlib import Path

import numpy as np
import pytest

from isp import default_pipeline
from isp.cli import main


@pytest.fixture(scope="module")
def dng_folder(tmp_path_factory):
    """Four small simulated DNGs (different ColorChecker arrangements and exposures) and a corrupt one."""
    import zonotope
    from isp.simulate import chart_image, simulate_capture, simulate_dng, spectral_setup

    d = tmp_path_factory.mktemp("raws")
    setup = spectral_setup("Nikon 5100 (NPL)")
    R = zonotope.resample(zonotope.reflectances("ColorChecker N Ohta"), setup.wavelengths).T.clip(0, 1)
    for i in range(4):
        order = np.random.default_rng(i).permutation(24)
        image, _ = chart_image(R[order], rows=4, cols=6, patch=6, gap=2)
        cap = simulate_capture(image, setup, training=R, exposure=0.5 + 0.05 * i, seed=i)
        simulate_dng(d / f"shot{i}.dng", cap, model="Nikon 5100 (NPL)")
    (d / "broken.dng").write_bytes(b"II*\x00" + b"\x00" * 60)
    (d / "notes.txt").write_text("not a RAW file: ignored")
    return d


def _digest(folder: Path) -> dict:
    """SHA-256 of every file; of the decoded pixels for TIFFs (their ICC profile carries a creation time)."""
    import tifffile

    return {
        p.name: hashlib.sha256(
            tifffile.imread(p).tobytes() if p.suffix == ".tif" else p.read_bytes()
        ).hexdigest()
        for p in sorted(folder.iterdir())
        if p.is_file()  # not the batch's record of what it wrote
    }


@pytest.fixture(scope="module")
def singles(dng_folder, tmp_path_factory):
    """Each good file developed alone by the single-file command: the expected bytes."""
    out = tmp_path_factory.mktemp("singles")
    for f in sorted(dng_folder.glob("shot*.dng")):
        assert main(["develop", str(f), "-o", str(out / f"{f.stem}.tif"), "-q"]) == 0
    return _digest(out)


def _manifest(folder: Path) -> list[dict]:
    with open(folder / "manifest.csv", newline="") as fh:
        return list(csv.DictReader(fh))


def test_folder_serial_resume_and_bad_file(dng_folder, singles, tmp_path):
    before = _digest(dng_folder)
    out = tmp_path / "dev"
    assert main(["develop", str(dng_folder), "-o", str(out), "--scheduler", "serial", "-q"]) == 1  # one bad
    rows = _manifest(out)
    assert [Path(r["input"]).name for r in rows] == ["broken.dng"] + [f"shot{i}.dng" for i in range(4)]
    assert [r["status"] for r in rows] == ["failed"] + ["ok"] * 4 and rows[0]["error"]
    got = _digest(out)
    manifests = ("manifest.csv", "manifest.settings.json")
    assert {k: v for k, v in got.items() if k not in manifests} == singles  # identical to single files
    assert main(["develop", str(dng_folder), "-o", str(out), "--scheduler", "serial", "-q"]) == 1  # rerun
    assert [r["status"] for r in _manifest(out)] == ["failed"] + ["done"] * 4
    assert _digest(dng_folder) == before  # inputs never touched
    assert main(["develop", str(dng_folder), "-o", str(dng_folder), "-q"]) == 2
    assert main(["develop", str(dng_folder), "-o", str(out), "--overwrite", "-q"]) == 2
    assert main(["develop", str(tmp_path / "nothing_here"), "-o", str(out), "-q"]) == 2


def test_develop_folder_library_call(dng_folder, singles, tmp_path):
    """The library function takes a Pipeline and plain values, reports through a callback, prints nothing."""
    from isp import PipelineError
    from isp.batch import develop_folder

    out, calls = tmp_path / "lib", []
    rows = develop_folder(
        dng_folder,
        out,
        pipeline=default_pipeline(),
        executor="serial",
        progress=lambda description, done, total: calls.append((description, done, total)),
    )
    assert [r["status"] for r in rows] == ["failed"] + ["ok"] * 4
    assert calls[0] == ("developing (serial)", 0, 5) and calls[-1][1:] == (5, 5)
    assert {k: v for k, v in _digest(out).items() if k.endswith(".tif")} == singles
    with pytest.raises(PipelineError, match="another folder than the input"):
        develop_folder(dng_folder, dng_folder, pipeline=default_pipeline())


def test_folder_progress_is_plain_lines_when_piped(dng_folder, tmp_path, capsys):
    """A folder batch drew rich's bar even when stderr was a log file (only its last frame landed
    there, as 'developing ━━━ 3/3'); now plain timed lines, as the single-file command prints."""
    raws = tmp_path / "raws"
    raws.mkdir()
    (raws / "shot0.dng").write_bytes((dng_folder / "shot0.dng").read_bytes())
    assert main(["develop", str(raws), "-o", str(tmp_path / "dev"), "--scheduler", "serial"]) == 0
    err = capsys.readouterr().err
    assert "s] developing (serial)" in err and "developing (serial): 1/1" in err and "━" not in err


def test_folder_never_replaces_nor_counts_a_users_files(dng_folder, tmp_path, capsys):
    """A user's ``manifest.csv`` in OUT was replaced, and a user's file with an output's name was
    counted ``done``; both are now refused in one line before any work, and left as they were."""
    raws = tmp_path / "raws"
    raws.mkdir()
    for name in ("shot0.dng", "shot1.dng"):
        (raws / name).write_bytes((dng_folder / name).read_bytes())
    run = ["develop", str(raws), "--scheduler", "serial", "-q", "-o"]

    theirs = tmp_path / "theirs"
    theirs.mkdir()
    (theirs / "manifest.csv").write_text("my,own,notes\n")
    assert main([*run, str(theirs)]) == 2
    err = capsys.readouterr().err
    assert "manifest.csv was not written by a folder batch" in err and len(err.strip().splitlines()) == 1
    assert (theirs / "manifest.csv").read_text() == "my,own,notes\n"
    assert sorted(p.name for p in theirs.iterdir()) == ["manifest.csv"]

    named = tmp_path / "named"
    named.mkdir()
    (named / "shot0.tif").write_bytes(b"a picture of mine")
    assert main([*run, str(named)]) == 2
    assert "shot0.tif exists but was not written by this batch" in capsys.readouterr().err
    assert sorted(p.name for p in named.iterdir()) == ["shot0.tif"]
    assert (named / "shot0.tif").read_bytes() == b"a picture of mine"

    out = tmp_path / "dev"  # the batch's own outputs still resume ...
    assert main([*run, str(out)]) == 0
    assert main([*run, str(out)]) == 0 and [r["status"] for r in _manifest(out)] == ["done", "done"]
    (out / "shot1.tif").unlink()  # ... and a user's file put in place of one of them is refused
    (out / "shot1.tif").write_bytes(b"another picture of mine")
    assert main([*run, str(out)]) == 2
    assert "shot1.tif exists but was not written by this batch" in capsys.readouterr().err
    assert (out / "shot1.tif").read_bytes() == b"another picture of mine"


@pytest.mark.slow
def test_folder_on_a_cluster_survives_a_killed_worker(dng_folder, singles, tmp_path, dask_cluster):
    from isp.batch import _develop_one, raw_files
    from zonotope.parallel import FileTask, run_files

    dask_cluster.wait_for(2)
    out = tmp_path / "dev"
    out.mkdir()
    tasks = [FileTask(str(f), str(out / f"{f.stem}.tif")) for f in raw_files(dng_folder)]
    killed = []

    def progress(stage, done, total):
        if done == 1 and not killed:
            dask_cluster.kill_worker()
            killed.append(done)

    rows = run_files(
        tasks,
        _develop_one,
        (default_pipeline(), None, None),  # isp develop's defaults: (pipeline, crop, save_stages)
        manifest=out / "manifest.csv",
        scheduler=dask_cluster.address,
        progress=progress,
    )
    assert killed
    said = "\n".join(f"{r['input']}: {r['status']} {r['error']}" for r in rows)  # in full, when it fails
    assert [r["status"] for r in rows] == ["failed"] + ["ok"] * 4, said
    got = _digest(out)
    assert {k: v for k, v in got.items() if k != "manifest.csv"} == singles  # complete, correct, no temps
    assert len(_manifest(out)) == 5
