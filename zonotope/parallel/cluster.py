"""Where a batch runs: the scheduler choice, the TLS security of the clusters, and :func:`executor`.

A local cluster is bound to 127.0.0.1 with certificates made for it alone
(``Security.temporary()``); a running cluster is trusted as it is, with the client's certificates
from ``security=`` or ``ZONOTOPE_SCHEDULER_SECURITY`` (the trust model:
:mod:`zonotope.parallel`).
"""

from __future__ import annotations

import logging
import os
import re
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

from .executors import DaskExecutor, Executor, ParallelError, SerialExecutor, dask_available

__all__ = ["ENV_VAR", "SCHEDULER_HELP", "SECURITY_ENV_VAR", "executor", "resolve_scheduler"]

#: Environment variable read when ``scheduler=None``.
ENV_VAR = "ZONOTOPE_SCHEDULER"

#: Environment variable read when ``security=None``: a YAML/JSON file of the client's TLS settings.
SECURITY_ENV_VAR = "ZONOTOPE_SCHEDULER_SECURITY"

#: What a command line's ``--scheduler`` accepts and whom each choice trusts (one text for every command).
SCHEDULER_HELP = (
    "'serial' (this process); 'local' or 'local:N' (a Dask cluster of N worker processes on this "
    "machine, default one per core, on 127.0.0.1 with TLS certificates made for this run, so no other "
    "user can reach it); a running Dask scheduler's address: 'tcp://host:8786' has no authentication, "
    "so anyone who reaches that port can run code as its workers (use it only on a trusted network), "
    "'tls://host:8786' with the client's certificates in a YAML/JSON file named by "
    f"${SECURITY_ENV_VAR} (tls_ca_file, tls_client_cert, tls_client_key); or a scheduler file "
    f"(default ${ENV_VAR}, else serial for small jobs and a local cluster for large ones)"
)

#: Keys a security file may hold: the client's side of ``distributed.security.Security``.
_SECURITY_KEYS = ("tls_ca_file", "tls_client_cert", "tls_client_key", "tls_ciphers", "require_encryption")

_ADDRESS = re.compile(r"^([a-z0-9+]+://.+|[A-Za-z0-9_.\-]+:\d+)$")


def resolve_scheduler(scheduler: str | None = None, *, tasks: int | None = None, min_tasks: int = 2) -> str:
    """Where a batch would run: ``"serial"``, ``"local:N"`` or an address / scheduler file.

    Parameters
    ----------
    scheduler : str, optional
        As in :func:`executor`; None reads ``ZONOTOPE_SCHEDULER``, then decides by size.
    tasks : int, optional
        Number of tasks of the batch (for the automatic choice).
    min_tasks : int
        Batches with fewer tasks run serially when no scheduler is named.
    """
    from_env = scheduler is None and bool(os.environ.get(ENV_VAR))
    if scheduler is None:
        scheduler = os.environ.get(ENV_VAR) or None
    cores = os.cpu_count() or 1
    if scheduler is None:
        if tasks is None or tasks < max(min_tasks, 2) or cores < 2 or not dask_available():
            return "serial"
        return f"local:{min(cores, tasks)}"
    try:
        return _parse_scheduler(scheduler, cores)
    except ParallelError as error:  # the user may not remember having set it: say where it came from
        if from_env:
            raise ParallelError(f"{ENV_VAR}={scheduler!r} (environment variable): {error}") from error
        raise


def _parse_scheduler(scheduler, cores: int) -> str:
    """An explicit scheduler string → ``"serial"``, ``"local:N"`` or an address / scheduler file."""
    if not isinstance(scheduler, str) or not scheduler.strip():
        raise ParallelError(
            f"scheduler must be 'serial', 'local', 'local:N', an address such as "
            f"'tcp://host:8786' or a scheduler file; got {scheduler!r}."
        )
    s = scheduler.strip()
    if s.lower() in ("serial", "none", "sync"):
        return "serial"
    if s.lower() == "local":
        return f"local:{cores}"
    if s.lower().startswith("local:"):
        n = s.split(":", 1)[1]
        if not n.isdigit() or int(n) < 1:
            raise ParallelError(f"scheduler 'local:N' needs a worker count N ≥ 1; got {scheduler!r}.")
        return f"local:{int(n)}"
    if _ADDRESS.match(s) or Path(s).is_file():
        return s
    raise ParallelError(
        f"scheduler {scheduler!r} is neither 'serial', 'local[:N]', an address "
        f"(tcp://host:8786 or host:8786) nor an existing scheduler file."
    )


def _local_security():
    """TLS settings for a cluster this process starts: a key and certificate made for it alone.

    Raises
    ------
    ParallelError
        ``cryptography`` (part of the ``zonotope[dask]`` extra) is missing.
    """
    from distributed.security import Security

    try:
        return Security.temporary()
    except ImportError as error:
        raise ParallelError(
            "a local Dask cluster is started with TLS certificates, which needs the 'cryptography' "
            "package: pip install 'zonotope[dask]' (or use scheduler='serial')."
        ) from error


