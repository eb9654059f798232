"""A real Dask cluster on localhost for the tests: ``dask scheduler`` and ``dask worker`` processes.

Started with subprocess on free ports (no nanny, one thread each), so that a test can SIGKILL one
worker mid-run the way a crashed machine would go away.
"""

from __future__ import annotations

import os
import signal
import socket
import subprocess
import sys
import time
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


class LocalDaskCluster:
    """``dask scheduler`` + ``n`` ``dask worker`` processes; ``address``, ``kill_worker``, ``close``."""

    def __init__(self, n_workers: int = 2, timeout: float = 60.0):
        pytest.importorskip("distributed")
        self.dask = str(Path(sys.executable).with_name("dask"))
        if not Path(self.dask).exists():
            pytest.skip("the dask command is not installed next to this Python")
        self.port = _free_port()
        self.address = f"tcp://127.0.0.1:{self.port}"
        path = os.pathsep.join([str(ROOT), os.environ.get("PYTHONPATH", "")])
        self.env = {**os.environ, "PYTHONPATH": path, "OMP_NUM_THREADS": "1", "JAX_PLATFORMS": "cpu"}
        self.env.pop("ZONOTOPE_SCHEDULER", None)
        self.procs: list[subprocess.Popen] = []
        self.scheduler = self._spawn(
            [self.dask, "scheduler", "--host", "127.0.0.1", "--port", str(self.port), "--no-dashboard"]
        )
        self.workers: list[subprocess.Popen] = []
        for _ in range(n_workers):
            self.add_worker()
        self.wait_for(n_workers, timeout)

    def _spawn(self, cmd) -> subprocess.Popen:
        p = subprocess.Popen(
            cmd,
            cwd=ROOT,
            env=self.env,
            stdout=subprocess.DEVNULL,
            stderr=subprocess.DEVNULL,
            process_group=0,  # its own group: a Ctrl-C of the test run reaches pytest, not the workers
        )
        self.procs.append(p)
        return p

    def add_worker(self) -> subprocess.Popen:
        """Start one more worker (one thread, no nanny: SIGKILL ends it at once)."""
        w = self._spawn(
            [
                self.dask,
                "worker",
                self.address,
                "--nthreads",
                "1",
                "--no-nanny",
                "--no-dashboard",
                "--host",
                "127.0.0.1",
                "--death-timeout",
                "60",
            ]
        )
        self.workers.append(w)
        return w

    def wait_for(self, n: int, timeout: float = 60.0) -> None:
        """Block until ``n`` workers are registered with the scheduler."""
        from distributed import Client

        deadline = time.monotonic() + timeout
        with Client(self.address, timeout=timeout) as client:
            while len(client.scheduler_info()["workers"]) < n:
                if time.monotonic() > deadline:
                    got = len(client.scheduler_info()["workers"])
                    raise RuntimeError(f"only {got} of {n} workers came up")
                time.sleep(0.2)

    def kill_worker(self) -> None:
        """SIGKILL the oldest living worker (no goodbye to the scheduler) and start a replacement,
        which joins while the batch goes on (later tests again find two workers)."""
        w = next(w for w in self.workers if w.poll() is None)
        os.kill(w.pid, signal.SIGKILL)
        w.wait(10)
        self.workers.remove(w)
        self.add_worker()

    def close(self) -> None:
        for p in reversed(self.procs):
            if p.poll() is None:
                p.terminate()
        for p in self.procs:
            try:
                p.wait(10)
            except subprocess.TimeoutExpired:
                p.kill()
                p.wait(10)
