"""Hostile and degenerate inputs for zonotope: Dask clusters refuse strangers, loaders and solids
bound what they build, and each bad input is one project error that names it."""

from __future__ import annotations

import io
import json
import os
import subprocess
import sys
import time
import tracemalloc
import zipfile

import numpy as np
import pytest

from zonotope import ZonotopeError
from zonotope._errors import GeometryError, SpectralDataError
from zonotope.parallel import SECURITY_ENV_VAR, ParallelError, executor

# --------------------------------------------------------------------------------------------------
# Dask: a local cluster speaks TLS on loopback with its own certificates


def _write_security(path, security) -> None:
    """The client's side of ``security`` as a YAML file (PEM text inline, as ``Security`` accepts)."""
    import yaml

    keys = ("tls_ca_file", "tls_client_cert", "tls_client_key")
    path.write_text(yaml.safe_dump({k: getattr(security, k) for k in keys} | {"require_encryption": True}))


def _stranger(address: str, options: str) -> str:
    """``"connected"`` or ``"refused"``: a client in another process that tries ``address``."""
    code = (
        "import sys\n"
        "from distributed import Client\n"
        "from distributed.security import Security\n"
        "try:\n"
        f"    Client({address!r}, timeout=3, {options})\n"
        "except (OSError, TypeError):\n"
        "    print('refused')\n"
        "else:\n"
        "    print('connected')\n"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)
    return out.stdout.strip().splitlines()[-1] if out.stdout.strip() else f"crashed: {out.stderr[-300:]}"


def test_local_cluster_refuses_an_unauthenticated_client(tmp_path):
    """Given the port, a client without the cluster's certificates is refused; the project's own works."""
    pytest.importorskip("distributed")
    pytest.importorskip("cryptography")
    with executor("local:1") as ex:
        address = ex.client.scheduler.address
        assert address.startswith("tls://127.0.0.1:")
        assert all(w.startswith("tls://127.0.0.1:") for w in ex.client.scheduler_info()["workers"])
        assert set(ex.client.run(os.getpid).values()) != {os.getpid()}  # code runs on its workers
        # each stranger in a fresh process: a refused client leaves Dask's loop state behind in this one
        assert _stranger(address, "") == "refused"  # no certificate at all
        assert _stranger(address, "security=Security.temporary()") == "refused"  # another authority
        assert _stranger(address.replace("tls://", "tcp://"), "") == "refused"  # plain TCP to the TLS port
        # the trust model for running clusters: the right certificates, from a file, are accepted
        _write_security(tmp_path / "sec.yaml", ex.client.security)
        with executor(address, security=tmp_path / "sec.yaml", timeout=10) as other:
            assert other.kind == "cluster" and list(other.map(abs, [-2])) == [2]
        with pytest.raises(ParallelError, match="speaks TLS"), executor(address, timeout=3):
            pass


def test_security_file_errors_name_the_file_and_key(tmp_path, monkeypatch):
    pytest.importorskip("distributed")
    from zonotope.parallel.cluster import _client_security

    bad = tmp_path / "sec.yaml"
    bad.write_text("tls_ca: x\n")
    with pytest.raises(ParallelError, match=r"sec\.yaml.*unknown key.*tls_ca"):
        _client_security(bad)
    bad.write_text("tls_ca_file: missing.pem\n")
    with pytest.raises(ParallelError, match=r"tls_ca_file file missing\.pem does not exist"):
        _client_security(bad)
    bad.write_text("- a list\n")
    with pytest.raises(ParallelError, match="mapping"):
        _client_security(bad)
    monkeypatch.setenv(SECURITY_ENV_VAR, str(tmp_path / "absent.yaml"))
    with pytest.raises(ParallelError, match=SECURITY_ENV_VAR):
        _client_security(None)
    (tmp_path / "ca.pem").write_text("-")
    bad.write_text("tls_ca_file: ca.pem\n")  # relative to the file
    assert _client_security(bad).tls_ca_file == str(tmp_path / "ca.pem")


# --------------------------------------------------------------------------------------------------
# saved corrections: every member checked before it is decompressed, damaged values refused

GRID = np.arange(400.0, 701.0, 10.0)


