"""Can cameras that photograph one scene correct each other's estimated sensitivities?

A multi-camera capture sees every surface through all its cameras at once. Where the curves are estimated
(from DNG matrices), the stacked responses the cameras really record are not the ones the estimated
curves predict, and a stacked correction reads that mismatch as signal (docs/notes/2026-11-29-ssf-goal.md).
This benchmark asks whether the co-registered responses alone — no reflectance, no truth — can repair
the estimates before the correction is fitted. Leave one camera model out, as ``bench_ssf_stack.py``
(DNG-matrix estimates, basis learned without the set's models); for random two- and three-camera sets:

* **scene**: the responses of the measured cameras to surfaces none of the test sets holds (SFU 1995's
  Dupont paint chips and its 57 additional surfaces: 177 reflectances, unknown to the method), with
  Gaussian noise ``--noise`` (a region mean's);
* **linear map**: one 3×3 per camera (the first fixed, each row summing to 1 so the white stays white)
  fitted so that each camera's scene responses match what a root-polynomial regression, trained on the
  estimated curves over the 190 training reflectances, predicts from the other cameras';
* **refined curves**: each channel's curve moved along the first ``--components`` principal components
  of the other models' held-out curve errors (coefficients in units of their spread, a Gaussian prior
  of weight ``--prior``), chosen by least squares so that the same cross-camera predictions match the
  scene (scipy ``least_squares``); the correction is then fitted on the refined curves.

Baselines in the same run: the regression fitted on the measured curves, and on the estimated curves
noise-free and told the calibrated σ (the shipped default). The bound of any per-camera 3×3 ("same
solver" rows, a plain degree-2 root-polynomial least squares): each camera's estimated training
responses mapped onto its true ones (truth no user has) before the noise-free fit. Finlayson 2015,
noise-free test responses, natural test sets; mean ΔE00 over test sets, then sets.

    python benchmarks/bench_ssf_selfcal.py --data ../shared/data --seed 0 --sets 8
    python benchmarks/bench_ssf_selfcal.py --data ../shared/data --seed 1 --sets 8 --noise 0.001
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import colour
import numpy as np
from scipy.optimize import least_squares

sys.path.insert(0, str(Path(__file__).parent))
from bench_ssf import measured_cameras
from bench_ssf_stack import Source, W, msds, random_sets

from zonotope.correct import NoiseModel, correction_problem, fit_correction, noise_options
from zonotope.correct.regressions import root_polynomial_terms
from zonotope.evaluate import natural_test_sets
from zonotope.spectra import builtin as spectra
from zonotope.spectra.estimate import SSF_SHAPE

METHOD = "Finlayson 2015"
#: Residual unit of the cross-camera predictions (white = 1): about their spread with measured curves.
UNIT = 0.002


def scene_reflectances(data: Path) -> np.ndarray:
    """SFU 1995's 57 additional surfaces and 120 Dupont paint chips: in no test set of the benchmark."""
    R = spectra.resample(spectra.read_sfu1995(data / "reflectance_sfu1995" / "reflect_db.reflect"), W).T
    return np.clip(np.concatenate([R[0:38], R[62:201]]), 0, 1)


def regression(X: np.ndarray, Y: np.ndarray):
    """Degree-2 root-polynomial least squares X → Y (a tiny ridge)."""
    P = root_polynomial_terms(X, degree=2)
    G = P.T @ P
    M = np.linalg.solve(G + 1e-7 * np.trace(G) / len(G) * np.eye(len(G)), P.T @ Y)
    return lambda x: root_polynomial_terms(x, degree=2) @ M


def balanced(curves: np.ndarray, R: np.ndarray, E: np.ndarray) -> np.ndarray:
    """White-balanced responses (white → 1) of reflectances ``R`` under ``E``."""
    G = np.maximum(curves, 0) * E[:, None]
    return R @ (G / G.sum(axis=0, keepdims=True))


