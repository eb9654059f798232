"""Where batch work runs: this process, a local Dask cluster, or any running Dask cluster.

One execution layer for every batch path of the project (MMV batches, folder batches of RAW files
and multi-channel images, camera-set surveys). The numerical code never knows where it runs: it
hands a function and its items to an executor and gets the results back, in order
(:meth:`Executor.map`, the :class:`concurrent.futures.Executor` protocol) or as they finish, with
failures returned per item (:meth:`Executor.outcomes`).

Choosing where (``scheduler=``, or the ``ZONOTOPE_SCHEDULER`` environment variable when the argument
is None):

- ``"serial"``: this process, one item after another (no Dask needed);
- ``"local"`` or ``"local:N"``: a local Dask cluster of N worker processes (default: one per core),
  one thread each, started for the batch and closed after it;
- an address (``"tcp://host:8786"``, ``"host:8786"``, ``"tls://…"``) or a scheduler file (the JSON
  written by ``dask scheduler --scheduler-file``, as dask-jobqueue setups use): that running
  cluster. Workers must import the same ``zonotope`` and, for folder batches, see the same paths
  (a shared file system);
- None and no environment variable (the default): serial for small jobs (fewer than ``min_tasks``
  items, one core, or Dask not installed), a local cluster for large ones.

Trust model. Whoever can talk to a Dask scheduler can run any code as the workers' user
(``Client.run``). A local cluster is therefore bound to 127.0.0.1 and speaks TLS with certificates
made for it alone (``Security.temporary()``): only this process holds the key, so another local user
given the port is refused. A running cluster is trusted as it is: a ``tcp://`` scheduler has no
authentication, so use one only on a network where everyone who reaches it may run code as its
workers, or run it with TLS (``dask scheduler --tls-ca-file … --tls-cert … --tls-key …``,
``tls://`` address) and give the client's certificates with ``security=`` (a
``distributed.security.Security`` or a YAML/JSON file of its ``tls_*`` keywords), or in the
``ZONOTOPE_SCHEDULER_SECURITY`` environment variable (that file's path) when the argument is None.

Dask is an optional extra (``pip install "zonotope[dask]"``); nothing here imports it until a
cluster is asked for, and single-image use never needs it.

The results do not depend on where they were computed: every item runs the same function on the
same inputs (bit-for-bit identical arrays, tested against the serial path). Killed workers are
handled by Dask: their tasks are run again on the others (tasks must be idempotent, which the
folder batches ensure by writing each output atomically and at most once).
"""

from __future__ import annotations

import logging
import os
import re
import shutil
import traceback
from collections.abc import Callable, Iterable, Iterator, Mapping
from concurrent.futures import Executor as _Executor
from concurrent.futures import Future
from contextlib import contextmanager
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from ._errors import ZonotopeError
from .utilities.progress import ProgressCallback

__all__ = [
    "BATCH_RECORD",
    "ENV_VAR",
    "FILE_MIN_TASKS",
    "MANIFEST_COLUMNS",
    "SCHEDULER_HELP",
    "SECURITY_ENV_VAR",
    "DaskExecutor",
    "Executor",
    "FileTask",
    "ParallelError",
    "SerialExecutor",
    "TaskFailure",
    "check_batch_folder",
    "check_settings",
    "dask_available",
    "executor",
    "resolve_scheduler",
    "run_files",
]

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


class ParallelError(ZonotopeError):
    """The execution layer could not be set up (bad scheduler, unreachable cluster, Dask missing)."""


@dataclass(frozen=True)
class TaskFailure:
    """An item whose task raised: the exception's type and message and the formatted traceback."""

    error: str
    traceback: str

    def __str__(self) -> str:
        return self.error


def dask_available() -> bool:
    """Whether ``dask.distributed`` can be imported (the ``zonotope[dask]`` extra)."""
    try:
        import distributed  # noqa: F401
    except ImportError:
        return False
    return True


