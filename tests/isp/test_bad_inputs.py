"""Bad arguments to isp's public functions are project errors that name the argument (issue 13 item 8),
never numpy's raw ValueError/TypeError/IndexError, an AttributeError or a bare FileNotFoundError."""

from __future__ import annotations

import numpy as np
import pytest

import isp
from zonotope import ZonotopeError

GREY = np.full((5, 3), 0.4)

BAD_CALLS = {
    "write_dcp(str profile)": (lambda p: isp.write_dcp(p / "x.dcp", "notaprofile"), "DCPProfile"),
    "read_dcp(missing)": (lambda p: isp.read_dcp(p / "none.dcp"), "not found"),
    "dcp_stage(missing)": (lambda p: isp.dcp_stage(p / "none.dcp"), "not found"),
    "read_raw(missing)": (lambda p: isp.read_raw(p / "none.dng"), "no such file"),
    "apply_hue_sat_map(2-D table)": (lambda p: isp.apply_hue_sat_map(GREY, np.ones((2, 2))), "table"),
    "apply_hue_sat_map(text rgb)": (
        lambda p: isp.apply_hue_sat_map("abc", np.ones((1, 2, 2, 3))),
        "rgb: expected an array",
    ),
    "apply_tone_curve(3 values)": (lambda p: isp.apply_tone_curve(GREY, [1, 2, 3]), "curve"),
    "DCPProfile(2-value matrix)": (lambda p: isp.DCPProfile(color_matrix_1=[1, 2]), "color_matrix_1"),
    "DCPProfile(text tone curve)": (
        lambda p: isp.DCPProfile(color_matrix_1=np.eye(3), tone_curve="abc"),
        "tone_curve",
    ),
    "tonemap(text)": (lambda p: isp.tonemap("abc"), "expected an array"),
    "demosaic(text)": (lambda p: isp.demosaic("abc", cfa="RGGB"), "mosaic: expected an array"),
    "fit_hue_sat_map(2 channels)": (
        lambda p: isp.fit_hue_sat_map(np.ones((3, 2)), np.ones((3, 2))),
        "(N, 3)",
    ),
    "fit_hue_sat_map(only greys)": (lambda p: isp.fit_hue_sat_map(GREY, GREY), "none of the 5 colours"),
    "profile_reflectances(text training)": (
        lambda p: isp.profile_reflectances(np.arange(400, 701, 10.0), "x"),
        "training: expected an array",
    ),
    "ProfileConfig(non-ASCII copyright)": (lambda p: isp.ProfileConfig(copyright="© me"), "ASCII"),
}


@pytest.mark.parametrize("name", list(BAD_CALLS))
def test_bad_arguments_raise_project_errors(name, tmp_path):
    call, match = BAD_CALLS[name]
    with pytest.raises(ZonotopeError, match=match):
        call(tmp_path)
    assert list(tmp_path.iterdir()) == []  # nothing written


def test_missing_inputs_are_also_file_not_found_errors(tmp_path):
    for call in (lambda: isp.read_dcp(tmp_path / "a.dcp"), lambda: isp.read_raw(tmp_path / "a.dng")):
        with pytest.raises(FileNotFoundError):
            call()
    assert issubclass(isp.InputFileNotFoundError, isp.RawFormatError)


def test_profile_cli_refuses_non_ascii_before_fitting(tmp_path, capsys):
    """The tag check used to run after the (minutes-long) fit, at write time (write_dcp's message);
    now the config refuses it before any fitting."""
    from isp.cli import main

    argv = ["profile", "--camera", "Nikon 5100 (NPL)", "-o", str(tmp_path / "x.dcp"), "--copyright", "© me"]
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert (
        "ProfileConfig.copyright" in err
        and "ASCII" in err
        and len(err.strip().splitlines()) == 1
        and list(tmp_path.iterdir()) == []
    )
