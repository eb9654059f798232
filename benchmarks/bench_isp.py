"""isp benchmark: the pipeline against rawpy on a real DNG, simulated ColorCheckers against the truth,
colour correction paths, and demosaicing quality (PSNR) and speed.

Run: ``.venv/bin/python benchmarks/bench_isp.py [--quick]``. Prints tables; timings are medians of
``--repeats`` (≥ 5) runs. Needs ../shared/data for the real-file and Munsell parts (skipped otherwise).

Tables
------
A. Real Canon 550D DNG (ColorChecker Passport): our pipeline (bilinear) vs
   ``rawpy.postprocess(demosaic_algorithm=LINEAR, use_camera_wb=True, no_auto_bright=True,
   output_bps=16, gamma=(1, 1))``, per patch, and ΔE00 of both against the ColorChecker reference
   (X-Rite "After November 2014" D50 values). Patch centres were measured by hand on a rendered PNG.
B. Simulated ColorChecker (SSF × D65 → noisy mosaic → DNG → read back → pipeline) vs true colours:
   every demosaicing method with the DNG ColorMatrix, and the metamer correction of ``isp develop
   --correction metamer`` (``isp.metamer_correction``, Prior, 400–700 nm / 10 nm) after Malvar 2004.
C. Colour correction on patch responses: DNG ColorMatrix path vs correction callables
   (least-squares 3 × 3 from the SSF; zonotope.correct root-polynomial; the metamer-based
   estimators Prior and Centroid on the simulation's grid, and Prior as the CLI fits it).
D. Demosaicing: PSNR on simulated scenes made of real reflectances, and time per megapixel.
E. ``--memory [MP ...]``: peak RSS of a whole development (read, default pipeline, 16-bit TIFF) of
   synthetic DNGs written to /tmp, each in a fresh process: strip-wise (what ``isp develop`` does) and,
   as the baseline, every stage on the whole image in float64 (one strip, as every stage ran before)
   at the smaller sizes. Only this table runs when ``--memory`` is given.
F. ``--brightness``: median displayed luminance (sRGB EOTF) of isp's development of the shared RAW
   files against rawpy's default ``postprocess()``, for isp's default tone curve and two alternatives.
"""

from __future__ import annotations

import argparse
import itertools
import os
import statistics
import sys
import time
from pathlib import Path

import colour
import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

import isp  # noqa: E402
import zonotope  # noqa: E402
from isp.simulate import (  # noqa: E402
    chart_image,
    fit_color_matrix,
    simulate_capture,
    simulate_dng,
    spectral_setup,
    true_XYZ,
)

DATA = Path(os.environ.get("ZONOTOPE_SHARED_DATA", ROOT.parent / "shared" / "data"))
D50_xy = colour.CCS_ILLUMINANTS["CIE 1931 2 Degree Standard Observer"]["D50"]
D65_xy = colour.CCS_ILLUMINANTS["CIE 1931 2 Degree Standard Observer"]["D65"]
CAMERAS = [
    "Nikon 5100 (NPL)",
    "Canon EOS 5D Mark II",
    str(DATA / "ssf_rawtoaces/data/camera/Sony_ILCE-7M3_380_780_5.json"),
]

# Hand-measured patch centres (row, column in the visible 1156 × 1734 mosaic) of the classic 24-patch
# chart in tinydng_colorchart_Canon_EOS_Kiss_X4_MagicLantern.dng; patches are ≈ 90 px wide, we
# average a 40 × 40 box around each centre. Row-major in the standard ColorChecker order.
CHART_ROWS = (624, 724, 822, 930)
CHART_COLS = (712, 820, 928, 1035, 1142, 1250)
BOX = 20


def _table(title: str, header: list[str], rows: list[list], fmt: str = "{:>10}") -> None:
    print(f"\n{title}")
    widths = [max(len(str(h)), *(len(str(r[i])) for r in rows)) + 2 for i, h in enumerate(header)]
    print("".join(str(h).rjust(w) for h, w in zip(header, widths)))
    for r in rows:
        print("".join(str(v).rjust(w) for v, w in zip(r, widths)))


