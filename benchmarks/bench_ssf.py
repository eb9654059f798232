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
    args = p.parse_args(argv)
    cams = measured_cameras(args.data)
    print(f"{len(cams)} measured cameras, {len({c['model'] for c in cams.values()})} models", file=sys.stderr)
    if args.write_basis:
        return write_basis(cams, args.write_basis, args.components)
    return 0


def loo_spread(cams: dict[str, dict], k: int, *, redistributable_only: bool) -> np.ndarray:
    """RMS per wavelength of (estimate − truth), peak-1 curves, DNG path, over held-out cameras."""
    errs = []
    for name, cam in cams.items():
        if redistributable_only and not cam["redistributable"]:
            continue
        basis = basis_without(cams, cam["model"], redistributable_only=redistributable_only, k=k)
        dng = synthesise_dng_matrices(msds(cam["values"], name))
        est = estimate_ssf(dng, basis=basis).values
        t = cam["values"]
        errs.append(est / est.max(axis=0) - t / t.max(axis=0))
    return np.sqrt(np.mean(np.square(errs), axis=0))


def write_basis(cams: dict[str, dict], path: Path, k: int) -> int:
    t0 = time.perf_counter()
    spread = loo_spread(cams, k, redistributable_only=True)
    pool = {n: c["values"] for n, c in cams.items() if c["redistributable"]}
    basis = learn_ssf_basis(pool, n_components=k, spread=spread, licence=LICENCE)
    import json

    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(json.dumps(basis.to_json(), indent=1) + "\n", encoding="utf-8")
    print(
        f"wrote {path}: {len(pool)} cameras, {k} components ({time.perf_counter() - t0:.1f} s)",
        file=sys.stderr,
    )
    return 0


if __name__ == "__main__":
    sys.exit(main())
