"""Benchmark: N-channel Gaussian splatting on the CPU — renderer step time and training to 30 dB.

Run: ``python benchmarks/bench_splat.py`` (prints two tables; timings are medians of ``--repeats``).

- Step time: forward + backward (loss = mean squared error against a fixed target) of the tiled
  back-end vs the exact reference back-end (the baseline, same process, same inputs), and of the
  numba ``cpu`` back-end vs the tiled one, for 64×64 px / 1k Gaussians / 9 channels, 160×128 px / 4k
  Gaussians / 9 channels and 480×360 px / 16k Gaussians / 9 channels (the benchmark capture's size;
  no reference there: it would take minutes) (random Gaussians in a unit box seen from 3.5 units).
  Also the largest |tiled − reference| and |cpu − tiled| differences of the forward image and the
  Gaussian–tile pairs the tiled back-end dropped.
- Training: :func:`splat.synthetic_scene` (3 real cameras × 12 views, 9 channels, 64×64, Bayer +
  Foveon mosaics with noise), :func:`splat.train` with the settings below; held-out PSNR (all 9
  channels of 6 unseen views, noise-free truth) against wall-clock time, compile included.
"""

from __future__ import annotations

import argparse
import os
import time

os.environ.setdefault("JAX_PLATFORMS", "cpu")

import jax
import jax.numpy as jnp
import numpy as np
from rich.console import Console
from rich.progress import BarColumn, Progress, TextColumn, TimeRemainingColumn
from rich.table import Table

from splat import (
    RenderConfig,
    SceneConfig,
    TrainConfig,
    init_gaussians,
    look_at,
    psnr,
    render,
    render_views,
    synthetic_scene,
    train,
)

try:  # run as a script (python benchmarks/bench_X.py) or imported as benchmarks.bench_X
    from _timing import median_time
except ImportError:
    from benchmarks._timing import median_time


def random_gaussians(G: int, N: int, seed: int = 0):
    r = np.random.default_rng(seed)
    return init_gaussians(
        r.uniform(-1, 1, (G, 3)),
        r.uniform(0.1, 0.9, (G, N)),
        scales=np.exp(r.uniform(np.log(0.02), np.log(0.08), G)),
        opacity=0.5,
        key=jax.random.key(seed),
    )


def step_times(args, console: Console) -> None:
    table = Table(title=f"forward + backward per step (ms, median of {args.repeats})")
    for col in (
        "size",
        "Gaussians",
        "N",
        "reference ms",
        "tiled ms",
        "tiled vs ref",
        "cpu ms",
        "cpu vs tiled",
        "max |tiled − ref|",
        "max |cpu − tiled|",
        "dropped (tiled)",
        "max per tile",
    ):
        table.add_column(col, justify="right")
    for W, H, G, cap in ((64, 64, 1000, 512), (160, 128, 4000, 512), (480, 360, 16000, 2048)):
        with_ref = G <= 4000
        g = random_gaussians(G, 9)
        cam = look_at((0.3, -3.5, 1.0), (0, 0, 0), width=W, height=H, fov_deg=45)
        cfg = RenderConfig(tile_capacity=cap)
        target = 0.9 * render(g, cam, method="tiled", config=cfg).image
        ms = {}
        for method in ("tiled", "cpu") + (("reference",) if with_ref else ()):

            def loss(p, method=method, cam=cam, cfg=cfg, target=target):
                return jnp.mean((render(p, cam, method=method, config=cfg).image - target) ** 2)

            f = jax.jit(jax.value_and_grad(loss))
            reps = args.repeats if method != "reference" or not args.quick else 1
            ms[method] = 1e3 * median_time(
                lambda f=f, g=g: f(g), reps, warmup=True, sync=jax.block_until_ready
            )
        tiled = render(g, cam, method="tiled", config=cfg)
        cpu = render(g, cam, method="cpu", config=cfg)
        err = "—"
        if with_ref:
            ref = render(g, cam, method="reference", config=cfg)
            err = f"{float(jnp.max(jnp.abs(tiled.image - ref.image))):.1e}"
        table.add_row(
            f"{W}×{H}",
            f"{G}",
            "9",
            f"{ms['reference']:.0f}" if with_ref else "—",
            f"{ms['tiled']:.0f}",
            f"{ms['reference'] / ms['tiled']:.1f}×" if with_ref else "—",
            f"{ms['cpu']:.0f}",
            f"{ms['tiled'] / ms['cpu']:.1f}×",
            err,
            f"{float(jnp.max(jnp.abs(cpu.image - tiled.image))):.1e}",
            f"{int(tiled.n_dropped)}",
            f"{int(tiled.max_per_tile)}",
        )
    console.print(table)


