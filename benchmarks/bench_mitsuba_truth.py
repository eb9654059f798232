"""The path-traced capture's truth: its Monte Carlo floor, a converged truth, and the accuracy table
against both (docs/notes/2026-11-29-mitsuba-truth.md).

    python benchmarks/bench_mitsuba_truth.py --capture /tmp/mitsuba_cap --chunks /tmp/truth_chunks \\
        --renders 16 --run /tmp/acc_mitsuba_colmap

1. Each held-out view of ``--capture`` (a ``splat.sim.mitsuba`` capture) is rendered ``--renders`` times
   at 32 spp, each with its own seed, through the three cameras' curves and XYZ (12 film channels,
   ``render_scale``), into ``--chunks`` (``<folder>_<stem>_12.npy``; files there are reused).
2. Per view: the per-pixel noise, how the chart floor falls with samples, the 32-spp truth against the
   mean of the renders (``conv``), and the pooled ratio of the two (a bias test of films and scale).
3. The pipeline's corrector (Prior, the run's δ) fed the renders' camera channels (true: their mean; one
   32-spp render), one camera against three, region means against ``conv`` and the 32-spp truth.
4. With ``--run`` (a ``bench_capture_accuracy.py`` work folder whose render step is done): its (a), (b),
   three-camera and render-only estimates, computed once, scored against both truths.
"""

from __future__ import annotations

import argparse
import json
import sys
import tomllib
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).parent))
from bench_capture_accuracy import labelled_regions

SPP = 32
STRIDE = 2


def render(capture: Path, chunks: Path, renders: int) -> None:
    """Step 1 (skips views already in ``chunks``)."""
    import mitsuba as mi

    from splat.sim import mitsuba as sm

    doc = tomllib.loads((capture / "truth" / "truth.toml").read_text())
    scene = sm._rebuilt_scene(capture, doc)
    E, curves, xyz = sm._curves(scene, doc["illuminant"])
    film = np.concatenate([*curves, xyz], 1)
    chunks.mkdir(parents=True, exist_ok=True)
    for vi, v in enumerate(scene.views):
        f = chunks / f"{scene.config.cameras[v.camera].folder}_{v.stem}_12.npy"
        if not v.holdout or f.exists():
            continue
        sc = sm.mitsuba_scene(scene, v, film, E, spp=SPP, seed=0)
        seeds = [1_200_000 + 1000 * vi + c for c in range(renders)]
        stack = [np.asarray(mi.render(sc, seed=s, spp=SPP), np.float32) for s in seeds]
        np.save(f, np.stack(stack) * np.float32(doc["render_scale"]))
        print(f"rendered {f.name}", flush=True)


