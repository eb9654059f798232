"""zonotope.parallel: serial / local / running-cluster executors, folder batches with resume and manifest.

The distributed tests run a real ``dask scheduler`` and two ``dask worker`` processes on localhost
(tests/_dask_cluster.py) and SIGKILL one of them mid-batch.
"""

from __future__ import annotations

import csv
import hashlib
import os
import time
from pathlib import Path

import numpy as np
import pytest

from zonotope.mismatch import metamer_mismatch_batch
from zonotope.parallel import (
    BATCH_RECORD,
    ENV_VAR,
    FileTask,
    ParallelError,
    SerialExecutor,
    TaskFailure,
    executor,
    resolve_scheduler,
    run_files,
)
from zonotope.parallel.files import _publish


@pytest.fixture
def cluster(dask_cluster):
    dask_cluster.wait_for(2)
    return dask_cluster


def _square_or_fail(x, offset=0):
    if x == 3:
        raise ValueError("three is bad")
    return x * x + offset


def slow_digest(src: str, tmp: str, delay: float) -> None:
    """A folder-batch task with a known answer: the SHA-256 of the input, after ``delay`` seconds."""
    data = Path(src).read_bytes()
    if data.startswith(b"BAD"):
        raise ValueError(f"{src} is marked bad")
    time.sleep(delay)
    Path(tmp).write_text(hashlib.sha256(data).hexdigest())


def _inputs(folder: Path, n: int, bad: tuple[int, ...] = ()) -> list[FileTask]:
    folder.mkdir()
    out = folder.parent / "out"
    out.mkdir(exist_ok=True)
    tasks = []
    for i in range(n):
        f = folder / f"in{i:02d}.bin"
        f.write_bytes((b"BAD" if i in bad else b"") + os.urandom(64))
        tasks.append(FileTask(str(f), str(out / f"in{i:02d}.txt")))
    return tasks


def test_resolve_scheduler(monkeypatch):
    monkeypatch.delenv(ENV_VAR, raising=False)
    assert resolve_scheduler(None) == "serial"  # size unknown: serial
    assert resolve_scheduler(None, tasks=1) == "serial"
    assert resolve_scheduler("serial", tasks=10**6) == "serial"
    assert resolve_scheduler("local:3") == "local:3"
    assert resolve_scheduler("tcp://10.0.0.1:8786") == "tcp://10.0.0.1:8786"
    assert resolve_scheduler("node7:8786") == "node7:8786"
    monkeypatch.setenv(ENV_VAR, "tcp://example:8786")
    assert resolve_scheduler(None, tasks=1) == "tcp://example:8786"  # the environment wins over size
    assert resolve_scheduler("serial") == "serial"  # the argument wins over the environment
    for bad in ("local:0", "local:x", "nonsense", "", "/no/such/scheduler.json"):
        with pytest.raises(ParallelError, match="scheduler"):
            resolve_scheduler(bad)


def test_serial_executor_outcomes_and_map():
    with executor("serial") as ex:
        assert isinstance(ex, SerialExecutor) and ex.describe().startswith("serial")
        assert list(ex.map(_square_or_fail, [1, 2])) == [1, 4]
        seen = []
        out = dict(
            ex.outcomes(_square_or_fail, range(5), shared=10, progress=lambda *call: seen.append(call))
        )
        assert seen[-1] == ("tasks", 5, 5)
        assert isinstance(out[3], TaskFailure) and "three is bad" in out[3].error
        assert [out[i] for i in (0, 1, 2, 4)] == [10, 11, 14, 26]


def test_unreachable_scheduler_is_a_project_error():
    from .._dask_cluster import _free_port

    pytest.importorskip("distributed")
    with (
        pytest.raises(ParallelError, match="could not reach"),
        executor(f"tcp://127.0.0.1:{_free_port()}", timeout=1),
    ):
        pass


def test_publish_creates_once(tmp_path):
    dest = tmp_path / "a.txt"
    for text, won in (("first", True), ("second", False)):
        tmp = tmp_path / f".a.{text}.part.txt"
        tmp.write_text(text)
        assert _publish(tmp, dest) is won and not tmp.exists()
    assert dest.read_text() == "first"


def test_small_folder_batch_runs_in_this_process(tmp_path, monkeypatch):
    """With no scheduler, fewer than FILE_MIN_TASKS files never start a local cluster (it took 15.6 s
    against 7.3 s serial for 3 RAW files on 2 loaded cores)."""
    import socket

    from zonotope.parallel import FILE_MIN_TASKS

    monkeypatch.delenv(ENV_VAR, raising=False)
    tasks = _inputs(tmp_path / "in", 3)
    assert len(tasks) < FILE_MIN_TASKS
    rows = run_files(tasks, slow_digest, 0.0, manifest=tmp_path / "out" / "manifest.csv")
    assert {r["worker"] for r in rows} == {f"{socket.gethostname()}:{os.getpid()}"}


