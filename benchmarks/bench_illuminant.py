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

``--estimate N``: the scene light unknown. N scenes per true light (A, FL2, FL11, LED-B3, D50), each
40 natural surfaces (the natural sets above) in raw responses (exposure 0.3–1, noise σ 0.002 of the
white), 400–680 nm / 10 nm so that 1, 2 and 3 cameras (Nikon, + Canon, + Sigma) can be stacked. The
light is chosen among 43 candidates (daylight locus, Planckian, CIE F, CIE LED; A and D50 are not
among them) by ``zonotope.spectra.illuminant_estimate.estimate_illuminant`` (maximum likelihood under
a Gaussian reflectance prior) against grey-world and white-patch (max-RGB) estimates of the white, raw
and snapped to the nearest candidate by angle over all stacked channels. Angular error of camera 1's
white (degrees); then the ΔE00 to D65 of the pipeline "white-balance by the estimated white, apply the
root-polynomial fitted for the chosen candidate → D65" (the exposure is taken as known, so the ΔE is
that of the light estimate alone), against the same pipeline with the true light. Grey-edge needs the
spatial layout of an image and is not run on sets of surfaces.

Run: ``python benchmarks/bench_illuminant.py [--lights A FL2 FL11 LED-B3 D50] [--atypical 150]
[--no-prior]`` or ``python benchmarks/bench_illuminant.py --estimate 10``
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
NOISE = 0.002  # raw response noise σ of the unknown-light scenes (white mean = 1)
CAMERA_SETS = (("Nikon 5100 (NPL)",), ("Nikon 5100 (NPL)", "Canon EOS 5D Mark II"))
METHODS_ESTIMATE = ("ML (ours)", "grey-world", "grey-world → cand.", "white-patch", "white-patch → cand.")
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


def _angle(a: np.ndarray, b: np.ndarray) -> float:
    cos = float(a @ b / (np.linalg.norm(a) * np.linalg.norm(b)))
    return float(np.degrees(np.arccos(np.clip(cos, -1.0, 1.0))))


def run_estimate(n_scenes: int, lights) -> None:
    from zonotope.spectra.illuminant_estimate import candidate_illuminants

    grid = np.arange(400.0, 681.0, 10.0)
    data = DATA if DATA.is_dir() else None
    X_all = np.concatenate([t.reflectances for t in natural_test_sets(grid, data_dir=data)])
    cands = candidate_illuminants()
    cam_sets = (
        ["Nikon 5100 (NPL)"],
        ["Nikon 5100 (NPL)", "Canon EOS 5D Mark II"],
        ["Nikon 5100 (NPL)", "Canon EOS 5D Mark II", "Sigma SDMerill (NPL)"],
    )
    methods = METHODS_ESTIMATE
    print(f"\n## unknown scene light: {n_scenes} scenes × {len(lights)} lights, 40 surfaces each")
    print("angular error of camera 1's white, mean / median (degrees); ΔE00 to D65 mean / p95")
    print(
        "| cameras | "
        + " | ".join(methods)
        + " | ΔE00: ML | ΔE00: grey-world | ΔE00: white-patch | ΔE00: true light |"
    )
    print("|---|" + "---|" * (len(methods) + 4))
    for cams in cam_sets:
        ang, dE = _estimate_cameras(cams, lights, n_scenes, grid, X_all, cands)
        cells = [f"{np.mean(ang[m]):5.2f} / {np.median(ang[m]):5.2f}" for m in ang]
        cells += [_stats(np.concatenate(dE[m])) for m in dE]
        print(f"| {' + '.join(c.split(' (')[0] for c in cams)} | " + " | ".join(cells) + " |")


def _estimate_cameras(cams, lights, n_scenes, grid, X_all, cands):
    """Angular errors and ΔE00 of every estimate for one camera set (see the module notes)."""
    from zonotope import generators, illuminant
    from zonotope.spectra.illuminant_estimate import estimate_illuminant, grey_world, white_patch

    k, names = 3 * len(cams), list(cands)

    def white(light):
        G = np.asarray(generators(cams, light, grid, normalise=None).values)
        return G / G.sum(axis=0).mean()

    cand_white = {n: white(cands[n]).sum(axis=0) for n in names}
    fitted: dict = {}

    def corrector(name):
        if name not in fitted:
            light = cands[name] if name in cands else illuminant(name)
            prob = correction_problem(cams, illuminant=light, reference=REFERENCE, shape=grid)
            fitted[name] = (prob, fit_correction(prob, method="Finlayson 2015", noise=NOISE / 0.5))
        return fitted[name]

    def snap(w):
        return min(names, key=lambda n: _angle(w, cand_white[n]))

    rng = np.random.default_rng(7)
    ang = {m: [] for m in METHODS_ESTIMATE}
    dE = {m: [] for m in ("ML", "grey-world", "white-patch", "true")}
    for light in lights:
        G = white(illuminant(light))
        w_true = G.sum(axis=0)
        for _ in range(n_scenes):
            x = X_all[rng.choice(len(X_all), 40, replace=False)]
            s = rng.uniform(0.3, 1.0)
            R = s * (x @ G) + NOISE * rng.normal(size=(40, k))
            est = estimate_illuminant(R, cams, candidates=cands, shape=grid)
            gw, wp = grey_world(R), white_patch(R)
            picks = {"ML (ours)": est.white, "grey-world": gw, "grey-world → cand.": cand_white[snap(gw)]}
            picks |= {"white-patch": wp, "white-patch → cand.": cand_white[snap(wp)]}
            for m, w in picks.items():
                ang[m].append(_angle(w[:3], w_true[:3]))
            truth = None
            for m, name, w in (
                ("ML", est.name, est.white),
                ("grey-world", snap(gw), gw),
                ("white-patch", snap(wp), wp),
                ("true", light, w_true),
            ):
                prob, cor = corrector(name)
                if truth is None:
                    truth = prob.target_of(x)
                c = (R / s) / (w / w.mean())  # white-balanced by the estimate, exposure known
                dE[m].append(prob.delta_E(cor(c), truth))
    return ang, dE


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--lights", nargs="+", default=["A", "FL2", "FL11", "LED-B3", "D50"])
    ap.add_argument("--atypical", type=int, default=150, help="spectra per atypical set (two sets)")
    ap.add_argument("--no-prior", action="store_true", help="skip the Prior estimator (the slowest fit)")
    ap.add_argument("--estimate", type=int, default=0, help="scenes per light for the unknown-light part")
    args = ap.parse_args()
    if args.estimate:
        run_estimate(args.estimate, args.lights)
    else:
        run(args.lights, args.atypical, not args.no_prior)


if __name__ == "__main__":
    main()
