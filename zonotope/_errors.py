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


def float_array(x, name: str, error: type[Exception] = SpectralDataError, *, copy: bool = False):
    """``np.asarray(x, float64)`` (``np.array`` with ``copy=True``), or ``error`` naming ``name`` when
    ``x`` is not an array of numbers (text, ragged nested lists) instead of numpy's raw
    ``ValueError``/``TypeError``."""
    import numpy as np

    try:
        return np.array(x, dtype=np.float64) if copy else np.asarray(x, dtype=np.float64)
    except (TypeError, ValueError) as exc:
        raise error(f"{name}: expected an array of numbers; got {type(x).__name__} ({exc}).") from None
