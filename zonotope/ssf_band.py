"""What the uncertainty band of estimated sensitivities does to a correction and to an MMV.

:func:`ssf_noise` widens a noise model by the band carried to white-balanced responses, so that any
estimator of :data:`~zonotope.correct.CORRECTION_METHODS` can be fitted on estimated curves without
trusting channel differences finer than they are known; :func:`band_mmvs` computes the metamer
mismatch volume of one reflectance with the estimate and with cameras drawn within its band
(:func:`~zonotope.spectra.estimate.sample_ssfs`), and how far they differ (volume, centroid ΔE00);
:func:`ssf_response_errors` gives a fit of stacked estimated cameras draws of their responses' error
(:func:`zonotope.correct.eiv.fit_errors_in_variables`), correlated as the held-out estimates' were;
:func:`unit_sigma` is what measured curves of another unit of the same model carry.
"""

from __future__ import annotations

from dataclasses import dataclass

import colour
import numpy as np

from ._errors import SpectralDataError
from ._tol import SSF_ERROR_DRAW_SCALE, SSF_ERROR_PROBLEM_ATOL, SSF_SAMPLE_CORRELATION_NM, SSF_UNIT_SIGMA
from .correct.noise import NoiseModel, noise_model
from .correct.problem import CorrectionProblem, correction_problem
from .spectra.estimate import SSFEstimate, sample_ssfs

__all__ = ["BandMMVs", "band_mmvs", "curves_sigma", "ssf_noise", "ssf_response_errors", "unit_sigma"]


def unit_sigma(n_cameras: int, *, exact=()) -> np.ndarray:
    """σ per channel (3 per camera, white → 1) that measured curves carry when they are a published
    measurement of the camera's model rather than of the very camera: :data:`~zonotope._tol.SSF_UNIT_SIGMA`
    for each camera of a stack of two or more, 0 for one camera alone and for the cameras whose index
    is in ``exact`` (curves measured on that very unit). Add it to the images' noise in quadrature for
    the cameras with measured curves (estimated ones carry their own band, :func:`ssf_noise`).

    Why: two measurements of one model differ by more than the DNG-matrix estimate of either does from
    it (responses 0.0105 / 0.0036 / 0.0037 RMS against 0.0047 / 0.0023 / 0.0030), and a stacked fit told
    only the images' noise leans on them: +3.6 / +6.0 ΔE00 for 2 / 3 cameras noise-free, +0.60 / +0.83
    told this σ (docs/notes/2026-12-01-published-curves.md); one camera loses nothing measurable
    either way, so it is left alone.
    """
    if not (isinstance(n_cameras, (int, np.integer)) and n_cameras >= 1):
        raise ValueError(f"n_cameras = {n_cameras!r}: expected a whole number ≥ 1.")
    out = np.tile(np.asarray(SSF_UNIT_SIGMA, dtype=np.float64), (n_cameras, 1))
    if n_cameras == 1:
        out[:] = 0.0
    for k in exact:
        out[k] = 0.0
    return out.ravel()


def curves_sigma(estimates, illuminant, *, exact=()) -> np.ndarray:
    """σ per channel (3 per camera, white → 1) of the response error each camera's curves carry, for
    one fit of the cameras together: an estimate's band (:meth:`SSFEstimate.response_sigma` under
    ``illuminant``) where ``estimates[i]`` is one, else measured curves' :func:`unit_sigma` (0 for the
    cameras in ``exact`` and for one camera alone). Why: the capture's correct step and ``zonotope
    correct`` tell a fit the same uncertainty of the same curves."""
    unit = unit_sigma(len(estimates), exact=exact).reshape(-1, 3)
    return np.concatenate(
        [
            u if e is None else np.asarray(e.response_sigma(illuminant), float)
            for e, u in zip(estimates, unit, strict=True)
        ]
    )


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


def ssf_response_errors(
    estimates,
    problem: CorrectionProblem,
    *,
    illuminant="D65",
    seed: int = 0,
    scale: float = SSF_ERROR_DRAW_SCALE,
) -> np.ndarray:
    """Draws of the error of ``problem``'s training responses when its cameras are ``estimates``:
    shape (M, N, 3·len(estimates)).

    Each camera's draws are :meth:`SSFEstimate.response_errors` of the training set (``scale``: the
    multiple of the held-out errors, default :data:`~zonotope._tol.SSF_ERROR_DRAW_SCALE`), in an order
    shuffled per camera (``seed``), so that one draw pairs different held-out cameras' errors: the
    cameras' errors are then related only as much as the held-out errors share (their mean). ``M``: the
    fewest draws of any camera. Give them to
    :func:`zonotope.correct.eiv.fit_errors_in_variables`. Why: the curves' error is correlated over
    wavelengths and channels, which a per-channel σ (:func:`ssf_noise`) cannot tell a fit; on natural
    surfaces without much sensor noise the fit gains 0.03–0.06 ΔE00 over :func:`ssf_noise`, on
    narrow-band (atypical) spectra it loses up to 0.36 (docs/notes/2026-11-29-ssf-goal.md, section 4).

    Raises
    ------
    SpectralDataError
        ``problem``'s source responses are not those of ``estimates`` under ``illuminant`` (other
        cameras, order or light), or an estimate whose basis stores no held-out errors.
    """
    ests = [estimates] if isinstance(estimates, SSFEstimate) else list(estimates)
    R = problem.training
    blocks = [e.response_errors(R, illuminant, scale=scale) for e in ests]
    G = [e.values * _light(illuminant, e.wavelengths)[:, None] for e in ests]
    mine = np.concatenate([R @ (g / g.sum(axis=0)) for g in G], axis=1)
    theirs = problem.source_of(R)
    if mine.shape != theirs.shape or not np.allclose(mine, theirs, atol=SSF_ERROR_PROBLEM_ATOL):
        raise SpectralDataError(
            f"ssf_response_errors: the problem's {theirs.shape[1]} source channels are not the responses of "
            f"these {len(ests)} estimates under {illuminant!r}; build the problem from their sensitivities "
            "in the same order and light."
        )
    m = min(b.shape[0] for b in blocks)
    rng = np.random.default_rng(seed)
    return np.concatenate([b[rng.permutation(b.shape[0])[:m]] for b in blocks], axis=2)


def _light(illuminant, w: np.ndarray) -> np.ndarray:
    """The illuminant's spectrum on the grid ``w``, shape (n,)."""
    from .spectra import builtin as spectra

    return spectra.resample(spectra.illuminant(illuminant), w)[:, 0]


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
