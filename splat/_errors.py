"""Errors raised on purpose by ``splat`` (part of the project's one exception hierarchy)."""

from __future__ import annotations

from zonotope import UnknownMethodError, ZonotopeError

__all__ = ["DataFormatError", "SplatError", "SplatMethodError"]


class SplatError(ZonotopeError, ValueError):
    """Arguments that ``splat`` cannot use: wrong shapes, unknown methods, inconsistent views, ..."""


class DataFormatError(SplatError):
    """A COLMAP model or ``transforms.json`` file that cannot be read (names the file and the line)."""


class SplatMethodError(SplatError, UnknownMethodError):
    """An unknown ``method=`` name of a ``splat`` registry (rendering); the message lists the valid names."""
