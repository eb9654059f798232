"""One pattern for "several algorithms for one job": a case-insensitive method registry.

Every ``*_METHODS`` table of the project (colour correction, demosaicing, tone mapping, splat
rendering, MMV support oracles) is a :class:`MethodRegistry`. It is a read-only mapping from
canonical names (``"Finlayson 2015"``) to implementations, looked up with case, spaces and
punctuation ignored (``"finlayson2015"``, ``"FINLAYSON-2015"``) or through declared aliases
(``"root-polynomial"``). Each entry carries its *properties* (e.g. whether a correction method
needs metamer mismatch volumes), so callers ask the registry instead of keeping their own lists
of names. An unknown name raises :class:`~zonotope.UnknownMethodError` (or the subclass the
registry was built with) naming the argument, the bad value and the valid names.

Examples
--------
>>> from zonotope.utilities import MethodRegistry
>>> SHAPES = MethodRegistry("shape")
>>> SHAPES.register("Unit Square", lambda: 1.0, aliases=("square",), corners=4)
>>> SHAPES["unit-square"](), SHAPES.resolve("SQUARE"), SHAPES.properties("square")["corners"]
(1.0, 'Unit Square', 4)
>>> SHAPES["circle"]  # doctest: +ELLIPSIS
Traceback (most recent call last):
...
zonotope._errors.UnknownMethodError: method='circle' is not a shape method; choose one of ['Unit Square'] ...
"""

from __future__ import annotations

from collections.abc import Iterator, Mapping
from dataclasses import dataclass, field
from types import MappingProxyType
from typing import Any, Generic, TypeVar

from .._errors import UnknownMethodError

__all__ = ["Method", "MethodRegistry"]

F = TypeVar("F")


def _key(name: object) -> str:
    """Lookup key of a method name: lower case, letters and digits only."""
    return "".join(ch for ch in str(name).lower() if ch.isalnum())


@dataclass(frozen=True)
class Method(Generic[F]):
    """One registered implementation.

    Attributes
    ----------
    name : str
        Canonical name (``"Finlayson 2015"``).
    function
        The implementation.
    properties : Mapping[str, Any]
        What callers may ask about the method (read-only).
    aliases : tuple of str
        Other accepted names.
    """

    name: str
    function: F
    properties: Mapping[str, Any] = field(default_factory=dict)
    aliases: tuple[str, ...] = ()


class MethodRegistry(Mapping[str, F]):
    """Case-insensitive, read-only mapping from method names to implementations.

    Parameters
    ----------
    what
        What the methods do, for messages (``"correction"``, ``"demosaicing"``).
    argument
        Name of the keyword argument that selects a method (for messages).
    error
        Exception class raised for an unknown name (a subclass of
        :class:`~zonotope.UnknownMethodError`, so that each package raises its own kind).

    Notes
    -----
    Iteration yields the canonical names in registration order, so ``list(REGISTRY)`` and
    ``", ".join(REGISTRY)`` give the valid choices. ``name in REGISTRY`` accepts aliases and any
    case.
    """

    def __init__(
        self, what: str, *, argument: str = "method", error: type[UnknownMethodError] = UnknownMethodError
    ) -> None:
        self.what = what
        self.argument = argument
        self.error = error
        self._methods: dict[str, Method[F]] = {}
        self._keys: dict[str, str] = {}

    def register(self, name: str, function: F, *, aliases: tuple[str, ...] = (), **properties: Any) -> None:
        """Add a method.

        Parameters
        ----------
        name
            Canonical name.
        function
            The implementation.
        aliases
            Other accepted names.
        **properties
            Facts about the method that callers may query with :meth:`properties` or
            :meth:`names`.

        Raises
        ------
        ValueError
            A name or alias that collides with one already registered (a programming error).
        """
        for n in (name, *aliases):
            if _key(n) in self._keys:
                raise ValueError(f"{self.what} method name {n!r} is already registered.")
        self._methods[name] = Method(name, function, MappingProxyType(dict(properties)), tuple(aliases))
        for n in (name, *aliases):
            self._keys[_key(n)] = name

    def resolve(self, name: str, *, argument: str | None = None) -> str:
        """Canonical name of ``name`` (any case, punctuation ignored, or an alias).

        Parameters
        ----------
        name
            The name to look up.
        argument
            Name of the argument for the error message (default: the registry's ``argument``).

        Raises
        ------
        UnknownMethodError
            When no method matches; the message lists the valid names.
        """
        canonical = self._keys.get(_key(name))
        if canonical is None:
            aliases = sorted(a for m in self._methods.values() for a in m.aliases)
            extra = f" (aliases: {aliases})" if aliases else ""
            raise self.error(
                f"{argument or self.argument}={name!r} is not a {self.what} method; choose one of "
                f"{list(self._methods)}{extra}.",
                argument=argument or self.argument,
                value=name,
                valid=tuple(self._methods),
            )
        return canonical

    def method(self, name: str) -> Method[F]:
        """The :class:`Method` record of ``name``."""
        return self._methods[self.resolve(name)]

    def properties(self, name: str) -> Mapping[str, Any]:
        """Properties of ``name`` (read-only mapping)."""
        return self.method(name).properties

    def names(self, **where: Any) -> tuple[str, ...]:
        """Canonical names whose properties equal every ``key=value`` given.

        Examples
        --------
        >>> from zonotope.correct import CORRECTION_METHODS
        >>> CORRECTION_METHODS.names(needs_mmv=False)
        ('Cheung 2004', 'Finlayson 2015', 'Dyer 2017', 'Guarded', 'MAP')
        """
        return tuple(
            n for n, m in self._methods.items() if all(m.properties.get(k) == v for k, v in where.items())
        )

    def __getitem__(self, name: str) -> F:
        return self._methods[self.resolve(name)].function

    def __contains__(self, name: object) -> bool:
        return _key(name) in self._keys

    def __iter__(self) -> Iterator[str]:
        return iter(self._methods)

    def __len__(self) -> int:
        return len(self._methods)

    def __repr__(self) -> str:
        return f"MethodRegistry({self.what!r}, {list(self._methods)})"
