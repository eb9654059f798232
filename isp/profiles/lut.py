"""3-D LUTs of a camera's estimator for ``isp profile --lut``: fast sampling and a self-describing header.

:func:`profile_LUT` samples a :class:`isp.MetamerCorrection` into the shaper + 3-D LUT of
:func:`zonotope.correct.profile.correction_LUT` (same lattice, shaper, output space and
clamping), but evaluates the estimator's costly part only on a sub-lattice: an MMV-based
estimator such as Prior solves one problem per lattice node (≈ 25 ms each, so 16 minutes for
33³ nodes), while its **closed-form part** (the estimator's own ``closed_form`` rows, else its
regression) costs microseconds. The LUT holds ``base(c) + r(c)`` with the residual
``r = estimator − base`` computed exactly on every ``stride``-th node per axis (and the last) and
trilinearly interpolated between them in lattice coordinates (the log2 shaper's, so evenly in
stops); sub-lattice nodes are exact. ``stride=1`` samples every node exactly (the reference
twin). The residual is what the MMV adds to a regression — smooth over the lattice — so it
interpolates far better than the estimate itself would from a coarser LUT.

:func:`lut_header` writes what the LUT is for into the file's comments: camera, estimator,
scene illuminant, input encoding (white-balanced camera RGB, the white at 1) and output space.
"""

from __future__ import annotations

import dataclasses

import numpy as np

from .._errors import PipelineError

__all__ = ["lut_header", "profile_LUT"]


def _base(corrector):
    """The cheap part of an estimator: its closed-form rows, else its regression."""
    closed = corrector.params.get("closed_form")
    if closed is not None:
        return lambda c: np.asarray(closed(c)[0], dtype=np.float64)
    reg = corrector.params.get("regression")
    if reg is None:
        from zonotope.correct import fit_correction

        reg = fit_correction(corrector.problem, method="Finlayson 2015")
    return lambda c: np.asarray(reg(c), dtype=np.float64)


def _over(c: np.ndarray) -> np.ndarray:
    return np.maximum(c.max(axis=-1, keepdims=True), 1.0)


def profile_LUT(correction, config=None, *, stride: int = 4, progress=None, **options):
    """Shaper + 3-D LUT of ``correction``, the costly part evaluated on a sub-lattice.

    Parameters
    ----------
    correction : isp.MetamerCorrection
        The estimator (white-balanced camera RGB, white = 1 → XYZ).
    config : zonotope.correct.LUTConfig, optional
        Lattice size, output space, headroom, shaper (default all defaults).
    stride : int
        Exact evaluation on every ``stride``-th node per axis (≥ 1; 1: every node, as
        :func:`zonotope.correct.profile.correction_LUT`). Regression estimators (cheap everywhere)
        are always sampled exactly.
    progress
        ``progress("LUT nodes", done, total)`` over the exactly evaluated nodes.
    **options
        :class:`zonotope.correct.LUTConfig` fields as keywords.

    Returns
    -------
    colour.LUTSequence
        As :func:`zonotope.correct.profile.correction_LUT`.
    """
    from zonotope.correct import CORRECTION_METHODS
    from zonotope.correct.profile import LUTConfig, correction_LUT, shaper_decode, white_node_toe
    from zonotope.utilities.config import with_options

    cfg = with_options(LUTConfig, config, options, where="profile_LUT")
    if isinstance(stride, bool) or not isinstance(stride, int | np.integer) or stride < 1:
        raise PipelineError(f"stride={stride!r}: give an integer ≥ 1 (1: every lattice node exactly).")
    corrector = correction.corrector
    if stride == 1 or CORRECTION_METHODS.properties(corrector.method)["closed_form"]:
        return correction_LUT(correction, cfg, progress=progress)
    n = cfg.size
    toe = white_node_toe(cfg.headroom, n)
    nodes = shaper_decode(np.linspace(0.0, 1.0, n), headroom=cfg.headroom, shaper=cfg.shaper, toe=toe)
    grid = np.stack(np.meshgrid(nodes, nodes, nodes, indexing="ij"), axis=-1).reshape(-1, 3)
    scaled = grid / _over(grid)  # what correction_LUT hands the estimator: ≤ 1, scaled back after
    wl = float(getattr(correction, "white_level", 1.0))  # MetamerCorrection's exposure of the white
    B = _base(corrector)(scaled / wl) * wl
    coarse = np.unique(np.append(np.arange(0, n, stride), n - 1))
    idx = np.stack(np.meshgrid(coarse, coarse, coarse, indexing="ij"), axis=-1).reshape(-1, 3)
    flat = (idx[:, 0] * n + idx[:, 1]) * n + idx[:, 2]
    E = np.empty((flat.size, 3))
    step = max(1, cfg.batch)
    for i in range(0, flat.size, step):
        E[i : i + step] = np.asarray(correction(scaled[flat[i : i + step]]), dtype=np.float64)
        if progress is not None:
            progress("LUT nodes", min(i + step, flat.size), flat.size)
    from scipy.interpolate import RegularGridInterpolator

    R = (E - B[flat]).reshape(coarse.size, coarse.size, coarse.size, 3)
    ijk = np.stack(np.meshgrid(*(np.arange(n),) * 3, indexing="ij"), axis=-1).reshape(-1, 3)
    final = B + RegularGridInterpolator((coarse,) * 3, R, method="linear")(ijk.astype(np.float64))
    final[flat] = E  # the sub-lattice exactly
    if not np.all(np.isfinite(final)):
        raise PipelineError("the estimator returned NaN or inf on some lattice nodes; it cannot be sampled.")

    def sampled(c):
        c = np.asarray(c, dtype=np.float64)
        if c.shape == scaled.shape and np.array_equal(c, scaled):
            return final
        return np.asarray(correction(c), dtype=np.float64)  # the white, or any other call: exactly

    return correction_LUT(sampled, dataclasses.replace(cfg, batch=grid.shape[0]))


def lut_header(lut, *, camera: str, method: str, illuminant: str, space: str, headroom: float, stride: int):
    """Put what a LUT is for into its comments (a ``.cube``'s header lines).

    Parameters
    ----------
    lut : colour.LUTSequence
        From :func:`profile_LUT`; changed in place and returned.
    camera, method, illuminant, space
        Camera, estimator, scene illuminant of the fit and linear output space.
    headroom
        Largest input in units of the white.
    stride
        Sub-lattice stride the estimator was evaluated exactly on (1: every node).
    """
    lut3d = lut[-1]
    lines = [
        f"zonotope: camera {camera}, estimator {method}, scene illuminant {illuminant}",
        f"input: linear camera RGB white-balanced for {illuminant} (the scene white at 1, 1, 1), "
        f"domain 0 to {headroom:g}",
        f"output: linear {space}"
        + (" (the white adapted to the space's white, Bradford)" if space != "XYZ" else ""),
        "sampled exactly on every node"
        if stride == 1
        else f"estimator exact on every {stride}th node per axis, its residual over the closed form "
        "interpolated between them",
    ]
    lut3d.comments = lines + [c for c in lut3d.comments if not c.startswith("zonotope: white")]
    return lut
