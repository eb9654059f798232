"""Real DNG colour matrices for the measured cameras: LibRaw's table and RawTherapee's profiles.

LibRaw's ``src/tables/colordata.cpp`` (``LibRaw::adobe_coeff``) carries, for over 700 camera models,
the XYZ → camera matrix under D65 that Adobe's DNG Converter writes as ColorMatrix2 ("All matrices
are from Adobe DNG Converter unless otherwise noted"). It is not shipped here (LGPL-2.1 / CDDL); the
benchmarks read it from a LibRaw checkout::

    git clone --depth 1 https://github.com/LibRaw/LibRaw
    python benchmarks/bench_ssf_stack.py --data ../shared/data --colordata LibRaw/src/tables/colordata.cpp ...

A camera's entry is found as LibRaw finds it: the first entry of its maker whose model prefix the
camera's model starts with (case ignored). Entries marked as not Adobe's (``/* DJC */``,
``/* LibRaw */``, ``/* temp */``, ``/* emb */``) are skipped.

RawTherapee's camera profiles (``/usr/share/rawtherapee/dcpprofiles/*.dcp``, installed with
RawTherapee) carry what a DNG carries: ColorMatrix1/2 (A and D65; the D65 one is Adobe's) and
ForwardMatrix1/2 (fitted by the profile's author to chart photographs). :func:`dcp_matrices` reads
them as the tags :func:`zonotope.spectra.estimate.read_dng_matrices` takes.
"""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np

_ENTRY = re.compile(
    r"\{\s*LIBRAW_CAMERAMAKER_(\w+)\s*,\s*\"([^\"]*)\"\s*,\s*[^,{}]+,\s*[^,{}/]+,\s*"
    r"(?://[^\n]*\n\s*|/\*.*?\*/\s*)?\{([-\d,\s]*)\}\s*\}\s*,?[ \t]*(/\*.*?\*/|//[^\n]*)?"
)
#: Comments that mark a matrix as not Adobe's.
NOT_ADOBE = ("DJC", "LibRaw", "temp", "emb")
#: Measured-camera names whose model LibRaw spells otherwise (maker, model as LibRaw has it).
SPELLING = {
    "Canon Digital Rebel XTi": ("Canon", "EOS 400D"),
    "Canon EOS 200D II": ("Canon", "EOS 250D"),
    "Canon EOS R5m2": ("Canon", "EOS R5 Mark II"),
    "Canon EOS R6m2": ("Canon", "EOS R6 Mark II"),
    "Canon 1DMarkIII": ("Canon", "EOS-1D Mark III"),
    "Canon 5DMarkII": ("Canon", "EOS 5D Mark II"),
    "Nikon Z6": ("Nikon", "Z 6"),
}
_MAKERS = {"Canon", "Nikon", "Sony", "Fujifilm", "Olympus", "Pentax", "Panasonic", "Hasselblad"}


def read_colordata(path: str | Path) -> list[tuple[str, str, np.ndarray]]:
    """(maker, model prefix, XYZ → camera 3 × 3 under D65) of every Adobe entry, in table order."""
    text = Path(path).read_text(errors="replace")
    out = []
    for m in _ENTRY.finditer(text):
        comment = m.group(4) or ""
        if any(tag in comment for tag in NOT_ADOBE):
            continue
        vals = [int(v) for v in m.group(3).split(",") if v.strip()]
        if len(vals) < 9 or not any(vals[:9]):
            continue
        out.append((m.group(1), m.group(2), np.array(vals[:9], dtype=np.float64).reshape(3, 3) / 10000.0))
    if len(out) < 100:
        raise ValueError(f"{path}: {len(out)} matrices read; give LibRaw's src/tables/colordata.cpp.")
    return out


def maker_and_model(name: str) -> tuple[str, str] | None:
    """(maker, model) of a measured camera's name (``"Canon 600D (camspec)"`` → Canon, EOS 600D)."""
    base = re.sub(r"\s*\([^)]*\)$", "", name).strip()
    if base in SPELLING:
        return SPELLING[base]
    maker, _, model = base.partition(" ")
    if maker not in _MAKERS:
        return None
    if maker == "Canon" and re.fullmatch(r"\d+D", model):
        model = "EOS " + model
    return maker, model


def colour_matrix(table, name: str) -> np.ndarray | None:
    """The D65 XYZ → camera matrix LibRaw gives the camera ``name``, or None."""
    mm = maker_and_model(name)
    if mm is None:
        return None
    maker, model = mm
    for mk, prefix, M in table:
        if mk.lower() == maker.lower() and model.lower().startswith(prefix.lower()):
            return M
    return None


