"""DNG camera profiles (DCP): read, write and apply them, the DNG 1.6 way.

A DCP is a TIFF-like file whose header magic is ``IIRC`` (``0x4352`` instead of 42) and whose only
IFD holds the camera-profile tags of the DNG specification (chapter 6): ColorMatrix1/2,
ForwardMatrix1/2, CalibrationIlluminant1/2, ProfileHueSatMapDims/Data1/Data2/Encoding,
ProfileLookTableDims/Data/Encoding, ProfileToneCurve, ProfileName, UniqueCameraModel,
ProfileCopyright, ProfileEmbedPolicy, BaselineExposureOffset, DefaultBlackRender. The same tags in
IFD 0 of a DNG are the file's *embedded* profile; :func:`read_dcp` reads both.

Order of operations (DNG 1.6, chapter 6; Adobe DNG SDK ``dng_render``, ``RefBaselineHueSatMap``,
``RefBaselineRGBTone``), as :meth:`DCPProfile.apply` does it:

1. white-balanced camera RGB → XYZ D50 with the matrices interpolated in inverse CCT of the scene
   white (:class:`isp.dng.DNGProfile`, the white found from the camera neutral);
2. XYZ D50 → linear ProPhoto (ROMM) RGB;
3. ProfileHueSatMap (Data1 and Data2 blended with the matrices' CCT weight): a table of hue shift
   (degrees), saturation scale and value scale over (hue, saturation[, value]) in the SDK's HSV;
4. ProfileLookTable, the same operation with one table;
5. ProfileToneCurve on ProPhoto RGB with the SDK's hue-preserving RGB tone operator;
6. back to XYZ D50 (the isp pipeline's connection space).

Departures from the SDK, all for scene-referred float data and matching RawTherapee's float
implementation (``rtengine/dcp.cc``): saturation is not clipped to 1 after the HueSatMap (it is
after the LookTable, as the SDK and RawTherapee do) and values above 1 are not pinned (except by
the tone curve, whose domain is [0, 1]; RawTherapee clips them to 1 whenever a LookTable or tone
curve is applied); a pixel with ``max(r, g, b) ≤ 0`` is left unchanged. The tone curve is
interpolated with a natural cubic spline through its points (the SDK's ``dng_spline_solver``).
BaselineExposureOffset is read and kept but not applied: exposure is the pipeline's tone-mapping
stage's business.

References
----------
.. [1] Adobe (2021). Digital Negative (DNG) Specification 1.6.0.0, chapter 6 and the camera
   profile tags of chapter 4 (pp. 60–71).
.. [2] Adobe DNG SDK 1.6, ``dng_reference.cpp`` (``RefBaselineHueSatMap``, ``RefBaselineRGBTone``)
   and ``dng_utils.h`` (``DNG_RGBtoHSV``, ``DNG_HSVtoRGB``).
"""

from __future__ import annotations

import logging
import os
import warnings
import weakref
from dataclasses import dataclass, field, replace
from pathlib import Path

import colour
import numpy as np

from .._config import float_array
from .._errors import InputFileNotFoundError, RawFormatError
from .._tol import NEUTRAL_XY_STEP
from ..dng import (
    LIGHT_SOURCE_CCT,
    D50_xy,
    DNGProfile,
    camera_neutral_to_xy,
    matrix_interpolated,
    xy_to_CCT_DNG,
)

__all__ = [
    "DCP_TAGS",
    "DCPError",
    "DCPProfile",
    "apply_hue_sat_map",
    "apply_tone_curve",
    "dcp_stage",
    "profile_pipeline",
    "read_dcp",
    "write_dcp",
]

#: Camera-profile tag codes (DNG 1.6, chapter 4).
DCP_TAGS: dict[str, int] = {
    "UniqueCameraModel": 50708,
    "ColorMatrix1": 50721,
    "ColorMatrix2": 50722,
    "CalibrationIlluminant1": 50778,
    "CalibrationIlluminant2": 50779,
    "ProfileCalibrationSignature": 50932,
    "ProfileName": 50936,
    "ProfileHueSatMapDims": 50937,
    "ProfileHueSatMapData1": 50938,
    "ProfileHueSatMapData2": 50939,
    "ProfileToneCurve": 50940,
    "ProfileEmbedPolicy": 50941,
    "ProfileCopyright": 50942,
    "ForwardMatrix1": 50964,
    "ForwardMatrix2": 50965,
    "ProfileLookTableDims": 50981,
    "ProfileLookTableData": 50982,
    "ProfileHueSatMapEncoding": 51107,
    "ProfileLookTableEncoding": 51108,
    "BaselineExposureOffset": 51109,
    "DefaultBlackRender": 51110,
}
_NAMES = {code: name for name, code in DCP_TAGS.items()}