def _box_means(image: np.ndarray) -> np.ndarray:
    return np.array(
        [
            image[r - BOX : r + BOX, c - BOX : c + BOX].reshape(-1, image.shape[-1]).mean(0)
            for r in CHART_ROWS
            for c in CHART_COLS
        ]
    )


def bench_rawpy() -> None:
    import dataclasses

    import rawpy

    path = DATA / "raw_samples" / "tinydng_colorchart_Canon_EOS_Kiss_X4_MagicLantern.dng"
    if not path.is_file():
        print("\nA. skipped: real DNG not found")
        return
    raw = isp.read_raw(path)
    ours = isp.develop(raw, demosaic="bilinear", stop_after="XYZ_to_linear_sRGB").image
    refs = {}
    for thr in (0.75, 0.0):  # 0.75 is LibRaw's default: it rescales to the data maximum if > 0.75 white
        with rawpy.imread(str(path)) as r:
            refs[thr] = (
                r.postprocess(
                    demosaic_algorithm=rawpy.DemosaicAlgorithm.LINEAR,
                    use_camera_wb=True,
                    no_auto_bright=True,
                    output_bps=16,
                    gamma=(1, 1),
                    adjust_maximum_thr=thr,
                ).astype(np.float64)
                / 65535
            )
    ref = refs[0.0]
    assert ref.shape == ours.shape, (ref.shape, ours.shape)
    p_ours, p_ref, p_default = _box_means(ours), _box_means(ref), _box_means(refs[0.75])
    # white balance from the chart's neutral patches instead of the file's AsShotNeutral
    cam = isp.develop(
        raw, pipeline=isp.default_pipeline(demosaic="bilinear").remove("white_balance"), stop_after="demosaic"
    ).image
    grey = _box_means(cam)[19:23].mean(0)
    ours_grey = isp.develop(
        dataclasses.replace(raw, as_shot_neutral=grey), demosaic="bilinear", stop_after="XYZ_to_linear_sRGB"
    ).image
    p_grey = _box_means(ours_grey)
    cc = colour.CCS_COLOURCHECKERS["ColorChecker24 - After November 2014"]
    names = list(cc.data)
    XYZ_true = colour.xyY_to_XYZ(np.array(list(cc.data.values())))  # D50 (ICC) reference

    def scaled_XYZ(rgb):  # linear sRGB → XYZ D50, exposure fitted on the Y of the 6 neutral patches
        X = colour.RGB_to_XYZ(rgb, "sRGB", illuminant=D50_xy, chromatic_adaptation_transform="Bradford")
        y, t = X[18:24, 1], XYZ_true[18:24, 1]
        return X * (y @ t) / (y @ y)

    def lab(X):
        return colour.XYZ_to_Lab(X, D50_xy)

    dE_ours = colour.delta_E(lab(scaled_XYZ(p_ours)), lab(XYZ_true), method="CIE 2000")
    dE_ref = colour.delta_E(lab(scaled_XYZ(p_default)), lab(XYZ_true), method="CIE 2000")
    dE_grey = colour.delta_E(lab(scaled_XYZ(p_grey)), lab(XYZ_true), method="CIE 2000")
    X_ref = colour.RGB_to_XYZ(p_ref, "sRGB", illuminant=D50_xy, chromatic_adaptation_transform="Bradford")
    X_ours = colour.RGB_to_XYZ(p_ours, "sRGB", illuminant=D50_xy, chromatic_adaptation_transform="Bradford")
    k = 1.0 / X_ref[18, 1]  # same scale for both: rawpy's white patch at Y = 1
    dE_between = colour.delta_E(lab(k * X_ours), lab(k * X_ref), method="CIE 2000")
    rel = np.abs(p_ours - p_ref).max(axis=1) / np.maximum(p_ref.max(axis=1), 1e-9)
    rows = [
        [
            i + 1,
            names[i][:14],
            *(f"{v:.4f}" for v in p_ours[i]),
            *(f"{v:.4f}" for v in p_ref[i]),
            f"{100 * rel[i]:.2f}",
            f"{dE_between[i]:.2f}",
            f"{dE_ours[i]:.2f}",
            f"{dE_ref[i]:.2f}",
            f"{dE_grey[i]:.2f}",
        ]
        for i in range(24)
    ]
    _table(
        "A. Real 550D DNG, bilinear: ours vs rawpy LINEAR (adjust_maximum_thr=0) linear-sRGB patch "
        "means; ΔE00 vs X-Rite reference (exposure fitted on the neutrals)",
        [
            "#",
            "patch",
            "R ours",
            "G ours",
            "B ours",
            "R rawpy",
            "G rawpy",
            "B rawpy",
            "max|Δ| %",
            "ΔE ours-rawpy",
            "ΔE ours",
            "ΔE rawpy",
            "ΔE ours grey-WB",
        ],
        rows,
    )

    def stats(x):
        return f"{x.mean():.2f}/{np.median(x):.2f}/{x.max():.2f}"

    print(
        f"   mean/median/max ΔE00: ours–rawpy {stats(dE_between)}; vs reference: ours {stats(dE_ours)}, "
        f"rawpy (default call) {stats(dE_ref)}, ours with grey-patch WB {stats(dE_grey)}"
    )
    ratio = np.median(p_default / p_ours)
    print(
        f"   rawpy's prescribed call (adjust_maximum_thr=0.75 default) is brighter by ≈ "
        f"{ratio:.3f} (exactly (15000 − 2056) / (data max 12128 − 2056) = 1.285): LibRaw rescales "
        "to the data maximum."
    )
    full = np.abs(ours - ref)[8:-8, 8:-8]
    print(
        f"   whole image (8 px border excluded): mean |Δ| {full.mean():.5f}, "
        f"99th pct {np.percentile(full, 99):.5f} (values relative to saturation 1)"
    )


