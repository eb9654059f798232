"""``isp develop --correction metamer --noise`` and ``isp profile --noise``: which noise the fit is for,
said on the command line and recorded in a folder batch's settings (simulated DNGs of known noise)."""

from __future__ import annotations

import json

import pytest

import zonotope
from isp.cli import main
from isp.simulate import chart_image, simulate_capture, simulate_dng, spectral_setup

CAMERA = "Nikon 5100 (NPL)"
METAMER = ["--correction", "metamer", "--camera", CAMERA, "--demosaic", "bilinear"]


@pytest.fixture(scope="module")
def dngs(tmp_path_factory):
    """The same noisy 148 × 220 ColorChecker as a DNG with its true NoiseProfile, with an implausible
    one, and without one."""
    setup = spectral_setup(CAMERA, illuminant="D65")
    R = zonotope.resample(zonotope.reflectances("ColorChecker N Ohta"), setup.wavelengths).T
    image, _ = chart_image(R, rows=4, cols=6, patch=32, gap=4)
    cap = simulate_capture(image, setup, full_well=3000.0, read_noise=4.0)
    folder = tmp_path_factory.mktemp("noisy")
    return {
        "profile": simulate_dng(folder / "profile.dng", cap, noise_profile=cap.noise_profile),
        "implausible": simulate_dng(folder / "implausible.dng", cap, noise_profile=[1.0, 0.5]),
        "plain": simulate_dng(folder / "plain.dng", cap),
    }


def _err(capsys) -> str:
    return " ".join(capsys.readouterr().err.split())


def test_noise_profile_used_and_said(dngs, tmp_path, capsys):
    assert main(["develop", str(dngs["profile"]), "-o", str(tmp_path / "a.tif"), *METAMER]) == 0
    err = _err(capsys)
    assert "noise: σ at white [" in err and "DNG NoiseProfile" in err
    assert (
        f"metamer correction {zonotope.correct.IMAGE_METHOD}" in err and "noise σ at white" in err
    )  # the final line


def test_implausible_profile_reported_and_estimate_used(dngs, tmp_path, capsys):
    assert main(["develop", str(dngs["implausible"]), "-o", str(tmp_path / "a.tif"), *METAMER, "-q"]) == 0
    err = _err(capsys)  # the note is printed even with -q
    assert "estimated from image" in err and "NoiseProfile ignored" in err and "not a plausible" in err


def test_noise_option_overrides(dngs, tmp_path, capsys):
    out = tmp_path / "a.tif"
    assert main(["develop", str(dngs["profile"]), "-o", str(out), *METAMER, "--noise", "0.01"]) == 0
    err = _err(capsys)
    assert "noise: σ at white [0.01, 0.01, 0.01] (shot + read; --noise)" in err and "NoiseProfile" not in err
    again = ["develop", str(dngs["profile"]), "-o", str(out), *METAMER, "--noise", "0", "--overwrite"]
    assert main(again) == 0
    assert "noise: none (noise-free fit)" in _err(capsys)


@pytest.mark.parametrize(
    ("value", "message"),
    [
        ("abc", "--noise 'abc': give 'auto', a σ such as 0.005, or SHOT:READ"),
        ("-1", "every value must be finite and ≥ 0"),
        ("nan", "every value must be finite and ≥ 0"),
        ("1:x", "give SHOT:READ as two numbers"),
        ("2e-5:-1e-7", "every value must be finite and ≥ 0"),
    ],
)
def test_bad_noise_is_a_one_line_error(dngs, tmp_path, capsys, value, message):
    out = str(tmp_path / "a.tif")
    assert main(["develop", str(dngs["plain"]), "-o", out, *METAMER, f"--noise={value}"]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and err.startswith("isp: error: --noise") and message in err, err
    assert not list(tmp_path.iterdir())


def test_noise_without_metamer_is_refused(dngs, tmp_path, capsys):
    assert main(["develop", str(dngs["plain"]), "-o", str(tmp_path / "a.tif"), "--noise", "0.01"]) == 2
    assert "--noise applies to --correction metamer only" in _err(capsys)


def test_folder_settings_record_the_noise(dngs, tmp_path, capsys):
    """A rerun into the same folder with another noise is refused: its fit would differ."""
    src = tmp_path / "in"
    src.mkdir()
    (src / "chart.dng").write_bytes(dngs["profile"].read_bytes())
    out = tmp_path / "out"
    run = ["develop", str(src), "-o", str(out), *METAMER, "--scheduler", "serial", "-q"]
    assert main([*run, "--noise", "0.01"]) == 0
    settings = json.loads((out / "manifest.settings.json").read_text())
    assert "noise" in json.dumps(settings) and "0.0001" in json.dumps(settings)
    assert main([*run, "--noise", "0.01"]) == 0  # the same noise: resumed (nothing to do)
    capsys.readouterr()
    assert main([*run, "--noise", "0.02"]) == 2
    assert "noise" in _err(capsys)
    assert main([*run]) == 2  # auto: the file's NoiseProfile, another noise again


@pytest.mark.parametrize(
    ("options", "message"),
    [
        (["--noise", "loud"], "--noise 'loud'"),
        (["--noise", "-0.5"], "every value must be finite and ≥ 0"),
        (["--noise", "0.01", "--noise-dng", "x.dng"], "--noise-dng applies to --noise auto only"),
    ],
)
def test_profile_bad_noise_is_a_one_line_error(tmp_path, capsys, options, message):
    out = tmp_path / "c.dcp"
    assert main(["profile", "--camera", CAMERA, "-o", str(out), "--matrix-only", *options]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and message in err, err
    assert not out.exists()


def test_profile_noise_from_a_dng(dngs, tmp_path, capsys):
    out = tmp_path / "c.dcp"
    noisy = str(dngs["profile"])
    rc = main(["profile", "--camera", CAMERA, "-o", str(out), "--matrix-only", "--noise-dng", noisy])
    assert rc == 0 and out.exists()
    err = _err(capsys)
    assert "noise: σ at white [" in err and "DNG NoiseProfile" in err and "from profile.dng" in err
    assert f"fitting {zonotope.correct.IMAGE_METHOD}" in err  # the photograph default
