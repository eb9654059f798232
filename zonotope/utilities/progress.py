"""The one progress-callback type of the three packages: ``progress(stage, done, total)``.

Library code prints nothing and draws no bars. Every long-running function takes an optional
``progress`` argument of type :class:`ProgressCallback` and calls it as it goes; the command
lines (``zonotope``, ``isp``, ``splat``) and the benchmarks turn the calls into bars or lines.

The contract
------------
``stage`` : str
    A short human-readable name of the step being counted (``"metamer mismatch volumes"``,
    ``"distinct colours"``, ``"train"``, ``"Nikon 5100 (NPL) · ColorChecker: Centroid"``). A
    display starts a new bar when the name changes.
``done`` : int
    Units finished in this stage, ``0 ≤ done ≤ total``, never decreasing within a stage. A
    function may call with ``done = 0`` to announce a stage before its first unit.
``total`` : int
    Units in the stage (≥ 0), constant within a stage.

Calls come from the caller's thread, in order; a callback must be cheap and must not raise
(an exception from it propagates and stops the work). Functions that split their work into
sub-stages report each under its own name; functions that run others (``evaluate``,
``write_report``, ``splat.pipeline.run``) hand the same callback down.

Examples
--------
>>> seen = []
>>> def progress(stage: str, done: int, total: int) -> None:
...     seen.append((stage, done, total))
>>> import numpy as np, zonotope
>>> Phi = zonotope.generators("Nikon 5100 (NPL)", shape=np.arange(400, 701, 20.0)).values
>>> out = zonotope.metamer_mismatch_batch(Phi, Phi, np.full((3, 16), 0.5) @ Phi, chunk=2,
...                                       progress=progress)
>>> seen
[('metamer mismatch volumes', 2, 3), ('metamer mismatch volumes', 3, 3)]
"""

from __future__ import annotations

from typing import Protocol

__all__ = ["ProgressCallback"]


class ProgressCallback(Protocol):
    """``progress(stage, done, total)``: see the module docstring for the contract."""

    def __call__(self, stage: str, done: int, total: int, /) -> None:
        """Record that ``done`` of ``total`` units of ``stage`` are finished."""
