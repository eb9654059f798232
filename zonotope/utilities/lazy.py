"""Lazy public names and the moved-module deprecation hook, shared by every package of the project.

Why: a package's ``__init__`` should list its public names once and load heavy modules only on first
use (``import zonotope`` stays cheap), and old module paths should keep working through one table
instead of one shim file per moved module.
"""

from __future__ import annotations

import importlib
import importlib.abc
import importlib.util
import sys
import warnings
from collections.abc import Callable, Iterable, Mapping

__all__ = ["install_moved_modules", "lazy_exports"]


def lazy_exports(
    package: str,
    table: Mapping[str, Iterable[str]],
    eager: Iterable[str] = (),
    deprecated: Mapping[str, tuple[str, str]] | None = None,
) -> tuple[Callable[[str], object], Callable[[], list[str]], list[str]]:
    """Module-level ``__getattr__`` and ``__dir__`` serving ``table`` lazily, and the lazy names.

    Parameters
    ----------
    package : str
        The package's ``__name__``.
    table : mapping of str to iterable of str
        Module path relative to ``package`` (``"geometry.polytope"``) -> public names it defines.
    eager : iterable of str
        Names already bound in the package's namespace (listed by ``__dir__``).
    deprecated : mapping of str to (str, str), optional
        Old name -> (module relative to ``package`` that defines it, the name to use instead). These
        still resolve, with a :class:`DeprecationWarning`, and are not listed.

    Returns
    -------
    (__getattr__, __dir__, names)
        ``names`` is the sorted list of lazy names, to be added to ``__all__``. ``__getattr__`` imports
        the defining module on first access and caches the value in the package namespace.
    """
    where = {name: module for module, names in table.items() for name in names}
    namespace = sys.modules[package].__dict__
    eager = list(eager)
    deprecated = dict(deprecated or {})

    def __getattr__(name: str):
        if name in deprecated:
            module, instead = deprecated[name]
            warnings.warn(
                f"{package}.{name} is deprecated; use {package}.{instead}", DeprecationWarning, stacklevel=2
            )
            return getattr(importlib.import_module(f"{package}.{module}"), name)
        if name in where:
            value = getattr(importlib.import_module(f"{package}.{where[name]}"), name)
            namespace[name] = value
            return value
        raise AttributeError(f"module {package!r} has no attribute {name!r}")

    def __dir__() -> list[str]:
        return sorted(set(namespace) | set(where) | set(eager))

    return __getattr__, __dir__, sorted(where)


class _MovedModuleFinder(importlib.abc.MetaPathFinder, importlib.abc.Loader):
    """Serves an old dotted module name as an alias of its new module, with a DeprecationWarning."""

    def __init__(self, moved: Mapping[str, str]):
        self.moved = dict(moved)
        self._specs: dict[str, object] = {}

    def find_spec(self, fullname, path=None, target=None):
        if fullname not in self.moved:
            return None
        return importlib.util.spec_from_loader(fullname, self)

    def create_module(self, spec):
        new = self.moved[spec.name]
        warnings.warn(
            f"module {spec.name!r} moved to {new!r}; import it from there", DeprecationWarning, stacklevel=2
        )
        module = importlib.import_module(new)
        self._specs[spec.name] = module.__spec__
        return module

    def exec_module(self, module):
        # The new module is already executed; the import system overwrote its ``__spec__`` with the
        # alias's, so put the real one back.
        module.__spec__ = self._specs.pop(module.__spec__.name, module.__spec__)


def install_moved_modules(moved: Mapping[str, str]) -> None:
    """Make every old dotted name in ``moved`` importable as an alias of its new module.

    Importing an old name emits a :class:`DeprecationWarning` naming the new path and returns the new
    module object itself (``sys.modules[old] is sys.modules[new]``), so attributes, monkeypatches and
    ``isinstance`` checks stay one object.
    """
    for finder in sys.meta_path:
        if isinstance(finder, _MovedModuleFinder):
            finder.moved.update(moved)
            return
    sys.meta_path.insert(0, _MovedModuleFinder(moved))
