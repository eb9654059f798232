"""A real-size capture end to end: ``splat run`` on 3 cameras × 12 photographs of ≥ 12 MP, time and
peak memory per step, and how each grows with pixels, views and Gaussians.

What the capture is (state it whenever quoting the numbers): the simulated scene of
``splat.sim.capture`` (fine texture, shot and read noise) rendered at ``--sim-scale`` × the CI size
(default 2: Nikon 256 × 192 RGGB, Sigma 224 × 168 full-colour, Canon 272 × 180 GBRG), 12 views per
camera (10 training + 2 held out), and every photograph **upsampled** to at least ``--mp`` megapixels
by :func:`_upsample.upsampled_dng` (bilinear, re-mosaicked, fresh shot + read noise from its own
NoiseProfile, written by isp's DNG writer with the source's EXIF): at the default 12 MP, Nikon
4096 × 3072 (×16), Sigma 4032 × 3024 (×18, LinearRaw), Canon 4352 × 2880 (×16). The files have a
real camera's pixel count and noise but no detail finer than the simulated render. ``capture.toml``
is the simulator's with the white card's box and the chart's corners scaled with their photographs;
the ground truth (``truth/``, at the simulated size) is not copied: this benchmark measures cost, not
colour.

Why upsampled rather than rendered at 12 MP: the ray-caster costs 18–33 s per megapixel on these
cores (docs/benchmarks.md, "The Mitsuba 3 capture"), so 36 × 12 MP would take 2–4 h to simulate;
upsampling takes seconds per photograph, and every step's cost beyond the working resolution depends on
the pixel count, not on the detail (the working resolution itself is bounded by
``splat._tol.TRAIN_PIXEL_BUDGET`` whatever the file size).

Each run is ``splat run CAPTURE -o OUT [options]`` in a child process, exactly as a user types it.
Per step: the wall time and peak RSS the pipeline records (``OUT/<step>/summary.json``:
``duration_s``, ``peak_rss_mib``; the report step has no summary, its wall time is taken from the
child's end), the child's CPU time (user + system, sampled from ``/proc/<pid>/stat`` every second
and split at the moment each step's summary appears), and the load average while it ran.

    python benchmarks/bench_capture_realsize.py --work W --run main            # the default run
    python benchmarks/bench_capture_realsize.py --work W --run main --steps 30 \
        --select nikon/DSC_0003.dng sigma/SDIM0003.dng canon/IMG_0003.dng   # every file, 3 corrected
    python benchmarks/bench_capture_realsize.py --work W --run 3mp 6views --steps 30 --select ...

``--sim mitsuba`` simulates the photographs with Mitsuba 3 (:mod:`splat.sim.mitsuba`, ``--spp``
samples per pixel) instead of the ray-caster before they are upsampled alike.

``main``: 12 views per camera at ``--mp``; ``3mp``: the same views at ``--mp-small`` megapixels;
``6views``: every second photograph of ``main``'s capture (the same files, 6 per camera); ``cap``:
``main``'s capture with ``--capacity-large`` Gaussians, its poses reused (copied from ``main``'s OUT,
which the settings record accepts as they depend on the capture alone). Results go to
``WORK/results_<run>.json`` and a Markdown table is printed. ``--poses-from OUT`` reuses another OUT's
poses step the same way for any run.

    python benchmarks/bench_capture_realsize.py --work W --run main --render-cost nikon/DSC_0005.dng
    python benchmarks/bench_capture_realsize.py --work W --step-cost

``--render-cost`` times the render step's reprojection into the named views of the run's finished OUT
with 2, 4, 6 photographs per camera against all, and with every second photograph only;
``--step-cost`` times one training step by working size and Gaussians (no capture).
"""

from __future__ import annotations

import argparse
import json
import math
import os
import resource
import shutil
import subprocess
import sys
import time
from pathlib import Path
from types import SimpleNamespace

try:  # run as a script (python benchmarks/bench_X.py) or imported as benchmarks.bench_X
    from _upsample import upsampled_dng
except ImportError:
    from benchmarks._upsample import upsampled_dng

STEPS = ("poses", "train", "render", "correct", "report")
TICK = 1.0  # seconds between samples of the child's CPU time and the load average


