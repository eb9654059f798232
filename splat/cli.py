"""``splat`` command: a RAW capture folder → poses → N-channel Gaussians → colour-corrected images.

``splat run CAPTURE -o OUT`` runs every step; ``splat poses|train|render|correct|report CAPTURE -o OUT``
runs one. Every step resumes from what ``OUT`` already holds when it was made from the same capture
and options (``OUT/settings.json``), and recomputes it otherwise; ``OUT`` is new, empty or splat's own.
Bad input (a missing SSF, an unknown key or option, an unreadable RAW file, mixed image sizes within a
camera, too few registered views, ...) is reported as one line on stderr with exit status 2, before any
work where it can be known then. Progress bars are drawn here (rich), never by the library.
"""

from __future__ import annotations

import argparse
import sys
from collections.abc import Sequence

__all__ = ["main"]


def _version() -> str:
    from importlib.metadata import PackageNotFoundError, version

    try:
        return version("zonotope")
    except PackageNotFoundError:  # pragma: no cover - a source tree that was never installed
        return "0+unknown"


def _parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(prog="splat", description=__doc__.splitlines()[0])
    p.add_argument("--version", action="version", version=f"%(prog)s {_version()}")
    sub = p.add_subparsers(dest="step", required=True)
    for name, help_ in (
        ("run", "every step: poses, train, render, correct, report"),
        ("poses", "recover (or read) the camera poses"),
        ("train", "train the N-channel Gaussians on all cameras' RAW mosaics"),
        ("render", "render every photograph (or --views) and --novel views"),
        ("correct", "colour-correct the renders; DNG-matrix developments for comparison"),
        ("report", "write OUT/report.html"),
    ):
        s = sub.add_parser(name, help=help_)
        s.add_argument("capture", help="capture folder (with capture.toml) or the capture.toml itself")
        s.add_argument("-o", "--out", required=True, help="output folder (outside the capture)")
        s.add_argument("--steps", type=int, default=3000, help="training steps (default 3000)")
        s.add_argument("--capacity", type=int, default=4096, help="Gaussian buffer size (default 4096)")
        s.add_argument(
            "--views",
            nargs="+",
            default=None,
            metavar="NAME",
            help="photographs to render and correct: <folder>/<file> names or patterns such as 'canon/*' "
            "(default: every photograph of every camera)",
        )
        s.add_argument(
            "--camera",
            default=None,
            help="camera folder whose views the novel views lie between (default: first)",
        )
        s.add_argument(
            "--novel", type=int, default=0, help="novel views between consecutive views (default 0)"
        )
        s.add_argument("--method", default="Prior", help="zonotope.correct estimator (default Prior)")
        s.add_argument("--quantum", type=float, default=5e-3, help="colour deduplication step (white = 1)")
        s.add_argument("--threads", type=int, default=-1, help="COLMAP threads (-1: all cores)")
        s.add_argument("--seed", type=int, default=0)
        s.add_argument(
            "--refine-exposure",
            action="store_true",
            help="learn a per-view exposure correction (one view per camera fixed); default: trust EXIF",
        )
        s.add_argument(
            "--refine-poses",
            action="store_true",
            help="learn a pose correction per training view with the Gaussians (two views fixed); "
            "default: keep the recovered poses",
        )
        s.add_argument(
            "--depth-weight",
            type=float,
            default=None,
            help="weight of the sparse depth term from the COLMAP points each view observes "
            "(0: off; default: TrainConfig.depth_weight)",
        )
        s.add_argument(
            "--tile-capacity",
            type=int,
            default=None,
            metavar="N",
            help='Gaussians one 16-pixel tile composites in training on a GPU (the "tiled" back-end; '
            "default 2048): below the model's fullest tile a step is faster and leaves pairs out "
            "(OUT/train/summary.json: dropped_per_step); renders are always made whole; no effect on "
            "the CPU",
        )
        s.add_argument(
            "--train-size",
            type=int,
            default=None,
            metavar="PX",
            help="longer side of the working resolution of training, in pixels (RAW files are binned, "
            "CFA-aware, to it; outputs stay at full resolution); default: capture.toml's train_size, "
            "else automatic (at most splat._tol.TRAIN_PIXEL_BUDGET pixels)",
        )
        s.add_argument(
            "--no-full-reprojection",
            dest="full_reprojection",
            action="store_false",
            help="full-resolution outputs take the other cameras' channels from the working-resolution "
            "fusion, upsampled, instead of reprojecting their photographs at full resolution (about 3× "
            "less time for binned photographs, less detail from the other cameras)",
        )
        s.add_argument(
            "--render-sources",
            default=None,
            metavar="K|all",
            help="photographs per camera reprojected into each rendered view, the K that see most of it "
            "(default: splat._tol.RENDER_SOURCES; 'all': every other photograph, a cost that grows with "
            "the square of the photographs)",
        )
        s.add_argument(
            "--workers",
            type=int,
            default=None,
            help="views rendered and strips of the full-resolution stage computed at once, on threads "
            "(default: the usable cores, at most splat._tol.FULL_WORKERS); the images are the same for "
            "any number",
        )
        s.add_argument(
            "--noise",
            default="auto",
            metavar="auto|SIGMA|SHOT:READ",
            help="noise of the photographs' own channels in the correction (white = 1): auto (default: "
            "the RAW file's NoiseProfile, else estimated from the mosaic), a σ, or shot:read variances",
        )
    _export_parser(sub)
    return p