def _patch_means(image, labels, n, margin=3):
    out = []
    for k in range(n):
        ys, xs = np.nonzero(labels == k)
        out.append(
            image[ys.min() + margin : ys.max() + 1 - margin, xs.min() + margin : xs.max() + 1 - margin]
            .reshape(-1, image.shape[-1])
            .mean(0)
        )
    return np.array(out)


def _dE(XYZ_est_D65, XYZ_true, white_true):
    D65 = colour.xy_to_XYZ(D65_xy)
    truth = colour.chromatic_adaptation(XYZ_true, white_true, D65, method="Von Kries", transform="Bradford")
    return colour.delta_E(
        colour.XYZ_to_Lab(XYZ_est_D65, D65_xy), colour.XYZ_to_Lab(truth, D65_xy), method="CIE 2000"
    )


def _label(cam: str) -> str:
    return Path(cam).stem.replace("_380_780_5", "") if cam.endswith(".json") else cam


def bench_simulated_chart(tmp: Path, quantum: float = 2e-3) -> None:
    """Table B. ``quantum``: deduplication step of the metamer correction (the CLI's default 2e-3)."""
    rows = []
    train_all = zonotope.reflectances("rawtoaces 190")
    for cam in CAMERAS:
        if cam.endswith(".json") and not Path(cam).is_file():
            continue
        setup = spectral_setup(cam, illuminant="D65")
        R = zonotope.resample(zonotope.reflectances("ColorChecker N Ohta"), setup.wavelengths).T
        image, labels = chart_image(R, rows=4, cols=6, patch=16, gap=4)
        train = zonotope.resample(train_all, setup.wavelengths).T
        cap = simulate_capture(image, setup, training=train)
        raw = isp.read_raw(simulate_dng(tmp / f"{_label(cam)}.dng", cap, overwrite=True))
        runs = [(method, "DNG ColorMatrix", "dng") for method in isp.DEMOSAIC_METHODS]
        label = "metamer Prior" + (f" (quantum {quantum:g})" if quantum != 2e-3 else "")
        runs.append(("Malvar 2004", label, isp.metamer_correction(cam, method="Prior", quantum=quantum)))
        for method, label, correction in runs:
            t0 = time.perf_counter()
            rgb = isp.develop(
                raw, demosaic=method, correction=correction, stop_after="XYZ_to_linear_sRGB"
            ).image
            seconds = time.perf_counter() - t0
            XYZ = colour.RGB_to_XYZ(rgb, "sRGB", illuminant=D65_xy) / cap.exposure
            dE = _dE(_patch_means(XYZ, labels, 24), true_XYZ(R, setup), setup.observer.sum(0))
            rows.append(
                [
                    _label(cam),
                    method,
                    label,
                    f"{dE.mean():.2f}",
                    f"{np.median(dE):.2f}",
                    f"{dE.max():.2f}",
                    f"{seconds:.2f}",
                ]
            )
    _table(
        "B. Simulated ColorChecker (D65, exposure 0.8, shot + read noise, DNG written and read back via "
        "rawpy; ColorMatrix fitted on rawtoaces 190; metamer = isp.metamer_correction as "
        "`isp develop --correction metamer` fits it, default --scene-white 1): ΔE00 vs true colours, "
        "time of the whole development",
        ["camera", "demosaic", "correction", "mean", "median", "max", "s"],
        rows,
    )


