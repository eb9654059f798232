"""White balance choices: which camera neutral (the camera's response to the scene white) to develop with.

:func:`white_balance_neutral` turns a choice into a neutral for a :class:`~isp.raw.RawImage`:

* ``"as-shot"``: the file's (DNG AsShotNeutral / AsShotWhiteXY, or the camera's multipliers; for a
  file that records none, LibRaw's automatic grey-world white, :func:`isp.raw.auto_white_balance`);
* ``"daylight"``: a white of 5500 K on the Planckian locus, the DNG SDK's temperature of the EXIF
  light source "Daylight" (:data:`isp.dng.LIGHT_SOURCE_CCT`);
* ``"5000K"``: a colour temperature in kelvin on the Planckian locus (tint 0), placed with the
  inverse of Robertson's (1968) method, the same one that :func:`isp.dng.xy_to_CCT_DNG` reads
  temperatures with, as the DNG SDK does;
* a CIE illuminant name (``"D65"``, ``"A"``, ``"FL2"``, … any key of colour-science's CIE 1931
  2° ``CCS_ILLUMINANTS``): its chromaticity;
* ``"spot:x0,y0,x1,y1"``: the mean raw response of a grey patch, the rectangle of columns
  ``x0 ≤ x < x1`` and rows ``y0 ≤ y < y1`` of the *developed* image (after ``crop`` and the
  orientation, i.e. the pixel coordinates a viewer shows for the output file).

A chromaticity becomes a neutral with the DNG spec's ``XYZ_to_camera(xy) · XYZ(xy)``
(:func:`isp.dng.xy_to_camera_neutral`), so the file's colour matrices define what "5000 K" means
for this camera.

>>> from isp.whitebalance import white_balance_xy
>>> white_balance_xy("D65").round(4)
array([ 0.3127,  0.329 ])
"""

from __future__ import annotations

import re

import colour
import numpy as np

from ._errors import PipelineError
from .dng import LIGHT_SOURCE_CCT, xy_to_camera_neutral
from .raw import RawImage

__all__ = ["CCT_RANGE", "describe_white_balance", "white_balance_neutral", "white_balance_xy"]

#: Colour temperatures (K) accepted: Robertson's isotherm table starts at 600 mired (1667 K); above
#: 25 000 K the Planckian locus barely moves.
CCT_RANGE = (1667.0, 25000.0)

_ILLUMINANTS = colour.CCS_ILLUMINANTS["CIE 1931 2 Degree Standard Observer"]
_KELVIN = re.compile(r"^\s*([0-9]+(?:\.[0-9]*)?)\s*k\s*$", re.IGNORECASE)
_CHOICES = (
    "as-shot",
    "daylight",
    "spot:x0,y0,x1,y1",
    "<Kelvin>K (e.g. 5000K)",
    "a CIE illuminant name (D65, A, FL2, ...)",
)


def _key(s: str) -> str:
    return "".join(ch for ch in s.lower() if ch.isalnum())


def white_balance_xy(choice: str) -> np.ndarray:
    """Chromaticity (CIE 1931 2° xy) of a white balance given as a temperature or an illuminant.

    Parameters
    ----------
    choice
        ``"daylight"``, ``"<T>K"`` or a CIE illuminant name (case and punctuation ignored).

    Returns
    -------
    ndarray of shape (2,)

    Raises
    ------
    PipelineError
        A temperature outside :data:`CCT_RANGE`, or an unknown name.
    """
    text = str(choice).strip()
    if _key(text) == "daylight":
        text = f"{LIGHT_SOURCE_CCT[1]}K"
    m = _KELVIN.match(text)
    if m:
        T = float(m.group(1))
        if not CCT_RANGE[0] <= T <= CCT_RANGE[1]:
            raise PipelineError(
                f"white balance {choice!r}: the temperature must lie in {CCT_RANGE[0]:g}–{CCT_RANGE[1]:g} K."
            )
        uv = colour.temperature.CCT_to_uv_Robertson1968(np.array([T, 0.0]))
        return np.asarray(colour.UCS_uv_to_xy(uv), dtype=np.float64)
    for name, xy in _ILLUMINANTS.items():
        if _key(name) == _key(text) and _key(text):
            return np.asarray(xy, dtype=np.float64)
    raise PipelineError(
        f"white balance {choice!r} is not known; use one of: {', '.join(_CHOICES)}. "
        f"Illuminant names: {', '.join(list(_ILLUMINANTS)[:20])}, ..."
    )


def _spot(choice: str) -> tuple[int, int, int, int] | None:
    text = str(choice).strip()
    if not text.lower().startswith("spot"):
        return None
    body = text[4:].lstrip(":= ")
    try:
        x0, y0, x1, y1 = (int(v) for v in body.split(","))
    except ValueError:
        raise PipelineError(
            f"white balance {choice!r}: write spot:x0,y0,x1,y1 (integer pixel "
            "coordinates of a grey patch in the developed image, x1, y1 excluded)."
        ) from None
    if x1 <= x0 or y1 <= y0 or x0 < 0 or y0 < 0:
        raise PipelineError(f"white balance {choice!r}: need 0 ≤ x0 < x1 and 0 ≤ y0 < y1.")
    return x0, y0, x1, y1