#: ProPhoto (ROMM) RGB, the space of the profile tables (white D50).
_PROPHOTO = colour.RGB_COLOURSPACES["ProPhoto RGB"]
PROPHOTO_FROM_XYZ = np.asarray(_PROPHOTO.matrix_XYZ_to_RGB, dtype=np.float64)
XYZ_FROM_PROPHOTO = np.asarray(_PROPHOTO.matrix_RGB_to_XYZ, dtype=np.float64)


class DCPError(RawFormatError):
    """A camera profile that is malformed (missing or inconsistent tags) or cannot be written."""


# ---------------------------------------------------------------------------------------------
# The profile
# ---------------------------------------------------------------------------------------------


def _table(data, dims, name: str) -> np.ndarray | None:
    if data is None:
        return None
    a = np.asarray(data, dtype=np.float64)
    H, S, V = (int(d) for d in dims)
    if a.shape == (V, H, S, 3):
        pass
    elif a.size == H * S * V * 3:
        a = a.reshape(V, H, S, 3)
    else:
        raise DCPError(
            f"{name}: {a.size} values do not fit the dimensions (hue {H}, saturation {S}, "
            f"value {V}) × 3 = {H * S * V * 3}; the profile is truncated or its Dims tag wrong."
        )
    if not np.all(np.isfinite(a)):
        raise DCPError(f"{name}: contains NaN or inf.")
    return a


def _dims(value, name: str):
    if value is None:
        return None
    d = np.asarray(value).astype(np.int64).ravel()
    if d.shape != (3,) or d[0] < 1 or d[1] < 2 or d[2] < 1:
        raise DCPError(f"{name}: expected (hue ≥ 1, saturation ≥ 2, value ≥ 1) divisions, got {d.tolist()}.")
    return tuple(int(x) for x in d)