def bench_correction(munsell_subset: int | None = None) -> None:
    """Table C. ``munsell_subset``: evaluate every column on that many seeded Munsell chips only."""
    sets = {"ColorChecker": zonotope.reflectances("ColorChecker N Ohta")}
    munsell = DATA / "reflectance_munsell_matte_joensuu_5nm" / "munsell_matte_1269_380_780_5nm.csv"
    subset_note = ""
    if munsell.is_file():
        msds = zonotope.read_reflectances(munsell)
        if munsell_subset and munsell_subset < len(msds.labels):
            keep = np.sort(np.random.default_rng(0).choice(len(msds.labels), munsell_subset, replace=False))
            msds = colour.MultiSpectralDistributions(
                msds.values[:, keep], msds.wavelengths, labels=[msds.labels[i] for i in keep], name=msds.name
            )
            subset_note = f"; --quick: {munsell_subset} of the 1269 Munsell chips, drawn with seed 0"
        sets[f"Munsell matte {len(msds.labels)}"] = msds
    try:
        from zonotope.correct import correction_problem, fit_correction
    except ImportError:  # pragma: no cover
        fit_correction = None
    rows = []
    seconds: dict[str, float] = {}
    fallbacks: dict[str, int] = {}
    for cam in CAMERAS:
        if cam.endswith(".json") and not Path(cam).is_file():
            continue
        setup = spectral_setup(cam, illuminant="D65")
        train = zonotope.resample(zonotope.reflectances("rawtoaces 190"), setup.wavelengths).T
        profile = isp.DNGProfile(color_matrix_1=fit_color_matrix(setup, train), calibration_illuminant_1=21)
        M_dng = isp.matrix_XYZ_from_balanced(profile, setup.neutral)
        bal = (train @ setup.camera) / setup.neutral
        M_ls = np.linalg.lstsq(bal, train @ setup.observer, rcond=None)[0]
        estimators = {"DNG ColorMatrix": None, "LS 3×3 callable": lambda c, M=M_ls: c @ M}
        if fit_correction is not None:
            prob = correction_problem(
                cam if not cam.endswith(".json") else zonotope.read_camera(cam),
                target="CIE 1931 2°",
                illuminant="D65",
                shape=setup.wavelengths,
                training=train,
            )
            estimators["zonotope root-poly"] = fit_correction(prob, method="Finlayson 2015")
            # metamer-based estimators through isp's wrapper (exact colours: quantum 0; a colour
            # whose estimate fails falls back to the regression and is counted)
            for method in ("Prior", "Centroid"):
                estimators[method] = isp.MetamerCorrection(fit_correction(prob, method=method), quantum=0)
            estimators["Prior (CLI fit)"] = isp.metamer_correction(cam, method="Prior", quantum=0)
        for set_name, msds in sets.items():
            R = np.clip(zonotope.resample(msds, setup.wavelengths).T, 0, 1)
            c = (R @ setup.camera) / setup.neutral
            truth = true_XYZ(R, setup)
            row = [_label(cam), set_name]
            for name, fn in estimators.items():
                before = getattr(fn, "fallbacks", 0)
                t0 = time.perf_counter()
                if fn is None:
                    XYZ50 = isp.camera_to_XYZ(c, matrix=M_dng)
                else:
                    XYZ50 = isp.apply_correction(c, XYZ_from_responses=fn)
                seconds[name] = seconds.get(name, 0.0) + time.perf_counter() - t0
                fallbacks[name] = fallbacks.get(name, 0) + getattr(fn, "fallbacks", 0) - before
                rgb = isp.XYZ_to_linear_sRGB(XYZ50)
                est = colour.RGB_to_XYZ(rgb, "sRGB", illuminant=D65_xy)
                if fn is not None:
                    est = est * np.asarray(fn(np.ones((1, 3)))).ravel()[1]
                dE = _dE(est, truth, setup.observer.sum(0))
                row.append(f"{dE.mean():.2f} / {dE.max():.2f}")
            rows.append(row)
    _table(
        "C. Colour correction of white-balanced responses (D65), mean / max ΔE00 vs truth "
        "(all fitted on rawtoaces 190; Prior, Centroid on the simulation's 5 nm grid, "
        f"Prior (CLI fit) on 400–700 nm / 10 nm as `isp develop --correction metamer`){subset_note}",
        ["camera", "set", *estimators],
        rows,
    )
    print(
        "   time (s, all cameras and sets): "
        + ", ".join(f"{name} {t:.2f}" for name, t in seconds.items())
        + "; colours that fell back to the regression: "
        + (", ".join(f"{name} {n}" for name, n in fallbacks.items() if n) or "none")
    )