def main(argv=None) -> int:
    import colour
    import tifffile

    from splat.capture import fit_corrector, read_capture

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--capture", required=True, help="a splat.sim.mitsuba capture")
    ap.add_argument("--chunks", required=True, help="folder of the renders (written, then reused)")
    ap.add_argument("--renders", type=int, default=16, help="32-spp renders per held-out view")
    ap.add_argument("--run", default=None, help="a bench_capture_accuracy.py work folder (render step done)")
    args = ap.parse_args(argv)
    capture, chunks = Path(args.capture), Path(args.chunks)
    doc = tomllib.loads((capture / "truth" / "truth.toml").read_text())
    if doc.get("generator") != "splat.sim.mitsuba" or args.renders < 4:
        print("--capture must be a splat.sim.mitsuba capture and --renders at least 4", file=sys.stderr)
        return 2
    render(capture, chunks, args.renders)
    spec = read_capture(capture)
    truth = capture / "truth"
    regions = labelled_regions(truth)
    neutral = np.concatenate([c["as_shot_neutral"] for c in doc["camera"]])
    n = len(spec.cameras)
    three = tuple(range(n))
    delta = 0.0025
    if args.run:
        delta = json.loads((Path(args.run) / "out" / "correct" / "delta.json").read_text())["delta"]
    corr = {s: fit_corrector(spec, list(s), "Prior", delta) for s in [(c,) for c in range(n)] + [three]}
    problem = corr[three].problem
    w = problem.white_XYZ
    xy = colour.XYZ_to_xy(w)

    def dE(a, b):
        la, lb = colour.XYZ_to_Lab(a / w[1], xy), colour.XYZ_to_Lab(b / w[1], xy)
        return np.asarray(colour.delta_E(la, lb, method="CIE 2000"))

    def region_means(img, lab):
        return {int(r): img[lab == r].mean(0) for r in np.unique(lab[lab > 0])}

    def floor(a, b, lab, chart):
        ma, mb = region_means(a, lab), region_means(b, lab)
        d = {r: float(dE(ma[r], mb[r])) for r in ma}
        ch = [x for r, x in d.items() if r in chart]
        un = [x for r, x in d.items() if r not in chart]
        return (np.mean(ch) if ch else np.nan), (np.mean(un) if un else np.nan)

    s2 = (slice(None, None, STRIDE),) * 2
    oracle: dict = {}
    conv = {}
    print("| view | rel. sd of Y per pixel | chart pixels (median, min, max) | 32 vs 32 | "
          "128 vs 128 | 256 vs 256 | 32-spp truth vs mean | mean ÷ 32-spp truth, pooled |")  # fmt: skip
    print("|---|---|---|---|---|---|---|---|")
    for f in sorted(chunks.glob("*_12.npy")):
        folder, stem = f.stem[:-3].split("_", 1)
        k = next(i for i, c in enumerate(spec.cameras) if c.folder == folder)
        A = np.load(f).astype(float)
        X = A[..., -3:]
        mean = A.mean(0)
        ref = np.asarray(tifffile.imread(truth / "xyz" / folder / f"{stem}.tiff"), float)
        conv[f"{folder}/{stem}"] = mean[..., -3:]
        lab, chart = regions(ref)
        L = lab[s2]
        rel = np.median((X.std(0, ddof=1)[..., 1] / np.maximum(mean[..., -2], 1e-9))[lab > 0])
        pix = [int(np.sum(L == r)) for r in chart]
        cells = []
        for m in (1, 4, 8):
            if 2 * m <= len(X):
                cells.append(
                    "{:.2f} / {:.2f}".format(*floor(X[:m].mean(0)[s2], X[m : 2 * m].mean(0)[s2], L, chart))
                )
            else:
                cells.append("–")
        tv = "{:.2f} / {:.2f}".format(*floor(ref[s2], mean[..., -3:][s2], L, chart))
        seen = tifffile.imread(truth / "labels" / folder / f"{stem}.tiff") > 0  # every surface hit
        pooled = mean[..., -3:][seen].sum(0) / ref[seen].sum(0)
        print(
            f"| {folder}/{stem} | {rel:.3f} | {int(np.median(pix)) if pix else 0}, {min(pix, default=0)}, "
            f"{max(pix, default=0)} | "
            + " | ".join(cells)
            + f" | {tv} | "
            + ", ".join(f"{x:.4f}" for x in pooled)
            + " |"
        )
        for src, C in (("true", mean), ("one 32-spp render", A[0])):
            t9 = np.maximum((C[..., : 3 * n] / neutral)[s2], 0)
            for who, s in (("own", (k,)), ("three", three)):
                est = correct_image_of(t9, s, corr[s])
                for r in np.unique(L[L > 0]):
                    m = L == r
                    kind = "chart" if int(r) in chart else "uniform"
                    for rname, rimg in (("512", mean[..., -3:][s2]), ("32", ref[s2])):
                        key = (folder, src, who, kind, rname)
                        oracle.setdefault(key, []).append(float(dE(est[m].mean(0), rimg[m].mean(0))))
    print("\nThe corrector fed responses (region means; chart / uniform ΔE00, own camera | three cameras):\n")
    for folder in [c.folder for c in spec.cameras]:
        for src in ("true", "one 32-spp render"):
            for rname in ("512", "32"):
                o = [
                    np.mean(oracle.get((folder, src, "own", kd, rname), [np.nan]))
                    for kd in ("chart", "uniform")
                ]
                t = [
                    np.mean(oracle.get((folder, src, "three", kd, rname), [np.nan]))
                    for kd in ("chart", "uniform")
                ]
                print(
                    f"{folder}, {src}, against the {rname}-spp XYZ: {o[0]:.2f} / {o[1]:.2f} | {t[0]:.2f} / "
                    f"{t[1]:.2f} (three ÷ own {t[0] / o[0]:.2f} / {t[1] / o[1]:.2f})"
                )
    if args.run:
        scored(Path(args.run), spec, regions, conv)
    return 0


