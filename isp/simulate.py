"""Spectral forward model of a camera: reflectances × illuminant × SSF → RAW mosaic → real DNG.

Used to test the pipeline against ground truth: the true XYZ of every pixel is known.

Model (per pixel, per channel ``c``)::

    q_c   = exposure · Σ_λ R(λ) S_c(λ) E(λ) Δλ / max_c' Σ_λ S_c'(λ) E(λ) Δλ     (white → ≤ 1)
    e⁻    ~ Poisson(q_c · full_well)                                            (shot noise)
    DN    = black + e⁻ / full_well · (white − black) + N(0, read_noise²)        (read noise)

rounded and clipped to [0, white]. The camera's un-balanced white response is the AsShotNeutral, and
the ColorMatrix (XYZ → camera) is fitted by least squares on training reflectances
(:func:`fit_color_matrix`).
"""

from __future__ import annotations

import os
from dataclasses import dataclass, field, replace
from pathlib import Path

import numpy as np

import zonotope

from ._errors import PipelineError
from .cfa import cfa_masks, check_cfa
from .dng import write_dng

__all__ = [
    "ILLUMINANT_LIGHT_SOURCE",
    "Capture",
    "SensorConfig",
    "SpectralSetup",
    "chart_image",
    "default_training",
    "fit_color_matrix",
    "simulate_capture",
    "simulate_dng",
    "spectral_setup",
    "true_XYZ",
]

#: EXIF LightSource codes (DNG CalibrationIlluminant) of the illuminants the simulator names.
ILLUMINANT_LIGHT_SOURCE: dict[str, int] = {
    "A": 17,
    "B": 18,
    "C": 19,
    "D50": 23,
    "D55": 20,
    "D65": 21,
    "D75": 22,
}


@dataclass(frozen=True, eq=False)
class SpectralSetup:
    """A camera and the CIE 1931 observer on one grid under one illuminant, plus the camera's white.

    The generators are a :class:`zonotope.GeneratorPair`, the object every part of the project
    uses for "source and target on one grid", with its one normalisation: ``Phi`` white-balanced
    (the perfect white gives 1 in every camera channel), ``Psi`` CIE 1931 2° XYZ with Y of the
    white = 1. What a RAW file records is the *un-balanced* response, ``Phi · diag(neutral)``:
    :attr:`camera`.

    Attributes
    ----------
    generators : zonotope.GeneratorPair
        ``Phi`` (n, 3) camera (white → 1 per channel), ``Psi`` (n, 3) XYZ (Y_white = 1),
        ``wavelengths`` (n,), ``illuminant``: identical to what ``zonotope.correction_problem``
        and ``zonotope.MetamerMismatch`` build for the same camera, illuminant and grid.
    neutral : ndarray of shape (3,)
        Camera response to the perfect white, largest channel 1: the AsShotNeutral.
    """

    generators: zonotope.GeneratorPair
    neutral: np.ndarray

    def __post_init__(self) -> None:
        n = np.asarray(self.neutral, dtype=np.float64)
        if n.shape != (self.generators.k,) or not np.all(np.isfinite(n)) or n.min() <= 0:
            raise PipelineError(
                f"neutral: give {self.generators.k} positive camera responses to the white; "
                f"got {self.neutral!r}."
            )
        object.__setattr__(self, "neutral", n)

    @property
    def wavelengths(self) -> np.ndarray:
        """The grid (n,), nm (``generators.wavelengths``)."""
        return self.generators.wavelengths

    @property
    def camera(self) -> np.ndarray:
        """Un-balanced camera generators ``Phi · diag(neutral)`` (n, 3): the RAW response."""
        return self.generators.Phi * self.neutral

    @property
    def observer(self) -> np.ndarray:
        """CIE 1931 2° XYZ generators (n, 3), Y of the white = 1 (``generators.Psi``)."""
        return self.generators.Psi

    @property
    def illuminant(self) -> str:
        """Name of the illuminant."""
        return self.generators.illuminant


def spectral_setup(camera, *, illuminant: str = "D65", shape=None) -> SpectralSetup:
    """Generator matrices of a camera and of the CIE 1931 observer under an illuminant.

    Parameters
    ----------
    camera
        A built-in camera name, a path to a rawtoaces JSON / CSV file, or a colour MSDS.
    illuminant
        Illuminant name (``zonotope.illuminant``).
    shape
        Wavelength grid; default the common range of the curves at 5 nm.

    Returns
    -------
    SpectralSetup
        ``generators`` from :func:`zonotope.generator_pair` (target CIE 1931 2°, Y_white = 1).
    """
    cam = zonotope.load_camera(camera)
    obs = zonotope.observer("CIE 1931 2°")
    light = zonotope.illuminant(illuminant)
    if shape is None:
        shape = zonotope.common_shape(cam, obs, light, interval=5)
    pair = zonotope.generator_pair(cam, obs, light, shape, target_normalise=1)
    pair = replace(pair, target="CIE 1931 2°", illuminant=str(illuminant))
    white = zonotope.generators(cam, light, pair.wavelengths, normalise=None).values.sum(axis=0)
    return SpectralSetup(generators=pair, neutral=white / white.max())


