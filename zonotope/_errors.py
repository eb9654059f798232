"""Project exceptions: one hierarchy, messages that say what was wrong and what to do."""

from __future__ import annotations

__all__ = [
    "GeometryError",
    "InfeasibleResponseError",
    "OptionError",
    "SpectralDataError",
    "UnknownMethodError",
    "ZonotopeError",
]


class ZonotopeError(Exception):
    """Base class of every error raised on purpose by ``zonotope``, ``isp`` and ``splat``."""


class SpectralDataError(ZonotopeError, ValueError):
    """Spectral curves that cannot be used: NaN, negative, non-monotonic, disjoint ranges, ..."""


class GeometryError(ZonotopeError, ValueError):
    """A geometric object cannot be built or queried as asked (wrong dimension, too large, ...)."""


class InfeasibleResponseError(ZonotopeError, ValueError):
    """A source response no reflectance in [0, 1] can produce.

    Attributes
    ----------
    distance
        How far outside the source object-colour solid the response lies (the smallest
        per-channel tolerance ``delta`` that would make it feasible, in response units).
    """

    def __init__(self, message: str, *, distance: float | None = None) -> None:
        super().__init__(message)
        self.distance = distance


class OptionError(ZonotopeError, ValueError):
    """An option (a field of a config dataclass, or its keyword) that is unknown, missing or out of
    range; the message names it, the value given and what is allowed."""


class UnknownMethodError(ZonotopeError, ValueError):
    """A ``method=`` (or similar) name that no registry knows.

    Attributes
    ----------
    argument : str
        The argument that named it (``"method"``, ``"demosaic"``).
    value
        The name given.
    valid : tuple of str
        The canonical names that would have been accepted.
    """

    def __init__(
        self, message: str, *, argument: str = "method", value: object = None, valid: tuple[str, ...] = ()
    ) -> None:
        super().__init__(message)
        self.argument = argument
        self.value = value
        self.valid = valid
