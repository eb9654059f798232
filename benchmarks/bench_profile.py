"""Camera profiles benchmark: our DCP vs the DNG ColorMatrix, in our pipeline and in RawTherapee.

Run: ``.venv/bin/python benchmarks/bench_profile.py [--quick] [--camera NAME ...] [--tables PQRSTU]``.
Prints up to six tables (timings only in T); ``--quick`` fits the DCPs on 300 instead of 1,500 random
spectra and samples table T's LUT at 17³ instead of 33³.
The DCPs are fitted without the ColorChecker sets (``isp.profiles.fitting.profile_reflectances``), so the
chart every table evaluates on is held out.
Needs ``rawtherapee-cli`` for the RawTherapee columns (skipped otherwise) and ../shared/data for
table Q (skipped otherwise).

Tables
------
P. Simulated ColorChecker (ColorChecker N Ohta reflectances × camera SSF × D65 → mosaic with shot and
   read noise → DNG, 64-px patches), developed to XYZ D50 and compared with the true XYZ (Bradford
   D65 → D50), ΔE00 mean / max over the 24 patches, exposure normalised on the white patch.
   The DNG's ColorMatrix is what a camera maker would ship: least squares on the rawtoaces 190
   training set, white exact (``isp.simulate.fit_color_matrix``). Columns: that matrix in
   ``isp develop`` and in ``rawtherapee-cli`` ("(camera)" input profile); our DCP
   (``isp profile``: Prior, A + D65, HueSatMap 90 × 30 + LookTable 36 × 12 × 8, rings up to
   saturation 0.35 bias-free) in ``isp develop --profile`` and in
   ``rawtherapee-cli``; ``isp develop --correction metamer`` (Prior, D65, scene white = exposure).
Q. Real Canon EOS 550D DNG with RawTherapee's shipped ``Canon EOS 550D.dcp``: per ColorChecker
   patch (40 × 40 boxes, centres of bench_isp.py) ΔE00 between ``rawtherapee-cli`` and
   ``isp develop --profile`` (both XYZ D50, same white scale), and the same for the DNG's own
   ColorMatrix: an independent check of our DCP reader.
R. Encoding accuracy: ΔE00 between an estimator (root-polynomial, Nikon 5100, D65, CIE 1931) and its
   DCP (per HueSatMap size, without and with the LookTable) or 3-D LUT (per lattice size, log2
   shaper, 16× headroom) encoding, on
   natural sets (ColorChecker, CIE 1995 TCS, NIST CQS) and 200 atypical spectra
   (``zonotope.spectra.atypical``), responses at the white's exposure.
S. Why the profile is fitted as it is (noise-free spectra, D65, ColorChecker N Ohta held out): ΔE00
   vs truth of the DNG matrix, the Prior estimator, last round's recipe (ForwardMatrix and 2.5-D
   HueSatMap fitted on all colours, random smooth spectra 87 % of them; with and without the
   ColorChecker in the fit), matrices + HueSatMap on natural colours only, and that + the 3-D
   LookTable (what ``fit_dcp`` ships); and each profile's encoding error on the random spectra.
T. ``isp profile --lut`` sampling of the Prior estimator (Nikon 5100, D65), in one process: the former
   per-node solvers (HiGHS distance to the source solid, scipy's per-row BVLS) on every lattice node
   (the baseline, ``quantum=0``) and with the default grouping, and the current solvers both ways:
   CPU seconds (median of ``--repeats``), peak traced memory (first run), solver groups, and ΔE00
   (mean / max) against the baseline's LUT on natural sets and 100 atypical spectra.
U. Chart fit on the real 550D DNG (needs ../shared/data): per shoot illuminant, mean / max ΔE00 of
   colour-science's least squares (``matrix_colour_correction``, Cheung 2004, 3 terms, white free),
   our white-preserving least squares, and that refined for ΔE00 (what ``isp profile --chart`` writes).
"""

from __future__ import annotations

import argparse
import contextlib
import os
import sys
import tempfile
from pathlib import Path

import colour
import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

