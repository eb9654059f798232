"""Run the doctests of every module of zonotope, isp and splat inside the normal test suite.

``pytest --doctest-modules`` would need the package folders on the command line; collecting them
here keeps the README's test command (``pytest -q --nbmake tests notebooks``) the one that runs
everything.
"""

from __future__ import annotations

import doctest
import importlib
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
MODULES = sorted(
    ".".join(p.relative_to(ROOT).with_suffix("").parts).removesuffix(".__init__")
    for package in ("zonotope", "isp", "splat")
    for p in (ROOT / package).rglob("*.py")
    if p.stem != "__main__" and ">>> " in p.read_text(encoding="utf-8")
)


def _examples(name: str) -> list[doctest.DocTest]:
    module = importlib.import_module(name)
    tests = doctest.DocTestFinder(exclude_empty=True).find(module, name)
    return [t for t in tests if t.examples]


@pytest.mark.parametrize("name", MODULES)
def test_doctests(name):
    tests = _examples(name)
    assert tests, f"{name} has '>>> ' in its source but no doctest was found"
    runner = doctest.DocTestRunner(optionflags=doctest.ELLIPSIS | doctest.NORMALIZE_WHITESPACE)
    report = []
    for test in tests:
        out: list[str] = []
        runner.run(test, out=out.append)
        report += out
    assert runner.failures == 0, "".join(report)
