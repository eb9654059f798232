"""3-D LUTs of a camera's estimator for ``isp profile --lut``: grouped sampling and a self-describing header.

:func:`profile_LUT` samples a :class:`isp.MetamerCorrection` into the shaper + 3-D LUT of
:func:`zonotope.correct.profile.correction_LUT` (same lattice, shaper, output space and
clamping). An MMV-based estimator such as Prior solves one problem per lattice node that its
closed form does not cover (98 % of a 33³ lattice: the nodes outside the object-colour solid and
above the white), ≈ 7 CPU-ms each. The whole lattice goes to the estimator in one call, so that
:func:`zonotope.correct.correct_image` groups the nodes that need a solver across the lattice
(greedy leader clustering within ``quantum`` of a leader response in every channel, each group
solved once and carried to its members with the estimator's closed form, as it does for
photographs); nodes with a closed form stay exact. ``quantum=0`` solves every node.

:func:`lut_header` writes what the LUT is for into the file's comments: camera, estimator,
scene illuminant, input encoding (white-balanced camera RGB, the white at 1) and output space.
"""

from __future__ import annotations

import dataclasses

from .._errors import PipelineError
from .._tol import LUT_QUANTUM

__all__ = ["lut_header", "profile_LUT"]


def profile_LUT(correction, config=None, *, quantum: float = LUT_QUANTUM, progress=None, **options):
    """Shaper + 3-D LUT of ``correction``, the nodes that need a solver grouped within ``quantum``.

    Parameters
    ----------
    correction : isp.MetamerCorrection
        The estimator (white-balanced camera RGB, white = 1 → XYZ).
    config : zonotope.correct.LUTConfig, optional
        Lattice size, output space, headroom, shaper (default all defaults).
    quantum : float
        Grouping radius in response units (white = 1), ≥ 0; 0 solves every node exactly (as
        :func:`zonotope.correct.profile.correction_LUT` of ``correction`` with ``quantum=0``).
    progress
        ``progress("distinct colours", done, total)`` over the groups solved.
    **options
        :class:`zonotope.correct.LUTConfig` fields as keywords.

    Returns
    -------
    colour.LUTSequence
        As :func:`zonotope.correct.profile.correction_LUT`.
    """
    from zonotope.correct.profile import LUTConfig, correction_LUT
    from zonotope.utilities.config import with_options

    cfg = with_options(LUTConfig, config, options, where="profile_LUT")
    try:
        ok = not isinstance(quantum, bool) and float(quantum) >= 0 and float(quantum) < float("inf")
    except (TypeError, ValueError):
        ok = False
    if not ok:
        raise PipelineError(f"quantum={quantum!r}: give a grouping radius ≥ 0 in response units (0: exact).")
    grouped = dataclasses.replace(correction, quantum=float(quantum), progress=progress)
    return correction_LUT(grouped, dataclasses.replace(cfg, batch=cfg.size**3))


def lut_header(
    lut, *, camera: str, method: str, illuminant: str, space: str, headroom: float, quantum: float
):
    """Put what a LUT is for into its comments (a ``.cube``'s header lines).

    Parameters
    ----------
    lut : colour.LUTSequence
        From :func:`profile_LUT`; changed in place and returned.
    camera, method, illuminant, space
        Camera, estimator, scene illuminant of the fit and linear output space.
    headroom
        Largest input in units of the white.
    quantum
        The grouping radius the lattice was sampled with (0: every node exactly).
    """
    lut3d = lut[-1]
    adapted = " (the white adapted to the space's white, Bradford)" if space != "XYZ" else ""
    lines = [
        f"zonotope: camera {camera}, estimator {method}, scene illuminant {illuminant}",
        f"input: linear camera RGB white-balanced for {illuminant} (the scene white at 1, 1, 1), "
        f"domain 0 to {headroom:g}",
        f"output: linear {space}{adapted}",
        "every lattice node solved exactly"
        if quantum == 0
        else f"nodes within {quantum:g} of each other solved once (closed-form transfer)",
    ]
    lut3d.comments = lines + [c for c in lut3d.comments if not c.startswith("zonotope: white")]
    return lut