def sim_capture(
    work: Path, scale: float, views: int, seed: int = 0, *, sim: str = "raycaster", spp: int = 16
) -> Path:
    """The simulated capture at ``scale`` × the CI size, ``views`` per camera (2 held out): the
    ray-caster's (:mod:`splat.sim.capture`) or, with ``sim="mitsuba"``, Mitsuba 3's path-traced one
    (:mod:`splat.sim.mitsuba`, ``spp`` samples per pixel; specular and rough surfaces,
    inter-reflection, soft shadows), so that the real-size run also meets a physically made scene."""
    if sim == "mitsuba":
        from splat.sim.mitsuba import write_mitsuba_capture

        path = work / f"mitsuba_x{scale:g}_{views}v_{spp}spp"
        if not (path / "capture.toml").is_file():
            write_mitsuba_capture(path, size=scale, views=views - 2, holdout=2, spp=spp, seed=seed)
        return path
    from dataclasses import replace

    from splat.sim.capture import SimCaptureConfig, write_synthetic_capture

    path = work / f"sim_x{scale:g}_{views}v"
    if not (path / "capture.toml").is_file():
        cams = tuple(
            replace(c, width=2 * round(c.width * scale / 2), height=2 * round(c.height * scale / 2))
            for c in SimCaptureConfig.ci().cameras
        )
        cfg = SimCaptureConfig.ci(cameras=cams, n_train=views - 2, n_holdout=2, seed=seed)
        write_synthetic_capture(path, cfg)
    return path


def _factor(shape, mp: float, bayer: bool) -> int:
    """Smallest upsampling (even for a Bayer file) that brings ``shape`` to at least ``mp`` MP."""
    s = math.ceil(math.sqrt(mp * 1e6 / (shape[0] * shape[1])))
    return s + (s % 2) if bayer else s


