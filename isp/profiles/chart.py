"""Camera profiles from a photographed chart: read the patches of a RAW file, fit, report ΔE00.

A ColorChecker Classic (24 patches, 4 × 6, also the classic side of the Passport) photographed
under a known illuminant is located by the centres of its four corner patches, given by the user
in the RAW file's pixel frame (the active area, as ``isp develop`` writes it before orientation):
patch 1 (dark skin, top left), patch 6 (bluish green, top right), patch 24 (black, bottom right)
and patch 19 (white, bottom left). The other centres follow from the homography of those four
points (a chart seen in perspective), and the mean **raw** camera RGB of a box around each centre
(black level subtracted, each CFA colour averaged over its own sites: no demosaicing) is the
patch's response (:func:`read_chart`).

:func:`fit_chart` fits the white-balanced camera RGB → XYZ matrix against the chart's reference
under the shoot illuminant (colour-science's spectral ColorChecker data × the illuminant × the CIE
1931 observer): the camera neutral from the six grey patches, a least-squares matrix with the
white held exactly, then refined to minimise ΔE00 over the patches as dcamprof and Lumariver
do. :func:`chart_dcp` encodes it as a one-illuminant DCP; :func:`write_chart_report` writes the
per-patch CSV and HTML report.
"""

from __future__ import annotations

import html
import os
from dataclasses import dataclass
from pathlib import Path

import colour
import numpy as np

from .._errors import PipelineError
from .._tol import CHART_BOX, CHART_CLIP_FRACTION, CHART_CLIP_LEVEL, CHART_MIN_SIGNAL

__all__ = [
    "CHART_TYPES",
    "REPORT_CSV_HEADER",
    "REPORT_MARK",
    "ChartError",
    "ChartFit",
    "ChartReading",
    "ChartType",
    "chart_dcp",
    "chart_patch_centres",
    "chart_reference",
    "fit_chart",
    "read_chart",
    "write_chart_report",
]


#: The CSV report's header line: how ``isp profile --overwrite`` recognises a report it wrote (by all but
#: the last column, ``illuminant``, which reports of earlier versions lack). The illuminant column names
#: the light the chart was photographed under, for ``zonotope ssf estimate --chart`` to read.
REPORT_CSV_HEADER = (
    "patch,name,raw_R,raw_G,raw_B,ref_L,ref_a,ref_b,fit_L,fit_a,fit_b,dE00_linear,dE00,illuminant"
)
#: The HTML report's generator tag, for the same purpose (``--overwrite`` replaces no other file).
REPORT_MARK = '<meta name="generator" content="isp profile chart report">'


class ChartError(PipelineError):
    """A chart that cannot be read or fitted: corners off the image, clipped or too dark patches."""


@dataclass(frozen=True)
class ChartType:
    """A chart layout and its reference data.

    Attributes
    ----------
    rows, cols : int
        Patch grid, patches numbered row by row from the top-left one.
    reference : str
        Key of ``colour.SDS_COLOURCHECKERS`` (spectral reflectances: any illuminant).
    neutrals : tuple of int
        0-based indices of the neutral patches (the white balance is measured on them).
    """

    rows: int
    cols: int
    reference: str
    neutrals: tuple[int, ...]


#: Chart types ``isp profile --chart-type`` knows. The ColorChecker Classic's reference is
#: BabelColor's average of 30 charts (Pascale 2006), spectral, so any shoot illuminant works.
CHART_TYPES: dict[str, ChartType] = {
    "colorchecker": ChartType(
        rows=4, cols=6, reference="BabelColor Average", neutrals=(18, 19, 20, 21, 22, 23)
    ),
}


def _chart_type(name: str) -> ChartType:
    t = CHART_TYPES.get(str(name).lower())
    if t is None:
        raise ChartError(f"chart type {name!r}: choose one of {sorted(CHART_TYPES)}.")
    return t


