"""Timing shared by the benchmark scripts: the median wall-clock time of repeated calls.

Scripts run as ``python benchmarks/bench_X.py`` (this folder is then first on ``sys.path``) import it
as ``_timing``; imported as ``benchmarks.bench_X`` they take it from the ``benchmarks`` package.
"""

from __future__ import annotations

import statistics
import time
from collections.abc import Callable
from typing import Any


def median_time(
    fn: Callable[[], Any],
    repeats: int,
    *,
    warmup: bool = False,
    sync: Callable[[Any], Any] | None = None,
) -> float:
    """Median wall-clock seconds of ``repeats`` calls of ``fn()``.

    Parameters
    ----------
    fn
        Called with no arguments.
    repeats
        Number of timed calls (≥ 1).
    warmup
        Call ``fn`` once, untimed, first (JIT compilation, caches).
    sync
        Applied to each result inside the timed region, e.g. ``jax.block_until_ready``: JAX returns
        before the work is done.
    """
    if repeats < 1:
        raise ValueError(f"repeats={repeats!r}: give at least 1 timed call")
    finish = sync if sync is not None else (lambda result: result)
    if warmup:
        finish(fn())
    times = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        finish(fn())
        times.append(time.perf_counter() - t0)
    return statistics.median(times)
