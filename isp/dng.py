"""DNG colour metadata: read the tags with tifffile, the DNG spec's camera → XYZ maths, write DNGs.

rawpy (LibRaw) decodes the pixels of a DNG but returns an all-zero ``rgb_xyz_matrix`` for it
(LibRaw issues #425, #751), so the colour tags are read here with tifffile.

Camera → XYZ follows the DNG specification 1.4, chapter 6 ("Mapping Camera Color Space to CIE XYZ
Space"):

* ``CM`` and ``CC`` are ColorMatrix1/2 and CameraCalibration1/2 interpolated linearly in inverse
  correlated colour temperature (mired) between the two calibration illuminants, clamped outside
  (:func:`matrix_interpolated`);
* ``XYZ_to_camera = AB · CC · CM`` (``AB = diag(AnalogBalance)``);
* the white's chromaticity is found from the camera neutral by fixed-point iteration
  (:func:`camera_neutral_to_xy`), because ``CM`` depends on the white's CCT;
* without ForwardMatrix: ``camera → XYZ_D50 = CAT(white → D50) · inv(XYZ_to_camera)`` (Bradford);
* with ForwardMatrix: ``camera → XYZ_D50 = FM · diag(1 / D) · inv(AB · CC)`` with
  ``D = inv(AB · CC) · neutral`` (the reference-camera neutral).

colour-hdri implements the same maths (``colour_hdri.matrix_camera_space_to_XYZ``); the tests compare
the two. It is not called here because its neutral → xy iteration has no iteration limit.

References
----------
.. [1] Adobe Systems (2012). Digital Negative (DNG) Specification 1.4.0.0, chapter 6, pp. 79–82.
"""

from __future__ import annotations

import os
from dataclasses import dataclass
from pathlib import Path

import colour
import numpy as np

from ._errors import RawFormatError
from ._tol import EXPOSURE_RECIPROCAL

__all__ = [
    "DNG_TAGS",
    "LIGHT_SOURCE_CCT",
    "DNGMetadata",
    "DNGProfile",
    "camera_neutral_to_xy",
    "matrix_interpolated",
    "noise_profile",
    "read_dng_tags",
    "write_dng",
    "xy_to_CCT_DNG",
    "xy_to_camera_neutral",
]

#: DNG / TIFF-EP tag codes used by :mod:`isp` (DNG spec 1.4, chapter 4).
DNG_TAGS: dict[str, int] = {
    "NewSubfileType": 254,
    "Make": 271,
    "Model": 272,
    "Orientation": 274,
    "DateTime": 306,
    "DateTimeOriginal": 36867,
    "CFARepeatPatternDim": 33421,
    "CFAPattern": 33422,
    "DNGVersion": 50706,
    "DNGBackwardVersion": 50707,
    "UniqueCameraModel": 50708,
    "CFAPlaneColor": 50710,
    "CFALayout": 50711,
    "LinearizationTable": 50712,
    "BlackLevelRepeatDim": 50713,
    "BlackLevel": 50714,
    "WhiteLevel": 50717,
    "ColorMatrix1": 50721,
    "ColorMatrix2": 50722,
    "CameraCalibration1": 50723,
    "CameraCalibration2": 50724,
    "AnalogBalance": 50727,
    "AsShotNeutral": 50728,
    "AsShotWhiteXY": 50729,
    "BaselineExposure": 50730,
    "CalibrationIlluminant1": 50778,
    "CalibrationIlluminant2": 50779,
    "ActiveArea": 50829,
    "ForwardMatrix1": 50964,
    "ForwardMatrix2": 50965,
    "NoiseProfile": 51041,
    "ExposureTime": 33434,
    "FNumber": 33437,
    "ISOSpeedRatings": 34855,
}

#: Correlated colour temperature (K) of the EXIF LightSource codes used by CalibrationIlluminant1/2,
#: as the Adobe DNG SDK 1.4 assigns them (``dng_camera_profile::IlluminantToTemperature``; the same
#: table as colour-hdri's ``CCT_ILLUMINANTS_ADOBEDNG``).
LIGHT_SOURCE_CCT: dict[int, float] = {
    1: 5500,
    2: 4200,
    3: 2850,
    4: 5500,
    9: 5500,
    10: 6500,
    11: 7500,
    12: 6400,
    13: 5000,
    14: 4200,
    15: 3450,
    16: 2925,
    17: 2850,
    18: 5500,
    19: 6500,
    20: 5500,
    21: 6500,
    22: 7500,
    23: 5000,
    24: 3200,
}

_RATIONAL = {5, 10}  # TIFF RATIONAL, SRATIONAL

#: CIE 1931 2° xy of D50, the DNG profile connection space white.
D50_xy = np.array(colour.CCS_ILLUMINANTS["CIE 1931 2 Degree Standard Observer"]["D50"], dtype=np.float64)