@dataclass(frozen=True, eq=False)
class DCPProfile:
    """A DNG camera profile (the tags of a ``.dcp`` file or of a DNG's IFD 0).

    Attributes
    ----------
    color_matrix_1, color_matrix_2 : ndarray of shape (3, 3) or None
        XYZ → reference camera under the calibration illuminants. ColorMatrix1 is required.
    forward_matrix_1, forward_matrix_2 : ndarray of shape (3, 3) or None
        White-balanced camera → XYZ D50.
    calibration_illuminant_1, calibration_illuminant_2 : int
        EXIF LightSource codes (17 = A, 21 = D65, 23 = D50; :data:`isp.dng.LIGHT_SOURCE_CCT`).
    hue_sat_map_1, hue_sat_map_2 : ndarray of shape (V, H, S, 3) or None
        ProfileHueSatMapData1/2: (hue shift in degrees, saturation scale, value scale) per node,
        ``V`` value, ``H`` hue and ``S`` saturation divisions (the tag's order: value slowest).
    hue_sat_map_encoding : int
        0 linear, 1 sRGB-encoded value axis (ProfileHueSatMapEncoding).
    look_table : ndarray of shape (V, H, S, 3) or None
    look_table_encoding : int
    tone_curve : ndarray of shape (N, 2) or None
        ProfileToneCurve points (x, y) in [0, 1], x increasing.
    profile_name, unique_camera_model, copyright, calibration_signature : str
    embed_policy : int
        0 allow copying, 1 embed if used, 2 never embed, 3 no restrictions.
    baseline_exposure_offset : float
    default_black_render : int
        0 auto, 1 none.
    """

    color_matrix_1: np.ndarray | None
    color_matrix_2: np.ndarray | None = None
    forward_matrix_1: np.ndarray | None = None
    forward_matrix_2: np.ndarray | None = None
    calibration_illuminant_1: int = 0
    calibration_illuminant_2: int = 0
    hue_sat_map_1: np.ndarray | None = field(default=None, repr=False)
    hue_sat_map_2: np.ndarray | None = field(default=None, repr=False)
    hue_sat_map_encoding: int = 0
    look_table: np.ndarray | None = field(default=None, repr=False)
    look_table_encoding: int = 0
    tone_curve: np.ndarray | None = field(default=None, repr=False)
    profile_name: str = ""
    unique_camera_model: str = ""
    copyright: str = ""
    calibration_signature: str = ""
    embed_policy: int = 0
    baseline_exposure_offset: float = 0.0
    default_black_render: int = 0

    def __post_init__(self) -> None:
        try:
            # the matrix checks of DNGProfile (9 finite values each, ColorMatrix present)
            DNGProfile(
                self.color_matrix_1,
                self.color_matrix_2,
                forward_matrix_1=self.forward_matrix_1,
                forward_matrix_2=self.forward_matrix_2,
            )
        except RawFormatError as exc:
            raise DCPError(f"camera profile: {exc}") from exc
        if self.color_matrix_1 is None:
            raise DCPError("camera profile: ColorMatrix1 is missing (the DNG specification requires it).")
        for name in ("color_matrix_1", "color_matrix_2", "forward_matrix_1", "forward_matrix_2"):
            m = getattr(self, name)
            if m is not None:
                m = float_array(m, name, DCPError)
                if m.size != 9 or not np.all(np.isfinite(m)):
                    raise DCPError(f"{name}: expected a finite 3 × 3 matrix, got shape {m.shape}.")
                object.__setattr__(self, name, m.reshape(3, 3))
        for name in ("hue_sat_map_1", "hue_sat_map_2", "look_table"):
            t = getattr(self, name)
            if t is not None:
                t = float_array(t, name, DCPError)
                if t.ndim != 4 or t.shape[-1] != 3 or t.shape[2] < 2 or not np.all(np.isfinite(t)):
                    raise DCPError(f"{name}: expected a finite (V, H, S ≥ 2, 3) table, got shape {t.shape}.")
                object.__setattr__(self, name, t)
        h1, h2 = self.hue_sat_map_1, self.hue_sat_map_2
        if h1 is not None and h2 is not None and h1.shape != h2.shape:
            raise DCPError(f"ProfileHueSatMapData1 {h1.shape} and Data2 {h2.shape} differ in size.")
        for name in ("hue_sat_map_encoding", "look_table_encoding"):
            if getattr(self, name) not in (0, 1):
                raise DCPError(f"{name}={getattr(self, name)}: must be 0 (linear) or 1 (sRGB).")
        if self.tone_curve is not None:
            tc = float_array(self.tone_curve, "tone_curve", DCPError)
            if tc.size % 2:
                raise DCPError(f"tone_curve: expected (x, y) pairs, got {tc.size} values.")
            tc = tc.reshape(-1, 2)
            if (
                tc.shape[0] < 2
                or not np.all(np.isfinite(tc))
                or np.any(np.diff(tc[:, 0]) <= 0)
                or tc.min() < 0
                or tc.max() > 1
            ):
                raise DCPError("ProfileToneCurve: expected ≥ 2 points (x, y) in [0, 1] with increasing x.")
            object.__setattr__(self, "tone_curve", tc)

    # -- construction --------------------------------------------------------------------------
    @classmethod
    def from_tags(cls, tags: dict) -> DCPProfile:
        """Build a profile from a tag-name → value dict (the values :func:`read_dcp` decodes)."""
        g = tags.get
        hsm_dims = _dims(g("ProfileHueSatMapDims"), "ProfileHueSatMapDims")
        lut_dims = _dims(g("ProfileLookTableDims"), "ProfileLookTableDims")
        for data, dims, dname in (
            ("ProfileHueSatMapData1", hsm_dims, "ProfileHueSatMapDims"),
            ("ProfileHueSatMapData2", hsm_dims, "ProfileHueSatMapDims"),
            ("ProfileLookTableData", lut_dims, "ProfileLookTableDims"),
        ):
            if g(data) is not None and dims is None:
                raise DCPError(f"{data} is present but {dname} is missing.")
        tc = g("ProfileToneCurve")
        return cls(
            color_matrix_1=g("ColorMatrix1"),
            color_matrix_2=g("ColorMatrix2"),
            forward_matrix_1=g("ForwardMatrix1"),
            forward_matrix_2=g("ForwardMatrix2"),
            calibration_illuminant_1=int(g("CalibrationIlluminant1", 0) or 0),
            calibration_illuminant_2=int(g("CalibrationIlluminant2", 0) or 0),
            hue_sat_map_1=_table(g("ProfileHueSatMapData1"), hsm_dims or (1, 2, 1), "ProfileHueSatMapData1"),
            hue_sat_map_2=_table(g("ProfileHueSatMapData2"), hsm_dims or (1, 2, 1), "ProfileHueSatMapData2"),
            hue_sat_map_encoding=int(g("ProfileHueSatMapEncoding", 0) or 0),
            look_table=_table(g("ProfileLookTableData"), lut_dims or (1, 2, 1), "ProfileLookTableData"),
            look_table_encoding=int(g("ProfileLookTableEncoding", 0) or 0),
            tone_curve=None if tc is None else np.asarray(tc, dtype=np.float64).reshape(-1, 2),
            profile_name=str(g("ProfileName", "") or ""),
            unique_camera_model=str(g("UniqueCameraModel", "") or ""),
            copyright=str(g("ProfileCopyright", "") or ""),
            calibration_signature=str(g("ProfileCalibrationSignature", "") or ""),
            embed_policy=int(g("ProfileEmbedPolicy", 0) or 0),
            baseline_exposure_offset=float(g("BaselineExposureOffset", 0.0) or 0.0),
            default_black_render=int(g("DefaultBlackRender", 0) or 0),
        )

    def with_options(self, **changes) -> DCPProfile:
        """A copy with some attributes changed (e.g. ``tone_curve=None``)."""
        return replace(self, **changes)

    # -- colour maths --------------------------------------------------------------------------
    def dng_profile(self, analog_balance=None) -> DNGProfile:
        """The matrix part as an :class:`isp.dng.DNGProfile` (camera calibration = identity)."""
        return DNGProfile(
            self.color_matrix_1,
            self.color_matrix_2,
            calibration_illuminant_1=self.calibration_illuminant_1,
            calibration_illuminant_2=self.calibration_illuminant_2,
            forward_matrix_1=self.forward_matrix_1,
            forward_matrix_2=self.forward_matrix_2,
            analog_balance=analog_balance,
        )

    def _weight_pair(self, a, b, CCT: float):
        if a is None or b is None:
            return a if b is None else b
        t1 = LIGHT_SOURCE_CCT.get(self.calibration_illuminant_1)
        t2 = LIGHT_SOURCE_CCT.get(self.calibration_illuminant_2)
        if t1 is None or t2 is None:
            return b
        return matrix_interpolated(CCT, t1, t2, a, b)

    def hue_sat_map(self, neutral, *, analog_balance=None) -> np.ndarray | None:
        """ProfileHueSatMapData1/2 blended for the scene white given by the camera ``neutral``."""
        if self.hue_sat_map_1 is None and self.hue_sat_map_2 is None:
            return None
        xy = white_xy(neutral, self.dng_profile(analog_balance))
        return self._weight_pair(self.hue_sat_map_1, self.hue_sat_map_2, xy_to_CCT_DNG(xy))

    def XYZ_from_balanced(self, neutral, *, analog_balance=None) -> np.ndarray:
        """The 3 × 3 matrix white-balanced camera RGB → XYZ D50 (step 1; white → Y = 1)."""
        dp = self.dng_profile(analog_balance)
        n = np.asarray(neutral, dtype=np.float64).reshape(-1)
        n = n / n.max()
        xy = white_xy(n, dp)
        CCT = xy_to_CCT_DNG(xy)
        FM = dp._pair(dp.forward_matrix_1, dp.forward_matrix_2, CCT, None)
        if FM is None:
            M = np.linalg.inv(dp.XYZ_to_camera(xy))
            M = (
                colour.adaptation.matrix_chromatic_adaptation_VonKries(
                    colour.xy_to_XYZ(xy), colour.xy_to_XYZ(D50_xy), transform="Bradford"
                )
                @ M
            )
        else:
            AB_inv = np.diag(1.0 / dp.analog_balance)
            M = FM @ np.diag(1.0 / (AB_inv @ n)) @ AB_inv
        M = M @ np.diag(n)
        return M / (M @ np.ones(3))[1]

    def apply(
        self, balanced, neutral, *, analog_balance=None, tables: bool = True, tone_curve: bool = True
    ) -> np.ndarray:
        """White-balanced camera RGB → XYZ D50 through the whole profile (steps 1–6 above).

        Parameters
        ----------
        balanced : array_like of shape (..., 3)
            Camera RGB divided by the camera neutral (the scene white → (1, 1, 1)).
        neutral : array_like of shape (3,)
            The camera neutral (AsShotNeutral), which sets the CCT of the interpolation.
        analog_balance : array_like of shape (3,), optional
            The DNG's AnalogBalance (default ones).
        tables, tone_curve
            Apply the HueSatMap/LookTable and the tone curve (both default True).

        Returns
        -------
        ndarray of shape (..., 3)
            XYZ D50, the scene white at Y = 1.
        """
        c = np.asarray(balanced, dtype=np.float64)
        if c.shape[-1:] != (3,):
            raise DCPError(f"balanced: last axis must hold 3 camera channels, got shape {c.shape}.")
        XYZ = c @ self.XYZ_from_balanced(neutral, analog_balance=analog_balance).T
        hsm = self.hue_sat_map(neutral, analog_balance=analog_balance) if tables else None
        lut = self.look_table if tables else None
        curve = self.tone_curve if tone_curve else None
        if hsm is None and lut is None and curve is None:
            return XYZ
        rgb = XYZ @ PROPHOTO_FROM_XYZ.T
        if hsm is not None:
            rgb = apply_hue_sat_map(rgb, hsm, encoding=self.hue_sat_map_encoding)
        if lut is not None:
            rgb = apply_hue_sat_map(rgb, lut, encoding=self.look_table_encoding, clip_saturation=True)
        if curve is not None:
            rgb = apply_tone_curve(rgb, curve)
        return rgb @ XYZ_FROM_PROPHOTO.T