import isp  # noqa: E402
import zonotope  # noqa: E402
from isp.profiles.dcp import DCPProfile, dcp_stage, read_dcp, write_dcp  # noqa: E402
from isp.profiles.fitting import fit_dcp  # noqa: E402
from isp.profiles.rawtherapee import develop_rawtherapee, patch_delta_E, rawtherapee_cli  # noqa: E402
from isp.simulate import chart_image, simulate_capture, simulate_dng, spectral_setup  # noqa: E402

DATA = Path(os.environ.get("ZONOTOPE_SHARED_DATA", ROOT.parent / "shared" / "data"))
D50_xy = colour.CCS_ILLUMINANTS["CIE 1931 2 Degree Standard Observer"]["D50"]
D50 = colour.xy_to_XYZ(D50_xy)
CHART_ROWS = (624, 724, 822, 930)  # patch centres in the 550D file (from bench_isp.py)
CHART_COLS = (712, 820, 928, 1035, 1142, 1250)
BOX = 20
GRID = np.arange(400.0, 701.0, 10.0)


def _table(title: str, header: list[str], rows: list[list]) -> None:
    print(f"\n{title}")
    widths = [max(len(str(h)), *(len(str(r[i])) for r in rows)) + 2 for i, h in enumerate(header)]
    print("".join(str(h).rjust(w) for h, w in zip(header, widths)))
    for r in rows:
        print("".join(str(v).rjust(w) for v, w in zip(r, widths)))


def simulated_chart(camera: str, folder: Path, *, exposure: float = 0.8, seed: int = 0):
    """A simulated ColorChecker DNG and its truth: (path, labels, true XYZ D50 per patch)."""
    setup = spectral_setup(camera, illuminant="D65")
    cc = np.clip(zonotope.resample(zonotope.reflectances("ColorChecker N Ohta"), setup.wavelengths).T, 0, 1)
    train = np.clip(zonotope.resample(zonotope.reflectances("rawtoaces 190"), setup.wavelengths).T, 0, 1)
    img, labels = chart_image(cc, rows=4, cols=6, patch=64, gap=16)
    cap = simulate_capture(img, setup, training=train, exposure=exposure, seed=seed)
    path = simulate_dng(folder / f"{camera.split()[0]}_chart.dng", cap, model=camera, overwrite=True)
    truth = cc @ setup.observer  # D65, Y_white = 1
    w = setup.observer.sum(0)
    cat = colour.adaptation.matrix_chromatic_adaptation_VonKries(w, D50, transform="Bradford")
    return path, labels, truth @ cat.T


def isp_XYZ(path, *, correction="dng", profile=None) -> np.ndarray:
    p = isp.default_pipeline(tonemap=None, encode=False, correction=correction)
    if profile is not None:
        p = p.replace("camera_to_XYZ", dcp_stage(profile))
    return isp.develop(path, pipeline=p, stop_after="camera_to_XYZ").image


_FITS: dict = {}


def _fit(cam: str, quick: bool):
    """fit_dcp (Prior, the defaults) once per camera for tables P and S."""
    if (cam, quick) not in _FITS:
        _FITS[cam, quick] = fit_dcp(cam, method="Prior", n_random=300 if quick else 1500)
    return _FITS[cam, quick]


def table_P(cameras, quick: bool) -> None:
    rows = []
    have_rt = rawtherapee_cli() is not None
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp)
        for cam in cameras:
            path, labels, truth = simulated_chart(cam, folder)
            fit = _fit(cam, quick)
            dcp = write_dcp(folder / "camera.dcp", fit.profile, overwrite=True)

            def score(XYZ, offset=(0, 0), labels=labels, truth=truth):
                lab = labels[offset[0] : offset[0] + XYZ.shape[0], offset[1] : offset[1] + XYZ.shape[1]]
                return patch_delta_E(XYZ, lab, truth, white_XYZ=D50, normalise_to=18)

            res = {"isp DNG": score(isp_XYZ(path)), "isp DCP": score(isp_XYZ(path, profile=dcp))}
            mc = isp.metamer_correction(cam, method="Prior", illuminant="D65", white_level=0.8)
            res["isp metamer"] = score(isp_XYZ(path, correction=mc))
            if have_rt:
                for key, prof in (("RT DNG", None), ("RT DCP", dcp)):
                    out = develop_rawtherapee(path, profile=prof)
                    res[key] = score(out.XYZ, out.offset)
            m = {k: v.mean() for k, v in res.items()}
            row = [cam] + [
                f"{res[k].mean():.3f} / {res[k].max():.2f}" if k in res else "—"
                for k in ("isp DNG", "RT DNG", "isp DCP", "RT DCP", "isp metamer")
            ]
            row += [
                f"{100 * (1 - m['isp DCP'] / m['isp DNG']):.0f} %",
                f"{100 * (1 - m['RT DCP'] / m['RT DNG']):.0f} %" if have_rt else "—",
                f"{m['isp DCP'] - m['isp metamer']:+.3f}",
            ]
            rows.append(row)
    _table(
        "P. Simulated ColorChecker under D65, ΔE00 mean / max vs truth (24 patches)",
        [
            "camera",
            "isp DNG CM",
            "RT DNG CM",
            "isp DCP",
            "RT DCP",
            "isp metamer",
            "DCP gain isp",
            "DCP gain RT",
            "DCP − metamer",
        ],
        rows,
    )


