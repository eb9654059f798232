"""Multi-camera capture against honest baselines: what a second and third camera add.

Writes a simulated capture (``splat.sim.capture``), runs ``splat``'s poses, train and render steps on its
held-out views, and scores them against ``truth/`` (:func:`splat.scoring.score`, Prior). For each held-out
view, three estimates of the same pixels:

- **(a) dev**: the view's own RAW file developed well — the pipeline's white (the marked card), the
  best of isp's demosaicing methods for that camera, no clipping before the matrix, a least-squares
  matrix fitted on the ColorChecker through the camera's sensitivities (``dev:<cam>``);
- **(b) one camera**: the same pipeline with the view's camera alone — its photograph averaged with its
  other photographs reprojected into it, no other camera (``Prior-fused:<cam>``);
- **three cameras**: the pipeline's fused output (``Prior-fused:<all>``);

plus the project's DNG-matrix development (``dng:<cam>``) and the render alone (``Prior:<all>``), each per
pixel (all pixels; flat pixels) and per region mean with the noise averaged (ColorChecker patches' mean
colour; every other uniform surface's mean colour). Ratios are taken view by view on the same pixels and
then averaged over the views. Goal (issue 39, item 9): three cameras ≤ 0.5 × (b) on chart-patch and
uniform-surface colour.

    python benchmarks/bench_capture_accuracy.py --size ci --work /tmp/acc_ci
    python benchmarks/bench_capture_accuracy.py --size ci --texture coarse --work /tmp/acc_coarse
    python benchmarks/bench_capture_accuracy.py --size benchmark --steps 3000 --work /tmp/acc_bench
    python benchmarks/bench_capture_accuracy.py --size benchmark --work /tmp/acc_bench --ladder
    python -m splat.sim.mitsuba /tmp/mitsuba --size 2 --spp 32
    python benchmarks/bench_capture_accuracy.py --capture /tmp/mitsuba --colmap --work /tmp/acc_mitsuba
    python benchmarks/bench_capture_accuracy.py --capture /tmp/mitsuba --colmap --work /tmp/acc_m --oracle 64

``--capture`` scores a capture written elsewhere (e.g. by :func:`splat.sim.mitsuba.write_mitsuba_capture`,
whose ``truth/`` has the same layout): it is copied into ``--work`` (the original is never written to)
and run with ``--steps`` / ``--capacity`` (default the CI size's). The Mitsuba capture's truth has no
3-D points: with its true poses the poses step triangulates them on the previews
(:func:`splat.poses.triangulate_points`; ``--colmap`` recovers poses and points with pycolmap instead).
Its regions come from ``truth/labels`` (:func:`labelled_regions`).
``--ladder`` (a capture the script writes) adds :func:`ladder`: the fused responses replaced by the true
ones step by step, to say where the region-mean error comes from.
``--oracle SPP`` (a Mitsuba capture) adds :func:`oracle`'s diagnostics from a second render of the
scene: the truth's Monte Carlo floor and each camera's level against the true responses.

True poses are given as a COLMAP model (``--colmap`` runs pycolmap instead): the comparison is of colour.
Steps already done in ``--work`` are reused.
"""

from __future__ import annotations

import argparse
import itertools
import shutil
import sys
import time
from pathlib import Path

import numpy as np

ROWS = (
    ("dng", "DNG-matrix development (project)"),
    ("dev", "(a) own photograph developed well"),
    ("one", "(b) one camera: its photographs fused"),
    ("render", "render only, three cameras"),
    ("three", "three cameras fused"),
)
QUANTUM = 2e-3  #: the colour deduplication step of the ladder's corrections, the scorer's default
MEASURES = (("mean", "per pixel, all"), ("flat", "per pixel, flat"), ("chart", "chart patch mean"),
            ("uniform", "uniform surface mean"))  # fmt: skip


def _labels(folder: str, folders: list[str]) -> dict:
    allc = "+".join(folders)
    return {
        "dng": f"dng:{folder}",
        "dev": f"dev:{folder}",
        "one": f"Prior-fused:{folder}",
        "render": f"Prior:{allc}",
        "three": f"Prior-fused:{allc}",
    }


