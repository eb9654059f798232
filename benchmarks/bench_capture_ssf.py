"""The capture benchmark with estimated sensitivities: the same simulated capture, measured vs estimated SSFs.

Runs :mod:`bench_capture_accuracy`'s simulated capture twice in one process: once with the cameras'
measured sensitivities in ``capture.toml`` (as the simulator writes it) and once with sensitivities
estimated from each camera's first DNG (its ColorMatrix1/2 and ForwardMatrix1/2), written as rawtoaces
JSON beside ``capture.toml`` — what ``ssf = "estimate"`` does, but with the basis learned without any
measurement of the camera's model (``--data``; without it the shipped basis, which contains the Nikon
D5100 and the Canon EOS 5D Mark II, so the estimate is not held out). The sensor data, poses and
held-out views are identical; only the curves the pipeline fits its corrections on differ, and with
estimated curves each fit is also told the estimate's response σ (``splat.capture.ssf_sigma``, as
``ssf = "estimate"`` does; ``--no-ssf-sigma``: the sensor noise only). Truth is the simulator's
(measured curves).

Headline (issue 42): three cameras fused with estimated curves against the best single camera's DNG
development (``dng:<cam>``, which uses no curves), uniform-surface mean ΔE00 over the held-out views of
that camera and over all views; goal ≤ 0.5×.

    python benchmarks/bench_capture_ssf.py --data ../shared/data --work /tmp/capture_ssf
    python benchmarks/bench_capture_ssf.py --data ../shared/data --work /tmp/capture_ssf_adobe \
        --colordata LibRaw/src/tables/colordata.cpp [--exact-prior]    # Adobe's matrices
    python benchmarks/bench_capture_ssf.py --data ../shared/data --work /tmp/capture_ssf_bench \
        --from /tmp/acc_bench    # the benchmark capture, its trained model reused

``--from WORK`` scores a finished ``bench_capture_accuracy.py`` work folder (``WORK/capture``, ``WORK/out``
with its render step done) instead of simulating and training a CI-size capture: the splat, its renders
and the reprojections do not depend on the curves (training fits the RAW channels), only the
corrections do, so both variants score the same model (a copy of the capture each, the steps' folders
linked, a fresh ``correct/``).
"""

from __future__ import annotations

import argparse
import contextlib
import dataclasses
import re
import shutil
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).parent))
from bench_capture_accuracy import MEASURES, _labels, table


def estimated_curves(
    capture: Path,
    data: Path | None,
    *,
    real_matrices: dict | None = None,
    exact_prior: bool = False,
    only: tuple[str, ...] | None = None,
) -> tuple[list[str], dict]:
    """Estimate every camera's curves from its first DNG, write them beside capture.toml and point
    capture.toml at them (once: a capture already pointing at them keeps its file); returns one line per
    camera (RMSE against the measured curves) and the estimates by folder. ``real_matrices``
    (``--colordata``): measured-camera name → Adobe's D65 matrix (LibRaw's table), estimated from instead
    of the simulated DNG's exact matrices; ``exact_prior`` (``--exact-prior``): no real-DNG calibration
    (prior 1e-4); ``only`` (``--estimate``): the folders estimated, the others keep their measured curves."""
    from bench_ssf import _model_key, basis_without, curve_errors, measured_cameras

    import zonotope
    from splat.sim.capture import SimCaptureConfig
    from zonotope.spectra.estimate import SSF_SHAPE, estimate_ssf, ssf_basis, write_ssf_json

    cams = measured_cameras(data) if data else {}
    measured_names = {c.folder: c.ssf for c in SimCaptureConfig.ci().cameras}
    toml = (capture / "capture.toml").read_text(encoding="utf-8")
    tables = re.findall(r'folder = "([^"]+)"\nssf = "([^"]+)"', toml)
    real_matrices = real_matrices or {}
    real_dng = None if exact_prior else ssf_basis().real_dng
    notes, ests = [], {}
    for folder, name in tables:
        if only is not None and folder not in only:
            continue
        again = name == f"ssf_estimated_{folder}.json"  # estimated by an earlier run: kept as written
        name = measured_names[folder] if again else name
        dng = sorted((capture / folder).glob("*.dng"))[0]
        model = _model_key(name)
        basis = None
        if cams:  # held out; judged, as ssf = "estimate" judges a DNG alone, by the real-DNG calibration
            basis = dataclasses.replace(
                basis_without(cams, model, redistributable_only=True, k=5), real_dng=real_dng
            )
        elif exact_prior:
            basis = dataclasses.replace(ssf_basis(), real_dng=None)
        source = real_matrices.get(name, dng)
        est = ests[folder] = estimate_ssf(source, basis=basis, name=name)
        if not again:
            out = write_ssf_json(est, capture / f"ssf_estimated_{folder}.json", overwrite=True)
            toml = toml.replace(
                f'folder = "{folder}"\nssf = "{name}"\nssf_exact = true',
                f'folder = "{folder}"\nssf = "{name}"',
            )
            toml = toml.replace(  # not the simulated camera's own curves: its levels are measured per channel
                f'folder = "{folder}"\nssf = "{name}"', f'folder = "{folder}"\nssf = "{out.name}"'
            )
        true = np.asarray(zonotope.camera(name).copy().align(SSF_SHAPE).values)  # Sigma: held at 680 nm
        rmse, ang = curve_errors(est.values, true)
        notes.append(
            f"{folder} ({name}): estimated from {'Adobe' if name in real_matrices else dng.name}, basis "
            f"{'without its model' if cams else 'shipped (not held out)'}; RMSE R/G/B "
            + " / ".join(f"{v:.3f}" for v in rmse)
            + ", angle "
            + " / ".join(f"{v:.1f}" for v in ang)
            + "°"
        )
    if toml != (capture / "capture.toml").read_text(encoding="utf-8"):
        (capture / "capture.toml").write_text(toml, encoding="utf-8")
    return notes, ests


