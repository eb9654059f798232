"""zonotope.spectra.loading: files with wavelengths in µm are refused in one line naming the file.

A camera file in µm (0.38–0.78) made ``zonotope evaluate --camera`` fail with an AssertionError deep
in the grid code; the loaders now refuse it before any work, with the factor to apply.
"""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import zonotope
from zonotope._errors import SpectralDataError


def _table(path, wavelengths, columns: int) -> None:
    rows = [",".join(["wavelength", *(f"c{i}" for i in range(columns))])]
    for k, w in enumerate(wavelengths):
        rows.append(",".join([f"{w:.6g}", *(f"{0.2 + 0.1 * ((k + i) % 5):.2f}" for i in range(columns))]))
    path.write_text("\n".join(rows) + "\n")


@pytest.mark.parametrize(
    ("load", "what"), [(zonotope.load_camera, "camera"), (zonotope.load_reflectances, "reflectances")]
)
def test_micrometres_are_refused_naming_the_file(tmp_path, load, what):
    path = tmp_path / "um.csv"
    _table(path, np.arange(0.38, 0.781, 0.01), 3)
    with pytest.raises(
        SpectralDataError, match=rf"{what} file .*um\.csv: wavelengths 0\.38–0\.78 are not in nanometres"
    ):
        load(path)
    _table(path, np.arange(380.0, 781.0, 10.0), 3)  # the same table in nm loads
    assert load(path).values.shape == (41, 3)


def test_the_cli_says_it_in_one_line(tmp_path, capsys):
    from zonotope.cli import main

    path = tmp_path / "um.csv"
    _table(path, np.arange(0.38, 0.781, 0.01), 3)
    assert main(["evaluate", "--camera", str(path)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "um.csv" in err[0] and "multiply the wavelength column by 1000" in err[0]


@settings(max_examples=20, deadline=None)
@given(start=st.floats(0.05, 90.0), step=st.floats(0.001, 0.5))
def test_any_grid_below_the_nm_floor_is_refused(tmp_path_factory, start, step):
    path = tmp_path_factory.mktemp("grid") / "curves.csv"
    w = start + step * np.arange(12)
    if w[-1] >= 100:
        return
    _table(path, w, 2)
    with pytest.raises(SpectralDataError, match="are not in nanometres, which zonotope reads"):
        zonotope.load_reflectances(path)
