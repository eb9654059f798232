"""Spectral sensitivities of cameras nobody measured: from DNG colour matrices, a chart photograph, or both.

Every camera's sensitivities ``S`` (shape ``(n, 3)``) are sought as non-negative, smooth curves near a
low-dimensional space learned from measured cameras (:class:`SSFBasis`, shipped with the package), by
one bounded least-squares problem (:func:`scipy.optimize.lsq_linear`) whose data terms are

* **DNG matrices** (Solomatov & Akkaynak 2023): for each calibration illuminant ``E_i`` the matrix
  ``A_i`` (camera from XYZ: ColorMatrix1/2, and ForwardMatrix1/2 turned round) must be what a least
  squares fit of the camera's responses to training reflectances ``R`` on their XYZ would give: its
  normal equations are linear in ``S`` (``k_i`` an unknown exposure per illuminant);
* **a chart photograph** (Jiang et al. 2013): the raw patch means ``C`` of chart reflectances ``R_c``
  under a known light ``E``: ``R_c·diag(E)·S ≈ C``;

and whose regularisers are a second-difference smoothness penalty and the distance of each channel
to its span in the basis. Why: a 3 × 3 matrix or 24 patches constrain far fewer numbers than a curve
has samples; measured cameras say which of the many consistent curves are plausible.

The per-wavelength uncertainty is the spread of the same estimate over measured cameras held out of
the basis (stored with the basis; see :func:`learn_ssf_basis`).

The DNG tags are read here with tifffile (rawpy's ``rgb_xyz_matrix`` is all zeros for DNG files);
``isp.read_dng_tags`` output can be given instead of a path, as can a :class:`DNGMatrices`.

References
----------
.. [1] Solomatov, G. & Akkaynak, D. (2023). Spectral sensitivity estimation without a camera.
   IEEE International Conference on Computational Photography (ICCP).
.. [2] Jiang, J., Liu, D., Gu, J. & Süsstrunk, S. (2013). What is the space of spectral sensitivity
   functions for digital color cameras? IEEE WACV, 168–179, doi:10.1109/WACV.2013.6475015.
.. [3] Adobe Systems (2012). Digital Negative (DNG) Specification 1.4.0.0, chapter 6.
"""

from __future__ import annotations

import dataclasses
import functools
import json
import os
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from importlib import resources
from pathlib import Path

import colour
import numpy as np

from .._errors import SpectralDataError
from .._tol import (
    SSF_CHART_CLIP,
    SSF_CHART_DARK,
    SSF_CHART_MIN_PATCHES,
    SSF_CHART_NEGATIVE,
    SSF_CHOLESKY_JITTER,
    SSF_ERROR_DRAW_SCALE,
    SSF_ERROR_WEIGHT_FLOOR,
    SSF_FIT_SIGMA_SCALE,
    SSF_MATRIX_CONDITION_MAX,
    SSF_PRIOR,
    SSF_SAMPLE_CORRELATION_NM,
    SSF_SMOOTHNESS,
    SSF_SUBSPACE,
)
from . import builtin as spectra

__all__ = [
    "SSF_SHAPE",
    "Chart",
    "DNGMatrices",
    "SSFBasis",
    "SSFCalibration",
    "SSFEstimate",
    "estimate_ssf",
    "held_out_error_model",
    "learn_ssf_basis",
    "read_dng_matrices",
    "read_ssf_band",
    "read_ssf_estimate",
    "sample_ssfs",
    "ssf_basis",
    "synthesise_dng_matrices",
    "write_ssf_json",
]

#: The grid every estimate lives on: 400–700 nm / 10 nm, the range every measured set covers.
SSF_SHAPE = colour.SpectralShape(400, 700, 10)

#: EXIF LightSource codes (CalibrationIlluminant1/2) → colour-science illuminant names, where the
#: code names a CIE illuminant whose spectrum is known (DNG spec 1.4, p. 47).
LIGHT_SOURCES: dict[int, str] = {
    17: "A",
    18: "B",
    19: "C",
    20: "D55",
    21: "D65",
    22: "D75",
    23: "D50",
    2: "FL2",
    3: "A",  # tungsten
    12: "FL1",  # daylight fluorescent (D 5700–7100 K)
    13: "FL8",  # day white fluorescent (N 4600–5400 K)
    14: "FL2",  # cool white fluorescent (W 3900–4500 K)
    15: "FL3",  # white fluorescent (WW 3200–3700 K)
    1: "D55",  # daylight
    9: "D55",  # fine weather
    10: "D65",  # cloudy weather
    11: "D75",  # shade
    24: "A",  # ISO studio tungsten (3200 K; A is the nearest CIE illuminant)
}

_BASIS_FILE = "ssf_basis.json"

#: What the first line of every file :func:`write_ssf_json` writes contains.
_SIGNATURE = '"document_creator": "zonotope.estimate_ssf"'


# ---------------------------------------------------------------------------------------------
# Basis
# ---------------------------------------------------------------------------------------------


@dataclass(frozen=True, eq=False)
class SSFCalibration:
    """How far estimates of one kind of data lay from measured curves, leave one camera model out.

    Why: DNG matrices synthesised from measured curves are exact least-squares fits, and an estimate
    trusts them; the matrices real DNG files carry (Adobe's) are not, and an estimate from them must
    lean on the prior and say it is less sure (docs/notes/2026-11-29-real-dng-matrices.md).

    Attributes
    ----------
    prior : float
        The weight of the Gaussian prior on the basis coefficients (:func:`estimate_ssf`'s ``prior``)
        for this kind of data, chosen leave one model out.
    spread, band_k, response_scale, errors, error_weight
        As the same attributes of :class:`SSFBasis`, measured on estimates from this kind of data.
    cameras : int
        The held-out cameras they were measured on.
    max_residual : float
        The largest misfit (:attr:`SSFEstimate.residual`) among them: an estimate that fits its data
        worse is unlike every camera the calibration saw (a Foveon sensor among Bayer ones), and
        :func:`estimate_ssf` does not apply the calibration to it.
    """

    prior: float
    spread: np.ndarray
    band_k: float
    response_scale: np.ndarray
    errors: np.ndarray | None = None
    error_weight: np.ndarray = field(default_factory=lambda: np.array([[1.0] * 3, [0.0] * 3]))
    cameras: int = 0
    max_residual: float = float("inf")

    def to_json(self) -> dict:
        """The calibration as a JSON-ready document (the ``real_dng`` entry of ``ssf_basis.json``)."""
        return {
            "prior": float(self.prior),
            "cameras": int(self.cameras),
            **(
                {}
                if not np.isfinite(self.max_residual)
                else {"max_residual": round(float(self.max_residual), 6)}
            ),
            "spread": np.round(self.spread, 6).tolist(),
            "band_k": round(float(self.band_k), 4),
            "response_scale": np.round(self.response_scale, 4).tolist(),
            **({} if self.errors is None else {"errors": np.round(self.errors, 6).tolist()}),
            "error_weight": np.round(self.error_weight, 6).tolist(),
        }

    @classmethod
    def from_json(cls, doc: Mapping, n: int) -> SSFCalibration:
        """Read :meth:`to_json` output for a grid of ``n`` wavelengths; malformed: SpectralDataError."""
        try:
            cal = cls(
                float(doc["prior"]),
                np.asarray(doc["spread"], dtype=np.float64),
                float(doc["band_k"]),
                np.asarray(doc["response_scale"], dtype=np.float64),
                None if doc.get("errors") is None else np.asarray(doc["errors"], dtype=np.float64),
                np.asarray(doc.get("error_weight", [[1.0] * 3, [0.0] * 3]), dtype=np.float64),
                int(doc.get("cameras", 0)),
                float(doc.get("max_residual", float("inf"))),
            )
        except (KeyError, TypeError, ValueError) as error:
            raise SpectralDataError(f"SSF basis: malformed calibration ({error}).") from None
        if (
            not (cal.prior >= 0 and cal.band_k > 0 and cal.max_residual > 0)
            or cal.spread.shape != (n, 3)
            or cal.response_scale.shape != (3,)
            or not np.all(cal.response_scale > 0)
            or cal.error_weight.shape != (2, 3)
            or (cal.errors is not None and (cal.errors.ndim != 3 or cal.errors.shape[1:] != (n, 3)))
        ):
            raise SpectralDataError(
                f"SSF basis: calibration of prior {cal.prior!r}, band_k {cal.band_k!r}, spread "
                f"{cal.spread.shape} does not fit {n} wavelengths (3 positive response scales, "
                "error_weight (2, 3))."
            )
        return cal


