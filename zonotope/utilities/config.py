"""Config dataclasses for functions with many options: one checked object, or keywords.

Functions with more than ~8 options (:func:`~zonotope.evaluate.evaluate`,
:func:`~zonotope.report.write_report`, :func:`~zonotope.metamer_mismatch_batch`) take a frozen
config dataclass whose ``__post_init__`` checks every field, *or* the same fields as keywords,
*or* a config plus keywords that override some of its fields::

    evaluate(sets, EvaluationConfig(noise=0.01, atypical=0))   # one checked object, reusable
    evaluate(sets, noise=0.01, atypical=0)                      # the same call, keywords
    evaluate(sets, base, noise=0.02)                             # a variant of ``base``

Keywords keep the many existing one-off call sites (tests, notebooks, CLIs) short; the config
object is what a CLI or a sweep builds once and checks before any work starts. Unknown keywords
are refused (never silently dropped).
"""

from __future__ import annotations

import math
from dataclasses import fields, replace
from typing import Any, TypeVar

from .._errors import OptionError

__all__ = ["check_bool", "check_count", "check_nonnegative", "with_options"]

T = TypeVar("T")


def with_options(cls: type[T], config: T | None, options: dict[str, Any], *, where: str) -> T:
    """``config`` with ``options`` applied (or ``cls(**options)`` when ``config`` is None).

    Raises
    ------
    OptionError
        ``config`` is not a ``cls``, or an option is not one of its fields.
    """
    names = [f.name for f in fields(cls)]
    unknown = sorted(set(options) - set(names))
    if unknown:
        raise OptionError(
            f"{where}: unknown option(s) {', '.join(unknown)}; the {cls.__name__} fields are "
            f"{', '.join(names)}."
        )
    if config is None:
        return cls(**options)
    if not isinstance(config, cls):
        raise OptionError(f"{where}: config must be a {cls.__name__}; got {type(config).__name__}.")
    return replace(config, **options) if options else config


def check_nonnegative(owner: str, name: str, value, *, allow_none: bool = False) -> float | None:
    """``float(value)`` if it is a finite number ≥ 0 (or None when allowed), else an OptionError."""
    if value is None and allow_none:
        return None
    try:
        ok = not isinstance(value, bool) and math.isfinite(float(value)) and float(value) >= 0
    except (TypeError, ValueError):
        ok = False
    if not ok:
        extra = " or None" if allow_none else ""
        raise OptionError(f"{owner}.{name}={value!r}: give a finite number ≥ 0{extra}.")
    return float(value)


def check_count(owner: str, name: str, value, *, minimum: int = 0, allow_none: bool = False) -> int | None:
    """``int(value)`` if it is an integer ≥ ``minimum`` (or None when allowed), else an OptionError."""
    if value is None and allow_none:
        return None
    integer = hasattr(value, "__index__") and not isinstance(value, bool)  # int, numpy integers
    if not integer or int(value) < minimum:
        raise OptionError(f"{owner}.{name}={value!r}: give an integer ≥ {minimum}.")
    return int(value)


def check_bool(owner: str, name: str, value) -> bool:
    """``value`` if it is a bool, else an OptionError."""
    if not isinstance(value, bool):
        raise OptionError(f"{owner}.{name}={value!r}: give True or False.")
    return value
