"""gsplat on the very scene ``gpu_capacity.py run --reference SCENE.npz`` rendered: a reference ratio.

Reads the Gaussians (centres, quaternions, scales, opacities, N-channel colours), the camera and this
project's rendered image from ``SCENE.npz``, renders the same view with gsplat's CUDA rasteriser
(``gsplat.rasterization``, classic mode, the same ``eps2d`` and near plane) and times the render alone
and the render with the gradient of a mean-squared loss (CUDA events, the median of ``--repeats``
after warm-up runs), as ``gpu_capacity.py`` times this project's back-end on the same input. The
relative difference of the two images says whether the two computed the same thing (both cut each
footprint at 3σ and alphas under 1/255 and clip them at 0.99; gsplat's tile cut-off and its
per-tile instead of per-pixel early stop differ in the last digits)::

    python benchmarks/gsplat_reference.py SCENE.npz RESULTS.json [--repeats 20]

gsplat (``pip install gsplat``) compiles its CUDA sources at first import (minutes; ``MAX_JOBS``,
``TORCH_CUDA_ARCH_LIST``); it needs PyTorch with CUDA and a GPU. Any failure is written to
``RESULTS.json`` as one line, so a batch of device checks goes on without it.
"""

from __future__ import annotations

import argparse
import json
import sys
import time
import traceback
from pathlib import Path

import numpy as np


def measure(scene: str, repeats: int = 20) -> dict:
    """Median milliseconds of gsplat's render and render + gradient on ``scene``, and the images'
    relative difference ``‖gsplat − this project‖ / ‖this project‖``."""
    import torch

    t0 = time.perf_counter()
    from gsplat import rasterization

    import_s = time.perf_counter() - t0
    s = np.load(scene)
    dev = torch.device("cuda")

    def t(name, grad=False):
        return torch.tensor(s[name], device=dev, requires_grad=grad)

    means, quats, scales = t("means", True), t("quats", True), t("scales", True)
    opacities, colours = t("opacities", True), t("colours", True)
    viewmat, K = t("viewmat")[None], t("K")[None]
    W, H = (int(v) for v in s["size"])
    target = torch.full((1, H, W, colours.shape[1]), 0.5, device=dev)

    def render():
        img, _, _ = rasterization(
            means,
            quats,
            scales,
            opacities,
            colours,
            viewmat,
            K,
            W,
            H,
            near_plane=float(s["near"]),
            eps2d=float(s["eps2d"]),
            packed=False,
            rasterize_mode="classic",
        )
        return img

    def render_grad():
        loss = torch.mean((render() - target) ** 2)
        loss.backward()
        return loss

    def median_ms(f):
        for _ in range(3):
            f()
        torch.cuda.synchronize()
        out = []
        for _ in range(repeats):
            a, b = torch.cuda.Event(enable_timing=True), torch.cuda.Event(enable_timing=True)
            a.record()
            f()
            b.record()
            torch.cuda.synchronize()
            out.append(a.elapsed_time(b))
        return float(np.median(out))

    with torch.no_grad():
        t_fwd = median_ms(render)
        img = render()[0].cpu().numpy()
    t_grad = median_ms(render_grad)
    ours = s["image"]
    return {
        "gsplat": __import__("gsplat").__version__,
        "torch": torch.__version__,
        "device": torch.cuda.get_device_name(),
        "import_s": round(import_s, 1),
        "gaussians": len(s["means"]),
        "size": [W, H],
        "channels": int(colours.shape[1]),
        "render_ms": round(t_fwd, 3),
        "render_grad_ms": round(t_grad, 3),
        "image_relative_difference": float(np.linalg.norm(img - ours) / max(np.linalg.norm(ours), 1e-12)),
    }


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("scene"), p.add_argument("results")
    p.add_argument("--repeats", type=int, default=20)
    a = p.parse_args(argv)
    try:
        res = measure(a.scene, a.repeats)
    except Exception as e:  # recorded, not raised: the device batch goes on
        res = {"error": f"{type(e).__name__}: {e}"[:2000], "trace": traceback.format_exc()[-4000:]}
    Path(a.results).write_text(json.dumps(res, indent=1))
    print(json.dumps(res), flush=True)
    return 0 if "error" not in res else 1


if __name__ == "__main__":
    sys.exit(main())
