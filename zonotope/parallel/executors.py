"""The map: executors that run one function over many items, here or on a Dask cluster.

:class:`SerialExecutor` (this process, the reference path) and :class:`DaskExecutor` (a
``distributed.Client``) share the :class:`concurrent.futures.Executor` protocol plus
:meth:`Executor.outcomes` (per-item failures as :class:`TaskFailure`, one shared object sent once).
Which one a batch gets is :func:`zonotope.parallel.executor`'s choice.
"""

from __future__ import annotations

import traceback
from collections.abc import Callable, Iterable, Iterator
from concurrent.futures import Executor as _Executor
from concurrent.futures import Future
from dataclasses import dataclass
from typing import Any

from .._errors import ZonotopeError
from ..utilities.progress import ProgressCallback

__all__ = ["DaskExecutor", "Executor", "ParallelError", "SerialExecutor", "TaskFailure", "dask_available"]


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
