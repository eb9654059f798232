"""Which photographs the correct step reads at full resolution: the render step's ranking against the
former one of the correct step.

    python benchmarks/bench_source_choice.py CAPTURE OUT [--stride 4]

On a finished run's model (``OUT`` after the train step; nothing is written), for every registered
photograph and every other camera, the :data:`splat._tol.FULL_SOURCES` photographs of that camera
chosen

- **now**: :func:`splat.capture.nearest_sources` with ``seen_only`` (visibility counted on every
  ``--stride``-th pixel, default the correct step's :data:`splat._tol.FULL_SOURCE_STRIDE`; ties by
  name, photographs that see nothing left out);
- **before**: the correct step's former ranking, kept here as the reference (every working pixel
  counted, ties by name, photographs that see nothing left out).

Printed: how many choices differ, and the share of the view's pixels the chosen photographs see
(counted on every pixel, the former ranking's own measure) under each, summed over the choice.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("capture", type=Path)
    ap.add_argument("out", type=Path)
    ap.add_argument(
        "--stride",
        type=int,
        default=None,
        help="pixel stride of the ranking now (default splat._tol.FULL_SOURCE_STRIDE, the correct step's)",
    )
    a = ap.parse_args(argv)
    if not (a.out / "train" / "summary.json").is_file():
        print(f"{a.out}: no finished train step (train/summary.json)", file=sys.stderr)
        return 2

    from splat._tol import FULL_SOURCE_STRIDE, FULL_SOURCES

    a.stride = FULL_SOURCE_STRIDE if a.stride is None else a.stride
    from splat.capture import (
        PipelineConfig,
        load_gaussians,
        load_model_capture,
        load_views,
        nearest_sources,
        read_capture,
        refined_views,
        working_binning,
        working_views,
    )
    from splat.reproject import MIN_ALPHA, depth_map, visibility

    spec = read_capture(a.capture)
    raws = {v.name: v for v in load_views(spec, binning=working_binning(PipelineConfig(), spec))}
    g, alive = load_gaussians(a.out)
    _, cap = load_model_capture(spec, a.out)
    views = {v.name: v for v in refined_views(working_views(cap.views, raws), a.out)}
    depth = {}
    for name, v in views.items():
        d, al = depth_map(g, v.camera, mask=alive)
        depth[name] = (d, al, np.where(al >= MIN_ALPHA, d, 0.0))

    n = differ = 0
    share_now, share_before = [], []
    for name, v in views.items():
        cam, (d, al, _) = v.camera, depth[name]
        pixels = d.size
        for c in range(len(spec.cameras)):
            if c == raws[name].camera:
                continue
            cands = [
                (m, views[m].camera, depth[m][2])
                for m, r in raws.items()
                if r.camera == c and r.exif is not None and m in views
            ]
            seen = {m: int(visibility(cam, d, al, sc, sd).sum()) for m, sc, sd in cands}
            before = [m for m in sorted(seen, key=lambda m: (-seen[m], m))[:FULL_SOURCES] if seen[m] > 0]
            now = [
                m
                for m, _, _ in nearest_sources(
                    cam, d, al, cands, FULL_SOURCES, seen_only=True, stride=a.stride
                )
            ]
            n += 1
            differ += set(now) != set(before)
            share_now.append(sum(seen[m] for m in now) / pixels)
            share_before.append(sum(seen[m] for m in before) / pixels)
            if set(now) != set(before):
                print(
                    f"{name}, camera {spec.cameras[c].folder}: before {before} "
                    f"({share_before[-1]:.3f}), now {now} ({share_now[-1]:.3f})"
                )
    print(
        f"\nstride {a.stride}: {n} choices of {FULL_SOURCES} photographs ({len(views)} views × other "
        f"cameras): {differ} differ. "
        f"Share of the view seen by the chosen photographs, summed over them, mean (min): before "
        f"{np.mean(share_before):.4f} ({np.min(share_before):.4f}), now {np.mean(share_now):.4f} "
        f"({np.min(share_now):.4f})."
    )
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
