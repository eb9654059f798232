"""The marked ColorChecker (``[chart]``): its corner patches as given, or found in the RAW file.

``[chart] corners`` may be left out: :func:`chart_of` then searches the photograph for a ColorChecker
Classic (:func:`isp.profiles.chart_detect.detect_chart_rgb`, on a half-resolution preview read with
the capture's own levels), once, before the poses step starts its work, and keeps what it found in
``OUT/poses/chart.json`` with the file's size and time, so that the report step reads the same
corners and a replaced file is searched again. :func:`check_chart` checks that the patches lie inside
the photograph.

Why: on a photograph of 12–60 MP the chart's 24 patches span hundreds of pixels each, where the
detector finds them as exactly as a hand (``tests/isp/test_chart_detect.py``), and a user should not
have to measure pixel positions to get the report's reference.
"""

from __future__ import annotations

import dataclasses
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from .spec import CaptureError, CaptureSpec, ChartSpec

if TYPE_CHECKING:
    from .raw import RawView
    from .workspace import Workspace

__all__ = ["CHART_RECORD", "chart_of", "chart_preview", "check_chart", "recorded_corners"]

#: Where the corners found in ``[chart] image`` are kept, relative to OUT (an output of the poses step).
CHART_RECORD = "poses/chart.json"

#: How a capture's user gives the corners instead (ends every message of a failed search).
_BY_HAND = (
    "give its corners in capture.toml: [chart] corners = [[x, y], [x, y], [x, y], [x, y]], the centres of "
    "the top-left, top-right, bottom-right and bottom-left patches in the RAW file's pixels"
)


