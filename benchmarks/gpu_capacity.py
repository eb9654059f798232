"""Held-out PSNR against the number of Gaussians, trained on a GPU (issue 9's 35 dB goal).

The benchmark capture's training inputs are exported once, on the machine that has the RAW files and
the pipeline's poses, into one small bundle (float16 values at the measured sites only), so that a GPU
machine with nothing but JAX and this repository can train on them::

    python benchmarks/gpu_capacity.py export CAPTURE OUT BUNDLE.npz   # OUT: the pipeline's output (poses)
    python benchmarks/gpu_capacity.py run BUNDLE.npz RESULTS.json --budget 520 --capacities 32768,262144

``run`` first times training steps of the pure-JAX ``"tiled"`` back-end with the tiles composited one
after another (``RenderConfig.tile_batch=1``, the baseline) and all at once (``tile_batch=0``) in the same
process, then trains the pipeline's schedule (:func:`splat.capture.train_config`) from the COLMAP points
at each capacity that still fits the time budget (largest first), and scores each model as the README's
PSNR table does: render × EXIF exposure against every held-out RAW mosaic's measured sites, peak 1, the
mean of the per-view, per-channel PSNRs. Results are written after every phase, so a run stopped at its
limit keeps what it measured. Each run also reports the PSNR normalised to the median exposure
(``+ 20 log10(exposure)`` per view, as ``splat.scoring``) of the held-out views, one by one, and of every
training view: peak-1 PSNR falls ≈ 6 dB per stop of exposure, the held-out views were shot brighter
than the training views, and only the normalised numbers separate the fit from the generalisation
(at the arc's ends the held-out views lag, in the middle they match the fit).
The float16 values quantise the mosaics 91 dB below their peak.
Figures of one H200 (2026-11-27) are in docs/benchmarks.md.

``--baseline cpu`` times the ``"cpu"`` back-end on the host's cores first instead of the serial tiles
(either at the least of ``--capacities``),
``--time-capacities`` names the capacities timed (every buffer slot alive: the COLMAP points resampled);
each timing row also holds the compiled step's memory (XLA's analysis) and the device's peak so far.
``--time-only`` stops after the timings.
``--reference SCENE.npz`` writes one view's Gaussians and this project's render for
``gsplat_reference.py`` and times the render and its gradient on them. ``--min-steps`` trains a shorter
schedule where ``--steps`` does not fit; ``--train-anyway`` trains regardless and scores the model where
the budget stopped it (``stopped`` in the results). ``benchmarks/gpu_run.sh`` runs the whole device
batch.

``--set FIELD=VALUE`` (repeatable) overrides a :class:`splat.TrainConfig` field of that schedule, e.g.
``--set densify_gradient=screen --set densify_fraction=0.5``; the overrides are written to the results.
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import sys
import time
from pathlib import Path

import numpy as np


def _pack(values: np.ndarray, weight: np.ndarray) -> dict:
    on = weight > 0
    return {"vals": values[on].astype(np.float16), "mask": np.packbits(on.reshape(-1)), "shape": on.shape}


def _unpack(vals, mask, shape) -> tuple[np.ndarray, np.ndarray]:
    on = np.unpackbits(mask)[: int(np.prod(shape))].reshape(shape).astype(bool)
    values = np.zeros(shape, np.float32)
    values[on] = vals.astype(np.float32)
    return values, on.astype(np.float32)


def _cams(cameras) -> dict:
    return {
        "R": np.stack([np.asarray(c.R) for c in cameras]),
        "t": np.stack([np.asarray(c.t) for c in cameras]),
        "focal": np.stack([np.asarray(c.focal) for c in cameras]),
        "principal": np.stack([np.asarray(c.principal) for c in cameras]),
        "wh": np.array([(c.width, c.height) for c in cameras]),
    }


def export(capture: str, out: str, bundle: str) -> None:
    """Write the training inputs (no ground truth) and the held-out views' RAW sites to ``bundle``."""
    from splat.capture import load_model_capture, load_views, read_capture, training_inputs
    from splat.capture.train import _scene_points

    spec = read_capture(capture)
    inp = training_inputs(spec, Path(out))
    cap = inp.capture
    model, mc = load_model_capture(spec, Path(out))
    raws = {v.name: v for v in load_views(spec)}
    hold = [v for v in mc.views if v.name in set(spec.holdout)]
    arrays = {f"train_{k}": v for k, v in _pack(np.asarray(inp.images), np.asarray(inp.weights)).items()}
    arrays |= {f"train_cam_{k}": v for k, v in _cams([v.camera for v in cap.views]).items()}
    arrays |= {
        "train_camera_id": np.array([v.camera_id for v in cap.views]),
        "train_exposure": np.array([v.exposure for v in cap.views]),
        "bounds": np.asarray(inp.bounds),
    }
    # every point the pipeline may start from, in its order: run draws a capacity's subset and colours
    # as training_inputs does (splat.capture.train._initial_points)
    xyz, rgb, _ = _scene_points(model, [v.camera for v in cap.views])
    valid = np.asarray(inp.weights) > 0
    arrays |= {"points": xyz, "points_rgb": rgb, "level": float(np.median(np.asarray(inp.images)[valid]))}
    if inp.depth is not None:  # the COLMAP points each view observes (TrainConfig.depth_weight)
        arrays |= dict(zip(("depth_pixel", "depth_z", "depth_valid"), inp.depth))
    arrays |= {f"hold_cam_{k}": v for k, v in _cams([v.camera for v in hold]).items()}
    for i, v in enumerate(hold):
        r = raws[v.name]
        arrays |= {f"hold{i}_{k}": x for k, x in _pack(r.values, r.weight).items()}
        arrays[f"hold{i}_meta"] = np.array([r.camera, r.exif])
    meta = {
        "channels": {str(k): list(v) for k, v in cap.channels.items()},
        "labels": list(cap.labels),
        "train_names": [v.name for v in cap.views],
        "hold_names": [v.name for v in hold],
    }
    np.savez_compressed(bundle, meta=np.array(json.dumps(meta)), **arrays)
    print(
        f"{bundle}: {Path(bundle).stat().st_size / 2**20:.1f} MiB, {len(cap.views)} training views, "
        f"{len(hold)} held out, {len(xyz)} points"
    )


