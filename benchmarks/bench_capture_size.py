"""The correct step on a real-size photograph: time, peak memory and how they grow with pixels.

What it builds (state it whenever quoting the numbers): the CI-size simulated capture
(``splat.sim.capture``, 3 cameras × 8 views at ~128 × 96) runs through poses, train and render; then
one of its held-out Nikon photographs is **upsampled** ``--scale`` times (its RAW file demosaiced,
upsampled bilinearly, re-mosaicked and given fresh shot + read noise from its own DNG NoiseProfile,
written as a DNG by isp's writer): at the default ``--scale 44`` a 5632 × 4224 (23.8 MP) RGGB file with
no detail finer than the original's 128 × 96 pixels. The other cameras' photographs that the
full-resolution reprojection reads (``splat._tol.FULL_SOURCES`` per camera, chosen as the correct step
chooses them) are upsampled the same way (the Sigma's as full-colour LinearRaw DNGs), so every
photograph is at ``--scale`` times its size and the working resolution is the original one
(``f = --scale``). The full-resolution stage's cost depends on the pixel count, the number of sources
and noise patterns, not on the content.

Measured, in one process:

* the working-resolution part of the correct step (the capture read at the working resolution, white,
  fusion noise; the view's fused responses, ``fused_view``, and their correction, ``correct_fused``, at
  the model's resolution, the same for any photograph size);
* the full-resolution stage (:func:`splat.strips.full_resolution_view` + :func:`splat.strips.write_full`:
  read the DNG, demosaic, correct, write the float32 TIFF and the PNG in strips) by **both paths,
  alternated run by run**: the previous one (the other cameras' channels from the working fusion
  upsampled and sharpened) and the full-resolution reprojection (the other cameras' photographs read
  at full resolution through the depth rendered per strip; the sources' files opened inside the
  timing); median of ``--runs`` runs at ``--scale``, one run at ``--scale`` / 4 and / 2 for the growth
  with pixels (log-log slopes of wall, CPU and peak RSS), peak RSS (Linux ``VmHWM`` reset before each
  run). The depth renderer is compiled for each image width before the timing (printed);
* unless ``--only-full``: **baselines** — the older path (every pixel of the fused responses corrected
  by Prior with colour deduplication, ``correct_fused``) on a 96 × 96 crop and on the view's own
  responses, extrapolated per pixel; and the plain development of the same photograph (isp's Malvar
  demosaic of the whole mosaic in one piece and the camera's DNG matrix).

``--against REV`` adds a path timed alongside: the full-res reprojection as ``splat/strips.py``,
``splat/reproject.py``, the rasteriser's kernels (``splat/_raster_kernel.py``) and the root-polynomial
regression's terms (``zonotope/correct/regressions.py``) were at git ``REV`` (their sources
made by that version, one strip after the other), for before/after ratios in one process.
``--own-sources N`` adds the current path reading ``N`` of the photograph's own camera's other
photographs (0: the other cameras' only, as before they were averaged in) instead of
:data:`splat._tol.FULL_OWN_SOURCES`, on as many threads as the most of ``--workers``; the ``REV`` path
reads the other cameras' only. ``--plain-texture`` adds it without the render at full resolution
anchored at textured pixels (their responses the working ones upsampled, as before). ``--workers 1,2``
times the current full-res reprojection with each number of strips computed at once (threads; default
``1`` and :func:`splat.strips.default_workers`), each printed with its process CPU and wall time, CPU /
wall (the cores it kept busy) and the machine's load average; ``--no-previous`` and ``--no-growth``
leave out the previous path and the smaller sizes; ``--no-write`` drops the strips instead of writing
the files.

    python benchmarks/bench_capture_size.py --work /tmp/bench_capture_size [--scale 44] [--runs 3]
        [--only-full] [--against REV] [--own-sources N] [--plain-texture] [--workers 1,2]
        [--no-previous] [--no-growth] [--no-write]
"""

from __future__ import annotations

import argparse
import contextlib
import inspect
import json
import os
import statistics
import sys
import time
from pathlib import Path

