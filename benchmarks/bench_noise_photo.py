"""Benchmark: correcting a noisy photograph of 1, 2 or 3 stacked cameras — time, peak memory, ΔE00.

The photograph (``--megapixels``, 24 by default, float32) is a mosaic of flat patches of natural
reflectances (built-in sets) under smooth shading, rendered for the cameras and given shot noise σ at
white (``--sigma``, 0.005 by default: variance σ² · c per channel). Per camera count, in this one
process: the baseline — the noise-aware root-polynomial (``"Finlayson 2015"`` fitted for the true
noise model) applied by ``correct_image`` — and ``correct_image(image, cameras)`` with its defaults
(noise estimated from the image, fit included). Reported: median wall time of ``--repeats`` runs
(the two interleaved), the ratio to the baseline, the peak of memory allocated during the call
(``tracemalloc``, one extra run; the image is not counted, the float64 XYZ output is), and the mean
ΔE00 against the true XYZ on ``--check`` sampled pixels.

Run: ``python benchmarks/bench_noise_photo.py [--megapixels 24] [--cameras 1 2 3] [--repeats 5]``
"""

from __future__ import annotations

import argparse
import statistics
import time
import tracemalloc

import numpy as np

from zonotope.correct import NoiseModel, correction_problem, fit_correction
from zonotope.correct.image import correct_image
from zonotope.evaluate import natural_test_sets

CAMERAS = {
    1: ["Nikon 5100 (NPL)"],
    2: ["Nikon 5100 (NPL)", "Canon EOS 5D Mark II"],
    3: ["Nikon 5100 (NPL)", "Sigma SDMerill (NPL)", "Canon EOS 5D Mark II"],
}


def photo(problem, megapixels: float, sigma: float, seed: int = 0):
    """A noisy float32 image ``(H, W, k)``, its true XYZ at ``check`` positions, and the noise model."""
    W_ = int(np.sqrt(megapixels * 1e6 * 1.5))
    H = int(megapixels * 1e6 / W_)
    w = problem.wavelengths
    X = np.concatenate([t.reflectances for t in natural_test_sets(w)])
    C, T = problem.source_of(X).astype(np.float32), problem.target_of(X)
    patch = 200
    rng = np.random.default_rng(seed)
    ids = rng.integers(0, X.shape[0], (H // patch + 1, W_ // patch + 1))
    model = NoiseModel.shot_limited(sigma, problem.k)
    img = np.empty((H, W_, problem.k), dtype=np.float32)
    xs = (0.7 + 0.3 * np.arange(W_) / W_).astype(np.float32)
    for i in range(0, H, patch):
        rows = slice(i, min(i + patch, H))
        idx = np.repeat(ids[i // patch], patch)[:W_]
        clean = C[idx] * xs[:, None]  # (W, k) shading along x
        block = np.broadcast_to(clean, (rows.stop - rows.start, W_, problem.k))
        noise = rng.standard_normal(block.shape, dtype=np.float32)
        img[rows] = block + noise * np.sqrt(model.variance(block)).astype(np.float32)
    truth = lambda r, c: T[ids[r // patch, c // patch]] * (0.7 + 0.3 * c / W_)[:, None]  # noqa: E731
    return img, truth, model


def timed(fns, repeats: int) -> list[tuple[float, object]]:
    """Median wall time and last result of each function, the runs interleaved (a, b, a, b, ...) so
    that a changing machine load falls on all of them alike."""
    times, outs = [[] for _ in fns], [None] * len(fns)
    for _ in range(repeats):
        for i, fn in enumerate(fns):
            t0 = time.perf_counter()
            outs[i] = fn()
            times[i].append(time.perf_counter() - t0)
    return [(statistics.median(t), o) for t, o in zip(times, outs)]


def peak_mb(fn) -> float:
    tracemalloc.start()
    tracemalloc.reset_peak()
    base = tracemalloc.get_traced_memory()[0]
    fn()
    peak = tracemalloc.get_traced_memory()[1] - base
    tracemalloc.stop()
    return peak / 2**20


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--megapixels", type=float, default=24.0)
    ap.add_argument("--cameras", nargs="+", type=int, default=[1, 2, 3], choices=[1, 2, 3])
    ap.add_argument("--sigma", type=float, default=0.005)
    ap.add_argument("--repeats", type=int, default=5)
    ap.add_argument("--check", type=int, default=20000)
    args = ap.parse_args()
    import colour

    for n in args.cameras:
        cams = CAMERAS[n]
        shape = colour.SpectralShape(400, 680 if any("Sigma" in c for c in cams) else 700, 10)
        problem = correction_problem(cams, shape=shape)
        img, truth, model = photo(problem, args.megapixels, args.sigma)
        rng = np.random.default_rng(1)
        r = rng.integers(0, img.shape[0], args.check)
        c = rng.integers(0, img.shape[1], args.check)
        T = np.stack([truth(ri, np.array([ci]))[0] for ri, ci in zip(r, c)])

        def baseline(img=img, problem=problem, model=model):
            return correct_image(img, fit_correction(problem, method="Finlayson 2015", noise=model))

        def default(img=img, problem=problem):
            return correct_image(img, problem)

        (t_base, out_base), (t_def, out_def) = timed([baseline, default], args.repeats)
        dE_base = problem.delta_E(out_base[r, c], T).mean()
        dE_def = problem.delta_E(out_def[r, c], T).mean()
        _, info = correct_image(img[:512, :512], problem, return_info=True)
        mem_base, mem_def = peak_mb(baseline), peak_mb(default)
        print(
            f"{n} camera(s), {img.shape[0]}×{img.shape[1]}×{img.shape[2]} float32 "
            f"({img.nbytes / 2**20:.0f} MB), σ = {args.sigma} shot at white; default method "
            f"{info['method']}, noise {info['noise'].describe() if info['noise'] else 'none'}\n"
            f"  baseline (NA root-poly, true noise): {t_base:7.2f} s  peak {mem_base:7.0f} MB  "
            f"ΔE00 {dE_base:.3f}\n"
            f"  correct_image defaults            : {t_def:7.2f} s  peak {mem_def:7.0f} MB  "
            f"ΔE00 {dE_def:.3f}   ratio {t_def / t_base:.2f}×",
            flush=True,
        )
        del img, out_base, out_def


if __name__ == "__main__":
    main()