class Executor(_Executor):
    """A :class:`concurrent.futures.Executor` with per-item outcomes and one shared object.

    Attributes
    ----------
    kind : str
        ``"serial"``, ``"local"`` or ``"cluster"``.
    workers : int
        Worker processes (1 for serial).
    """

    kind: str = "serial"
    workers: int = 1

    def outcomes(
        self,
        fn: Callable,
        items: Iterable,
        *,
        shared: Any = None,
        progress: ProgressCallback | None = None,
        stage: str = "tasks",
    ) -> Iterator[tuple[int, Any]]:
        """Run ``fn(item, shared)`` (or ``fn(item)`` when ``shared`` is None) for every item.

        Yields ``(index, result)`` as the tasks finish (any order); a task that raised yields a
        :class:`TaskFailure` instead of its result and the others go on. ``shared`` is sent to
        each worker once, not once per item. ``progress(stage, done, total)`` is called after
        each finished task (:class:`~zonotope.utilities.ProgressCallback`).
        """
        raise NotImplementedError  # pragma: no cover - the subclasses implement it

    def describe(self) -> str:
        """One line for the CLIs, e.g. ``"local Dask cluster, 2 workers"``."""
        return {"serial": "serial (this process)"}.get(self.kind, f"{self.kind}, {self.workers} workers")


class SerialExecutor(Executor):
    """Everything in this process, in order (the reference path)."""

    def submit(self, fn, /, *args, **kwargs) -> Future:
        """Run ``fn(*args, **kwargs)`` now; a completed :class:`~concurrent.futures.Future`."""
        fut: Future = Future()
        try:
            fut.set_result(fn(*args, **kwargs))
        except BaseException as error:  # handed back through the future
            fut.set_exception(error)
        return fut

    def map(self, fn, *iterables, timeout=None, chunksize=1) -> Iterator:
        """Lazy ``map(fn, *iterables)`` in this process."""
        return map(fn, *iterables)

    def outcomes(self, fn, items, *, shared=None, progress=None, stage="tasks"):
        """See :meth:`Executor.outcomes` (here: one item after the other, in order)."""
        items = list(items)
        for i, item in enumerate(items):
            try:
                out = fn(item) if shared is None else fn(item, shared)
            except Exception as error:  # one bad item must not stop the batch
                out = TaskFailure(f"{type(error).__name__}: {error}", traceback.format_exc())
            if progress is not None:
                progress(stage, i + 1, len(items))
            yield i, out


class DaskExecutor(Executor):
    """Tasks on a Dask cluster through a ``distributed.Client``.

    At most ``window`` tasks are submitted ahead of the results consumed (bounded memory on the
    client for batches of any length).
    """

    def __init__(self, client, *, kind: str = "cluster", window: int | None = None):
        self.client = client
        self.kind = kind
        self.workers = max(1, len(client.scheduler_info().get("workers", {})))
        self.window = window

    def _window(self) -> int:
        if self.window is not None:
            return self.window
        threads = sum(self.client.nthreads().values()) or 1
        return 4 * threads

    def submit(self, fn, /, *args, **kwargs):
        """Submit one task; a ``distributed.Future``."""
        return self.client.submit(fn, *args, pure=False, **kwargs)

    def map(self, fn, *iterables, timeout=None, chunksize=1) -> Iterator:
        """Results of ``fn(*args)`` in the order of ``iterables``, a bounded window at a time."""
        from collections import deque

        pending: deque = deque()
        window = self._window()
        for args in zip(*iterables):
            pending.append(self.client.submit(fn, *args, pure=False))
            if len(pending) >= window:
                yield pending.popleft().result(timeout=timeout)
        while pending:
            yield pending.popleft().result(timeout=timeout)

    def outcomes(self, fn, items, *, shared=None, progress=None, stage="tasks"):
        """See :meth:`Executor.outcomes` (here: Dask futures, yielded as they complete)."""
        from distributed import as_completed

        items = list(items)
        total = len(items)
        if total == 0:
            return
        extra = () if shared is None else (self.client.scatter(shared, broadcast=True, hash=False),)
        index: dict = {}
        source = iter(enumerate(items))
        window = self._window()

        def more(n):
            out = []
            for i, item in source:
                fut = self.client.submit(_call, fn, item, *extra, pure=False)
                index[fut.key] = i
                out.append(fut)
                if len(out) >= n:
                    break
            return out

        pool = as_completed(more(window), with_results=False)
        done = 0
        for fut in pool:
            i = index.pop(fut.key)
            if fut.status == "finished":
                out = fut.result()
            else:
                error = fut.exception()
                out = TaskFailure(
                    f"{type(error).__name__}: {error}", "".join(traceback.format_exception(error))
                )
            fut.release()
            done += 1
            if progress is not None:
                progress(stage, done, total)
            for new in more(1):
                pool.add(new)
            yield i, out

    def shutdown(self, wait=True, *, cancel_futures=False):
        """Nothing to stop here: :func:`executor` closes the client and any cluster it started."""