def table_Q() -> None:
    path = DATA / "raw_samples" / "tinydng_colorchart_Canon_EOS_Kiss_X4_MagicLantern.dng"
    dcp = Path("/usr/share/rawtherapee/dcpprofiles/Canon EOS 550D.dcp")
    if not path.is_file() or rawtherapee_cli() is None or not dcp.is_file():
        print("\nQ. skipped: needs the 550D DNG in ../shared/data and RawTherapee with its DCPs")
        return

    def boxes(X, off):
        return np.array(
            [
                X[r - off[0] - BOX : r - off[0] + BOX, c - off[1] - BOX : c - off[1] + BOX]
                .reshape(-1, 3)
                .mean(0)
                for r in CHART_ROWS
                for c in CHART_COLS
            ]
        )

    def lab(X):
        return colour.XYZ_to_Lab(X, D50_xy)

    out = {}
    for key, prof in (("DCP", dcp), ("DNG", None)):
        rt = develop_rawtherapee(path, profile=prof)
        ours = isp_XYZ(path, profile=prof if prof is None else read_dcp(prof))
        a, b = boxes(rt.XYZ, rt.offset), boxes(ours, (0, 0))
        k = 1.0 / a[18, 1]
        out[key] = (colour.delta_E(lab(k * a), lab(k * b), method="CIE 2000"), a * k, b * k)
    rows = [
        [
            i + 1,
            f"{out['DCP'][0][i]:.3f}",
            f"{out['DNG'][0][i]:.3f}",
            " ".join(f"{v:.4f}" for v in out["DCP"][1][i]),
            " ".join(f"{v:.4f}" for v in out["DCP"][2][i]),
        ]
        for i in range(24)
    ]
    rows.append(["mean", f"{out['DCP'][0].mean():.3f}", f"{out['DNG'][0].mean():.3f}", "", ""])
    rows.append(["max", f"{out['DCP'][0].max():.3f}", f"{out['DNG'][0].max():.3f}", "", ""])
    _table(
        "Q. Real 550D DNG: ΔE00 between rawtherapee-cli and isp develop, per ColorChecker patch "
        "(RawTherapee's 'Canon EOS 550D.dcp', and the DNG ColorMatrix)",
        ["patch", "ΔE00 DCP", "ΔE00 DNG CM", "XYZ RT (DCP)", "XYZ isp (DCP)"],
        rows,
    )


