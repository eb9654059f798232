"""Spectral sensitivity estimation, measured leave-one-camera-out over every measured camera.

For each measured camera (rawtoaces, camspec, NPL, the Butcher spectroscope set; duplicates of one
model grouped): learn the basis without any measurement of that model, synthesise the DNG matrices a
converter would write from its measured curves (:func:`synthesise_dng_matrices`: A and D65 on the 24
ColorChecker patches), estimate its curves from those matrices (and from a simulated chart photo),
and compare with the measurement: RMSE and angle per channel, Vora value error, and the ΔE00 of
colour correction fitted on the estimated curves but applied to the measured camera's responses,
against the same correction fitted on the measured curves (the baseline a user with a measured camera
would get).

    python benchmarks/bench_ssf.py --data ../shared/data            # the table of docs/benchmarks.md
    python benchmarks/bench_ssf.py --data ../shared/data --write-basis zonotope/spectra/data/ssf_basis.json

``--write-basis`` regenerates the basis shipped with the package from the cameras whose licence allows
redistribution: rawtoaces (Apache-2.0) and colour-science's NPL Nikon D5100 (BSD-3); camspec and the
Butcher set (CC BY-NC-SA 4.0) are only evaluated, never shipped.
"""

from __future__ import annotations

import argparse
import re
import sys
import time
from pathlib import Path

import colour
import numpy as np

import zonotope
from zonotope.spectra import builtin as spectra
from zonotope.spectra.estimate import (
    SSF_SHAPE,
    Chart,
    SSFBasis,
    estimate_ssf,
    learn_ssf_basis,
    synthesise_dng_matrices,
)

W = np.asarray(SSF_SHAPE.wavelengths)

#: Licence statement stored with the shipped basis.
LICENCE = (
    "Derived from rawtoaces-data (AcademySoftwareFoundation/rawtoaces-data, Apache-2.0; 52 cameras by "
    "wetadigital, scitech/AMPAS and J. Irons) and colour-science's NPL Nikon D5100 (Darrodi et al. 2015, "
    "BSD-3-Clause). Redistributed under those terms."
)


def _model_key(name: str) -> str:
    """Make + model reduced so that one model measured by several sets groups together."""
    k = re.sub(r"[^0-9a-z]+", "", name.lower())
    for a, b in (("eos", ""), ("markiii", "mk3"), ("markii", "mk2"), ("mark", "mk"), ("nikond", "nikon")):
        k = k.replace(a, b)
    k = k.replace("npl", "").replace("5100", "d5100") if "nikon" in k else k
    return k.replace("nikond5100", "nikon5100").replace("nikon5100", "nikond5100")


def measured_cameras(data: Path | None) -> dict[str, dict]:
    """Every measured RGB camera on the 400–700/10 nm grid: name → {values, set, model, redistributable}."""
    out: dict[str, dict] = {}

    def add(name: str, msds, dataset: str, redistributable: bool) -> None:
        try:
            values = spectra.resample(msds, W)
        except zonotope.SpectralDataError:
            return  # not measured over 400–700 nm (the Sigma Foveon stops at 680 nm)
        if values.shape[1] != 3:
            return
        out[f"{name} ({dataset})"] = {
            "values": values / values.max(),
            "set": dataset,
            "model": _model_key(name),
            "redistributable": redistributable,
        }

    add("Nikon D5100", colour.MSDS_CAMERA_SENSITIVITIES["Nikon 5100 (NPL)"], "NPL", True)
    if data is None:
        return out
    for f in sorted((data / "ssf_rawtoaces" / "data" / "camera").glob("*.json")):
        m = zonotope.load_camera(f)
        add(m.name, m, "rawtoaces", True)
    for d in sorted((data / "ssf_jiang2013_camspec").iterdir()):
        for f in d.glob("*.csv"):
            add(d.name.replace("_", " "), zonotope.load_camera(f), "camspec", False)
    for d in sorted((data / "ssf_butcher_spectroscope").iterdir()):
        for f in d.glob("*_ssf.csv"):
            add(d.name.replace("_", " "), zonotope.load_camera(f), "spectroscope", False)
    return out