def _call(fn, item, *shared):
    return fn(item, *shared)


#: Smallest folder batch that starts a local cluster by default: starting one costs seconds, and on a
#: loaded 2-core machine 3 RAW files took 7.3 s serial against 15.6 s on a 2-worker local cluster.
FILE_MIN_TASKS = 8


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


# --------------------------------------------------------------------------------------------------
# folder batches: one output per input, written atomically and at most once, resumable, with a manifest


@dataclass(frozen=True)
class FileTask:
    """One input file and the output it becomes."""

    input: str
    output: str


#: Columns of the manifest CSV written by :func:`run_files`.
MANIFEST_COLUMNS = ("input", "output", "status", "seconds", "worker", "error")

#: Folder, beside a batch's outputs, that records what the batch wrote: one empty file
#: ``<output name>.<size>-<mtime_ns>`` per output, made by the worker just before it publishes it.
#: An existing output is the batch's (``done``) only if it still has a recorded size and time; the
#: folder's presence also says that the manifest and settings record beside it are the batch's.
BATCH_RECORD = ".zonotope-batch"


def _stamp(path: Path, st: os.stat_result | None = None) -> str:
    st = path.stat() if st is None else st
    return f"{path.name}.{st.st_size}-{st.st_mtime_ns}"


def _recorded(path: Path) -> bool:
    """Whether ``path`` is an output this batch tool wrote (its size and time are recorded)."""
    try:
        return (path.parent / BATCH_RECORD / _stamp(path)).is_file()
    except OSError:
        return False


def check_batch_folder(tasks: Iterable[FileTask], manifest: str | os.PathLike) -> None:
    """Refuse a folder batch that would replace or count as its own a file it did not write.

    Run before any long work (a fit). The manifest, its settings record and every existing output
    must have been written by a folder batch (:data:`BATCH_RECORD`): a user's ``manifest.csv`` is
    never replaced, and a user's file that merely has an output's name is never counted ``done``.

    Raises
    ------
    ParallelError
        Naming the first such file and what to do.
    """
    manifest = Path(manifest)
    owned = (manifest.parent / BATCH_RECORD).is_dir()
    for p in (manifest, _settings_path(manifest)):
        if p.exists() and not owned:
            raise ParallelError(
                f"{p} was not written by a folder batch (no {BATCH_RECORD} record beside it); move it "
                "out of the folder or choose another output folder."
            )
    for t in tasks:
        out = Path(t.output)
        if out.exists() and not _recorded(out):
            raise ParallelError(
                f"{out} exists but was not written by this batch (no record in "
                f"{out.parent / BATCH_RECORD}); move it out of the folder or choose another output folder."
            )