@dataclass(frozen=True, eq=False)
class SSFBasis:
    """A low-dimensional space of camera sensitivities, per channel, learned from measured cameras.

    Attributes
    ----------
    wavelengths : ndarray of shape (n,)
    components : ndarray of shape (3, n, K)
        Orthonormal columns per channel (R, G, B), uncentred principal components of peak-normalised
        measured curves, so any scale of a curve in their span is in their span.
    spread : ndarray of shape (n, 3)
        Root-mean-square error, per wavelength, of the DNG-matrix estimate of held-out cameras
        (curves with peak 1): the uncertainty band of an estimate.
    sigma : ndarray of shape (3, K)
        Singular value of each component relative to the first (how far the measured curves spread
        along it): the prior of the estimate.
    sources : tuple of str
        The measured cameras (and their data sets) the basis was learned from.
    licence : str
        The licence statement of the data it was learned from.
    band_k : float
        The multiple of ``spread`` within which the held-out cameras' measured curves lie at
        :data:`~zonotope._tol.SSF_BAND_COVERAGE` of wavelengths (calibrated leave one model out; 2
        for an uncalibrated basis).
    response_scale : ndarray of shape (3,)
        The held-out estimates' RMS response error (white-balanced, D65, rawtoaces 190) over the
        fully correlated bound of :meth:`SSFEstimate.response_sigma`, per channel (calibrated leave
        one model out; 1, the bound, for an uncalibrated basis).
    errors : ndarray of shape (M, n, 3) or None
        The held-out estimates' curve errors (measured minus estimate, each channel peaking at 1),
        one per calibration camera, leave one model out: the error model of
        :meth:`SSFEstimate.response_errors` (None for an uncalibrated basis).
    error_weight : ndarray of shape (2, 3)
        ``(a, b)`` per channel: an estimate of misfit ``r`` has ``a + b·r`` times the calibration
        cameras' RMS response error (least squares over them; ``(1, 0)``: every estimate alike).
    real_dng : SSFCalibration or None
        The calibration of estimates from the colour matrices of real DNG files (Adobe's), which
        :func:`estimate_ssf` uses when it is given a DNG and no chart; None: the attributes above
        serve every estimate.
    """

    wavelengths: np.ndarray
    components: np.ndarray
    spread: np.ndarray
    sigma: np.ndarray
    sources: tuple[str, ...] = ()
    licence: str = ""
    band_k: float = 2.0
    response_scale: np.ndarray = field(default_factory=lambda: np.ones(3))
    errors: np.ndarray | None = None
    error_weight: np.ndarray = field(default_factory=lambda: np.array([[1.0] * 3, [0.0] * 3]))
    real_dng: SSFCalibration | None = None

    @property
    def n_components(self) -> int:
        """Components per channel (K)."""
        return int(self.components.shape[2])

    def to_json(self) -> dict:
        """The basis as a JSON-ready document (what ``ssf_basis.json`` holds)."""
        return {
            "description": "Camera spectral sensitivity basis of zonotope.estimate_ssf: per channel "
            "(R, G, B) the uncentred principal components of peak-normalised measured curves, and the "
            "RMS error of the estimate of held-out cameras (spread, peak = 1); band_k: the multiple of "
            "spread holding the held-out cameras' curves at 90 % of wavelengths; response_scale: their RMS "
            "response error over the fully correlated bound, per channel; errors: the held-out estimates' "
            "curve errors (measured - estimate, peak 1); error_weight: (a, b) per channel, their RMS "
            "response error ~ a + b * misfit over the RMS of all; real_dng: the same, and the prior's "
            "weight, for estimates from real DNG files' colour matrices alone.",
            "licence": self.licence,
            "sources": list(self.sources),
            "wavelengths": self.wavelengths.tolist(),
            "components": np.round(self.components, 8).tolist(),
            "spread": np.round(self.spread, 6).tolist(),
            "sigma": np.round(self.sigma, 8).tolist(),
            "band_k": round(float(self.band_k), 4),
            "response_scale": np.round(self.response_scale, 4).tolist(),
            **(
                {}
                if self.errors is None
                else {
                    "errors": np.round(self.errors, 6).tolist(),
                    "error_weight": np.round(self.error_weight, 6).tolist(),
                }
            ),
            **({} if self.real_dng is None else {"real_dng": self.real_dng.to_json()}),
        }

    @classmethod
    def from_json(cls, doc: Mapping) -> SSFBasis:
        """Read :meth:`to_json` output back; a malformed document raises SpectralDataError."""
        try:
            w = np.asarray(doc["wavelengths"], dtype=np.float64)
            V = np.asarray(doc["components"], dtype=np.float64)
            spread = np.asarray(doc["spread"], dtype=np.float64)
            sigma = np.asarray(doc["sigma"], dtype=np.float64)
            band_k = float(doc.get("band_k", 2.0))
            scale = np.asarray(doc.get("response_scale", np.ones(3)), dtype=np.float64)
            errors = None if doc.get("errors") is None else np.asarray(doc["errors"], dtype=np.float64)
            weight = np.asarray(doc.get("error_weight", [[1.0] * 3, [0.0] * 3]), dtype=np.float64)
        except (KeyError, TypeError, ValueError) as error:
            raise SpectralDataError(f"SSF basis: malformed document ({error}).") from None
        if (
            V.ndim != 3
            or V.shape[:2] != (3, w.size)
            or spread.shape != (w.size, 3)
            or sigma.shape != (3, V.shape[2])
        ):
            raise SpectralDataError(
                f"SSF basis: components {V.shape} and spread {spread.shape} do not fit {w.size} wavelengths."
            )
        if not (band_k > 0 and scale.shape == (3,) and np.all(scale > 0)):
            raise SpectralDataError(
                f"SSF basis: band_k {band_k!r} and response_scale {scale.tolist()} must be > 0 (3 values)."
            )
        if (errors is not None and (errors.ndim != 3 or errors.shape[1:] != (w.size, 3))) or weight.shape != (
            2,
            3,
        ):
            raise SpectralDataError(
                f"SSF basis: errors {None if errors is None else errors.shape} and error_weight "
                f"{weight.shape} must be (M, {w.size}, 3) and (2, 3)."
            )
        return cls(
            w,
            V,
            spread,
            sigma,
            tuple(doc.get("sources", ())),
            str(doc.get("licence", "")),
            band_k,
            scale,
            errors,
            weight,
            None if doc.get("real_dng") is None else SSFCalibration.from_json(doc["real_dng"], w.size),
        )


def _peak_normalised(values: np.ndarray) -> np.ndarray:
    peak = values.max(axis=0, keepdims=True)
    return values / np.where(peak > 0, peak, 1.0)