# ---------------------------------------------------------------------------------------------
# Reading tags
# ---------------------------------------------------------------------------------------------


def _tag_value(tag):
    """A tifffile tag as a float array (rationals divided out, 0/0 read as 0) or its raw value."""
    value = tag.value
    if int(tag.dtype) in _RATIONAL:
        v = np.asarray(value, dtype=np.float64).reshape(-1, 2)
        with np.errstate(divide="ignore", invalid="ignore"):
            return np.where(v[:, 1] != 0, v[:, 0] / np.where(v[:, 1] != 0, v[:, 1], 1), 0.0)
    if isinstance(value, bytes) and tag.code in (
        DNG_TAGS["CFAPattern"],
        DNG_TAGS["DNGVersion"],
        DNG_TAGS["DNGBackwardVersion"],
        DNG_TAGS["CFAPlaneColor"],
    ):
        return np.frombuffer(value, dtype=np.uint8).astype(np.int64)
    if isinstance(value, tuple | list) and value and all(isinstance(x, int | float) for x in value):
        return np.asarray(value, dtype=np.float64)
    if isinstance(value, int | float) and not isinstance(value, bool):
        return int(value) if isinstance(value, int) else float(value)
    return value


def read_dng_tags(path: str | os.PathLike) -> dict[str, object]:
    """Read the DNG colour and layout tags of a file with tifffile.

    Colour tags come from IFD 0; layout tags (CFA, black/white level, linearisation table, active
    area) from the raw IFD (``NewSubfileType == 0`` with CFA or LinearRaw photometric), which may be
    IFD 0 itself or one of its SubIFDs.

    Parameters
    ----------
    path
        A DNG file.

    Returns
    -------
    dict
        Tag name (see :data:`DNG_TAGS`) → value. Rationals are floats, matrices are flat arrays
        of 9 values (row-major), byte tags (CFAPattern, DNGVersion) int arrays. Missing tags are
        absent.

    Raises
    ------
    RawFormatError
        Not a TIFF file, or a TIFF without the DNGVersion tag.
    """
    import tifffile

    try:
        with tifffile.TiffFile(path) as tif:
            ifd0 = tif.pages[0]
            if DNG_TAGS["DNGVersion"] not in ifd0.tags:
                raise RawFormatError(f"{path}: a TIFF file but not a DNG (no DNGVersion tag).")
            raw_ifd = None
            for page in [ifd0, *(getattr(ifd0, "pages", None) or [])]:
                sub = page.tags.get(254)
                photometric = int(page.tags[262].value) if 262 in page.tags else -1
                if (sub is None or int(sub.value) == 0) and photometric in (32803, 34892):
                    raw_ifd = page
                    break
            out: dict[str, object] = {}
            names = {code: name for name, code in DNG_TAGS.items()}
            for page in [ifd0] if raw_ifd is None else [ifd0, raw_ifd]:
                for tag in page.tags.values():
                    if tag.code in names:
                        out[names[tag.code]] = _tag_value(tag)
            out["_raw_ifd_found"] = raw_ifd is not None
            return out
    except RawFormatError:
        raise
    except (tifffile.TiffFileError, OSError, ValueError, IndexError, KeyError, TypeError) as exc:
        # TypeError: a damaged tag whose value is a tuple where a number belongs (found by fuzzing)
        raise RawFormatError(f"{path}: cannot read DNG tags ({type(exc).__name__}: {exc}).") from exc


def noise_profile(tags: dict, path: str | os.PathLike | None = None, planes: int = 3) -> np.ndarray | None:
    """The DNG NoiseProfile (tag 51041, DNG 1.3+) of :func:`read_dng_tags` output, one row per colour.

    The tag models the noise of the linear signal ``x ∈ [0, 1]`` (0 at BlackLevel, 1 at WhiteLevel)
    before demosaicing: standard deviation ``sqrt(S·x + O)``, with one ``(S, O)`` pair per colour
    plane (CFA colours in CFAPlaneColor order, R, G, B here) or a single pair for all of them. The
    DNG SDK (``dng_noise_function::IsValid``) requires ``S > 0`` and ``O ≥ 0``.

    Parameters
    ----------
    tags : dict
        :func:`read_dng_tags` output (or ``RawImage.tags``).
    path : path, optional
        The file, named in the error message.
    planes : int
        Colour planes of the image (3 for the Bayer and LinearRaw files isp reads).

    Returns
    -------
    ndarray of shape (planes, 2) or None
        Rows ``(S, O)``; a single pair repeated for every plane. None when the file has no NoiseProfile.

    Raises
    ------
    RawFormatError
        A malformed tag: a count other than 2 or ``2 · planes``, a non-finite value, ``S ≤ 0`` or
        ``O < 0`` (the message names the file and the tag, and how to remove it).
    """
    value = tags.get("NoiseProfile")
    if value is None:
        return None
    where = f"{path}: " if path is not None else ""
    fix = "the file is damaged or was written wrongly; remove the tag (exiftool -NoiseProfile= FILE)."
    try:
        v = np.asarray(value, dtype=np.float64).ravel()
    except (TypeError, ValueError):
        raise RawFormatError(f"{where}NoiseProfile (tag 51041) is not numeric ({value!r}); {fix}") from None
    if v.size not in (2, 2 * planes):
        raise RawFormatError(
            f"{where}NoiseProfile (tag 51041) has {v.size} values; expected 2 (one (S, O) pair for all "
            f"colours) or {2 * planes} (one per colour plane); {fix}"
        )
    pairs = v.reshape(-1, 2)
    if not np.all(np.isfinite(pairs)) or np.any(pairs[:, 0] <= 0) or np.any(pairs[:, 1] < 0):
        raise RawFormatError(
            f"{where}NoiseProfile (tag 51041) = {v.tolist()}: every pair (S, O) must be finite with S > 0 "
            f"and O ≥ 0 (noise variance S·x + O); {fix}"
        )
    return np.broadcast_to(pairs, (planes, 2)).copy()


