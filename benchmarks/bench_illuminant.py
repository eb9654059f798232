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
a Gaussian reflectance prior; one exposure for all channels, and one per camera as a capture uses it,
with its bootstrap angular uncertainty) and by ``grey_card`` (a flat card of reflectance 0.9 in the
scene, its 8 × 8 pixels averaged), against grey-world, white-patch (max-RGB) and first-order grey-edge
(van de Weijer et al. 2007; σ = 1 px, p = 1, and σ = 2 px, p = 6 ("p6"), near the paper's best
first-order setting) estimates of the white, raw and snapped to the nearest candidate by angle over
all stacked channels. Grey-edge needs an image: it reads a Mondrian of the
scene's 40 surfaces (5 × 8 blocks of 8 × 8 px, the same pixel noise); the others read the 40
responses. Angular error of camera 1's white (degrees); then the ΔE00 to D65 of the pipeline
"white-balance by the estimated white, apply the root-polynomial fitted for the chosen candidate → D65"
(the exposure is taken as known, so the ΔE is that of the light estimate alone; the card's own
response is its white), against the same pipeline with the true light.

``--capture FOLDER``: the CI simulated capture lit by CIE A (three cameras, 130 training steps) through
``splat run`` once, then its correct step four times: the light named (``illuminant = "A"``) or
estimated (``illuminant = "estimate"``, ``reference = "A"``), with the marked card or the brightest
neutral surface as the white; ΔE00 of the fused ``Prior`` estimates on the truth's flat pixels of the
held-out views (about 25 minutes on 2 shared cores).

Run: ``python benchmarks/bench_illuminant.py [--lights A FL2 FL11 LED-B3 D50] [--atypical 150]
[--no-prior]``, ``python benchmarks/bench_illuminant.py --estimate 10`` or
``python benchmarks/bench_illuminant.py --capture /tmp/illuminant-capture``
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
METHODS_ESTIMATE = (
    "ML (ours)",
    "ML, exposure per camera",
    "grey card",
    "grey-world",
    "grey-world → cand.",
    "white-patch",
    "white-patch → cand.",
    "grey-edge",
    "grey-edge p6",
    "grey-edge p6 → cand.",
)
DE_ESTIMATE = (
    "ML",
    "ML, exposure per camera",
    "grey card",
    "grey-world",
    "white-patch",
    "grey-edge p6",
    "true light",
)
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
    from zonotope.spectra.illuminant_estimate import white_angle

    return white_angle(a, b)


def run_estimate(n_scenes: int, lights) -> None:
    from zonotope import reflectances, resample
    from zonotope.spectra.illuminant_estimate import candidate_illuminants

    grid = np.arange(400.0, 681.0, 10.0)
    data = DATA if DATA.is_dir() else None
    X_all = np.concatenate([t.reflectances for t in natural_test_sets(grid, data_dir=data)])
    training = resample(reflectances("rawtoaces 190"), grid).T  # the prior, resampled once
    cands = candidate_illuminants()
    cam_sets = (
        ["Nikon 5100 (NPL)"],
        ["Nikon 5100 (NPL)", "Canon EOS 5D Mark II"],
        ["Nikon 5100 (NPL)", "Canon EOS 5D Mark II", "Sigma SDMerill (NPL)"],
    )
    print(f"\n## unknown scene light: {n_scenes} scenes × {len(lights)} lights, 40 surfaces each")
    print("angular error of camera 1's white, mean / median (degrees)")
    print("| cameras | " + " | ".join(METHODS_ESTIMATE) + " |")
    print("|---|" + "---|" * len(METHODS_ESTIMATE))
    rows, calib = [], []
    for cams in cam_sets:
        ang, dE, unc = _estimate_cameras(cams, lights, n_scenes, grid, X_all, cands, training)
        label = " + ".join(c.split(" (")[0] for c in cams)
        cells = [f"{np.mean(ang[m]):5.2f} / {np.median(ang[m]):5.2f}" for m in METHODS_ESTIMATE]
        print(f"| {label} | " + " | ".join(cells) + " |")
        rows.append((label, dE))
        calib.append((label, unc))
    print(
        "\nΔE00 to D65 after white balance by the estimate and the correction fitted for its light, "
        "mean / p95"
    )
    print("| cameras | " + " | ".join(DE_ESTIMATE) + " |")
    print("|---|" + "---|" * len(DE_ESTIMATE))
    for label, dE in rows:
        print(f"| {label} | " + " | ".join(_stats(np.concatenate(dE[m])) for m in DE_ESTIMATE) + " |")
    print("\nML (exposure per camera): bootstrap angular uncertainty against the angular error")
    print(
        "| cameras | uncertainty mean | error mean | error ≤ uncertainty | error ≤ 2 × uncertainty + 0.5° |"
    )
    print("|---|---|---|---|---|")
    for label, (u, e) in calib:
        u, e = np.array(u), np.array(e)
        print(
            f"| {label} | {u.mean():.2f}° | {e.mean():.2f}° | {np.mean(e <= u + 1e-9):.0%} | "
            f"{np.mean(e <= 2 * u + 0.5):.0%} |"
        )


