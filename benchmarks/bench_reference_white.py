"""Benchmark: the white of a regression fitted from a scene light to a reference light.

A regression fitted scene light → reference light maps the perfect white to the reference white only in
least squares. For one Nikon 5100 and each scene light, this prints the chroma C*ab of the estimated
white (CIELAB relative to the reference white) and the mean ΔE00 of the ColorChecker (held out) and of
the training set (rawtoaces 190) as fitted, and after a CAT02 adaptation of the estimated white to the
reference white (what ``isp develop`` does with any correction). 400–700 nm / 10 nm, noise-free.

    python benchmarks/bench_reference_white.py
"""

from __future__ import annotations

import warnings

import colour
import numpy as np

import zonotope
from zonotope.correct import correction_problem, fit_correction

CAMERA = "Nikon 5100 (NPL)"
GRID = np.arange(400, 701, 10.0)
LIGHTS = [("A", "D65"), ("A", None), ("D65", None), ("FL2", "D65"), ("LED-B3", "D65")]


def main() -> None:
    warnings.filterwarnings("ignore")
    print("| set | scene → reference | estimator | white C*ab | mean ΔE00 | after white CAT02 |")
    print("|---|---|---|---|---|---|")
    for name in ("ColorChecker N Ohta", "rawtoaces 190"):
        R = zonotope.resample(zonotope.reflectances(name), GRID).T
        for scene, ref in LIGHTS:
            p = correction_problem(CAMERA, illuminant=scene, reference=ref, shape=GRID)
            c, t = R @ p.Phi, R @ p.Psi
            for method in ("Finlayson 2015", "Cheung 2004"):
                est = fit_correction(p, method=method)
                out, white = est(c), est(np.ones((1, 3)))[0]
                M = colour.adaptation.matrix_chromatic_adaptation_VonKries(
                    white, p.white_XYZ, transform="CAT02"
                )
                chroma = float(np.hypot(*p.to_Lab(white)[1:]))
                print(
                    f"| {name} | {scene} → {ref or scene} | {method} | {chroma:.2f} | "
                    f"{p.delta_E(out, t).mean():.2f} | {p.delta_E(out @ M.T, t).mean():.2f} |"
                )


if __name__ == "__main__":
    main()