def dcp_matrices(folder: str | Path, names) -> dict[str, dict]:
    """Measured-camera name → the DNG tags of RawTherapee's profile of that model, where there is one."""
    from isp.profiles.dcp import read_dcp
    from isp.profiles.models import same_camera

    profiles = []
    for f in sorted(Path(folder).glob("*.dcp")):
        p = read_dcp(f)
        profiles.append((p.unique_camera_model or f.stem, p))
    out = {}
    for n in names:
        mm = maker_and_model(n)
        if mm is None:
            continue
        for model, p in profiles:
            if same_camera(" ".join(mm), model):
                tags = {"UniqueCameraModel": model}
                for i, (cm, fm, code) in enumerate(
                    (
                        (p.color_matrix_1, p.forward_matrix_1, p.calibration_illuminant_1),
                        (p.color_matrix_2, p.forward_matrix_2, p.calibration_illuminant_2),
                    ),
                    start=1,
                ):
                    if cm is not None:
                        tags |= {f"ColorMatrix{i}": cm, f"CalibrationIlluminant{i}": code}
                        if fm is not None:
                            tags[f"ForwardMatrix{i}"] = fm
                out[n] = tags
                break
    return out


def synthesised_d65(cams: dict[str, dict], names) -> dict[str, np.ndarray]:
    """The D65 ColorMatrix synthesised from each named camera's measured curves (what a converter fitted
    to them would write; :func:`zonotope.spectra.estimate.synthesise_dng_matrices`)."""
    from bench_ssf import msds

    from zonotope.spectra.estimate import synthesise_dng_matrices

    return {
        n: synthesise_dng_matrices(msds(cams[n]["values"], n), illuminants=("D65",)).color_matrices[0]
        for n in names
    }


def common_transform(real: list[np.ndarray], synthesised: list[np.ndarray], side: str = "xyz") -> np.ndarray:
    """The 3 × 3 transform, common to the cameras, that best takes each real matrix (unit norm) to the
    synthesised one (unit norm), least squares: ``A T`` on the XYZ side, ``C A`` on the camera side."""
    A = np.array([m / np.linalg.norm(m) for m in real])
    S = np.array([m / np.linalg.norm(m) for m in synthesised])
    if side == "xyz":
        return np.linalg.lstsq(np.vstack(A), np.vstack(S), rcond=None)[0]
    return np.linalg.lstsq(np.hstack(A).T, np.hstack(S).T, rcond=None)[0].T


def times_transform(M: np.ndarray, T: np.ndarray) -> np.ndarray:
    """``M · T`` at ``M``'s norm: a real matrix corrected by :func:`common_transform` (as ``estimate_ssf``
    does with :attr:`SSFCalibration.transform`)."""
    MT = M @ T
    return MT * (np.linalg.norm(M) / np.linalg.norm(MT))


def common_transform_report(cams: dict[str, dict], table) -> dict:
    """How much of the difference between Adobe's D65 ColorMatrix and the one synthesised from the same
    model's measured curves one transform common to every camera explains, leave one camera out.

    Each matrix is scaled to unit Frobenius norm; a difference is ``‖S − s·A‖ / ‖S‖`` with the best
    scale ``s``. The common transform (:func:`common_transform`) is fitted on the other cameras, on the
    XYZ side (``A T``) or on the camera side (``C A``). Why: a systematic part (another observer,
    training set or white) could be removed before the fit; what is left is each model's own tuning.
    """
    real = {n: m for n in cams if (m := colour_matrix(table, n)) is not None}
    syn = synthesised_d65(cams, real)
    names = list(real)

    def diff(a, s):
        a, s = a / np.linalg.norm(a), s / np.linalg.norm(s)
        return float(np.linalg.norm(s - np.sum(a * s) / np.sum(a * a) * a) / np.linalg.norm(s))

    out = {"cameras": len(names), "none": [], "xyz side": [], "camera side": []}
    for n in names:
        rest = [m for m in names if m != n]
        T = common_transform([real[m] for m in rest], [syn[m] for m in rest], "xyz")
        C = common_transform([real[m] for m in rest], [syn[m] for m in rest], "camera")
        a = real[n] / np.linalg.norm(real[n])
        out["none"].append(diff(a, syn[n]))
        out["xyz side"].append(diff(a @ T, syn[n]))
        out["camera side"].append(diff(C @ a, syn[n]))
    return out


def main(argv=None) -> int:
    """``python benchmarks/real_matrices.py --data ../shared/data --colordata colordata.cpp``: the
    common-transform report (:func:`common_transform_report`) over the measured cameras."""
    import argparse
    import sys

    sys.path.insert(0, str(Path(__file__).parent))
    from bench_ssf import measured_cameras

    p = argparse.ArgumentParser(description=main.__doc__.split("\n\n")[0])
    p.add_argument("--data", type=Path, required=True, help="the measured data folder (camera SSFs)")
    p.add_argument("--colordata", type=Path, required=True, help="LibRaw's src/tables/colordata.cpp")
    a = p.parse_args(argv)
    r = common_transform_report(measured_cameras(a.data), read_colordata(a.colordata))
    print(f"{r['cameras']} cameras; ‖synthesised − Adobe's‖ / ‖synthesised‖, leave one camera out:")
    print("| common transform | median | mean | 90th percentile |\n|---|---:|---:|---:|")
    for k in ("none", "xyz side", "camera side"):
        v = np.asarray(r[k])
        print(f"| {k} | {np.median(v):.3f} | {v.mean():.3f} | {np.percentile(v, 90):.3f} |")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
