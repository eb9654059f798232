"""Config dataclasses in isp: one checked object, or its fields as keywords (as in zonotope).

``write_dng(path, mosaic, metadata, **fields)`` and ``simulate_capture(image, setup, sensor,
**options)`` accept a frozen dataclass, the same fields as keywords, or both (keywords override the
object's fields). Unknown or missing fields are :class:`~isp.PipelineError` s naming them.
"""

from __future__ import annotations

from dataclasses import MISSING, fields, replace
from typing import Any, TypeVar

from ._errors import PipelineError

T = TypeVar("T")


def with_options(cls: type[T], config: T | None, options: dict[str, Any], *, where: str) -> T:
    """``config`` with ``options`` applied, or ``cls(**options)`` when ``config`` is None."""
    names = [f.name for f in fields(cls)]
    unknown = sorted(set(options) - set(names))
    if unknown:
        raise PipelineError(
            f"{where}: unknown option(s) {', '.join(unknown)}; the {cls.__name__} fields are "
            f"{', '.join(names)}."
        )
    if config is None:
        required = [f.name for f in fields(cls) if f.default is MISSING and f.default_factory is MISSING]
        missing = [n for n in required if n not in options]
        if missing:
            raise PipelineError(
                f"{where}: missing {', '.join(missing)} (pass them as keywords or a {cls.__name__})."
            )
        return cls(**options)
    if not isinstance(config, cls):
        raise PipelineError(f"{where}: expected a {cls.__name__}; got {type(config).__name__}.")
    return replace(config, **options) if options else config
