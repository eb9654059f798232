"""The work folder a scoring benchmark reads: a finished run of a capture that has a truth.

Run as scripts (``python benchmarks/bench_X.py``) the benchmarks import this module as ``_workfolder``;
imported as ``benchmarks.bench_X`` they take it from the ``benchmarks`` package.
"""

from __future__ import annotations

import argparse
from pathlib import Path

__all__ = ["add_work_arguments", "work_folders"]


def add_work_arguments(ap: argparse.ArgumentParser) -> None:
    """``--work`` (a ``bench_capture_accuracy`` work folder), or ``--capture`` and ``--out``."""
    ap.add_argument("--work", type=Path, help="a bench_capture_accuracy work folder (capture/, out/)")
    ap.add_argument("--capture", type=Path, help="the capture (default WORK/capture)")
    ap.add_argument("--out", type=Path, help="the run's output folder (default WORK/out)")


def work_folders(ap: argparse.ArgumentParser, a: argparse.Namespace) -> tuple[Path, Path]:
    """``(capture, out)`` from the parsed arguments; ``ap.error`` (one line, exit 2) unless the capture
    has the simulator's truth (``truth/xyz``) and ``out`` a finished render step."""
    capture = a.capture or (a.work / "capture" if a.work else None)
    out = a.out or (a.work / "out" if a.work else None)
    if capture is None or out is None:
        ap.error("give --work, or --capture and --out")
    if not (capture / "truth" / "xyz").is_dir() or not (out / "render" / "index.json").is_file():
        ap.error(f"{capture} needs truth/xyz and {out} a finished render step")
    return capture, out
