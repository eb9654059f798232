"""Config dataclasses in isp: one checked object, or its fields as keywords (as in zonotope).

``write_dng(path, mosaic, metadata, **fields)`` and ``simulate_capture(image, setup, sensor,
**options)`` accept a frozen dataclass, the same fields as keywords, or both (keywords override the
object's fields). Unknown or missing fields are :class:`~isp.PipelineError` s naming them.
:func:`~isp.metamer_correction` (:class:`~isp.MetamerConfig`) and :func:`~isp.fit_dcp`
(:class:`~isp.ProfileConfig`) work the same way; the options they pass on to a ``zonotope.correct``
estimator are one field, ``estimator_options`` (a mapping), so that every other keyword is checked.
The ``check_*`` helpers below are what the configs' ``__post_init__`` use.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import MISSING, fields, replace
from typing import Any, TypeVar

import numpy as np

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


def check_number(owner: str, name: str, value, ok: Callable[[float], bool], allowed: str) -> float:
    """``float(value)`` if it is a real number (not a bool) for which ``ok`` holds, else a PipelineError."""
    try:
        numeric = isinstance(value, int | float | np.number) and not isinstance(value, bool)
        good = numeric and bool(ok(float(value)))
    except (TypeError, ValueError, OverflowError):
        good = False
    if not good:
        raise PipelineError(f"{owner}.{name}={value!r}: {allowed}.")
    return float(value)


def check_int(owner: str, name: str, value, *, minimum: int, maximum: int | None = None) -> int:
    """``int(value)`` if it is an integer in ``[minimum, maximum]`` (not a bool), else a PipelineError."""
    ok = hasattr(value, "__index__") and not isinstance(value, bool)
    if not ok or int(value) < minimum or (maximum is not None and int(value) > maximum):
        where = f"≥ {minimum}" if maximum is None else f"in {minimum}…{maximum}"
        raise PipelineError(f"{owner}.{name}={value!r}: give an integer {where}.")
    return int(value)


def check_options(owner: str, name: str, value) -> dict[str, Any]:
    """A copy of ``value`` (a dict, so configs stay picklable) if it is a mapping with string keys,
    else a PipelineError.

    Used for ``estimator_options``: keywords passed on to an estimator's fitting function, kept
    apart from the config's own fields so that a misspelt field is refused, not passed on.
    """
    if value is None:
        return {}
    if not isinstance(value, Mapping) or not all(isinstance(k, str) for k in value):
        raise PipelineError(
            f"{owner}.{name}={value!r}: give a mapping of keyword names to values, e.g. {{'noise': 0.01}}."
        )
    return dict(value)


def float_array(x, what: str, error: type[Exception] = PipelineError) -> np.ndarray:
    """``np.asarray(x, float64)``, or ``error`` naming ``what`` when ``x`` is not an array of numbers
    (text, ragged nested lists, objects) instead of numpy's raw ``ValueError``/``TypeError``."""
    try:
        return np.asarray(x, dtype=np.float64)
    except (TypeError, ValueError) as exc:
        raise error(f"{what}: expected an array of numbers; got {type(x).__name__} ({exc}).") from None