def _scene(setup, size: int, seed: int, reflectances: np.ndarray, ss: int = 4) -> np.ndarray:
    """Random disks and rectangles of real reflectances, 4× supersampled (anti-aliased edges)."""
    rng = np.random.default_rng(seed)
    n = size * ss
    idx = np.full((n, n), rng.integers(len(reflectances)))
    yy, xx = np.mgrid[0:n, 0:n]
    for _ in range(60):
        k = rng.integers(len(reflectances))
        cy, cx, r = [*rng.uniform(0, n, 2).tolist(), rng.uniform(n / 40, n / 6)]
        if rng.random() < 0.5:
            idx[(yy - cy) ** 2 + (xx - cx) ** 2 < r**2] = k
        else:
            idx[(np.abs(yy - cy) < r) & (np.abs(xx - cx) < r / 2)] = k
    rgb = (reflectances @ setup.camera / setup.neutral)[idx]  # white-balanced camera RGB
    stripes = 0.75 + 0.25 * np.sin(xx / (3.0 * ss) + yy / (7.0 * ss))[..., None]  # fine shading
    return (rgb * stripes).reshape(size, ss, size, ss, 3).mean(axis=(1, 3))


def bench_demosaic(repeats: int, size: int) -> None:
    setup = spectral_setup("Nikon 5100 (NPL)", illuminant="D65")
    refl = np.clip(zonotope.resample(zonotope.reflectances("rawtoaces 190"), setup.wavelengths).T, 0, 1)
    psnr = {m: [] for m in isp.DEMOSAIC_METHODS}
    for seed in range(5):
        truth = _scene(setup, size, seed, refl)
        for cfa in ("RGGB", "GBRG"):
            m = isp.mosaic(truth, cfa=cfa)
            for method in isp.DEMOSAIC_METHODS:
                out = isp.demosaic(m, cfa=cfa, method=method)
                mse = np.mean((out - truth)[4:-4, 4:-4] ** 2)
                psnr[method].append(10 * np.log10(truth.max() ** 2 / mse))
    mosaic = isp.mosaic(_scene(setup, 512, 99, refl), cfa="RGGB")
    rows = []
    for method in isp.DEMOSAIC_METHODS:
        times = []
        for _ in range(repeats):
            t0 = time.perf_counter()
            isp.demosaic(mosaic, cfa="RGGB", method=method)
            times.append(time.perf_counter() - t0)
        ms_per_mp = 1e3 * statistics.median(times) / (mosaic.size / 1e6)
        p = np.array(psnr[method])
        rows.append([method, f"{p.mean():.2f}", f"{p.min():.2f}", f"{p.max():.2f}", f"{ms_per_mp:.0f}"])
    _table(
        f"D. Demosaicing: PSNR (dB) on 10 simulated {size}² scenes of rawtoaces-190 reflectances "
        f"(Nikon 5100, D65, noise-free), time = median of {repeats} on 512²",
        ["method", "PSNR mean", "min", "max", "ms / MP"],
        rows,
    )