def _reflectance_array(R, n: int, what: str = "reflectances") -> np.ndarray:
    a = np.asarray(R, dtype=np.float64)
    if a.shape[-1:] != (n,):
        raise PipelineError(f"{what}: last axis must have the {n} wavelengths of the grid; got {a.shape}.")
    if not np.all(np.isfinite(a)) or a.min() < zonotope.REFLECTANCE_MIN or a.max() > zonotope.REFLECTANCE_MAX:
        raise PipelineError(
            f"{what}: reflectances must be finite and within [0, 1] (got "
            f"{np.nanmin(a):.3g}…{np.nanmax(a):.3g}); divide percent data by 100."
        )
    return a


def true_XYZ(reflectances, setup: SpectralSetup) -> np.ndarray:
    """CIE 1931 XYZ (Y_white = 1, under the setup's illuminant) of reflectances.

    Parameters
    ----------
    reflectances : array_like of shape (..., n)
    setup : SpectralSetup

    Returns
    -------
    ndarray of shape (..., 3)
    """
    return _reflectance_array(reflectances, setup.wavelengths.size) @ setup.observer


def default_training(setup: SpectralSetup) -> np.ndarray:
    """The ColorChecker's 24 reflectances (``"ColorChecker N Ohta"``) on the setup's grid, shape (24, n):
    the ColorMatrix training set of images whose own colours cannot determine one."""
    return zonotope.resample(zonotope.reflectances("ColorChecker N Ohta"), setup.wavelengths).T


def fit_color_matrix(setup: SpectralSetup, training) -> np.ndarray:
    """Least-squares XYZ → camera matrix (DNG ColorMatrix convention) with the white held exactly.

    Parameters
    ----------
    setup
        From :func:`spectral_setup`.
    training : array_like of shape (N, n)
        Training reflectances on the setup's grid.

    Returns
    -------
    ndarray of shape (3, 3)
        ``camera ≈ M @ XYZ``; ``M @ XYZ_white = neutral`` exactly.

    Notes
    -----
    Minimises ``Σ ‖M x_i − c_i‖²`` subject to ``M x_w = c_w`` (Lagrange multipliers, one 3 × 3
    solve per row), so the camera neutral maps back to exactly the illuminant's chromaticity.
    """
    R = _reflectance_array(training, setup.wavelengths.size, "training")
    X = R @ setup.observer  # (N, 3)
    rank = np.linalg.matrix_rank(X) if X.size else 0
    if rank < 3:  # the bordered system is singular: M is not determined (LAPACK may or may not notice)
        raise PipelineError(
            f"fit_color_matrix: the {len(R)} training reflectance(s) span only {rank} of the 3 XYZ "
            "dimensions, which cannot determine a 3 × 3 ColorMatrix; give at least 3 colours of "
            "different chromaticity (e.g. a ColorChecker)."
        )
    C = R @ setup.camera  # (N, 3)
    xw = setup.observer.sum(0)
    cw = setup.camera.sum(0)
    A = X.T @ X
    K = np.block([[A, xw[:, None]], [xw[None, :], np.zeros((1, 1))]])
    rhs = np.vstack([X.T @ C, cw[None, :]])  # (4, 3)
    sol = np.linalg.solve(K, rhs)
    return sol[:3].T


def chart_image(reflectances, *, rows: int, cols: int, patch: int = 16, gap: int = 4):
    """Lay out patch reflectances as a chart image.

    Parameters
    ----------
    reflectances : array_like of shape (rows · cols, n)
    rows, cols
        Chart layout (row-major patch order).
    patch, gap
        Patch side and gap in pixels (use even values to keep every patch on the same CFA phase).

    Returns
    -------
    image : ndarray of shape (H, W, n)
        Gaps have reflectance 0.2 (a grey surround).
    labels : ndarray of shape (H, W), int
        Patch index per pixel, -1 in the gaps.
    """
    R = np.asarray(reflectances, dtype=np.float64)
    if R.ndim != 2 or R.shape[0] != rows * cols:
        raise PipelineError(
            f"reflectances: expected shape ({rows * cols}, n) for {rows} × {cols} patches; got {R.shape}."
        )
    H, W = rows * (patch + gap) + gap, cols * (patch + gap) + gap
    labels = np.full((H, W), -1, dtype=np.int64)
    for k in range(rows * cols):
        i, j = divmod(k, cols)
        y, x = gap + i * (patch + gap), gap + j * (patch + gap)
        labels[y : y + patch, x : x + patch] = k
    image = np.where(labels[..., None] >= 0, R[np.maximum(labels, 0)], 0.2)
    return image, labels


