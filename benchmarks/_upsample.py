"""A RAW photograph upsampled to a real camera's size, for the benchmarks that need real-size files.

Run as scripts (``python benchmarks/bench_X.py``) the benchmarks import this module as ``_upsample``;
imported as ``benchmarks.bench_X`` they take it from the ``benchmarks`` package.

What the file is (state it whenever quoting a figure made with it): the photograph's RAW file
demosaiced (bilinear; a full-colour file as it is), upsampled bilinearly ``scale`` times, re-mosaicked
with the same CFA pattern (a full-colour file stays full-colour, LinearRaw) and given fresh shot + read
noise from its own DNG NoiseProfile, written by isp's DNG writer with the source's colour matrices,
white balance, levels, make, model and exposure (time, ISO, f-number). It holds no detail finer than
the original's pixels; the cost of work that does not depend on the content (reading, binning,
demosaicing, per-pixel regressions, writing) is that of a real file of its size.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

__all__ = ["upsampled_dng"]

_STRIP = 512  # rows generated at a time: memory only


def _exif(path: Path) -> dict:
    from isp.dng import read_dng_tags

    tags = read_dng_tags(path)
    out = {}
    for key, name in (("exposure_time", "ExposureTime"), ("f_number", "FNumber")):
        if name in tags:
            out[key] = float(np.ravel(tags[name])[0])
    if "ISOSpeedRatings" in tags:
        out["iso"] = int(np.ravel(tags["ISOSpeedRatings"])[0])
    for key, name in (("make", "Make"), ("model", "Model")):
        if isinstance(tags.get(name), str):
            out[key] = tags[name]
    return out


def upsampled_dng(view, spec, path: Path, scale: int, seed: int = 0) -> Path:
    """The photograph ``view.path`` (camera ``spec.cameras[view.camera]``) upsampled ``scale`` × as a
    new DNG at ``path`` (see the module notes); an existing ``path`` is returned as it is.

    ``scale`` must be even for a Bayer file (the pattern keeps its phase); any integer ≥ 1 for a
    full-colour one.
    """
    from isp.cfa import cfa_masks
    from isp.dng import write_dng
    from isp.stages import demosaic
    from splat.capture import open_raw
    from splat.strips import upsample_rows

    path = Path(path)
    if path.is_file():
        return path
    src = open_raw(view.path, spec.cameras[view.camera])
    bayer = src.cfa is not None
    if bayer and scale % 2:
        raise ValueError(f"scale={scale}: must be even for the Bayer file {view.path}")
    values, _ = src.rows(0, src.shape[0])
    if bayer:
        lin = np.maximum(demosaic(values.sum(-1), cfa=src.cfa, method="bilinear"), 0)
    else:
        lin = np.maximum(values.astype(np.float64), 0)
    H, W = lin.shape[0] * scale, lin.shape[1] * scale
    P = src.info["noise_profile"]
    rng = np.random.default_rng(seed)
    black = float(np.mean(src.black))
    dn = np.zeros((H, W) if bayer else (H, W, 3), np.uint16)
    for r0 in range(0, H, _STRIP):
        r1 = min(H, r0 + _STRIP)
        up = upsample_rows(lin, scale, r0, r1, W)
        if bayer:
            m = cfa_masks((r1 - r0, W), src.cfa)
            x = (up * m).sum(-1)
            var = None if P is None else (m * (P[:, 0] * np.maximum(up, 0) + P[:, 1])).sum(-1)
        else:
            x = up
            var = None if P is None else P[:, 0] * np.maximum(up, 0) + P[:, 1]
        if var is not None:
            x = x + rng.normal(size=x.shape) * np.sqrt(var)
        dn[r0:r1] = np.clip(np.round(black + np.clip(x, 0, 1) * (src.white - black)), 0, src.white)
    p = src.info["profile"]
    extra = {}
    if p.color_matrix_2 is not None and p.calibration_illuminant_2:
        extra = dict(
            color_matrix_2=p.color_matrix_2, calibration_illuminant_2=int(p.calibration_illuminant_2)
        )
    write_dng(
        path,
        dn,
        cfa=src.cfa or "RGGB",  # ignored for a full-colour (H, W, 3) image
        black_level=black,
        white_level=int(src.white),
        color_matrix_1=p.color_matrix_1,
        calibration_illuminant_1=int(p.calibration_illuminant_1 or 21),
        as_shot_neutral=src.info["neutral"],
        noise_profile=None if P is None else np.asarray(P, float),
        **extra,
        **_exif(Path(view.path)),
    )
    return path