def table_R(quick: bool) -> None:
    from zonotope.correct.profile import correction_LUT
    from zonotope.spectra.atypical import atypical_reflectances

    cam = "Nikon 5100 (NPL)"
    mcs = [
        isp.metamer_correction(cam, method="Finlayson 2015", illuminant=i, quantum=0.0, target="CIE 1931 2°")
        for i in ("A", "D65")
    ]
    mc = mcs[1]
    prob = mc.corrector.problem
    w = prob.wavelengths
    sets = {
        name: np.clip(zonotope.resample(zonotope.reflectances(name), w).T, 0, 1)
        for name in ("ColorChecker N Ohta", "CIE 1995 TCS", "NIST CQS 9.0")
    }
    sets["atypical (200)"] = atypical_reflectances(w, 200)[0]
    white = mc(np.ones((1, 3)))[0]
    cat = colour.adaptation.matrix_chromatic_adaptation_VonKries(white / white[1], D50, transform="Bradford")

    def lab(X):
        return colour.XYZ_to_Lab(X, D50_xy)

    rows = []
    encoders = [("matrices only", dict(dims=None, look_table_dims=None))]
    encoders += [
        (f"HueSatMap {h}×{s}", dict(dims=(h, s, 1), look_table_dims=None))
        for h, s in ((6, 6), (36, 12), (90, 30), (180, 60))
    ]
    encoders += [("HueSatMap 90×30 + LookTable 36×12×8 (default)", {})]
    for label, kw in encoders:
        prof: DCPProfile = fit_dcp(cam, corrections=mcs, n_random=300 if quick else 1500, **kw).profile
        row = [label]
        for R in sets.values():
            c = R @ prob.Phi
            ref = (mc(c) / white[1]) @ cat.T
            dE = colour.delta_E(lab(prof.apply(c, mc.neutral)), lab(ref), method="CIE 2000")
            row.append(f"{dE.mean():.3f}")
        rows.append(row)
    for size in (17, 33, 65):
        lut = correction_LUT(mc, size=size, space="XYZ")
        row = [f"LUT {size}³ (log2)"]
        for R in sets.values():
            c = R @ prob.Phi
            ref = mc(c) / white[1]
            dE = colour.delta_E(lab(lut.apply(c) @ cat.T), lab(ref @ cat.T), method="CIE 2000")
            row.append(f"{dE.mean():.3f}")
        rows.append(row)
    _table(
        "R. Encoding error: mean ΔE00 between root-polynomial (Nikon 5100, D65) and its DCP / LUT",
        ["encoding", *sets],
        rows,
    )


def table_S(cameras, quick: bool) -> None:
    """Why the profile is fitted as it is: noise-free spectral ablation on the held-out ColorChecker."""
    from isp.profiles.dcp import PROPHOTO_FROM_XYZ
    from isp.profiles.fitting import _fit_white_preserving, fit_hue_sat_map

    def lab(X):
        return colour.XYZ_to_Lab(X, D50_xy)

    def dE(a, b):
        return colour.delta_E(lab(a), lab(b), method="CIE 2000")

    rows = []
    for cam in cameras:
        fit = _fit(cam, quick)
        mc, prof = fit.corrections[1], fit.profile  # D65: the CCT weight is all on table 2
        prob = mc.corrector.problem
        Phi, XYZ_of = prob.Phi, prob.Psi @ prob.XYZ_from_target
        xw = XYZ_of.sum(0)
        to_D50 = colour.adaptation.matrix_chromatic_adaptation_VonKries(xw, D50, transform="Bradford")
        cc = np.clip(
            zonotope.resample(zonotope.reflectances("ColorChecker N Ohta"), prob.wavelengths).T, 0, 1
        )
        c_cc, truth = cc @ Phi, (cc @ XYZ_of / xw[1]) @ to_D50.T
        CM = _fit_white_preserving(prob.training @ XYZ_of, prob.training @ Phi, xw, np.ones(3))
        dng = (c_cc @ np.linalg.inv(CM).T / xw[1]) @ to_D50.T
        white = np.asarray(mc(np.ones((1, 3))))[0]
        cat = colour.adaptation.matrix_chromatic_adaptation_VonKries(
            white / white[1], D50, transform="Bradford"
        )
        est_cc = (np.asarray(mc(c_cc)) / white[1]) @ cat.T
        c_all, T_all, rnd = fit.reflectances @ Phi, fit.targets[1], ~fit.natural

        def old_recipe(c_fit, T_fit, prof=prof):  # last round: one 2.5-D fit over all colours, equal weights
            F = _fit_white_preserving(c_fit, T_fit, np.ones(3), D50)
            hsm = fit_hue_sat_map((c_fit @ F.T) @ PROPHOTO_FROM_XYZ.T, T_fit @ PROPHOTO_FROM_XYZ.T)
            return prof.with_options(forward_matrix_2=F, hue_sat_map_2=hsm, look_table=None)

        variants = {
            "old recipe, CC in fit": old_recipe(np.vstack([c_all, c_cc]), np.vstack([T_all, est_cc])),
            "old recipe, CC held out": old_recipe(c_all, T_all),
            "natural FM + HSM": prof.with_options(look_table=None),
            "+ LookTable (ours)": prof,
        }
        e_dng, e_est = dE(dng, truth).mean(), dE(est_cc, truth).mean()
        row = [cam, f"{e_dng:.3f}", f"{e_est:.3f}"]
        atyp = []
        for p in variants.values():
            row.append(f"{dE(p.apply(c_cc, mc.neutral), truth).mean():.3f}")
            atyp.append(f"{dE(p.apply(c_all[rnd], mc.neutral), T_all[rnd]).mean():.3f}")
        e_ours = dE(prof.apply(c_cc, mc.neutral), truth).mean()
        row += [f"{100 * (1 - e_ours / e_dng):.0f} %", *atyp[1:]]
        rows.append(row)
    _table(
        "S. Noise-free ColorChecker (held out), D65, mean ΔE00 vs truth; last three columns: mean ΔE00 "
        "between each profile and the estimator on the random smooth spectra",
        [
            "camera",
            "DNG CM",
            "Prior",
            "old, CC in fit",
            "old, CC out",
            "natural FM+HSM",
            "+ LookTable",
            "gain vs DNG",
            "atyp: old",
            "atyp: FM+HSM",
            "atyp: +LT",
        ],
        rows,
    )