@dataclass(frozen=True, eq=False)
class Capture:
    """A simulated RAW capture.

    Attributes
    ----------
    mosaic : ndarray of shape (H, W), uint16
    cfa : str
    black_level, white_level : int
    responses : ndarray of shape (H, W, 3)
        Noise-free linear camera responses (white's largest channel = 1 at exposure 1).
    XYZ : ndarray of shape (H, W, 3)
        True CIE 1931 XYZ under the illuminant (Y_white = 1).
    color_matrix : ndarray of shape (3, 3)
        Fitted XYZ → camera matrix (:func:`fit_color_matrix`).
    neutral : ndarray of shape (3,)
    setup : SpectralSetup
    """

    mosaic: np.ndarray
    cfa: str
    black_level: int
    white_level: int
    responses: np.ndarray
    XYZ: np.ndarray
    color_matrix: np.ndarray
    neutral: np.ndarray
    setup: SpectralSetup = field(repr=False)
    exposure: float = 1.0
    sensor: SensorConfig | None = field(default=None, repr=False)

    @property
    def noise_profile(self) -> np.ndarray:
        """The sensor's true DNG NoiseProfile ``(S, O)`` per channel, shape (3, 2): the variance of the
        linear signal ``x ∈ [0, 1]`` is ``x / full_well`` (shot) plus the read noise and the
        rounding to DN (``(read_noise² + 1/12) / (white − black)²``)."""
        if self.sensor is None:
            raise PipelineError("Capture.noise_profile: the capture does not record its sensor.")
        span = float(self.white_level - self.black_level)
        S = 1.0 / self.sensor.full_well if np.isfinite(self.sensor.full_well) else 0.0
        O = (self.sensor.read_noise**2 + 1.0 / 12.0) / span**2
        return np.tile([S, O], (3, 1))


@dataclass(frozen=True)
class SensorConfig:
    """The simulated sensor of :func:`simulate_capture` (checked when made).

    Attributes
    ----------
    exposure : float
        Response of the white's largest channel, as a fraction of saturation, in (0, 1].
    cfa : str
        Bayer pattern, e.g. ``"RGGB"``.
    black_level, white_level : int
        In DN, ``0 ≤ black_level < white_level ≤ 65535``.
    full_well : float
        Electrons at saturation (sets the shot noise; ``inf`` for none), > 0.
    read_noise : float
        Standard deviation of the read noise in DN (0 for none), ≥ 0.

    Raises
    ------
    PipelineError
        A value out of range (named, with what is allowed).
    RawFormatError
        A CFA pattern that is not a 2 × 2 arrangement of R, G, B.
    """

    exposure: float = 0.8
    cfa: str = "RGGB"
    black_level: int = 512
    white_level: int = 16383
    full_well: float = 30000.0
    read_noise: float = 2.0

    def __post_init__(self) -> None:
        def number(name, value, ok, allowed):
            try:
                numeric = isinstance(value, int | float | np.number) and not isinstance(value, bool)
                good = numeric and bool(ok(float(value)))
            except (TypeError, ValueError):
                good = False
            if not good:
                raise PipelineError(f"SensorConfig.{name}={value!r}: {allowed}.")

        number("exposure", self.exposure, lambda v: 0 < v <= 1, "must lie in (0, 1] (fraction of saturation)")
        object.__setattr__(self, "cfa", check_cfa(self.cfa))
        for name in ("black_level", "white_level"):
            v = getattr(self, name)
            if isinstance(v, bool) or not hasattr(v, "__index__") or not 0 <= int(v) <= 65535:
                raise PipelineError(f"SensorConfig.{name}={v!r}: give an integer DN in 0…65535.")
        if self.black_level >= self.white_level:
            raise PipelineError(
                f"SensorConfig.black_level={self.black_level!r}: must lie below "
                f"white_level={self.white_level!r}."
            )
        number(
            "full_well",
            self.full_well,
            lambda v: v > 0,
            "give a positive electron count (inf: no shot noise)",
        )
        number("read_noise", self.read_noise, lambda v: np.isfinite(v) and v >= 0, "give a finite DN ≥ 0")