def learn_ssf_basis(
    cameras: Mapping[str, colour.MultiSpectralDistributions | np.ndarray],
    *,
    n_components: int = 5,
    shape: colour.SpectralShape = SSF_SHAPE,
    spread: np.ndarray | None = None,
    licence: str = "",
    band_k: float = 2.0,
    response_scale=(1.0, 1.0, 1.0),
) -> SSFBasis:
    """Learn the per-channel basis from measured cameras (uncentred PCA of peak-normalised curves).

    Parameters
    ----------
    cameras : mapping of str to colour.MultiSpectralDistributions or ndarray of shape (n, 3)
        Measured RGB sensitivities by name (arrays must already lie on ``shape``).
    n_components : int
        Components kept per channel.
    shape : colour.SpectralShape
        The grid.
    spread : ndarray of shape (n, 3), optional
        The uncertainty band to store; default: the leave-one-out residual of the basis itself
        (RMS over cameras of each held-out curve minus its projection on the others' basis), a lower
        bound of the estimate's error.
    licence : str
        The licence statement of the data, stored with the basis.
    band_k, response_scale
        The band's calibration (:class:`SSFBasis`); ``benchmarks/bench_ssf.py --write-basis`` measures
        both leaving one camera model out.

    Returns
    -------
    SSFBasis
    """
    w = np.asarray(shape.wavelengths, dtype=np.float64)
    names = list(cameras)
    need = n_components + (spread is None)  # the leave-one-out spread learns from one camera fewer
    if len(names) < need:
        raise SpectralDataError(
            f"learn_ssf_basis: {len(names)} cameras for {n_components} components; give at least {need}."
        )
    curves = np.stack([_on_grid(cameras[k], w, k) for k in names])  # (m, n, 3)
    V, sigma = _components(curves, n_components)
    if spread is None:
        res = []
        for j in range(len(names)):
            Vj, _ = _components(np.delete(curves, j, axis=0), n_components)
            s = curves[j]
            res.append(np.stack([s[:, c] - Vj[c] @ (Vj[c].T @ s[:, c]) for c in range(3)], axis=1))
        spread = np.sqrt(np.mean(np.square(res), axis=0))
    return SSFBasis(
        w,
        V,
        np.asarray(spread, dtype=np.float64),
        sigma,
        tuple(names),
        licence,
        float(band_k),
        np.asarray(response_scale, dtype=np.float64),
    )


def _components(curves: np.ndarray, k: int) -> tuple[np.ndarray, np.ndarray]:
    """(3, n, k) leading left singular vectors of each channel's (n, m) stack of curves, and their
    (3, k) singular values relative to the first."""
    out, sig = [], []
    for c in range(3):
        U, sv, _ = np.linalg.svd(curves[:, :, c].T, full_matrices=False)
        U = U[:, :k]
        out.append(U * np.where(U.sum(axis=0, keepdims=True) < 0, -1.0, 1.0))  # positive-lobed first
        sig.append(sv[:k] / sv[0])
    return np.stack(out), np.stack(sig)


def _on_grid(curve, w: np.ndarray, name: str) -> np.ndarray:
    if isinstance(curve, colour.MultiSpectralDistributions):
        values = spectra.resample(curve, w)
    else:
        values = np.asarray(curve, dtype=np.float64)
    if values.shape != (w.size, 3):
        raise SpectralDataError(
            f"camera {name!r}: expected 3 channels on {w.size} wavelengths, got {values.shape}."
        )
    return _peak_normalised(values)


@functools.cache
def _shipped_basis() -> SSFBasis:
    text = (resources.files("zonotope.spectra") / "data" / _BASIS_FILE).read_text(encoding="utf-8")
    return SSFBasis.from_json(json.loads(text))


def ssf_basis() -> SSFBasis:
    """The basis shipped with ``zonotope`` (``zonotope/spectra/data/ssf_basis.json``).

    Learned from the rawtoaces cameras (Apache-2.0) and colour-science's NPL Nikon D5100 (BSD-3) by
    ``benchmarks/bench_ssf.py --write-basis``; its ``sources`` and ``licence`` say which.
    """
    return _shipped_basis()


# ---------------------------------------------------------------------------------------------
# DNG matrices
# ---------------------------------------------------------------------------------------------


@dataclass(frozen=True, eq=False)
class DNGMatrices:
    """The colour matrices of a DNG (reference camera), per calibration illuminant.

    Attributes
    ----------
    color_matrices : tuple of ndarray of shape (3, 3)
        XYZ → camera (ColorMatrix1, ColorMatrix2, ...).
    illuminants : tuple of str
        The colour-science illuminant of each calibration illuminant (``"A"``, ``"D65"``).
    forward_matrices : tuple of (ndarray of shape (3, 3) or None)
        White-balanced camera → XYZ D50 (ForwardMatrix1/2), None where the file has none.
    name : str
        Make and model, where the file names them.
    """

    color_matrices: tuple[np.ndarray, ...]
    illuminants: tuple[str, ...]
    forward_matrices: tuple[np.ndarray | None, ...] = ()
    name: str = ""

    def __post_init__(self) -> None:
        cms = tuple(_matrix(m, f"ColorMatrix{i + 1}") for i, m in enumerate(self.color_matrices))
        if not cms:
            raise SpectralDataError("DNG matrices: no ColorMatrix1/2; the camera's colour is unknown.")
        if len(self.illuminants) != len(cms):
            raise SpectralDataError(
                f"DNG matrices: {len(cms)} colour matrices but {len(self.illuminants)} illuminants."
            )
        fms = tuple(self.forward_matrices) + (None,) * (len(cms) - len(self.forward_matrices))
        fms = tuple(None if m is None else _matrix(m, f"ForwardMatrix{i + 1}") for i, m in enumerate(fms))
        for light in self.illuminants:
            spectra.illuminant(light)  # an unknown name is refused here, listing the valid ones
        object.__setattr__(self, "color_matrices", cms)
        object.__setattr__(self, "forward_matrices", fms[: len(cms)])
        object.__setattr__(self, "illuminants", tuple(self.illuminants))


def _matrix(m, name: str) -> np.ndarray:
    a = np.asarray(m, dtype=np.float64)
    if a.size != 9 or not np.all(np.isfinite(a)):
        raise SpectralDataError(f"{name}: expected 9 finite values (a 3 × 3 matrix), got {a.ravel()[:12]}.")
    a = a.reshape(3, 3)
    if not np.linalg.cond(a) < SSF_MATRIX_CONDITION_MAX:
        raise SpectralDataError(f"{name} is singular (all zeros or damaged); the camera's colour is unknown.")
    return a


def _dng_tags(path: Path) -> dict:
    """ColorMatrix1/2, ForwardMatrix1/2, CalibrationIlluminant1/2, Make, Model of IFD 0 (tifffile)."""
    import tifffile

    codes = {
        50721: "ColorMatrix1",
        50722: "ColorMatrix2",
        50964: "ForwardMatrix1",
        50965: "ForwardMatrix2",
        50778: "CalibrationIlluminant1",
        50779: "CalibrationIlluminant2",
        50706: "DNGVersion",
        271: "Make",
        272: "Model",
        50708: "UniqueCameraModel",
    }
    try:
        with tifffile.TiffFile(path) as tif:
            tags = {}
            for tag in tif.pages[0].tags.values():
                if tag.code in codes:
                    value = tag.value
                    if int(tag.dtype) in (5, 10):  # RATIONAL, SRATIONAL: (num, den) pairs
                        v = np.asarray(value, dtype=np.float64).reshape(-1, 2)
                        value = v[:, 0] / np.where(v[:, 1] != 0, v[:, 1], 1.0)
                    tags[codes[tag.code]] = value
    except (tifffile.TiffFileError, OSError, ValueError, IndexError, KeyError, TypeError) as exc:
        raise SpectralDataError(
            f"{path}: not a readable DNG file ({type(exc).__name__}: {exc}); convert the RAW to DNG "
            "(Adobe DNG Converter) first."
        ) from None
    if "DNGVersion" not in tags:
        raise SpectralDataError(f"{path}: a TIFF file but not a DNG (no DNGVersion tag); give a DNG.")
    return tags