def labelled_regions(truth: Path):
    """A stand-in for :func:`splat.scoring.region_labels` on a capture whose ``truth/labels`` says which
    surface each held-out pixel sees (:func:`splat.sim.mitsuba.surface_labels`), or None without them.

    Why: the scorer finds uniform regions where the true XYZ is constant over 5 × 5 pixels, which a
    path-traced truth never is (soft shadows, inter-reflection, Monte Carlo noise: 14 % between
    neighbouring pixels at 32 spp); the labels give each one-reflectance surface and chart patch instead,
    with the same interior rule (pixels whose 5 × 5 neighbourhood is that surface) and minimum size. A
    view is recognised by its truth image; any other image goes to the scorer's own rule."""
    import tifffile
    from scipy.ndimage import binary_erosion, label

    import splat.scoring as scoring
    from splat._tol import REGION_MIN_PIXELS
    from splat.sim.mitsuba import LABEL_CHART, LABEL_OTHER, LABEL_UNIFORM

    files = sorted((truth / "labels").rglob("*.tiff"))
    if not files:
        return None
    by_truth = {}
    for f in files:
        xyz = truth / "xyz" / f.relative_to(truth / "labels")
        by_truth[np.asarray(tifffile.imread(xyz), np.float32).tobytes()] = tifffile.imread(f)
    own = scoring.region_labels

    def region_labels(XYZ, chart_XYZ=None, *, radius: int = 2, **kw):
        codes = by_truth.get(np.asarray(XYZ, np.float32).tobytes())
        if codes is None:
            return own(XYZ, chart_XYZ, radius=radius, **kw)
        lab, chart, n = np.zeros(codes.shape, int), {}, 0
        for code in np.unique(codes):
            if code == 0 or code >= LABEL_OTHER:
                continue
            inner = binary_erosion(codes == code, structure=np.ones((2 * radius + 1,) * 2), border_value=0)
            parts, m = label(inner, structure=np.ones((3, 3)))
            for c in range(1, m + 1):
                if np.sum(parts == c) >= REGION_MIN_PIXELS:
                    n += 1
                    lab[parts == c] = n
                    if code < LABEL_UNIFORM:
                        chart[n] = int(code - LABEL_CHART)
        return lab, chart

    return region_labels


