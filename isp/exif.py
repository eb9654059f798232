"""What a developed image carries besides pixels: the ICC profile of its colour space and the camera metadata.

:func:`srgb_icc_profile` gives the bytes of an sRGB ICC profile (LittleCMS's built-in sRGB, made
by Pillow's ``ImageCms``); :func:`output_tags` the TIFF tags copied from the RAW file (Make, Model,
date and time, exposure time, f-number, ISO). Pass both to :func:`isp.write_image`
(``icc_profile=``, ``tiff_tags=``). The image is written already rotated (the ``orient`` stage), so
the tags say Orientation 1.

>>> from isp.exif import srgb_icc_profile
>>> srgb_icc_profile()[36:40]  # the ICC signature
b'acsp'
"""

from __future__ import annotations

import functools

import numpy as np

from ._tol import EXPOSURE_NOMINAL
from .raw import RawImage

__all__ = ["output_tags", "srgb_icc_profile"]


@functools.cache
def srgb_icc_profile() -> bytes:
    """ICC v2 profile of sRGB (IEC 61966-2-1), as bytes to embed in an image file.

    Returns
    -------
    bytes
    """
    from PIL import ImageCms

    return ImageCms.ImageCmsProfile(ImageCms.createProfile("sRGB")).tobytes()


def _rational(v: float, exposure: bool = False) -> tuple[int, int]:
    v = float(v)
    if exposure and 0 < v < 1:
        if abs(1 / round(1 / v) - v) < EXPOSURE_NOMINAL * v:
            return (1, round(1 / v))  # 1/200 s, as cameras write it (nominal within 1 %)
        return (round(v * 1_000_000), 1_000_000)
    return (round(v * 10_000), 10_000)


def _ascii(s: str) -> str:
    return s.encode("ascii", "replace").decode("ascii")


def output_tags(raw: RawImage, *, orientation: int = 1) -> list[tuple]:
    """TIFF tags that copy the RAW file's camera metadata into a developed image.

    Parameters
    ----------
    raw
        The RAW image the output was developed from.
    orientation
        Orientation tag of the output (1: it is stored upright, as :func:`isp.default_pipeline`'s
        ``orient`` stage leaves it).

    Returns
    -------
    list of tuple
        tifffile ``extratags`` ``(code, dtype, count, value, writeonce)``: Make (271), Model (272),
        Orientation (274), DateTime (306) and DateTimeOriginal (36867), ExposureTime (33434),
        FNumber (33437), ISOSpeedRatings (34855); only those the RAW records.
    """
    tags: list[tuple] = [(274, "H", 1, int(orientation), True)]
    if raw.make:
        tags.append((271, "s", 0, _ascii(raw.make), True))
    if raw.model:
        tags.append((272, "s", 0, _ascii(raw.model), True))
    cap = raw.capture
    if "datetime" in cap:
        tags += [
            (306, "s", 0, _ascii(cap["datetime"])[:19], True),
            (36867, "s", 0, _ascii(cap["datetime"])[:19], True),
        ]
    if cap.get("exposure_time", 0) > 0:
        tags.append((33434, "2I", 1, _rational(cap["exposure_time"], exposure=True), True))
    if cap.get("f_number", 0) > 0:
        tags.append((33437, "2I", 1, _rational(cap["f_number"]), True))
    if cap.get("iso", 0) > 0:
        tags.append((34855, "H", 1, int(np.clip(cap["iso"], 1, 65535)), True))
    return tags