def basis_without(
    cams: dict[str, dict], model: str | None, *, redistributable_only: bool, k: int
) -> SSFBasis:
    pool = {
        n: c["values"]
        for n, c in cams.items()
        if c["model"] != model
        and (c["redistributable"] or not redistributable_only)
        and c["set"] != "spectroscope"
    }
    return learn_ssf_basis(pool, n_components=k)


def angle(a: np.ndarray, b: np.ndarray) -> float:
    cos = a @ b / (np.linalg.norm(a) * np.linalg.norm(b))
    return float(np.degrees(np.arccos(np.clip(cos, -1, 1))))


def curve_errors(est: np.ndarray, true: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """RMSE (curves with peak 1 each, per channel) and angle (degrees) per channel."""
    e = est / est.max(axis=0)
    t = true / true.max(axis=0)
    return np.sqrt(np.mean((e - t) ** 2, axis=0)), np.array([angle(e[:, c], t[:, c]) for c in range(3)])


def msds(values: np.ndarray, name: str) -> colour.MultiSpectralDistributions:
    return colour.MultiSpectralDistributions(values, W, labels=["red", "green", "blue"], name=name)


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--data", type=Path, help="folder laid out like ../shared/data")
    p.add_argument("--write-basis", type=Path, help="write the shipped basis JSON here and stop")
    p.add_argument("--components", type=int, default=5)
    p.add_argument("--limit", type=int, help="only the first N held-out cameras (quick runs)")
    p.add_argument("--sets", type=int, default=20, help="random 2- and 3-camera sets (each size)")
    p.add_argument("--seed", type=int, default=0)
    args = p.parse_args(argv)
    cams = measured_cameras(args.data)
    print(f"{len(cams)} measured cameras, {len({c['model'] for c in cams.values()})} models", file=sys.stderr)
    if args.write_basis:
        return write_basis(cams, args.write_basis, args.components)
    t0 = time.perf_counter()
    held = list(cams)[: args.limit] if args.limit else list(cams)
    est = estimates(cams, held, args.components)
    t_est = time.perf_counter() - t0
    print_curve_table(cams, est)
    print(f"\n{len(held)} cameras estimated in {t_est:.1f} s (every path)", file=sys.stderr)
    t0 = time.perf_counter()
    print_correction_table(cams, est, args.data, seed=args.seed, n_sets=args.sets)
    print(f"correction table in {time.perf_counter() - t0:.1f} s", file=sys.stderr)
    return 0


#: The estimates compared, in table order: name → what it uses.
PATHS = {
    "mean camera (no data)": "the mean of the basis cameras, peak-normalised per channel",
    "DNG matrices": "estimate_ssf(DNG matrices)",
    "chart, colour Jiang 2013": "colour.recovery's Jiang et al. 2013, 3 PCA components of the same cameras",
    "chart": "estimate_ssf(chart=...)",
    "DNG + chart": "estimate_ssf(DNG, chart=...)",
}


def simulated_chart(values: np.ndarray, *, sigma: float = 0.0, seed: int = 0) -> np.ndarray:
    """Raw patch means of the 24-patch ColorChecker under D65, the brightest channel at 0.8 of saturation."""
    R = spectra.resample(zonotope.reflectances("ColorChecker N Ohta"), W).T
    E = spectra.resample(zonotope.illuminant("D65"), W)[:, 0]
    C = (R * E) @ values
    C = 0.8 * C / C.max()
    if sigma:
        C = C + sigma * np.random.default_rng(seed).standard_normal(C.shape)
    return C


def jiang2013(C: np.ndarray, pool: dict[str, np.ndarray], k: int = 3, *, light: str = "D65") -> np.ndarray:
    """colour-science's Jiang et al. (2013) recovery with a PCA basis of the same training cameras."""
    from colour.recovery import PCA_Jiang2013, RGB_to_msds_camera_sensitivities_Jiang2013

    basis = PCA_Jiang2013({n: msds(v, n) for n, v in pool.items()}, k)
    refl = colour.MultiSpectralDistributions(
        spectra.resample(zonotope.reflectances("ColorChecker N Ohta"), W), W, name="chart"
    )
    light = colour.SpectralDistribution(spectra.resample(zonotope.illuminant(light), W)[:, 0], W)
    import warnings

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        out = RGB_to_msds_camera_sensitivities_Jiang2013(
            C, light, refl, np.transpose(np.stack(basis, axis=-1), (1, 0, 2)), SSF_SHAPE
        )
    return np.asarray(out.values)


#: Held-out camera → the fully correlated response σ bound of its DNG estimate (response_sigma(bound=True)).
SIGMA: dict[str, np.ndarray] = {}


def estimates(cams: dict[str, dict], held: list[str], k: int) -> dict[str, dict[str, np.ndarray]]:
    """Every path's estimate of every held-out camera, the basis learned without its model."""
    out: dict[str, dict[str, np.ndarray]] = {p: {} for p in PATHS}
    for name in held:
        cam = cams[name]
        basis = basis_without(cams, cam["model"], redistributable_only=True, k=k)
        pool = {n: c["values"] for n, c in cams.items() if n in basis.sources}
        mean = np.mean([v / v.max(axis=0) for v in pool.values()], axis=0)
        dng = synthesise_dng_matrices(msds(cam["values"], name))
        C = simulated_chart(cam["values"])
        chart = Chart(C)
        out["mean camera (no data)"][name] = mean
        e = estimate_ssf(dng, basis=basis)
        out["DNG matrices"][name] = e.values
        SIGMA[name] = e.response_sigma(bound=True)
        out["chart, colour Jiang 2013"][name] = np.maximum(jiang2013(C, pool), 0.0)
        out["chart"][name] = estimate_ssf(chart=chart, basis=basis).values
        out["DNG + chart"][name] = estimate_ssf(dng, chart=chart, basis=basis).values
    return out


def vora(values: np.ndarray) -> float:
    from zonotope.vora import vora_value

    E = spectra.resample(zonotope.illuminant("D65"), W)[:, 0]
    X = spectra.resample(zonotope.observer("CIE 1931 2°"), W)
    return vora_value(values * E[:, None], X * E[:, None])


def print_curve_table(cams: dict[str, dict], est: dict[str, dict[str, np.ndarray]]) -> None:
    names = list(next(iter(est.values())))
    print(f"\nSSF error over {len(names)} held-out cameras (basis learned without the camera's model; curves")
    print(
        "peak-normalised per channel). Mean over cameras; Vora value error |v(est) − v(measured)|"
        " vs CIE 1931 under D65.\n"
    )
    print(
        "| estimate | RMSE R | RMSE G | RMSE B | angle R (°) | angle G (°) | angle B (°) | Vora error "
        "| within ±2σ |"
    )
    print("|---|---|---|---|---|---|---|---|---|")
    for path, by_cam in est.items():
        rm, an, dv, cover = [], [], [], []
        for name, e in by_cam.items():
            t = cams[name]["values"]
            r, a = curve_errors(e, t)
            rm.append(r)
            an.append(a)
            dv.append(abs(vora(e) - vora(t)))
            if path in ("DNG matrices", "chart", "DNG + chart"):
                band = 2 * zonotope.spectra.ssf_basis().spread  # peak-1 curves: the shipped band
                cover.append(np.mean(np.abs(e / e.max(axis=0) - t / t.max(axis=0)) <= band))
        rm, an = np.mean(rm, axis=0), np.mean(an, axis=0)
        cv = f"{100 * np.mean(cover):.0f} %" if cover else "–"
        print(
            f"| {path} | {rm[0]:.4f} | {rm[1]:.4f} | {rm[2]:.4f} | {an[0]:.2f} | {an[1]:.2f} | {an[2]:.2f} "
            f"| {np.mean(dv):.4f} | {cv} |"
        )
    # two measurements of one model: how far apart measured curves of one model are
    groups: dict[str, list[str]] = {}
    for n, c in cams.items():
        groups.setdefault(c["model"], []).append(n)
    rm, an = [], []
    for members in groups.values():
        for i in range(len(members)):
            for j in range(i + 1, len(members)):
                a, b = cams[members[i]]["values"], cams[members[j]]["values"]
                if np.allclose(a, b):
                    continue  # the same measurement shipped twice
                r, g = curve_errors(a, b)
                rm.append(r)
                an.append(g)
    if rm:
        n_pairs = len(rm)
        rm, an = np.mean(rm, axis=0), np.mean(an, axis=0)
        print(
            f"| two measurements of one model ({n_pairs} pairs) | {rm[0]:.4f} | {rm[1]:.4f} | "
            f"{rm[2]:.4f} | {an[0]:.2f} | {an[1]:.2f} | {an[2]:.2f} | – | – |"
        )


def print_correction_table(cams, est, data: Path | None, *, seed: int, n_sets: int) -> None:
    """ΔE00 of corrections fitted on estimated curves, applied to the measured camera's responses."""
    from zonotope.correct import correction_problem, fit_correction, noise_options
    from zonotope.evaluate import atypical_test_sets, natural_test_sets

    names = list(next(iter(est.values())))
    rng = np.random.default_rng(seed)
    sets = [[n] for n in names]
    for size in (2, 3):
        for _ in range(n_sets):
            pick = list(rng.choice(names, size, replace=False))
            if len({cams[n]["model"] for n in pick}) == size:
                sets.append(pick)
    tests = natural_test_sets(W, data_dir=data, size=150, seed=seed) + atypical_test_sets(W, 100, seed=seed)
    methods = ("Cheung 2004", "Finlayson 2015")
    paths = ("measured", "DNG matrices", "DNG, band σ", "chart", "DNG + chart", "mean camera (no data)")
    acc: dict = {}
    for cam_set in sets:
        truth = correction_problem([msds(cams[n]["values"], n) for n in cam_set], shape=SSF_SHAPE)
        for path in paths:
            source = "DNG matrices" if path == "DNG, band σ" else path
            curves = [cams[n]["values"] if path == "measured" else est[source][n] for n in cam_set]
            problem = correction_problem(
                [msds(v, n) for v, n in zip(curves, cam_set, strict=True)], shape=SSF_SHAPE
            )
            band = np.concatenate([SIGMA[n] for n in cam_set]) if path == "DNG, band σ" else 0.0
            for sigma in (0.0, 0.005):
                told = float(np.sqrt(sigma**2 + np.mean(np.square(band))))  # the fit is told the band σ too
                for m in methods:
                    fit = fit_correction(problem, method=m, **(noise_options(m, told) if told else {}))
                    for ts in tests:
                        C = truth.source_of(ts.reflectances)
                        if sigma:
                            C = C + sigma * np.random.default_rng([seed, len(cam_set)]).standard_normal(
                                C.shape
                            )
                        dE = truth.delta_E(fit(C), truth.target_of(ts.reflectances))
                        key = (len(cam_set), ts.kind, sigma, m, path)
                        acc.setdefault(key, []).append(float(np.mean(dE)))
    print(
        "\nCorrection ΔE00 (mean over test spectra, then over camera sets) with curves fitted on measured vs"
    )
    print(
        "estimated sensitivities, applied to the measured camera's responses. Natural: ColorChecker, CIE TCS,"
    )
    print("NIST CQS, Munsell, SFU Krinov/Vrhel, CIE 224 CES; atypical: both generators (100 each).\n")
    print(
        "| cameras | sets | test | σ | method | measured | DNG matrices | DNG, fit told the band σ | chart "
        "| DNG + chart | mean camera |"
    )
    print("|---|---|---|---|---|---|---|---|---|---|---|")
    for size in (1, 2, 3):
        for kind in ("natural", "atypical"):
            for sigma in (0.0, 0.005):
                for m in methods:
                    row = [np.mean(acc[size, kind, sigma, m, p]) for p in paths]
                    n = len(acc[size, kind, sigma, m, "measured"]) // sum(t.kind == kind for t in tests)
                    cells = " | ".join(
                        f"{v:.3f}" if i == 0 else f"{v:.3f} ({v - row[0]:+.3f})" for i, v in enumerate(row)
                    )
                    print(f"| {size} | {n} | {kind} | {sigma:g} | {m} | {cells} |")


def loo_errors(cams: dict[str, dict], k: int, *, redistributable_only: bool) -> dict[str, tuple]:
    """Held-out camera → (DNG-path estimate, measured curves), basis learned without its model."""
    out = {}
    for name, cam in cams.items():
        if redistributable_only and not cam["redistributable"]:
            continue
        basis = basis_without(cams, cam["model"], redistributable_only=redistributable_only, k=k)
        dng = synthesise_dng_matrices(msds(cam["values"], name))
        out[name] = (estimate_ssf(dng, basis=basis), cam["values"])
    return out


def calibrate_band(held: dict[str, tuple], spread: np.ndarray) -> tuple[float, np.ndarray]:
    """(band_k, response_scale) of a band ``spread`` over held-out estimates (leave one model out).

    band_k: the SSF_BAND_COVERAGE quantile of |estimate − measured| / spread (peak-1 curves) over every
    wavelength, channel and camera. response_scale: per channel, the RMS over cameras of the real
    white-balanced response error (D65, rawtoaces 190) over the RMS of the fully correlated bound.
    """
    import dataclasses

    from zonotope._tol import SSF_BAND_COVERAGE
    from zonotope.correct import correction_problem

    ratios, real, bound = [], [], []
    for name, (e, t) in held.items():
        ratios.append(np.abs(e.values / e.values.max(axis=0) - t / t.max(axis=0)) / spread)
        pe = correction_problem(e.sensitivities, shape=SSF_SHAPE)
        pt = correction_problem(msds(t, name), shape=SSF_SHAPE)
        real.append(pt.source_of(pt.training) - pe.source_of(pe.training))
        u = dataclasses.replace(e, uncertainty=spread * e.values.max(axis=0, keepdims=True))
        bound.append(u.response_sigma(bound=True))
    band_k = float(np.quantile(np.concatenate([r.ravel() for r in ratios]), SSF_BAND_COVERAGE))
    scale = np.sqrt(np.mean(np.square(np.concatenate(real)), axis=0)) / np.sqrt(
        np.mean(np.square(bound), axis=0)
    )
    return band_k, scale


def held_out_spread(held: dict) -> np.ndarray:
    """The RMS over held-out cameras of (estimate − measured curve), each at peak 1, per wavelength and
    channel: the ``spread`` of a basis or a calibration, from ``held`` (name → (estimate, measured))."""
    errs = [e.values / e.values.max(axis=0) - t / t.max(axis=0) for e, t in held.values()]
    return np.sqrt(np.mean(np.square(errs), axis=0))


def write_basis(cams: dict[str, dict], path: Path, k: int) -> int:
    t0 = time.perf_counter()
    held = loo_errors(cams, k, redistributable_only=True)
    spread = held_out_spread(held)
    band_k, scale = calibrate_band(held, spread)
    pool = {n: c["values"] for n, c in cams.items() if c["redistributable"]}
    basis = learn_ssf_basis(
        pool, n_components=k, spread=spread, licence=LICENCE, band_k=band_k, response_scale=scale
    )
    import json

    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(json.dumps(basis.to_json(), indent=1) + "\n", encoding="utf-8")
    print(
        f"wrote {path}: {len(pool)} cameras, {k} components, band_k {band_k:.3f}, response_scale "
        f"{np.round(scale, 3).tolist()} ({time.perf_counter() - t0:.1f} s)",
        file=sys.stderr,
    )
    return 0


if __name__ == "__main__":
    sys.exit(main())