def oracle(capture: Path, out: Path, spp: int, regions) -> str:
    """Diagnostics of a path-traced capture that need its scene (truth: never given to the pipeline).

    Each held-out view is rendered again by Mitsuba (another seed, ``spp`` samples per pixel) through
    *every* camera's curves and the observer, at the truth's scale. Per view camera, over the labelled
    regions: (1) the truth's own floor, the ΔE00 of the region means of the two XYZ renders (Monte Carlo
    noise of the 32-sample truth, at the scorer's stride); (2) each camera's level, the median over
    regions of its white → 1 channels in the pipeline (its own photograph where it took the view, its
    reprojected photographs elsewhere) over the true responses (the render ÷ the camera's white); (3)
    the true responses corrected with the view camera alone and with all cameras, by a corrector fitted
    to δ alone and as the pipeline corrects a fused view (:func:`splat.capture.correct_fused`, the fused
    view's σ per pixel: what the scene allows the pipeline's estimator)."""
    import tomllib

    import tifffile

    import zonotope
    from splat.capture import read_capture, reprojected_of
    from splat.fusion import measured
    from splat.scoring import correction_inputs
    from splat.sim.capture import build_scene
    from splat.sim.mitsuba import mitsuba_config, mitsuba_scene

    spec = read_capture(capture)
    tt = tomllib.loads((capture / "truth" / "truth.toml").read_text())
    if tt.get("generator") != "splat.sim.mitsuba":
        return "--oracle: not a splat.sim.mitsuba capture; skipped"
    size = tt["camera"][0]["width"] / mitsuba_config().cameras[0].width
    config = mitsuba_config(size=size, seed=tt["seed"], noise=tt["noise"], illuminant=tt["illuminant"])
    scene = build_scene(config)
    grid = scene.wavelengths
    spd = zonotope.illuminant(tt["illuminant"])
    E = np.interp(grid, np.asarray(spd.wavelengths, float), np.asarray(spd.values, float))
    E = E / E.max()
    step = float(grid[1] - grid[0])
    curves = [np.asarray(g, float) / (E[:, None] * step) for g in scene.camera_generators]
    film = np.concatenate([*curves, np.asarray(scene.observer, float) / (E[:, None] * step)], axis=1)
    neutral = np.concatenate([c["as_shot_neutral"] for c in tt["camera"]])
    raws, index, _white, scale = correction_inputs(spec, out)
    from splat.capture import correction_problem_of

    problem = correction_problem_of(spec, list(range(len(spec.cameras))))
    import colour

    wXYZ = problem.white_XYZ

    def dE(a, b):  # CIELAB relative to the problem's white, as the scorer
        xy = colour.XYZ_to_xy(wXYZ)
        la, lb = colour.XYZ_to_Lab(a / wXYZ[1], xy), colour.XYZ_to_Lab(b / wXYZ[1], xy)
        return float(colour.delta_E(la, lb, method="CIE 2000"))

    from splat.capture import correct_fused, delta_of, fit_corrector, fused_fitter, fused_view, fusion_of
    from zonotope.correct.image import correct_image

    delta = delta_of(spec, out, index, scale)["delta"]
    fusion = fusion_of(spec, out, index, raws, scale)
    n = len(spec.cameras)
    corr = {
        s: fit_corrector(spec, list(s), "Prior", delta) for s in [(c,) for c in range(n)] + [tuple(range(n))]
    }
    fitters = {s: fused_fitter(spec, list(s), "Prior") for s in corr}
    lines = [
        "| view camera | truth floor, chart | truth floor, uniform | "
        + " | ".join(f"{c.folder} level (R, G, B)" for c in spec.cameras)
        + " | true responses, corrector fitted to δ: own camera, chart / uniform | three cameras"
        + " | three ÷ own"
        + " | the same, corrected as the pipeline (its σ): own camera | three cameras | three ÷ own |",
        "|---|---:|---:|" + "---|" * len(spec.cameras) + "---|---|---|---|---|---|",
    ]
    per = {}
    for vi, v in enumerate(scene.views):
        name = f"{config.cameras[v.camera].folder}/{v.stem}.dng"
        if not v.holdout or name not in index:
            continue
        sc = mitsuba_scene(scene, v, film, E, spp=spp, seed=7919 + vi)
        import mitsuba as mi  # the variant is set by mitsuba_scene

        img = np.asarray(mi.render(sc), float)
        img *= tt["render_scale"]
        ref = np.asarray(tifffile.imread(capture / "truth" / "xyz" / Path(name).with_suffix(".tiff")), float)
        lab, chart = regions(ref)
        true9 = img[..., :-3] / neutral
        r = raws[name]
        k = r.camera
        values, count = reprojected_of(out / "render" / index[name]["dir"], scale)
        pipe = values.copy()
        pipe[..., 3 * k : 3 * k + 3] = measured(r, scale[3 * k : 3 * k + 3])
        row = per.setdefault(spec.cameras[k].folder, {"chart": [], "uniform": [], "level": []})
        s2 = (slice(None, None, 2), slice(None, None, 2))
        # the pipeline's corrector given the true responses (no noise, no fusion), on the stride grid,
        # against this render's own XYZ (the same samples: its Monte Carlo noise nearly cancels)
        est = {
            s: correct_image(np.maximum(true9[s2][..., [3 * c + j for c in s for j in range(3)]], 0), cor)
            for s, cor in corr.items()
        }
        render = np.asarray(tifffile.imread(out / "render" / index[name]["dir"] / "render.tiff"), float)
        rep = (values, count)
        for s in [(k,), tuple(range(n))]:  # with the fused view's σ per pixel, as the pipeline corrects
            _f, code, sigma = fused_view(fusion, name, render / scale, r, scale, list(s), rep)
            t = true9[s2][..., [3 * c + j for c in s for j in range(3)]]
            est[("σ", s)] = correct_fused(t, code[s2], sigma, fitters[s], QUANTUM)
        for reg in np.unique(lab[lab > 0]):
            m2 = lab[s2] == reg
            kind = "chart" if int(reg) in chart else "uniform"
            d = dE(img[s2][m2][:, -3:].mean(0), ref[s2][m2].mean(0))
            row[kind].append(d)
            for s, e in est.items():
                tag, s = s if s[0] == "σ" else ("", s)
                who = "three" if len(s) == n else ("own" if s == (k,) else None)
                who = f"{who} {tag}".strip() if who else None
                if who:
                    row.setdefault((who, kind), []).append(dE(e[m2].mean(0), img[s2][m2][:, -3:].mean(0)))
            m = lab == reg
            row["level"].append(pipe[m].mean(0) / true9[m].mean(0))

    def mean(xs):
        return float(np.mean(xs)) if xs else float("nan")

    for cam, row in per.items():
        lv = np.median(np.array(row["level"]), 0)
        tr = {
            key: mean(row.get(key, []))
            for key in itertools.product(("own", "three", "own σ", "three σ"), ("chart", "uniform"))
        }
        lines.append(
            f"| {cam} | {np.mean(row['chart']):.2f} | {np.mean(row['uniform']):.2f} | "
            + " | ".join(
                ", ".join(f"{x:.3f}" for x in lv[3 * c : 3 * c + 3]) for c in range(len(spec.cameras))
            )
            + f" | {tr[('own', 'chart')]:.2f} / {tr[('own', 'uniform')]:.2f}"
            + f" | {tr[('three', 'chart')]:.2f} / {tr[('three', 'uniform')]:.2f}"
            + f" | {tr[('three', 'chart')] / tr[('own', 'chart')]:.2f}"
            + f" / {tr[('three', 'uniform')] / tr[('own', 'uniform')]:.2f}"
            + f" | {tr[('own σ', 'chart')]:.2f} / {tr[('own σ', 'uniform')]:.2f}"
            + f" | {tr[('three σ', 'chart')]:.2f} / {tr[('three σ', 'uniform')]:.2f}"
            + f" | {tr[('three σ', 'chart')] / tr[('own σ', 'chart')]:.2f}"
            + f" / {tr[('three σ', 'uniform')] / tr[('own σ', 'uniform')]:.2f} |"
        )
    return "\n".join(lines)