def _cameras(b, prefix):
    from splat.camera import Camera

    w = b[f"{prefix}_cam_wh"]
    return [
        Camera(
            b[f"{prefix}_cam_R"][i],
            b[f"{prefix}_cam_t"][i],
            b[f"{prefix}_cam_focal"][i],
            b[f"{prefix}_cam_principal"][i],
            int(w[i, 0]),
            int(w[i, 1]),
        )
        for i in range(len(w))
    ]


def run(
    bundle: str,
    results: str,
    budget: float,
    capacities: list[int],
    steps: int,
    time_steps: int,
    method: str,
    tile_capacity: int = 0,
    save_model: str | None = None,
    overrides: dict | None = None,
    *,
    min_steps: int | None = None,
    baseline: str = "serial",
    time_capacities: list[int] | None = None,
    reference: str | None = None,
    train_anyway: bool = False,
    time_only: bool = False,
) -> None:
    import jax
    import jax.numpy as jnp

    from splat.capture import PipelineConfig, train_config
    from splat.capture.train import _initial_points
    from splat.data import Capture, View
    from splat.outputs import render_views
    from splat.rendering import RenderConfig, default_method
    from splat.training import init_state, train, train_step

    t_start = time.perf_counter()
    min_steps = steps if min_steps is None else min_steps
    res = {
        "device": str(jax.devices()[0]),
        "backend": jax.default_backend(),
        "jax": jax.__version__,
        "timing": [],
        "runs": [],
        "train_overrides": overrides or {},
    }

    def save():
        Path(results).write_text(json.dumps(res, indent=1))

    b = np.load(bundle)
    meta = json.loads(str(b["meta"]))
    images, weights = _unpack(b["train_vals"], b["train_mask"], tuple(b["train_shape"]))
    cams = _cameras(b, "train")
    views = tuple(
        View(n, c, int(i), float(e))
        for n, c, i, e in zip(meta["train_names"], cams, b["train_camera_id"], b["train_exposure"])
    )
    capture = Capture(views, {int(k): tuple(v) for k, v in meta["channels"].items()}, tuple(meta["labels"]))
    hold = []
    for i, (name, cam) in enumerate(zip(meta["hold_names"], _cameras(b, "hold"))):
        vals, on = _unpack(b[f"hold{i}_vals"], b[f"hold{i}_mask"], tuple(b[f"hold{i}_shape"]))
        c, exif = b[f"hold{i}_meta"]
        hold.append((name, cam, int(c), float(exif), vals, on > 0))
    bounds, points, rgb, level = b["bounds"], b["points"], b["points_rgb"], float(b["level"])
    depth = tuple(b[k] for k in ("depth_pixel", "depth_z", "depth_valid")) if "depth_z" in b else None
    res["data"] = {"train": list(images.shape), "held_out": len(hold), "points": len(points)}
    res["data"]["depth_targets"] = 0 if depth is None else int(depth[2].sum())
    print(res, flush=True)

    def config(capacity, render, n_steps=steps):  # the pipeline's train step, without checkpoints
        tc = train_config(PipelineConfig(steps=n_steps, capacity=capacity))
        return dataclasses.replace(tc, render=render, method=method, **(overrides or {}))

    def init_points(capacity):
        return _initial_points(points, rgb, level, capacity, capture.n_channels)

    def view_psnr(params, alive, render, cam, chans, exif, vals, on):
        """The README's per-view PSNR (the mean over the view's camera's channels ``chans``, peak 1)
        and its mean normalised to the median exposure (``+ 20 log10(exposure)``, as splat.scoring)."""
        pred = np.asarray(render_views(params, [cam], mask=alive, config=render, method=method)[0])
        pred = np.minimum(pred[..., list(chans)] * exif, 1)
        ps = [
            10 * np.log10(1 / np.mean((pred[..., j] - vals[..., j])[on[..., j]] ** 2))
            for j in range(len(chans))
        ]
        return ps, float(np.mean(ps)) + 20 * np.log10(exif)

    def psnr(params, alive, render):
        out, norm = [], {}
        for name, cam, c, exif, vals, on in hold:
            ps, n = view_psnr(params, alive, render, cam, range(3 * c, 3 * c + 3), exif, vals, on)
            out += ps
            norm[name] = n
        return float(np.mean(out)), float(np.min(out)), norm

    def psnr_training(params, alive, render):  # every training view, normalised: the fit itself
        norm = []
        for v, view in enumerate(views):
            ch = list(capture.channels[view.camera_id])
            on, vals = weights[v][..., ch] > 0, images[v][..., ch]
            norm.append(view_psnr(params, alive, render, view.camera, ch, view.exposure, vals, on)[1])
        return float(np.mean(norm))

    ims, wts = jnp.asarray(images), jnp.asarray(weights)
    masks = jnp.asarray(np.stack([capture.channel_mask(v) for v in capture.views]), jnp.float32)
    extent = float(np.linalg.norm(bounds[1] - bounds[0]))

    def tiles(capacity, tile_batch=0):  # tile capacity: the trained 32 768-Gaussian model needs ≤ 826
        k = tile_capacity or (1024 if capacity <= 65536 else 2048)
        return RenderConfig(tile_batch=tile_batch, tile_capacity=k)

    cpu = jax.devices("cpu")[0]

    def full_points(capacity):  # every buffer slot alive: the COLMAP points, resampled and jittered
        pts, cols = init_points(capacity)
        rng = np.random.default_rng(1)
        take = rng.integers(0, len(pts), capacity)
        jitter = rng.normal(scale=1e-3 * extent, size=(capacity, 3))
        return pts[take] + jitter, cols[take]

    def time_steps_of(capacity, render, backend=method, on_cpu=False):
        """Median wall seconds of a train step (after one compiled run), the step's compiled memory
        (arguments + outputs + temporaries, XLA's own analysis) and the device's peak so far."""
        cfg = dataclasses.replace(config(capacity, render), method=backend)
        pts, cols = full_points(capacity)
        dev = cpu if on_cpu else jax.devices()[0]
        with jax.default_device(dev):
            state = init_state(
                cfg,
                bounds=bounds,
                n_channels=capture.n_channels,
                points=pts,
                colours=cols,
                n_init=len(pts),
                n_views=len(views),
            )
            state = jax.device_put(state, dev)
            args = [
                (
                    views[v].camera,
                    *jax.device_put((ims[v], wts[v], masks[v], jnp.float32(views[v].exposure)), dev),
                )
                for v in range(min(len(views), time_steps + 1))
            ]
            t0 = time.perf_counter()
            step = train_step.lower(state, *args[0], config=cfg, extent=extent).compile()
            compile_s = time.perf_counter() - t0
            ts = []
            for k in range(time_steps + 1):
                t0 = time.perf_counter()
                state, loss, dropped = step(state, *args[k % len(args)])
                loss.block_until_ready()
                ts.append(time.perf_counter() - t0)
        return {
            "capacity": capacity,
            "backend": default_method() if backend == "auto" else backend,
            "device": str(dev),
            "alive": int(state.alive.sum()),
            "tile_batch": render.tile_batch,
            "tile_capacity": render.tile_capacity,
            "compile_s": round(compile_s, 2),
            "first_step_s": round(ts[0], 3),
            "step_s_median": round(float(np.median(ts[1:])), 4),
            "dropped_last": int(dropped),
            "loss_last": float(loss),
            **_memory(step, dev),
        }

    # 1. step time, in the same process: the baseline (tiles one after another, or the "cpu" back-end on
    # the host's cores), then all tiles at once at each timed capacity, every buffer slot alive
    lo, hi = min(capacities), max(capacities)
    plan = {"serial": [(lo, method, 1, False)], "cpu": [(lo, "cpu", 1, True)], "none": []}[baseline]
    plan += [(c, method, 0, False) for c in sorted(set(time_capacities or [lo, hi]))]
    for cap_, backend, tb, on_cpu in plan:
        if time.perf_counter() - t_start > 0.3 * budget:
            continue
        try:
            r = time_steps_of(cap_, tiles(cap_, tb), backend=backend, on_cpu=on_cpu)
        except Exception as e:  # record it and go on: the run's other phases still measure
            r = {
                "capacity": cap_,
                "backend": backend,
                "tile_batch": tb,
                "error": f"{type(e).__name__}: {e}"[:500],
            }
        res["timing"].append(r)
        print(r, flush=True)
        save()
    if reference:  # the same Gaussians and view for an outside rasteriser (gsplat_reference.py)
        try:
            res["reference"] = _reference_scene(
                reference, full_points(lo), lo, views[0].camera, tiles(lo), method
            )
        except Exception as e:
            res["reference"] = {"error": f"{type(e).__name__}: {e}"[:500]}
        print(res["reference"], flush=True)
        save()
    known = sorted(
        (t["capacity"], t["step_s_median"])
        for t in res["timing"]
        if t.get("tile_batch") == 0 and "error" not in t
    )

    def step_time(capacity):  # a power law through the measured capacities (linear from one)
        if not known:
            return None
        (g0, s0), (g1, s1) = known[0], known[-1]
        k = float(np.clip(np.log(s1 / s0) / np.log(g1 / g0), 0.3, 1.0)) if g1 > g0 else 1.0
        return s1 * (capacity / g1) ** k

    # 2. train and score the largest capacities that still fit, largest first
    class OutOfTime(Exception):
        pass

    for capacity in [] if time_only else sorted(capacities, reverse=True):
        left = budget - (time.perf_counter() - t_start)
        est = step_time(capacity)
        n_steps = next(
            (n for n in range(steps, min_steps - 1, -500) if est is not None and n * est * 1.2 + 45 <= left),
            None,
        )
        if n_steps is None and train_anyway:  # the budget stops it; the model is scored as it stood
            n_steps = steps
        if n_steps is None:
            res["runs"].append({"capacity": capacity, "skipped": f"{left:.0f} s left, ≈ {est} s/step"})
            save()
            continue
        render = tiles(capacity)
        cfg = config(capacity, render, n_steps)
        pts, cols = init_points(capacity)
        marks, last = {}, {}
        t0 = time.perf_counter()

        def cb(step, state, loss, t0=t0, marks=marks, last=last, capacity=capacity, n=n_steps):
            last.update(step=step, state=state)
            if step in (1, n // 2, n) or step % 500 == 0:
                marks[step] = (round(time.perf_counter() - t0, 1), float(loss), int(state.alive.sum()))
                print(capacity, step, marks[step], flush=True)
            if step % 100 == 0 and step < n and time.perf_counter() - t_start > budget:
                raise OutOfTime(f"stopped at step {step}: past the {budget:.0f} s budget")

        stopped = None
        try:
            try:
                out = train(
                    capture,
                    ims,
                    wts,
                    config=cfg,
                    bounds=bounds,
                    points=pts,
                    colours=cols,
                    callback=cb,
                    depth=depth,
                )
                params, alive, n_dropped = out.gaussians, jnp.asarray(out.alive), out.history["n_dropped"]
            except OutOfTime as e:  # score the model as it stood: a shorter schedule, said so
                stopped = str(e)
                params, alive, n_dropped = last["state"].params, last["state"].alive, None
            done = last.get("step", n_steps)
            t_train = time.perf_counter() - t0
            t1 = time.perf_counter()
            mean, low, held_norm = psnr(params, alive, render)
            train_norm = psnr_training(params, alive, render)
            run_ = {
                "capacity": capacity,
                "steps": done,
                "schedule_steps": n_steps,
                "stopped": stopped,
                "train_s": round(t_train, 1),
                "step_s_mean": round(t_train / done, 4),
                # seconds per step between the last two marks: the grown model's step
                "step_s_last_interval": _last_interval(marks),
                "psnr_heldout_db": round(mean, 2),
                "psnr_lowest_channel_view_db": round(low, 2),
                # normalised to the median exposure: held out vs the training views' own fit
                "psnr_heldout_normalised_db": round(float(np.mean(list(held_norm.values()))), 2),
                "psnr_training_normalised_db": round(train_norm, 2),
                "psnr_heldout_views_normalised_db": {k: round(v, 2) for k, v in held_norm.items()},
                "score_s": round(time.perf_counter() - t1, 1),
                "alive": int(np.asarray(alive).sum()),
                "dropped_mean_last100": None if n_dropped is None else float(np.mean(n_dropped[-100:])),
                "marks": marks,
                **_memory(None, jax.devices()[0]),
            }
            if save_model and not any("psnr_heldout_db" in r for r in res["runs"]):
                run_["saved"] = _save_model(params, np.asarray(alive), Path(save_model), capacity)
        except Exception as e:
            run_ = {"capacity": capacity, "error": f"{type(e).__name__}: {e}"[:500], "marks": marks}
        res["runs"].append(run_)
        print(run_, flush=True)
        save()
    res["total_s"] = round(time.perf_counter() - t_start, 1)
    save()


def _last_interval(marks: dict) -> float | None:
    """Seconds per step between the last two marks (the grown model), or None with fewer than two."""
    k = sorted(marks)[-2:]
    if len(k) < 2:
        return None
    return round((marks[k[1]][0] - marks[k[0]][0]) / (k[1] - k[0]), 4)


def _memory(compiled, device) -> dict:
    """The compiled step's own memory (XLA's analysis: arguments + outputs + temporaries − aliased, MiB)
    and the device's peak allocation so far in this process (MiB; None where the device keeps none,
    as JAX's CPU device)."""
    out = {}
    if compiled is not None:
        try:
            m = compiled.memory_analysis()
            total = m.argument_size_in_bytes + m.output_size_in_bytes + m.temp_size_in_bytes
            out["step_memory_mib"] = round((total - m.alias_size_in_bytes) / 2**20, 1)
            out["step_temp_mib"] = round(m.temp_size_in_bytes / 2**20, 1)
        except Exception:  # an analysis this back-end does not give
            pass
    stats = device.memory_stats() or {}
    peak = stats.get("peak_bytes_in_use")
    out["device_peak_mib"] = None if peak is None else round(peak / 2**20, 1)
    return out


def _reference_scene(
    path: str, points, capacity: int, camera, render, method: str, repeats: int = 20
) -> dict:
    """Write one view's Gaussians (constrained values), camera and image to ``path`` for
    ``gsplat_reference.py``, and time this project's render and its gradient on them (median of
    ``repeats`` after a compiled run): an outside rasteriser is then timed on the very same input."""
    import jax
    import jax.numpy as jnp

    from splat.rendering import render as render_fn
    from splat.training import TrainConfig, init_state

    pts, cols = points
    cfg = dataclasses.replace(TrainConfig(), capacity=capacity)
    g = init_state(
        cfg,
        bounds=np.stack([pts.min(0), pts.max(0)]),
        n_channels=cols.shape[1],
        points=pts,
        colours=cols,
        n_init=len(pts),
    ).params
    target = jnp.full((camera.height, camera.width, g.n_channels), 0.5, jnp.float32)

    def loss(params):
        out = render_fn(params, camera, method=method, config=render)
        return jnp.mean((out.image - target) ** 2), out

    fwd = jax.jit(lambda p: render_fn(p, camera, method=method, config=render).image)
    grad = jax.jit(jax.value_and_grad(loss, has_aux=True))

    def median_s(f):
        jax.block_until_ready(f(g))
        ts = []
        for _ in range(repeats):
            t0 = time.perf_counter()
            jax.block_until_ready(f(g))
            ts.append(time.perf_counter() - t0)
        return round(float(np.median(ts)), 5)

    t_fwd, t_grad = median_s(fwd), median_s(grad)
    (_, out), _ = grad(g)
    viewmat = np.eye(4, dtype=np.float32)
    viewmat[:3, :3], viewmat[:3, 3] = np.asarray(camera.R), np.asarray(camera.t)
    K = np.array(
        [[camera.focal[0], 0, camera.principal[0]], [0, camera.focal[1], camera.principal[1]], [0, 0, 1]],
        np.float32,
    )
    np.savez(
        path,
        means=np.asarray(g.means, np.float32),
        quats=np.asarray(g.quats, np.float32),
        scales=np.asarray(g.scales, np.float32),
        opacities=np.asarray(g.opacities, np.float32),
        colours=np.asarray(g.colours, np.float32),
        viewmat=viewmat,
        K=K,
        size=np.array([camera.width, camera.height]),
        image=np.asarray(out.image, np.float32),
        eps2d=render.eps2d,
        near=render.near,
    )
    return {
        "capacity": capacity,
        "gaussians": int(g.n),
        "size": [camera.width, camera.height],
        "channels": int(g.n_channels),
        "render_s": t_fwd,
        "render_grad_s": t_grad,
        "dropped": int(out.n_dropped),
        "file": path,
    }


def _save_model(params, alive, folder: Path, capacity: int, limit: float = 15.5 * 2**20) -> list[str]:
    """The alive Gaussians, one ``.npy`` per field (centres float32, the rest float16, each under the
    device tool's 16 MiB per file); fields over the limit are left out and named in the list."""
    folder.mkdir(parents=True, exist_ok=True)
    saved = []
    for k in ("means", "quats", "log_scales", "opacity_logits", "colour_params"):
        x = np.asarray(getattr(params, k))[alive]
        x = x.astype(np.float32 if k == "means" else np.float16)
        if x.nbytes > limit:
            saved.append(f"{k}: too large ({x.nbytes / 2**20:.1f} MiB), not saved")
            continue
        np.save(folder / f"g{capacity}_{k}.npy", x)
        saved.append(k)
    return saved


def _overrides(items: list[str]) -> dict:
    """``--set FIELD=VALUE`` pairs as :class:`splat.TrainConfig` overrides of the pipeline's schedule
    (VALUE parsed as JSON where it is, else kept as a string); checked here, before any timing."""
    from splat.training import TrainConfig

    fixed = {"steps", "capacity", "render", "method", "checkpoint"}  # set by the other options
    names = sorted({f.name for f in dataclasses.fields(TrainConfig)} - fixed)
    out = {}
    for item in items:
        key, sep, value = item.partition("=")
        if not sep or key not in names:
            raise SystemExit(f"--set {item!r}: expected FIELD=VALUE with FIELD one of {', '.join(names)}")
        try:
            out[key] = json.loads(value)
        except json.JSONDecodeError:
            out[key] = value
    dataclasses.replace(TrainConfig(), **out)  # a bad value fails now (SplatError names it)
    return out


def main(argv=None) -> None:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    sub = p.add_subparsers(dest="cmd", required=True)
    e = sub.add_parser("export")
    e.add_argument("capture"), e.add_argument("out"), e.add_argument("bundle")
    r = sub.add_parser("run")
    r.add_argument("bundle"), r.add_argument("results")
    r.add_argument("--budget", type=float, default=520.0, help="seconds for the whole run")
    r.add_argument("--capacities", default="32768,262144")
    r.add_argument("--steps", type=int, default=3000)
    r.add_argument("--time-steps", type=int, default=10)
    r.add_argument("--method", default="auto", help="render back-end (auto: tiled on a GPU)")
    r.add_argument("--tile-capacity", type=int, default=0, help="0: 1024 up to 65 536 Gaussians, else 2048")
    r.add_argument("--save-model", default=None, help="folder for the largest trained model's Gaussians")
    r.add_argument(
        "--min-steps",
        type=int,
        default=None,
        help="train fewer steps (down to this, by 500) where --steps does not fit the budget",
    )
    r.add_argument(
        "--baseline",
        choices=("serial", "cpu", "none"),
        default="serial",
        help="timed first: tiles one after another, or the 'cpu' back-end on the host's cores",
    )
    r.add_argument("--time-capacities", default=None, help="capacities to time (default: the least and most)")
    r.add_argument(
        "--train-anyway",
        action="store_true",
        help="train even where the estimate (every slot alive) says it will not fit: stopped at the "
        "budget and scored as it stood",
    )
    r.add_argument("--reference", default=None, help="write one view's scene here for gsplat_reference.py")
    r.add_argument(
        "--set",
        action="append",
        default=[],
        metavar="FIELD=VALUE",
        help="override a TrainConfig field of the pipeline's schedule, e.g. densify_gradient=screen",
    )
    r.add_argument("--time-only", action="store_true", help="time the steps, train nothing")
    a = p.parse_args(argv)
    if a.cmd == "export":
        export(a.capture, a.out, a.bundle)
    else:
        caps = [int(c) for c in a.capacities.split(",")]
        run(
            a.bundle,
            a.results,
            a.budget,
            caps,
            a.steps,
            a.time_steps,
            a.method,
            a.tile_capacity,
            a.save_model,
            _overrides(a.set),
            min_steps=a.min_steps,
            baseline=a.baseline,
            time_capacities=[int(c) for c in a.time_capacities.split(",")] if a.time_capacities else None,
            reference=a.reference,
            train_anyway=a.train_anyway,
            time_only=a.time_only,
        )


if __name__ == "__main__":
    sys.exit(main())