def correct_image_of(t9, cams, cor):
    from zonotope.correct.image import correct_image

    return correct_image(t9[..., [3 * c + j for c in cams for j in range(3)]], cor)


def scored(work: Path, spec, regions, conv: dict) -> None:
    """Step 4: the run's estimates once, against the 32-spp truth and the renders' mean."""
    import tifffile

    import splat.scoring as S
    from splat.capture import (
        correct_fused,
        delta_of,
        fit_corrector,
        fused_fitter,
        fused_view,
        fusion_of,
        pipeline_mix,
        reprojected_of,
    )

    out = work / "out"
    raws, index, white, scale = S.correction_inputs(spec, out)
    delta = delta_of(spec, out, index, scale)["delta"]
    fusion = fusion_of(spec, out, index, raws, scale)
    n = len(spec.cameras)
    three = tuple(range(n))
    corr3 = fit_corrector(spec, list(three), "Prior", delta, mix=pipeline_mix("Prior"))  # as the step
    best = (
        json.loads((out / "score.json").read_text())["dev_demosaic"] if (out / "score.json").is_file() else {}
    )
    fitters: dict = {}
    res: dict = {}
    for name, info in index.items():
        stem = S._truth_stem(name)
        if info["kind"] != "holdout" or stem not in conv:
            continue
        k = raws[name].camera
        folder = spec.cameras[k].folder
        ref32 = np.asarray(tifffile.imread(spec.root / "truth" / "xyz" / f"{stem}.tiff"), float)
        lab, chart = regions(ref32)
        L = lab[::STRIDE, ::STRIDE]
        dm = best.get(folder, "Menon 2007")
        est = {
            "(a)": S.develop(
                raws[name],
                white["scale"][k],
                S.chart_matrix(spec, k),
                demosaic="Malvar 2004" if dm == "as is" else dm,
            )[::STRIDE, ::STRIDE]
        }
        rend = np.asarray(tifffile.imread(out / "render" / spec.out_stem(name) / "render.tiff"), float)
        from zonotope.correct.image import correct_image

        est["render only"] = correct_image(np.maximum(rend / scale, 0)[::STRIDE, ::STRIDE], corr3)
        rep = reprojected_of(out / "render" / spec.out_stem(name), scale)
        for key, sub in (("(b)", (k,)), ("three", three)):
            f, code, sigma = fused_view(fusion, name, rend / scale, raws[name], scale, list(sub), rep)
            fitters.setdefault(sub, fused_fitter(spec, list(sub), "Prior"))
            est[key] = correct_fused(
                f[::STRIDE, ::STRIDE], code[::STRIDE, ::STRIDE], sigma, fitters[sub], 2e-3
            )
        for tname, ref in (("32 spp", ref32), ("mean of the renders", conv[stem])):
            for key, e in est.items():
                ch, un = S._region_dE(corr3.problem, e, ref[::STRIDE, ::STRIDE], L, chart)
                r = res.setdefault((tname, folder, key), {"chart": [], "uniform": []})
                r["chart"].append(np.mean(ch))
                r["uniform"].append(np.mean(un))
    print(
        "\n| views | truth | (a) | (b) | three cameras | render only | three ÷ (b) |\n"
        "|---|---|---|---|---|---|---|"
    )
    for folder in [c.folder for c in spec.cameras] + ["all"]:
        for tname in ("32 spp", "mean of the renders"):
            m = {}
            for key in ("(a)", "(b)", "three", "render only"):
                rows = [
                    v for (t, f, kk), v in res.items() if t == tname and kk == key and folder in (f, "all")
                ]
                m[key] = [np.mean([x for r in rows for x in r[kd]]) for kd in ("chart", "uniform")]
            print(
                f"| {folder} | {tname} | "
                + " | ".join(f"{m[key][0]:.2f} / {m[key][1]:.2f}" for key in m)
                + f" | {m['three'][0] / m['(b)'][0]:.2f} / {m['three'][1] / m['(b)'][1]:.2f} |"
            )


if __name__ == "__main__":
    sys.exit(main())