def _client_security(security):
    """``security=`` (a ``Security``, a file, or None: the environment variable) → ``Security`` or None.

    A file is a YAML or JSON mapping of the client's ``Security`` keywords (:data:`_SECURITY_KEYS`);
    the certificate values are paths or PEM text, as ``Security`` takes them.

    Raises
    ------
    ParallelError
        Unreadable file, not a mapping, an unknown key, or a named certificate file that is missing.
    """
    from_env = security is None and bool(os.environ.get(SECURITY_ENV_VAR))
    if security is None:
        security = os.environ.get(SECURITY_ENV_VAR) or None
    if security is None:
        return None
    from distributed.security import Security

    if isinstance(security, Security):
        return security
    where = f"{SECURITY_ENV_VAR}={security}" if from_env else f"security={security}"
    if not isinstance(security, (str, os.PathLike)):
        raise ParallelError(
            "security must be a distributed.security.Security or a YAML/JSON file; "
            f"got {type(security).__name__}."
        )
    import yaml

    try:
        text = Path(security).read_text(encoding="utf-8")
        data = yaml.safe_load(text)
    except (OSError, UnicodeDecodeError, yaml.YAMLError) as error:
        raise ParallelError(
            f"{where}: unreadable security file ({type(error).__name__}: {error})."
        ) from error
    if not isinstance(data, dict):
        raise ParallelError(f"{where}: a security file is a mapping of {', '.join(_SECURITY_KEYS)}.")
    unknown = sorted(str(k) for k in data if k not in _SECURITY_KEYS)
    if unknown:
        raise ParallelError(
            f"{where}: unknown key(s) {', '.join(unknown)}; allowed: {', '.join(_SECURITY_KEYS)}."
        )
    for key in ("tls_ca_file", "tls_client_cert", "tls_client_key"):
        value = data.get(key)
        if value is not None and not isinstance(value, str):
            raise ParallelError(f"{where}: {key} must be a file path or PEM text; got {value!r}.")
        if isinstance(value, str) and "-----BEGIN" not in value:
            path = Path(value).expanduser()
            if not path.is_absolute():  # relative to the security file, as users write them beside it
                path = Path(security).resolve().parent / path
            if not path.is_file():
                raise ParallelError(f"{where}: {key} file {value} does not exist.")
            data[key] = str(path)
    return Security(**data)


@contextmanager
def executor(
    scheduler: str | None = None,
    *,
    tasks: int | None = None,
    min_tasks: int = 2,
    timeout: float = 30.0,
    security=None,
) -> Iterator[Executor]:
    """An executor for one batch, closed (with any cluster it started) when the block ends.

    Parameters
    ----------
    scheduler : str, optional
        ``"serial"``, ``"local"``, ``"local:N"``, a Dask scheduler address or scheduler file; None
        reads the ``ZONOTOPE_SCHEDULER`` environment variable, then picks serial for fewer than
        ``min_tasks`` tasks and a local cluster (one worker process per core) for more.
    tasks, min_tasks : int
        Size of the batch and the smallest batch worth a local cluster (starting one costs a
        few seconds; see ``benchmarks/bench_parallel.py``).
    timeout : float
        Seconds to wait for a running cluster to answer.
    security : distributed.security.Security or path, optional
        The client's TLS settings for a running cluster (a ``Security`` or a YAML/JSON file of its
        ``tls_ca_file``, ``tls_client_cert``, ``tls_client_key`` keywords); None reads the
        ``ZONOTOPE_SCHEDULER_SECURITY`` environment variable, then Dask's own configuration. A
        local cluster always gets its own temporary certificates and listens on 127.0.0.1 only,
        since anyone who reaches a scheduler can run code as its workers' user.

    Yields
    ------
    Executor

    Raises
    ------
    ParallelError
        Bad ``scheduler`` or ``security``, Dask not installed for a cluster, or the cluster did not
        answer.

    Examples
    --------
    >>> from zonotope.parallel import executor
    >>> with executor("serial") as ex:
    ...     list(ex.map(abs, [-1, 2]))
    [1, 2]
    """
    where = resolve_scheduler(scheduler, tasks=tasks, min_tasks=min_tasks)
    if where == "serial":
        yield SerialExecutor()
        return
    if not dask_available():
        raise ParallelError(
            f"scheduler {where!r} needs Dask: pip install 'zonotope[dask]' (or use scheduler='serial')."
        )
    from distributed import Client, LocalCluster

    cluster = None
    try:
        if where.startswith("local:"):
            secure = _local_security()
            cluster = LocalCluster(
                n_workers=int(where.split(":")[1]),
                threads_per_worker=1,
                processes=True,
                host="127.0.0.1",
                protocol="tls://",
                security=secure,
                dashboard_address="127.0.0.1:0",
                silence_logs=logging.CRITICAL,
            )
            client = Client(cluster, security=secure)
            kind = "local"
        elif Path(where).is_file():
            client = Client(scheduler_file=where, timeout=timeout, security=_client_security(security))
            kind = "cluster"
        else:
            client = Client(where, timeout=timeout, security=_client_security(security))
            kind = "cluster"
    except TypeError as error:  # Dask's word for a tls:// address with no client certificates
        raise ParallelError(
            f"scheduler {where!r} speaks TLS: give the client's certificates with security=FILE "
            f"or {SECURITY_ENV_VAR}=FILE (YAML with {', '.join(_SECURITY_KEYS[:3])}); {error}"
        ) from error
    except (OSError, TimeoutError) as error:
        if cluster is not None:
            cluster.close()
        raise ParallelError(
            f"could not reach the Dask scheduler {where!r} within {timeout:g} s "
            f"({error}); start one with `dask scheduler` or use scheduler='serial'."
        ) from error
    try:
        yield DaskExecutor(client, kind=kind)
    finally:
        client.close()
        if cluster is not None:
            cluster.close()