import numpy as np

try:  # run as a script (python benchmarks/bench_X.py) or imported as benchmarks.bench_X
    from _upsample import upsampled_dng as _upsampled_dng
except ImportError:
    from benchmarks._upsample import upsampled_dng as _upsampled_dng


def _ci_run(work: Path, steps: int):
    from splat.capture import PipelineConfig, read_capture, run
    from splat.sim.capture import SimCaptureConfig, write_synthetic_capture

    cap = work / "capture"
    if not (cap / "capture.toml").is_file():
        write_synthetic_capture(cap, SimCaptureConfig.ci())
    spec = read_capture(cap)
    name = next(h for h in spec.holdout if h.startswith("nikon/"))
    config = PipelineConfig(steps=steps, capacity=2048, quantum=0.02, threads=2, views=(name,))
    out = work / "out"
    res = run(cap, out, config=config, steps=("poses", "train", "render"))
    return spec, config, out, name, res


def _modules_at(rev: str):
    """``splat/strips.py`` and ``splat/reproject.py`` as they were at git ``rev``, loaded as modules of
    ``splat`` beside the current ones (the same process, so that the machine's load falls on both), and
    the rasteriser's kernels (``splat/_raster_kernel.py``) and root-polynomial regression
    (``zonotope/correct/regressions.py``) at ``rev``, which :func:`_kernels_of` puts in place while
    that path runs."""
    import importlib.util
    import subprocess

    root = Path(__file__).resolve().parents[1]
    mods = []
    for package, name in (("splat", "reproject"), ("splat", "strips"), ("splat", "_raster_kernel"),
                          ("zonotope.correct", "regressions")):  # fmt: skip
        text = subprocess.run(
            ["git", "-C", str(root), "show", f"{rev}:{package.replace('.', '/')}/{name}.py"],
            capture_output=True,
            text=True,
            check=True,
        ).stdout
        text = text.replace("from .reproject import", "from ._reproject_older import")
        text = text.replace("cache=True", "cache=False")  # numba caches only functions with a file
        spec = importlib.util.spec_from_loader(f"{package}._{name}_older", loader=None)
        mod = importlib.util.module_from_spec(spec)
        mod.__package__ = package
        sys.modules[spec.name] = mod
        exec(compile(text, f"{rev}:{package}/{name}.py", "exec"), mod.__dict__)
        mods.append(mod)
    return mods[1], mods[0], mods[2], mods[3]


@contextlib.contextmanager
def _kernels_of(older):
    """The rasteriser's forward kernel and the root-polynomial terms of ``older`` (:func:`_modules_at`)
    in place of the current ones meanwhile (the fitted estimators look them up when called)."""
    from splat import _raster_kernel as kern
    from zonotope.correct import regressions as reg

    _, _, old_kern, old_reg = older
    kept = (kern.forward, reg._terms_by_row)
    try:
        kern.forward, reg._terms_by_row = old_kern.forward, old_reg._terms_by_row
        yield
    finally:
        kern.forward, reg._terms_by_row = kept


