"""What the SSF uncertainty band does to metamer mismatch volumes, and the picture of it.

For measured cameras held out of the basis (leave one model out, as ``bench_ssf.py``), estimate the
curves from synthesised DNG matrices, then for each ColorChecker patch under D65 compute the MMV
with the estimate, with ``--samples`` cameras drawn within ±2σ of its band
(:func:`zonotope.band_mmvs`) and, as the check a user cannot make, with the measured camera. Prints
the spread of the sample volumes relative to the estimate's volume and the ΔE00 shift of their
centroids, and the same two figures for the measured camera.

    python benchmarks/bench_ssf_band.py --data ../shared/data                      # the table
    python benchmarks/bench_ssf_band.py --data ../shared/data --picture docs/_static/ssf_band_mmv.png
"""

from __future__ import annotations

import argparse
import dataclasses
import sys
import time
from pathlib import Path

import numpy as np

import zonotope
from zonotope.correct import correction_problem
from zonotope.mismatch.volume import metamer_mismatch_bounds
from zonotope.spectra import builtin as spectra
from zonotope.spectra.estimate import SSF_SHAPE, estimate_ssf, ssf_basis, synthesise_dng_matrices

sys.path.insert(0, str(Path(__file__).parent))
from bench_ssf import basis_without, measured_cameras, msds

W = SSF_SHAPE.wavelengths


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--data", type=Path, default=None, help="shared data folder (rawtoaces, camspec)")
    ap.add_argument("--cameras", type=int, default=6, help="held-out cameras (every k-th, sorted)")
    ap.add_argument("--samples", type=int, default=8)
    ap.add_argument("--patches", default="all", help="ColorChecker patch indices, e.g. 2,13 (default all)")
    ap.add_argument("--k", type=float, default=None, help="draws within ±k σ (default the estimate's band_k)")
    ap.add_argument("--correlation", type=float, default=40.0, help="correlation length of the draws (nm)")
    ap.add_argument(
        "--band",
        choices=("basis", "shipped"),
        default="basis",
        help="the held-out basis' own band (PCA residual, ±2σ) or the shipped one (spread, band_k)",
    )
    ap.add_argument("--picture", type=Path, default=None, help="PNG of the band's MMVs for --picture-patch")
    ap.add_argument("--picture-camera", default="", help="substring of the camera to draw")
    ap.add_argument("--picture-patch", type=int, default=2)
    a = ap.parse_args(argv)

    cams = measured_cameras(a.data)
    names = sorted(cams)
    step = max(1, len(names) // a.cameras)
    chosen = names[::step][: a.cameras]
    if a.picture_camera:
        chosen = [n for n in names if a.picture_camera in n][:1] or chosen
    R = spectra.resample(zonotope.load_reflectances("ColorChecker N Ohta"), W).T
    patches = range(len(R)) if a.patches == "all" else [int(p) for p in a.patches.split(",")]
    rows = []
    for name in chosen:
        c = cams[name]
        basis = basis_without(cams, c["model"], redistributable_only=True, k=5)
        est = estimate_ssf(synthesise_dng_matrices(msds(c["values"], name)), basis=basis, name=name)
        if a.band == "shipped":  # the calibrated band of the shipped basis, scaled to this estimate's peaks
            shipped = ssf_basis()
            est = dataclasses.replace(
                est, uncertainty=shipped.spread * est.values.max(axis=0), band_k=shipped.band_k
            )
        true_pb = correction_problem(msds(c["values"], name), shape=W)
        t = time.perf_counter()
        for i in patches:
            band = zonotope.band_mmvs(est, R[i], n=a.samples, seed=i, k=a.k, correlation=a.correlation)
            true = metamer_mismatch_bounds(
                true_pb.Phi, true_pb.Psi, R[i] @ true_pb.Phi, on_infeasible="nearest"
            ).inner
            v = band.sample_volumes / band.volume
            rows.append(
                (
                    name,
                    i,
                    v.min(),
                    np.median(v),
                    v.max(),
                    np.median(band.centroid_delta_e),
                    band.centroid_delta_e.max(),
                    true.volume / band.volume,
                    float(band.problem.delta_E(true.centroid, band.mmv.centroid)),
                    bool(v.min() <= true.volume / band.volume <= v.max()),
                )
            )
            if a.picture is not None and i == a.picture_patch and name == chosen[0]:
                from zonotope.viz import plot_mmv_band

                title = (
                    f"{name.split(' (')[0]}, ColorChecker patch {i + 1}: estimate (sRGB), "
                    f"{a.samples} band samples, measured (black)"
                )
                plot_mmv_band(band, reference=true, filename=a.picture, title=title).close()
        print(f"{name}: {len(patches)} patches in {time.perf_counter() - t:.0f} s", flush=True)
    arr = np.array([r[2:] for r in rows], dtype=float)
    print(
        "\ncamera | patch | sample vol / est vol min, median, max | centroid ΔE00 median, max | "
        "measured vol / est vol | measured centroid ΔE00 | measured vol in sample range"
    )
    for r in rows:
        print(
            f"{r[0]} | {r[1]} | {r[2]:.2f} {r[3]:.2f} {r[4]:.2f} | {r[5]:.2f} {r[6]:.2f} | "
            f"{r[7]:.2f} | {r[8]:.2f} | {r[9]}"
        )
    q = lambda x: f"{np.median(x):.2f} [{np.percentile(x, 10):.2f}, {np.percentile(x, 90):.2f}]"  # noqa: E731
    print(f"\nover {len(rows)} camera × patch cases (median [10th, 90th percentile]):")
    print(f"  sample vol / est vol, min over samples:    {q(arr[:, 0])}")
    print(f"  sample vol / est vol, max over samples:    {q(arr[:, 2])}")
    print(f"  sample centroid ΔE00 from est, median:     {q(arr[:, 3])}")
    print(f"  sample centroid ΔE00 from est, max:        {q(arr[:, 4])}")
    print(f"  measured-camera vol / est vol:             {q(arr[:, 5])}")
    print(f"  measured-camera centroid ΔE00 from est:    {q(arr[:, 6])}")
    print(f"  measured vol inside the samples' range:    {arr[:, 7].mean():.0%}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