def mondrian(responses: np.ndarray, rng, *, block: int = 8, noise: float = NOISE) -> np.ndarray:
    """A Mondrian image (5 × 8 blocks of ``block`` px) of 40 surfaces' noise-free responses (40, k),
    with independent pixel noise σ = ``noise``: what grey-edge needs (the layout of an image)."""
    k = responses.shape[1]
    tiles = responses.reshape(5, 8, k)
    img = np.kron(tiles, np.ones((block, block, 1)))
    return img + noise * rng.normal(size=img.shape)


def _estimate_cameras(cams, lights, n_scenes, grid, X_all, cands, training):
    """Angular errors and ΔE00 of every estimate for one camera set (see the module notes)."""
    from zonotope import generators, illuminant
    from zonotope.spectra.illuminant_estimate import (
        estimate_illuminant,
        grey_card,
        grey_edge,
        grey_world,
        white_patch,
    )

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
    dE = {m: [] for m in DE_ESTIMATE}
    unc = ([], [])
    for light in lights:
        G = white(illuminant(light))
        w_true = G.sum(axis=0)
        for _ in range(n_scenes):
            x = X_all[rng.choice(len(X_all), 40, replace=False)]
            s = rng.uniform(0.3, 1.0)
            R = s * (x @ G) + NOISE * rng.normal(size=(40, k))
            img = mondrian(s * (x @ G), rng)
            # a flat card of reflectance 0.9 in the scene: the mean of its 8 × 8 pixels
            card = s * 0.9 * w_true + NOISE / 8 * rng.normal(size=k)
            opts = {"candidates": cands, "shape": grid, "training": training}
            est = estimate_illuminant(R, cams, **opts)
            per = estimate_illuminant(R, cams, exposures="per camera", bootstrap=20, **opts)
            gc = grey_card(card, cams, candidates=cands, shape=grid)
            gw, wp, ge, ge6 = grey_world(R), white_patch(R), grey_edge(img), grey_edge(img, sigma=2.0, p=6.0)
            picks = {"ML (ours)": est.white, "ML, exposure per camera": per.white, "grey card": gc.white}
            picks |= {"grey-world": gw, "grey-world → cand.": cand_white[snap(gw)]}
            picks |= {"white-patch": wp, "white-patch → cand.": cand_white[snap(wp)]}
            picks |= {"grey-edge": ge, "grey-edge p6": ge6, "grey-edge p6 → cand.": cand_white[snap(ge6)]}
            for m, w in picks.items():
                ang[m].append(_angle(w[:3], w_true[:3]))
            unc[0].append(per.angular_uncertainty)
            unc[1].append(ang["ML, exposure per camera"][-1])
            truth = None
            for m, name, w in (
                ("ML", est.name, est.white),
                ("ML, exposure per camera", per.name, per.white),
                ("grey card", gc.name, card),
                ("grey-world", snap(gw), gw),
                ("white-patch", snap(wp), wp),
                ("grey-edge p6", snap(ge6), ge6),
                ("true light", light, w_true),
            ):
                prob, cor = corrector(name)
                if truth is None:
                    truth = prob.target_of(x)
                c = (R / s) / (w / w.mean())  # white-balanced by the estimate, exposure known
                dE[m].append(prob.delta_E(cor(c), truth))
    return ang, dE, unc