def cross_residuals(stacked: list[np.ndarray], observed: np.ndarray) -> np.ndarray:
    """Each camera's observed responses minus what a regression trained on ``stacked`` (simulated
    responses per camera) predicts from the other cameras' observed responses, in units of UNIT."""
    K, P = len(stacked), np.concatenate(stacked, axis=1)
    out = []
    for k in range(K):
        own = list(range(3 * k, 3 * k + 3))
        rest = [i for i in range(3 * K) if i not in own]
        out.append((regression(P[:, rest], P[:, own])(observed[:, rest]) - observed[:, own]).ravel())
    return np.concatenate(out) / UNIT


def linear_maps(stacked: list[np.ndarray], observed: np.ndarray) -> list[np.ndarray]:
    """Per camera a 3×3 (rows summing to 1; the first camera the identity) so that its mapped scene
    responses match the regression's prediction from the others' (three alternating passes)."""
    K = len(stacked)
    P, cur = np.concatenate(stacked, axis=1), observed.copy()
    maps = [np.eye(3) for _ in range(K)]
    one = np.ones(3)
    for _ in range(3):
        for k in range(1, K):
            own = list(range(3 * k, 3 * k + 3))
            rest = [i for i in range(3 * K) if i not in own]
            target = regression(P[:, rest], P[:, own])(cur[:, rest])
            X = observed[:, own]
            Ainv = np.linalg.inv(X.T @ X)
            Mt = Ainv @ X.T @ target
            Mt -= np.outer(Ainv @ one, (one @ Mt - one) / (one @ Ainv @ one))  # each map's rows sum to 1
            maps[k], cur[:, own] = Mt.T, X @ Mt
    return maps


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--data", type=Path, required=True)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--sets", type=int, default=8, help="random sets of each size (2 and 3 cameras)")
    ap.add_argument("--components", type=int, default=8, help="error components per channel")
    ap.add_argument("--prior", type=float, default=1.0, help="weight of the coefficients' Gaussian prior")
    ap.add_argument("--noise", type=float, default=0.0, help="σ of the scene responses (white = 1)")
    a = ap.parse_args(argv)
    cams = measured_cameras(a.data)
    names = list(cams)
    t0 = time.perf_counter()
    src = Source(cams, "dng", seed=a.seed)
    print(f"{len(names)} cameras estimated in {time.perf_counter() - t0:.0f} s", file=sys.stderr)
    tests = natural_test_sets(W, data_dir=a.data, size=150, seed=a.seed)
    scene = scene_reflectances(a.data)
    E = spectra.resample(spectra.illuminant("D65"), W)[:, 0]
    sets = random_sets(cams, a.sets, np.random.default_rng(a.seed))
    peak1 = {n: src.est[n].values / src.est[n].values.max(axis=0) for n in names}
    acc: dict = {}
    for cam_set in sets:
        K, models = len(cam_set), {cams[n]["model"] for n in cam_set}
        others = [n for n in names if cams[n]["model"] not in models]
        errors = np.stack([cams[n]["values"] / cams[n]["values"].max(axis=0) - peak1[n] for n in others])
        comps = []
        for c in range(3):  # principal components of the other models' curve errors, scaled to their spread
            _, S, Vt = np.linalg.svd(errors[:, :, c], full_matrices=False)
            comps.append(Vt[: a.components] * (S[: a.components, None] / np.sqrt(len(others))))
        est = [peak1[n] for n in cam_set]

        def curves_of(x, est=est, comps=comps, K=K):
            x = x.reshape(K, 3, a.components)
            return [np.stack([est[k][:, c] + x[k, c] @ comps[c] for c in range(3)], 1) for k in range(K)]

        truth = correction_problem([msds(cams[n]["values"], n) for n in cam_set], shape=SSF_SHAPE)
        pool = truth.training  # the training reflectances: what a user has
        observed = np.concatenate([balanced(cams[n]["values"], scene, E) for n in cam_set], axis=1)
        observed += a.noise * np.random.default_rng([a.seed, K]).standard_normal(observed.shape)
        t1 = time.perf_counter()

        def residuals(x, curves_of=curves_of, pool=pool, observed=observed):
            stacked = [balanced(c, pool, E) for c in curves_of(x)]
            return np.concatenate([cross_residuals(stacked, observed), np.sqrt(a.prior) * x])

        x0 = np.zeros(K * 3 * a.components)
        sol = least_squares(residuals, x0, diff_step=1e-4, max_nfev=60)

        def problem(curves):
            return correction_problem(
                [
                    colour.MultiSpectralDistributions(np.maximum(c, 0), W, labels=("R", "G", "B"))
                    for c in curves
                ],
                shape=SSF_SHAPE,
            )

        eprob, rprob = problem(est), problem(curves_of(sol.x))
        maps = linear_maps([balanced(c, pool, E) for c in est], observed)
        cal = np.concatenate([src.calibrated(n, models) for n in cam_set])
        told = noise_options(METHOD, NoiseModel(np.zeros(3 * K), np.square(cal), source="calibrated"))
        fits = {
            "measured": fit_correction(truth, method=METHOD),
            "estimated, noise-free": fit_correction(eprob, method=METHOD),
            "estimated, calibrated σ (shipped)": fit_correction(eprob, method=METHOD, **told),
            "linear maps, calibrated σ": fit_correction(eprob, method=METHOD, **told),
            "refined curves, noise-free": fit_correction(rprob, method=METHOD),
            "refined curves, calibrated σ": fit_correction(rprob, method=METHOD, **told),
        }
        # the bound of any per-camera 3×3: each camera's estimated training responses mapped onto its true
        # ones by least squares (truth no user has), then the noise-free regression on them
        Ce, Ct, Tt = eprob.source_of(pool), truth.source_of(pool), truth.target_of(pool)
        best = [
            np.linalg.lstsq(Ce[:, 3 * k : 3 * k + 3], Ct[:, 3 * k : 3 * k + 3], rcond=None)[0]
            for k in range(K)
        ]
        fits["same solver: estimated, noise-free"] = regression(Ce, Tt)
        fits["same solver: best 3×3 onto the truth, noise-free"] = regression(
            np.concatenate([Ce[:, 3 * k : 3 * k + 3] @ best[k] for k in range(K)], axis=1), Tt
        )
        rmse = [
            np.sqrt(np.mean(np.square(c / c.max(axis=0) - cams[n]["values"] / cams[n]["values"].max(axis=0))))
            for cur in (est, curves_of(sol.x))
            for c, n in zip(cur, cam_set, strict=True)
        ]
        acc.setdefault((K, "curve RMSE, estimated"), []).append(np.mean(rmse[:K]))
        acc.setdefault((K, "curve RMSE, refined"), []).append(np.mean(rmse[K:]))
        for ts in tests:
            C, T = truth.source_of(ts.reflectances), truth.target_of(ts.reflectances)
            for label, f in fits.items():
                x = C
                if label.startswith("linear"):
                    x = np.concatenate([C[:, 3 * k : 3 * k + 3] @ maps[k].T for k in range(K)], axis=1)
                acc.setdefault((K, label), []).append(float(np.mean(truth.delta_E(f(x), T))))
        print(
            f"{' + '.join(cam_set)}: {time.perf_counter() - t1:.0f} s, cross residual "
            f"{np.std(residuals(x0)[: -x0.size]) * UNIT:.4f} → {np.std(sol.fun[: -x0.size]) * UNIT:.4f}",
            file=sys.stderr,
        )
    labels = [k for s, k in acc if s == 2]
    print(
        f"\nseed {a.seed}, {a.sets} + {a.sets} sets, scene noise σ {a.noise:g}, {a.components} components, "
        f"prior {a.prior:g}; natural sets, mean ΔE00 (Δ to measured curves); curve RMSE of peak-1 curves\n"
    )
    print("| | " + " | ".join(f"{s} cameras" for s in (2, 3)) + " |\n|---|---:|---:|")
    for label in labels:
        cells = []
        for s in (2, 3):
            v = np.mean(acc[s, label])
            ref = np.mean(acc[s, "measured"])
            cells.append(f"{v:.4f}" if label.startswith("curve") else f"{v:.3f} ({v - ref:+.2f})")
        print(f"| {label} | " + " | ".join(cells) + " |")
    return 0


if __name__ == "__main__":
    sys.exit(main())