def read_dng_matrices(source) -> DNGMatrices:
    """The colour matrices and calibration illuminants of a DNG file.

    Parameters
    ----------
    source : path, mapping or DNGMatrices
        A DNG file, or tags by name as ``isp.read_dng_tags`` returns them (ColorMatrix1, ...).

    Returns
    -------
    DNGMatrices

    Raises
    ------
    SpectralDataError
        Not a DNG, or no usable ColorMatrix (absent, all zeros, singular), or a calibration
        illuminant whose spectrum is unknown (the message names the tag and what to do).
    """
    if isinstance(source, DNGMatrices):
        return source
    where = "DNG tags"
    if isinstance(source, str | os.PathLike):
        path = Path(source)
        if not path.is_file():
            raise SpectralDataError(f"{path}: no such file; give a DNG file.")
        tags, where = _dng_tags(path), str(path)
    elif isinstance(source, Mapping):
        tags = dict(source)
    else:
        raise SpectralDataError(
            f"read_dng_matrices: expected a DNG path or a tag mapping, got {type(source).__name__}."
        )
    cms, lights, fms = [], [], []
    for i in (1, 2):
        cm = tags.get(f"ColorMatrix{i}")
        if cm is None or np.asarray(cm).size != 9 or not np.any(np.asarray(cm, dtype=np.float64)):
            continue
        code = int(np.ravel(tags.get(f"CalibrationIlluminant{i}", 0) or 0)[0])
        if code not in LIGHT_SOURCES:
            if code == 0 and tags.get("ColorMatrix2") is None:
                code = 21  # a single matrix of an unknown illuminant: DNG writers calibrate it for D65
            else:
                raise SpectralDataError(
                    f"{where}: CalibrationIlluminant{i} = {code} has no known spectrum (known EXIF codes: "
                    f"{sorted(LIGHT_SOURCES)}); the ColorMatrix{i} cannot be used."
                )
        cms.append(cm)
        lights.append(LIGHT_SOURCES[code])
        fm = tags.get(f"ForwardMatrix{i}")
        fms.append(fm if fm is not None and np.any(np.asarray(fm, dtype=np.float64)) else None)
    if not cms:
        raise SpectralDataError(
            f"{where}: no usable ColorMatrix1/ColorMatrix2 (absent or all zeros); the DNG says nothing about "
            "the camera's colour. Convert the RAW with Adobe DNG Converter, or photograph a chart (--chart)."
        )
    make, model = (str(tags.get(k) or "").strip("\x00 ") for k in ("Make", "Model"))
    name = model if model.lower().startswith(make.lower()) else f"{make} {model}".strip()
    try:
        return DNGMatrices(
            tuple(cms), tuple(lights), tuple(fms), name or str(tags.get("UniqueCameraModel", ""))
        )
    except SpectralDataError as error:
        raise SpectralDataError(f"{where}: {error}") from None


def _camera_from_XYZ(dng: DNGMatrices, w: np.ndarray) -> list[tuple[np.ndarray, np.ndarray]]:
    """(E_i on ``w``, camera-from-XYZ A_i) pairs: each ColorMatrix, and each ForwardMatrix turned round."""
    out = []
    for cm, light, fm in zip(dng.color_matrices, dng.illuminants, dng.forward_matrices, strict=True):
        E = spectra.resample(spectra.illuminant(light), w)[:, 0]
        out.append((E, cm))
        if fm is not None:
            cmfs = spectra.resample(spectra.observer("CIE 1931 2°"), w)
            white = cmfs.T @ E
            white = white / white[1]
            neutral = cm @ white
            D50 = colour.xy_to_XYZ(colour.CCS_ILLUMINANTS["CIE 1931 2 Degree Standard Observer"]["D50"])
            cat = colour.adaptation.matrix_chromatic_adaptation_VonKries(white, D50, transform="Bradford")
            # XYZ_D50 = FM · diag(1/neutral) · camera  →  camera = diag(neutral) · FM⁻¹ · CAT · XYZ
            out.append((E, np.diag(neutral) @ np.linalg.inv(fm) @ cat))
    return out


def synthesise_dng_matrices(
    camera, *, reflectances="BabelColor Average", illuminants: Sequence[str] = ("A", "D65"), name: str = ""
) -> DNGMatrices:
    """The ColorMatrix/ForwardMatrix pairs a DNG converter would write for measured sensitivities.

    For each illuminant: the least-squares camera → XYZ matrix over ``reflectances`` (ColorMatrix =
    its inverse, scaled so that the illuminant's white gives a largest camera value of 1, as the DNG
    specification normalises it), and the white-preserving white-balanced camera → XYZ D50 matrix
    (ForwardMatrix: Bradford-adapted targets, least squares with the white mapped exactly).

    Parameters
    ----------
    camera : str, path or colour.MultiSpectralDistributions
        Measured sensitivities (``zonotope.load_camera`` resolves it).
    reflectances : str or colour.MultiSpectralDistributions
        The calibration chart (default the 24 ColorChecker patches, BabelColor average).
    illuminants : sequence of str
        The calibration illuminants (default A and D65, as Adobe's DNG Converter profiles).
    name : str

    Returns
    -------
    DNGMatrices
    """
    from .loading import load_camera, load_reflectances

    w = np.asarray(SSF_SHAPE.wavelengths)
    S = spectra.resample(load_camera(camera), w)
    R = spectra.resample(load_reflectances(reflectances), w).T
    cmfs = spectra.resample(spectra.observer("CIE 1931 2°"), w)
    D50 = colour.xy_to_XYZ(colour.CCS_ILLUMINANTS["CIE 1931 2 Degree Standard Observer"]["D50"])
    cms, fms = [], []
    for light in illuminants:
        E = spectra.resample(spectra.illuminant(light), w)[:, 0]
        white = cmfs.T @ E
        XYZ = (R * E) @ cmfs / white[1]
        cam = (R * E) @ S
        M = np.linalg.lstsq(cam, XYZ, rcond=None)[0].T  # XYZ ≈ M · camera
        cm = np.linalg.inv(M)
        cm = cm / (cm @ (white / white[1])).max()
        cms.append(cm)
        # ForwardMatrix: XYZ_D50 ≈ FM · (camera / neutral'), FM · 1 = D50 white exactly
        n_cam = S.T @ E
        wb = cam / n_cam
        cat = colour.adaptation.matrix_chromatic_adaptation_VonKries(
            white / white[1], D50, transform="Bradford"
        )
        target = XYZ @ cat.T
        # constrained least squares: FM = FM0 + Δ with Δ · 1 = 0 (each row), FM0 = D50 · 1ᵀ / 3
        FM0 = np.outer(D50, np.ones(3)) / 3.0
        N = np.array([[1.0, -1.0, 0.0], [1.0, 1.0, -2.0]]).T  # basis of {v : 1ᵀ v = 0}
        coef = np.linalg.lstsq(wb @ N, target - wb @ FM0.T, rcond=None)[0]
        fms.append(FM0 + (N @ coef).T)
    return DNGMatrices(
        tuple(cms), tuple(illuminants), tuple(fms), name or getattr(camera, "name", str(camera))
    )


# ---------------------------------------------------------------------------------------------
# Chart
# ---------------------------------------------------------------------------------------------


@dataclass(frozen=True, eq=False)
class Chart:
    """A photographed chart: raw patch means, the chart's reflectances, the light.

    Attributes
    ----------
    rgb : array_like of shape (N, 3)
        Linear raw means per patch (black subtracted), scaled so that 1 is the sensor's saturation
        (divide by WhiteLevel − BlackLevel).
    reflectances : str, path or colour.MultiSpectralDistributions
        The chart's N reflectances in patch order (default the 24-patch ColorChecker).
    illuminant : str or colour.SpectralDistribution
        The light the chart was photographed under.
    name : str
    """

    rgb: np.ndarray
    reflectances: object = "ColorChecker N Ohta"
    illuminant: object = "D65"
    name: str = "chart"