def white_xy(neutral, profile: DNGProfile) -> np.ndarray:
    """Scene-white chromaticity from the camera neutral, as the DNG SDK finds it.

    :func:`isp.dng.camera_neutral_to_xy` (fixed point to 1e-10); when that does not converge (a
    two-value oscillation, e.g. RawTherapee's ``samsung SM-G930V.dcp``) the SDK's rule: 30 passes,
    then the mean of the last two estimates (``dng_color_spec::NeutralToXY``).
    """
    try:
        return camera_neutral_to_xy(neutral, profile)
    except RawFormatError as exc:
        if "did not converge" not in str(exc):
            raise
    n = np.asarray(neutral, dtype=np.float64).reshape(-1)
    last = D50_xy.copy()
    for i in range(30):
        nxt = colour.XYZ_to_xy(np.linalg.solve(profile.XYZ_to_camera(last), n))
        if np.abs(nxt - last).sum() < NEUTRAL_XY_STEP:
            return nxt
        if i == 29:
            nxt = 0.5 * (nxt + last)
        last = nxt
    return last


# ---------------------------------------------------------------------------------------------
# HSV tables and tone curve (DNG SDK reference code, vectorised)
# ---------------------------------------------------------------------------------------------


def _rgb_to_hsv(rgb: np.ndarray):
    r, g, b = rgb[..., 0], rgb[..., 1], rgb[..., 2]
    v = np.max(rgb, axis=-1)
    gap = v - np.min(rgb, axis=-1)
    ok = (gap > 0) & (v > 0)
    safe = np.where(ok, gap, 1.0)
    h = np.where(r == v, (g - b) / safe, np.where(g == v, 2.0 + (b - r) / safe, 4.0 + (r - g) / safe))
    h = np.where(h < 0, h + 6.0, h)
    h = np.where(ok, h, 0.0)
    s = np.where(ok, gap / np.where(v > 0, v, 1.0), 0.0)
    return h, s, v