@contextlib.contextmanager
def _solvers(former: bool):
    """The per-node solvers of the LUT as they were (HiGHS distance of a node outside the source solid,
    scipy's per-row BVLS for the exact-constraint MAP) or as they are (the exact distance from the
    solid's facets, the batched ``fiber_box_lsq``): the reference twins' switches."""
    import zonotope.correct.prior as prior
    import zonotope.mismatch.volume as volume

    saved = volume._EXACT_DISTANCE, prior._STIFF_SOLVER
    volume._EXACT_DISTANCE = prior._STIFF_SOLVER = not former
    try:
        yield
    finally:
        volume._EXACT_DISTANCE, prior._STIFF_SOLVER = saved


def table_T(quick: bool, exact: bool = True, repeats: int = 5, memory: bool = True) -> None:
    """Table T: CPU seconds (median of ``repeats``) and peak traced memory of ``profile_LUT`` with the
    former and the current per-node solvers, every node solved and grouped as by default, all in one
    process; ΔE00 against the first row (the former solvers on every node; with ``exact=False`` the
    former solvers' default grouping). ``memory=False``: no traced run (peak memory "nan")."""
    import time
    import tracemalloc

    from isp._tol import LUT_OUTSIDE_QUANTUM, LUT_QUANTUM
    from isp.profiles.lut import profile_LUT
    from zonotope.correct.profile import apply_correction_LUT
    from zonotope.spectra.atypical import atypical_reflectances

    size = 17 if quick else 33
    mc = isp.metamer_correction(
        "Nikon 5100 (NPL)", method="Prior", illuminant="D65", quantum=0.0, target="CIE 1931 2°"
    )
    prob = mc.corrector.problem
    sets = {
        n: np.clip(zonotope.resample(zonotope.reflectances(n), prob.wavelengths).T, 0, 1)
        for n in ("ColorChecker N Ohta", "CIE 1995 TCS", "NIST CQS 9.0")
    }
    sets["atypical (100)"] = atypical_reflectances(prob.wavelengths, 100)[0]
    D65 = colour.CCS_ILLUMINANTS["CIE 1931 2 Degree Standard Observer"]["D65"]
    default = (LUT_QUANTUM, LUT_OUTSIDE_QUANTUM)
    settings = [(True, default), (False, (0.0, None)), (False, default)]
    if exact:
        settings.insert(0, (True, (0.0, None)))
    luts, rows = [], []
    for former, (q, q_out) in settings:
        solves, times = [], []
        with _solvers(former):

            def sample(solves=solves, q=q, q_out=q_out):
                return profile_LUT(
                    mc,
                    size=size,
                    space="XYZ",
                    quantum=q,
                    outside_quantum=q_out,
                    progress=lambda s, d, n: solves.append(n),
                )

            peak = float("nan")
            if memory:  # a first, untimed run: peak memory (traced allocations, numpy's included)
                tracemalloc.start()
                lut = sample()
                peak = tracemalloc.get_traced_memory()[1] / 2**20
                tracemalloc.stop()
            for _ in range(repeats):
                t = time.process_time()
                lut = sample()
                times.append(time.process_time() - t)
        luts.append(lut)
        name = ("former" if former else "current") + " solvers, "
        name += "every node" if q == 0 else f"grouped {q:g} / {q_out:g}"
        dt = float(np.median(times))
        row = [
            name,
            dt,
            f"{dt:.1f} ({min(times):.1f}–{max(times):.1f})",
            f"{peak:.0f}",
            max(solves, default=0),
        ]
        for R in sets.values():
            c = R @ prob.Phi
            a = colour.XYZ_to_Lab(apply_correction_LUT(luts[0], c), D65)
            b = colour.XYZ_to_Lab(apply_correction_LUT(lut, c), D65)
            d = colour.delta_E(a, b, method="CIE 2000")
            row.append(f"{d.mean():.3f} / {d.max():.2f}")
        rows.append(row)
    base = rows[0][1]
    for r in rows:
        r[1] = f"{base / max(r[1], 1e-9):.1f}×"
    _table(
        f"T. Prior LUT {size}³ (Nikon 5100, D65), one process: speed-up against the first row, CPU s "
        f"(median of {repeats}, range), peak traced MB, solver groups, ΔE00 mean / max vs the first row",
        ["solvers, grouping", "speed-up", "CPU s", "peak MB", "solves", *sets],
        rows,
    )