# ---------------------------------------------------------------------------------------------
# DNG colour maths
# ---------------------------------------------------------------------------------------------


def xy_to_CCT_DNG(xy) -> float:
    """Correlated colour temperature of a chromaticity, Robertson (1968) on CIE 1960 UCS uv, as the
    DNG SDK computes it.

    Parameters
    ----------
    xy : array_like of shape (2,)

    Returns
    -------
    float
        CCT in kelvin.
    """
    XYZ = colour.xy_to_XYZ(np.asarray(xy, dtype=np.float64))
    uv = colour.UCS_to_uv(colour.XYZ_to_UCS(XYZ))
    return float(colour.temperature.uv_to_CCT_Robertson1968(uv)[0])


def matrix_interpolated(CCT: float, CCT_1: float, CCT_2: float, M_1, M_2) -> np.ndarray:
    """Interpolate two calibration matrices linearly in inverse CCT (mired), clamped outside.

    Parameters
    ----------
    CCT
        Colour temperature of the scene white (K).
    CCT_1, CCT_2
        Colour temperatures of CalibrationIlluminant1 and 2 (either order).
    M_1, M_2 : array_like of shape (3, 3)

    Returns
    -------
    ndarray of shape (3, 3)

    References
    ----------
    DNG specification 1.4, p. 80 ("interpolated ... based on the inverse of the CCT").

    Examples
    --------
    The Canon EOS 5D Mark II matrices of colour-hdri's documentation:

    >>> M_1 = [[0.5309, -0.0229, -0.0336], [-0.6241, 1.3265, 0.3337], [-0.0817, 0.1215, 0.6664]]
    >>> M_2 = [[0.4716, 0.0603, -0.0830], [-0.7798, 1.5474, 0.2480], [-0.1496, 0.1937, 0.6651]]
    >>> matrix_interpolated(5000, 2850, 6500, M_1, M_2)[0].round(6)
    array([ 0.485491,  0.040811, -0.071428])
    """
    M_1 = np.asarray(M_1, dtype=np.float64)
    M_2 = np.asarray(M_2, dtype=np.float64)
    if CCT_1 > CCT_2:
        CCT_1, CCT_2, M_1, M_2 = CCT_2, CCT_1, M_2, M_1
    if CCT <= CCT_1 or CCT_1 == CCT_2:
        return M_1.copy()
    if CCT >= CCT_2:
        return M_2.copy()
    g = (1.0 / CCT - 1.0 / CCT_2) / (1.0 / CCT_1 - 1.0 / CCT_2)
    return g * M_1 + (1.0 - g) * M_2


#: DNG colour matrices are inverted (camera → XYZ); one whose condition number reaches this is
#: singular to float64 for practical purposes (real ColorMatrix tags measure ≈ 3–30) and would turn
#: noise into colour, so it is refused as damaged metadata.
MATRIX_CONDITION_MAX = 1e8


def _matrix3(value, name: str) -> np.ndarray | None:
    if value is None:
        return None
    m = np.asarray(value, dtype=np.float64)
    if m.size != 9 or not np.all(np.isfinite(m)):
        raise RawFormatError(f"{name}: expected 9 finite values (a 3 × 3 matrix), got {m.ravel()[:12]}.")
    return m.reshape(3, 3)