def chart_patch_centres(corners, rows: int, cols: int) -> np.ndarray:
    """Patch centres ``(rows · cols, 2)`` as (x, y) from the centres of the four corner patches.

    Parameters
    ----------
    corners : array_like of shape (4, 2)
        (x, y) of the top-left, top-right, bottom-right and bottom-left patch centres.
    rows, cols : int

    Returns
    -------
    ndarray of shape (rows · cols, 2)
        Row by row, through the homography that takes the patch grid to the four points.
    """
    P = np.asarray(corners, dtype=np.float64)
    if P.shape != (4, 2) or not np.all(np.isfinite(P)):
        raise ChartError(f"corners: give 4 (x, y) points, got shape {P.shape}.")
    G = np.array([[0, 0], [cols - 1, 0], [cols - 1, rows - 1], [0, rows - 1]], dtype=np.float64)
    A, b = [], []
    for (u, v), (x, y) in zip(G, P, strict=True):
        A.append([u, v, 1, 0, 0, 0, -u * x, -v * x])
        A.append([0, 0, 0, u, v, 1, -u * y, -v * y])
        b += [x, y]
    try:
        h = np.linalg.solve(np.array(A), np.array(b))
    except np.linalg.LinAlgError:
        raise ChartError(
            "corners: three of the four points are on one line; give the centres of the four corner "
            "patches in the order top-left, top-right, bottom-right, bottom-left."
        ) from None
    H = np.append(h, 1.0).reshape(3, 3)
    j, i = np.meshgrid(np.arange(cols), np.arange(rows))
    uv1 = np.stack([j.ravel(), i.ravel(), np.ones(rows * cols)], axis=1)
    xyw = uv1 @ H.T
    return xyw[:, :2] / xyw[:, 2:]


@dataclass(frozen=True, eq=False)
class ChartReading:
    """The mean raw camera RGB of each patch of a photographed chart.

    Attributes
    ----------
    rgb : ndarray of shape (P, 3)
        Mean raw camera RGB per patch, black level subtracted, in units of the raw range
        (white level − black level).
    std : ndarray of shape (P, 3)
        Standard deviation of the pixels in each patch's box (same units).
    centres : ndarray of shape (P, 2)
        (x, y) patch centres in the mosaic.
    half : int
        Half side of the boxes in pixels.
    chart : str
        Chart type (key of :data:`CHART_TYPES`).
    camera : str
        Make and model of the RAW file.
    """

    rgb: np.ndarray
    std: np.ndarray
    centres: np.ndarray
    half: int
    chart: str
    camera: str