def _forget_stale(tasks: list[FileTask]) -> None:
    """Remove record entries of outputs that no longer match them (another attempt, a removed file)."""
    by_folder: dict[Path, dict[str, str | None]] = {}
    for t in tasks:
        out = Path(t.output)
        try:
            current = _stamp(out) if out.is_file() else None
        except OSError:
            current = None
        by_folder.setdefault(out.parent, {})[out.name] = current
    for folder, names in by_folder.items():
        record = folder / BATCH_RECORD
        if not record.is_dir():
            continue
        for entry in record.iterdir():
            name, _, stamp = entry.name.rpartition(".")
            if name in names and entry.name != names[name] and re.fullmatch(r"\d+-\d+", stamp):
                entry.unlink(missing_ok=True)


def _publish(tmp: Path, dest: Path) -> bool:
    """Make ``tmp`` appear at ``dest`` atomically, only if nothing is there yet; True if it was ours.

    ``os.link`` creates ``dest`` or fails, so two attempts of one task (a worker killed after
    writing, its task re-run elsewhere) never both replace the file: the first one wins.
    """
    try:
        os.link(tmp, dest)
        return True
    except FileExistsError:
        return False
    except OSError:  # file systems without hard links: an atomic rename (last attempt wins)
        os.replace(tmp, dest)
        return True
    finally:
        tmp.unlink(missing_ok=True)


def _temp_for(dest: Path) -> Path:
    import uuid

    return dest.with_name(f".{dest.stem}.{uuid.uuid4().hex[:12]}.part{dest.suffix}")


def _file_task(task: FileTask, shared) -> dict:
    """Run ``work(input, temporary_output, options)`` for one file on a worker; never raises."""
    import socket
    import time

    work, options = shared
    dest = Path(task.output)
    row = {
        "input": task.input,
        "output": task.output,
        "seconds": 0.0,
        "worker": f"{socket.gethostname()}:{os.getpid()}",
        "error": "",
    }
    if dest.exists():  # a re-run of a task whose first attempt finished (its worker then died)
        if _recorded(dest):
            return {**row, "status": "done"}
        return {
            **row,
            "status": "failed",
            "error": f"{dest} appeared during the batch and was not written by it; it was left as it is.",
        }
    tmp = _temp_for(dest)
    t0 = time.perf_counter()
    entry = None
    try:
        work(task.input, str(tmp), options)
        if not tmp.is_file():
            raise ZonotopeError(f"the task wrote nothing for {task.input}")
        # recorded before it appears, so that a kill between the two never leaves an output unrecorded
        entry = dest.parent / BATCH_RECORD / _stamp(dest, tmp.stat())
        entry.touch()
        if not _publish(tmp, dest):  # another attempt published first: its entry is the one that counts
            entry.unlink(missing_ok=True)
    except Exception as error:  # one bad file is reported, the batch goes on
        tmp.unlink(missing_ok=True)
        if entry is not None and not dest.exists():
            entry.unlink(missing_ok=True)
        return {
            **row,
            "status": "failed",
            "seconds": time.perf_counter() - t0,
            "error": f"{type(error).__name__}: {error}".replace("\n", " "),
        }
    return {**row, "status": "ok", "seconds": time.perf_counter() - t0}


def _write_manifest(path: Path, rows: list[dict]) -> None:
    import csv
    import io

    buf = io.StringIO()
    w = csv.DictWriter(buf, fieldnames=MANIFEST_COLUMNS, lineterminator="\n")
    w.writeheader()
    for r in rows:
        w.writerow({k: (f"{r[k]:.3f}" if k == "seconds" else r[k]) for k in MANIFEST_COLUMNS})
    tmp = _temp_for(path)
    tmp.write_text(buf.getvalue(), encoding="utf-8")
    os.replace(tmp, path)