@dataclass(frozen=True, eq=False)
class DNGProfile:
    """The colour calibration of a camera as DNG tags describe it (3-channel cameras).

    Attributes
    ----------
    color_matrix_1, color_matrix_2 : ndarray of shape (3, 3) or None
        XYZ → reference camera matrices under the calibration illuminants.
    calibration_illuminant_1, calibration_illuminant_2 : int
        EXIF LightSource codes (0 = unknown; see :data:`LIGHT_SOURCE_CCT`).
    camera_calibration_1, camera_calibration_2 : ndarray of shape (3, 3) or None
        Reference camera → this camera (identity when None).
    forward_matrix_1, forward_matrix_2 : ndarray of shape (3, 3) or None
        White-balanced camera → XYZ D50.
    analog_balance : ndarray of shape (3,)
    """

    color_matrix_1: np.ndarray | None
    color_matrix_2: np.ndarray | None = None
    calibration_illuminant_1: int = 0
    calibration_illuminant_2: int = 0
    camera_calibration_1: np.ndarray | None = None
    camera_calibration_2: np.ndarray | None = None
    forward_matrix_1: np.ndarray | None = None
    forward_matrix_2: np.ndarray | None = None
    analog_balance: np.ndarray = None  # type: ignore[assignment]

    def __post_init__(self) -> None:
        for name in (
            "color_matrix_1",
            "color_matrix_2",
            "camera_calibration_1",
            "camera_calibration_2",
            "forward_matrix_1",
            "forward_matrix_2",
        ):
            m = _matrix3(getattr(self, name), name)
            if m is not None and not np.linalg.cond(m) < MATRIX_CONDITION_MAX:
                tag = "".join(w.capitalize() for w in name.split("_")[:-1]) + name[-1]
                raise RawFormatError(
                    f"{tag} ({name}) is singular or nearly so (condition number "
                    f"{np.linalg.cond(m):.3g}): the colour calibration is damaged; convert the "
                    "camera's original RAW again or correct the tag (exiftool)."
                )
            object.__setattr__(self, name, m)
        ab = np.ones(3) if self.analog_balance is None else np.asarray(self.analog_balance, np.float64)
        if ab.shape != (3,) or not np.all(np.isfinite(ab)) or np.any(ab <= 0):
            raise RawFormatError(f"analog_balance: expected 3 positive gains, got {ab}.")
        object.__setattr__(self, "analog_balance", ab)
        if self.color_matrix_1 is None and self.color_matrix_2 is None:
            raise RawFormatError(
                "the profile has no ColorMatrix1/2: camera → XYZ is unknown. "
                "Give a colour matrix or use a correction callable instead."
            )

    @classmethod
    def from_tags(cls, tags: dict) -> DNGProfile:
        """Build a profile from :func:`read_dng_tags` output."""
        get = tags.get
        return cls(
            color_matrix_1=get("ColorMatrix1"),
            color_matrix_2=get("ColorMatrix2"),
            calibration_illuminant_1=int(get("CalibrationIlluminant1", 0) or 0),
            calibration_illuminant_2=int(get("CalibrationIlluminant2", 0) or 0),
            camera_calibration_1=get("CameraCalibration1"),
            camera_calibration_2=get("CameraCalibration2"),
            forward_matrix_1=get("ForwardMatrix1"),
            forward_matrix_2=get("ForwardMatrix2"),
            analog_balance=get("AnalogBalance"),
        )

    # -- interpolation -------------------------------------------------------------------------
    def _pair(
        self, a: np.ndarray | None, b: np.ndarray | None, CCT: float | None, default: np.ndarray | None
    ) -> np.ndarray | None:
        if a is None and b is None:
            return default
        if a is None or b is None:
            return (a if b is None else b).copy()
        t1 = LIGHT_SOURCE_CCT.get(self.calibration_illuminant_1)
        t2 = LIGHT_SOURCE_CCT.get(self.calibration_illuminant_2)
        if t1 is None or t2 is None or CCT is None:
            return b.copy()  # unknown illuminants: DNG SDK uses the second (usually D65) set
        return matrix_interpolated(CCT, t1, t2, a, b)

    def XYZ_to_camera(self, xy) -> np.ndarray:
        """``AB · CC · CM`` for a scene white of chromaticity ``xy`` (shape (2,)) → (3, 3)."""
        CCT = xy_to_CCT_DNG(xy)
        CM = self._pair(self.color_matrix_1, self.color_matrix_2, CCT, None)
        CC = self._pair(self.camera_calibration_1, self.camera_calibration_2, CCT, np.eye(3))
        return np.diag(self.analog_balance) @ CC @ CM

    def camera_from_XYZ_is_constant(self) -> bool:
        """True when the profile has a single colour matrix (no CCT dependence)."""
        return (self.color_matrix_1 is None) != (self.color_matrix_2 is None)

    def camera_to_XYZ_D50(self, neutral, *, cat: str = "Bradford") -> np.ndarray:
        """Camera (not white balanced) → XYZ D50 for the camera neutral ``neutral``.

        Parameters
        ----------
        neutral : array_like of shape (3,)
            Camera response to the scene white (AsShotNeutral); any positive scale.
        cat
            Chromatic adaptation transform from the scene white to D50 (ColorMatrix path only).

        Returns
        -------
        M : ndarray of shape (3, 3)
            ``XYZ_D50 = M @ camera``, scaled so that ``M @ neutral`` has Y = 1 when ``neutral`` is
            normalised to max 1.
        """
        n = _neutral(neutral)
        xy = camera_neutral_to_xy(n, self)
        CCT = xy_to_CCT_DNG(xy)
        FM = self._pair(self.forward_matrix_1, self.forward_matrix_2, CCT, None)
        if FM is None:
            M = np.linalg.inv(self.XYZ_to_camera(xy))
            CAT = colour.adaptation.matrix_chromatic_adaptation_VonKries(
                colour.xy_to_XYZ(xy), colour.xy_to_XYZ(D50_xy), transform=cat
            )
            M = CAT @ M
        else:
            CC = self._pair(self.camera_calibration_1, self.camera_calibration_2, CCT, np.eye(3))
            ABCC_inv = np.linalg.inv(np.diag(self.analog_balance) @ CC)
            D = ABCC_inv @ n
            M = FM @ np.diag(1.0 / D) @ ABCC_inv
        Y = (M @ (n / n.max()))[1]
        return M / Y


