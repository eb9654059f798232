"""The report step: ``OUT/report.html`` from what the other steps wrote (the page itself is
:mod:`splat.report`).
"""

from __future__ import annotations

import os
from pathlib import Path
from typing import TYPE_CHECKING

from .chart import chart_of
from .config import PipelineConfig, step_workspace
from .files import read_index

if TYPE_CHECKING:
    from zonotope.utilities import ProgressCallback

__all__ = [
    "report_step",
]


def report_step(
    capture: str | os.PathLike,
    out: str | os.PathLike,
    *,
    config: PipelineConfig = PipelineConfig(),
    progress: ProgressCallback | None = None,
) -> Path:
    """Write ``OUT/report.html`` (:mod:`splat.report`): per photograph the corrected image beside the
    camera's own development, the marked card's ΔE00 where there is one, what was done, how long it took
    and what to do next; the step summaries collapsed below."""
    from ..report import write_report

    spec, ws = step_workspace(capture, out, config, "report", lambda spec: {})
    ws.check_made_from(spec)  # a capture edited since the run: its old results are not reported as new
    spec = chart_of(spec, ws)  # the poses step found them, unless [chart] was added after it ran
    out = ws.root
    index = (
        read_index(spec, out / "render" / "index.json") if (out / "render" / "index.json").is_file() else {}
    )
    return write_report(spec, out, index, default_steps=PipelineConfig.steps)
