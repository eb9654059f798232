"""isp._MOVED_MODULES: an old module path still imports, warns, and is the new module object."""

from __future__ import annotations

import importlib
import sys

import pytest

import isp


@pytest.mark.parametrize(("old", "new"), sorted(isp._MOVED_MODULES.items()))
def test_old_module_path_warns_and_aliases_the_new_module(old, new, monkeypatch):
    monkeypatch.delitem(sys.modules, old, raising=False)
    with pytest.warns(DeprecationWarning, match=f"{old} moved to {new}"):
        module = importlib.import_module(old)
    assert module is importlib.import_module(new)