def _hsv_to_rgb(h, s, v) -> np.ndarray:
    h = np.mod(h, 6.0)
    i = np.minimum(np.floor(h).astype(np.int64), 5)
    f = h - i
    p, q, t = v * (1 - s), v * (1 - s * f), v * (1 - s * (1 - f))
    r = np.choose(i, [v, q, p, p, t, v])
    g = np.choose(i, [t, v, v, q, p, p])
    b = np.choose(i, [p, p, t, v, v, q])
    out = np.stack([r, g, b], axis=-1)
    grey = s <= 0
    return np.where(grey[..., None], v[..., None], out)


def _srgb_encode(x):
    return colour.models.eotf_inverse_sRGB(np.clip(x, 0.0, 1.0))


def apply_hue_sat_map(rgb, table, *, encoding: int = 0, clip_saturation: bool = False) -> np.ndarray:
    """Apply a ProfileHueSatMap or ProfileLookTable to linear ProPhoto RGB (DNG SDK order).

    Parameters
    ----------
    rgb : array_like of shape (..., 3)
        Linear ProPhoto RGB.
    table : array_like of shape (V, H, S, 3)
        (hue shift °, saturation scale, value scale) per node; hue nodes at ``i · 360° / H``
        (wrapping), saturation nodes at ``j / (S − 1)``, value nodes at ``k / (V − 1)`` of the
        (encoded) value.
    encoding
        0: the value axis is linear; 1: it is sRGB-encoded (the value scale then applies to the
        encoded value).
    clip_saturation
        Clip the new saturation to 1 (the SDK does for both tables, RawTherapee for the
        LookTable; a saturation above 1 is a negative ProPhoto component).

    Returns
    -------
    ndarray of shape (..., 3)
    """
    x = float_array(rgb, "rgb")
    if x.ndim < 1 or x.shape[-1] != 3:
        raise DCPError(f"rgb: expected linear ProPhoto RGB of shape (..., 3), got {x.shape}.")
    T = float_array(table, "table", DCPError)
    if T.ndim != 4 or T.shape[-1] != 3 or T.shape[2] < 2:
        raise DCPError(f"table: expected a (V, H, S ≥ 2, 3) HueSatMap/LookTable, got shape {T.shape}.")
    V, H, S, _ = T.shape
    h, s, v = _rgb_to_hsv(x)
    hs = h * (H / 6.0)
    h0 = np.floor(hs).astype(np.int64)
    h0 = np.clip(h0, 0, H - 1)
    h1 = np.where(h0 >= H - 1, 0, h0 + 1)
    fh = hs - h0
    ss = s * (S - 1)
    s0 = np.clip(np.floor(ss).astype(np.int64), 0, S - 2)
    fs = ss - s0
    v_enc = _srgb_encode(v) if encoding == 1 else v
    if V > 1:
        vs = v_enc * (V - 1)
        v0 = np.clip(np.floor(vs).astype(np.int64), 0, V - 2)
        fv = vs - v0
        corners = [(v0, 1.0 - fv), (v0 + 1, fv)]
    else:
        corners = [(np.zeros_like(h0), np.ones_like(hs))]
    mod = 0.0
    for vi, wv in corners:
        for hi, wh in ((h0, 1.0 - fh), (h1, fh)):
            for si, ws in ((s0, 1.0 - fs), (s0 + 1, fs)):
                mod = mod + (wv * wh * ws)[..., None] * T[vi, hi, si]
    h_new = h + mod[..., 0] * (6.0 / 360.0)
    s_new = s * mod[..., 1]
    if clip_saturation:
        s_new = np.minimum(s_new, 1.0)
    if encoding == 1:
        v_new = colour.models.eotf_sRGB(np.clip(v_enc * mod[..., 2], 0.0, 1.0))
        v_new = np.where(v > 1, v * mod[..., 2], v_new)  # above the encoding's range: linear
    else:
        v_new = v * mod[..., 2]
    out = _hsv_to_rgb(h_new, s_new, v_new)
    return np.where((v > 0)[..., None], out, x)