def ladder(capture: Path, out: Path, config, stride: int) -> dict:
    """Where the fused estimate's region-mean error comes from, on a capture of ``splat.sim.capture``
    (its scene rebuilt from ``config``: truth, never given to the pipeline).

    Each held-out view's true responses of every camera (the ray-caster's noise-free render, white → 1
    at exposure 1) replace the pipeline's fused responses step by step, for three cameras and for the
    view's camera alone (b). Rows, ΔE00 of region means as the scorer takes them (chart patches /
    uniform surfaces):

    - ``true, δ``: the true responses corrected as the oracle would be, with the pipeline's δ alone
      (what the scene and the corrector allow);
    - ``true, pipeline σ``: the same responses through :func:`splat.capture.correct_fused` with the
      fused view's own noise pattern per pixel (the estimator's noise awareness alone);
    - ``true + fused σ noise``: the true responses with independent Gaussian noise of that σ added per
      pixel: the error the fused responses declare (an upper bound, as the guided re-reading averages
      noise below the σ it reports), against which the fused rows say whether they keep within it;
    - ``own fused``: the view's own channels as the pipeline fused them, the others true; ``, bias
      only``: their error's median over each region alone; ``, noise only``: the error less that median;
    - ``own photograph alone``: the view's own photograph demosaiced (no fusion) as its own channels;
    - ``others fused`` (likewise): the other cameras' channels as fused, the own channels true;
    - ``pipeline``: everything as fused (the scorer's row).

    Also each channel group's level and scatter: the median and the median absolute deviation over
    regions of (pipeline region mean ÷ true region mean).

    Returns ``{"rows": {(views, "three" | "one", responses): (chart ΔE00s, uniform ΔE00s)}, "levels":
    {view camera: (regions, 3 n) ratios}, "folders": [...]}`` (views: a camera folder or "all views");
    :func:`ladder_table` prints it."""
    import tifffile

    from splat.capture import (
        correct_fused,
        delta_of,
        fit_corrector,
        fused_fitter,
        fused_view,
        fusion_of,
        read_capture,
        reprojected_of,
    )
    from splat.fusion import measured
    from splat.scoring import _chart_XYZ, _region_dE, _truth_stem, correction_inputs, region_labels
    from splat.sim.capture import build_scene
    from zonotope.correct.image import correct_image

    spec = read_capture(capture)
    scene = build_scene(config)
    G = [np.asarray(g, float) / np.asarray(g, float).sum(0) for g in scene.camera_generators]  # white → 1
    raws, index, _white, scale = correction_inputs(spec, out)
    delta = delta_of(spec, out, index, scale)["delta"]
    fusion = fusion_of(spec, out, index, raws, scale)
    n = len(spec.cameras)
    chart_XYZ = _chart_XYZ(spec)
    by_stem = {f"{config.cameras[v.camera].folder}/{v.stem}": v for v in scene.views}
    rows: dict = {}
    levels: dict = {}
    fitters, oracles = {}, {}
    for name in (k for k, v in index.items() if v["kind"] == "holdout"):
        sv = by_stem.get(_truth_stem(name))
        if sv is None or name not in fusion["views"]:
            continue
        ref = np.asarray(tifffile.imread(capture / "truth" / "xyz" / f"{_truth_stem(name)}.tiff"), float)
        if not np.allclose(scene.XYZ(sv), ref, rtol=1e-4, atol=1e-6):
            raise SystemExit(f"--ladder: the scene rebuilt does not match {name}'s truth")
        lab, chart = region_labels(ref, chart_XYZ)
        lab, r = lab[::stride, ::stride], ref[::stride, ::stride]
        true = scene.render(sv, scene.library @ np.concatenate(G, 1))[::stride, ::stride]
        k = raws[name].camera
        folder = spec.cameras[k].folder
        render = np.asarray(tifffile.imread(out / "render" / spec.out_stem(name) / "render.tiff"), float)
        rep = reprojected_of(out / "render" / spec.out_stem(name), scale)
        for who, sub in (("three", tuple(range(n))), ("one", (k,))):
            f, code, sigma = fused_view(fusion, name, render / scale, raws[name], scale, list(sub), rep)
            f, code = f[::stride, ::stride], code[::stride, ::stride]
            idx = [3 * c + j for c in sub for j in range(3)]
            t = true[..., idx]
            own = np.zeros(len(idx), bool)
            own[3 * sub.index(k) : 3 * sub.index(k) + 3] = True
            if sub not in fitters:
                fitters[sub] = fused_fitter(spec, list(sub), "Prior")
                oracles[sub] = fit_corrector(spec, list(sub), "Prior", delta)
            ests = {
                "true, δ": correct_image(np.maximum(t, 0), oracles[sub], quantum=QUANTUM),
                "true, pipeline σ": correct_fused(t, code, sigma, fitters[sub], QUANTUM),
            }
            # the true responses with the noise the fused ones declare (σ of each pixel's code)
            rng = np.random.default_rng(0)
            sd = np.zeros_like(t)
            for cd, s_ in sigma.items():
                sd[code == cd] = np.asarray(s_, float)
            ests["true + fused σ noise"] = correct_fused(
                t + sd * rng.standard_normal(t.shape), code, sigma, fitters[sub], QUANTUM
            )
            if who == "three":
                # the fused error split per region into its median over the region (bias: demosaicing,
                # reprojection, level) and what is left about it (noise, misplaced pixels)
                err = f - t
                bias = np.zeros_like(err)
                for reg in np.unique(lab[lab > 0]):
                    m = lab == reg
                    bias[m] = np.median(err[m], 0)
                for part, sel in (("own", own), ("others", ~own)):
                    for what, e in (("", err), (", bias only", bias), (", noise only", err - bias)):
                        ests[f"{part} fused{what}"] = correct_fused(
                            np.where(sel, t + e, t), code, sigma, fitters[sub], QUANTUM
                        )
                # the own photograph alone, demosaiced, in place of the own channels fused
                for dm in ("Malvar 2004", "bilinear"):
                    photo = measured(raws[name], scale[3 * k : 3 * k + 3], method=dm)[::stride, ::stride]
                    mixed = t.copy()
                    mixed[..., own] = photo
                    ests[f"own photograph alone ({dm})"] = correct_fused(
                        mixed, code, sigma, fitters[sub], QUANTUM
                    )
            ests["pipeline"] = correct_fused(f, code, sigma, fitters[sub], QUANTUM)
            for label, e in ests.items():
                ch, un = _region_dE(oracles[sub].problem, e, r, lab, chart)
                for g in (folder, "all views"):
                    row = rows.setdefault((g, who, label), ([], []))
                    row[0].extend(ch)
                    row[1].extend(un)
            if who == "three":
                for reg in np.unique(lab[lab > 0]):
                    m = lab == reg
                    levels.setdefault(folder, []).append(f[m].mean(0) / t[m].mean(0))
    folders = [c.folder for c in spec.cameras]
    return {"rows": rows, "levels": {k: np.array(v) for k, v in levels.items()}, "folders": folders}


