"""Errors raised on purpose by ``splat`` (part of the project's one exception hierarchy)."""

from __future__ import annotations

from zonotope._errors import ZonotopeError

__all__ = ["DataFormatError", "SplatError"]


class SplatError(ZonotopeError, ValueError):
    """Arguments that ``splat`` cannot use: wrong shapes, unknown methods, inconsistent views, ..."""


class DataFormatError(SplatError):
    """A COLMAP model or ``transforms.json`` file that cannot be read (names the file and the line)."""
