"""Hostile and degenerate inputs for zonotope: Dask clusters refuse strangers, loaders and solids
bound what they build, and each bad input is one project error that names it."""

from __future__ import annotations

import os

import pytest

from zonotope.parallel import SECURITY_ENV_VAR, ParallelError, executor

# --------------------------------------------------------------------------------------------------
# Dask: a local cluster speaks TLS on loopback with its own certificates


def _write_security(path, security) -> None:
    """The client's side of ``security`` as a YAML file (PEM text inline, as ``Security`` accepts)."""
    import yaml

    keys = ("tls_ca_file", "tls_client_cert", "tls_client_key")
    path.write_text(yaml.safe_dump({k: getattr(security, k) for k in keys} | {"require_encryption": True}))


def test_local_cluster_refuses_an_unauthenticated_client(tmp_path):
    """Given the port, a client without the cluster's certificates is refused; the project's own works."""
    distributed = pytest.importorskip("distributed")
    pytest.importorskip("cryptography")
    from distributed.security import Security

    with executor("local:1") as ex:
        address = ex.client.scheduler.address
        assert address.startswith("tls://127.0.0.1:")
        assert all(w.startswith("tls://127.0.0.1:") for w in ex.client.scheduler_info()["workers"])
        assert set(ex.client.run(os.getpid).values()) != {os.getpid()}  # code runs on its workers
        with pytest.raises((OSError, TypeError)):  # no certificate at all
            distributed.Client(address, timeout=3)
        with pytest.raises(OSError, match="TLS"):  # a certificate of another authority
            distributed.Client(address, timeout=3, security=Security.temporary())
        with pytest.raises(OSError):  # plain TCP to the TLS port
            distributed.Client(address.replace("tls://", "tcp://"), timeout=3)
        # the trust model for running clusters: the right certificates, from a file, are accepted
        _write_security(tmp_path / "sec.yaml", ex.client.security)
        with executor(address, security=tmp_path / "sec.yaml", timeout=10) as other:
            assert other.kind == "cluster" and list(other.map(abs, [-2])) == [2]
        with pytest.raises(ParallelError, match="speaks TLS"), executor(address, timeout=3):
            pass


def test_security_file_errors_name_the_file_and_key(tmp_path, monkeypatch):
    pytest.importorskip("distributed")
    from zonotope.parallel import _client_security

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