def ladder_table(result: dict) -> str:
    """Markdown tables of :func:`ladder`'s result: ΔE00 means per row, then the levels."""
    rows, folders = result["rows"], result["folders"]
    n = len(folders)
    groups = [f for f in folders if (f, "three", "pipeline") in rows] + ["all views"]
    lines = [
        "| views | cameras | responses | chart patch mean | uniform surface mean |",
        "|---|---|---|---:|---:|",
    ]
    for g in groups:
        ch, un = rows[(g, "three", "pipeline")]
        lines.append(f"| {g} | regions | | {len(ch)} | {len(un)} |")
        for (g_, who, label), (ch, un) in rows.items():
            if g_ == g:
                c = f"{np.mean(ch):.2f}" if ch else "—"
                u = f"{np.mean(un):.2f}" if un else "—"
                lines.append(
                    f"| {g} | {'three' if who == 'three' else '(b) own camera'} | {label} | {c} | {u} |"
                )
    head = " | ".join(f"{f}: level (scatter) R, G, B" for f in folders)
    lines += ["", f"| view camera | {head} |", "|---|" + "---|" * n]
    for folder, lv in result["levels"].items():
        med = np.median(lv, 0)
        mad = np.median(np.abs(lv - med), 0)
        lines.append(
            f"| {folder} | "
            + " | ".join(
                ", ".join(f"{med[3 * c + j]:.3f} ({mad[3 * c + j]:.3f})" for j in range(3)) for c in range(n)
            )
            + " |"
        )
    return "\n".join(lines)


