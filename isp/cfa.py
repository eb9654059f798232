"""Bayer colour filter arrays: the supported 2 × 2 patterns, their check, and per-channel site masks.

Kept apart from reading (:mod:`isp.raw`), DNG tags (:mod:`isp.dng`) and the stages so that each of
them can check a pattern without importing the others.
"""

from __future__ import annotations

import numpy as np

from ._errors import RawFormatError

__all__ = ["CFA_PATTERNS", "CHANNEL_INDEX", "cfa_masks", "check_cfa"]

#: The 2 × 2 Bayer layouts the pipeline handles (top-left site first, row-major).
CFA_PATTERNS: tuple[str, ...] = ("RGGB", "BGGR", "GRBG", "GBRG")


#: Index of each CFA letter on the channel (last) axis of an RGB image.
CHANNEL_INDEX = {"R": 0, "G": 1, "B": 2}


def check_cfa(cfa: str) -> str:
    """Return ``cfa`` upper-cased, or raise :class:`RawFormatError` naming the valid patterns."""
    p = str(cfa).upper()
    if p not in CFA_PATTERNS:
        raise RawFormatError(
            f"cfa={cfa!r} is not a supported Bayer pattern; use one of {list(CFA_PATTERNS)}."
        )
    return p


def cfa_masks(shape: tuple[int, int], cfa: str) -> np.ndarray:
    """Boolean masks of the R, G, B sites of a Bayer pattern.

    Parameters
    ----------
    shape
        (H, W) of the mosaic.
    cfa
        2 × 2 pattern, e.g. ``"RGGB"``.

    Returns
    -------
    ndarray of shape (H, W, 3), bool
    """
    cfa = check_cfa(cfa)
    H, W = shape
    out = np.zeros((H, W, 3), dtype=bool)
    for k, letter in enumerate(cfa):
        i, j = divmod(k, 2)
        out[i::2, j::2, CHANNEL_INDEX[letter]] = True
    return out
