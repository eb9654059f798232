"""``[chart]`` without corners: the ColorChecker found in the capture's own RAW file (a real Canon EOS
550D DNG of a ColorChecker Passport), recorded in OUT and searched again only for another file; a
photograph without a chart and a missing detector are one-line errors that say how to give the
corners."""

from __future__ import annotations

import dataclasses
import os
import shutil
import sys

import numpy as np
import pytest

from splat.capture import CaptureError, Workspace, chart_of, read_capture, recorded_corners

pytest.importorskip("colour_checker_detection")

#: The hand-given corners of the 550D's chart (tests/isp/test_chart_detect.py): a rectangle rounded to
#: whole pixels; the chart is turned by 1.3°, 12 px over its 538 px width.
HAND = np.array([(712, 624), (1250, 624), (1250, 930), (712, 930)], dtype=float)


@pytest.fixture
def capture(shared_data, tmp_path):
    raws = shared_data / "raw_samples"
    dng = raws / "tinydng_colorchart_Canon_EOS_Kiss_X4_MagicLantern.dng"
    if not dng.is_file():
        pytest.skip(f"{dng} not present")
    cap = tmp_path / "cap"
    for folder, name in (("canon", "IMG_1.dng"), ("nikon", "DSC_1.dng")):
        (cap / folder).mkdir(parents=True)
        shutil.copy(dng, cap / folder / name)
    crw = raws / "rawsamples_RAW_CANON_D30_SRGB.CRW"
    if crw.is_file():
        shutil.copy(crw, cap / "nikon" / "CRW_2.crw")
    (cap / "capture.toml").write_text(
        'illuminant = "A"\n'
        '[[camera]]\nfolder = "canon"\nssf = "Canon EOS 5D Mark II"\n'
        '[[camera]]\nfolder = "nikon"\nssf = "Nikon 5100 (NPL)"\n'
        '[chart]\nimage = "canon/IMG_1.dng"\n'
    )
    return cap


def test_the_chart_is_found_where_the_hand_put_it_and_recorded(capture, tmp_path, monkeypatch):
    spec = read_capture(capture)
    assert spec.chart.corners is None and not spec.chart.found
    ws = Workspace(spec, tmp_path / "out")
    got = chart_of(spec, ws)
    corners = np.array(got.chart.corners)
    assert got.chart.found and got.chart.image == "canon/IMG_1.dng"
    assert np.abs(corners - HAND).max() < 0.15 * 538 / 5  # within 0.15 of the 108 px patch pitch
    assert recorded_corners(spec, ws.root) == got.chart.corners

    import isp.profiles.chart_detect as detect

    def no_search(*a, **k):
        raise AssertionError("searched again")

    monkeypatch.setattr(detect, "detect_chart_rgb", no_search)
    assert chart_of(spec, ws).chart.corners == got.chart.corners  # the record is read, not searched
    given = dataclasses.replace(spec, chart=dataclasses.replace(got.chart, found=False))
    assert chart_of(given, ws) is given  # corners given: neither searched nor read from the record

    st = os.stat(capture / "canon" / "IMG_1.dng")  # another file under the same name: searched again
    os.utime(capture / "canon" / "IMG_1.dng", ns=(st.st_atime_ns, st.st_mtime_ns + 10**9))
    assert recorded_corners(spec, ws.root) is None
    with pytest.raises(AssertionError, match="searched again"):
        chart_of(spec, ws)


def test_no_chart_in_the_photograph_is_one_line_saying_how_to_give_the_corners(capture, tmp_path, capsys):
    if not (capture / "nikon" / "CRW_2.crw").is_file():
        pytest.skip("the Canon D30 CRW is not present")
    (capture / "capture.toml").write_text(
        (capture / "capture.toml").read_text().replace("canon/IMG_1.dng", "nikon/CRW_2.crw")
    )
    spec = read_capture(capture)
    with pytest.raises(CaptureError, match=r"\[chart\] image 'nikon/CRW_2.crw'.*no ColorChecker found") as e:
        chart_of(spec, Workspace(spec, tmp_path / "out"))
    assert "\n" not in str(e.value) and "[chart] corners = [[x, y]" in str(e.value)
    assert "--chart-corners" not in str(e.value)
    assert not (tmp_path / "out" / "poses" / "chart.json").exists()

    from splat.cli import main  # the poses step stops before it decodes or registers anything

    assert main(["poses", str(capture), "-o", str(tmp_path / "run")]) == 2
    *warnings, error = capsys.readouterr().err.splitlines()  # the 550D's DNG under a Nikon's curves is
    assert all(w.startswith("splat: warning: ") and "Canon" in w for w in warnings)  # a maker warning
    assert error.startswith("splat: error: ") and "no ColorChecker found" in error
    assert sorted(p.name for p in (tmp_path / "run").iterdir()) == [".splat-output.json", "settings.json"]


def test_a_missing_detector_is_one_line_before_any_work(capture, tmp_path, monkeypatch):
    monkeypatch.setitem(sys.modules, "colour_checker_detection", None)
    spec = read_capture(capture)
    with pytest.raises(
        CaptureError, match=r"pip install 'zonotope\[chart\]', or give its corners in capture.toml"
    ):
        chart_of(spec, Workspace(spec, tmp_path / "out"))