_MEMORY_CHILD = """
import resource, sys, time
import numpy as np
import isp
from isp.exif import srgb_icc_profile
from isp.io import write_image
from isp.raw import read_raw
dng, out, mode, path = sys.argv[1:5]
pipeline = isp.default_pipeline()
if path == "metamer":  # as isp develop --correction metamer --camera 'Nikon 5100 (NPL)' builds it
    from isp.metamer import metamer_correction
    from isp.pipeline import correction_stage
    metamer = metamer_correction("Nikon 5100 (NPL)", noise=0.002)
    stage = correction_stage(metamer, reach=getattr(metamer, "reach", None))  # None: the code before strips
    pipeline = pipeline.replace("camera_to_XYZ", stage)
elif path == "dcp":  # as isp develop --profile FILE: matrices, HueSatMap 90x30, LookTable 36x12x8, tone curve
    from isp.profiles.dcp import DCPProfile, profile_pipeline, write_dcp
    from isp.profiles.tone import camera_tone_curve
    rng = np.random.default_rng(0)
    def table(V, H, S):
        t = np.ones((V, H, S, 3))
        t[..., 0] = rng.normal(0, 3, (V, H, S))
        t[..., 1:] += rng.normal(0, 0.03, (V, H, S, 2))
        return t
    cm = np.array([[0.9, -0.3, -0.1], [-0.4, 1.2, 0.2], [-0.1, 0.2, 0.6]])
    fm = np.array([[0.6, 0.25, 0.1], [0.25, 0.7, 0.05], [0.0, 0.1, 0.72]])
    prof = DCPProfile(cm, forward_matrix_1=fm, calibration_illuminant_1=21, hue_sat_map_1=table(1, 90, 30),
                      look_table=table(8, 36, 12), look_table_encoding=1, tone_curve=camera_tone_curve())
    write_dcp(out + ".dcp", prof, overwrite=True)
    pipeline = profile_pipeline(pipeline, out + ".dcp")
rss0 = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
t0 = time.perf_counter()
raw = read_raw(dng)
if mode == "whole":  # one strip: every stage on the whole image in float64, as before strips
    isp._tol.STRIP_PIXELS = 2**62
dev = pipeline(raw, keep=False)
write_image(out, dev.image, overwrite=True, icc_profile=srgb_icc_profile())
print(rss0, resource.getrusage(resource.RUSAGE_SELF).ru_maxrss, time.perf_counter() - t0)
"""


