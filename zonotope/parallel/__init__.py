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

The code is in three modules, one per concept: :mod:`~zonotope.parallel.executors` (the map:
serial and Dask executors), :mod:`~zonotope.parallel.cluster` (the scheduler choice, TLS security,
:func:`executor`) and :mod:`~zonotope.parallel.files` (folder batches and their record); every public
name is importable from ``zonotope.parallel``.
"""

from __future__ import annotations

from .cluster import (
    ENV_VAR,
    SCHEDULER_HELP,
    SECURITY_ENV_VAR,
    executor,
    resolve_scheduler,
)
from .executors import DaskExecutor, Executor, ParallelError, SerialExecutor, TaskFailure, dask_available
from .files import (
    BATCH_RECORD,
    FILE_MIN_TASKS,
    MANIFEST_COLUMNS,
    FileTask,
    _check_tasks,  # noqa: F401  (zonotope.cli.batch checks a folder's tasks before the fit)
    check_batch_folder,
    check_settings,
    run_files,
)

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
