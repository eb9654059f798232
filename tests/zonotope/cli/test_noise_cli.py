"""``zonotope correct --noise``: estimated from the images by default, or given as σ or SHOT:READ."""

from __future__ import annotations

import numpy as np

from zonotope.cli import main
from zonotope.correct import NoiseModel, estimate_noise, fit_correction


def _write(tmp_path, seed=0):
    import tifffile

    rng = np.random.default_rng(seed)
    img = np.repeat(np.repeat(rng.uniform(0.05, 0.7, (4, 4, 3)), 16, 0), 16, 1)
    img = NoiseModel.shot_limited(0.01, 3).sample(img, rng).astype(np.float32)
    folder = tmp_path / "in"
    folder.mkdir()
    tifffile.imwrite(folder / "a.tif", img, photometric="rgb")
    return folder, img


def _argv(folder, out, *extra):
    return [
        "correct",
        str(folder),
        "-o",
        str(out),
        "--camera",
        "Nikon 5100 (NPL)",
        "--method",
        "Finlayson 2015",
    ]


def test_default_noise_is_estimated_from_the_image_and_said(tmp_path, capsys):
    import tifffile

    folder, img = _write(tmp_path)
    argv = [*_argv(folder, tmp_path / "out"), "--scheduler", "serial"]
    assert main(argv) == 0
    err = capsys.readouterr().err
    assert "noise: σ at white" in err and "estimated from image" in err
    got = tifffile.imread(tmp_path / "out" / "a_XYZ.tif")
    want = fit_correction("Nikon 5100 (NPL)", method="Finlayson 2015", noise=estimate_noise(img))(img)
    np.testing.assert_allclose(got, want, rtol=1e-5, atol=1e-6)


def test_shot_read_noise_and_bad_values(tmp_path, capsys):
    import tifffile

    folder, img = _write(tmp_path)
    argv = [*_argv(folder, tmp_path / "out"), "--scheduler", "serial", "--noise", "1e-4:1e-6"]
    assert main(argv) == 0
    assert "(shot + read; given)" in capsys.readouterr().err
    model = NoiseModel(1e-4, 1e-6).check_channels(3)
    want = fit_correction("Nikon 5100 (NPL)", method="Finlayson 2015", noise=model)(img)
    np.testing.assert_allclose(tifffile.imread(tmp_path / "out" / "a_XYZ.tif"), want, rtol=1e-5, atol=1e-6)
    for bad in ("loud", "1:x", "-1e-4:0"):
        try:
            code = main([*_argv(folder, tmp_path / "o2"), "--scheduler", "serial", f"--noise={bad}"])
        except SystemExit as exc:  # argparse refuses what it cannot parse
            code = exc.code
        assert code == 2
        err = capsys.readouterr().err.strip().splitlines()
        assert "noise" in err[-1].lower()


def test_default_method_is_that_of_correct_image(tmp_path, capsys):
    """``zonotope correct`` corrects folders of photographs: its default estimator is the photo default
    of ``correct_image`` (the registry's ``image_default`` entry), said in ``--help``."""
    import inspect

    import tifffile

    from zonotope.cli.batch import default_method
    from zonotope.correct import IMAGE_METHOD, correct_image

    assert default_method() == inspect.signature(correct_image).parameters["method"].default
    assert default_method() == IMAGE_METHOD == "Guarded"
    folder, img = _write(tmp_path)
    argv = ["correct", str(folder), "-o", str(tmp_path / "out"), "--camera", "Nikon 5100 (NPL)"]
    assert main([*argv, "--scheduler", "serial"]) == 0
    assert "fitting Guarded" in capsys.readouterr().err
    got = tifffile.imread(tmp_path / "out" / "a_XYZ.tif")
    want = fit_correction("Nikon 5100 (NPL)", method=IMAGE_METHOD, noise=estimate_noise(img))(img)
    np.testing.assert_allclose(got, want, rtol=1e-5, atol=1e-6)
    try:
        main(["correct", "--help"])
    except SystemExit:
        pass
    assert "'Guarded'" in " ".join(capsys.readouterr().out.split())


def test_a_camera_file_of_estimated_curves_adds_its_band_to_the_noise(tmp_path, capsys):
    """``--camera est.json`` written by ``zonotope ssf estimate``: its band σ joins the images' noise in
    the fit (as the capture does). Two stacked cameras, the Canon's curves estimated from its DNG
    matrices, the image of the measured cameras' responses, told noise-free: the fit told the band
    stays near the measured-curve fit (0.78 against 0.18 ΔE00 on these 219 surfaces with
    ``--exact-curves``; 1.01 by default, the Nikon's curves told the spread between units), where the
    noise-free one leans on the estimated curves' channel differences (4.04)."""
    import tifffile

    import zonotope
    from zonotope.correct import correction_problem
    from zonotope.spectra.estimate import synthesise_dng_matrices

    est = zonotope.estimate_ssf(synthesise_dng_matrices("Canon EOS 5D Mark II"), name="Canon test")
    cam = zonotope.write_ssf_json(est, tmp_path / "canon.json")
    back = zonotope.read_ssf_estimate(cam)  # the file keeps what response_sigma needs
    np.testing.assert_allclose(back.response_sigma(), est.response_sigma(), rtol=1e-4)
    truth = correction_problem(["Canon EOS 5D Mark II", "Nikon 5100 (NPL)"])
    sets = ("ColorChecker N Ohta", "CIE 1995 TCS", "NIST CQS 9.0")
    R = np.clip(
        np.concatenate([zonotope.resample(zonotope.reflectances(n), truth.wavelengths).T for n in sets]), 0, 1
    )
    folder = tmp_path / "in"
    folder.mkdir()
    tifffile.imwrite(folder / "a.tif", truth.source_of(R)[None].astype(np.float32))
    argv = ["correct", str(folder), "-o", str(tmp_path / "out"), "--camera", str(cam), "--camera"]
    argv += ["Nikon 5100 (NPL)", "--method", "Finlayson 2015", "--noise", "0", "--scheduler", "serial", "-q"]
    assert main(argv) == 0
    assert "their band added, " in capsys.readouterr().err  # said even with -q
    XYZ = tifffile.imread(tmp_path / "out" / "a_XYZ.tif")[0]
    assert np.mean(truth.delta_E(XYZ, truth.target_of(R))) < 1.5