def truth_noise(truth: Path, regions, stride: int) -> dict | None:
    """The expected ΔE00 of each region mean of a separately rendered truth from its own Monte Carlo
    noise (``truth/xyz_se``, :func:`splat.sim.mitsuba.truth_xyz`), on the scorer's stride grid: camera
    folder → (chart, uniform) with the X, Y, Z errors fully correlated, then (chart, uniform) with them
    independent, means over regions; None without ``xyz_se``. The pixels' errors are independent, so a
    region mean's standard error is √Σse² / n; its ΔE00 is averaged over 64 draws. The path tracer's
    errors are those of the light's sampling, correlated 0.92–0.99 across X, Y, Z (2026-11-29 record),
    so the first pair is the one to read; independent errors would move the chromaticity too."""
    import colour
    import tifffile

    files = sorted((truth / "xyz_se").rglob("*.tiff"))
    if not files:
        return None
    w = np.array(colour.xy_to_XYZ(colour.CCS_ILLUMINANTS["CIE 1931 2 Degree Standard Observer"]["D65"]))
    xy = colour.XYZ_to_xy(w)
    rng = np.random.default_rng(0)
    per: dict = {}
    for f in files:
        rel = f.relative_to(truth / "xyz_se")
        ref = np.asarray(tifffile.imread(truth / "xyz" / rel), float)
        se = np.asarray(tifffile.imread(f), float)
        lab, chart = regions(ref)
        s = (slice(None, None, stride),) * 2
        lab, ref, se = lab[s], ref[s], se[s]
        row = per.setdefault(rel.parts[0], {})
        for reg in np.unique(lab[lab > 0]):
            m = lab == reg
            mu = ref[m].mean(0)
            sem = np.sqrt((se[m] ** 2).sum(0)) / m.sum()
            lab_mu = colour.XYZ_to_Lab(mu / w[1], xy)
            kind = "chart" if int(reg) in chart else "uniform"
            for how, z in (
                ("correlated", rng.normal(size=(64, 1))),
                ("independent", rng.normal(size=(64, 3))),
            ):
                draws = colour.XYZ_to_Lab((mu + z * sem) / w[1], xy)
                d = colour.delta_E(lab_mu, draws, method="CIE 2000")
                row.setdefault((how, kind), []).append(float(np.mean(d)))
    keys = [(h, k) for h in ("correlated", "independent") for k in ("chart", "uniform")]
    return {
        f: tuple(float(np.mean(v[x])) if v.get(x) else float("nan") for x in keys) for f, v in per.items()
    }