def realsize_capture(sim: Path, out: Path, mp: float) -> tuple[Path, dict]:
    """``sim``'s photographs upsampled to ≥ ``mp`` MP in ``out`` (with the scaled ``capture.toml``);
    returns the folder and, per camera, ``(W, H, factor)``."""
    import tomllib

    from splat.capture import open_raw, read_capture

    spec = read_capture(sim)
    if (out / "capture.toml").is_file():  # built before: kept as it is (its files' times key OUT's steps)
        sizes = {}
        for cam in spec.cameras:
            small = open_raw(sorted((sim / cam.folder).glob("*.dng"))[0], cam).shape
            big = open_raw(sorted((out / cam.folder).glob("*.dng"))[0], cam).shape
            sizes[cam.folder] = (big[1], big[0], big[0] // small[0])
        return out, sizes
    doc = tomllib.loads((sim / "capture.toml").read_text())
    sizes = {}
    for k, cam in enumerate(spec.cameras):
        files = sorted((sim / cam.folder).glob("*.dng"))
        src = open_raw(files[0], cam)
        f = _factor(src.shape, mp, src.cfa is not None)
        sizes[cam.folder] = (src.shape[1] * f, src.shape[0] * f, f)
        (out / cam.folder).mkdir(parents=True, exist_ok=True)
        for i, p in enumerate(files):
            upsampled_dng(
                SimpleNamespace(path=p, camera=k), spec, out / cam.folder / p.name, f, seed=1000 * k + i
            )
    white = doc["white"]
    f = sizes[white["image"].split("/")[0]][2]
    white["box"] = [int(x) * f for x in white["box"]]
    if "chart" in doc and "corners" in doc["chart"]:  # RAW pixel j's centre moves to (j + 1/2) f - 1/2
        g = sizes[doc["chart"]["image"].split("/")[0]][2]
        doc["chart"]["corners"] = [[(x + 0.5) * g - 0.5 for x in c] for c in doc["chart"]["corners"]]
    (out / "capture.toml").write_text(_toml(doc, f"{sim.name} upsampled to ≥ {mp:g} MP"))
    return out, sizes


def subset_capture(src: Path, out: Path, every: int) -> Path:
    """Every ``every``-th photograph of each camera of ``src`` (hard links; the white card's photograph
    always kept), with the matching ``capture.toml``."""
    import tomllib

    doc = tomllib.loads((src / "capture.toml").read_text())
    keep = {doc["white"]["image"]}
    for cam in doc["camera"]:
        files = sorted((src / cam["folder"]).glob("*.dng"))
        start = next((i for i, p in enumerate(files) if f"{cam['folder']}/{p.name}" in keep), 0) % every
        for p in files[start::every]:
            keep.add(f"{cam['folder']}/{p.name}")
    for name in keep:
        (out / name).parent.mkdir(parents=True, exist_ok=True)
        if not (out / name).exists():
            os.link(src / name, out / name)
    if "holdout" in doc:
        doc["holdout"]["images"] = [h for h in doc["holdout"]["images"] if h in keep]
    (out / "capture.toml").write_text(_toml(doc, f"every {every}th photograph of {src.name}"))
    return out


def _toml(doc: dict, note: str) -> str:
    def val(v):
        if isinstance(v, str):
            return json.dumps(v)
        if isinstance(v, bool):
            return "true" if v else "false"
        if isinstance(v, list):
            return "[" + ", ".join(val(x) for x in v) + "]"
        return repr(v)

    lines = [f"# {note}"]
    lines += [f"{k} = {val(v)}" for k, v in doc.items() if not isinstance(v, dict | list)]
    for cam in doc["camera"]:
        lines += ["", "[[camera]]", *(f"{k} = {val(v)}" for k, v in cam.items())]
    for table in ("white", "chart", "holdout", "poses"):
        if table in doc:
            lines += ["", f"[{table}]", *(f"{k} = {val(v)}" for k, v in doc[table].items())]
    return "\n".join(lines) + "\n"


def _cpu_s(pid: int) -> float | None:
    """User + system CPU seconds of ``pid`` and its waited-for children (``/proc/<pid>/stat``)."""
    try:
        fields = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()
    except OSError:
        return None
    return sum(int(x) for x in fields[11:15]) / os.sysconf("SC_CLK_TCK")


def splat_run(capture: Path, out: Path, options: list[str], log: Path) -> dict:
    """``splat run capture -o out options`` in a child process; per step wall s, CPU s, peak RSS MiB
    and load average."""
    exe = Path(sys.executable).with_name("splat")
    cmd = [str(exe), "run"] if exe.is_file() else [sys.executable, "-m", "splat.cli", "run"]
    cmd += [str(capture), "-o", str(out), *options]
    marks = {s: (out / "report.html" if s == "report" else out / s / "summary.json") for s in STEPS}
    start = time.time()
    t0 = time.perf_counter()
    ru0 = resource.getrusage(resource.RUSAGE_CHILDREN)
    with open(log, "a") as fh:
        fh.write(f"\n$ {' '.join(cmd)}\n")
        fh.flush()
        child = subprocess.Popen(cmd, stdout=fh, stderr=subprocess.STDOUT)
    samples = []  # (t, cpu, load1)
    ends = {}  # step → (t, cpu) when its summary appeared
    last_cpu = 0.0
    trace = open(log.with_suffix(".cpu.tsv"), "a")
    trace.write(f"# {' '.join(cmd)}\n# seconds since start, child CPU s, load average (1 min)\n")

    def poll():
        nonlocal last_cpu
        c = _cpu_s(child.pid)
        if c is not None:
            last_cpu = c
        t = time.perf_counter() - t0
        samples.append((t, last_cpu, os.getloadavg()[0]))
        trace.write(f"{t:.1f}\t{last_cpu:.2f}\t{samples[-1][2]:.2f}\n")
        trace.flush()
        for s, p in marks.items():
            if s not in ends and p.is_file() and p.stat().st_mtime >= start:
                ends[s] = (t, last_cpu)

    while child.poll() is None:
        poll()
        time.sleep(TICK)
    wall = time.perf_counter() - t0
    ru = resource.getrusage(resource.RUSAGE_CHILDREN)
    cpu_total = (ru.ru_utime - ru0.ru_utime) + (ru.ru_stime - ru0.ru_stime)
    poll()
    trace.close()
    rows, prev = {}, (0.0, 0.0)
    for s in STEPS:
        if s not in ends:
            continue
        t, c = ends[s]
        if s == "report":  # no summary: from the step before's end to the child's end
            t, c = wall, cpu_total
        summary = {}
        if s != "report":
            summary = json.loads(marks[s].read_text())
        loads = [x[2] for x in samples if prev[0] <= x[0] <= t]
        rows[s] = {
            "wall_s": summary.get("duration_s", t - prev[0]),
            "wall_between_marks_s": t - prev[0],
            "cpu_s": c - prev[1],
            "peak_rss_mib": summary.get("peak_rss_mib"),
            "load": [min(loads), sorted(loads)[len(loads) // 2], max(loads)] if loads else None,
        }
        prev = (t, c)
    loads = [x[2] for x in samples]
    return {
        "command": " ".join(["splat", "run", str(capture), "-o", str(out), *options]),
        "returncode": child.returncode,
        "wall_s": wall,
        "cpu_s": cpu_total,
        "max_rss_mib": ru.ru_maxrss / 1024,
        "load": [min(loads), sorted(loads)[len(loads) // 2], max(loads)] if loads else None,
        "steps": rows,
    }


def step_cost(sizes, gaussians, steps: int = 10, views: int = 3) -> list[dict]:
    """CPU and wall seconds of one training step (:func:`splat.train`, the capture's loss and render
    back-end, ``"auto"``: the CPU one on a CPU, ``"tiled"`` on a GPU) at each working size ``(W, H)`` and
    number of alive Gaussians: the median over the steps after the first two (compilation), ``views``
    views per camera of the synthetic scene at that size, no densification (the alive count stays as
    given); on a GPU also the device's peak memory so far. Why: the train step's cost at a real size is
    steps × this; its growth in pixels and Gaussians decides what a working resolution costs."""
    from dataclasses import replace

    import jax
    import numpy as np

    from splat import SceneConfig, synthetic_scene
    from splat.capture import capture_train_config
    from splat.training import train

    rows = []
    for W, H in sizes:
        scene = synthetic_scene(
            SceneConfig(width=W, height=H, views_per_camera=views, test_views_per_camera=1)
        )
        rng = np.random.default_rng(0)
        lo, hi = (np.asarray(b, float) for b in scene.bounds)
        for G in gaussians:
            cfg = replace(
                capture_train_config(steps=steps, capacity=G), densify_from=steps + 1, densify_until=steps + 1
            )
            marks = []

            def cb(step, state, loss, marks=marks):
                alive = int(state.alive.sum())  # waits for the step's result
                marks.append((time.process_time(), time.perf_counter(), alive))

            t, w = time.process_time(), time.perf_counter()
            train(
                scene.capture,
                scene.images,
                scene.weights,
                config=cfg,
                bounds=scene.bounds,
                points=rng.uniform(lo, hi, (G, 3)),
                callback=cb,
            )
            per = np.diff([t] + [m[0] for m in marks])[2:]
            wall = np.diff([w] + [m[1] for m in marks])[2:]
            peak = (jax.devices()[0].memory_stats() or {}).get("peak_bytes_in_use")
            rows.append(
                {
                    "size": [W, H],
                    "pixels": W * H,
                    "gaussians": marks[-1][2],
                    "cpu_s_per_step": float(np.median(per)),
                    "wall_s_per_step": float(np.median(wall)),
                    "device": str(jax.devices()[0]),
                    "device_peak_mib": None if peak is None else round(peak / 2**20, 1),
                }
            )
            print(
                f"step cost {W}×{H}, {marks[-1][2]} Gaussians: {rows[-1]['cpu_s_per_step']:.3f} s CPU, "
                f"{rows[-1]['wall_s_per_step']:.3f} s wall",
                flush=True,
            )
    return rows


def render_cost(
    capture: Path, out: Path, names: list[str], ks: list, every: int = 2, rounds: int = 1
) -> list:
    """CPU seconds of reprojecting the photographs into each of ``names`` (the render step's
    :func:`splat.capture.reprojected_view`) from a finished run's OUT, for each ``k`` of ``ks``
    (photographs per camera; None: all), in one process, alternating; and the same with only every
    ``every``-th photograph as candidates (fewer views). Each view's depth maps and photographs are
    computed once, before the timing (one untimed reprojection from all), as the render step keeps
    them for all views."""
    from splat.capture import (
        PipelineConfig,
        Workspace,
        load_gaussians,
        load_model_capture,
        read_capture,
        read_working,
        refined_views,
        reprojected_view,
        working_views,
    )

    spec = read_capture(capture)
    ws = Workspace(spec, out)
    _, cap = load_model_capture(spec, out)
    g, alive = load_gaussians(out)
    raws = {v.name: v for v in read_working(spec, ws, PipelineConfig())}
    views = refined_views(working_views(cap.views, raws), out)
    by_name = {v.name: v for v in views}
    subset = [v for i, v in enumerate(views) if i % every == 0 or v.name in names]
    cache: dict = {}
    n = len(spec.cameras)
    t = time.process_time()  # every depth map and photograph computed once, outside the timing
    reprojected_view(names[0], by_name[names[0]].camera, views, raws, (g, alive), cache, n)
    print(f"depth maps, photographs and a first view: {time.process_time() - t:.1f} s CPU", flush=True)
    rows = []
    for _ in range(rounds):
        for name in names:
            for vs in (views, subset):
                for k in ks:
                    t = time.process_time()
                    reprojected_view(name, by_name[name].camera, vs, raws, (g, alive), cache, n, k)
                    rows.append({"view": name, "views": len(vs), "k": k, "cpu_s": time.process_time() - t})
                    print(
                        f"{name}: {len(vs)} photographs, k = {k}: {rows[-1]['cpu_s']:.1f} s CPU", flush=True
                    )
    return rows


def _table(name: str, res: dict) -> str:
    lines = [
        f"**{name}**: `{res['command']}` — exit {res['returncode']}, wall {res['wall_s']:.0f} s, "
        f"CPU {res['cpu_s']:.0f} s, load {res['load']}",
        "",
        "| step | wall s | CPU s | peak RSS MiB | load (min / median / max) |",
        "|---|---:|---:|---:|---|",
    ]
    for s, r in res["steps"].items():
        rss = "—" if r["peak_rss_mib"] is None else f"{r['peak_rss_mib']:.0f}"
        load = "—" if r["load"] is None else " / ".join(f"{x:.1f}" for x in r["load"])
        lines.append(f"| {s} | {r['wall_s']:.1f} | {r['cpu_s']:.1f} | {rss} | {load} |")
    return "\n".join(lines)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--work", type=Path, default=Path("/tmp/bench_capture_realsize"))
    ap.add_argument("--run", nargs="+", default=["main"], choices=["main", "3mp", "6views", "cap"])
    ap.add_argument("--sim-scale", type=float, default=2.0, help="simulated size, × the CI size")
    ap.add_argument(
        "--sim",
        choices=["raycaster", "mitsuba"],
        default="raycaster",
        help="the simulator of the photographs before upsampling (mitsuba: pip install mitsuba)",
    )
    ap.add_argument("--spp", type=int, default=16, help="with --sim mitsuba: samples per pixel")
    ap.add_argument("--views", type=int, default=12, help="photographs per camera")
    ap.add_argument("--mp", type=float, default=12.0, help="megapixels of every photograph (at least)")
    ap.add_argument("--mp-small", type=float, default=3.0)
    ap.add_argument("--steps", type=int, default=None, help="training steps (default: splat's)")
    ap.add_argument("--capacity", type=int, default=None, help="Gaussians (default: splat's)")
    ap.add_argument("--capacity-large", type=int, default=16384)
    ap.add_argument(
        "--poses-from",
        type=Path,
        default=None,
        help="an OUT of the same capture whose poses step is reused (copied; its settings record accepts it)",
    )
    ap.add_argument(
        "--render-cost",
        nargs="+",
        default=None,
        metavar="VIEW",
        help="only time the render step's reprojection into these views of --run's finished OUT, "
        "k = 2, 4, 6 photographs per camera against all",
    )
    ap.add_argument(
        "--step-cost",
        action="store_true",
        help="only time one training step at working sizes × Gaussians (no capture, no run)",
    )
    ap.add_argument("--step-sizes", default="128x96,256x192,512x384", help="with --step-cost: W×H list")
    ap.add_argument("--step-gaussians", default="1024,4096", help="with --step-cost: Gaussians")
    ap.add_argument(
        "--select", nargs="+", default=None, help="splat run --views: photographs to render and correct"
    )
    args = ap.parse_args(argv)
    work = args.work
    work.mkdir(parents=True, exist_ok=True)
    if args.render_cost:
        cap, out = work / f"capture_{args.mp:g}mp", work / f"out_{args.run[0]}"
        rows = render_cost(cap, out, args.render_cost, [None, 2, 4, 6])
        (work / "results_render_cost.json").write_text(json.dumps(rows, indent=1))
        import numpy as np

        print("| photographs | k per camera | CPU s per view (median) |\n|---:|---|---:|")
        for nv in sorted({r["views"] for r in rows}, reverse=True):
            for k in (None, 2, 4, 6):
                xs = [r["cpu_s"] for r in rows if r["views"] == nv and r["k"] == k]
                print(f"| {nv} | {'all' if k is None else k} | {np.median(xs):.1f} |")
        return 0
    if args.step_cost:
        sizes = [tuple(int(v) for v in s.split("x")) for s in args.step_sizes.split(",")]
        rows = step_cost(sizes, [int(g) for g in args.step_gaussians.split(",")], steps=8)
        (work / "results_step_cost.json").write_text(json.dumps(rows, indent=1))
        print(
            "| working size | pixels | Gaussians | CPU s per step | wall s per step |\n"
            "|---|---:|---:|---:|---:|"
        )
        for r in rows:
            w, h = r["size"]
            print(
                f"| {w}×{h} | {r['pixels']} | {r['gaussians']} | {r['cpu_s_per_step']:.3f} "
                f"| {r['wall_s_per_step']:.3f} |"
            )
        return 0
    opts = []
    if args.steps is not None:
        opts += ["--steps", str(args.steps)]
    if args.capacity is not None:
        opts += ["--capacity", str(args.capacity)]
    if args.select is not None:
        opts += ["--views", *args.select]

    t = time.perf_counter()
    sim = sim_capture(work, args.sim_scale, args.views, sim=args.sim, spp=args.spp)
    print(f"simulated capture {sim}: {time.perf_counter() - t:.1f} s", flush=True)

    def build(mp):
        t, c = time.perf_counter(), time.process_time()
        cap, sizes = realsize_capture(sim, work / f"capture_{mp:g}mp", mp)
        dt, dc = time.perf_counter() - t, time.process_time() - c
        print(f"capture {cap} ({sizes}): {dt:.1f} s (CPU {dc:.1f} s)", flush=True)
        return cap, sizes

    for name in args.run:
        if name in ("main", "6views", "cap"):
            cap, sizes = build(args.mp)
        else:
            cap, sizes = build(args.mp_small)
        o = list(opts)
        out = work / f"out_{name}"
        if name == "6views":
            cap = subset_capture(cap, work / f"capture_{args.mp:g}mp_6v", 2)
        main_out = work / "out_main"
        if name == "cap":
            o = [x for i, x in enumerate(o) if x != "--capacity" and (i == 0 or o[i - 1] != "--capacity")]
            o += ["--capacity", str(args.capacity_large)]
        if args.poses_from is not None:
            main_out = args.poses_from
        if name == "cap" or args.poses_from is not None:
            if not out.exists() and (main_out / "poses").is_dir():
                out.mkdir()
                for p in ("previews", "poses", ".splat-output.json", "settings.json"):
                    if (main_out / p).is_dir():
                        shutil.copytree(main_out / p, out / p)
                    elif (main_out / p).is_file():
                        shutil.copy2(main_out / p, out / p)
                record = json.loads((out / "settings.json").read_text())  # the poses step's record only
                record["steps"] = {"poses": record["steps"]["poses"]}
                (out / "settings.json").write_text(json.dumps(record))
        n = sum(1 for _ in cap.glob("*/*.dng"))
        print(f"{name}: splat run on {n} photographs {sizes} ...", flush=True)
        res = splat_run(cap, out, o, work / f"run_{name}.log")
        res.update(photographs=n, sizes=sizes)
        (work / f"results_{name}.json").write_text(json.dumps(res, indent=1))
        print(_table(name, res), flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