def test_batch_removes_the_writer_temporaries_of_a_killed_attempt(tmp_path):
    """A worker killed inside the atomic write of its ``.part`` file leaves the writer's own temporary
    (``..shot2.<hex>.part.tif.<pid>.tmp-….tif``); the batch removes it with the ``.part`` files
    (seen once in the killed-worker test of tests/isp/test_batch.py). Other files stay."""
    tasks = _inputs(tmp_path / "in", 2)
    out = Path(tasks[0].output).parent
    out.mkdir(parents=True, exist_ok=True)
    stem = Path(tasks[0].output).stem
    leftovers = [
        out / f"..{stem}.6f412c87b1fb.part.txt.99999999.tmp-mz612eem.txt",  # a file temporary
        out / f"..{stem}.0123456789ab.part.txt.99999998.partial-x1",  # a folder temporary
        out / f".{stem}.abcdefabcdef.part.txt",
    ]
    leftovers[0].write_text("half")
    leftovers[1].mkdir()
    leftovers[2].write_text("half")
    keep = [out / "notes.txt", out / "..other.6f412c87b1fb.part.txt.99999999.tmp-mz612eem.txt"]
    for k in keep:
        k.write_text("mine")
    run_files(tasks, slow_digest, 0.0, manifest=out / "manifest.csv", scheduler="serial")
    assert not any(p.exists() for p in leftovers)
    assert all(k.read_text() == "mine" for k in keep)


def test_a_finished_batch_run_again_starts_no_cluster(tmp_path, monkeypatch):
    """Every output already made: nothing to do, so no executor (no Dask cluster to start and wait for)."""
    import zonotope.parallel.files as files

    tasks = _inputs(tmp_path / "in", 3)
    manifest = tmp_path / "out" / "manifest.csv"
    run_files(tasks, slow_digest, 0.0, manifest=manifest, scheduler="serial")

    def no_executor(*args, **kwargs):
        raise AssertionError("an executor was started with nothing to do")

    monkeypatch.setattr(files, "executor", no_executor)
    again = run_files(tasks, slow_digest, 0.0, manifest=manifest, scheduler="local:2")
    assert [r["status"] for r in again] == ["done"] * 3


def test_run_files_serial_resume_and_manifest(tmp_path):
    tasks = _inputs(tmp_path / "in", 5, bad=(2,))
    before = {t.input: Path(t.input).read_bytes() for t in tasks}
    manifest = tmp_path / "out" / "manifest.csv"
    rows = run_files(tasks, slow_digest, 0.0, manifest=manifest, scheduler="serial")
    assert [r["status"] for r in rows] == ["ok", "ok", "failed", "ok", "ok"]
    assert "marked bad" in rows[2]["error"] and not Path(tasks[2].output).exists()
    for t in tasks[:2] + tasks[3:]:
        assert Path(t.output).read_text() == hashlib.sha256(before[t.input]).hexdigest()
    with open(manifest, newline="") as fh:
        listed = list(csv.DictReader(fh))
    assert [r["input"] for r in listed] == [t.input for t in tasks]
    assert [r["status"] for r in listed] == ["ok", "ok", "failed", "ok", "ok"]
    mtimes = {t.output: os.stat(t.output).st_mtime_ns for t in tasks if Path(t.output).exists()}
    again = run_files(tasks, slow_digest, 0.0, manifest=manifest, scheduler="serial")  # resume
    assert [r["status"] for r in again] == ["done", "done", "failed", "done", "done"]
    assert mtimes == {o: os.stat(o).st_mtime_ns for o in mtimes}  # nothing rewritten
    assert {t.input: Path(t.input).read_bytes() for t in tasks} == before  # inputs untouched
    with pytest.raises(ParallelError, match="one of the inputs"):
        run_files(
            [FileTask(tasks[0].input, tasks[0].input)],
            slow_digest,
            0.0,
            manifest=manifest,
            scheduler="serial",
        )
    with pytest.raises(ParallelError, match=r"in00\.bin and .*in01\.bin would both be written to x\.txt"):
        run_files(
            [FileTask(tasks[0].input, "x.txt"), FileTask(tasks[1].input, "x.txt")],
            slow_digest,
            0.0,
            manifest=manifest,
            scheduler="serial",
        )