def _spot_neutral(raw: RawImage, rect: tuple[int, int, int, int], choice: str) -> np.ndarray:
    from . import stages as st

    x0, y0, x1, y1 = rect
    H, W = raw.shape
    Ho, Wo = (H, W) if raw.orientation <= 4 else (W, H)
    if x1 > Wo or y1 > Ho:
        raise PipelineError(
            f"white balance {choice!r}: the patch reaches outside the developed image "
            f"({Wo} × {Ho} pixels, width × height)."
        )
    # the mosaic sites under the patch: orient the sites' (row, column) indices like the image
    rows, cols = (
        st.orient(np.indices((H, W), dtype=np.int32).transpose(1, 2, 0), raw.orientation)[y0:y1, x0:x1]
        .reshape(-1, 2)
        .T
    )
    table = None if raw.table_applied else raw.linearisation_table
    r0, r1, c0, c1 = rows.min(), rows.max() + 1, cols.min(), cols.max() + 1
    # linearise a CFA-aligned window around the patch (even origin keeps the black-level layout)
    wr, wc = r0 - r0 % 2, c0 - c0 % 2
    window = raw.mosaic[wr : r1 + (r1 - wr) % 2, wc : c1 + (c1 - wc) % 2]
    lin = st.linearise(
        window, black_level=raw.black_level, white_level=raw.white_level, table=table, clip=False
    )
    masks = st.cfa_masks(lin.shape, raw.cfa)
    sel = (slice(r0 - wr, r1 - wr), slice(c0 - wc, c1 - wc))
    patch, pm = lin[sel], masks[sel]
    if np.any(patch >= 1.0):
        raise PipelineError(
            f"white balance {choice!r}: {int(np.sum(patch >= 1))} pixel(s) of the patch are "
            "saturated; pick a darker grey patch."
        )
    counts = pm.sum(axis=(0, 1))
    if np.any(counts == 0):
        raise PipelineError(
            f"white balance {choice!r}: the patch holds no {'RGB'[int(np.argmin(counts))]} "
            "site; make it at least 2 × 2 pixels."
        )
    mean = np.array([patch[pm[..., k]].mean() for k in range(3)])
    if not np.all(mean > 0):
        raise PipelineError(
            f"white balance {choice!r}: the patch's mean response {mean} has a channel at "
            "or below black; pick a lit grey patch."
        )
    return mean / mean.max()


def white_balance_neutral(raw: RawImage, choice="as-shot") -> np.ndarray:
    """The camera neutral for a white-balance choice (see the module docstring), normalised to max 1.

    Parameters
    ----------
    raw
        The RAW image (its profile turns chromaticities into neutrals; its mosaic gives spot values).
    choice
        ``"as-shot"``, ``"daylight"``, ``"<T>K"``, an illuminant name, ``"spot:x0,y0,x1,y1"``, or a
        camera neutral (3 positive values).

    Returns
    -------
    ndarray of shape (3,)

    Raises
    ------
    PipelineError
        An unknown choice, a temperature out of range, a spot outside the image, saturated or black.
    RawFormatError
        A chromaticity the camera's colour matrix cannot see as a white.
    """
    if not isinstance(choice, str):
        n = np.asarray(choice, dtype=np.float64).reshape(-1)
        if n.shape != (3,) or not np.all(np.isfinite(n)) or np.any(n <= 0):
            raise PipelineError(f"white balance neutral {choice!r}: expected 3 positive finite values.")
        return n / n.max()
    if _key(choice) in ("asshot", "camera", ""):
        return np.asarray(raw.as_shot_neutral, dtype=np.float64)
    rect = _spot(choice)
    if rect is not None:
        return _spot_neutral(raw, rect, choice)
    return xy_to_camera_neutral(white_balance_xy(choice), raw.profile)


def describe_white_balance(raw: RawImage, choice="as-shot") -> str:
    """A one-line account of the white balance used (for CLIs and logs)."""
    if isinstance(choice, str) and _key(choice) in ("asshot", "camera", ""):
        return {
            "AsShotNeutral": "as shot (DNG AsShotNeutral)",
            "AsShotWhiteXY": "as shot (DNG AsShotWhiteXY)",
            "camera": "as shot (the camera's multipliers)",
            "auto": "automatic (grey world over unclipped 8×8 blocks, as LibRaw's camera/auto white balance; "
            "the file records no as-shot white)",
            "daylight": "daylight multipliers of LibRaw (the file records no as-shot white balance)",
            "none": "unit gains (the file records no white balance)",
        }.get(raw.white_balance_source, raw.white_balance_source)
    if isinstance(choice, str) and _spot(choice) is not None:
        return f"grey patch {choice.strip()[4:].lstrip(':= ')} (x0,y0,x1,y1)"
    if isinstance(choice, str):
        xy = white_balance_xy(choice)
        return f"{choice.strip()} (xy {xy[0]:.4f}, {xy[1]:.4f})"
    return f"neutral {np.round(np.asarray(choice, dtype=float), 4).tolist()}"
