"""What the uncertainty band of estimated sensitivities does to a correction and to an MMV.

:func:`ssf_noise` widens a noise model by the band carried to white-balanced responses, so that any
estimator of :data:`~zonotope.correct.CORRECTION_METHODS` can be fitted on estimated curves without
trusting channel differences finer than they are known; :func:`band_mmvs` computes the metamer
mismatch volume of one reflectance with the estimate and with cameras drawn within its band
(:func:`~zonotope.spectra.estimate.sample_ssfs`), and how far they differ (volume, centroid ΔE00).
"""

from __future__ import annotations

from dataclasses import dataclass

import colour
import numpy as np

from ._errors import SpectralDataError
from ._tol import SSF_SAMPLE_CORRELATION_NM
from .correct.noise import NoiseModel, noise_model
from .correct.problem import CorrectionProblem, correction_problem
from .spectra.estimate import SSFEstimate, sample_ssfs

__all__ = ["BandMMVs", "band_mmvs", "ssf_noise"]


def ssf_noise(
    estimate: SSFEstimate, noise=None, *, illuminant="D65", reflectances="rawtoaces 190"
) -> NoiseModel:
    """``noise`` (None, σ, σ per channel or a :class:`~zonotope.correct.NoiseModel`) with the band's
    response σ (:meth:`SSFEstimate.response_sigma`) added in quadrature to its read variance.

    Give the result as ``noise=`` to a fit (``noise_options(method, model)``) on ``estimate``'s
    curves. Why: the band is an error of the curves that every response carries, independent of
    the sensor noise, so the variances add.

    Raises
    ------
    NoiseModelError
        ``noise`` negative, NaN, or not of 3 channels.
    """
    base = noise_model(noise, 3) or NoiseModel.constant(0.0, 3, source="noise-free")
    band = estimate.response_sigma(illuminant, reflectances)
    return NoiseModel(base.shot, base.read + band**2, source=f"{base.source} + SSF band")


@dataclass(frozen=True, eq=False)
class BandMMVs:
    """The MMV of one reflectance with an estimate and with cameras drawn within its band.

    Attributes
    ----------
    problem : CorrectionProblem
        The estimate as the source camera.
    samples : list of CorrectionProblem
        One per drawn camera (same target and illuminant).
    reflectance : ndarray of shape (n,)
    mmv, sample_mmvs : Polytope, list of Polytope
        The certified inner MMVs (target space).
    centroid_delta_e : ndarray of shape (len(samples),)
        ΔE00 between each sample MMV's centroid and the estimate MMV's centroid.
    """

    problem: CorrectionProblem
    samples: list
    reflectance: np.ndarray
    mmv: object
    sample_mmvs: list
    centroid_delta_e: np.ndarray

    @property
    def volume(self) -> float:
        """Volume of the estimate's MMV."""
        return float(self.mmv.volume)

    @property
    def sample_volumes(self) -> np.ndarray:
        """Volumes of the sample MMVs, shape (len(samples),)."""
        return np.array([float(m.volume) for m in self.sample_mmvs])


def band_mmvs(
    estimate: SSFEstimate,
    reflectance,
    *,
    n: int = 8,
    seed: int = 0,
    k: float | None = None,
    correlation: float = SSF_SAMPLE_CORRELATION_NM,
    illuminant="D65",
    target="CIE 2015 2°",
) -> BandMMVs:
    """The MMV of ``reflectance`` (array on the estimate's grid, or a colour SD) with the estimate and
    with ``n`` cameras drawn within ``k`` σ of its band (default its calibrated ``band_k``), each from its
    own response to it (``correlation``: of the draws, as :func:`~zonotope.spectra.estimate.sample_ssfs`).

    Why: the MMV is what a correction cannot know; this shows how much of it is the camera's and how
    much the curves' uncertainty (draw them with :func:`zonotope.viz.plot_mmv_band`).
    """
    from .mismatch.volume import metamer_mismatch_bounds

    w = estimate.wavelengths
    shape = colour.SpectralShape(w[0], w[-1], w[1] - w[0])
    if isinstance(reflectance, colour.SpectralDistribution):
        x = np.asarray(reflectance.copy().align(shape).values, dtype=np.float64)
    else:
        x = np.asarray(reflectance, dtype=np.float64)
    if x.shape != w.shape:
        raise SpectralDataError(
            f"band_mmvs reflectance has shape {x.shape}; give {w.size} values on {w[0]:g}–{w[-1]:g} nm."
        )
    problems = [
        correction_problem(cam, target=target, illuminant=illuminant, shape=shape)
        for cam in [
            estimate.sensitivities,
            *sample_ssfs(estimate, n, seed=seed, k=k, correlation=correlation),
        ]
    ]
    mmvs = [
        metamer_mismatch_bounds(pb.Phi, pb.Psi, x @ pb.Phi, on_infeasible="nearest").inner for pb in problems
    ]
    dE = np.array([float(problems[0].delta_E(m.centroid, mmvs[0].centroid)) for m in mmvs[1:]])
    return BandMMVs(problems[0], problems[1:], x, mmvs[0], mmvs[1:], dE)