def apply_tone_curve(rgb, curve) -> np.ndarray:
    """The SDK's hue-preserving RGB tone operator (``RefBaselineRGBTone``) with a tone curve.

    The largest and smallest channel go through the curve; the middle one keeps its relative
    position between them. Input is clipped to [0, 1], the curve's domain.

    Parameters
    ----------
    rgb : array_like of shape (..., 3)
    curve : array_like of shape (N, 2)
        (x, y) points, natural cubic spline between them.

    Returns
    -------
    ndarray of shape (..., 3)
    """
    from scipy.interpolate import CubicSpline

    pts = float_array(curve, "curve", DCPError)
    if pts.ndim != 2 or pts.shape[1] != 2 or pts.shape[0] < 2:
        raise DCPError(f"curve: expected (x, y) pairs of shape (M ≥ 2, 2), got {pts.shape}.")
    x = np.clip(float_array(rgb, "rgb"), 0.0, 1.0)
    f = (
        CubicSpline(pts[:, 0], pts[:, 1], bc_type="natural")
        if len(pts) > 2
        else (lambda t: np.interp(t, pts[:, 0], pts[:, 1]))
    )
    order = np.argsort(-x, axis=-1, kind="stable")
    srt = np.take_along_axis(x, order, axis=-1)
    hi, mid, lo = srt[..., 0], srt[..., 1], srt[..., 2]
    thi, tlo = np.clip(f(hi), 0, 1), np.clip(f(lo), 0, 1)
    span = hi - lo
    tmid = np.where(span > 0, tlo + (thi - tlo) * (mid - lo) / np.where(span > 0, span, 1.0), f(mid))
    out_sorted = np.stack([thi, tmid, tlo], axis=-1)
    out = np.empty_like(out_sorted)
    np.put_along_axis(out, order, out_sorted, axis=-1)
    return out


# ---------------------------------------------------------------------------------------------
# File I/O (tifffile)
# ---------------------------------------------------------------------------------------------


def _decode(tag):
    value = tag.value
    dtype = int(tag.dtype)
    if dtype in (5, 10):  # (S)RATIONAL
        v = np.asarray(value, dtype=np.float64).reshape(-1, 2)
        with np.errstate(divide="ignore", invalid="ignore"):
            out = np.where(v[:, 1] != 0, v[:, 0] / np.where(v[:, 1] != 0, v[:, 1], 1), 0.0)
        return float(out[0]) if out.size == 1 else out
    if isinstance(value, bytes):
        return value.decode("latin-1").rstrip("\x00")
    if isinstance(value, np.ndarray | tuple | list):
        return np.asarray(value, dtype=np.float64)
    return value