def simulate_capture(
    reflectance_image,
    setup: SpectralSetup,
    sensor: SensorConfig | None = None,
    *,
    training=None,
    seed: int | None = 0,
    **options,
) -> Capture:
    """Render a reflectance image through a camera into a noisy Bayer mosaic.

    Parameters
    ----------
    reflectance_image : array_like of shape (H, W, n)
        Reflectances on the setup's grid (H, W even).
    setup
        From :func:`spectral_setup`.
    sensor : SensorConfig, optional
        Exposure, CFA, black/white level and noise; default ``SensorConfig()``.
    training : array_like of shape (N, n), optional
        Reflectances for the ColorMatrix fit; default the image's distinct pixels, or
        :func:`default_training` (the ColorChecker) when their XYZ span fewer than 3 dimensions (a flat
        or single-hue image cannot determine a 3 × 3 matrix).
    seed
        Random seed (None: fresh randomness).
    **options
        :class:`SensorConfig` fields as keywords, alone or overriding those of ``sensor``
        (e.g. ``simulate_capture(image, setup, full_well=np.inf, read_noise=0)``).

    Returns
    -------
    Capture

    Raises
    ------
    PipelineError
        A bad reflectance image, an unknown option or a sensor value out of range.
    """
    from ._config import with_options

    sensor = with_options(SensorConfig, sensor, options, where="simulate_capture")
    exposure, cfa, black_level, white_level = (
        sensor.exposure,
        sensor.cfa,
        sensor.black_level,
        sensor.white_level,
    )
    full_well, read_noise = sensor.full_well, sensor.read_noise
    R = _reflectance_array(reflectance_image, setup.wavelengths.size, "reflectance_image")
    if R.ndim != 3 or R.shape[0] % 2 or R.shape[1] % 2:
        raise PipelineError(f"reflectance_image: expected shape (H, W, n) with even H, W; got {R.shape}.")
    rgb = exposure * (R @ setup.camera)
    XYZ = R @ setup.observer
    signal = np.sum(rgb * cfa_masks(rgb.shape[:2], cfa), axis=-1)
    rng = np.random.default_rng(seed)
    if np.isfinite(full_well):
        signal = rng.poisson(np.clip(signal, 0, None) * full_well) / full_well
    dn = black_level + signal * (white_level - black_level)
    if read_noise > 0:
        dn = dn + rng.normal(0.0, read_noise, size=dn.shape)
    mosaic = np.clip(np.round(dn), 0, white_level).astype(np.uint16)
    train = np.unique(R.reshape(-1, R.shape[-1]), axis=0) if training is None else training
    if training is None and np.linalg.matrix_rank(train @ setup.observer) < 3:
        train = default_training(setup)  # e.g. a flat grey image: its own colours cannot fit a matrix
    M = fit_color_matrix(setup, train)
    return Capture(
        mosaic=mosaic,
        cfa=cfa,
        black_level=black_level,
        white_level=white_level,
        responses=rgb,
        XYZ=XYZ,
        color_matrix=M,
        neutral=setup.neutral,
        setup=setup,
        exposure=exposure,
        sensor=sensor,
    )


def simulate_dng(
    path: str | os.PathLike,
    capture: Capture,
    *,
    model: str = "simulated",
    make: str | None = None,
    noise_profile=None,
    overwrite: bool = False,
) -> Path:
    """Write a :class:`Capture` as a DNG (ColorMatrix1, CalibrationIlluminant1, AsShotNeutral, ...).

    Parameters
    ----------
    path
        Output file (written atomically).
    capture
        From :func:`simulate_capture`.
    model
        Model tag (e.g. the camera name).
    make
        Make tag; default the maker a built-in camera's ``model`` names (its first word:
        :func:`isp.metamer.sensitivities_maker`), else ``"zonotope"``.
    noise_profile : array_like of shape (2,) or (3, 2), optional
        DNG NoiseProfile to write (e.g. ``capture.noise_profile``, the true one); None: no tag.
    overwrite
        Replace an existing file.

    Returns
    -------
    Path
    """
    from .metamer import sensitivities_maker

    code = ILLUMINANT_LIGHT_SOURCE.get(capture.setup.illuminant.upper().replace(" ", ""), 255)
    return write_dng(
        path,
        capture.mosaic,
        cfa=capture.cfa,
        black_level=capture.black_level,
        white_level=capture.white_level,
        color_matrix_1=capture.color_matrix,
        as_shot_neutral=capture.neutral,
        calibration_illuminant_1=code,
        make=make if make is not None else sensitivities_maker(model) or "zonotope",
        model=model,
        noise_profile=noise_profile,
        overwrite=overwrite,
    )
