"""The trained model's depth against the simulator's ray-cast depth, by fifths of the image width.

For a capture written by :mod:`splat.sim.capture` and the pipeline's output folder: each chosen view is
rendered as depth (:func:`splat.render_depth`, in the model's own frame and cameras) and compared with the
depth the simulator's geometry gives along every pixel's centre ray (the pipeline never sees it). The
model's frame may differ from the simulator's by a similarity (pycolmap's poses), so the ratio
``model / true`` is divided by its median over the middle three fifths of each view. Printed per view and
fifth: the median of ``|ratio − 1|``, the share of pixels off by more than 5 %, and the share of those in
front of the true surface. It showed that the arc-end views' outer fifths (the backdrop and far floor,
beyond the arc's end) were drawn 1–3 m too near when the initial Gaussians left the scene's periphery
out (docs/notes/2026-11-28-colmap-initialisation.md).

    python benchmarks/depth_error.py CAPTURE OUT --views nikon/DSC_0019.dng,nikon/DSC_0008.dng
    python benchmarks/depth_error.py CAPTURE OUT --model other/model.npz   # any model.npz of the same capture

The scene is rebuilt from ``--size`` and the seed, texture and noise recorded in ``truth/truth.toml``; the
rebuilt views must match the capture's true poses (``truth/images.txt``), or the script stops.
"""

from __future__ import annotations

import argparse
import sys
import tomllib
from pathlib import Path

import numpy as np


def depth_error(capture: Path, out: Path, *, size: str, model: Path | None, views: list[str] | None) -> dict:
    import splat
    from splat.capture import load_model_capture, read_capture
    from splat.colmap import read_colmap
    from splat.sim.capture import SimCaptureConfig, build_scene
    from splat.sim.geometry import shade

    truth = tomllib.loads((capture / "truth" / "truth.toml").read_text())
    keys = {k: truth[k] for k in ("seed", "texture", "noise", "supersample", "gain") if k in truth}
    cfg = getattr(SimCaptureConfig, size)(**keys)
    scene = build_scene(cfg)
    cams = scene.config.cameras
    sim = {f"{cams[v.camera].folder}/{v.stem}.dng": v for v in scene.views}
    true_images = {im.name: im for im in read_colmap(capture / "truth").images.values()}
    for name, im in true_images.items():
        v = sim.get(name)
        if v is None or not np.allclose(splat.qvec_to_rotmat(im.qvec), v.R, atol=1e-6):
            sys.exit(
                f"{name}: the rebuilt --size {size} scene does not match truth/images.txt; wrong --size?"
            )

    _, mc = load_model_capture(read_capture(capture / "capture.toml"), out)
    with np.load(model or out / "train" / "model.npz") as f:
        g = splat.Gaussians.from_numpy({k: f[k] for k in f.files})
        alive = f["alive"]
    result = {}
    for view in mc.views:
        if views is not None and view.name not in views:
            continue
        depth, _ = splat.render_depth(g, view.camera, mask=alive)
        s = sim[view.name]
        H, W = depth.shape
        u, w = np.meshgrid(np.arange(W) + 0.5, np.arange(H) + 0.5)
        o, d = scene.rays(s, u.ravel(), w.ravel())
        _, _, t = shade(scene, o, d)
        ratio = depth / (t * (d @ s.R[2])).reshape(H, W)  # camera-frame z of the hit: t · (R d)_z
        middle = ratio[:, W // 5 : 4 * W // 5]
        ratio = ratio / np.nanmedian(middle[np.isfinite(middle)])
        fifths = []
        for k in range(5):
            r = ratio[:, k * W // 5 : (k + 1) * W // 5]
            r = r[np.isfinite(r)]
            off = np.abs(r - 1) > 0.05
            front = float(np.mean(r[off] < 1)) if off.any() else 0.0
            fifths.append((float(np.median(np.abs(r - 1))), float(np.mean(off)), front))
        result[view.name] = fifths
    return result


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("capture", type=Path, help="a capture written by splat.sim.capture")
    ap.add_argument("out", type=Path, help="the pipeline's output folder (poses, train)")
    ap.add_argument("--size", choices=("benchmark", "ci"), default="benchmark")
    ap.add_argument("--model", type=Path, help="a model.npz (default: OUT/train/model.npz)")
    ap.add_argument("--views", help="comma-separated view names (default: all)")
    a = ap.parse_args(argv)
    res = depth_error(
        a.capture, a.out, size=a.size, model=a.model, views=a.views.split(",") if a.views else None
    )
    print("view | per fifth of the width, left to right: median |model/true − 1|, share > 5 % (in front)")
    for name, fifths in res.items():
        print(name, " | ".join(f"{m:.3f} {o:4.0%} ({f:4.0%})" for m, o, f in fifths))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