def read_dcp(path: str | os.PathLike) -> DCPProfile:
    """Read a DCP file, or the embedded camera profile of a DNG (its IFD 0 tags).

    Parameters
    ----------
    path
        A ``.dcp`` file (magic ``IIRC``/``MMCR``) or a DNG.

    Returns
    -------
    DCPProfile

    Raises
    ------
    DCPError
        Not a TIFF/DCP file, or tags missing or inconsistent (e.g. table data that does not fit
        its Dims tag, no ColorMatrix1).
    InputFileNotFoundError
        ``path`` does not exist (a ``FileNotFoundError`` too).
    """
    import tifffile

    path = Path(path)
    if not path.is_file():
        raise InputFileNotFoundError(f"camera profile {path} not found.")
    head = path.read_bytes()[:4]
    if head not in (b"IIRC", b"MMCR", b"II*\x00", b"MM\x00*"):
        raise DCPError(f"{path}: not a DNG camera profile (header {head!r}; a .dcp starts with b'IIRC').")
    log = logging.getLogger("tifffile")
    level = log.level
    log.setLevel(logging.CRITICAL)  # a DCP has no image data: tifffile logs "missing data offset"
    try:
        with tifffile.TiffFile(path) as tif:
            tags = {_NAMES[t.code]: _decode(t) for t in tif.pages[0].tags.values() if t.code in _NAMES}
    except (tifffile.TiffFileError, OSError, ValueError, IndexError, KeyError, struct_error()) as exc:
        raise DCPError(f"{path}: cannot read the camera profile ({type(exc).__name__}: {exc}).") from exc
    finally:
        log.setLevel(level)
    if "ColorMatrix1" not in tags:
        raise DCPError(
            f"{path}: no ColorMatrix1 tag, so this is not a camera profile (a DCP or a DNG "
            "with an embedded profile needs at least ColorMatrix1)."
        )
    try:
        return DCPProfile.from_tags(tags)
    except DCPError as exc:
        raise DCPError(f"{path}: {exc}") from exc


def struct_error():
    import struct

    return struct.error


def _srational(m, denominator: int = 10000) -> tuple[int, ...]:
    out: list[int] = []
    for v in np.asarray(m, dtype=np.float64).ravel():
        out += [round(float(v) * denominator), denominator]
    return tuple(out)


def _ascii(s: str, name: str) -> str:
    try:
        s.encode("ascii")
    except UnicodeEncodeError as exc:
        raise DCPError(f"{name}={s!r}: DCP text tags are ASCII; remove the non-ASCII characters.") from exc
    return s


def write_dcp(path: str | os.PathLike, profile: DCPProfile, *, overwrite: bool = False) -> Path:
    """Write a profile as a ``.dcp`` file (atomically: temporary file, then rename).

    tifffile writes the tags (with an empty image, which every DCP reader ignores); the TIFF magic
    42 is then replaced by the DCP magic ``RC``. Matrices are stored as SRATIONAL with denominator
    10000 (as Adobe's profiles), tables as FLOAT.

    Parameters
    ----------
    path
        Output ``.dcp`` file.
    profile
        The profile.
    overwrite
        Replace an existing file.

    Returns
    -------
    Path

    Raises
    ------
    DCPError
        ``path`` exists (and not ``overwrite``), or a text tag is not ASCII.
    """
    import tifffile

    if not isinstance(profile, DCPProfile):
        raise DCPError(f"profile: expected an isp.DCPProfile; got {type(profile).__name__}.")
    path = Path(path)
    if path.exists() and not overwrite:
        raise DCPError(f"{path} exists; pass overwrite=True (--overwrite) or choose another name.")
    p = profile
    tags: list[tuple] = [
        (50708, "s", 0, _ascii(p.unique_camera_model or "unknown", "unique_camera_model"), True)
    ]
    tags.append((50721, 10, 9, _srational(p.color_matrix_1), True))
    if p.color_matrix_2 is not None:
        tags.append((50722, 10, 9, _srational(p.color_matrix_2), True))
    tags.append((50778, "H", 1, int(p.calibration_illuminant_1), True))
    if p.color_matrix_2 is not None:
        tags.append((50779, "H", 1, int(p.calibration_illuminant_2), True))
    if p.calibration_signature:
        tags.append((50932, "s", 0, _ascii(p.calibration_signature, "calibration_signature"), True))
    tags.append((50936, "s", 0, _ascii(p.profile_name or "profile", "profile_name"), True))
    hsm = [t for t in (p.hue_sat_map_1, p.hue_sat_map_2) if t is not None]
    if hsm:
        V, H, S, _ = hsm[0].shape
        tags.append((50937, "I", 3, (H, S, V), True))
        for code, t in ((50938, p.hue_sat_map_1), (50939, p.hue_sat_map_2)):
            if t is not None:
                tags.append((code, "f", t.size, tuple(np.asarray(t, np.float32).ravel().tolist()), True))
    if p.tone_curve is not None:
        tags.append(
            (50940, "f", p.tone_curve.size, tuple(p.tone_curve.astype(np.float32).ravel().tolist()), True)
        )
    tags.append((50941, "I", 1, int(p.embed_policy), True))
    tags.append((50942, "s", 0, _ascii(p.copyright or "", "copyright") or " ", True))
    for code, m in ((50964, p.forward_matrix_1), (50965, p.forward_matrix_2)):
        if m is not None:
            tags.append((code, 10, 9, _srational(m), True))
    if p.look_table is not None:
        V, H, S, _ = p.look_table.shape
        tags.append((50981, "I", 3, (H, S, V), True))
        tags.append(
            (
                50982,
                "f",
                p.look_table.size,
                tuple(np.asarray(p.look_table, np.float32).ravel().tolist()),
                True,
            )
        )
    if hsm:
        tags.append((51107, "I", 1, int(p.hue_sat_map_encoding), True))
    if p.look_table is not None:
        tags.append((51108, "I", 1, int(p.look_table_encoding), True))
    if p.baseline_exposure_offset:
        tags.append((51109, 10, 1, _srational([p.baseline_exposure_offset], 1000), True))
    tags.append((51110, "I", 1, int(p.default_black_render), True))
    from zonotope.utilities import atomic_path

    def write(tmp: Path) -> None:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")  # "writing zero-size array": a DCP has no image
            tifffile.imwrite(
                tmp, shape=(0, 0), dtype=np.uint8, extratags=tags, metadata=None, software="zonotope profile"
            )
        with open(tmp, "r+b") as fh:
            fh.seek(2)
            fh.write(b"RC")

    atomic_path(path, write)  # temporary sibling, fsync, umask permissions, rename
    return path