def read_chart(raw, corners, *, chart: str = "colorchecker") -> ChartReading:
    """Mean raw camera RGB per patch of a chart photographed in ``raw``.

    Parameters
    ----------
    raw : isp.RawImage or path
        The RAW file (:func:`isp.read_raw`).
    corners : array_like of shape (4, 2)
        (x, y) centres of the top-left, top-right, bottom-right and bottom-left patches in the
        mosaic's pixel frame (see the module notes).
    chart
        Chart type, a key of :data:`CHART_TYPES`.

    Returns
    -------
    ChartReading

    Raises
    ------
    ChartError
        Boxes off the image, patches too small, clipped patches (any colour channel at the white
        level in more than a few pixels) or a chart too dark to measure (the brightest neutral
        patch below a few percent of the raw range).
    """
    from ..cfa import cfa_masks
    from ..raw import read_raw

    if not hasattr(raw, "mosaic"):
        raw = read_raw(raw)
    t = _chart_type(chart)
    centres = chart_patch_centres(corners, t.rows, t.cols)
    pitch = min(
        np.linalg.norm(centres[1] - centres[0]),
        np.linalg.norm(centres[t.cols] - centres[0]),
    )
    half = int(CHART_BOX * pitch)
    m = np.asarray(raw.mosaic)
    H, W = m.shape
    if half < 2:
        raise ChartError(
            f"corners: patches {pitch:.1f} px apart leave boxes under 4 px; give the four corner patch "
            "centres (x, y) of a chart that fills more of the frame."
        )
    lo, hi = centres - half, centres + half
    if lo.min() < 0 or hi[:, 0].max() >= W or hi[:, 1].max() >= H:
        raise ChartError(
            f"corners: some patch boxes fall outside the {W} × {H} image; give the (x, y) centres of "
            "the corner patches in the RAW file's pixel frame (x to the right, y down)."
        )
    black = np.tile(np.asarray(raw.black_level, dtype=np.float64), (H // 2 + 1, W // 2 + 1))[:H, :W]
    scale = float(raw.white_level) - float(np.max(raw.black_level))
    masks = cfa_masks((H, W), raw.cfa)
    rgb, std = np.empty((centres.shape[0], 3)), np.empty((centres.shape[0], 3))
    for k, (x, y) in enumerate(np.round(centres).astype(int)):
        sl = (slice(y - half, y + half), slice(x - half, x + half))
        px = m[sl].astype(np.float64)
        clipped = px >= CHART_CLIP_LEVEL * float(raw.white_level)
        if clipped.mean() > CHART_CLIP_FRACTION:
            raise ChartError(
                f"{_path(raw)}: patch {k + 1} is clipped ({100 * clipped.mean():.0f} % of its pixels at the "
                "white level); photograph the chart with less exposure."
            )
        v = (px - black[sl]) / scale
        for ch in range(3):
            sel = v[masks[sl][..., ch]]
            rgb[k, ch], std[k, ch] = sel.mean(), sel.std()
    bright = rgb[list(t.neutrals)].max()
    if not bright >= CHART_MIN_SIGNAL:
        raise ChartError(
            f"{_path(raw)}: the brightest neutral patch reaches {100 * max(bright, 0):.2f} % of the raw "
            f"range (need ≥ {100 * CHART_MIN_SIGNAL:g} %); photograph the chart brighter or check the "
            "corners."
        )
    camera = f"{raw.make} {raw.model}".strip()
    return ChartReading(rgb=rgb, std=std, centres=centres, half=half, chart=str(chart).lower(), camera=camera)


def _path(raw) -> str:
    return str(getattr(raw, "path", None) or "RAW file")


def chart_reference(chart: str, illuminant: str) -> tuple[np.ndarray, list[str], np.ndarray]:
    """Reference XYZ of a chart's patches under an illuminant (CIE 1931 2°, perfect white Y = 1).

    Returns
    -------
    XYZ : ndarray of shape (P, 3)
    names : list of str
    white : ndarray of shape (3,)
        XYZ of the perfect white under the illuminant.
    """
    t = _chart_type(chart)
    sds = colour.SDS_COLOURCHECKERS[t.reference]
    ill = colour.SDS_ILLUMINANTS.get(str(illuminant))
    if ill is None:
        raise ChartError(
            f"illuminant {illuminant!r}: give a CIE illuminant colour-science tabulates "
            "(e.g. D50, D65, A, FL2)."
        )
    shape = next(iter(sds.values())).shape  # the reference's range: nothing trimmed or extrapolated
    cmfs = colour.MSDS_CMFS["CIE 1931 2 Degree Standard Observer"].copy().align(shape)
    ill = ill.copy().align(shape)
    XYZ = np.array([colour.sd_to_XYZ(sd, cmfs, ill) for sd in sds.values()]) / 100.0
    white = colour.sd_to_XYZ(colour.sd_ones(shape), cmfs, ill) / 100.0
    return XYZ, list(sds), white


@dataclass(frozen=True, eq=False)
class ChartFit:
    """A camera matrix fitted from a photographed chart and its per-patch errors.

    Attributes
    ----------
    matrix : ndarray of shape (3, 3)
        White-balanced camera RGB → XYZ under the shoot illuminant (white (1, 1, 1) → its white, Y = 1).
    forward_matrix : ndarray of shape (3, 3)
        White-balanced camera RGB → XYZ D50 (Bradford), ``FM · (1, 1, 1) = D50``.
    neutral : ndarray of shape (3,)
        Raw camera RGB of the perfect white (from the neutral patches), in raw-range units.
    illuminant : str
    names : list of str
    reference, fitted : ndarray of shape (P, 3)
        XYZ under the illuminant (white Y = 1).
    delta_E : ndarray of shape (P,)
        ΔE00 per patch (CIELAB relative to the illuminant's white).
    delta_E_linear : ndarray of shape (P,)
        ΔE00 of the least-squares matrix before the ΔE00 refinement (for comparison).
    reading : ChartReading
    """

    matrix: np.ndarray
    forward_matrix: np.ndarray
    neutral: np.ndarray
    illuminant: str
    names: list
    reference: np.ndarray
    fitted: np.ndarray
    delta_E: np.ndarray
    delta_E_linear: np.ndarray
    reading: ChartReading


def fit_chart(reading: ChartReading, *, illuminant: str = "D50", refine: bool = True) -> ChartFit:
    """Fit the camera matrix of a :func:`read_chart` reading against the chart's reference.

    Parameters
    ----------
    reading
    illuminant
        The light the chart was photographed under (a colour-science illuminant name).
    refine
        Refine the least-squares matrix to minimise ΔE00 over the patches (default True); the
        white stays exact either way.

    Returns
    -------
    ChartFit
    """
    from scipy.optimize import least_squares

    from .fitting import _fit_white_preserving

    ref, names, white = chart_reference(reading.chart, illuminant)
    neutrals = list(_chart_type(reading.chart).neutrals)
    # raw ≈ neutral · Y on the grey patches: least squares per channel
    Yg = ref[neutrals, 1]
    neutral = (reading.rgb[neutrals] * Yg[:, None]).sum(0) / (Yg**2).sum()
    if not np.all(neutral > 0):
        raise ChartError(
            f"the neutral patches give a camera white {neutral.tolist()} with a channel ≤ 0; "
            "check the corners."
        )
    c = reading.rgb / neutral
    M0 = _fit_white_preserving(c, ref, np.ones(3), white)
    white_xy = colour.XYZ_to_xy(white)

    def lab(X):
        return colour.XYZ_to_Lab(X, white_xy)

    ref_lab = lab(ref)

    def dE(M):
        return colour.delta_E(lab(c @ M.T), ref_lab, method="CIE 2000")

    # M = M0 + N with N (1, 1, 1) = 0: two free entries per row keep the white exact
    def matrix(p):
        N = np.column_stack([p.reshape(3, 2), -p.reshape(3, 2).sum(1)])
        return M0 + N

    M = M0
    if refine:
        res = least_squares(lambda p: dE(matrix(p)), np.zeros(6), method="lm")
        if res.success and dE(matrix(res.x)).mean() <= dE(M0).mean():
            M = matrix(res.x)
    D50 = colour.xy_to_XYZ(colour.CCS_ILLUMINANTS["CIE 1931 2 Degree Standard Observer"]["D50"])
    cat = colour.adaptation.matrix_chromatic_adaptation_VonKries(white, D50, transform="Bradford")
    FM = cat @ M
    FM = np.diag(D50 / (FM @ np.ones(3))) @ FM  # exact D50 white (Bradford of the white to ~1e-16)
    return ChartFit(
        matrix=M,
        forward_matrix=FM,
        neutral=neutral,
        illuminant=str(illuminant),
        names=names,
        reference=ref,
        fitted=c @ M.T,
        delta_E=dE(M),
        delta_E_linear=dE(M0),
        reading=reading,
    )


def chart_dcp(fit: ChartFit, *, unique_camera_model: str, profile_name: str = "", copyright: str = ""):
    """A one-illuminant DCP (ColorMatrix1, ForwardMatrix1) of a :class:`ChartFit`.

    ColorMatrix1 = diag(n) · M⁻¹ (``n`` the camera neutral, max 1), so that the DNG's white
    search finds the shoot illuminant's white for that neutral.

    Raises
    ------
    ChartError
        The illuminant has no EXIF LightSource code (the DCP's CalibrationIlluminant1).
    """
    from ..simulate import ILLUMINANT_LIGHT_SOURCE
    from .dcp import DCPProfile

    code = ILLUMINANT_LIGHT_SOURCE.get(fit.illuminant.upper().replace(" ", ""))
    if code is None:
        raise ChartError(
            f"illuminant {fit.illuminant!r}: a DCP names its illuminant by an EXIF LightSource code; "
            f"use one of {sorted(ILLUMINANT_LIGHT_SOURCE)} (or write only --icc)."
        )
    n = fit.neutral / fit.neutral.max()
    CM = np.diag(n) @ np.linalg.inv(fit.matrix)
    return DCPProfile(
        color_matrix_1=CM,
        forward_matrix_1=fit.forward_matrix,
        calibration_illuminant_1=code,
        profile_name=profile_name or f"{unique_camera_model} chart {fit.illuminant} (zonotope)",
        unique_camera_model=unique_camera_model,
        copyright=copyright,
        embed_policy=3,
    )


def _srgb8(XYZ, white) -> list[str]:
    rgb = colour.XYZ_to_sRGB(XYZ, colour.XYZ_to_xy(white), chromatic_adaptation_transform="Bradford")
    return ["#" + "".join(f"{c:02x}" for c in v) for v in np.round(255 * np.clip(rgb, 0, 1)).astype(int)]


def write_chart_report(
    fit: ChartFit, csv_path: str | os.PathLike, *, overwrite: bool = False
) -> tuple[Path, Path]:
    """Write the per-patch report: ``csv_path`` and an HTML table next to it (same name, ``.html``).

    Columns: patch number and name, mean raw camera RGB (raw-range units), reference and fitted
    CIELAB (relative to the illuminant's white), ΔE00 of the least-squares and of the refined
    matrix, the illuminant; the HTML adds reference/fitted swatches (sRGB) and the mean, median and
    maximum.

    Raises
    ------
    ChartError
        An output exists (and not ``overwrite``).
    """
    from zonotope.utilities import atomic_write_text

    csv_path = Path(csv_path)
    html_path = csv_path.with_suffix(".html")
    for p in (csv_path, html_path):
        if p.exists() and not overwrite:
            raise ChartError(f"{p} exists; pass --overwrite or choose another name.")
    wxy = colour.XYZ_to_xy(chart_reference(fit.reading.chart, fit.illuminant)[2])
    L_ref, L_fit = colour.XYZ_to_Lab(fit.reference, wxy), colour.XYZ_to_Lab(fit.fitted, wxy)
    lines = [REPORT_CSV_HEADER]
    for k, name in enumerate(fit.names):
        vals = [*fit.reading.rgb[k], *L_ref[k], *L_fit[k], fit.delta_E_linear[k], fit.delta_E[k]]
        lines.append(f"{k + 1},{name}," + ",".join(f"{v:.6g}" for v in vals) + f",{fit.illuminant}")
    white = chart_reference(fit.reading.chart, fit.illuminant)[2]
    sw_ref, sw_fit = _srgb8(fit.reference, white), _srgb8(fit.fitted, white)
    rows = "\n".join(
        f"<tr><td>{k + 1}</td><td>{html.escape(name)}</td>"
        f'<td style="background:{sw_ref[k]};width:3em"></td>'
        f'<td style="background:{sw_fit[k]};width:3em"></td>'
        f"<td>{L_ref[k][0]:.1f} {L_ref[k][1]:.1f} {L_ref[k][2]:.1f}</td>"
        f"<td>{L_fit[k][0]:.1f} {L_fit[k][1]:.1f} {L_fit[k][2]:.1f}</td>"
        f"<td>{fit.delta_E_linear[k]:.2f}</td><td><b>{fit.delta_E[k]:.2f}</b></td></tr>"
        for k, name in enumerate(fit.names)
    )
    e = fit.delta_E
    page = f"""<!DOCTYPE html>
<html><head><meta charset="utf-8">{REPORT_MARK}<title>{html.escape(fit.reading.camera)} chart profile</title>
<style>body{{font-family:sans-serif}} td,th{{padding:2px 8px;text-align:right}}</style></head><body>
<h1>{html.escape(fit.reading.camera)}: {html.escape(fit.reading.chart)}
under {html.escape(fit.illuminant)}</h1>
<p>ΔE00 (CIELAB relative to the illuminant's white): mean {e.mean():.2f}, median {np.median(e):.2f},
max {e.max():.2f} (patch {int(e.argmax()) + 1}); least-squares matrix before refinement: mean
{fit.delta_E_linear.mean():.2f}, max {fit.delta_E_linear.max():.2f}.</p>
<table><tr><th>#</th><th>patch</th><th>reference</th><th>fitted</th><th>Lab reference</th><th>Lab fitted</th>
<th>ΔE00 LS</th><th>ΔE00</th></tr>
{rows}
</table></body></html>
"""
    atomic_write_text(csv_path, "\n".join(lines) + "\n")
    atomic_write_text(html_path, page)
    return csv_path, html_path