def _neutral(neutral) -> np.ndarray:
    n = np.asarray(neutral, dtype=np.float64).reshape(-1)
    if n.shape != (3,) or not np.all(np.isfinite(n)) or np.any(n <= 0):
        raise RawFormatError(
            f"camera neutral: expected 3 positive finite values, got {n}. "
            "Pass the AsShotNeutral of the image, or a white patch's raw response."
        )
    return n


def xy_to_camera_neutral(xy, profile: DNGProfile) -> np.ndarray:
    """Camera neutral (the camera's response to a white of chromaticity ``xy``), max 1.

    The inverse of :func:`camera_neutral_to_xy`: ``neutral ∝ XYZ_to_camera(xy) · XYZ(xy)`` (DNG
    spec 1.4, p. 81, as the SDK turns AsShotWhiteXY into a neutral).

    Parameters
    ----------
    xy : array_like of shape (2,)
        Chromaticity of the scene white (CIE 1931 2°).
    profile
        The camera's :class:`DNGProfile`.

    Returns
    -------
    ndarray of shape (3,)

    Raises
    ------
    RawFormatError
        ``xy`` is not a chromaticity inside the unit triangle, or the camera's response to it has a
        non-positive channel (a white this colour matrix cannot see as a white).
    """
    c = np.asarray(xy, dtype=np.float64).reshape(-1)
    if c.shape != (2,) or not np.all(np.isfinite(c)) or np.any(c <= 0) or c.sum() >= 1:
        raise RawFormatError(f"white chromaticity xy={c}: expected 2 positive values with x + y < 1.")
    n = profile.XYZ_to_camera(c) @ colour.xy_to_XYZ(c)
    if not np.all(n > 0):
        raise RawFormatError(
            f"white chromaticity xy={c} gives the camera response {n} with a non-positive "
            "channel: it is too far from the colours this camera's matrix was made for."
        )
    return n / n.max()


def camera_neutral_to_xy(
    neutral, profile: DNGProfile, *, atol: float = 1e-10, max_iter: int = 100
) -> np.ndarray:
    """Chromaticity of the scene white from the camera neutral (DNG spec 1.4, p. 81).

    Parameters
    ----------
    neutral : array_like of shape (3,)
        Camera neutral (AsShotNeutral), any positive scale.
    profile
        The camera's :class:`DNGProfile`.
    atol, max_iter
        Absolute convergence threshold on xy and iteration limit.

    Returns
    -------
    ndarray of shape (2,)

    Raises
    ------
    RawFormatError
        Bad neutral, or no convergence within ``max_iter`` iterations.
    """
    n = _neutral(neutral)
    xy = D50_xy.copy()
    for _ in range(max_iter):
        XYZ = np.linalg.solve(profile.XYZ_to_camera(xy), n)
        if XYZ.sum() <= 0:
            raise RawFormatError(
                f"camera neutral {n} maps to XYZ {XYZ} with a non-positive sum: the "
                "neutral is not a plausible white for this colour matrix."
            )
        new = colour.XYZ_to_xy(XYZ)
        if np.abs(new - xy).max() <= atol:
            return new
        xy = new
    raise RawFormatError(
        f"camera neutral {n}: white chromaticity did not converge in {max_iter} "
        "iterations (last xy {xy}). Check AsShotNeutral and the colour matrices."
    )


