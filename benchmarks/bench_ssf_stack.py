"""Why stacked cameras with estimated sensitivities lose accuracy, and what repairs it.

Leave one camera model out (as ``bench_ssf.py``): every held-out camera is estimated, with the basis
learned without its model, from ``--sources``: ``dng`` (DNG matrices synthesised from its measured
curves), ``chart`` (a simulated photograph of a ColorChecker under D65 with the errors of a real one:
:func:`chart_photo`, one chart and one light for every camera), ``both``, ``charts`` (the chart under
each of ``--chart-lights``) or ``both charts``. For random sets of 1–3
cameras, a correction is fitted on the estimated curves and applied to the responses of the measured
cameras (the honest setting), against the same correction fitted on the measured curves (the
baseline: the same estimator, told only the sensor noise). Diagnostics: SSF RMSE / angle per channel
and the RMS response error per source, the correlation between different cameras' response errors.
Fits compared, all in one process:

* ``none``: noise-free (the fit trusts the estimated curves exactly);
* ``calibrated RMS``: told ``SSFEstimate.response_sigma(rms=True)``, the held-out estimates' RMS
  response error (the bound times ``response_scale``, the scale calibrated on the other models'
  estimates only);
* ``calibrated``: told ``SSFEstimate.response_sigma()``, the default: the RMS σ times
  ``SSF_FIT_SIGMA_SCALE``;
* ``× s`` (``--scales``): told s × the RMS σ (the sweep that chose ``SSF_FIT_SIGMA_SCALE``);
* ``draws`` (``--draws``): a regression fitted on 16 camera sets drawn within the band (errors in
  the variables with the band's wavelength correlation);
* ``one camera``: the first camera of the set alone (do not stack);
* ``oracle σ``: told the set's true response error RMS (ground truth; no user has it);
* ``error draws``: fitted on draws of the responses' error (``zonotope.ssf_response_errors``,
  ``zonotope.correct.eiv.fit_errors_in_variables``): the held-out curve errors of the OTHER models'
  estimates, weighted by each estimate's misfit, carried to the set's responses (their correlation
  over wavelengths, channels and responses kept) — the full-covariance model of the curves' error.

    python benchmarks/bench_ssf_stack.py --data ../shared/data --sources dng,chart,both --seed 2
    python benchmarks/bench_ssf_stack.py --data ../shared/data --sources dng,both --seed 1 --sets 12 \
        --singles 2 --methods "Finlayson 2015" --scales 0.1,0.2,0.3,0.4,0.5,0.7   # the sweep
    python benchmarks/bench_ssf_stack.py --data ../shared/data --all-sets-basis   # basis with camspec
    python benchmarks/bench_ssf_stack.py --data ../shared/data --mmv-sets 3       # Centroid, Prior
    python benchmarks/bench_ssf_stack.py --data ../shared/data --shipped-check    # camspec, shipped basis
    python benchmarks/bench_ssf_stack.py --data ../shared/data --sources dng,both --sets 12 --singles 2 \
        --methods "Finlayson 2015" --rejected                                      # rejected fits
    python benchmarks/bench_ssf_stack.py --data ../shared/data --sources dng,chart --seed 2 --curves-only \
        --estimate-kw '{"subspace": 1}'                          # estimator weights, curve errors only
    python benchmarks/bench_ssf_stack.py --data ../shared/data --sources chart --ideal-chart --sets 12 \
        --singles 2 --methods "Finlayson 2015"                                    # a lab chart photo
    python benchmarks/bench_ssf_stack.py --data ../shared/data --sources chart,charts --seed 2 --curves-only \
        --chart-lights D65,A --response-lights A,FL11          # the chart under several lights
    python benchmarks/bench_ssf_stack.py --data ../shared/data --sources dng --sets 12 --singles 2 \
        --methods "Finlayson 2015" --draw-scales 0.3,0.5,0.7                      # the draws' scale
    python benchmarks/bench_ssf_stack.py --data ../shared/data --sources dng,chart,both --seed 2 \
        --singles 10 --methods "Finlayson 2015" --draws-and-sigma                 # the draws' table
    python benchmarks/bench_ssf_stack.py --data ../shared/data --write-errors \
        zonotope/spectra/data/ssf_basis.json        # store the held-out errors in the shipped basis
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import sys
import time
from pathlib import Path

import numpy as np

import zonotope
from zonotope._tol import SSF_ERROR_DRAW_SCALE
from zonotope.correct import NoiseModel, correction_problem, fit_correction, noise_options
from zonotope.correct.eiv import fit_errors_in_variables
from zonotope.evaluate import atypical_test_sets, natural_test_sets
from zonotope.spectra import builtin as spectra
from zonotope.spectra.estimate import (
    SSF_SHAPE,
    Chart,
    DNGMatrices,
    estimate_ssf,
    held_out_error_model,
    read_dng_matrices,
    ssf_basis,
    synthesise_dng_matrices,
)
from zonotope.ssf_band import ssf_response_errors

sys.path.insert(0, str(Path(__file__).parent))
from bench_ssf import basis_without, measured_cameras, msds

W = np.asarray(SSF_SHAPE.wavelengths)
METHODS = ("Cheung 2004", "Finlayson 2015")
FITS = ("measured", "none", "calibrated RMS", "calibrated", "error draws", "one camera", "oracle σ")
#: ``--rejected``: ridge toward the first camera's fit (weight × mean diagonal, on the calibrated σ);
#: the stacked cameras' chart photos added to the training set with weight w, on the estimated curves
#: (told the calibrated σ) and, the fair baseline, on the measured curves (told the sensor noise).
REJECTED = ("shrink 0.001", "shrink 0.1", "anchor 4", "anchor 16", "measured anchor 4", "measured anchor 16")


def training_responses(values: np.ndarray, name: str, illuminant: str = "D65") -> np.ndarray:
    """White-balanced responses (white → 1) to the 190 training reflectances under ``illuminant``."""
    pb = correction_problem(msds(values, name), shape=SSF_SHAPE, illuminant=illuminant)
    return pb.training @ pb.Phi


def chart_photo(
    values: np.ndarray,
    rng: np.random.Generator,
    noise_rng: np.random.Generator,
    *,
    illuminant: str = "D65",
    light_rng: np.random.Generator | None = None,
) -> np.ndarray:
    """Raw patch means of a photographed 24-patch ColorChecker, with the errors of a real photograph.

    The brightest channel at 0.8 of saturation; the physical chart's reflectances differ from the
    reference data by a smooth 2 % (per patch, 40 nm correlation: batch and ageing), the light from
    its nominal spectrum by a smooth 2 % (common to every patch), the light on each patch by 1 %
    (uneven lighting), all drawn from ``rng`` (one chart, one light: the same for every camera given
    the same ``rng`` state); each mean carries 5e-4 of noise from ``noise_rng`` (sensor noise averaged
    over the patch). ``light_rng`` (default ``rng``) draws the light's errors: the same chart under
    another light shares ``rng``'s reflectance errors and takes that light's from its own generator.
    """
    R = spectra.resample(zonotope.reflectances("ColorChecker N Ohta"), W).T
    E = spectra.resample(zonotope.illuminant(illuminant), W)[:, 0]
    d = W[:, None] - W[None, :]
    L = np.linalg.cholesky(np.exp(-0.5 * (d / 40.0) ** 2) + 1e-9 * np.eye(W.size))
    R = R * (1 + CHART_REFLECTANCE * (L @ rng.standard_normal((W.size, R.shape[0]))).T)
    light_rng = rng if light_rng is None else light_rng
    E = E * (1 + CHART_LIGHT * (L @ light_rng.standard_normal(W.size)))
    C = (R * E) @ values * (1 + CHART_UNEVEN * light_rng.standard_normal((R.shape[0], 1)))
    C = 0.8 * C / C.max()
    return C + CHART_NOISE * noise_rng.standard_normal(C.shape)


#: The simulated photograph's errors (relative; see chart_photo).
CHART_REFLECTANCE, CHART_LIGHT, CHART_UNEVEN, CHART_NOISE = 0.02, 0.02, 0.01, 5e-4
SOURCES = (
    "dng",
    "chart",
    "both",
    "charts",
    "both charts",
    "dng-d65",
    "libraw",
    "libraw-common",
    "dcp",
    "mean",
)
#: ``charts`` / ``both charts``: the chart photographed under each of these lights (the first as ``chart``).
CHART_LIGHTS = ("D65", "A")
#: ``--colordata``: measured-camera name → the real D65 ColorMatrix LibRaw carries for it (Adobe's).
LIBRAW: dict[str, np.ndarray] = {}
#: ``--colordata``: the same, times the transform common to the other models' matrices that takes
#: them closest to the ones synthesised from their measured curves (real_matrices.common_transform).
LIBRAW_COMMON: dict[str, np.ndarray] = {}
#: ``--dcp-dir``: measured-camera name → the DNG tags of RawTherapee's profile of the model.
DCP: dict[str, dict] = {}


def held_out_estimates(
    cams: dict[str, dict],
    source: str = "dng",
    *,
    seed: int = 0,
    redistributable_only: bool = True,
    photos: dict | None = None,
    pool: dict[str, dict] | None = None,
    **kw,
) -> dict:
    """Every camera's estimate from ``source`` with the basis learned without its model (from ``pool``,
    default ``cams``: the cameras estimated may be fewer than those the basis is learned from).

    ``source``: ``"dng"`` (synthesised DNG matrices), ``"chart"`` (a simulated photo, :func:`chart_photo`,
    under D65), ``"both"``, ``"dng-d65"`` (the synthesised D65 ColorMatrix alone: what LibRaw's table
    holds, from the measured curves), ``"libraw"`` (the real one, :data:`LIBRAW`) or ``"dcp"`` (the real
    A and D65 colour and forward matrices of RawTherapee's profile, :data:`DCP`) or ``"mean"`` (no
    data: the mean of the basis cameras, with the DNG estimate's band); ``kw`` goes to ``estimate_ssf``.
    """
    out = {}
    pool = cams if pool is None else pool
    for i, (n, c) in enumerate(cams.items()):
        basis = basis_without(pool, c["model"], redistributable_only=redistributable_only, k=5)
        if source.startswith("both"):  # beside a chart only its prior is read: the matrices' weight
            basis = dataclasses.replace(basis, real_dng=ssf_basis().real_dng)
        dng = synthesise_dng_matrices(msds(c["values"], n)) if source in ("dng", "both") else None
        if source == "dng-d65":
            dng = DNGMatrices(
                synthesise_dng_matrices(msds(c["values"], n), illuminants=("D65",)).color_matrices, ("D65",)
            )
        elif source == "libraw":
            dng = DNGMatrices((LIBRAW[n],), ("D65",), name=n)
        elif source == "libraw-common":
            dng = DNGMatrices((LIBRAW_COMMON[n],), ("D65",), name=n)
        elif source == "dcp":
            dng = read_dng_matrices(DCP[n])
        chart = None
        if source in ("chart", "both"):
            photo = chart_photo(c["values"], np.random.default_rng(seed), np.random.default_rng([seed, i]))
            chart = Chart(photo)
            if photos is not None:
                photos[n] = photo
        elif source.startswith(("charts", "both ")):  # one chart under each light of CHART_LIGHTS
            chart = [
                Chart(
                    chart_photo(
                        c["values"],
                        np.random.default_rng(seed),
                        np.random.default_rng([seed, i, j]),
                        illuminant=light,
                        light_rng=np.random.default_rng([seed, 1000 + j]) if j else None,
                    ),
                    illuminant=light,
                )
                for j, light in enumerate(CHART_LIGHTS)
            ]
            if source.startswith("both "):
                dng = synthesise_dng_matrices(msds(c["values"], n))
        if source == "mean":
            dng = synthesise_dng_matrices(msds(c["values"], n))
            mean = np.mean([pool[m]["values"] / pool[m]["values"].max(axis=0) for m in basis.sources], axis=0)
            e = estimate_ssf(dng, basis=basis, name=n, **kw)
            out[n] = dataclasses.replace(e, sensitivities=msds(mean / mean.max(), n), sources=("mean",))
            continue
        out[n] = estimate_ssf(dng, chart=chart, basis=basis, name=n, **kw)
    return out


def fit_on_draws(estimates, method: str, sigma: float, *, n: int = 16, seed: int = 0):
    """A regression fitted on the responses of ``n`` camera sets drawn within the estimates' bands."""
    from zonotope.correct.regressions import expected_normal_equations, root_polynomial_terms
    from zonotope.spectra.estimate import sample_ssfs

    degree = 1 if method == "Cheung 2004" else 2
    draws = [sample_ssfs(e, n, seed=seed + i) for i, e in enumerate(estimates)]
    G = B = 0.0
    k = 3 * len(estimates)
    noise = NoiseModel(np.zeros(k), np.full(k, sigma**2), source="sensor")
    for d in range(n):
        pb = correction_problem([dr[d] for dr in draws], shape=SSF_SHAPE)
        g, b = expected_normal_equations(
            pb.source_of(pb.training), pb.target_of(pb.training), noise, degree=degree
        )
        G, B = G + g, B + b
    M = np.linalg.solve(G + 1e-9 * np.trace(G) / G.shape[0] * np.eye(G.shape[0]), B)
    if degree == 1:
        return lambda c: c @ M
    return lambda c: root_polynomial_terms(c, degree=degree) @ M


def mmv_table(cams, est, err, bound, calibrated, a) -> int:
    """Centroid and Prior (MMV-based; told σ through their δ / noise) on estimated curves, noise-free
    ColorChecker and CIE 1995 TCS responses of the measured cameras: δ = 0 vs the calibrated σ."""
    import zonotope
    from zonotope.spectra import builtin as spectra

    names = list(cams)
    rng = np.random.default_rng(a.seed + 1)
    R = np.concatenate(
        [
            spectra.resample(zonotope.load_reflectances(n), W).T
            for n in ("ColorChecker N Ohta", "CIE 1995 TCS")
        ]
    )
    acc: dict = {}
    for size in (2, 3):
        k = 0
        while k < a.mmv_sets:
            pick = list(rng.choice(names, size, replace=False))
            models = {cams[n]["model"] for n in pick}
            if len(models) < size:
                continue
            k += 1
            truth = correction_problem([msds(cams[n]["values"], n) for n in pick], shape=SSF_SHAPE)
            eprob = correction_problem([est[n].sensitivities for n in pick], shape=SSF_SHAPE)
            cal = np.concatenate([calibrated(n, models) for n in pick])
            model = NoiseModel(np.zeros(3 * size), cal**2, source="calibrated")
            rms = np.concatenate([calibrated(n, models, rms=True) for n in pick])
            model_rms = NoiseModel(np.zeros(3 * size), rms**2, source="calibrated RMS")
            C, T = truth.source_of(R), truth.target_of(R)
            for m in ("Finlayson 2015", "Centroid", "Prior"):
                for fit_name, pb, opts in (
                    ("measured", truth, {}),
                    ("none (δ = 0)", eprob, {}),
                    ("calibrated RMS", eprob, noise_options(m, model_rms)),
                    ("calibrated", eprob, noise_options(m, model)),
                ):
                    t0 = time.perf_counter()
                    dE = truth.delta_E(fit_correction(pb, method=m, **opts)(C), T)
                    acc.setdefault((size, m, fit_name), []).append(float(np.mean(dE)))
                    print(
                        f"{size} {m} {fit_name}: {np.mean(dE):.3f} ({time.perf_counter() - t0:.0f} s)",
                        file=sys.stderr,
                        flush=True,
                    )
    print(
        f"\nMMV estimators, {a.mmv_sets} sets each, ColorChecker + CIE 1995 TCS, noise-free responses of the "
        "measured cameras (mean ΔE00):\n"
    )
    print("| cameras | method | measured | none (δ = 0) | calibrated RMS | calibrated |")
    print("|---|---|---|---|---|---|")
    for size in (2, 3):
        for m in ("Finlayson 2015", "Centroid", "Prior"):
            cols = ("measured", "none (δ = 0)", "calibrated RMS", "calibrated")
            row = [np.mean(acc[size, m, f]) for f in cols]
            print(
                f"| {size} | {m} | {row[0]:.3f} | "
                + " | ".join(f"{v:.3f} ({v - row[0]:+.2f})" for v in row[1:])
                + " |"
            )
    return 0


#: camspec models absent from the shipped basis (their curves never entered it nor its calibration).
CAMSPEC_HELD_OUT = (
    "Canon_20D", "Canon_40D", "Canon_50D", "Canon_60D", "Canon_500D", "Nikon_D3X",
    "Nikon_D50", "Nikon_D80", "Nikon_D90", "Pentax_K-5", "Sony_NEX-5N", "Olympus_E-PL2",
)  # fmt: skip


def shipped_check(data: Path) -> int:
    """The shipped basis as a user gets it, on camspec cameras it never saw: Finlayson 2015 told the
    default σ against the RMS σ (ColorChecker + CIE 1995 TCS, 10 three-camera sets; natural sets, 20
    two- or three-camera sets)."""
    folder = data / "ssf_jiang2013_camspec"
    measured = [zonotope.load_camera(next((folder / m).glob("*.csv"))) for m in CAMSPEC_HELD_OUT]
    est = [estimate_ssf(synthesise_dng_matrices(m)) for m in measured]
    chart = np.concatenate(
        [
            spectra.resample(zonotope.load_reflectances(n), W).T
            for n in ("ColorChecker N Ohta", "CIE 1995 TCS")
        ]
    )
    natural = [t.reflectances for t in natural_test_sets(W, data_dir=data, size=150, seed=0)]
    for label, tests, seed, sizes in (
        ("ColorChecker + TCS", [chart], 0, (3,)),
        ("natural", natural, 1, (2, 3)),
    ):
        rng = np.random.default_rng(seed)
        res = []
        for _ in range(10 if seed == 0 else 20):
            size = sizes[0] if len(sizes) == 1 else int(rng.integers(2, 4))
            pick = rng.choice(len(measured), size, replace=False)
            truth = correction_problem([measured[i] for i in pick], shape=SSF_SHAPE)
            fitted = correction_problem([est[i].sensitivities for i in pick], shape=SSF_SHAPE)
            row = []
            for rms in (False, True):
                sigma = np.concatenate([est[i].response_sigma(rms=rms) for i in pick])
                model = NoiseModel(np.zeros(sigma.size), sigma**2, source="SSF")
                fit = fit_correction(
                    fitted, method="Finlayson 2015", **noise_options("Finlayson 2015", model)
                )
                dE = [np.mean(truth.delta_E(fit(truth.source_of(R)), truth.target_of(R))) for R in tests]
                row.append(float(np.mean(dE)))
            res.append(row)
        res = np.array(res)
        print(
            f"shipped basis, camspec, {label}: default σ {res[:, 0].mean():.3f}, "
            f"RMS σ {res[:, 1].mean():.3f} ΔE00 (default better in "
            f"{100 * np.mean(res[:, 0] < res[:, 1]):.0f} % of {len(res)} sets)"
        )
    return 0


def write_errors(data: Path, path: Path) -> int:
    """Add the held-out error model of the redistributable cameras (leave one model out, DNG estimates,
    as the basis' band is calibrated) to the basis file ``path`` (``errors``, ``error_weight``)."""
    from bench_ssf import loo_errors

    from zonotope.spectra.estimate import SSFBasis

    cams = measured_cameras(data)
    held = loo_errors(cams, ssf_basis().n_components, redistributable_only=True)
    errors, weight = held_out_error_model(list(held.values()))
    doc = json.loads(path.read_text(encoding="utf-8"))
    doc["errors"], doc["error_weight"] = errors.tolist(), weight.tolist()
    doc = SSFBasis.from_json(doc).to_json()
    path.write_text(json.dumps(doc, indent=1) + "\n", encoding="utf-8")
    print(f"wrote {path}: {len(errors)} held-out errors, error_weight {np.round(weight, 3).tolist()}")
    return 0


def write_real_dng(data: Path, path: Path, colordata: Path, prior: float) -> int:
    """Add the calibration of estimates from real DNG matrices to the basis file ``path``: for every
    redistributable camera LibRaw has Adobe's matrix for, the estimate from that matrix (prior weight
    ``prior``) with the basis learned without its model, against its measured curves."""
    from bench_ssf import calibrate_band, held_out_spread
    from real_matrices import colour_matrix, read_colordata

    from zonotope.spectra.estimate import SSFBasis, SSFCalibration

    cams = measured_cameras(data)
    table = read_colordata(colordata)
    k = ssf_basis().n_components
    held = {}
    for n, c in cams.items():
        M = colour_matrix(table, n)
        if M is None or not c["redistributable"]:
            continue
        basis = basis_without(cams, c["model"], redistributable_only=True, k=k)
        held[n] = (estimate_ssf(DNGMatrices((M,), ("D65",), name=n), basis=basis, prior=prior), c["values"])
    spread = held_out_spread(held)
    band_k, scale = calibrate_band(held, spread)
    errors, weight = held_out_error_model(list(held.values()))
    doc = json.loads(path.read_text(encoding="utf-8"))
    top = float(np.ceil(max(e.residual for e, _ in held.values()) * 1e6) / 1e6)  # as stored: 6 decimals
    doc["real_dng"] = SSFCalibration(prior, spread, band_k, scale, errors, weight, len(held), top).to_json()
    doc = SSFBasis.from_json(doc).to_json()
    path.write_text(json.dumps(doc, indent=1) + "\n", encoding="utf-8")
    print(
        f"wrote {path}: real DNG calibration from {len(held)} cameras, prior {prior:g}, band_k {band_k:.3f}, "
        f"response_scale {np.round(scale, 3).tolist()}, max_residual {top:.4f}",
        file=sys.stderr,
    )
    return 0


def delta_cells(values, ref: float) -> str:
    """Markdown cells ``mean (Δ to ref)`` for mean ΔE00 ``values`` ("–" for NaN: a fit not made)."""
    return " | ".join(f"{v:.3f} ({v - ref:+.2f})" if v == v else "–" for v in values)


def _inputs(key, C: np.ndarray) -> np.ndarray:
    """The responses a fit takes: the first camera's alone for ``one camera``, else all."""
    return C[:, :3] if key[1:] == ("one camera",) else C


def score_fits(
    acc: dict, truth, tests, fits: dict, *, size: int, sigma: float, method: str, seed: int, inputs=None
):
    """Each fit's mean ΔE00 over every test set, appended to ``acc[size, test kind, sigma, method, key]``:
    applied to the true cameras' responses (``truth``) with noise ``sigma`` (seeded by ``seed`` and
    ``size``); ``inputs(key, C)`` picks the channels a fit takes (default all)."""
    for ts in tests:
        C = truth.source_of(ts.reflectances)
        if sigma:
            C = C + sigma * np.random.default_rng([seed, size]).standard_normal(C.shape)
        T = truth.target_of(ts.reflectances)
        for key, f in fits.items():
            dE = truth.delta_E(f(C if inputs is None else inputs(key, C)), T)
            acc.setdefault((size, ts.kind, sigma, method, key), []).append(float(np.mean(dE)))


def print_delta_table(acc: dict, methods, cols, ref: str, key=lambda col: col) -> None:
    """The Markdown table of mean ΔE00 per cameras, test, σ and method: ``ref``'s fit, then every column
    as :func:`delta_cells` against it; ``acc[cameras, test, σ, method, key(column)]`` holds the values."""
    print(f"| cameras | test | σ | method | {ref} | " + " | ".join(cols) + " |")
    print("|---" * (5 + len(cols)) + "|")
    for size in (1, 2, 3):
        for kind in ("natural", "atypical"):
            for sigma in (0.0, 0.005):
                for m in methods:
                    base = np.mean(acc[size, kind, sigma, m, ref])
                    row = [np.mean(acc.get((size, kind, sigma, m, key(f)), np.nan)) for f in cols]
                    print(f"| {size} | {kind} | {sigma:g} | {m} | {base:.3f} | {delta_cells(row, base)} |")


def random_sets(cams: dict[str, dict], n: int, rng: np.random.Generator) -> list[list[str]]:
    """``n`` random two-camera sets, then ``n`` three-camera sets, of the cameras ``cams``, each of
    distinct models (drawn in this order from ``rng``, so a seed gives the same sets everywhere)."""
    names, sets = list(cams), []
    for size in (2, 3):
        k = 0
        while k < n:
            pick = list(rng.choice(names, size, replace=False))
            if len({cams[m]["model"] for m in pick}) == size:
                sets.append(pick)
                k += 1
    return sets


def normal_equations_fit(pb, told, method: str, *, extra=(), toward=None, weight: float = 0.0):
    """The noise-aware regression of ``pb`` (told ``told`` per channel) solved from its normal
    equations, with ``extra`` (responses, targets, weight) rows added and a ridge of ``weight`` × the
    mean diagonal toward the coefficients ``toward``: what the rejected fits of the record need."""
    from zonotope.correct.regressions import expected_normal_equations, root_polynomial_terms

    degree = 1 if method == "Cheung 2004" else 2
    k = pb.source_of(pb.training).shape[1]
    noise = NoiseModel(np.zeros(k), np.square(np.broadcast_to(told, (k,))), source="told")
    G, B = expected_normal_equations(
        pb.source_of(pb.training), pb.target_of(pb.training), noise, degree=degree
    )
    for C, T, w in extra:
        g, b = expected_normal_equations(
            C, T, NoiseModel(np.zeros(k), np.zeros(k), source="0"), degree=degree
        )
        G, B = G + w * g, B + w * b
    s = np.trace(G) / G.shape[0]
    if toward is not None:
        G, B = G + weight * s * np.eye(G.shape[0]), B + weight * s * toward
    M = np.linalg.solve(G + 1e-9 * s * np.eye(G.shape[0]), B)
    return (lambda c: c @ M) if degree == 1 else (lambda c: root_polynomial_terms(c, degree=2) @ M)


def one_camera_embedded(pb_one, told, method: str, k: int) -> np.ndarray:
    """The first camera's coefficients (:func:`normal_equations_fit` on it alone) placed in the
    stacked regression's terms, zero for every term using another camera's channels."""
    from zonotope.correct.regressions import expected_normal_equations, root_polynomial_exponents

    degree = 1 if method == "Cheung 2004" else 2
    noise = NoiseModel(np.zeros(3), np.square(np.broadcast_to(told, (3,))), source="told")
    G, B = expected_normal_equations(
        pb_one.source_of(pb_one.training), pb_one.target_of(pb_one.training), noise, degree=degree
    )
    M1 = np.linalg.solve(G + 1e-9 * np.trace(G) / G.shape[0] * np.eye(G.shape[0]), B)
    if degree == 1:
        return np.vstack([M1, np.zeros((k - 3, M1.shape[1]))])
    P, P1 = root_polynomial_exponents(k, degree=2), root_polynomial_exponents(3, degree=2)
    out = np.zeros((P.shape[0], M1.shape[1]))
    for i, row in enumerate(P1):
        full = np.concatenate([row, np.zeros(k - 3, dtype=row.dtype)])
        out[np.flatnonzero((P == full).all(axis=1))[0]] = M1[i]
    return out


def chart_rows(pb, photos: list[np.ndarray]):
    """The stacked cameras' chart photos as training rows of ``pb``: each channel scaled to ``pb``'s
    predicted chart responses (white balance from the chart), with the chart's nominal targets."""
    Rc = spectra.resample(zonotope.reflectances("ColorChecker N Ohta"), W).T
    photo = np.concatenate(photos, axis=1)
    pred = pb.source_of(Rc)
    return photo * ((photo * pred).sum(0) / (photo * photo).sum(0)), pb.target_of(Rc)


class Source:
    """One source's held-out estimates and what the benchmark derives from them."""

    def __init__(
        self,
        cams: dict[str, dict],
        source: str,
        *,
        seed: int,
        redistributable_only: bool = True,
        pool: dict[str, dict] | None = None,
        **kw,
    ):
        self.cams, self.names = cams, list(cams)
        self.photos: dict[str, np.ndarray] = {}
        self.est = held_out_estimates(
            cams,
            source,
            seed=seed,
            redistributable_only=redistributable_only,
            photos=self.photos,
            pool=pool,
            **kw,
        )
        self.err = {
            n: training_responses(cams[n]["values"], n) - training_responses(self.est[n].values, n)
            for n in self.names
        }
        self.bound = {n: self.est[n].response_sigma(bound=True) for n in self.names}
        self._errors: dict = {}

    def calibrated(self, n: str, exclude: set[str], *, rms: bool = False) -> np.ndarray:
        """``response_sigma(rms=rms)`` with response_scale calibrated as the shipped basis' is
        (bench_ssf.calibrate_band), on the estimates of the OTHER models only."""
        others = [m for m in self.names if self.cams[m]["model"] not in exclude]
        real = np.sqrt(np.mean(np.square(np.concatenate([self.err[m] for m in others])), axis=0))
        scale = real / np.sqrt(np.mean(np.square([self.bound[m] for m in others]), axis=0))
        return dataclasses.replace(self.est[n], response_scale=scale).response_sigma(rms=rms)

    def with_errors(self, n: str, exclude: set[str]):
        """The estimate of ``n`` carrying the held-out error model (``held_out_error_model``) of the
        estimates of the OTHER models only, as the shipped basis carries that of its cameras."""
        key = frozenset(exclude)
        if key not in self._errors:
            others = [m for m in self.names if self.cams[m]["model"] not in exclude]
            self._errors[key] = held_out_error_model([(self.est[m], self.cams[m]["values"]) for m in others])
        errors, weight = self._errors[key]
        return dataclasses.replace(self.est[n], errors=errors, error_weight=weight)


def curve_table(cams: dict[str, dict], sources: dict[str, Source]) -> None:
    """SSF RMSE and angle per channel (peak-1 curves), mean over the held-out cameras, per source."""
    from bench_ssf import curve_errors

    print("\n| source | RMSE R / G / B | angle R / G / B (°) | response error RMS R / G / B |")
    print("|---|---|---|---|")
    for label, src in sources.items():
        ce = [curve_errors(src.est[n].values, cams[n]["values"]) for n in src.names]
        rm, an = np.mean([c[0] for c in ce], axis=0), np.mean([c[1] for c in ce], axis=0)
        rr = np.sqrt(np.mean(np.square(np.concatenate(list(src.err.values()))), axis=0))
        print(
            f"| {label} | {' / '.join(f'{v:.3f}' for v in rm)} | {' / '.join(f'{v:.1f}' for v in an)} "
            f"| {' / '.join(f'{v:.4f}' for v in rr)} |"
        )


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--data", type=Path)
    ap.add_argument("--sets", type=int, default=20, help="random sets of each size")
    ap.add_argument("--singles", type=int, default=40, help="one-camera sets (every k-th camera)")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument(
        "--sources",
        default="dng",
        help="comma-separated estimate sources: dng, chart, both (DNG + chart), dng-d65, libraw",
    )
    ap.add_argument(
        "--colordata",
        type=Path,
        help="LibRaw's src/tables/colordata.cpp: the libraw source and only cameras it has a matrix for",
    )
    ap.add_argument(
        "--dcp-dir",
        type=Path,
        help="RawTherapee's dcpprofiles folder: the dcp source and only cameras it has a profile for",
    )
    ap.add_argument("--all-sets-basis", action="store_true", help="basis also from camspec (not shippable)")
    ap.add_argument("--methods", default=",".join(METHODS))
    ap.add_argument("--mmv-sets", type=int, default=0, help="only the MMV estimators on N sets of 2 and 3")
    ap.add_argument("--draws", action="store_true", help="also fit on 16 cameras drawn in the band (slow)")
    ap.add_argument("--scales", default="", help="comma-separated multiples of the RMS σ to fit with too")
    ap.add_argument(
        "--draw-scales", default="", help="comma-separated scales of the error draws to fit with too"
    )
    ap.add_argument(
        "--draws-and-sigma", action="store_true", help="also the error draws plus the calibrated σ"
    )
    ap.add_argument("--write-errors", type=Path, help="store the held-out error model in this basis file")
    ap.add_argument(
        "--write-real-dng",
        type=Path,
        help="store the calibration of estimates from real DNG matrices (with --colordata) in this basis",
    )
    ap.add_argument(
        "--real-dng-prior", type=float, default=None, help="the prior weight --write-real-dng uses"
    )
    ap.add_argument(
        "--rejected",
        action="store_true",
        help="also the rejected fits: shrink to one camera, chart anchoring",
    )
    ap.add_argument("--estimate-kw", default="{}", help='estimate_ssf options as JSON, e.g. {"subspace": 1}')
    ap.add_argument("--ideal-chart", action="store_true", help="chart photos with only the patch noise")
    ap.add_argument(
        "--chart-lights",
        default="D65,A",
        help="the lights of the charts / both charts sources (comma-separated)",
    )
    ap.add_argument(
        "--response-lights", default="", help="also the response error under these lights (comma-separated)"
    )
    ap.add_argument("--curves-only", action="store_true", help="stop after the estimates' error table")
    ap.add_argument("--shipped-check", action="store_true", help="only the shipped basis on camspec cameras")
    a = ap.parse_args(argv)
    methods = tuple(a.methods.split(","))
    if a.shipped_check:
        return shipped_check(a.data)
    if a.write_errors:
        return write_errors(a.data, a.write_errors)
    if a.write_real_dng:
        if not (a.colordata and a.real_dng_prior is not None):
            ap.error("--write-real-dng needs --colordata and --real-dng-prior")
        return write_real_dng(a.data, a.write_real_dng, a.colordata, a.real_dng_prior)
    scales = [float(v) for v in a.scales.split(",") if v]
    draw_scales = [float(v) for v in a.draw_scales.split(",") if v]
    fit_names = (
        *FITS,
        *(f"× {v:g}" for v in scales),
        *(f"draws × {v:g}" for v in draw_scales),
        *(("draws",) if a.draws else ()),
        *(("error draws + σ",) if a.draws_and_sigma else ()),
    )
    if a.rejected:
        fit_names = (*fit_names, *REJECTED)
    if a.ideal_chart:  # a lab: the very chart's reflectances, the light measured, even light
        global CHART_REFLECTANCE, CHART_LIGHT, CHART_UNEVEN
        CHART_REFLECTANCE = CHART_LIGHT = CHART_UNEVEN = 0.0
    global CHART_LIGHTS
    CHART_LIGHTS = tuple(a.chart_lights.split(","))
    cams = pool = measured_cameras(a.data)
    if {"libraw", "libraw-common"} & set(a.sources.split(",")) and not a.colordata:
        ap.error("--sources libraw needs --colordata LibRaw/src/tables/colordata.cpp")
    if a.colordata:
        from real_matrices import colour_matrix, read_colordata

        table = read_colordata(a.colordata)
        LIBRAW.update({n: M for n in cams if (M := colour_matrix(table, n)) is not None})
        cams = {n: c for n, c in cams.items() if n in LIBRAW}
        if "libraw-common" in a.sources.split(","):
            from real_matrices import common_transform, synthesised_d65, times_transform

            syn = synthesised_d65(cams, cams)
            for n in cams:  # leave the model out, as the basis does
                rest = [m for m in cams if cams[m]["model"] != cams[n]["model"]]
                T = common_transform([LIBRAW[m] for m in rest], [syn[m] for m in rest])
                LIBRAW_COMMON[n] = times_transform(LIBRAW[n], T)
        print(f"{len(cams)} measured cameras with a LibRaw (Adobe) matrix", file=sys.stderr)
    if "dcp" in a.sources.split(",") and not a.dcp_dir:
        ap.error("--sources dcp needs --dcp-dir /usr/share/rawtherapee/dcpprofiles")
    if a.dcp_dir:
        from real_matrices import dcp_matrices

        DCP.update(dcp_matrices(a.dcp_dir, cams))
        cams = {n: c for n, c in cams.items() if n in DCP}
        print(f"{len(cams)} measured cameras with a RawTherapee profile", file=sys.stderr)
    names = list(cams)
    t0 = time.perf_counter()
    sources = {}
    for s in a.sources.split(","):
        if s not in SOURCES:
            ap.error(f"--sources {s!r}: choose from {', '.join(SOURCES)}")
        kw = json.loads(a.estimate_kw)
        sources[s] = Source(cams, s, seed=a.seed, redistributable_only=not a.all_sets_basis, pool=pool, **kw)
    print(f"{len(names)} cameras estimated in {time.perf_counter() - t0:.0f} s", file=sys.stderr)
    curve_table(cams, sources)
    for light in [v for v in a.response_lights.split(",") if v]:
        print(f"\nresponse error RMS R / G / B under {light}:")
        for label, src in sources.items():
            e = np.concatenate(
                [
                    training_responses(cams[n]["values"], n, light)
                    - training_responses(src.est[n].values, n, light)
                    for n in src.names
                ]
            )
            print(f"| {label} | {' / '.join(f'{v:.4f}' for v in np.sqrt(np.mean(np.square(e), axis=0)))} |")
    if a.curves_only:
        return 0

    shipped = ssf_basis()
    for label, src in sources.items():
        for k, klabel in ((2.0, "±2σ"), (shipped.band_k, f"±band_k = ±{shipped.band_k:.2f}σ")):
            cover: dict[str, list] = {}
            for n in names:
                e, t = src.est[n].values, cams[n]["values"]
                inside = np.abs(e / e.max(axis=0) - t / t.max(axis=0)) <= k * shipped.spread
                cover.setdefault(cams[n]["set"], []).append(inside.mean())
                cover.setdefault("all", []).append(inside.mean())
            print(
                f"{label}: measured curve within {klabel} of the estimate (fraction of wavelengths × "
                "channels): " + ", ".join(f"{d} {100 * np.mean(v):.0f} %" for d, v in cover.items())
            )
        ratio = np.array([np.sqrt(np.mean(np.square(src.err[n]), axis=0)) / src.bound[n] for n in names])
        print(
            f"{label}: real response error RMS / fully correlated bound, median over cameras (R, G, B): "
            + " / ".join(f"{v:.2f}" for v in np.median(ratio, axis=0))
        )

    if a.mmv_sets:
        src = next(iter(sources.values()))
        return mmv_table(cams, src.est, src.err, src.bound, src.calibrated, a)
    step = max(1, len(names) // a.singles)
    sets = [[n] for n in names[::step]] + random_sets(cams, a.sets, np.random.default_rng(a.seed))
    tests = natural_test_sets(W, data_dir=a.data, size=150, seed=a.seed) + atypical_test_sets(
        W, 100, seed=a.seed
    )
    acc: dict = {}
    diag: dict = {}
    t0 = time.perf_counter()
    for cam_set in sets:
        size = len(cam_set)
        truth = correction_problem([msds(cams[n]["values"], n) for n in cam_set], shape=SSF_SHAPE)
        models = {cams[m]["model"] for m in cam_set}
        for sigma in (0.0, 0.005):
            for m in methods:
                fits = {}
                for label, src in sources.items():
                    est = src.est
                    eprob = correction_problem([est[n].sensitivities for n in cam_set], shape=SSF_SHAPE)
                    one = correction_problem([est[cam_set[0]].sensitivities], shape=SSF_SHAPE)
                    told_by = {
                        "band": np.concatenate([src.bound[n] for n in cam_set]),
                        "calibrated": np.concatenate([src.calibrated(n, models) for n in cam_set]),
                        "calibrated RMS": np.concatenate(
                            [src.calibrated(n, models, rms=True) for n in cam_set]
                        ),
                        "oracle σ": np.sqrt(
                            np.mean(np.square(np.concatenate([src.err[n] for n in cam_set], axis=1)), axis=0)
                        ),
                    }
                    for v in scales:
                        told_by[f"× {v:g}"] = v * told_by["calibrated RMS"]
                    if sigma == 0 and m == methods[0] and size > 1:
                        e = [src.err[n] for n in cam_set]
                        r = [
                            np.corrcoef(e[i][:, c], e[j][:, c])[0, 1]
                            for i in range(size)
                            for j in range(i + 1, size)
                            for c in range(3)
                        ]
                        diag.setdefault((label, size, "error correlation between cameras"), []).append(
                            np.mean(r)
                        )
                    for fit_name in fit_names:
                        if fit_name == "measured" and label != next(iter(sources)):
                            continue
                        key = "measured" if fit_name == "measured" else (label, fit_name)
                        if fit_name == "draws":
                            fits[key] = fit_on_draws([est[n] for n in cam_set], m, sigma, seed=a.seed)
                            continue
                        if fit_name.startswith(("error draws", "draws × ")):
                            scale = float(fit_name.split()[-1]) if "×" in fit_name else SSF_ERROR_DRAW_SCALE
                            ests = [src.with_errors(n, models) for n in cam_set]
                            draws = ssf_response_errors(ests, eprob, seed=a.seed, scale=scale)
                            told = sigma
                            if fit_name == "error draws + σ":  # and the calibrated σ per channel
                                told = np.sqrt(sigma**2 + np.square(told_by["calibrated"]))
                            fits[key] = fit_errors_in_variables(
                                eprob, draws, method=m, noise=told if np.any(told) else None
                            )
                            continue
                        if fit_name in REJECTED:
                            if size == 1 or (fit_name.startswith(("anchor", "measured")) and not src.photos):
                                continue
                            w = float(fit_name.split()[-1])
                            cal = np.sqrt(sigma**2 + np.square(told_by["calibrated"]))
                            if fit_name.startswith("shrink"):
                                M1 = one_camera_embedded(one, cal[:3], m, 3 * size)
                                fits[key] = normal_equations_fit(eprob, cal, m, toward=M1, weight=w)
                                continue
                            pb = truth if fit_name.startswith("measured") else eprob
                            told = sigma if fit_name.startswith("measured") else cal
                            Cc, Tc = chart_rows(pb, [src.photos[n] for n in cam_set])
                            fits[key] = normal_equations_fit(pb, told, m, extra=[(Cc, Tc, w)])
                            continue
                        told = np.sqrt(sigma**2 + np.square(told_by.get(fit_name, 0.0)))
                        pb = {"measured": truth, "one camera": one}.get(fit_name, eprob)
                        if fit_name == "one camera":
                            told = told[:3] if np.ndim(told) else told
                        model = NoiseModel(np.zeros(np.size(told)), np.square(told), source=fit_name)
                        opts = noise_options(m, model) if np.any(told > 0) else {}
                        fits[key] = fit_correction(pb, method=m, **opts)
                first = lambda key, C: C[:, :3] if key[1:] == ("one camera",) else C  # noqa: E731
                score_fits(
                    acc, truth, tests, fits, size=size, sigma=sigma, method=m, seed=a.seed, inputs=first
                )
    print(f"corrections in {time.perf_counter() - t0:.0f} s", file=sys.stderr)
    for key, v in diag.items():
        print(
            f"{key[0]}, {key[1]} cameras, {key[2]}: median {np.median(v):.2f} [{np.percentile(v, 10):.2f}, "
            f"{np.percentile(v, 90):.2f}]"
        )
    cols = [f for f in fit_names if f != "measured"]
    for label in sources:
        print(f"\nSource: {label} (mean ΔE00; in brackets Δ to the measured-curve fit)\n")
        print_delta_table(acc, methods, cols, "measured", key=lambda f, label=label: (label, f))
    return 0


if __name__ == "__main__":
    sys.exit(main())
