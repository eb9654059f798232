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