# ---------------------------------------------------------------------------------------------
# Writing
# ---------------------------------------------------------------------------------------------


def _srational(m) -> tuple[int, ...]:
    out = []
    for v in np.asarray(m, dtype=np.float64).ravel():
        out += [round(float(v) * 10000), 10000]
    return tuple(out)


def _rational(v) -> tuple[int, ...]:
    out = []
    for x in np.asarray(v, dtype=np.float64).ravel():
        out += [round(float(x) * 1_000_000), 1_000_000]
    return tuple(out)


def _exposure_rational(t: float) -> tuple[int, int]:
    """Exposure time as a camera writes it: 1/n for short times, else micro-second precision."""
    t = float(t)
    if 0 < t < 1 and abs(1 / t - round(1 / t)) < EXPOSURE_RECIPROCAL:
        return (1, round(1 / t))
    return (round(t * 1_000_000), 1_000_000)


_CFA_CODES = {"R": 0, "G": 1, "B": 2}


@dataclass(frozen=True)
class DNGMetadata:
    """Everything :func:`write_dng` stores besides the pixels, checked when it is made.

    One object can be reused for every frame of a camera (a simulated capture writes many).

    Attributes
    ----------
    cfa : str or None
        2 × 2 pattern, e.g. ``"RGGB"``; required for a Bayer mosaic, ignored (may be None) for a
        full-colour LinearRaw image.
    black_level : float or array_like of shape (2, 2)
        Per CFA site (LinearRaw: a float or 3 values, one per channel).
    white_level : int
        Saturation value, 1…65535.
    color_matrix_1 : array_like of shape (3, 3)
        XYZ → camera under ``calibration_illuminant_1`` (stored to 4 decimals, as SRATIONAL/10000).
    as_shot_neutral : array_like of shape (3,)
        Positive camera response to the scene white.
    calibration_illuminant_1 : int
        EXIF LightSource code (21 = D65).
    forward_matrix_1 : array_like of shape (3, 3), optional
    make, model : str
        Make, Model and UniqueCameraModel tags.
    color_matrix_2 : array_like of shape (3, 3), optional
        XYZ → camera under ``calibration_illuminant_2`` (both or neither).
    calibration_illuminant_2 : int, optional
    exposure_time, iso, f_number : optional
        EXIF ExposureTime (s, RATIONAL 33434), ISOSpeedRatings (SHORT 34855) and FNumber (RATIONAL
        33437), written in IFD 0; positive.
    orientation : int
        TIFF/EXIF Orientation (274) of the picture: 1 = as stored, 3 = rotate 180°, 6 = rotate 90°
        clockwise to view, 8 = 90° counter-clockwise; 2, 4, 5, 7 add a mirror.
    noise_profile : array_like of shape (2,) or (3, 2), optional
        DNG NoiseProfile (tag 51041, DOUBLE): the noise variance ``S·x + O`` of the linear signal
        ``x ∈ [0, 1]`` (black → white level), one ``(S, O)`` pair for all colours or one per colour
        (R, G, B); ``S > 0``, ``O ≥ 0`` as the DNG SDK requires. Read back by :func:`noise_profile`.

    Raises
    ------
    PipelineError
        A value of the wrong shape or range (named, with what is allowed).
    RawFormatError
        A CFA pattern that is not a 2 × 2 arrangement of R, G, B.
    """

    cfa: str | None
    black_level: object
    white_level: int
    color_matrix_1: object
    as_shot_neutral: object
    calibration_illuminant_1: int = 21
    forward_matrix_1: object = None
    make: str = "zonotope"
    model: str = "simulated"
    color_matrix_2: object = None
    calibration_illuminant_2: int | None = None
    exposure_time: float | None = None
    iso: int | None = None
    f_number: float | None = None
    orientation: int = 1
    noise_profile: object = None

    def __post_init__(self):
        from ._errors import PipelineError
        from .cfa import check_cfa

        def fail(name, value, allowed):
            raise PipelineError(f"DNGMetadata.{name}={value!r}: {allowed}.")

        if self.cfa is not None:
            object.__setattr__(self, "cfa", check_cfa(self.cfa))
        if not _integral(self.white_level) or not 1 <= self.white_level <= 65535:
            fail("white_level", self.white_level, "use an integer saturation value in 1…65535")
        object.__setattr__(self, "white_level", int(self.white_level))
        black = np.asarray(self.black_level, dtype=np.float64) if _numeric(self.black_level) else None
        if black is None or black.size not in (1, 3, 4) or not np.all(np.isfinite(black)) or black.min() < 0:
            fail("black_level", self.black_level, "use one value ≥ 0, 3 (LinearRaw) or 2 × 2 (per CFA site)")
        if black.max() >= self.white_level:
            fail("black_level", self.black_level, f"it must lie below white_level={self.white_level}")
        for name in ("color_matrix_1", "forward_matrix_1", "color_matrix_2"):
            v = getattr(self, name)
            if v is None and name != "color_matrix_1":
                continue
            M = np.asarray(v, dtype=np.float64) if _numeric(v) else None
            if M is None or M.shape != (3, 3) or not np.all(np.isfinite(M)):
                fail(name, v, "give a finite 3 × 3 matrix (XYZ → camera)")
            object.__setattr__(self, name, M)
        n = np.asarray(self.as_shot_neutral, dtype=np.float64) if _numeric(self.as_shot_neutral) else None
        if n is None or n.shape != (3,) or not np.all(np.isfinite(n)) or n.min() <= 0:
            fail("as_shot_neutral", self.as_shot_neutral, "give 3 positive finite camera responses")
        for name in ("calibration_illuminant_1", "calibration_illuminant_2", "iso"):
            v = getattr(self, name)
            if v is None and name != "calibration_illuminant_1":
                continue
            if not _integral(v) or not 0 <= v <= 65535:
                fail(name, v, "use an integer in 0…65535 (an EXIF SHORT)")
            object.__setattr__(self, name, int(v))
        if (self.color_matrix_2 is None) != (self.calibration_illuminant_2 is None):
            raise PipelineError(
                "color_matrix_2 and calibration_illuminant_2 go together: pass both or neither."
            )
        for name in ("exposure_time", "f_number"):
            v = getattr(self, name)
            if v is not None and not (_numeric(v) and np.ndim(v) == 0 and np.isfinite(v) and v > 0):
                fail(name, v, "give a positive finite number or None")
        if isinstance(self.orientation, bool) or self.orientation not in range(1, 9):
            raise PipelineError(
                f"orientation={self.orientation!r}: use a TIFF Orientation code 1–8 (1 = as stored, "
                "6 = rotate 90° clockwise, 3 = 180°, 8 = 90° counter-clockwise)."
            )
        for name in ("make", "model"):
            if not isinstance(getattr(self, name), str):
                fail(name, getattr(self, name), "give a string")
        if self.noise_profile is not None:
            P = np.asarray(self.noise_profile, dtype=np.float64) if _numeric(self.noise_profile) else None
            if (
                P is None
                or P.shape not in ((2,), (1, 2), (3, 2))
                or not np.all(np.isfinite(P))
                or np.any(P.reshape(-1, 2)[:, 0] <= 0)
                or np.any(P.reshape(-1, 2)[:, 1] < 0)
            ):
                fail(
                    "noise_profile",
                    self.noise_profile,
                    "give one (S, O) pair or 3 (R, G, B), finite, with S > 0 and O ≥ 0 (variance S·x + O)",
                )
            object.__setattr__(self, "noise_profile", P.reshape(-1, 2))