@pytest.fixture(scope="module")
def saved(tmp_path_factory):
    """A real saved correction (linear, 3 channels) and its members."""
    from zonotope.correct import fit_correction, save_correction

    path = tmp_path_factory.mktemp("saved") / "cheung.npz"
    save_correction(path, fit_correction("Nikon 5100 (NPL)", method="Cheung 2004", shape=GRID))
    with np.load(path) as z:
        members = {name: z[name] for name in z.files}
    return path, members


def _rewrite(path, members, **changes):
    """``members`` with ``changes`` (None removes one) written uncompressed to ``path``."""
    out = {k: v for k, v in {**members, **changes}.items() if v is not None}
    np.savez(path, **out)
    return path


def _meta(members, **changes):
    meta = json.loads(str(members["meta"]))
    return np.array(json.dumps({**meta, **changes}))


def test_load_correction_refuses_an_archive_that_inflates_past_the_bound(tmp_path, saved):
    """A ~1 MB archive declaring more than SAVED_CORRECTION_MAX_BYTES is refused before it is read."""
    from zonotope.correct.profile import SAVED_CORRECTION_MAX_BYTES, load_correction

    path = _rewrite(tmp_path / "bomb.npz", saved[1], Phi=None)
    n = (SAVED_CORRECTION_MAX_BYTES + 2**20) // 8
    with zipfile.ZipFile(path, "a", zipfile.ZIP_DEFLATED, compresslevel=1) as zf:
        with zf.open("Phi.npy", "w", force_zip64=True) as fh:
            np.lib.format.write_array_header_1_0(fh, {"descr": "<f8", "fortran_order": False, "shape": (n,)})
            block = bytes(2**24)
            for _ in range(n * 8 // len(block)):
                fh.write(block)
            fh.write(bytes(n * 8 % len(block)))
    assert path.stat().st_size < 4 * 2**20
    t0 = time.perf_counter()
    with pytest.raises(ZonotopeError, match=r"bomb\.npz: declares .* MiB .*SAVED_CORRECTION_MAX_BYTES"):
        load_correction(path)
    assert time.perf_counter() - t0 < 2.0


def test_load_correction_checks_each_member_header_before_allocating(tmp_path, saved):
    """A member whose .npy header declares 2 GiB over a few stored bytes allocates nothing."""
    from zonotope.correct.profile import load_correction

    _, members = saved
    path = tmp_path / "liar.npz"
    np.savez(path, **members)
    with zipfile.ZipFile(path, "a") as zf:  # a second 'training' member: a header and 8 bytes
        buf = io.BytesIO()
        np.lib.format.write_array_header_1_0(buf, {"descr": "<f8", "fortran_order": False, "shape": (2**28,)})
        zf.writestr("Psi_big.npy", b"")  # an unexpected name is refused too
    tracemalloc.start()
    try:
        with pytest.raises(ZonotopeError, match=r"liar\.npz: not a saved correction \(member 'Psi_big\.npy'"):
            load_correction(path)
    finally:
        tracemalloc.stop()
    liar = dict(members)
    liar.pop("training")
    np.savez(path, **liar)
    with zipfile.ZipFile(path, "a") as zf:
        zf.writestr("training.npy", buf.getvalue() + bytes(8))
    tracemalloc.start()
    try:
        with pytest.raises(ZonotopeError, match=r"member 'training' declares shape \(268435456,\), larger"):
            load_correction(path)
        assert tracemalloc.get_traced_memory()[1] < 64 * 2**20
    finally:
        tracemalloc.stop()


@pytest.mark.parametrize(
    ("case", "message"),
    [
        ("pickle", r"member 'Phi' has dtype object; .*pickled objects are never loaded"),
        ("nan_M", r"array 'param_M' contains NaN or inf"),
        ("inf_Phi", r"array 'Phi' contains NaN or inf"),
        ("meta_list", r"format 'list'; this version reads"),
        ("options_list", r"header 'meta' needs .* scalar options"),
        ("sources_int", r"header 'meta' needs .* a list of source names"),
        ("M_shape", r"param_M has shape \(2, 3\); 'Cheung 2004' on 3 channels needs \(3, 3\)"),
        ("Psi_rows", r"array 'Psi' has shape \(5, 3\); expected \(31, 3\)"),
        ("truncated", r"not a saved correction \(an \.npz written by save_correction\)"),
        ("text", r"not a saved correction"),
        ("no_meta", r"no JSON header 'meta'"),
        ("bad_degree", r"option degree='x'"),
    ],
)
def test_load_correction_hostile_corpus(tmp_path, saved, case, message):
    """Each damaged or hostile saved correction is one ZonotopeError naming the file and the member."""
    from zonotope.correct.profile import load_correction

    good, m = saved
    path = tmp_path / f"{case}.npz"
    if case == "pickle":
        with zipfile.ZipFile(_rewrite(path, m, Phi=None), "a") as zf:
            buf = io.BytesIO()
            np.save(buf, np.array([{"x": 1}], dtype=object), allow_pickle=True)
            zf.writestr("Phi.npy", buf.getvalue())
    elif case == "nan_M":
        _rewrite(path, m, param_M=np.full((3, 3), np.nan))
    elif case == "inf_Phi":
        _rewrite(
            path, m, Phi=np.where(np.arange(m["Phi"].size).reshape(m["Phi"].shape) == 4, np.inf, m["Phi"])
        )
    elif case == "meta_list":
        _rewrite(path, m, meta=np.array("[1, 2]"))
    elif case == "options_list":
        _rewrite(path, m, meta=_meta(m, options=["x"]))
    elif case == "sources_int":
        _rewrite(path, m, meta=_meta(m, sources=5))
    elif case == "M_shape":
        _rewrite(path, m, param_M=np.ones((2, 3)))
    elif case == "Psi_rows":
        _rewrite(path, m, Psi=m["Psi"][:5])
    elif case == "truncated":
        data = good.read_bytes()
        path.write_bytes(data[: len(data) // 2])
    elif case == "text":
        path.write_text("not an archive\n")
    elif case == "no_meta":
        _rewrite(path, m, meta=None)
    elif case == "bad_degree":
        _rewrite(path, m, meta=_meta(m, method="Finlayson 2015", options={"degree": "x"}))
    with pytest.raises(ZonotopeError, match=rf"{case}\.npz: .*{message}"):
        load_correction(path)


def test_load_correction_still_loads_what_save_correction_wrote(saved):
    from zonotope.correct.profile import load_correction

    path, members = saved
    loaded = load_correction(path)
    np.testing.assert_array_equal(loaded.params["M"], members["param_M"])


# --------------------------------------------------------------------------------------------------
# solids and grids: guarded like the k-D path, no silent 0 volume, no NaN direction


def test_zonotope_3d_refuses_more_facets_than_facets_max():
    """5,000 directions in 3-D (≈ 2.5·10⁷ facets) are refused at once, as the k-D volume is."""
    from zonotope import Zonotope
    from zonotope.geometry.solid import FACETS_MAX

    G = np.random.default_rng(0).random((5000, 3))
    t0 = time.perf_counter()
    with pytest.raises(GeometryError, match=r"5000 generator directions .* FACETS_MAX.* coarser grid"):
        _ = Zonotope(G).volume
    with pytest.raises(GeometryError, match="FACETS_MAX"):
        Zonotope(G).contains([0.1, 0.1, 0.1])
    assert time.perf_counter() - t0 < 5.0
    assert FACETS_MAX >= 401 * 400  # a 1 nm grid over 380–780 nm stays exact


def test_tiny_generators_volume_is_an_error_not_zero():
    from zonotope import Zonotope

    G = np.random.default_rng(1).random((6, 3))
    with pytest.raises(GeometryError, match=r"magnitude .* below float64's range.*rescale"):
        _ = Zonotope(G * 1e-120).volume
    assert Zonotope(G * 1e-60).volume == pytest.approx(Zonotope(G).volume * 1e-180, rel=1e-9)
    with pytest.raises(GeometryError, match="below float64's range"):
        _ = Zonotope(np.random.default_rng(2).random((6, 4)) * 1e-90).volume  # the k-D path too
    assert Zonotope(np.zeros((4, 3))).volume == 0.0  # flat: a true zero


@pytest.mark.parametrize("bad", [[np.nan, 0, 0], [np.inf, 1, 0]])
def test_support_refuses_a_non_finite_direction(bad):
    from zonotope import Zonotope

    with pytest.raises(GeometryError, match="directions contain NaN or inf"):
        Zonotope(np.eye(3)).support(bad)


def test_common_shape_refuses_a_grid_past_grid_points_max():
    import colour

    from zonotope.spectra import common_shape, generators
    from zonotope.spectra.builtin import GRID_POINTS_MAX

    cmfs = colour.MSDS_CMFS["CIE 1931 2 Degree Standard Observer"]
    t0 = time.perf_counter()
    with pytest.raises(SpectralDataError, match=r"interval=.*1e-06 nm grid .* GRID_POINTS_MAX"):
        common_shape(cmfs, interval=1e-6)
    with pytest.raises(SpectralDataError, match="finite"):
        common_shape(cmfs, interval=float("inf"))
    with pytest.raises(SpectralDataError, match=r"shape: a 0\.0001 nm grid"):
        generators("Nikon 5100 (NPL)", shape=colour.SpectralShape(400, 700, 1e-4))
    assert time.perf_counter() - t0 < 2.0
    assert len(common_shape(cmfs, interval=0.1).wavelengths) <= GRID_POINTS_MAX


@pytest.mark.parametrize("name", [None, 5, 1.5])
def test_camera_of_a_non_name_is_a_project_error(name):
    from zonotope.spectra import camera

    with pytest.raises(SpectralDataError, match=r"camera must be a built-in name or spectral data"):
        camera(name)


@pytest.mark.parametrize(
    ("text", "names", "width"),
    [
        ("wavelength,r,g,b\n400,0.1\n410,0.2\n420,0.3\n", 4, 2),  # would load as 1 channel
        ("Wavelength (nm),r,g,b,x\n400,1,2,3\n410,1,2,3\n420,1,2,3\n", 5, 4),  # labels would be 1, 2, 3
    ],
)
def test_a_header_that_does_not_fit_the_rows_is_refused(tmp_path, text, names, width):
    from zonotope.spectra import load_camera

    path = tmp_path / "cam.csv"
    path.write_text(text)
    with pytest.raises(
        SpectralDataError, match=rf"line 1: the header names {names} columns .* have {width} values"
    ):
        load_camera(path)


def test_a_text_preamble_above_the_header_is_still_skipped(tmp_path):
    from zonotope.spectra import load_camera

    path = tmp_path / "cam.csv"
    path.write_text(
        "Measured 2020, by lab\nwavelength,r,g,b\n400,0.1,0.2,0.3\n410,0.2,0.2,0.3\n420,0.3,0.2,0.3\n"
    )
    assert list(load_camera(path).labels) == ["r", "g", "b"]


# --------------------------------------------------------------------------------------------------
# correctors: responses that are not numbers or beyond float64's working range


@pytest.fixture(scope="module")
def correctors():
    from zonotope.correct import fit_correction

    return {
        m: fit_correction("Nikon 5100 (NPL)", method=m, shape=GRID) for m in ("Finlayson 2015", "Projection")
    }


@pytest.mark.parametrize("method", ["Finlayson 2015", "Projection"])
@pytest.mark.parametrize(
    ("responses", "match"),
    [
        ("abc", r"responses must be numbers, an array_like of shape \(\.\.\., 3\); got dtype <U3"),
        ([["a", "b", "c"]], r"responses must be numbers"),
        (np.full((1, 3), 1e200), r"responses of magnitude 1e\+200 exceed 1e\+150"),
        (np.array([[np.inf, 1, 1], [1e200, 1, 1]]), r"magnitude 1e\+200"),
    ],
)
def test_corrector_refuses_non_numbers_and_huge_responses(correctors, method, responses, match):
    with pytest.raises(SpectralDataError, match=match):
        correctors[method](responses)


def test_root_polynomial_of_huge_responses_is_exact_not_nan(correctors):
    from zonotope.correct.regressions import root_polynomial_terms

    x = np.array([[0.2, 0.5, 0.3]])
    for degree in (2, 3, 4):
        np.testing.assert_allclose(
            root_polynomial_terms(x * 1e140, degree=degree),
            root_polynomial_terms(x, degree=degree) * 1e140,
            rtol=1e-12,
        )
    big = correctors["Finlayson 2015"](x * 1e120)
    np.testing.assert_allclose(big, correctors["Finlayson 2015"](x) * 1e120, rtol=1e-9)
    assert np.isnan(correctors["Finlayson 2015"](np.array([[np.nan, 1, 1]]))).all()  # a NaN pixel stays NaN


# --------------------------------------------------------------------------------------------------
# Folder batches: a file the batch did not write is never replaced nor counted done


def _copy_task(src: str, tmp: str, plant: dict) -> None:
    """A folder-batch task: copies its input; ``plant`` maps an input to a foreign file it drops."""
    from pathlib import Path

    if src in plant:  # a user's file appears under another task's output name during the batch
        Path(plant[src]).write_bytes(b"theirs")
    Path(tmp).write_bytes(Path(src).read_bytes())


@pytest.fixture
def batch(tmp_path):
    from zonotope.parallel import FileTask

    src = tmp_path / "in"
    src.mkdir()
    tasks = []
    for i in range(3):
        (src / f"f{i}.bin").write_bytes(os.urandom(32))
        tasks.append(FileTask(str(src / f"f{i}.bin"), str(tmp_path / "out" / f"f{i}.out")))
    return tasks, tmp_path / "out"


def test_run_files_refuses_a_users_manifest_and_outputs(batch):
    from pathlib import Path

    from zonotope.parallel import run_files

    tasks, out = batch
    out.mkdir()
    (out / "manifest.csv").write_text("mine\n")
    with pytest.raises(ParallelError, match=r"manifest\.csv was not written by a folder batch"):
        run_files(tasks, _copy_task, {}, manifest=out / "manifest.csv", scheduler="serial")
    (out / "manifest.csv").unlink()
    (out / "manifest.settings.json").write_text("{}")
    with pytest.raises(ParallelError, match=r"manifest\.settings\.json was not written by a folder batch"):
        run_files(tasks, _copy_task, {}, manifest=out / "manifest.csv", scheduler="serial")
    (out / "manifest.settings.json").unlink()
    Path(tasks[1].output).write_bytes(b"mine")
    with pytest.raises(ParallelError, match=r"f1\.out exists but was not written by this batch"):
        run_files(tasks, _copy_task, {}, manifest=out / "manifest.csv", scheduler="serial")
    assert sorted(p.name for p in out.iterdir()) == ["f1.out"]  # nothing written, nothing replaced
    assert Path(tasks[1].output).read_bytes() == b"mine"


def test_run_files_counts_only_what_it_wrote(batch):
    from pathlib import Path

    from zonotope.parallel import run_files

    tasks, out = batch
    plant = {tasks[0].input: tasks[2].output}  # appears while the batch runs
    rows = run_files(tasks, _copy_task, plant, manifest=out / "manifest.csv", scheduler="serial")
    assert [r["status"] for r in rows] == ["ok", "ok", "failed"]
    assert "appeared during the batch" in rows[2]["error"]
    assert Path(tasks[2].output).read_bytes() == b"theirs"
    Path(tasks[2].output).unlink()
    (out / "manifest.csv").unlink()  # as after a kill before the manifest was written: the record resumes
    rows = run_files(tasks, _copy_task, {}, manifest=out / "manifest.csv", scheduler="serial")
    assert [r["status"] for r in rows] == ["done", "done", "ok"]
    for t in tasks:
        assert Path(t.output).read_bytes() == Path(t.input).read_bytes()
    Path(tasks[0].output).write_bytes(b"edited")  # changed after the batch wrote it: no longer the batch's
    with pytest.raises(ParallelError, match=r"f0\.out exists but was not written by this batch"):
        run_files(tasks, _copy_task, {}, manifest=out / "manifest.csv", scheduler="serial")


def test_zonotope_correct_refuses_a_users_manifest_before_the_fit(tmp_path, capsys):
    import tifffile

    from zonotope.cli import main

    src, out = tmp_path / "renders", tmp_path / "out"
    src.mkdir()
    out.mkdir()
    tifffile.imwrite(src / "view.tif", np.full((4, 4, 3), 0.5, np.float32), photometric="minisblack")
    (out / "manifest.csv").write_text("mine\n")
    (out / "view_XYZ.tif").write_bytes(b"mine")
    args = [
        "correct",
        str(src),
        "-o",
        str(out),
        "--camera",
        "Nikon 5100 (NPL)",
        "--scheduler",
        "serial",
        "-q",
    ]
    t0 = time.perf_counter()
    assert main(args) == 2
    assert time.perf_counter() - t0 < 5  # refused before the fit
    assert "manifest.csv was not written by a folder batch" in capsys.readouterr().err
    assert (out / "manifest.csv").read_text() == "mine\n" and (out / "view_XYZ.tif").read_bytes() == b"mine"