def table_U() -> None:
    from isp.profiles.chart import chart_reference, fit_chart, read_chart

    path = DATA / "raw_samples" / "tinydng_colorchart_Canon_EOS_Kiss_X4_MagicLantern.dng"
    if not path.is_file():
        print("\nU. skipped: needs the 550D DNG in ../shared/data")
        return
    corners = [(CHART_COLS[0], CHART_ROWS[0]), (CHART_COLS[-1], CHART_ROWS[0])]
    corners += [(CHART_COLS[-1], CHART_ROWS[-1]), (CHART_COLS[0], CHART_ROWS[-1])]
    reading = read_chart(isp.read_raw(path), corners)
    rows = []
    for ill in ("D50", "D65", "A", "FL2"):
        fit = fit_chart(reading, illuminant=ill)
        ref, _, white = chart_reference("colorchecker", ill)
        c = reading.rgb / fit.neutral
        M = colour.characterisation.matrix_colour_correction(c, ref, method="Cheung 2004", terms=3)
        wxy = colour.XYZ_to_xy(white)
        d = colour.delta_E(colour.XYZ_to_Lab(c @ M.T, wxy), colour.XYZ_to_Lab(ref, wxy), method="CIE 2000")
        rows.append([ill] + [f"{e.mean():.2f} / {e.max():.2f}" for e in (d, fit.delta_E_linear, fit.delta_E)])
    _table(
        "U. Real 550D chart, ΔE00 mean / max over 24 patches (CIELAB of the shoot illuminant's white)",
        ["illuminant", "colour LS (white free)", "white-preserving LS", "+ ΔE00 refinement (ours)"],
        rows,
    )


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="fewer fitting colours (300 random, not 1,500)")
    ap.add_argument("--camera", action="append", help="table P for these cameras (default all built-in)")
    ap.add_argument("--tables", default="PQRSTU", help="which tables to print (default PQRSTU)")
    ap.add_argument(
        "--no-exact",
        action="store_true",
        help="table T without the every-node baseline (253 CPU-s at 33³): against the former default",
    )
    ap.add_argument("--repeats", type=int, default=5, help="table T: timed runs per row (the median)")
    ap.add_argument(
        "--no-memory", action="store_true", help="table T without the traced (memory) run per row"
    )
    args = ap.parse_args()
    cameras = args.camera or zonotope.list_builtin()["cameras"]
    if "P" in args.tables:
        table_P(cameras, args.quick)
    if "Q" in args.tables:
        table_Q()
    if "R" in args.tables:
        table_R(args.quick)
    if "S" in args.tables:
        table_S(cameras, args.quick)
    if "T" in args.tables:
        table_T(args.quick, exact=not args.no_exact, repeats=args.repeats, memory=not args.no_memory)
    if "U" in args.tables:
        table_U()


if __name__ == "__main__":
    main()
