"""isp.cli: the ``isp`` command on a crop of the real 550D DNG (outputs go to tmp_path)."""

from __future__ import annotations

import subprocess
import sys

import numpy as np
import pytest
import tifffile

from isp.cli import main

CROP = ["--crop", "560", "640", "64", "96"]


def test_develop_png_and_stages(dng_550d, tmp_path):
    out = tmp_path / "out.png"
    stages = tmp_path / "stages"
    rc = main(["develop", str(dng_550d), "-o", str(out), "--demosaic", "bilinear", *CROP,
               "--save-stages", str(stages), "-q"])
    assert rc == 0
    assert out.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    names = sorted(p.name for p in stages.iterdir())
    assert names[0] == "00_input.tif" and names[-1] == "07_encode_sRGB.tif"
    demosaiced = tifffile.imread(stages / "03_demosaic.tif")
    assert demosaiced.shape == (64, 96, 3) and demosaiced.dtype == np.float32
    # refuses to overwrite without --overwrite
    assert main(["develop", str(dng_550d), "-o", str(out), *CROP, "-q"]) == 2


def test_develop_tiff_clip(dng_550d, tmp_path):
    out = tmp_path / "out.tif"
    assert main(["develop", str(dng_550d), "-o", str(out), *CROP, "--tonemap", "clip", "--exposure", "1",
                 "-q"]) == 0
    img = tifffile.imread(out)
    assert img.dtype == np.uint16 and img.shape == (64, 96, 3)
    assert main(["develop", str(dng_550d), "-o", str(tmp_path / "b.tif"), "--exposure", "1", "-q"]) == 2


def test_errors_exit_2(tmp_path, capsys):
    bad = tmp_path / "notes.dng"
    bad.write_text("not a raw file")
    assert main(["develop", str(bad), "-o", str(tmp_path / "x.png"), "-q"]) == 2
    assert "not a readable RAW file" in capsys.readouterr().err
    assert main(["develop", str(bad), "-o", str(bad), "-q"]) == 2
    assert bad.read_text() == "not a raw file"
    assert main(["develop", str(tmp_path / "missing.dng"), "-o", str(tmp_path / "x.png"), "-q"]) == 2
    with pytest.raises(SystemExit):
        main(["develop"])


def test_python_m_isp_info(dng_350d):
    res = subprocess.run([sys.executable, "-m", "isp", "info", str(dng_350d), "--metadata-only"],
                         capture_output=True, text=True, timeout=120)
    assert res.returncode == 0, res.stderr
    assert "350D" in res.stdout and "0.6018" in res.stdout
