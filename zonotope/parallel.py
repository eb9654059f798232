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
import traceback
from collections.abc import Callable, Iterable, Iterator
from concurrent.futures import Executor as _Executor
from concurrent.futures import Future
from contextlib import contextmanager
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from ._errors import ZonotopeError

__all__ = [
    "ENV_VAR",
    "DaskExecutor",
    "Executor",
    "SerialExecutor",
    "TaskFailure",
    "dask_available",
    "executor",
    "resolve_scheduler",
]

#: Environment variable read when ``scheduler=None``.
ENV_VAR = "ZONOTOPE_SCHEDULER"

#: Called as ``progress(done, total)``.
ProgressCallback = Callable[[int, int], None]

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

    def outcomes(self, fn: Callable, items: Iterable, *, shared: Any = None,
                 progress: ProgressCallback | None = None) -> Iterator[tuple[int, Any]]:
        """Run ``fn(item, shared)`` (or ``fn(item)`` when ``shared`` is None) for every item.

        Yields ``(index, result)`` as the tasks finish (any order); a task that raised yields a
        :class:`TaskFailure` instead of its result and the others go on. ``shared`` is sent to
        each worker once, not once per item.
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

    def outcomes(self, fn, items, *, shared=None, progress=None):
        items = list(items)
        for i, item in enumerate(items):
            try:
                out = fn(item) if shared is None else fn(item, shared)
            except Exception as error:  # one bad item must not stop the batch
                out = TaskFailure(f"{type(error).__name__}: {error}", traceback.format_exc())
            if progress is not None:
                progress(i + 1, len(items))
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

    def outcomes(self, fn, items, *, shared=None, progress=None):
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
                out = TaskFailure(f"{type(error).__name__}: {error}",
                                  "".join(traceback.format_exception(error)))
            fut.release()
            done += 1
            if progress is not None:
                progress(done, total)
            for new in more(1):
                pool.add(new)
            yield i, out

    def shutdown(self, wait=True, *, cancel_futures=False):
        """Nothing to stop here: :func:`executor` closes the client and any cluster it started."""


def _call(fn, item, *shared):
    return fn(item, *shared)


def resolve_scheduler(scheduler: str | None = None, *, tasks: int | None = None,
                      min_tasks: int = 2) -> str:
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
    if scheduler is None:
        scheduler = os.environ.get(ENV_VAR) or None
    cores = os.cpu_count() or 1
    if scheduler is None:
        if tasks is None or tasks < max(min_tasks, 2) or cores < 2 or not dask_available():
            return "serial"
        return f"local:{min(cores, tasks)}"
    if not isinstance(scheduler, str) or not scheduler.strip():
        raise ParallelError(f"scheduler must be 'serial', 'local', 'local:N', an address such as "
                            f"'tcp://host:8786' or a scheduler file; got {scheduler!r}.")
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
    raise ParallelError(f"scheduler {scheduler!r} is neither 'serial', 'local[:N]', an address "
                        f"(tcp://host:8786 or host:8786) nor an existing scheduler file.")


@contextmanager
def executor(scheduler: str | None = None, *, tasks: int | None = None, min_tasks: int = 2,
             timeout: float = 30.0) -> Iterator[Executor]:
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

    Yields
    ------
    Executor

    Raises
    ------
    ParallelError
        Bad ``scheduler``, Dask not installed for a cluster, or the cluster did not answer.

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
        raise ParallelError(f"scheduler {where!r} needs Dask: pip install 'zonotope[dask]' "
                            f"(or use scheduler='serial').")
    from distributed import Client, LocalCluster

    cluster = None
    try:
        if where.startswith("local:"):
            cluster = LocalCluster(n_workers=int(where.split(":")[1]), threads_per_worker=1,
                                   processes=True, dashboard_address=None,
                                   silence_logs=logging.CRITICAL)
            client = Client(cluster)
            kind = "local"
        elif Path(where).is_file():
            client = Client(scheduler_file=where, timeout=timeout)
            kind = "cluster"
        else:
            client = Client(where, timeout=timeout)
            kind = "cluster"
    except (OSError, TimeoutError) as error:
        if cluster is not None:
            cluster.close()
        raise ParallelError(f"could not reach the Dask scheduler {where!r} within {timeout:g} s "
                            f"({error}); start one with `dask scheduler` or use scheduler='serial'."
                            ) from error
    try:
        yield DaskExecutor(client, kind=kind)
    finally:
        client.close()
        if cluster is not None:
            cluster.close()