def _check_tasks(tasks: list[FileTask]) -> None:
    """Refuse a layout where two inputs share an output or an output is an input (before any work).

    Raises
    ------
    ParallelError
        Naming the two inputs (or the output) concerned.
    """
    first: dict[Path, str] = {}
    for t in tasks:
        out = Path(t.output).resolve()
        if out in first:
            if Path(first[out]).resolve() == Path(t.input).resolve():
                raise ParallelError(f"input {t.input} is given more than once; give each file once.")
            raise ParallelError(
                f"inputs {first[out]} and {t.input} would both be written to {t.output}; "
                "rename one of them or give them separately to different output folders."
            )
        first[out] = str(t.input)
    ins = {Path(t.input).resolve() for t in tasks}
    clash = [str(t.output) for t in tasks if Path(t.output).resolve() in ins]
    if clash:
        raise ParallelError(f"output {clash[0]} is one of the inputs; choose another output folder.")


def _settings_path(manifest: str | os.PathLike) -> Path:
    manifest = Path(manifest)
    return manifest.with_name(manifest.stem + ".settings.json")


def _settings_json(settings: Mapping[str, Any]) -> dict:
    import json

    return json.loads(json.dumps(dict(settings), sort_keys=True, default=str))


def check_settings(manifest: str | os.PathLike, settings: Mapping[str, Any]) -> None:
    """Refuse to resume a folder batch that was started with other settings.

    A rerun skips the outputs that exist, so one made with other options (another estimator,
    demosaicing, white balance, ...) would silently stay among the new ones. :func:`run_files`
    keeps a batch's ``settings`` beside its manifest (``manifest.csv`` → ``manifest.settings.json``);
    call this before long work (a fit) to refuse early.

    Parameters
    ----------
    manifest : path
        The batch's manifest path.
    settings : mapping
        The options that change the outputs (JSON-serialisable; others are stored as text).

    Raises
    ------
    ParallelError
        The folder holds a batch with other settings; names the first differences.
    """
    import json

    path = _settings_path(manifest)
    if not path.is_file():
        return
    try:
        old = json.loads(path.read_text())
    except (OSError, ValueError) as error:
        raise ParallelError(
            f"{path}: unreadable batch settings ({error}); delete it to start over."
        ) from error
    new = _settings_json(settings)
    if old != new:
        diff = sorted(k for k in old.keys() | new.keys() if old.get(k) != new.get(k))
        shown = "; ".join(f"{k}: {old.get(k)!r} then, {new.get(k)!r} now" for k in diff[:3])
        raise ParallelError(
            f"{path.parent} holds outputs of a batch with other settings ({shown}); a rerun only "
            "resumes the same batch: choose another output folder, or delete this one to start over."
        )


