"""isp develop: absurd options and running out of memory are one-line errors, never tracebacks; every
batch command's ``--scheduler`` help says what each choice means and whom it trusts."""

from __future__ import annotations

import numpy as np
import pytest

from isp.cli import main
from isp.dng import write_dng


@pytest.fixture(scope="module")
def dng(tmp_path_factory):
    m = np.clip(np.random.default_rng(0).normal(1500, 40, (40, 60)), 0, 4095).astype(np.uint16)
    path = tmp_path_factory.mktemp("opts") / "grey.dng"
    write_dng(
        path,
        m,
        cfa="RGGB",
        black_level=64,
        white_level=4095,
        color_matrix_1=np.eye(3),
        as_shot_neutral=[0.5, 1, 0.7],
    )
    return path


def _one_line(capsys) -> str:
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1, err
    return err[0]


@pytest.mark.parametrize("exposure", ["1e6", "nan", "inf", "-33"])
def test_exposure_out_of_range_is_one_line(dng, tmp_path, capsys, exposure):
    out = tmp_path / "o.tif"
    assert (
        main(["develop", str(dng), "-o", str(out), "-q", "--tonemap", "clip", f"--exposure={exposure}"]) == 2
    )
    assert "--exposure" in _one_line(capsys) and not out.exists()


def test_exposure_in_range_still_develops(dng, tmp_path):
    assert (
        main(
            [
                "develop",
                str(dng),
                "-o",
                str(tmp_path / "o.tif"),
                "-q",
                "--tonemap",
                "clip",
                "--exposure",
                "-2",
            ]
        )
        == 0
    )


def test_library_tonemap_clip_refuses_an_overflowing_gain():
    from isp import PipelineError, tonemap_clip

    with pytest.raises(PipelineError, match=r"exposure=1000000\.0: a gain in stops must be finite"):
        tonemap_clip(np.ones((2, 3)), exposure=1e6)
    np.testing.assert_allclose(tonemap_clip(np.full((1, 3), 0.25), exposure=1.0), 0.5)


def test_quantum_must_be_finite(dng, tmp_path, capsys):
    args = ["develop", str(dng), "-o", str(tmp_path / "o.tif"), "-q", "--correction", "metamer"]
    assert main([*args, "--camera", "Nikon 5100 (NPL)", "--quantum", "inf"]) == 2
    assert "--quantum inf: must be a finite number" in _one_line(capsys)


@pytest.mark.parametrize("white", ["1e308", "1e-300", "0", "nan"])
def test_scene_white_out_of_range_is_one_line(dng, tmp_path, capsys, white):
    args = ["develop", str(dng), "-o", str(tmp_path / "o.tif"), "-q", "--correction", "metamer"]
    assert main([*args, "--camera", "Nikon 5100 (NPL)", f"--scene-white={white}"]) == 2
    assert "--scene-white" in _one_line(capsys) and not (tmp_path / "o.tif").exists()


def test_out_of_memory_is_one_line_naming_the_file(dng, tmp_path, capsys, monkeypatch):
    import isp.pipeline

    def exhausted(self, raw, **kwargs):
        raise MemoryError

    monkeypatch.setattr(isp.pipeline.Pipeline, "__call__", exhausted)
    out = tmp_path / "o.tif"
    assert main(["develop", str(dng), "-o", str(out), "-q"]) == 2
    line = _one_line(capsys)
    assert str(dng) in line and "out of memory" in line and "--crop" in line and not out.exists()


@pytest.mark.parametrize(
    "command",
    [("isp", ["develop"]), ("zonotope", ["correct"]), ("zonotope", ["survey"])],
    ids=["isp develop", "zonotope correct", "zonotope survey"],
)
def test_scheduler_help_says_what_each_choice_trusts(command, capsys):
    import zonotope.cli

    prog, sub = command
    entry = main if prog == "isp" else zonotope.cli.main
    with pytest.raises(SystemExit):
        entry([*sub, "--help"])
    text = " ".join(capsys.readouterr().out.split())
    for words in (
        "'local:N'",
        "TLS certificates made for this run",
        "tcp://host:8786' has no authentication",
        "tls://host:8786",
        "$ZONOTOPE_SCHEDULER_SECURITY",
        "scheduler file",
    ):
        assert words in text, words
