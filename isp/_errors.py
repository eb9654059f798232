"""Exceptions of the ``isp`` package (part of the project's one hierarchy under ``ZonotopeError``)."""

from __future__ import annotations

from zonotope import UnknownMethodError, ZonotopeError

__all__ = ["InputFileNotFoundError", "PipelineError", "PipelineMethodError", "RawFormatError"]


class RawFormatError(ZonotopeError, ValueError):
    """A file that cannot be read as a camera RAW/DNG image (corrupt, truncated, not RAW, no pixels),
    or RAW metadata that cannot be used (missing or singular colour matrix, bad CFA pattern)."""


class InputFileNotFoundError(RawFormatError, FileNotFoundError):
    """An input file (RAW, DNG, camera profile) that does not exist: a project error that is also a
    ``FileNotFoundError``, so callers that caught that still do."""


class PipelineError(ZonotopeError, ValueError):
    """A pipeline asked for something it cannot do: unknown stage name, wrong array shape for a stage,
    an output path that would overwrite the input, ..."""


class PipelineMethodError(PipelineError, UnknownMethodError):
    """An unknown ``method=`` name of an ``isp`` registry (demosaicing, tone mapping); the message
    lists the valid names."""