def reuse_trained(source: Path, work: Path) -> None:
    """``work/capture`` a copy of ``source/capture`` and ``work/out`` its trained steps linked with a fresh
    ``correct/`` (once: a ``work`` already holding a capture is kept). Why: the splat, its renders and the
    reprojections do not depend on the curves, so every variant scores the same model."""
    capture, out = work / "capture", work / "out"
    if (capture / "capture.toml").is_file():
        return
    shutil.copytree(source / "capture", capture)
    (out / "correct").mkdir(parents=True)
    for step in ("decoded", "poses", "train", "render"):
        if (source / "out" / step).exists():
            (out / step).symlink_to((source / "out" / step).resolve())


def run_variant(
    work: Path,
    steps: int,
    capacity: int,
    threads: int,
    stride: int,
    data,
    estimate: bool,
    ssf_sigma: bool,
    source: Path | None = None,
    sim=None,
    **estimate_kw,
):
    """Score one variant in ``work``: the trained capture of ``source`` reused, else a capture simulated
    from ``sim`` (default ``SimCaptureConfig.ci()``) with its true poses and trained here."""
    from splat.capture import PipelineConfig, read_capture, run
    from splat.scoring import score
    from splat.sim.capture import SimCaptureConfig, write_synthetic_capture

    capture, out = work / "capture", work / "out"
    notes: list[str] = []
    if source is not None:
        reuse_trained(source, work)
    if not (capture / "capture.toml").is_file():
        write_synthetic_capture(capture, sim or SimCaptureConfig.ci())
        (capture / "poses").mkdir()
        for f in ("cameras.txt", "images.txt", "points3D.txt"):
            shutil.copy(capture / "truth" / f, capture / "poses" / f)
        with open(capture / "capture.toml", "a") as fh:
            fh.write('\n[poses]\ncolmap = "poses"\n')
    ests = {}
    if estimate:
        notes, ests = estimated_curves(capture, data, **estimate_kw)
    spec = read_capture(capture)
    cfg = PipelineConfig(steps=steps, capacity=capacity, threads=threads, views=tuple(spec.holdout))
    if not (out / "render" / "index.json").is_file():
        for step in ("poses", "train", "render"):
            run(capture, out, config=cfg, steps=(step,))
    folders = [c.folder for c in spec.cameras]
    n = len(folders)
    subsets = [(k,) for k in range(n)] + [tuple(range(n))]
    with _told_band(ests if ssf_sigma else {}):
        sc = score(capture, out, stride=stride, methods=("Prior",), subsets=subsets, raw_methods=())
    return sc, folders, notes


@contextlib.contextmanager
def _told_band(ests: dict):
    """The corrections told each estimated camera's response σ (``splat.capture.ssf_sigma``), as
    ``ssf = "estimate"`` does, from ``ests`` (folder → estimate with the held-out basis) meanwhile."""
    from splat.capture.spec import CaptureSpec

    kept = CaptureSpec.ssf_estimate
    try:
        if ests:
            CaptureSpec.ssf_estimate = lambda self, k: ests.get(self.cameras[k].folder)
        yield
    finally:
        CaptureSpec.ssf_estimate = kept