# ---------------------------------------------------------------------------------------------
# Pipeline stage
# ---------------------------------------------------------------------------------------------


def dcp_stage(
    profile: DCPProfile | str | os.PathLike | None = None,
    *,
    tone_curve: bool = True,
    neutral=None,
    name: str = "camera_to_XYZ",
):
    """An :class:`isp.Stage` that applies a camera profile in place of the DNG ColorMatrix stage.

    Parameters
    ----------
    profile
        A :class:`DCPProfile`, a ``.dcp`` path, or None for the DNG's own embedded profile (its
        IFD 0 tags, read when the stage runs; files without tables give the matrix path exactly).
    tone_curve
        Apply the profile's ProfileToneCurve (default True; the pipeline's tone mapping comes after).
    neutral : callable, optional
        ``neutral(raw) -> (3,)``: the camera neutral the pipeline white-balanced with (default the
        file's AsShotNeutral); it sets the CCT of the interpolation.
    name
        Stage name (default replaces ``"camera_to_XYZ"``).

    Returns
    -------
    isp.Stage
        Input: white-balanced camera RGB (H, W, 3); output: XYZ D50 (white Y = 1). Per pixel
        (``reach=0``): a pipeline runs it strip by strip, the profile and neutral read once per image.
    """
    from ..pipeline import Stage

    prof = read_dcp(profile) if isinstance(profile, str | os.PathLike) else profile
    cache: list = []  # (weakref to the RawImage, profile, neutral) of the image being developed

    def fn(x, raw):
        if not cache or cache[0]() is not raw:
            p = prof
            if p is None:
                if raw.path is None:
                    raise DCPError("the embedded profile needs the DNG file (RawImage.path is None).")
                p = read_dcp(raw.path)
            n = raw.as_shot_neutral if neutral is None else neutral(raw)
            cache[:] = weakref.ref(raw), p, n
        _, p, n = cache
        return p.apply(x, n, analog_balance=raw.profile.analog_balance, tone_curve=tone_curve)

    return Stage(name, fn, reach=0)


def profile_pipeline(pipeline, profile, *, white_balance="as-shot"):
    """``pipeline`` with its ``camera_to_XYZ`` stage replaced by :func:`dcp_stage` of ``profile``.

    Parameters
    ----------
    pipeline : isp.Pipeline
        A pipeline with a ``camera_to_XYZ`` stage (e.g. :func:`isp.default_pipeline`).
    profile : str or path
        A ``.dcp`` file, or ``"embedded"`` for the DNG's own profile tags.
    white_balance
        As in :func:`isp.default_pipeline`; other than as-shot, the profile's matrices are
        interpolated for that white (the DNG spec's rule).
    """
    wb = white_balance
    neutral = None
    if wb and str(wb).lower() not in ("as-shot", "asshot", "as_shot"):
        from ..whitebalance import white_balance_neutral

        def neutral(raw):
            return white_balance_neutral(raw, wb)

    prof = None if str(profile).lower() == "embedded" else read_dcp(profile)
    return pipeline.replace("camera_to_XYZ", dcp_stage(prof, neutral=neutral))
