"""3-D LUTs of a camera's estimator for ``isp profile --lut``: grouped sampling and a self-describing header.

:func:`profile_LUT` samples a :class:`isp.MetamerCorrection` into the shaper + 3-D LUT of
:func:`zonotope.correct.profile.correction_LUT` (same lattice, shaper, output space and
clamping). An MMV-based estimator such as Prior solves one problem per lattice node that its
closed form does not cover (98 % of a 33³ lattice: the nodes outside the object-colour solid and
above the white), ≈ 1.2 CPU-ms each (7 before the exact distance to the solid and the batched
exact-constraint MAP of ``zonotope``; ``docs/notes/2026-11-29-lut-speed.md``). The whole lattice
goes to the estimator in one call, so that :func:`zonotope.correct.correct_image` groups the nodes
that need a solver across the lattice (greedy leader clustering within ``quantum`` of a leader
response in every channel, each group solved once and carried to its members with the estimator's
closed form, as it does for photographs); nodes with a closed form stay exact. ``quantum=0`` solves
every node.

Most nodes of the lattice (4,518 of 4,913 at 17³ for a Nikon 5100 under D65) lie outside the
object-colour solid: no surface under the fit's illuminant has those responses. Those whose
neighbouring cells cannot meet the solid never enter the interpolation of a real colour; they are
grouped within the coarser ``outside_quantum``, the others within ``quantum`` (measured in
``docs/notes/2026-11-29-lut-speed.md``).

:func:`lut_header` writes what the LUT is for into the file's comments: camera, estimator,
scene illuminant, input encoding (white-balanced camera RGB, the white at 1) and output space.
"""

from __future__ import annotations

import dataclasses

import numpy as np

from .._errors import PipelineError
from .._tol import LUT_OUTSIDE_QUANTUM, LUT_QUANTUM

__all__ = ["lut_header", "profile_LUT"]


class _SolidSplit:
    """Responses (white = 1) → XYZ: the lattice nodes ``fine`` (those a real colour's cell can use)
    grouped within ``quantum``, the others within ``outside_quantum`` (one grouped call each), the
    progress summed over both. Rows other than the lattice ``grid`` are fine where they lie in the
    object-colour solid."""

    def __init__(self, correction, quantum: float, outside_quantum: float, progress, grid=None, fine=None):
        import zonotope

        self.white_level = correction.white_level
        self.solid = zonotope.Zonotope(correction.corrector.problem.Phi)
        self.grid, self.fine = grid, fine
        counts = {"inside": (0, 0), "outside": (0, 0)}

        def part(name):
            if progress is None:
                return None

            def report(stage, done, total):
                counts[name] = (done, total)
                progress(stage, sum(d for d, _ in counts.values()), sum(t for _, t in counts.values()))

            return report

        self.inside = dataclasses.replace(correction, quantum=quantum, progress=part("inside"))
        self.outside = dataclasses.replace(correction, quantum=outside_quantum, progress=part("outside"))

    def __call__(self, c):
        c = np.asarray(c, dtype=np.float64)
        if self.grid is not None and c.shape == self.grid.shape and np.array_equal(c, self.grid):
            inside = self.fine
        else:
            inside = self.solid.contains(np.maximum(c, 0.0) / self.white_level)
        out = np.empty((c.shape[0], 3))
        for rows, fn in ((inside, self.inside), (~inside, self.outside)):
            if rows.any():
                out[rows] = fn(c[rows])
        return out


def _near_nodes(solid, cfg, white_level: float):
    """The lattice of :func:`zonotope.correct.profile.correction_LUT` as its estimator sees it (nodes
    above the white scaled onto the cube's faces), and which nodes are corners of a cell that can meet
    the object-colour solid: those within the half-diagonal of their neighbouring cells of it (the
    solid's facets have unit normals, so ``contains(atol=r)`` holds every point within r)."""
    from zonotope.correct.profile import shaper_decode, white_node_toe

    size = cfg.size
    toe = white_node_toe(cfg.headroom, size)
    nodes = shaper_decode(np.linspace(0.0, 1.0, size), headroom=cfg.headroom, shaper=cfg.shaper, toe=toe)
    step = np.diff(nodes)
    reach = np.maximum(np.r_[step, step[-1]], np.r_[step[0], step])  # the larger neighbouring spacing
    idx = np.stack(np.meshgrid(*(np.arange(size),) * 3, indexing="ij"), axis=-1).reshape(-1, 3)
    points = nodes[idx]
    radius = np.sqrt(3.0) * reach[idx].max(axis=1)
    fine = np.zeros(points.shape[0], dtype=bool)
    for r in np.unique(radius):
        rows = radius == r
        fine[rows] = solid.contains(points[rows] / white_level, atol=float(r) / white_level)
    c = np.maximum(points, 0.0)
    return c / np.maximum(c.max(axis=-1, keepdims=True), 1.0), fine


def _radius(value, name: str) -> float:
    try:
        ok = not isinstance(value, bool) and 0 <= float(value) < float("inf")
    except (TypeError, ValueError):
        ok = False
    if not ok:
        raise PipelineError(f"{name}={value!r}: give a grouping radius ≥ 0 in response units (0: exact).")
    return float(value)


def profile_LUT(
    correction,
    config=None,
    *,
    quantum: float = LUT_QUANTUM,
    outside_quantum: float | None = LUT_OUTSIDE_QUANTUM,
    progress=None,
    **options,
):
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
    outside_quantum : float, optional
        Grouping radius of the nodes whose neighbouring cells cannot meet the object-colour solid
        (default :data:`isp._tol.LUT_OUTSIDE_QUANTUM`); None: ``quantum`` for every node.
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
    quantum = _radius(quantum, "quantum")
    outside = quantum if outside_quantum is None else _radius(outside_quantum, "outside_quantum")
    if quantum == 0 or outside == quantum:
        grouped = dataclasses.replace(correction, quantum=quantum, progress=progress)
    else:
        grouped = _SolidSplit(correction, quantum, outside, progress)
        grouped.grid, grouped.fine = _near_nodes(grouped.solid, cfg, correction.white_level)
    return correction_LUT(grouped, dataclasses.replace(cfg, batch=cfg.size**3))


def lut_header(
    lut,
    *,
    camera: str,
    method: str,
    illuminant: str,
    space: str,
    headroom: float,
    quantum: float,
    outside_quantum: float | None = None,
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
    outside_quantum
        The radius of the nodes no surface colour is interpolated from, when it differs.
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
        else f"nodes within {quantum:g} of each other solved once (closed-form transfer)"
        + (
            f"; nodes no surface colour is interpolated from within {outside_quantum:g}"
            if outside_quantum not in (None, quantum)
            else ""
        ),
    ]
    lut3d.comments = lines + [c for c in lut3d.comments if not c.startswith("zonotope: white")]
    return lut