def _synthetic_dng(path: Path, megapixels: float) -> tuple[int, int]:
    """A 3:2 Bayer DNG of smooth colour ramps with noise, written in row blocks (no full float copy)."""
    from isp.dng import write_dng

    W = round((megapixels * 1e6 * 1.5) ** 0.5 / 2) * 2
    H = round(megapixels * 1e6 / W / 2) * 2
    rng = np.random.default_rng(0)
    x = np.linspace(0, 1, W, dtype=np.float32)[None, :]
    m = np.empty((H, W), np.uint16)
    for r0 in range(0, H, 512):
        y = np.linspace(0, 1, H, dtype=np.float32)[r0 : r0 + 512, None]
        block = 64 + 3000 * (0.2 + 0.6 * y * x) + rng.normal(0, 8, (y.shape[0], W))
        m[r0 : r0 + 512] = np.clip(block, 0, 4095).astype(np.uint16)
    cm = np.array([[0.9, -0.3, -0.1], [-0.4, 1.2, 0.2], [-0.1, 0.2, 0.6]])
    write_dng(
        path,
        m,
        cfa="RGGB",
        black_level=64,
        white_level=4095,
        color_matrix_1=cm,
        as_shot_neutral=[0.5, 1.0, 0.7],
        overwrite=True,
    )
    return H, W


def bench_memory(sizes: list[float], paths: list[str], baseline_max: float = 12.0) -> None:
    """Table E: peak RSS of a development per colour path (``plain``: the DNG matrices, ``metamer``:
    ``--correction metamer``, ``dcp``: ``--profile``), strip-wise and (up to ``baseline_max`` MP)
    whole-image."""
    import subprocess
    import tempfile

    rows = []
    with tempfile.TemporaryDirectory(dir="/tmp") as tmp:
        for mp in sizes:
            dng = Path(tmp) / f"{mp:g}MP.dng"
            H, W = _synthetic_dng(dng, mp)
            for path, mode in itertools.product(
                paths, ("strips", "whole") if mp <= baseline_max else ("strips",)
            ):
                out = subprocess.run(
                    [sys.executable, "-c", _MEMORY_CHILD, str(dng), str(Path(tmp) / "out.tif"), mode, path],
                    capture_output=True,
                    text=True,
                    env={**os.environ, "PYTHONPATH": str(ROOT)},
                )
                if out.returncode:
                    error = out.stderr.strip().splitlines()[-1][:60]
                    rows.append([f"{mp:g} ({H}×{W})", path, mode, "failed", "", error])
                    continue
                rss0, rss, seconds = (float(v) for v in out.stdout.split())
                rows.append(
                    [
                        f"{mp:g} ({H}×{W})",
                        path,
                        mode,
                        f"{rss / 1024:.0f}",
                        f"{rss0 / 1024:.0f}",
                        f"{seconds:.1f}",
                    ]
                )
            dng.unlink()
    _table(
        "E. Peak RSS of a development (read + default pipeline + 16-bit TIFF), fresh process each",
        ["MP", "colour path", "stages", "peak MB", "after imports MB", "seconds"],
        rows,
        fmt="{:>16}",
    )


def _rawtherapee_default(path: Path, tmp: Path) -> np.ndarray | None:
    """RawTherapee's default rendering of ``path`` (``rawtherapee-cli -d``, 16-bit sRGB TIFF), or None."""
    import shutil
    import subprocess

    import tifffile

    if shutil.which("rawtherapee-cli") is None:
        return None
    out = tmp / (path.stem + ".tif")
    subprocess.run(
        ["rawtherapee-cli", "-d", "-Y", "-o", str(out), "-t", "-b16", "-c", str(path)],
        capture_output=True,
        check=True,
    )
    return tifffile.imread(out) / 65535.0


