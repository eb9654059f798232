"""The splat package: cheap import, lazy public names, errors in the project hierarchy."""

from __future__ import annotations

import subprocess
import sys

import splat
import zonotope


def test_import_splat_does_not_import_jax():
    code = "import sys, splat; print('jax' in sys.modules)"
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "False"


def test_public_names_resolve_and_errors_subclass_the_project_ones():
    for name in splat.__all__:
        assert getattr(splat, name) is not None
    assert issubclass(splat.SplatError, zonotope.ZonotopeError)
    assert issubclass(splat.SplatError, ValueError)
    assert issubclass(splat.DataFormatError, splat.SplatError)
    assert callable(splat.render) and callable(splat.train)


def test_moved_modules_import_as_their_new_module_with_a_deprecation_warning():
    code = (
        "import warnings, importlib, splat\n"
        "for old, new in splat._MOVED_MODULES.items():\n"
        "    with warnings.catch_warnings(record=True) as w:\n"
        "        warnings.simplefilter('always')\n"
        "        m = importlib.import_module(old)\n"
        "    assert m is importlib.import_module(new), old\n"
        "    assert m.__spec__.name == new and m.__name__ == new, old\n"
        "    dep = [x for x in w if issubclass(x.category, DeprecationWarning)]\n"
        "    assert any(new in str(x.message) for x in dep), old\n"
        "from splat.simcapture import write_synthetic_capture\n"
        "print('ok')\n"
    )
    out = subprocess.run([sys.executable, "-W", "ignore", "-c", code], capture_output=True, text=True)
    assert out.stdout.strip() == "ok", out.stderr