def _render_sources(value: str | None) -> dict:
    """``--render-sources K|all`` as PipelineConfig keywords (none given: its default)."""
    from ._errors import SplatError

    if value is None:
        return {}
    if value.strip().lower() == "all":
        return {"render_sources": None}
    try:
        return {"render_sources": int(value)}
    except ValueError:
        raise SplatError(
            f"--render-sources {value!r}: give a number of photographs per camera (≥ 1) or 'all'."
        ) from None


def _export_parser(sub) -> None:
    e = sub.add_parser("export", help="the trained scene as .ply files and the poses for other tools")
    e.add_argument("out", help="the output folder of splat run (read; the exports go where named)")
    e.add_argument("--capture", required=True, help="the capture folder (or capture.toml) of that run")
    e.add_argument("--ply", help="3DGS .ply of the corrected colours (sRGB f_dc, linear XYZ kept)")
    e.add_argument("--ply-channels", help="the same with the model's channels as f_<camera>_<channel>")
    e.add_argument("--transforms", help="nerfstudio transforms.json of the registered views")
    e.add_argument("--colmap", help="folder for a COLMAP binary model of the registered views")
    e.add_argument(
        "--sh-degree", type=int, choices=(0, 1, 2, 3), default=3, help="f_rest_* zeros (default 3)"
    )
    e.add_argument("--no-xyz", action="store_true", help="leave out XYZ_X/Y/Z (fixed-layout readers)")
    e.add_argument("--force", action="store_true", help="replace the outputs of an earlier splat export")


def _export(args) -> int:
    from zonotope import ZonotopeError

    from .export import PlyOptions, export_scene

    try:
        done = export_scene(
            args.capture,
            args.out,
            ply=args.ply,
            ply_channels=args.ply_channels,
            transforms=args.transforms,
            colmap=args.colmap,
            options=PlyOptions(sh_degree=args.sh_degree, xyz=not args.no_xyz),
            force=args.force,
        )
    except (ZonotopeError, FileNotFoundError, ValueError, OSError) as exc:
        print(f"splat: error: {' '.join(str(exc).split())}", file=sys.stderr)
        return 2
    for what, d in done.items():
        n = d.get("gaussians", d.get("views"))
        unit = "Gaussians" if "gaussians" in d else "views"
        print(f"{what}: {d['path']} ({n} {unit}, {d['bytes'] / max(n, 1):.0f} bytes each)")
    return 0


