"""The capture benchmark when ``capture.toml`` names published curves of another unit of each model.

The CI-size simulated capture of ``bench_capture_accuracy.py`` (true poses) is rendered with the
built-in curves (Nikon D5100 by NPL, Sigma SD Merrill by NPL, Canon 5D Mark II by rawtoaces), trained
once, and scored three times on the same model, in one process:

* ``own curves``: ``capture.toml`` as the simulator writes it (the very curves, ``ssf_exact = true``);
* ``published, trusted``: the Nikon and the Canon named by camspec's measurements of the same models
  (another unit, another laboratory), ``ssf_exact = true`` kept — the fit trusts them exactly, as
  every fit on measured curves did before ``zonotope.unit_sigma``;
* ``published, levels per channel``: ``ssf_exact`` removed, so the two cameras' levels against the
  others are measured per channel (``splat.fusion.camera_levels``), but the fits told no σ
  (``zonotope.unit_sigma`` held at 0): what the levels alone repair;
* ``published, σ told``: the same curves, ``ssf_exact`` removed — the default: levels per channel and
  the fits told the spread between units of one model (``SSF_UNIT_SIGMA``).

The Sigma keeps its curves (no second measurement of it exists). Truth is the simulator's. Why: the
default for measured curves must be measured on the product's own path, where a real user's curves are
never their unit's.

    python benchmarks/bench_capture_units.py --data ../shared/data --work /tmp/capture_units
    python benchmarks/bench_capture_units.py --data ../shared/data --work /tmp/capture_units_coarse \
        --texture coarse --level-pixels 10     # the cameras' levels measured on the small views
"""

from __future__ import annotations

import argparse
import contextlib
import re
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).parent))
from bench_capture_accuracy import MEASURES, _labels, table
from bench_capture_ssf import mean_over, reuse_trained, run_variant

#: folder → camspec file of another measurement of the simulated camera's model.
PUBLISHED = {
    "nikon": "ssf_jiang2013_camspec/Nikon_D5100/Nikon_D5100.csv",
    "canon": "ssf_jiang2013_camspec/Canon_5DMarkII/Canon_5DMarkII.csv",
}
VARIANTS = ("own curves", "published, trusted", "published, levels per channel", "published, σ told")


def published_capture(work: Path, source: Path, data: Path, *, trusted: bool) -> Path:
    """A copy of ``source``'s capture (its trained steps linked, a fresh ``correct/``) whose
    ``capture.toml`` names :data:`PUBLISHED` for those folders, ``ssf_exact = true`` kept if
    ``trusted``; returns the copy's folder."""
    capture = work / "capture"
    reuse_trained(source, work)
    toml = (capture / "capture.toml").read_text(encoding="utf-8")
    for folder, rel in PUBLISHED.items():
        f = (data / rel).resolve()
        if not f.is_file():
            raise SystemExit(f"--data {data}: {rel} not found")
        table_re = re.compile(rf'(folder = "{folder}"\nssf = )"[^"]+"\n(ssf_exact = true\n)?')
        exact = "ssf_exact = true\n" if trusted else ""
        toml = table_re.sub(lambda m, f=f, exact=exact: f'{m.group(1)}"{f}"\n{exact}', toml)
    (capture / "capture.toml").write_text(toml, encoding="utf-8")
    return capture


@contextlib.contextmanager
def _no_unit_sigma(active: bool):
    """``zonotope.unit_sigma`` returning zeros meanwhile (when ``active``)."""
    import numpy as np

    import zonotope

    kept = zonotope.unit_sigma
    try:
        if active:
            zonotope.unit_sigma = lambda n, *, exact=(): np.zeros(3 * n)
        yield
    finally:
        zonotope.unit_sigma = kept


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--data", type=Path, required=True, help="shared data folder (camspec's curves)")
    ap.add_argument("--work", type=Path, required=True, help="work folder (steps already done are reused)")
    ap.add_argument("--steps", type=int, default=300)
    ap.add_argument("--capacity", type=int, default=2048)
    ap.add_argument("--stride", type=int, default=2)
    ap.add_argument("--threads", type=int, default=2)
    ap.add_argument(
        "--texture",
        choices=("fine", "coarse"),
        default="fine",
        help="the simulated surfaces' texture (coarse: smooth regions, where camera levels are measured)",
    )
    ap.add_argument(
        "--level-pixels",
        type=int,
        help="smooth shared pixels a view needs for a camera-level ratio (default CAMERA_LEVEL_MIN_PIXELS; "
        "the CI-size views hold fewer)",
    )
    a = ap.parse_args(argv)
    from splat.scoring import score

    if a.level_pixels is not None:
        import splat._tol

        splat._tol.CAMERA_LEVEL_MIN_PIXELS = a.level_pixels

    results = {}
    for variant in VARIANTS:
        t0 = time.perf_counter()
        if variant == "own curves":
            import dataclasses

            from splat.sim.capture import SimCaptureConfig

            sim = dataclasses.replace(SimCaptureConfig.ci(), texture=a.texture)
            sc, folders, _ = run_variant(
                a.work / "own", a.steps, a.capacity, a.threads, a.stride, None, False, False, sim=sim
            )
        else:
            capture = published_capture(
                a.work / variant.replace(", ", "-").replace(" ", "_"),
                a.work / "own",
                a.data,
                trusted=variant == "published, trusted",
            )
            n = len(folders)
            subsets = [(k,) for k in range(n)] + [tuple(range(n))]
            with _no_unit_sigma(variant == "published, levels per channel"):
                sc = score(
                    capture,
                    capture.parent / "out",
                    stride=a.stride,
                    methods=("Prior",),
                    subsets=subsets,
                    raw_methods=(),
                )
        results[variant] = sc
        text, _ = table(sc, folders)
        print(f"\n## {variant} ({time.perf_counter() - t0:.0f} s; δ = {sc['delta']:.4f})\n\n{text}")
    print("\n## three cameras fused, uniform-surface mean (flat pixels)\n")
    print("| views | DNG development | " + " | ".join(VARIANTS) + " |")
    print("|---|---:|" + "---:|" * len(VARIANTS))
    sc0 = results["own curves"]
    groups = {f: [v for v in sc0["per_view"] if v.split("/")[0] == f] for f in folders}
    groups["all views"] = list(sc0["per_view"])
    for g, views in groups.items():
        dng = [
            mean_over(sc0, views, lambda v: _labels(v.split("/")[0], folders)["dng"], m)
            for m in ("uniform", "flat")
        ]
        cells = []
        for variant in VARIANTS:
            u, f = (
                mean_over(results[variant], views, lambda v: _labels(v.split("/")[0], folders)["three"], m)
                for m in ("uniform", "flat")
            )
            cells.append(f"{u:.2f} ({f:.2f})")
        print(f"| {g} ({len(views)}) | {dng[0]:.2f} ({dng[1]:.2f}) | " + " | ".join(cells) + " |")
    print(f"\n(measures: {dict(MEASURES)})")
    return 0


if __name__ == "__main__":
    sys.exit(main())