def chart_preview(path: Path, camera) -> np.ndarray:
    """The half-resolution linear RGB of a RAW file that the chart is searched in: each 2 × 2 block's
    channel means (a Bayer mosaic's own sites; every pixel of a full-colour sensor), the capture's
    black and white levels applied, divided by the file's as-shot neutral, on the detector's scale
    (:func:`isp.profiles.chart_detect.white_scaled`). Pixel (u, v) is centred on RAW pixel
    (2u + 0.5, 2v + 0.5).
    """
    from isp.profiles.chart_detect import white_scaled

    from .raw import open_raw

    src = open_raw(path, camera)
    H, W = (s // 2 * 2 for s in src.shape)
    total = np.zeros((H // 2, W // 2, 3))
    count = np.zeros((H // 2, W // 2, 3))
    step = 512  # rows at a time: memory bounded by the strip, not the photograph
    for r0 in range(0, H, step):
        r1 = min(r0 + step, H)
        values, weight = src.rows(r0, r1)
        v, w = values[:, :W].astype(np.float64), weight[:, :W].astype(np.float64)
        h = (r1 - r0) // 2
        total[r0 // 2 : r0 // 2 + h] = (v * w).reshape(h, 2, W // 2, 2, 3).sum((1, 3))
        count[r0 // 2 : r0 // 2 + h] = w.reshape(h, 2, W // 2, 2, 3).sum((1, 3))
    return white_scaled(np.where(count > 0, total / np.maximum(count, 1), 0.0) / src.info["neutral"])


def _detection_light(spec: CaptureSpec) -> str:
    """The named CIE illuminant the found chart's colours are checked under: the capture's when
    colour-science tabulates it, else D50 (the check allows a white-preserving matrix, so the light's
    colour matters little)."""
    import colour

    return spec.illuminant if spec.illuminant in colour.SDS_ILLUMINANTS else "D50"


def chart_of(spec: CaptureSpec, ws: Workspace) -> CaptureSpec:
    """``spec`` with ``[chart] corners`` known: as given, else the ones recorded in
    :data:`CHART_RECORD` for this file (same name, size and time), else found now and recorded.

    Raises
    ------
    CaptureError
        The chart was not found, or the detector is not installed (one line: why, and how to give
        the corners instead).
    """
    chart = spec.chart
    if chart is None or chart.corners is not None:
        return spec
    found = recorded_corners(spec, ws.root)
    if found is not None:
        return dataclasses.replace(spec, chart=ChartSpec(chart.image, found, found=True))
    from isp.profiles.chart import ChartError
    from isp.profiles.chart_detect import detect_chart_rgb, require_detector

    from .files import write_json
    from .workspace import file_stamp

    path = spec.root / chart.image
    name = Path(chart.image).as_posix()
    record = ws.path(CHART_RECORD)
    where = f"{spec.file}: [chart] image {chart.image!r}"
    try:
        require_detector(by_hand=_BY_HAND)
        camera = spec.cameras[spec.camera_index(chart.image.rsplit("/", 1)[0])]  # "<folder>/<file>"
        d = detect_chart_rgb(
            chart_preview(path, camera), illuminant=_detection_light(spec), path=where, by_hand=_BY_HAND
        )
    except ChartError as e:
        msg = str(e)
        raise CaptureError(msg if msg.startswith(where) else f"{where}: {msg}") from None
    corners = 2 * d.corners + 0.5  # preview pixel (u, v) is centred on RAW (2u + 0.5, 2v + 0.5)
    record.parent.mkdir(parents=True, exist_ok=True)
    write_json(
        record,
        {
            "image": name,
            "file": file_stamp(path),
            "corners": corners.tolist(),
            "delta_E": d.delta_E,
            "squares": d.squares,
            "found": "automatically (isp.profiles.chart_detect)",
        },
    )
    return dataclasses.replace(spec, chart=ChartSpec(chart.image, _corners(corners, record), found=True))


def recorded_corners(spec: CaptureSpec, out: Path) -> tuple[tuple[float, float], ...] | None:
    """The corners :func:`chart_of` found in ``[chart] image`` and recorded under ``out``; None when
    there is no record or it was made from another file (name, size or time)."""
    from .workspace import file_stamp, read_json

    record = Path(out) / CHART_RECORD
    if spec.chart is None or not record.is_file():
        return None
    doc = read_json(record, what="chart record")
    name = Path(spec.chart.image).as_posix()
    if doc.get("image") != name or doc.get("file") != file_stamp(spec.root / spec.chart.image):
        return None
    return _corners(doc.get("corners"), record)


def _corners(c, where: Path) -> tuple[tuple[float, float], ...]:
    a = np.asarray(c, dtype=np.float64)
    if a.shape != (4, 2) or not np.isfinite(a).all():
        raise CaptureError(f"{where}: not a splat chart record (corners); remove it.")
    return tuple((float(x), float(y)) for x, y in a)


def check_chart(spec: CaptureSpec, views: list[RawView]) -> None:
    """``[chart] image`` is one of the capture's views and its patch centres lie inside it; checked with
    the white box, as soon as the files are read (``spec`` from :func:`chart_of`).

    Raises
    ------
    CaptureError
        The image is no camera's view, or a patch centre falls outside it.
    """
    if spec.chart is None:
        return
    from isp.profiles.chart import chart_patch_centres

    v = next((v for v in views if v.name == Path(spec.chart.image).as_posix()), None)
    if v is None:
        raise CaptureError(
            f"{spec.file}: [chart].image {spec.chart.image!r} is not one of the capture's views."
        )
    if spec.chart.corners is None:
        raise CaptureError(f"{spec.file}: [chart] corners are not known yet (splat.capture.chart_of).")
    H, W = v.size
    xy = chart_patch_centres(spec.chart.corners, 4, 6)
    if not ((xy >= 0).all() and (xy[:, 0] < W).all() and (xy[:, 1] < H).all()):
        raise CaptureError(
            f"{spec.file}: [chart].corners {[list(c) for c in spec.chart.corners]} put patches outside the "
            f"{W}×{H} image; give the four corner patches' centres in the RAW file's pixels."
        )