def _chart_terms(chart: Chart, w: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(A, C) with A = R·diag(E) (patches × wavelengths) and C the checked patch means."""
    from .loading import load_reflectances

    try:
        C = np.asarray(chart.rgb, dtype=np.float64)
    except (TypeError, ValueError):
        raise SpectralDataError(f"{chart.name}: the patch means are not numbers.") from None
    if C.ndim != 2 or C.shape[1] != 3:
        raise SpectralDataError(f"{chart.name}: patch means of shape {C.shape}; expected (patches, 3) RGB.")
    if not np.all(np.isfinite(C)):
        raise SpectralDataError(f"{chart.name}: patch means hold NaN or infinite values.")
    R = spectra.resample(load_reflectances(chart.reflectances), w).T
    if R.shape[0] != C.shape[0]:
        raise SpectralDataError(
            f"{chart.name}: {C.shape[0]} patch means for a chart of {R.shape[0]} reflectances; "
            "give one mean per patch of a known chart, in the chart's patch order."
        )
    if C.shape[0] < SSF_CHART_MIN_PATCHES:
        raise SpectralDataError(
            f"{chart.name}: {C.shape[0]} patches; at least {SSF_CHART_MIN_PATCHES} are needed."
        )
    if C.max() > 1.0 / SSF_CHART_CLIP:
        raise SpectralDataError(
            f"{chart.name}: patch means up to {C.max():.4g}; give them as fractions of saturation "
            "(black subtracted, divided by WhiteLevel − BlackLevel)."
        )
    clipped = np.flatnonzero((C >= SSF_CHART_CLIP).any(axis=1))
    if clipped.size:
        raise SpectralDataError(
            f"{chart.name}: patches {(clipped + 1).tolist()} are clipped (a channel ≥ {SSF_CHART_CLIP:g} of "
            "saturation); photograph the chart with less exposure."
        )
    if C.max() < SSF_CHART_DARK:
        raise SpectralDataError(
            f"{chart.name}: too dark (brightest patch mean {C.max():.3g} of saturation, below "
            f"{SSF_CHART_DARK:g}); photograph the chart with more exposure."
        )
    if (C < 0).mean() > SSF_CHART_NEGATIVE:
        raise SpectralDataError(
            f"{chart.name}: most patch means are negative; subtract the black level once."
        )
    E = spectra.resample(spectra.illuminant(chart.illuminant), w)[:, 0]
    return R * E, C


# ---------------------------------------------------------------------------------------------
# Estimate
# ---------------------------------------------------------------------------------------------


@dataclass(frozen=True, eq=False)
class SSFEstimate:
    """Estimated sensitivities with their uncertainty band.

    Attributes
    ----------
    sensitivities : colour.MultiSpectralDistributions
        R, G, B on :data:`SSF_SHAPE`, non-negative, the largest channel peaking at 1.
    uncertainty : ndarray of shape (n, 3)
        One standard deviation per wavelength and channel, on the same scale.
    sources : tuple of str
        What the estimate used: ``"dng"``, ``"chart"``.
    residual : float
        Relative RMS misfit of the data terms (0: reproduced exactly).
    band_k : float
        Default multiple of ``uncertainty`` in :meth:`band` (the basis' calibrated 90 % coverage).
    response_scale : ndarray of shape (3,)
        Calibration of :meth:`response_sigma` (the basis').
    errors, error_weight
        The basis' held-out curve errors and their weighting by misfit (:class:`SSFBasis`), the error
        model of :meth:`response_errors`.
    calibration : str
        What the band and these were measured on: ``"real DNG matrices"`` (a DNG alone,
        :attr:`SSFBasis.real_dng`) or ``"synthesised matrices"`` (the basis' own calibration), the
        latter saying so when a DNG alone fell back to it (a camera unlike the real-DNG calibration's).
    """

    sensitivities: colour.MultiSpectralDistributions
    uncertainty: np.ndarray
    sources: tuple[str, ...]
    residual: float
    name: str = field(default="estimated camera")
    band_k: float = 2.0
    response_scale: np.ndarray = field(default_factory=lambda: np.ones(3))
    errors: np.ndarray | None = None
    error_weight: np.ndarray = field(default_factory=lambda: np.array([[1.0] * 3, [0.0] * 3]))
    calibration: str = "synthesised matrices"

    @property
    def values(self) -> np.ndarray:
        """The curves, shape (n, 3)."""
        return np.asarray(self.sensitivities.values)

    @property
    def wavelengths(self) -> np.ndarray:
        """The grid (nm), shape (n,)."""
        return np.asarray(self.sensitivities.wavelengths)

    def band(self, k: float | None = None) -> tuple[np.ndarray, np.ndarray]:
        """(lower, upper) curves ``values ∓ k·uncertainty``, the lower clipped at 0; each (n, 3).

        Default ``k``: :attr:`band_k`, within which held-out measured curves lay at 90 % of wavelengths.
        """
        k = self.band_k if k is None else k
        return np.maximum(self.values - k * self.uncertainty, 0.0), self.values + k * self.uncertainty

    def response_sigma(
        self, illuminant="D65", reflectances="rawtoaces 190", *, bound: bool = False, rms: bool = False
    ) -> np.ndarray:
        """What the curves' error does to white-balanced responses: a noise σ per channel, shape (3,).

        ``bound=True``: the RMS over ``reflectances`` of ``R·diag(E)·u_c / white_c`` (``u`` the band,
        one standard deviation, taken as fully correlated over wavelengths: an upper bound, 4–6× the
        real error). ``rms=True``: that bound times :attr:`response_scale`, the ratio of held-out
        cameras' real RMS response error to it (calibrated leave one model out). Default: the RMS σ
        times :data:`~zonotope._tol.SSF_FIT_SIGMA_SCALE`, the σ to tell a noise-aware fit (the error is
        systematic, not independent per response: told its full RMS, a fit of stacked cameras gives up
        more of the stack than it needs to). Give it to the correction as noise
        (:func:`zonotope.ssf_noise`). Why: a regression fitted noise-free on estimated curves of several
        cameras amplifies their errors (docs/notes/2026-11-29-ssf-stacking.md,
        docs/notes/2026-11-29-ssf-goal.md).
        """
        w = self.wavelengths
        E = spectra.resample(spectra.illuminant(illuminant), w)[:, 0]
        R = _training(reflectances, tuple(w)) if isinstance(reflectances, str) else None
        if R is None:
            from .loading import load_reflectances

            R = spectra.resample(load_reflectances(reflectances), w).T
        white = E @ self.values
        sigma = np.sqrt(np.mean(np.square((R * E) @ self.uncertainty), axis=0)) / white
        if bound:
            return sigma
        sigma = sigma * np.asarray(self.response_scale, dtype=np.float64)
        return sigma if rms else sigma * SSF_FIT_SIGMA_SCALE

    def response_errors(
        self, reflectances="rawtoaces 190", illuminant="D65", *, scale: float = SSF_ERROR_DRAW_SCALE
    ) -> np.ndarray:
        """What the curves' error does to white-balanced responses, as draws: shape (M, N, 3).

        Draw ``m`` is the response of ``reflectances`` (a named set or an ``(N, n)`` array on the grid)
        with the curves ``values + scale·w·p·e_m`` (clipped at 0) minus that with ``values``: ``e_m`` the
        ``m``-th held-out curve error of the basis (:attr:`errors`), ``p`` each channel's peak and ``w``
        its weight ``a + b·residual`` (:attr:`error_weight`, at least
        :data:`~zonotope._tol.SSF_ERROR_WEIGHT_FLOOR`). The draws carry the error's correlation over
        wavelengths, channels and responses, which a σ per channel (:meth:`response_sigma`) drops; give
        them to :func:`zonotope.correct.eiv.fit_errors_in_variables` (stacks:
        :func:`zonotope.ssf_response_errors`). Default ``scale``:
        :data:`~zonotope._tol.SSF_ERROR_DRAW_SCALE` (docs/notes/2026-11-29-ssf-goal.md).

        Raises
        ------
        SpectralDataError
            A basis without held-out errors, or reflectances off the grid.
        """
        if self.errors is None:
            raise SpectralDataError(
                f"{self.name}: the basis stores no held-out errors; use response_sigma() or a basis "
                "calibrated with errors."
            )
        w = self.wavelengths
        if isinstance(reflectances, str):
            R = _training(reflectances, tuple(w))
        else:
            R = np.asarray(reflectances, dtype=np.float64)
            if R.ndim != 2 or R.shape[1] != w.size:
                raise SpectralDataError(
                    f"response_errors reflectances have shape {R.shape}; give (N, {w.size}) on the grid."
                )
        E = spectra.resample(spectra.illuminant(illuminant), w)[:, 0]
        v = self.values
        a, b = np.asarray(self.error_weight, dtype=np.float64)
        weight = np.maximum(a + b * self.residual, SSF_ERROR_WEIGHT_FLOOR)
        drawn = np.maximum(v + scale * weight * v.max(axis=0) * np.asarray(self.errors), 0.0)  # (M, n, 3)

        def responses(curves):
            G = curves * E[:, None]
            return R @ (G / np.maximum(G.sum(axis=-2, keepdims=True), 1e-300))

        return responses(drawn) - responses(v)


def sample_ssfs(
    estimate: SSFEstimate,
    n: int,
    *,
    seed: int = 0,
    k: float | None = None,
    correlation: float = SSF_SAMPLE_CORRELATION_NM,
) -> list[colour.MultiSpectralDistributions]:
    """``n`` cameras drawn within the band of ``estimate``, usable wherever a camera is.

    Each channel is ``values + u·z`` with ``u`` the band (one σ) and ``z`` a smooth Gaussian process
    (squared-exponential, ``correlation`` nm), the deviation cut symmetrically at
    ``min(k·u, values)`` (default ``k``: the estimate's calibrated :attr:`~SSFEstimate.band_k`): the
    draws are non-negative, inside ``values ± k·u`` and centred on the
    estimate (where a curve is below ``k·u`` its downward room, and so its upward, is the curve
    itself). Why: to see what the band does to a result, fit or MMV, one camera at a time.

    Raises
    ------
    SpectralDataError
        ``n`` < 1, ``k`` ≤ 0 or ``correlation`` ≤ 0.
    """
    if int(n) != n or n < 1:
        raise SpectralDataError(f"sample_ssfs n={n!r}: give a whole number of cameras ≥ 1.")
    k = estimate.band_k if k is None else k
    if not (np.isfinite(k) and k > 0 and np.isfinite(correlation) and correlation > 0):
        raise SpectralDataError(f"sample_ssfs k={k!r}, correlation={correlation!r}: give numbers > 0.")
    w, v, u = estimate.wavelengths, estimate.values, np.asarray(estimate.uncertainty, dtype=np.float64)
    C = np.exp(-0.5 * ((w[:, None] - w[None, :]) / correlation) ** 2)
    vals, vecs = np.linalg.eigh(C)
    L = vecs * np.sqrt(np.maximum(vals, 0.0))  # C = L·Lᵀ, robust to its near-singular tail
    z = np.einsum("ij,sjc->sic", L, np.random.default_rng(seed).standard_normal((int(n), w.size, 3)))
    room = np.minimum(k * u, v)
    draws = v + np.clip(u * z, -room, room)
    return [
        colour.MultiSpectralDistributions(
            d, w, labels=["red", "green", "blue"], name=f"{estimate.name} (band sample {i})"
        )
        for i, d in enumerate(draws)
    ]


@functools.lru_cache(maxsize=8)
def _training(name: str, w: tuple[float, ...]) -> np.ndarray:
    """A named reflectance set on a grid (read once: the built-in rawtoaces set takes a second)."""
    from .loading import load_reflectances

    R = spectra.resample(load_reflectances(name), np.asarray(w)).T
    R.setflags(write=False)
    return R


def _luther_peak(A: np.ndarray, T: np.ndarray, cmfs: np.ndarray) -> float:
    """Peak of the curves ``cmfs · M`` that best give ``A · s ≈ T`` (a block's scale, before any fit)."""
    M = np.linalg.lstsq(A @ cmfs, T, rcond=None)[0]
    return float(np.abs(cmfs @ M).max())


def _second_difference(n: int) -> np.ndarray:
    D = np.zeros((n - 2, n))
    for i in range(n - 2):
        D[i, i : i + 3] = (1.0, -2.0, 1.0)
    return D


def estimate_ssf(
    dng=None,
    *,
    chart: Chart | None = None,
    basis: SSFBasis | None = None,
    training="rawtoaces 190",
    smoothness: float = SSF_SMOOTHNESS,
    subspace: float = SSF_SUBSPACE,
    prior: float | None = None,
    name: str | None = None,
) -> SSFEstimate:
    """Estimate a camera's RGB spectral sensitivities from its DNG colour matrices, a chart, or both.

    Parameters
    ----------
    dng : path, mapping or DNGMatrices, optional
        A DNG file (its ColorMatrix1/2, ForwardMatrix1/2 and CalibrationIlluminant1/2 are read),
        ``isp.read_dng_tags`` output, or :class:`DNGMatrices`.
    chart : Chart or sequence of Chart, optional
        A photographed chart (raw patch means, reflectances, light), or several (the same or other
        charts, under other lights); each photograph's exposure is an unknown of its own.
    basis : SSFBasis, optional
        Default :func:`ssf_basis`.
    training : str or colour.MultiSpectralDistributions
        Reflectances on which the DNG matrices' mapping is reproduced (default the 190 rawtoaces
        training patches).
    smoothness, subspace, prior : float
        Weights of the second-difference penalty, of each channel's distance to its basis span, and of
        the Gaussian prior on the basis coefficients beyond the first, relative to the data (defaults
        chosen leaving one camera model out, docs/notes/2026-11-29-ssf-estimation.md). ``prior``
        defaults to ``basis.real_dng.prior`` for a DNG without a chart where the basis has that
        calibration (real DNG matrices are not exact fits of the curves:
        docs/notes/2026-11-29-real-dng-matrices.md), and the estimate then carries that calibration's
        band, unless its misfit exceeds the calibration's ``max_residual`` (a camera unlike all of its
        cameras, estimated as the basis without the calibration would); else
        :data:`~zonotope._tol.SSF_PRIOR`. A ``prior`` given with a DNG alone keeps the real-DNG band.
    name : str, optional
        Name of the estimated camera (default the DNG's make and model).

    Returns
    -------
    SSFEstimate

    Raises
    ------
    SpectralDataError
        Neither a DNG nor a chart; a DNG without usable colour matrices; a clipped or too dark chart,
        or a chart whose patch count is not the reflectance set's (each names what is missing).

    Notes
    -----
    Unknowns: the curves ``S`` (``n × 3``, bounded below by 0) and one exposure ``k_i`` per DNG
    illuminant after the first. Each matrix ``A_i`` (camera from XYZ) is the least-squares fit of the
    camera's responses on XYZ over ``R`` under ``E_i``, so its normal equations hold:
    ``x̄ᵀ·W_i·(s_c − k_i·x̄·a_c) = 0`` with ``W_i = diag(E_i)·RᵀR·diag(E_i)`` (9 rows per matrix,
    whitened by the Cholesky factor of ``x̄ᵀ·W_i·x̄``). Each chart adds ``R_c·diag(E)·S − k_c·C``, with
    ``k_c`` fixed to 1 only where the chart is the first block (no DNG); ``C`` is first brought to the
    curves' scale of the first block (through the 3 × 3 on the CIE 1931 functions that best fits each),
    so that every ``k`` is near 1. Each block is scaled to unit norm of its target (the DNG blocks
    share one unit, the charts another; beside a chart, the DNG blocks are weighted by ``prior ÷`` the
    real-DNG calibration's prior where the basis has one, as alone they are judged by that prior:
    docs/notes/2026-12-01-dng-and-chart.md); the regularisers
    ``√smoothness · D₂ s_c``, ``√subspace · (I − V_c V_cᵀ) s_c`` and ``√prior · (V_c / σ_c)ᵀ s_c``
    (components beyond the first) are scaled by the data's column norm. Solved by
    :func:`scipy.optimize.lsq_linear` (bounded least squares); the result is scaled so that its
    largest channel peaks at 1.

    Examples
    --------
    >>> import zonotope
    >>> from zonotope.spectra.estimate import estimate_ssf, synthesise_dng_matrices
    >>> est = estimate_ssf(synthesise_dng_matrices("Nikon 5100 (NPL)"))
    >>> est.values.shape, bool(est.values.min() >= 0)
    ((31, 3), True)
    """
    from scipy.optimize import lsq_linear

    from .loading import load_reflectances

    charts = [] if chart is None else [chart] if isinstance(chart, Chart) else list(chart)
    if not all(isinstance(c, Chart) for c in charts):
        raise SpectralDataError("estimate_ssf: chart must be a Chart or a sequence of Charts.")
    if dng is None and not charts:
        raise SpectralDataError(
            "estimate_ssf: give a DNG (its colour matrices), a chart photograph, or both."
        )
    basis = ssf_basis() if basis is None else basis
    # a DNG alone is judged by what real files' matrices give; a chart brings data of its own
    cal = basis.real_dng if not charts else None
    if cal is not None and prior is None:
        kw = dict(dng=read_dng_matrices(dng), training=training, smoothness=smoothness, subspace=subspace)
        est = estimate_ssf(basis=basis, prior=cal.prior, name=name, **kw)
        if est.residual <= cal.max_residual:
            return est
        # unlike every camera the calibration saw: trust the matrices, as for exact ones
        exact = estimate_ssf(
            basis=dataclasses.replace(basis, real_dng=None), prior=SSF_PRIOR, name=name, **kw
        )
        why = f"misfit {est.residual:.3g} at the real-DNG prior > {cal.max_residual:.3g}, any "
        why += "calibration camera's"
        return dataclasses.replace(exact, calibration=f"synthesised matrices ({why})")
    if prior is None:
        prior = SSF_PRIOR
    w = np.asarray(basis.wavelengths, dtype=np.float64)
    n = w.size
    # (A per channel, target (N, 3), its unknown exposure: an index, or None where the block fixes the scale)
    blocks: list[tuple[np.ndarray, np.ndarray, int | None]] = []
    n_exposures = 0
    matrices = None
    cmfs = spectra.resample(spectra.observer("CIE 1931 2°"), w)
    if dng is not None:
        matrices = read_dng_matrices(dng)
        R = _training(training, tuple(w)) if isinstance(training, str) else None
        if R is None:
            R = spectra.resample(load_reflectances(training), w).T
        lights = []
        for E, A in _camera_from_XYZ(matrices, w):
            key = next((j for j, e in enumerate(lights) if np.array_equal(e, E)), None)
            if key is None:
                lights.append(E)
                key = len(lights) - 1
            # the matrix is the least-squares fit of camera on XYZ over R: its normal equations
            # x̄ᵀ·W·(s_c − k·x̄·a_c) = 0 (W = diag(E)·RᵀR·diag(E)), whitened, hold for every channel
            RE = R * E / (cmfs[:, 1] @ E)
            G = (RE @ cmfs).T @ RE  # (3, n)
            L = np.linalg.cholesky(G @ cmfs)
            G = np.linalg.solve(L, G)
            blocks.append((G, G @ cmfs @ A.T, key))
        n_exposures = len(lights) - 1
        blocks = [(G, T, None if key == 0 else key - 1) for G, T, key in blocks]  # k_0 = 1 fixed
    n_dng = len(blocks)
    for c in charts:
        A_c, C = _chart_terms(c, w)
        if blocks:
            # every photograph has its own exposure k; its target is brought to the curves' scale the
            # first block sets, so k ≈ 1 and the regularisers (scaled by the data) see one scale
            C = C * (_luther_peak(*blocks[0][:2], cmfs) / _luther_peak(A_c, C, cmfs))
            blocks.append((A_c, C, n_exposures))
            n_exposures += 1
        else:
            blocks.append((A_c, C, None))
    n_var = 3 * n + n_exposures
    # beside a chart, matrices weigh against the basis prior as much as they do alone: with the real-DNG
    # calibration (real files' matrices are not exact fits) this prior ÷ its prior, else 1
    real = basis.real_dng
    dng_weight = prior / real.prior if charts and real is not None and real.prior > 0 else 1.0
    rows, rhs = [], []
    for i, (A, T, key) in enumerate(blocks):
        # the DNG blocks share one unit of weight, the charts another
        scale = 1.0 / max(np.linalg.norm(T), 1e-300) / np.sqrt(n_dng if i < n_dng else len(charts))
        scale = scale * np.sqrt(dng_weight if i < n_dng else 1.0)
        for c in range(3):
            M = np.zeros((A.shape[0], n_var))
            M[:, c * n : (c + 1) * n] = A * scale
            t = T[:, c] * scale
            if key is not None:
                M[:, 3 * n + key] = -t  # R·E·s_c − k·t
                t = np.zeros_like(t)
            rows.append(M)
            rhs.append(t)
    # regularisers, relative to the data's scale: curves are O(1 / column norm of the data)
    data = np.vstack(rows)
    col = np.sqrt(np.mean(np.square(data[:, : 3 * n]).sum(axis=0)))
    D2 = _second_difference(n)
    for c in range(3):
        V = basis.components[c]
        ridge = (V[:, 1:] / basis.sigma[c, 1:]).T  # components beyond the first, in units of their spread
        for weight, P in ((smoothness, D2), (subspace, np.eye(n) - V @ V.T), (prior, ridge)):
            M = np.zeros((P.shape[0], n_var))
            M[:, c * n : (c + 1) * n] = np.sqrt(weight) * col * P
            rows.append(M)
            rhs.append(np.zeros(P.shape[0]))
    M, b = np.vstack(rows), np.concatenate(rhs)
    lower = np.zeros(n_var)
    lower[3 * n :] = -np.inf
    # the same least-squares problem in n_var rows (Cholesky factor of the normal equations): fast BVLS
    H = M.T @ M
    L = np.linalg.cholesky(H + np.eye(n_var) * (SSF_CHOLESKY_JITTER * np.trace(H) / n_var))
    sol = lsq_linear(L.T, np.linalg.solve(L, M.T @ b), bounds=(lower, np.inf), method="bvls")
    S = sol.x[: 3 * n].reshape(3, n).T
    peak = S.max()
    if not peak > 0:
        raise SpectralDataError(
            "estimate_ssf: the data give all-zero sensitivities; check the matrices or chart."
        )
    fit = data @ sol.x - np.concatenate(rhs[: len(blocks) * 3])
    n_dng_rows = sum(3 * A.shape[0] for A, _, _ in blocks[:n_dng])
    fit[:n_dng_rows] /= np.sqrt(dng_weight)  # the misfit of each source in its own unit
    residual = float(np.linalg.norm(fit) / np.sqrt(len(blocks)))
    S = S / peak
    held = basis if cal is None else cal  # the calibration these data are judged by
    spread = np.asarray(held.spread, dtype=np.float64) * S.max(axis=0, keepdims=True)
    label = name or (matrices.name if matrices is not None and matrices.name else "estimated camera")
    msds = colour.MultiSpectralDistributions(S, w, labels=["red", "green", "blue"], name=label)
    sources = tuple(s for s, given in (("dng", dng is not None), ("chart", bool(charts))) if given)
    return SSFEstimate(
        msds,
        spread,
        sources,
        residual,
        label,
        float(held.band_k),
        np.asarray(held.response_scale),
        held.errors,
        np.asarray(held.error_weight),
        "synthesised matrices" if cal is None else "real DNG matrices",
    )


def held_out_error_model(
    pairs: Sequence[tuple[SSFEstimate, np.ndarray]], reflectances="rawtoaces 190", illuminant="D65"
) -> tuple[np.ndarray, np.ndarray]:
    """``(errors, error_weight)`` of :class:`SSFBasis` from held-out estimates and their measured curves.

    ``pairs``: (estimate made without the camera's model, measured curves ``(n, 3)``). ``errors`` are
    the curve errors (each channel at peak 1), ``error_weight`` the least-squares line of each camera's
    RMS white-balanced response error (``reflectances`` under ``illuminant``) on its misfit, over the
    RMS of all. Why: an estimate that fits its data worse errs more (Spearman 0.2–0.6 per channel).
    """
    if len(pairs) < 3:
        raise SpectralDataError(f"held_out_error_model: {len(pairs)} cameras; give at least 3.")
    w = pairs[0][0].wavelengths
    R = _training(reflectances, tuple(w)) if isinstance(reflectances, str) else np.asarray(reflectances)
    E = spectra.resample(spectra.illuminant(illuminant), w)[:, 0]

    def responses(curves):
        G = curves * E[:, None]
        return R @ (G / np.maximum(G.sum(axis=0, keepdims=True), 1e-300))

    errors = np.stack([t / t.max(axis=0) - e.values / e.values.max(axis=0) for e, t in pairs])
    rms = np.array(
        [np.sqrt(np.mean(np.square(responses(t) - responses(e.values)), axis=0)) for e, t in pairs]
    )
    r = np.array([e.residual for e, _ in pairs])
    line = np.linalg.lstsq(np.stack([np.ones_like(r), r], axis=1), rms, rcond=None)[0]  # (2, 3)
    return errors, line / np.sqrt(np.mean(np.square(rms), axis=0))


# ---------------------------------------------------------------------------------------------
# Output
# ---------------------------------------------------------------------------------------------


def ssf_json(estimate: SSFEstimate) -> dict:
    """The estimate as a rawtoaces / AMPAS spectral JSON document (``zonotope.load_camera`` reads it).

    The uncertainty (one standard deviation) travels in ``spectral_data.data.uncertainty``, which
    rawtoaces ignores.
    """
    make, _, model = estimate.name.partition(" ")
    return {
        "header": {
            "schema_version": "1.0.0",
            "manufacturer": make or "unknown",
            "model": model or estimate.name,
            "description": "camera spectral sensitivity data, estimated by zonotope.estimate_ssf from "
            + " and ".join(
                {"dng": "DNG colour matrices", "chart": "a chart photograph"}[s] for s in estimate.sources
            ),
            "document_creator": "zonotope.estimate_ssf",
            "comments": f"relative misfit {estimate.residual:.3g}; 'uncertainty' is one standard deviation",
            "zonotope": {  # what SSFEstimate.response_sigma needs (read_ssf_estimate); rawtoaces ignores it
                "sources": list(estimate.sources),
                "residual": round(float(estimate.residual), 6),
                "band_k": round(float(estimate.band_k), 6),
                "response_scale": [round(float(v), 6) for v in estimate.response_scale],
                "calibration": estimate.calibration,
            },
        },
        "spectral_data": {
            "units": "relative",
            "index": {"main": ["R", "G", "B"]},
            "data": {
                "main": {
                    f"{w:g}": [round(float(v), 6) for v in row]
                    for w, row in zip(estimate.wavelengths, estimate.values, strict=True)
                },
                "uncertainty": {
                    f"{w:g}": [round(float(v), 6) for v in row]
                    for w, row in zip(estimate.wavelengths, estimate.uncertainty, strict=True)
                },
            },
        },
    }


def _camera_json(camera) -> dict | None:
    """The parsed document of a ``.json`` camera file, or None (not a path to readable JSON)."""
    import json
    import os

    if not isinstance(camera, str | os.PathLike) or Path(camera).suffix.lower() != ".json":
        return None
    try:
        doc = json.loads(Path(camera).read_text(encoding="utf-8"))
    except (OSError, UnicodeDecodeError, ValueError):
        return None
    return doc if isinstance(doc, dict) else None


def _band_of(doc: dict | None, wavelengths) -> tuple[np.ndarray, str] | None:
    """:func:`read_ssf_band` of a parsed camera document."""
    if doc is None:
        return None
    try:
        table = doc["spectral_data"]["data"]["uncertainty"]
        w = np.array([float(k) for k in table], dtype=np.float64)
        u = np.array([[float(x) for x in table[k]] for k in table], dtype=np.float64)
    except (ValueError, KeyError, TypeError, AttributeError):
        return None
    if u.ndim != 2 or u.shape[1] != 3 or not np.isfinite(u).all():
        return None
    order = np.argsort(w)
    grid = np.asarray(wavelengths, dtype=np.float64)
    sigma = np.stack([np.interp(grid, w[order], u[order, c], left=0.0, right=0.0) for c in range(3)], 1)
    header = doc.get("header") if isinstance(doc.get("header"), dict) else {}
    return sigma, str(header.get("description") or "uncertainty given in the file")


def read_ssf_band(camera, wavelengths) -> tuple[np.ndarray, str] | None:
    """The uncertainty a camera file carries, on ``wavelengths``: ``(σ (n, 3), description)``, or None.

    ``camera``: a rawtoaces JSON file with ``spectral_data.data.uncertainty`` (one standard deviation
    per wavelength and channel, in the curves' own units, as :func:`ssf_json` writes it) and its
    header's ``description``; anything else (a built-in name, a CSV, a measured curve's file) gives
    None. σ is interpolated linearly and 0 outside the file's range. Why: a report on an estimated
    camera must say its curves are estimated and show how well they are known.
    """
    return _band_of(_camera_json(camera), wavelengths)


def read_ssf_estimate(camera) -> SSFEstimate | None:
    """The :class:`SSFEstimate` a camera file written by :func:`write_ssf_json` holds (its curves, band and
    calibration: what :meth:`~SSFEstimate.response_sigma` needs), or None for any other camera (a
    built-in name, a CSV, a measured curve's file). Why: a fit on a file's curves must be told their
    band as noise, as the capture does, wherever the file goes (``zonotope correct --camera FILE``).

    The held-out error draws are not stored (:meth:`~SSFEstimate.response_errors` needs the basis); a
    file of an earlier version, without the calibration block, gets the shipped basis' calibration.
    """
    doc = _camera_json(camera)
    header = (doc or {}).get("header")
    if not isinstance(header, dict) or header.get("document_creator") != "zonotope.estimate_ssf":
        return None
    band = _band_of(doc, SSF_SHAPE.wavelengths)
    if band is None:
        return None
    from .loading import load_camera

    loaded = load_camera(camera)
    curves = spectra.resample(loaded, SSF_SHAPE.wavelengths)
    cal = header.get("zonotope") if isinstance(header.get("zonotope"), dict) else {}
    basis = ssf_basis()
    try:
        scale = np.asarray(cal.get("response_scale", basis.response_scale), dtype=np.float64).reshape(3)
        return SSFEstimate(
            sensitivities=colour.MultiSpectralDistributions(
                curves, SSF_SHAPE.wavelengths, labels=("R", "G", "B"), name=str(loaded.name)
            ),
            uncertainty=band[0],
            sources=tuple(cal.get("sources", ())),
            residual=float(cal.get("residual", np.nan)),
            name=str(loaded.name),
            band_k=float(cal.get("band_k", basis.band_k)),
            response_scale=scale,
            calibration=str(cal.get("calibration", "synthesised matrices (the shipped basis')")),
        )
    except (TypeError, ValueError) as error:
        raise SpectralDataError(f"{camera}: a malformed 'zonotope' block in its header ({error}).") from None


def write_ssf_json(estimate: SSFEstimate, path, *, overwrite: bool = False) -> Path:
    """Write :func:`ssf_json` atomically; an existing file is replaced only with ``overwrite`` and only
    when an earlier estimate wrote it."""
    from ..utilities.io import atomic_write_text, check_output

    dest = check_output(path, overwrite=overwrite, signature=_SIGNATURE, what="output")
    doc = ssf_json(estimate)
    # the header on the first line: it carries the signature that marks a file this function wrote
    text = '{"header": ' + json.dumps(doc["header"], ensure_ascii=False) + ',\n"spectral_data": '
    text += json.dumps(doc["spectral_data"]) + "}\n"
    return atomic_write_text(dest, text)