def run_capture(folder: Path) -> None:
    """The CI simulated capture under CIE A (three cameras, 130 training steps, the held-out views):
    the correct step with the light named and with ``illuminant = "estimate"`` (``reference = "A"``, so
    both are compared with the truth under A), with the marked card and with the brightest neutral
    surface as the white; ΔE00 of the fused estimates (``Prior``) on the truth's flat pixels."""
    import json
    import re
    import shutil

    import tifffile

    from splat.capture import read_capture
    from splat.cli import main as splat_main
    from splat.scoring import flat_mask
    from splat.sim.capture import SimCaptureConfig, write_synthetic_capture

    if folder.exists():
        raise SystemExit(f"{folder} exists; give a new folder for the capture and its outputs.")
    cap0 = write_synthetic_capture(folder / "capture", SimCaptureConfig.ci(illuminant="A"))
    opts = ["--steps", "130", "--capacity", "2048", "--quantum", "0.02", "--threads", "2"]
    holdout = list(read_capture(cap0).holdout)
    assert splat_main(["run", str(cap0), "-o", str(folder / "out"), *opts, "--views", *holdout]) == 0
    print("\n## a capture under CIE A, light named or estimated; flat pixels of the held-out views, ΔE00")
    print("| white | light | chosen | uncertainty | mean | median | p95 |")
    print("|---|---|---|---|---|---|---|")
    for white in ("marked card", "brightest neutral"):
        for light, top in (
            ("A (named)", 'illuminant = "A"'),
            ("estimate", 'illuminant = "estimate"\nreference = "A"'),
        ):
            tag = f"{white}-{light}".replace(" ", "_").replace("(", "").replace(")", "")
            cap, out = folder / f"cap_{tag}", folder / f"out_{tag}"
            shutil.copytree(cap0, cap)
            shutil.copytree(folder / "out", out)
            shutil.rmtree(out / "correct")
            (out / "report.html").unlink(missing_ok=True)
            text = re.sub(
                r"^illuminant = .*\n", top + "\n", (cap / "capture.toml").read_text(), count=1, flags=re.M
            )
            if white == "brightest neutral":
                text = re.sub(r"\[white\]\n(.*\n)*?(?=\[|\Z)", "", text)
            (cap / "capture.toml").write_text(text)
            assert splat_main(["correct", str(cap), "-o", str(out), "--quantum", "0.02"]) == 0
            s = json.loads((out / "correct" / "summary.json").read_text())
            w = np.asarray(s["white_XYZ"])
            xy = colour.XYZ_to_xy(w)
            flat = []
            for info in json.loads((out / "render" / "index.json").read_text()).values():
                truth = np.asarray(tifffile.imread(cap / "truth" / "xyz" / f"{info['dir']}.tiff"), float)
                est = np.asarray(
                    tifffile.imread(out / "correct" / info["dir"] / "Prior_fused_XYZ.tiff"), float
                )
                dE = colour.delta_E(
                    colour.XYZ_to_Lab(est, xy), colour.XYZ_to_Lab(truth, xy), method="CIE 2000"
                )
                flat.append(dE[flat_mask(truth)])
            f = np.concatenate(flat)
            est = s["illuminant"]["estimate"] or {}
            unc = est.get("angular_uncertainty_deg")
            print(
                f"| {white} | {light} | {s['illuminant']['light']} ({est.get('method', 'named')}) | "
                f"{'' if unc is None else f'{unc:.2f}°'} | {f.mean():.2f} | {np.median(f):.2f} | "
                f"{np.percentile(f, 95):.2f} |"
            )


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--lights", nargs="+", default=["A", "FL2", "FL11", "LED-B3", "D50"])
    ap.add_argument("--atypical", type=int, default=150, help="spectra per atypical set (two sets)")
    ap.add_argument("--no-prior", action="store_true", help="skip the Prior estimator (the slowest fit)")
    ap.add_argument("--estimate", type=int, default=0, help="scenes per light for the unknown-light part")
    ap.add_argument(
        "--capture", type=Path, help="new folder: the simulated capture, named vs estimated light"
    )
    args = ap.parse_args()
    if args.capture:
        run_capture(args.capture)
    elif args.estimate:
        run_estimate(args.estimate, args.lights)
    else:
        run(args.lights, args.atypical, not args.no_prior)


if __name__ == "__main__":
    main()