def bench_brightness() -> None:
    """Table F: isp's brightness against rawpy's and RawTherapee's default renderings, in stops of
    median displayed luminance (every file decoded with the sRGB EOTF, as a viewer shows it)."""
    import tempfile

    import rawpy

    from isp.profiles.dcp import apply_tone_curve
    from isp.profiles.tone import camera_tone_curve

    Y = np.asarray(colour.RGB_COLOURSPACES["sRGB"].matrix_RGB_to_XYZ[1])
    files = ["tinydng_colorchart_Canon_EOS_Kiss_X4_MagicLantern.dng", "rawsamples_RAW_CANON_D30_SRGB.CRW"]

    def shown(encoded) -> float:
        return float(np.median(colour.models.eotf_sRGB(np.clip(encoded.astype(np.float64), 0, 1)) @ Y))

    rows = []
    for name in files:
        path = DATA / "raw_samples" / name
        if not path.is_file():
            print(f"F. skipped: {path} not present")
            return
        raw = isp.read_raw(path)
        with rawpy.imread(str(path)) as r:  # rawpy's default postprocess(), 8 bits
            ref = shown(r.postprocess(user_flip=0) / 255.0)
        with tempfile.TemporaryDirectory() as tmp:
            rt = _rawtherapee_default(path, Path(tmp))
        rt_stops = "n/a" if rt is None else f"{np.log2(shown(rt) / ref):+.2f}"

        def stops(image, ref=ref) -> str:
            return f"{np.log2(shown(image) / ref):+.2f}"

        def develop(raw=raw, **options):
            return isp.default_pipeline(**options)(raw, keep=False).image

        reinhard = develop(tonemap="Reinhard 2002")
        bright = develop(tonemap="auto-bright", encode=False)
        curved = isp.encode_sRGB(apply_tone_curve(bright, camera_tone_curve()))
        rows.append(
            [
                name[:28],
                raw.white_balance_source,
                rt_stops,
                stops(reinhard),
                stops(develop(tonemap_options={"key": None}, tonemap="Reinhard 2002")),
                stops(isp.encode_sRGB(bright)),
                stops(curved),
            ]
        )
    _table(
        "F. Median displayed luminance against rawpy's default postprocess (stops; RT = RawTherapee -d)",
        ["file", "white", "RT default", "Reinhard 0.18", "key None", "auto-bright", "+ tone curve"],
        rows,
        fmt="{:>14}",
    )


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=5)
    parser.add_argument(
        "--quick",
        action="store_true",
        help="smaller demosaic scenes, coarser colour deduplication of the metamer "
        "correction in table B, 200 of the Munsell chips in table C",
    )
    parser.add_argument(
        "--memory",
        type=float,
        nargs="*",
        metavar="MP",
        help="only table E, at these sizes in megapixels (default 6 60); whole-image baseline up to 12 MP",
    )
    parser.add_argument(
        "--paths",
        nargs="+",
        default=["plain"],
        choices=["plain", "metamer", "dcp"],
        help="colour paths of table E: plain (DNG matrices), metamer (--correction metamer), dcp (--profile)",
    )
    parser.add_argument("--brightness", action="store_true", help="only table F (shared data)")
    args = parser.parse_args()
    import tempfile

    t0 = time.perf_counter()
    if args.brightness:
        bench_brightness()
        return
    if args.memory is not None:
        bench_memory(args.memory or [6.0, 60.0], args.paths)
        print(f"\ntotal {time.perf_counter() - t0:.0f} s")
        return
    bench_rawpy()
    with tempfile.TemporaryDirectory() as tmp:
        bench_simulated_chart(Path(tmp), quantum=1e-2 if args.quick else 2e-3)
    bench_correction(munsell_subset=200 if args.quick else None)
    bench_demosaic(max(args.repeats, 5), 128 if args.quick else 256)
    print(f"\ntotal {time.perf_counter() - t0:.0f} s")


if __name__ == "__main__":
    main()
