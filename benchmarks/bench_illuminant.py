"""Benchmark: colours of a scene under another light as under a reference light (D65).

For each scene light (A, FL2, FL11, the CIE LED-B3 phosphor LED, D50) and each camera set (one
camera, two stacked), the cameras' white-balanced responses under the scene light are mapped to
CIE 2015 2° XYZ **as under D65** and compared with the truth (the reflectance's XYZ under D65) in
ΔE00 relative to the D65 white:

- *ours*: estimators fitted straight from scene light to reference light,
  ``correction_problem(cams, illuminant=L, reference="D65")`` + ``fit_correction`` (the registry's
  least-squares matrix, root-polynomial, ``Prior`` and MMV ``Centroid``, unchanged);
- *baselines* (the conventional pipeline): the per-light 3×3 least-squares matrix (or the per-light
  root-polynomial, the stronger one) to XYZ under L, then a chromatic adaptation L white → D65
  white with ``colour.chromatic_adaptation`` (von Kries in Hunt-Pointer-Estevez cones, CAT02,
  CAT16).

Training: rawtoaces 190 (the library default). Test sets: the built-in natural sets (ColorChecker,
CIE 1995 TCS, NIST CQS; Munsell matte and SFU Krinov/Vrhel from ../shared/data when present) with
spectra near a training spectrum removed (``zonotope.evaluate.source_split``), and the two atypical
sets (``atypical_test_sets``). Mean and 95th percentile ΔE00 pooled per kind. Noise-free responses;
400–700 nm / 10 nm.

Run: ``python benchmarks/bench_illuminant.py [--lights A FL2 FL11 LED-B3 D50] [--atypical 150]
[--no-prior]``
"""

from __future__ import annotations

import argparse
import os
import time
from pathlib import Path

import colour
import numpy as np

from zonotope.correct import correction_problem, fit_correction
from zonotope.evaluate import atypical_test_sets, natural_test_sets, source_split

DATA = Path(os.environ.get("ZONOTOPE_SHARED_DATA", Path(__file__).resolve().parents[2] / "shared" / "data"))
GRID = np.arange(400.0, 701.0, 10.0)
REFERENCE = "D65"
CAMERA_SETS = (("Nikon 5100 (NPL)",), ("Nikon 5100 (NPL)", "Canon EOS 5D Mark II"))
CATS = (("von Kries", "Von Kries"), ("CAT02", "CAT02"), ("CAT16", "CAT16"))


def _stats(dE: np.ndarray) -> str:
    return f"{np.mean(dE):5.2f} / {np.percentile(dE, 95):5.2f}"


def run(lights, n_atypical: int, prior: bool) -> None:
    data = DATA if DATA.is_dir() else None
    for cams in CAMERA_SETS:
        label = " + ".join(cams)
        print(f"\n## {label}: scene light → {REFERENCE}, mean / p95 ΔE00")
        ours = ["Cheung 2004", "Finlayson 2015", "Centroid"] + (["Prior"] if prior else [])
        base = [f"3×3 + {name}" for name, _ in CATS] + ["root-poly + CAT16"]
        cols = ours + base
        print("| light | kind | " + " | ".join(f"{c}" for c in cols) + " |")
        print("|---|---|" + "---|" * len(cols))
        for light in lights:
            t0 = time.perf_counter()
            ref = correction_problem(list(cams), illuminant=light, reference=REFERENCE, shape=GRID)
            scene = correction_problem(list(cams), illuminant=light, shape=GRID)
            sets = {
                "natural": source_split(natural_test_sets(GRID, data_dir=data), ref.training)[0],
                "atypical": atypical_test_sets(GRID, n_atypical),
            }
            estimators = {}
            for m in ours:
                opts = {"eps": 1e-3} if m == "Centroid" else {}
                estimators[m] = fit_correction(ref, method=m, **opts)
            per_light = {m: fit_correction(scene, method=m) for m in ("Cheung 2004", "Finlayson 2015")}
            for kind, test_sets in sets.items():
                X = np.concatenate([t.reflectances for t in test_sets])
                C, truth = ref.source_of(X), ref.target_of(X)
                cells = []
                for m in ours:
                    cells.append(_stats(ref.delta_E(estimators[m](C), truth)))
                for _, transform in CATS:
                    xyz = colour.chromatic_adaptation(
                        per_light["Cheung 2004"](C),
                        scene.white_XYZ,
                        ref.white_XYZ,
                        method="Von Kries",
                        transform=transform,
                    )
                    cells.append(_stats(ref.delta_E(xyz, truth)))
                xyz = colour.chromatic_adaptation(
                    per_light["Finlayson 2015"](C),
                    scene.white_XYZ,
                    ref.white_XYZ,
                    method="Von Kries",
                    transform="CAT16",
                )
                cells.append(_stats(ref.delta_E(xyz, truth)))
                print(f"| {light} | {kind} ({X.shape[0]}) | " + " | ".join(cells) + " |")
            print(f"<!-- {light}: {time.perf_counter() - t0:.1f} s -->")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--lights", nargs="+", default=["A", "FL2", "FL11", "LED-B3", "D50"])
    ap.add_argument("--atypical", type=int, default=150, help="spectra per atypical set (two sets)")
    ap.add_argument("--no-prior", action="store_true", help="skip the Prior estimator (the slowest fit)")
    args = ap.parse_args()
    run(args.lights, args.atypical, not args.no_prior)


if __name__ == "__main__":
    main()
