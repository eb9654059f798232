"""Runs the steps of a capture run in order (:func:`run`)."""

from __future__ import annotations

import os
from typing import TYPE_CHECKING

from .._errors import SplatError
from .config import STEPS, PipelineConfig
from .correct import correct_step
from .poses import poses_step
from .render import render_step
from .report import report_step
from .train import fit_step

if TYPE_CHECKING:
    from zonotope.utilities import ProgressCallback

__all__ = [
    "run",
]


def run(
    capture: str | os.PathLike,
    out: str | os.PathLike,
    *,
    config: PipelineConfig = PipelineConfig(),
    steps=STEPS,
    progress: ProgressCallback | None = None,
) -> dict:
    """Run the steps in order (each skipped or resumed when its results exist); returns their results."""
    fns = {
        "poses": poses_step,
        "train": fit_step,
        "render": render_step,
        "correct": correct_step,
        "report": report_step,
    }
    bad = [s for s in steps if s not in fns]
    if bad:
        raise SplatError(f"unknown step(s) {bad}; steps are {list(STEPS)}.")
    return {s: fns[s](capture, out, config=config, progress=progress) for s in steps}