def main(argv: Sequence[str] | None = None) -> int:
    """Entry point of the ``splat`` command; returns the exit status (2 for bad input)."""
    args = _parser().parse_args(argv)
    if args.step == "export":
        return _export(args)
    import os

    os.environ.setdefault("GLOG_minloglevel", "2")  # COLMAP's own log lines would drown the progress bars
    from dataclasses import replace

    from rich.console import Console
    from rich.progress import BarColumn, Progress, TextColumn, TimeElapsedColumn, TimeRemainingColumn

    from zonotope import ZonotopeError
    from zonotope.correct import parse_noise

    from ._errors import SplatError
    from .capture import STEPS, PipelineConfig, capture_train_config, run

    try:
        # the training options (TRAIN_OPTIONS, --steps … --depth-weight) make config.train
        train = capture_train_config(
            steps=args.steps,
            capacity=args.capacity,
            seed=args.seed,
            refine_exposure=args.refine_exposure,
            refine_poses=args.refine_poses,
            depth_weight=args.depth_weight,
        )
        if args.tile_capacity is not None:
            if args.tile_capacity < 1:
                raise SplatError(f"--tile-capacity {args.tile_capacity}: must be a number of Gaussians ≥ 1.")
            train = replace(train, render=replace(train.render, tile_capacity=args.tile_capacity))
        config = PipelineConfig(
            train=train,
            camera=args.camera,
            views=None if args.views is None else tuple(args.views),
            novel=args.novel,
            method=args.method,
            quantum=args.quantum,
            threads=args.threads,
            train_size=args.train_size,
            noise=parse_noise(args.noise),
            full_reprojection=args.full_reprojection,
            workers=args.workers,
            **_render_sources(args.render_sources),
        )
    except ZonotopeError as exc:  # bad option values: one line, before any work
        print(f"splat: error: {' '.join(str(exc).split())}", file=sys.stderr)
        return 2
    steps = STEPS if args.step == "run" else (args.step,)
    if args.step in ("run", "poses"):  # before any work: each camera's curves against its files' maker
        from .capture import maker_warnings, read_capture

        try:
            for line in maker_warnings(read_capture(args.capture)):
                print(f"splat: warning: {line}", file=sys.stderr)
        except (ZonotopeError, OSError, ValueError):
            pass  # the run itself says what is wrong with the capture, in one line
    console = Console(stderr=True)
    bar = Progress(
        TextColumn("{task.description:>9}"),
        BarColumn(),
        TextColumn("{task.completed}/{task.total}"),
        TimeElapsedColumn(),
        TextColumn("left"),
        TimeRemainingColumn(),
        console=console,
        transient=False,
        disable=not console.is_terminal,
    )
    tasks: dict[str, int] = {}
    import time

    t0, printed = time.monotonic(), {"at": -1e9}

    started: dict[str, tuple[float, int]] = {}

    def progress(what: str, done: int, total: int) -> None:
        if what not in tasks:
            tasks[what] = bar.add_task(what, total=total)
        bar.update(tasks[what], completed=done, total=total)
        now = time.monotonic()
        # stderr is not a terminal (piped, redirected): rich draws nothing there, so plain lines,
        # one per step start and end and at most one every 10 s in between, with the time left at the
        # task's mean rate so far
        if not console.is_terminal and (done in (0, total) or now - printed["at"] >= 10.0):
            printed["at"] = now
            t_start, d_start = started.setdefault(what, (now, done))
            left = ""
            if 0 < done - d_start and done < total:
                left = f", about {(now - t_start) / (done - d_start) * (total - done):.0f} s left"
            print(f"[{now - t0:7.1f} s] {what}: {done}/{total}{left}", file=sys.stderr, flush=True)

    try:
        with bar:
            before = tuple(s for s in steps if s != "report")
            results = run(args.capture, args.out, config=config, steps=before, progress=progress)
            if "report" in steps:
                from .export import prepare_scene

                # the report's 3-D view: every Gaussian's colour corrected
                prepare_scene(args.capture, args.out, progress=progress)
                results.update(run(args.capture, args.out, config=config, steps=("report",)))
    except KeyboardInterrupt:  # one line, no traceback; outputs are written atomically
        print("splat: interrupted", file=sys.stderr)
        return 130
    except (ZonotopeError, FileNotFoundError, ValueError, OSError) as exc:
        msg = " ".join(str(exc).split())
        print(f"splat: error: {msg}", file=sys.stderr)
        return 2
    if "poses" in results:
        p = results["poses"]
        cams = ", ".join(f"{k} {v['registered']}/{v['views']}" for k, v in p["cameras"].items())
        tri = f"; {p['triangulated']} points triangulated on them" if p.get("triangulated") else ""
        print(f"poses ({p['source']}): {p['registered']} of {p['views']} views registered ({cams}){tri}")
    if "train" in results:
        t = results["train"]
        for folder, w in (t.get("working") or {}).items():
            if w["binning"] == 1:
                print(f"train: {folder} at full resolution {w['full'][0]}×{w['full'][1]} (the RAW mosaics)")
            else:
                n = w["sites_per_channel"]
                print(
                    f"train: {folder} {w['full'][0]}×{w['full'][1]} binned {w['binning']}×{w['binning']} to "
                    f"{w['working'][0]}×{w['working'][1]}: each pixel's R, G, B the mean of {n[0]}, {n[1]}, "
                    f"{n[2]} sites (noise σ ÷ {', '.join(f'{x:g}' for x in w['noise_sigma_divided_by'])}); "
                    "outputs at full resolution"
                )
        import jax

        device = jax.devices()[0]  # JAX picks the GPU when the `gpu` extra (jax[cuda12]) is installed
        print(
            f"train: {t['steps']} steps, {t['gaussians']} Gaussians, {t['seconds']:.0f} s "
            f"on {device.platform} ({device.device_kind})"
        )
        if "pose_correction_size" in t:
            c = t["pose_correction_size"]
            print(
                f"train: pose corrections {c['rotation_deg_mean']:.3f}° (max {c['rotation_deg_max']:.3f}°), "
                f"{c['translation_mean']:.4f} (max {c['translation_max']:.4f}) for a scene extent "
                f"{c['scene_extent']:.2f}; reference views {', '.join(t['pose_reference_views'])}"
            )
    if "render" in results:
        print(f"render: {len(results['render'])} views")
    if "correct" in results:
        c = results["correct"]
        print(
            f"correct: {c['method']}, δ = {c['delta']:.4f} (95th percentile of the rendered "
            "responses' distances to the object-colour solid)"
        )
        f = c.get("fusion") or {}
        if f.get("views"):
            print(
                f"correct: {f['views']} photographed views also fused with their RAW files and the other "
                f"photographs reprojected into them ({f['files']}; render σ {f['render_sigma']:.3f})"
            )
        full = c.get("full_resolution") or {}
        if full.get("views"):
            print(
                f"correct: {full['views']} photographs corrected at their full resolution ({full['files']}; "
                f"{full['method']}); own-channel noise from "
                f"{', '.join(sorted({d['source'] for d in c.get('own_noise', {}).values()})) or '-'}"
            )
        if f.get("novel"):
            print(
                f"correct: {f['novel']} novel views also corrected from the photographs reprojected into them"
            )
    if "report" in results:
        print(f"report: {results['report']}")
    return 0


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
