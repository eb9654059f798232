"""Develop a DNG with RawTherapee (``rawtherapee-cli``) colorimetrically, to check our profiles against it.

:func:`develop_rawtherapee` writes a processing profile (``.pp3``) that switches off everything that
is not colorimetric — no auto exposure, no exposure/contrast/saturation curves, no highlight
recovery or compression, no chromatic-aberration correction, no sharpening, the DCP's tone curve and
baseline exposure offset off, its HueSatMap and LookTable on — develops to a 32-bit float TIFF in
ProPhoto primaries (RawTherapee's ``RTv4_Large`` output profile: ProPhoto RGB, D50, sRGB transfer
function, read from the ICC), and returns XYZ D50. RawTherapee crops a few border pixels while
demosaicing; the result is centred on the input (:attr:`RawTherapeeImage.offset`).

:func:`patch_delta_E` measures per-patch ΔE00 of a developed chart against the true XYZ.
"""

from __future__ import annotations

import os
import shutil
import subprocess
import tempfile
from dataclasses import dataclass
from pathlib import Path

import colour
import numpy as np

from .._errors import PipelineError

__all__ = ["RawTherapeeImage", "develop_rawtherapee", "patch_delta_E", "rawtherapee_cli"]

_PP3 = """[Exposure]
Auto=false
Clip=0
Compensation=0
Brightness=0
Contrast=0
Saturation=0
Black=0
HighlightCompr=0
HighlightComprThreshold=0
ShadowCompr=0
HistogramMatching=false
CurveFromHistogramMatching=false
ClampOOG=false
CurveMode=Standard
CurveMode2=Standard
Curve=0;
Curve2=0;

[HLRecovery]
Enabled=false

[White Balance]
Enabled=true
Setting=Camera

[RAW]
CA=false
HotPixelFilter=false
DeadPixelFilter=false

[RAW Bayer]
Method={demosaic}

[Sharpening]
Enabled=false

[Color Management]
InputProfile={input}
ToneCurve=false
ApplyLookTable=true
ApplyBaselineExposureOffset=false
ApplyHueSatMap=true
DCPIlluminant=0
WorkingProfile=ProPhoto
WorkingTRC=none
OutputProfile=RTv4_Large
"""

_PROPHOTO = colour.RGB_COLOURSPACES["ProPhoto RGB"]


def rawtherapee_cli() -> str | None:
    """Path of ``rawtherapee-cli``, or None when RawTherapee is not installed."""
    return shutil.which("rawtherapee-cli")


@dataclass(frozen=True, eq=False)
class RawTherapeeImage:
    """A RawTherapee development.

    Attributes
    ----------
    XYZ : ndarray of shape (H', W', 3)
        XYZ D50 (the DNG profile connection space).
    offset : tuple of int
        (top, left) of ``XYZ`` in the input mosaic's pixel grid.
    """

    XYZ: np.ndarray
    offset: tuple[int, int]


def develop_rawtherapee(
    dng: str | os.PathLike,
    *,
    profile: str | os.PathLike | None = None,
    demosaic: str = "amaze",
    timeout: float = 120.0,
) -> RawTherapeeImage:
    """Develop a DNG with ``rawtherapee-cli`` and a colorimetric processing profile.

    Parameters
    ----------
    dng
        Input DNG.
    profile
        A ``.dcp`` camera profile, or None for the DNG's own ColorMatrix (RawTherapee's
        ``(camera)`` input profile).
    demosaic
        RawTherapee demosaicing method (``amaze``, ``rcd``, ``vng4``, ...).
    timeout
        Seconds before the run is abandoned.

    Returns
    -------
    RawTherapeeImage

    Raises
    ------
    PipelineError
        RawTherapee missing, failing, or leaving no output.
    """
    import tifffile

    cli = rawtherapee_cli()
    if cli is None:
        raise PipelineError(
            "rawtherapee-cli not found; install RawTherapee (Debian: apt-get install rawtherapee)."
        )
    src = Path(dng).resolve()
    inp = "(camera)" if profile is None else f"file:{Path(profile).resolve()}"
    with tempfile.TemporaryDirectory() as tmp:
        pp3 = Path(tmp) / "colorimetric.pp3"
        pp3.write_text(_PP3.format(input=inp, demosaic=demosaic))
        out = Path(tmp) / "out.tif"
        env = dict(os.environ, HOME=tmp)  # RawTherapee writes its cache and options under $HOME
        run = subprocess.run(
            [cli, "-q", "-Y", "-t", "-b32", "-p", str(pp3), "-o", str(out), "-c", str(src)],
            capture_output=True,
            text=True,
            timeout=timeout,
            env=env,
        )
        if run.returncode != 0 or not out.exists():
            raise PipelineError(
                f"rawtherapee-cli failed on {src} (exit {run.returncode}): "
                f"{(run.stderr or run.stdout).strip()[-400:]}"
            )
        a = tifffile.imread(out).astype(np.float64)
    import rawpy

    with rawpy.imread(str(src)) as r:
        H, W = r.raw_image_visible.shape
    rgb = colour.models.eotf_sRGB(a[..., :3])
    XYZ = rgb @ np.asarray(_PROPHOTO.matrix_RGB_to_XYZ).T
    return RawTherapeeImage(XYZ=XYZ, offset=((H - a.shape[0]) // 2, (W - a.shape[1]) // 2))


def patch_delta_E(
    XYZ, labels, truth_XYZ, *, white_XYZ, patches=None, normalise_to: int | None = None, margin: int = 4
) -> np.ndarray:
    """Per-patch CIEDE2000 of a developed chart against the truth (mean XYZ of each patch).

    Parameters
    ----------
    XYZ : array_like of shape (H, W, 3)
        Developed image in XYZ (any white; ``white_XYZ`` is its reference white).
    labels : array_like of shape (H, W), int
        Patch index per pixel (-1 outside), aligned with ``XYZ``.
    truth_XYZ : array_like of shape (n_patches, 3)
        True XYZ per patch, with the same white as ``XYZ``.
    white_XYZ : array_like of shape (3,)
        The white of both (CIELAB reference).
    patches : sequence of int, optional
        Patches to measure (default all labels ≥ 0).
    normalise_to
        Scale the image so that this patch's Y equals the truth's (removes the exposure), or None.
    margin
        Pixels eroded from each patch edge (demosaicing bleed).

    Returns
    -------
    ndarray of shape (n_patches,)
    """
    from scipy.ndimage import binary_erosion

    X = np.asarray(XYZ, dtype=np.float64)
    lab = np.asarray(labels)
    T = np.asarray(truth_XYZ, dtype=np.float64)
    ids = sorted(int(k) for k in np.unique(lab) if k >= 0) if patches is None else list(patches)
    P = np.empty((len(ids), 3))
    for i, k in enumerate(ids):
        m = binary_erosion(lab == k, iterations=margin) if margin else lab == k
        if not m.any():
            raise PipelineError(f"patch {k}: no pixels left after eroding {margin} px; use a larger chart.")
        P[i] = X[m].mean(axis=0)
    Tk = T[ids]
    if normalise_to is not None:
        j = ids.index(normalise_to)
        P = P * (Tk[j, 1] / P[j, 1])
    w = colour.XYZ_to_xy(np.asarray(white_XYZ, dtype=np.float64))
    return colour.delta_E(colour.XYZ_to_Lab(P, w), colour.XYZ_to_Lab(Tk, w), method="CIE 2000")
