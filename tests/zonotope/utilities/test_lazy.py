"""Lazy exports and the one moved-module table: old paths import, warn, and are the new module."""

from __future__ import annotations

import importlib
import subprocess
import sys
import types

import pytest

import zonotope
from zonotope.utilities import lazy_exports


@pytest.mark.parametrize("old, new", sorted(zonotope._MOVED_MODULES.items()))
def test_old_module_paths_warn_and_alias_the_new_module(old, new):
    sys.modules.pop(old, None)
    with pytest.warns(DeprecationWarning, match=new.replace(".", r"\.")):
        module = importlib.import_module(old)
    assert module is importlib.import_module(new)
    assert module.__spec__.name == new  # the alias does not rename the real module


def test_deprecated_names_warn_and_point_to_the_loader():
    with pytest.warns(DeprecationWarning, match="load_camera"):
        read = zonotope.read_camera
    assert read is importlib.import_module("zonotope.spectra.builtin").read_camera
    with pytest.warns(DeprecationWarning, match="load_reflectances"):
        zonotope.spectra.read_sfu1995  # noqa: B018
    assert "read_camera" not in zonotope.__all__ and "load_camera" in zonotope.__all__


def test_plumbing_is_not_in_the_top_level():
    for name in ("MethodRegistry", "Method", "ProgressCallback", "atomic_path", "atomic_write_text"):
        assert name not in zonotope.__all__
        assert hasattr(importlib.import_module("zonotope.utilities"), name)


def test_lazy_exports_load_on_first_use(monkeypatch):
    package = types.ModuleType("fakepkg")
    package.__path__ = []
    monkeypatch.setitem(sys.modules, "fakepkg", package)
    monkeypatch.setitem(sys.modules, "fakepkg.mod", types.SimpleNamespace(f=len, g=abs))
    getattr_, dir_, names = lazy_exports("fakepkg", {"mod": ["f"]}, deprecated={"g": ("mod", "f")})
    assert names == ["f"] and "f" in dir_() and "g" not in dir_()
    assert getattr_("f") is len and package.__dict__["f"] is len
    with pytest.warns(DeprecationWarning, match="fakepkg.f"):
        assert getattr_("g") is abs
    with pytest.raises(AttributeError):
        getattr_("h")


def test_console_entry_point_and_python_m_still_work():
    out = subprocess.run([sys.executable, "-m", "zonotope", "--help"], capture_output=True, text=True)
    assert out.returncode == 0 and "usage" in out.stdout.lower()