@pytest.mark.slow
def test_mmv_batch_on_a_cluster_is_bit_identical(cluster):
    from zonotope.mismatch import MetamerMismatch

    mm = MetamerMismatch("Nikon 5100 (NPL)", shape=np.arange(400.0, 701.0, 10.0))
    rng = np.random.default_rng(1)
    C = mm.source_of(rng.random((16, 31)) * 0.9)
    one = metamer_mismatch_batch(mm.Phi, mm.Psi, C, chunk=4)
    with executor(cluster.address) as ex:
        assert ex.kind == "cluster" and ex.workers == 2
        two = metamer_mismatch_batch(mm.Phi, mm.Psi, C, chunk=4, executor=ex)
        failing = dict(ex.outcomes(_square_or_fail, range(6), shared=1))
    for name in ("centroids", "volumes", "volume_bounds", "centroid_errors", "affine_dims"):
        np.testing.assert_array_equal(getattr(one, name), getattr(two, name))
    assert one.lp_calls == two.lp_calls
    assert isinstance(failing[3], TaskFailure) and "three is bad" in failing[3].error
    assert [failing[i] for i in (0, 1, 2, 4, 5)] == [1, 2, 5, 17, 26]  # the others are not lost


def test_folder_batch_survives_a_killed_worker(cluster, tmp_path):
    tasks = _inputs(tmp_path / "in", 12, bad=(5,))
    manifest = tmp_path / "out" / "manifest.csv"
    killed = []

    def progress(stage, done, total):
        assert stage == "files"
        if done == 2 and not killed:  # mid-run: 10 tasks still queued or running
            cluster.kill_worker()
            killed.append(done)

    rows = run_files(tasks, slow_digest, 0.3, manifest=manifest, scheduler=cluster.address, progress=progress)
    assert killed
    assert [r["status"] for r in rows] == ["ok"] * 5 + ["failed"] + ["ok"] * 6
    for t in tasks:
        if "BAD" not in Path(t.input).read_text(errors="ignore")[:3]:
            assert Path(t.output).read_text() == hashlib.sha256(Path(t.input).read_bytes()).hexdigest()
    out_dir = tmp_path / "out"
    assert sorted(p.name for p in out_dir.iterdir()) == sorted(
        ["manifest.csv", BATCH_RECORD] + [Path(t.output).name for i, t in enumerate(tasks) if i != 5]
    )  # no temporaries
    with open(manifest, newline="") as fh:
        assert len(list(csv.DictReader(fh))) == len(tasks)  # one row per input, each written once


@pytest.mark.slow
def test_zonotope_correct_folder_serial_equals_cluster(cluster, tmp_path):
    """``zonotope correct DIR -o OUT``: one fitted estimator, N-band TIFFs → XYZ; same pixels anywhere."""
    import tifffile

    from zonotope import spectra
    from zonotope.cli import main
    from zonotope.correct import correction_problem, fit_correction

    cams = ["Nikon 5100 (NPL)", "Canon EOS 5D Mark II"]  # a 6-band image, as splat renders one
    problem = correction_problem(cams)
    R = np.clip(spectra.resample(spectra.reflectances("ColorChecker N Ohta"), problem.wavelengths).T, 0, 1)
    src = tmp_path / "renders"
    src.mkdir()
    for i in range(3):
        idx = np.random.default_rng(i).integers(0, 24, (12, 10))
        tifffile.imwrite(
            src / f"view{i}.tif", problem.source_of(R)[idx].astype(np.float32), photometric="minisblack"
        )
    tifffile.imwrite(src / "wrong_bands.tif", np.zeros((4, 4, 3), np.float32), photometric="minisblack")
    before = {p.name: p.read_bytes() for p in src.iterdir()}
    opts = ["--camera", cams[0], "--camera", cams[1], "--method", "Cheung 2004", "-q", "--exact-curves"]
    assert main(["correct", str(src), "-o", str(tmp_path / "a"), "--scheduler", "serial", *opts]) == 1
    assert main(["correct", str(src), "-o", str(tmp_path / "b"), "--scheduler", cluster.address, *opts]) == 1
    est = fit_correction(cams, method="Cheung 2004")
    for i in range(3):
        a = tifffile.imread(tmp_path / "a" / f"view{i}_XYZ.tif")
        np.testing.assert_array_equal(a, tifffile.imread(tmp_path / "b" / f"view{i}_XYZ.tif"))
        img = tifffile.imread(src / f"view{i}.tif").astype(np.float64)
        np.testing.assert_allclose(a, est(img.reshape(-1, 6)).reshape(12, 10, 3), rtol=1e-6, atol=1e-7)
    for d in ("a", "b"):
        with open(tmp_path / d / "manifest.csv", newline="") as fh:
            rows = {Path(r["input"]).name: r for r in csv.DictReader(fh)}
        bad = rows["wrong_bands.tif"]
        assert bad["status"] == "failed" and "(H, W, 6)" in bad["error"]
        assert [rows[f"view{i}.tif"]["status"] for i in range(3)] == ["ok"] * 3
    assert {p.name: p.read_bytes() for p in src.iterdir()} == before