@contextlib.contextmanager
def _using(strips, mod):
    """``splat.strips``' row sources and :class:`FullReprojection` taken from ``mod`` meanwhile (the
    correct step's ``full_reprojection`` imports them when called; fields the older one lacks are
    dropped)."""
    names = ("raw_row_source", "FullReprojection")
    kept = {n: getattr(strips, n) for n in names}
    older = mod.FullReprojection
    try:
        strips.raw_row_source = mod.raw_row_source
        strips.FullReprojection = lambda *args: older(*args[: len(older._fields)])
        yield
    finally:
        for n, v in kept.items():
            setattr(strips, n, v)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--work", type=Path, default=Path("/tmp/bench_capture_size"))
    ap.add_argument("--scale", type=int, default=44, help="upsampling of the 128 × 96 photograph (even)")
    ap.add_argument("--runs", type=int, default=3)
    ap.add_argument("--steps", type=int, default=150, help="training steps of the small model")
    ap.add_argument("--crop", type=int, default=96, help="side of the baseline's crop")
    ap.add_argument("--only-full", action="store_true", help="the full-resolution stage only (no baselines)")
    ap.add_argument(
        "--against",
        metavar="REV",
        help="also time the full-res reprojection as splat/strips.py, splat/reproject.py, the rasteriser's "
        "kernels and the root-polynomial regression were at git REV",
    )
    ap.add_argument(
        "--workers", help="comma-separated numbers of strips computed at once (default 1,<cores>)"
    )
    ap.add_argument(
        "--own-sources",
        type=int,
        metavar="N",
        help="also time the full-res reprojection reading N of the own camera's other photographs "
        "(0: the other cameras' only) instead of splat._tol.FULL_OWN_SOURCES",
    )
    ap.add_argument(
        "--plain-texture",
        action="store_true",
        help="also time the full-res reprojection without the render anchored at textured pixels",
    )
    ap.add_argument("--no-previous", action="store_true", help="leave out the previous (upsampled) path")
    ap.add_argument("--no-growth", action="store_true", help="time --scale only (no smaller sizes)")
    ap.add_argument(
        "--no-write", action="store_true", help="consume the strips without writing the TIFF and PNG"
    )
    args = ap.parse_args(argv)
    if args.scale % 2:
        ap.error("--scale must be even (the RGGB pattern keeps its phase)")
    args.work.mkdir(parents=True, exist_ok=True)

    from splat import capture as P
    from splat import strips
    from splat.capture import load_views, open_raw
    from splat.capture.workspace import peak_rss_mib, reset_peak_rss

    spec, config, out, name, _ = _ci_run(args.work, args.steps)
    steps = {
        s: {
            k: json.loads((out / s / "summary.json").read_text()).get(k)
            for k in ("duration_s", "peak_rss_mib")
        }
        for s in ("poses", "train", "render")
    }
    print(f"CI capture, one view ({name}), small-model steps (s, MiB): {steps}")

    # the working-resolution part of the correct step, as correct_step does it
    t, c0 = time.perf_counter(), time.process_time()
    raws = {v.name: v for v in load_views(spec, binning=P.working_binning(config, spec))}
    index = P.read_index(spec, out / "render" / "index.json")
    # the white and noise caches go to a scratch folder beside OUT (OUT's correct step is not run here)
    scratch = args.work / "scratch"
    (scratch / "correct").mkdir(parents=True, exist_ok=True)
    if not (scratch / "render").exists():
        (scratch / "render").symlink_to(out / "render")
    white = P.white_of(spec, scratch, list(raws.values()))
    scale = np.concatenate(white["scale"])
    n = len(spec.cameras)
    fusion = P.fusion_of(spec, scratch, index, raws, scale)
    d = out / "render" / index[name]["dir"]
    img = P.read_tiff(d / "render.tiff") / scale
    rep = P.reprojected_of(d, scale)
    view = raws[name]
    fused, code, sigma = P.fused_view(fusion, name, img, view, scale, list(range(n)), rep)
    fit_full = P.fused_fitter(spec, list(range(n)), strips.FULL_METHOD)
    # the view's working-resolution answer, as correct_step writes it (config.method, its λ)
    P.correct_fused(fused, code, sigma, P.fused_fitter(spec, list(range(n)), config.method), config.quantum)
    wXYZ = P.correction_problem_of(spec, list(range(n))).white_XYZ
    t_working, cpu_working = time.perf_counter() - t, time.process_time() - c0
    print(
        f"working-resolution part ({view.shape[1]}×{view.shape[0]}): {t_working:.1f} s "
        f"(read, white, fusion noise, fused_view, its correction; process CPU {cpu_working:.1f} s)"
    )

    noise = P.own_noise(fusion, raws, scale, "auto")[name]
    # the other cameras' photographs at full resolution: every photograph upsampled like the view
    import dataclasses

    from splat.capture.correct import full_reprojection
    from splat.capture.train import load_model_capture, refined_views

    _, cap = load_model_capture(spec, out)
    wviews = {v.name: v for v in refined_views(P.working_views(cap.views, raws), out)}

    def model_at(s, own=None):
        fake = {m: dataclasses.replace(r, binning=s) for m, r in raws.items()}

        def open_source(r):
            stem = r.name.replace("/", "_").rsplit(".", 1)[0]
            return open_raw(
                _upsampled_dng(raws[r.name], spec, args.work / f"{stem}_x{s}.dng", s), spec.cameras[r.camera]
            )

        made = full_reprojection(
            spec, out, fake, fusion, scale, views=wviews, open_source=open_source, own_sources=own
        )
        return made, fake[name]

    rows = []
    counts = sorted({int(w) for w in (args.workers or f"1,{strips.default_workers()}").split(",")})
    if not counts or min(counts) < 1:
        ap.error("--workers: give numbers ≥ 1, e.g. 1,2")
    full = {
        (
            f"full-res reprojection, {w} thread{'s' if w > 1 else ''}"
            if len(counts) > 1
            else "full-res reprojection"
        ): w
        for w in counts
    }
    paths = (*(() if args.no_previous else ("previous",)), *full)
    own_path = None
    if args.own_sources is not None:
        own_path = f"full-res reprojection, {args.own_sources} own photographs"
        paths = (*paths, own_path)
    tex_path = "full-res reprojection, textured pixels upsampled" if args.plain_texture else None
    if tex_path:
        paths = (*paths, tex_path)
    older = _modules_at(args.against) if args.against else None
    if older is not None:
        paths = (*paths, f"full-res reprojection at {args.against}")
    sizes = (
        {args.scale}
        if args.no_growth
        else {max(2, args.scale // 4 // 2 * 2), max(2, args.scale // 2 // 2 * 2)}
    )
    for s in sorted(sizes | {args.scale}):
        big = _upsampled_dng(view, spec, args.work / f"nikon_x{s}.dng", s)
        model, fake_view = model_at(s)
        if older is not None:
            with _using(strips, older[0]):  # the older path's sources as the older module makes them
                older_model, _ = model_at(s, own=0)  # the other cameras' photographs only
        own_model = model_at(s, own=args.own_sources)[0] if own_path else None
        H, W = open_raw(big, spec.cameras[view.camera]).shape
        chosen = model(fake_view, (H, W))  # writes the sources' DNGs once, outside the timing
        t = time.perf_counter()  # the depth renderer compiled for this width (once per image size)
        for r0 in sorted({0, (H - 1) // strips.STRIP_ROWS * strips.STRIP_ROWS}):
            strips.reprojected_strip(chosen.rep, r0, min(H, r0 + strips.STRIP_ROWS))
            if older is not None:
                with _kernels_of(older):  # the older kernel compiled too
                    strips.reprojected_strip(chosen.rep, r0, min(H, r0 + strips.STRIP_ROWS))
        named = {spec.cameras[k].folder: [r.name for r in g] for k, g in chosen.names.items()}
        print(
            f"  ×{s}: sources at full resolution {named}; compiling and first strips "
            f"{time.perf_counter() - t:.1f} s"
        )
        del chosen
        res = {p: ([], [], []) for p in paths}
        for _ in range(args.runs if s == args.scale else 1):
            for path in paths:  # alternated, so that the machine's load falls on both alike
                times, cpus, peaks = res[path]
                load = os.getloadavg()[0]
                reset_peak_rss()
                t, c0 = time.perf_counter(), time.process_time()
                src = open_raw(big, spec.cameras[view.camera])
                mod = older[0] if path == paths[-1] and older is not None else strips
                made = older_model if mod is not strips else own_model if path == own_path else model
                rep = made(fake_view, (H, W)) if path != "previous" else None
                given = None if rep is None else rep.rep
                if path == tex_path:
                    given = given._replace(render_scale=None)
                if mod is strips:
                    threads = {"workers": full.get(path, max(full.values()))}
                else:  # the older code with as many strips at once as the current one, where it can
                    takes = "workers" in inspect.signature(mod.full_resolution_view).parameters
                    threads = {"workers": max(full.values())} if takes else {}
                gen = mod.full_resolution_view(
                    strips.Photograph(
                        src, view.exif, white["scale"][view.camera], np.asarray(noise["sigma_full"])
                    ),
                    strips.WorkingFusion(fused, code, sigma, slice(3 * view.camera, 3 * view.camera + 3), s),
                    fit_full,
                    reprojection=given,
                    **threads,
                )
                with _kernels_of(older) if mod is not strips else contextlib.nullcontext():
                    if args.no_write:
                        for _ in gen:
                            pass
                    else:
                        strips.write_full(
                            args.work / "full_XYZ.tiff",
                            args.work / "full_sRGB.png",
                            gen,
                            (H, W),
                            strips.sRGB8_encoder(wXYZ),
                        )
                times.append(time.perf_counter() - t)
                cpus.append(time.process_time() - c0)
                peaks.append(peak_rss_mib())
                print(
                    f"    run: {path}: wall {times[-1]:.1f} s, CPU {cpus[-1]:.1f} s, CPU/wall "
                    f"{cpus[-1] / times[-1]:.2f}, load {load:.1f} → {os.getloadavg()[0]:.1f}",
                    flush=True,
                )
                del src, rep, gen
        for path in paths:
            times, cpus, peaks = res[path]
            rows.append(
                (s, H * W / 1e6, statistics.median(times), max(peaks), times, statistics.median(cpus), path)
            )
            print(
                f"  ×{s}: {W}×{H} = {H * W / 1e6:.1f} MP, {path}: {statistics.median(times):.1f} s "
                f"(runs {[round(x, 1) for x in times]}), process CPU {statistics.median(cpus):.1f} s "
                f"(runs {[round(x, 1) for x in cpus]}), "
                f"CPU/wall {statistics.median(cpus) / statistics.median(times):.2f}, "
                f"peak RSS {max(peaks):.0f} MiB"
            )
    for path in paths:
        sel = [r for r in rows if r[6] == path]
        mp = np.array([r[1] for r in sel])
        ts, cs, pk = (np.array([r[i] for r in sel]) for i in (2, 5, 3))

        def fit(y, mp=mp):
            return float(np.polyfit(np.log(mp), np.log(y), 1)[0])

        growth = (
            f"wall ∝ pixels^{fit(ts):.2f}, CPU ∝ pixels^{fit(cs):.2f}, peak RSS ∝ pixels^{fit(pk):.2f}; "
            if len(mp) > 1  # --no-growth: one size, no slope
            else ""
        )
        print(f"{path}: {growth}{cs[-1] / mp[-1]:.2f} s of CPU per MP at the largest size")
    last = {r[6]: r for r in rows}  # each path at the largest size
    base = [p for p in paths if p not in full]  # previous, REV, own N: the baselines in this process
    for p in full:
        for b in base:
            new, old = last[p], last[b]
            print(
                f"{p} / {b} at {new[1]:.1f} MP: wall {new[2] / old[2]:.2f}×, CPU "
                f"{new[5] / old[5]:.2f}×, peak RSS {new[3]:.0f} / {old[3]:.0f} MiB"
            )
    print(f"load average during the run: {os.getloadavg()[0]:.1f} (2 cores)")
    if args.only_full:
        return 0
    rows = [r for r in rows if r[6] == list(full)[-1]]

    # baseline 1: the previous path (Prior with deduplication, per pixel) on a crop of the same responses
    s = args.scale
    src = open_raw(args.work / f"nikon_x{s}.dng", spec.cameras[view.camera])
    H, W = src.shape
    c = args.crop
    r0 = (H // 2) // 2 * 2
    from splat.strips import demosaic_rows, upsample_rows

    lin, _ = demosaic_rows(src, r0, r0 + c)
    photo = (lin / view.exif / white["scale"][view.camera])[:, W // 2 : W // 2 + c]
    up = upsample_rows(fused, s, r0, r0 + c, W)[:, W // 2 : W // 2 + c]
    own = slice(3 * view.camera, 3 * view.camera + 3)
    ratio = (np.maximum(photo, 0).sum(-1, keepdims=True) + 1e-6) / (
        np.maximum(up[..., own], 0).sum(-1, keepdims=True) + 1e-6
    )
    resp = np.maximum(up, 0) * ratio
    resp[..., own] = photo
    cd = strips.nearest_rows(code, s, r0, r0 + c, W)[:, W // 2 : W // 2 + c]
    fit_prior = P.fused_fitter(spec, list(range(n)), config.method)
    for cc in np.unique(np.concatenate([cd.ravel(), code.ravel()])):  # fits: not the per-pixel cost
        fit_prior(sigma[int(cc)])
    t, c0 = time.perf_counter(), time.process_time()
    P.correct_fused(resp, cd, {int(k): sigma[int(k)] for k in np.unique(cd)}, fit_prior, config.quantum)
    t_crop, cpu_crop = time.perf_counter() - t, time.process_time() - c0
    t_prior = t_crop * H * W / (c * c)
    print(
        f"baseline (previous path, {config.method} per pixel with deduplication, quantum "
        f"{config.quantum}) on a "
        f"{c}×{c} crop: {t_crop:.1f} s (process CPU {cpu_crop:.1f} s) → {t_prior:.0f} s for "
        f"{H * W / 1e6:.1f} MP by extrapolation"
    )
    # baseline 1b: the same previous path on the view's own working-resolution responses (real texture:
    # every pixel a distinct colour, as on a real photograph), per pixel, extrapolated
    t, c0 = time.perf_counter(), time.process_time()
    P.correct_fused(fused, code, sigma, fit_prior, config.quantum)
    t_real, cpu_real = time.perf_counter() - t, time.process_time() - c0
    n_px = fused.shape[0] * fused.shape[1]
    print(
        f"baseline on the view's {fused.shape[1]}×{fused.shape[0]} textured responses: {t_real:.1f} s "
        f"(process CPU "
        f"{cpu_real:.1f} s) → {t_real * H * W / n_px:.0f} s (CPU {cpu_real * H * W / n_px:.0f} s) for "
        f"{H * W / 1e6:.1f} MP by extrapolation"
    )
    # baseline 2: the plain development of the same photograph in one piece (Malvar + DNG matrix)
    from isp.stages import demosaic

    reset_peak_rss()
    t, c0 = time.perf_counter(), time.process_time()
    values, _ = src.rows(0, H)
    lin = demosaic(values.sum(-1), cfa=src.cfa, method="Malvar 2004")
    del values
    raw = __import__("isp").read_raw(args.work / f"nikon_x{s}.dng")
    X = P.dng_matrix_XYZ(
        np.maximum(lin / view.exif / white["scale"][view.camera], 0), raw.profile, raw.as_shot_neutral, wXYZ
    )
    t_dev, cpu_dev = time.perf_counter() - t, time.process_time() - c0
    print(
        "plain development of the same photograph (whole image, Malvar + DNG matrix): "
        f"{t_dev:.1f} s (process CPU {cpu_dev:.1f} s), peak RSS {peak_rss_mib():.0f} MiB"
    )
    del X, lin
    full = rows[-1]
    print(
        f"correct step on one {full[1]:.1f} MP three-camera photograph: {t_working + full[2]:.1f} s "
        f"(working part {t_working:.1f} s + full resolution {full[2]:.1f} s, median of {len(full[4])}); "
        f"{t_prior / (t_working + full[2]):.0f}× faster than the previous path's extrapolated "
        f"{t_prior:.0f} s; "
        f"process CPU {cpu_working + full[5]:.1f} s; "
        f"goal ≤ 60 s (wall): {'met' if t_working + full[2] <= 60 else 'NOT met'}"
    )
    return 0


if __name__ == "__main__":
    sys.exit(main())