def training(args, console: Console) -> None:
    scene = synthetic_scene(SceneConfig(width=64, height=64, views_per_camera=12, test_views_per_camera=2))
    rc = RenderConfig(tile_capacity=512)
    cfg = TrainConfig(
        steps=args.steps, capacity=args.capacity, densify_until=int(0.65 * args.steps), render=rc
    )
    test_cams = [v.camera for v in scene.test.views]
    rows = []
    t0 = time.perf_counter()

    def check(step, state, loss):
        if step % args.eval_every == 0 or step == cfg.steps:
            elapsed = time.perf_counter() - t0
            pred = render_views(state.params, test_cams, mask=state.alive, config=rc)
            rows.append((step, elapsed, psnr(pred, scene.test_images), int(state.alive.sum())))

    bar = (
        None
        if args.no_progress
        else Progress(
            TextColumn("splat"),
            BarColumn(),
            TextColumn("{task.completed}/{task.total}"),
            TextColumn("loss {task.fields[loss]:.4g}"),
            TextColumn("{task.fields[n]} Gaussians"),
            TimeRemainingColumn(),
            console=console,
        )
    )

    def step_done(step, state, loss):  # the library prints nothing: the bar is drawn here
        check(step, state, loss)
        if bar is not None and (step % 25 == 0 or step == cfg.steps):
            bar.update(task, completed=step, loss=float(loss), n=int(state.alive.sum()))

    if bar is not None:
        task = bar.add_task("train", total=cfg.steps, loss=float("nan"), n=0)
        bar.start()
    try:
        result = train(
            scene.capture, scene.images, scene.weights, config=cfg, bounds=scene.bounds, callback=step_done
        )
    finally:
        if bar is not None:
            bar.stop()
    table = Table(
        title=f"training: synthetic scene, 3 cameras × 12 views, 64×64, 9 channels, "
        f"capacity {args.capacity} (one run)"
    )
    for col in ("step", "time s (incl. compile, eval)", "held-out PSNR dB", "alive Gaussians"):
        table.add_column(col, justify="right")
    for step, elapsed, p, n in rows:
        table.add_row(str(step), f"{elapsed:.0f}", f"{p:.2f}", str(n))
    console.print(table)
    first = next((r for r in rows if r[2] >= 30), None)
    dropped = int(result.history["n_dropped"].max())
    reached = f"30 dB reached at step {first[0]} after {first[1]:.0f} s" if first else "30 dB not reached"
    console.print(f"max Gaussian–tile pairs dropped in a training step: {dropped}; {reached}")


def main() -> None:
    parser = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument("--repeats", type=int, default=5)
    parser.add_argument("--steps", type=int, default=3000)
    parser.add_argument("--capacity", type=int, default=1024)
    parser.add_argument("--eval-every", type=int, default=250)
    parser.add_argument("--quick", action="store_true", help="reference back-end timed once")
    parser.add_argument("--skip-training", action="store_true")
    parser.add_argument("--no-progress", action="store_true")
    args = parser.parse_args()
    console = Console(width=160)
    console.print(f"jax {jax.__version__} on {jax.devices()[0].platform}, {os.cpu_count()} CPU cores")
    step_times(args, console)
    if not args.skip_training:
        training(args, console)


if __name__ == "__main__":
    main()