def run_files(
    tasks: Iterable[FileTask],
    work: Callable[[str, str, Any], None],
    options: Any = None,
    *,
    manifest: str | os.PathLike,
    scheduler: str | None = None,
    min_tasks: int = FILE_MIN_TASKS,
    progress: ProgressCallback | None = None,
    settings: Mapping[str, Any] | None = None,
) -> list[dict]:
    """Make one output file per input file, on the chosen executor; resumable, with a manifest.

    Parameters
    ----------
    tasks : iterable of FileTask
        Inputs and their outputs (outputs must differ from every input and from each other).
    work : callable
        ``work(input_path, temporary_output_path, options)`` writes the output to the temporary
        path (same folder and suffix as the output); a module-level function, so that workers can
        import it. It may raise: the file is then reported ``failed`` and the others go on.
    options : object
        Sent to every worker once (e.g. a fitted estimator).
    manifest : path
        CSV rewritten atomically as the batch goes (columns :data:`MANIFEST_COLUMNS`).
    scheduler, min_tasks
        Where to run (see :func:`executor`). With no scheduler, a local cluster is started only for
        ``min_tasks`` files or more (default :data:`FILE_MIN_TASKS`).
    progress : callable, optional
        ``progress("files", done, total)`` over the files that had to be made
        (:class:`~zonotope.utilities.ProgressCallback`).
    settings : mapping, optional
        The options that change the outputs: kept beside the manifest, and a rerun into the same
        folder with other settings is refused (:func:`check_settings`).

    Returns
    -------
    list of dict
        One row per task, in input order: ``status`` is ``ok`` (made now), ``done`` (the output
        already existed and was written by this batch tool: skipped, which is how a rerun resumes) or
        ``failed`` (``error`` says why).

    Raises
    ------
    ParallelError
        Two inputs share an output, or the folder holds a manifest, settings record or output that
        a folder batch did not write (:func:`check_batch_folder`): it is never replaced or counted.

    Notes
    -----
    Each output is written to a temporary file and published with a hard link, so it appears
    complete or not at all, and a task run twice (its worker killed after writing) never writes it
    a second time. What was written is recorded in :data:`BATCH_RECORD` before it appears, so a
    rerun after a kill still resumes. Inputs are only read.
    """
    import time

    tasks = list(tasks)
    _check_tasks(tasks)
    manifest = Path(manifest)
    check_batch_folder(tasks, manifest)
    for folder in {manifest.parent, *(Path(t.output).parent for t in tasks)}:
        (folder / BATCH_RECORD).mkdir(parents=True, exist_ok=True)
    if settings is not None:
        import json

        from .utilities.io import atomic_write_bytes

        check_settings(manifest, settings)
        if not _settings_path(manifest).is_file():
            text = json.dumps(_settings_json(settings), sort_keys=True, indent=1, ensure_ascii=False)
            atomic_write_bytes(_settings_path(manifest), (text + "\n").encode())
    rows: list[dict] = []
    todo: list[int] = []
    for i, t in enumerate(tasks):
        if Path(t.output).exists():
            rows.append(
                {
                    "input": t.input,
                    "output": t.output,
                    "status": "done",
                    "seconds": 0.0,
                    "worker": "",
                    "error": "",
                }
            )
        else:
            rows.append(
                {
                    "input": t.input,
                    "output": t.output,
                    "status": "pending",
                    "seconds": 0.0,
                    "worker": "",
                    "error": "",
                }
            )
            todo.append(i)
    _write_manifest(manifest, rows)
    last = time.monotonic()
    try:
        with executor(scheduler, tasks=len(todo), min_tasks=min_tasks) as ex:
            for j, out in ex.outcomes(
                _file_task, [tasks[i] for i in todo], shared=(work, options), progress=progress, stage="files"
            ):
                i = todo[j]
                if isinstance(out, TaskFailure):  # the task itself was lost (e.g. killed too often)
                    out = {**rows[i], "status": "failed", "error": out.error.replace("\n", " ")}
                rows[i] = out
                if time.monotonic() - last > 2.0:
                    _write_manifest(manifest, rows)
                    last = time.monotonic()
    finally:
        _remove_temporaries(tasks)
        _forget_stale(tasks)
        _write_manifest(manifest, rows)
    return rows


def _remove_temporaries(tasks: list[FileTask]) -> None:
    """Remove the temporaries of attempts whose worker died while writing (only this batch's): the
    ``.part`` files, and the atomic writers' own temporaries of a ``.part`` file (a worker killed
    inside ``zonotope.utilities.io``'s write of it leaves ``..stem.<hex>.part.tif.<pid>.tmp-….tif``)."""
    from .utilities.io import _TMP

    names: dict[Path, set[str]] = {}
    for t in tasks:
        out = Path(t.output)
        names.setdefault(out.parent, set()).add(out.stem)
    pattern = re.compile(r"^\.(.+)\.[0-9a-f]{12}\.part(\.[^.]*)?$")
    for folder, stems in names.items():
        if not folder.is_dir():
            continue
        for entry in folder.iterdir():
            inner = _TMP.match(entry.name)
            m = pattern.match(inner.group("name") if inner else entry.name)
            if not (m and m.group(1) in stems):
                continue
            if entry.is_dir() and not entry.is_symlink():
                shutil.rmtree(entry, ignore_errors=True)
            else:
                entry.unlink(missing_ok=True)