def _integral(value) -> bool:
    """Whether ``value`` is a whole number (an int, or a float such as 4095.0; not a bool)."""
    if isinstance(value, bool) or not isinstance(value, int | float | np.integer | np.floating):
        return False
    return bool(np.isfinite(value)) and float(value).is_integer()


def _numeric(value) -> bool:
    """Whether ``value`` is a number or a regular array of numbers (no strings, bools, ragged lists)."""
    try:
        a = np.asarray(value)
    except (TypeError, ValueError):
        return False
    return a.dtype.kind in "iuf"


def write_dng(
    path: str | os.PathLike,
    mosaic,
    metadata: DNGMetadata | None = None,
    *,
    overwrite: bool = False,
    **fields,
) -> Path:
    """Write a Bayer mosaic (or a full-colour LinearRaw image) as an uncompressed DNG 1.4 that
    rawpy/LibRaw reads (atomically).

    Parameters
    ----------
    path
        Output file; written to a temporary file in the same folder, then renamed.
    mosaic : array_like of shape (H, W) or (H, W, 3), integers in [0, white_level]
        Raw values including the black level; stored as uint16. An (H, W, 3) array (a full-colour,
        e.g. Foveon-type, sensor) is written as LinearRaw (PhotometricInterpretation 34892, no CFA
        tags; ``cfa`` is then ignored).
    metadata : DNGMetadata, optional
        The tags (see :class:`DNGMetadata`); made from ``**fields`` when omitted.
    overwrite
        Refuse to replace an existing file unless True.
    **fields
        :class:`DNGMetadata` fields (``cfa=``, ``black_level=``, ``white_level=``,
        ``color_matrix_1=``, ``as_shot_neutral=``, ...), alone or overriding those of ``metadata``.
        Keeping them as keywords lets a one-off call read as before; a series of files shares
        one checked :class:`DNGMetadata`.

    Returns
    -------
    Path

    Raises
    ------
    PipelineError
        ``path`` exists and ``overwrite`` is False; an unknown or missing field, or a bad value
        (see :class:`DNGMetadata`).
    RawFormatError
        Bad mosaic (not 2-D, out of range) or CFA pattern.

    Examples
    --------
    >>> import numpy as np, tempfile, pathlib
    >>> meta = DNGMetadata(cfa="RGGB", black_level=64, white_level=4095,
    ...                    color_matrix_1=np.eye(3), as_shot_neutral=[0.5, 1.0, 0.7])
    >>> out = pathlib.Path(tempfile.mkdtemp()) / "grey.dng"
    >>> write_dng(out, np.full((4, 6), 1000, np.uint16), meta).name
    'grey.dng'
    >>> write_dng(out, np.full((4, 6), 1000, np.uint16), meta, overwrite=True, iso=200).stat().st_size > 0
    True
    """
    import tifffile

    from ._config import with_options
    from ._errors import PipelineError

    metadata = with_options(DNGMetadata, metadata, fields, where="write_dng")
    d = metadata
    path = Path(path)
    if path.exists() and not overwrite:
        raise PipelineError(f"{path} exists; pass overwrite=True or choose another name.")
    m = np.asarray(mosaic)
    linear_raw = m.ndim == 3
    if linear_raw:
        if m.shape[2] != 3 or m.shape[0] < 2 or m.shape[1] < 2:
            raise RawFormatError(f"mosaic: a full-colour image must have shape (H, W, 3); got {m.shape}.")
        black = np.broadcast_to(np.asarray(d.black_level, dtype=np.float64).ravel(), (3,))
    else:
        if d.cfa is None:
            raise RawFormatError("cfa: a Bayer mosaic needs its 2 × 2 pattern, e.g. cfa='RGGB'.")
        if m.ndim != 2 or m.shape[0] < 2 or m.shape[1] < 2 or m.shape[0] % 2 or m.shape[1] % 2:
            raise RawFormatError(f"mosaic: expected an (H, W) array with even H, W ≥ 2, got shape {m.shape}.")
        black = np.broadcast_to(np.asarray(d.black_level, dtype=np.float64), (2, 2))
    white_level = int(d.white_level)
    if not np.all(np.isfinite(m)) or m.min() < 0 or m.max() > white_level:
        raise RawFormatError(
            f"mosaic: values must lie in [0, white_level={white_level}] ≤ 65535; got {m.min()}…{m.max()}."
        )
    layout = (
        [(50713, "H", 2, (1, 1), True)]
        if linear_raw
        else [
            (33421, "H", 2, (2, 2), True),
            (33422, "B", 4, tuple(_CFA_CODES[c] for c in d.cfa), True),
            (50713, "H", 2, (2, 2), True),
        ]
    )
    tags = [
        (254, "I", 1, 0, True),
        (271, "s", 0, d.make, True),
        (272, "s", 0, d.model, True),
        (274, "H", 1, int(d.orientation), True),
        *layout,
        (50706, "B", 4, (1, 4, 0, 0), True),
        (50707, "B", 4, (1, 1, 0, 0), True),
        (50708, "s", 0, f"{d.make} {d.model}", True),
        (50714, "I", black.size, tuple(round(float(b)) for b in black.ravel()), True),
        (50717, "I", 1, int(white_level), True),
        (50721, 10, 9, _srational(d.color_matrix_1), True),
        (50727, 5, 3, _rational(np.ones(3)), True),
        (50728, 5, 3, _rational(_neutral(d.as_shot_neutral)), True),
        (50778, "H", 1, int(d.calibration_illuminant_1), True),
    ]
    if d.forward_matrix_1 is not None:
        tags.append((50964, 10, 9, _srational(d.forward_matrix_1), True))
    if d.color_matrix_2 is not None:
        tags += [
            (50722, 10, 9, _srational(d.color_matrix_2), True),
            (50779, "H", 1, int(d.calibration_illuminant_2), True),
        ]
    if d.exposure_time is not None:
        tags.append((33434, 5, 1, _exposure_rational(d.exposure_time), True))
    if d.f_number is not None:
        tags.append((33437, 5, 1, _rational(d.f_number), True))
    if d.iso is not None:
        tags.append((34855, "H", 1, int(d.iso), True))
    if d.noise_profile is not None:
        tags.append((51041, 12, d.noise_profile.size, tuple(float(x) for x in d.noise_profile.ravel()), True))
    from zonotope.utilities import atomic_path

    def write(tmp: Path) -> None:
        tifffile.imwrite(
            tmp,
            np.ascontiguousarray(m, dtype=np.uint16),
            photometric=34892 if linear_raw else 32803,
            planarconfig="contig",
            extratags=tags,
            metadata=None,
            software="isp (zonotope)",
        )

    atomic_path(path, write)  # temporary sibling, fsync, umask permissions, rename
    return path