def mean_over(sc: dict, views: list[str], label_of, measure: str) -> float:
    xs = [sc["per_view"][v].get(label_of(v), {}).get(measure) for v in views]
    xs = [x for x in xs if x is not None and np.isfinite(x)]
    return float(np.mean(xs)) if xs else float("nan")


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--data", type=Path, help="shared data folder: basis learned without each camera's model")
    ap.add_argument("--steps", type=int, default=300)
    ap.add_argument("--capacity", type=int, default=2048)
    ap.add_argument("--stride", type=int, default=2)
    ap.add_argument("--threads", type=int, default=2)
    ap.add_argument("--work", type=Path, required=True, help="work folder (steps already done are reused)")
    ap.add_argument(
        "--no-ssf-sigma",
        action="store_true",
        help="tell the corrections the sensor noise only (the default adds each estimate's σ)",
    )
    ap.add_argument(
        "--colordata",
        type=Path,
        help="LibRaw's colordata.cpp: estimate the cameras it has Adobe's D65 matrix for from that matrix",
    )
    ap.add_argument(
        "--exact-prior", action="store_true", help="estimate without the real-DNG calibration (prior 1e-4)"
    )
    ap.add_argument(
        "--sigma-scale",
        type=float,
        help="tell the fits this multiple of each estimate's RMS response error (default "
        "SSF_FIT_SIGMA_SCALE, the value chosen on natural sets)",
    )
    ap.add_argument(
        "--estimate",
        metavar="FOLDERS",
        help="comma-separated camera folders to estimate (default all); the others keep measured curves",
    )
    ap.add_argument(
        "--from",
        dest="source",
        type=Path,
        help="a bench_capture_accuracy.py work folder with its render step done: its model is scored",
    )
    a = ap.parse_args(argv)
    if a.source is not None and not (a.source / "out" / "render" / "index.json").is_file():
        print(
            f"--from {a.source}: no out/render/index.json (run bench_capture_accuracy.py there first)",
            file=sys.stderr,
        )
        return 2
    real = {}
    if a.colordata:
        from real_matrices import colour_matrix, read_colordata

        from splat.sim.capture import SimCaptureConfig
        from zonotope.spectra.estimate import DNGMatrices

        libraw = read_colordata(a.colordata)
        for cam in SimCaptureConfig.ci().cameras:
            M = colour_matrix(libraw, cam.ssf.replace(" (NPL)", "").replace("5100", "D5100"))
            if M is not None:
                real[cam.ssf] = DNGMatrices((M,), ("D65",), name=cam.ssf)
        print(f"Adobe's matrices for {sorted(real)}", file=sys.stderr)
    if a.sigma_scale is not None:  # the told σ of every estimate (SSFEstimate.response_sigma) meanwhile
        import zonotope.spectra.estimate as est_module

        if not (np.isfinite(a.sigma_scale) and a.sigma_scale >= 0):
            print(f"--sigma-scale {a.sigma_scale}: must be a finite number ≥ 0", file=sys.stderr)
            return 2
        est_module.SSF_FIT_SIGMA_SCALE = a.sigma_scale
    results = {}
    for variant in ("measured", "estimated"):
        t0 = time.perf_counter()
        sc, folders, notes = run_variant(
            a.work / variant,
            a.steps,
            a.capacity,
            a.threads,
            a.stride,
            a.data,
            variant == "estimated",
            not a.no_ssf_sigma,
            a.source,
            real_matrices=real,
            exact_prior=a.exact_prior,
            only=None if a.estimate is None else tuple(a.estimate.split(",")),
        )
        results[variant] = (sc, folders)
        text, _ = table(sc, folders)
        print(f"\n## {variant} sensitivities ({time.perf_counter() - t0:.0f} s; δ = {sc['delta']:.4f})\n")
        for line in notes:
            print(f"- {line}")
        print("\n" + text)
    print("\n## three cameras fused ÷ DNG development of one camera (uniform-surface mean; flat pixels)\n")
    print(
        "| views | DNG development | three fused, measured | three fused, estimated | ratio measured "
        "| ratio estimated |"
    )
    print("|---|---:|---:|---:|---:|---:|")
    sc_m, folders = results["measured"]
    sc_e, _ = results["estimated"]
    groups = {f: [v for v in sc_m["per_view"] if v.split("/")[0] == f] for f in folders}
    groups["all views"] = list(sc_m["per_view"])
    best = {}
    for g, views in groups.items():
        for m in ("uniform", "flat"):
            dng = mean_over(sc_m, views, lambda v: _labels(v.split("/")[0], folders)["dng"], m)
            three_m = mean_over(sc_m, views, lambda v: _labels(v.split("/")[0], folders)["three"], m)
            three_e = mean_over(sc_e, views, lambda v: _labels(v.split("/")[0], folders)["three"], m)
            if m == "uniform" and g != "all views":
                best[g] = dng
            print(
                f"| {g} ({dict(MEASURES)[m]}) | {dng:.2f} | {three_m:.2f} | {three_e:.2f} "
                f"| {three_m / dng:.2f} | {three_e / dng:.2f} |"
            )
    g = min(best, key=best.get)
    views = groups[g]
    dng = best[g]
    three_e = mean_over(sc_e, views, lambda v: _labels(v.split("/")[0], folders)["three"], "uniform")
    print(
        f"\nbest single camera's DNG development: {g} ({dng:.2f} ΔE00 uniform-surface mean on its views); "
        f"three cameras with estimated curves on the same views {three_e:.2f} = {three_e / dng:.2f}× "
        f"(goal ≤ 0.5: {'met' if three_e / dng <= 0.5 else 'NOT met'})"
    )
    return 0


if __name__ == "__main__":
    sys.exit(main())