def table(sc: dict, folders: list[str]) -> tuple[str, dict]:
    """Markdown table of the score (views grouped by camera, then all) and the ratios three / (a), (b)."""
    per_view = sc["per_view"]
    groups = {f: [v for v in per_view if v.split("/")[0] == f] for f in folders}
    groups["all views"] = list(per_view)
    lines = [
        "| views | estimate | " + " | ".join(m for _, m in MEASURES) + " |",
        "|---|---|" + "---:|" * len(MEASURES),
    ]
    ratios = {}
    for g, names in groups.items():
        if not names:
            continue
        vals = {}
        for key, text in ROWS:
            cells = []
            for m, _ in MEASURES:
                xs = []
                for v in names:
                    row = per_view[v].get(_labels(v.split("/")[0], folders)[key], {})
                    xs.append(row.get(m))
                xs = [x for x in xs if x is not None]
                vals[(key, m)] = float(np.mean(xs)) if len(xs) == len(names) else float("nan")
                cells.append(f"{vals[(key, m)]:.2f}")
            lines.append(f"| {g} ({len(names)}) | {text} | " + " | ".join(cells) + " |")
        for base in ("dev", "one"):
            ratios[(g, base)] = {m: vals[("three", m)] / vals[(base, m)] for m, _ in MEASURES}
        lines.append(
            f"| {g} | three ÷ (a), ÷ (b) | "
            + " | ".join(f"{ratios[(g, 'dev')][m]:.2f}, {ratios[(g, 'one')][m]:.2f}" for m, _ in MEASURES)
            + " |"
        )
    return "\n".join(lines), ratios


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--size", choices=("ci", "benchmark"), default="ci")
    ap.add_argument(
        "--capture", default=None, help="a simulated capture with truth/ to score instead of writing one"
    )
    ap.add_argument("--steps", type=int, default=None, help="training steps (default 300 CI, 3000 benchmark)")
    ap.add_argument("--capacity", type=int, default=None, help="Gaussians (default 2048 CI, 16384 benchmark)")
    ap.add_argument("--texture", choices=("fine", "coarse"), default="fine")
    ap.add_argument("--no-noise", action="store_true", help="noise-free simulated capture")
    ap.add_argument("--colmap", action="store_true", help="recover poses with pycolmap (default: true poses)")
    ap.add_argument("--stride", type=int, default=2, help="pixel stride of the splat estimates' scores")
    ap.add_argument("--threads", type=int, default=2)
    ap.add_argument("--work", default=None, help="work folder (default: a temporary one)")
    ap.add_argument(
        "--oracle",
        type=int,
        default=0,
        metavar="SPP",
        help="a splat.sim.mitsuba capture: render the held-out views again at SPP samples through every "
        "camera and print the truth's noise floor and each camera's level against the truth",
    )
    ap.add_argument(
        "--truth-spp",
        type=int,
        default=0,
        metavar="SPP",
        help="a splat.sim.mitsuba capture: score against its held-out views' XYZ rendered again on their "
        "own at SPP samples per pixel (splat.sim.mitsuba.write_truth, in the work folder's copy)",
    )
    ap.add_argument(
        "--ladder",
        action="store_true",
        help="a capture this script writes: replace the fused responses by the true ones step by step "
        "and print where the region-mean error comes from (ladder)",
    )
    ap.add_argument(
        "--render-sources",
        type=int,
        default=None,
        help="photographs per camera reprojected into each view (PipelineConfig.render_sources; 0: all)",
    )
    args = ap.parse_args(argv)
    big = args.size == "benchmark"
    steps = args.steps or (3000 if big else 300)
    capacity = args.capacity or (16384 if big else 2048)
    import tempfile

    from splat.capture import PipelineConfig, read_capture, run
    from splat.scoring import score
    from splat.sim.capture import SimCaptureConfig, write_synthetic_capture

    work = Path(args.work or tempfile.mkdtemp(prefix="bench_capture_accuracy_"))
    capture, out = work / "capture", work / "out"
    t0 = time.perf_counter()
    if args.capture is not None and not Path(args.capture, "truth").is_dir():
        print(f"--capture {args.capture}: no truth/ folder (a simulated capture is needed)", file=sys.stderr)
        return 2
    if not (capture / "capture.toml").is_file():
        if args.capture is not None:
            shutil.copytree(args.capture, capture)
        else:
            make = SimCaptureConfig.benchmark if big else SimCaptureConfig.ci
            write_synthetic_capture(capture, make(texture=args.texture, noise=not args.no_noise))
        if not args.colmap:
            (capture / "poses").mkdir()
            for f in ("cameras.txt", "images.txt", "points3D.txt"):
                shutil.copy(capture / "truth" / f, capture / "poses" / f)
            with open(capture / "capture.toml", "a") as fh:
                fh.write('\n[poses]\ncolmap = "poses"\n')
    if args.truth_spp:
        import tomllib

        from splat.sim.mitsuba import write_truth

        tt = tomllib.loads((capture / "truth" / "truth.toml").read_text())
        if tt.get("generator") != "splat.sim.mitsuba":
            print(f"--truth-spp: {capture} is not a splat.sim.mitsuba capture", file=sys.stderr)
            return 2
        if tt.get("truth_spp") != args.truth_spp:
            t0 = time.perf_counter()
            write_truth(capture, args.truth_spp)
            print(f"truth rendered again at {args.truth_spp} spp in {time.perf_counter() - t0:.0f} s")
    spec = read_capture(capture)
    held = tuple(spec.holdout)
    extra = {}
    if args.render_sources is not None:
        extra["render_sources"] = args.render_sources or None
    cfg = PipelineConfig(steps=steps, capacity=capacity, threads=args.threads, views=held, **extra)
    times = {"simulate": time.perf_counter() - t0}
    # scoring writes its white, δ and fusion caches into OUT/correct, which the pipeline's workspace
    # then refuses as foreign: a scored work folder is scored again without rerunning the steps
    if not (out / "render" / "index.json").is_file():
        for step in ("poses", "train", "render"):
            t0 = time.perf_counter()
            run(capture, out, config=cfg, steps=(step,))
            times[step] = time.perf_counter() - t0
    t0 = time.perf_counter()
    folders = [c.folder for c in spec.cameras]
    regions = labelled_regions(capture / "truth")
    if regions is not None:  # a path-traced truth: surfaces from its labels (see labelled_regions)
        import splat.scoring

        splat.scoring.region_labels = regions
    n = len(folders)
    sc = score(
        capture,
        out,
        stride=args.stride,
        methods=("Prior",),
        subsets=[(k,) for k in range(n)] + [tuple(range(n))],
        raw_methods=(),
    )
    times["score"] = time.perf_counter() - t0
    what = (
        f"capture {args.capture}"
        if args.capture
        else f"capture {args.size}, texture {args.texture}, noise {not args.no_noise}"
    )
    print(
        f"{what}, {steps} steps, "
        f"capacity {capacity}; {len(sc['per_view'])} held-out views; δ = {sc['delta']:.4f}; best "
        f"demosaicing for (a): {sc['dev_demosaic']}; seconds: "
        + ", ".join(f"{k} {v:.0f}" for k, v in times.items())
        + "\n"
    )
    text, ratios = table(sc, folders)
    print(text)
    r = ratios[("all views", "one")]
    for m in ("chart", "uniform"):
        if not np.isfinite(r[m]):  # e.g. the CI size: chart patches of 3–5 px have no 5 × 5 interior
            print(f"\n{dict(MEASURES)[m]}: not measured (no such region's interior in every held-out view)")
            continue
        print(
            f"\n{dict(MEASURES)[m]}: three cameras ÷ one camera (b) = {r[m]:.2f} (goal ≤ 0.5: "
            f"{'met' if r[m] <= 0.5 else 'NOT met'}); ÷ own development (a) = "
            f"{ratios[('all views', 'dev')][m]:.2f}"
        )
    floor = truth_noise(capture / "truth", regions, args.stride) if regions is not None else None
    if floor:
        print(
            "\nThe truth's own noise, expected ΔE00 of a region mean, chart / uniform, its X, Y, Z errors "
            "correlated (independent): "
            + ", ".join(f"{k} {c:.2f} / {u:.2f} ({ci:.2f} / {ui:.2f})" for k, (c, u, ci, ui) in floor.items())
        )
    if args.oracle and regions is not None:
        print("\nDiagnostics from the scene (not available to the pipeline):\n")
        print(oracle(capture, out, args.oracle, regions))
    if args.ladder:
        if args.capture is not None:
            print("\n--ladder: needs a capture this script writes (its scene is rebuilt); skipped")
        else:
            make = SimCaptureConfig.benchmark if big else SimCaptureConfig.ci
            print("\nWhere the region-mean error comes from (truth, not available to the pipeline):\n")
            config = make(texture=args.texture, noise=not args.no_noise)
            print(ladder_table(ladder(capture, out, config, args.stride)))
    print(f"\nwork folder {work}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
