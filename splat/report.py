"""The capture report ``OUT/report.html``: per photograph, the corrected image beside the camera's own
development, how far a marked reference lies from its known colour, what was done, how long it took and
what to do next; the step summaries collapsed below, each explained in a sentence.

The page reads only what the pipeline wrote into ``OUT`` (and the capture's ``[white]`` card, which the
pipeline used too): a figure computed from a simulator's ground truth (``score.json``) appears only in the
diagnostics, labelled as such. Images are referenced relatively inside ``OUT``; the page needs no network
(collapsed parts are ``<details>`` elements). Below the photographs, the corrected scene in 3-D: the one
script of the page, :mod:`splat.viewer`, with the scene packed inside it (from ``OUT/correct/scene.npz``,
:func:`splat.export.prepare_scene`).

Why: a photographer opening the folder must see at once which image is the answer, how good it is where
that can be known, and what to do to make it better.
"""

from __future__ import annotations

import html
import json
from dataclasses import dataclass, field
from pathlib import Path
from urllib.parse import quote

import numpy as np

from ._tol import CARD_DELTA_E_FLOOR, REPORT_WHITE_TINT, UNCERTAINTY_PNG_MAX
from .capture import CaptureError, CaptureSpec
from .capture.workspace import read_json

__all__ = ["DIAGNOSTICS", "CardCheck", "card_check", "report_html", "write_report"]

#: The JSON files of ``OUT`` shown collapsed in the report, each with the sentence that explains it.
DIAGNOSTICS = (
    (
        "poses/summary.json",
        "Poses: how many photographs of each camera were placed in 3-D and from what source (COLMAP on "
        "the previews, or the capture's own poses), each photograph's relative exposure and its "
        "saturated or dead pixels.",
    ),
    (
        "train/summary.json",
        "Training: the Gaussian model fitted to every camera's RAW mosaics — steps, working size, "
        "Gaussians, the loss at the start and the end, and the residual noise per channel.",
    ),
    (
        "render/index.json",
        "Rendered views: each view's camera, kind (held-out photograph, photograph, novel view) and "
        "folder under render/ and correct/.",
    ),
    (
        "correct/summary.json",
        "Correction: the estimator, the noise tolerance δ and the rule that chose it, the white scale "
        "and the scene white (Y = 1).",
    ),
    (
        "correct/illuminant.json",
        'Scene light of illuminant = "estimate": the chosen candidate, from what (a marked card or '
        "rendered pixels), its angular uncertainty and the runners-up.",
    ),
    (
        "correct/white.json",
        "White scale: per camera, the divisor that puts raw responses on the scale where a perfect white "
        "gives 1, and how it was found (a marked card, or the brightest neutral surface).",
    ),
    (
        "correct/delta.json",
        "Noise tolerance δ: how far a sample of the rendered responses lies from the colours real "
        "surfaces can give (the object-colour solid), and the percentile that set δ.",
    ),
    (
        "correct/fusion.json",
        "Noise levels of the fused correction: each photograph's own sensor noise, the error of every "
        "camera's photographs reprojected into another view, and the render's error.",
    ),
    (
        "settings.json",
        "Settings record: per step, the options and inputs its results were made from; a change "
        "recomputes that step and the ones after it.",
    ),
    (
        "score.json",
        "Score against the simulator's ground truth (written by splat.scoring.score): exists only for "
        "simulated captures; the pipeline never reads it and nothing above is computed from it.",
    ),
)

_KIND = {"holdout": "photograph, held out of training", "view": "photograph", "novel": "novel view"}

_CSS = """
body{font:15px/1.4 system-ui,-apple-system,"Segoe UI",sans-serif;margin:0 auto;max-width:1400px;
 padding:0 20px;color:#1d1d1f;background:#fff}
header{padding:10px 0 6px;border-bottom:1px solid #ddd}
header h1{font-size:22px;margin:0 0 4px}
header p{margin:2px 0}
nav a{margin-right:10px}
section.photo{padding:10px 0 18px;border-bottom:1px solid #ddd}
section.photo h2{font-size:19px;margin:4px 0 8px}
section.photo h2 small{font-weight:normal;color:#555}
.pair{display:grid;grid-template-columns:1fr 1fr;gap:14px;align-items:start}
.pair figure{margin:0}
.frame{position:relative;margin:0 auto}
.frame img{display:block;width:100%;height:100%}
span.card{position:absolute;outline:2px solid #d00;box-shadow:0 0 0 3px rgba(255,255,255,.8)}
span.patch{position:absolute;outline:1px solid #fff;box-shadow:0 0 0 1px #000}
img.small{image-rendering:pixelated}
img.umap{display:block;width:min(100%,420px);image-rendering:pixelated;margin:4px 0}
figcaption{font-size:14px;margin-top:4px}
figcaption b{display:block}
.missing{display:flex;align-items:center;justify-content:center;min-height:200px;background:#f3f3f3;
 color:#555;padding:12px;text-align:center}
.facts{display:grid;grid-template-columns:1fr 1fr;gap:14px;margin:8px 0 4px}
.facts h3{font-size:15px;margin:6px 0 2px}
.facts p{margin:2px 0}
.facts ul{margin:0;padding-left:1.2em}
table{border-collapse:collapse;margin:2px 0}
td,th{border:1px solid #ccc;padding:2px 8px;text-align:right}
th{background:#f3f3f3}
td:first-child,th:first-child{text-align:left}
code{font-size:13px;background:#f3f3f3;padding:0 3px}
details{margin:6px 0}
summary{cursor:pointer}
pre{background:#f6f6f6;padding:8px;overflow:auto;font-size:12px;max-height:480px}
.others figure{display:inline-block;margin:4px 8px 4px 0;vertical-align:top;width:300px}
.others img{width:300px;height:auto}
"""


@dataclass
class CardCheck:
    """ΔE00 (CIE 2000) of the marked white card's mean colour against its known colour (the card's
    reflectance × the scene white), in the corrected image and in the camera's own development.

    Attributes
    ----------
    reflectance : float
    expected_Lab : ndarray of shape (3,)
    Lab, delta_E : dict
        ``"corrected"`` / ``"camera"`` → the box's mean L*a*b* (3,) and its ΔE00; a key is absent when
        that image is not in ``OUT``.
    """

    reflectance: float
    expected_Lab: np.ndarray
    Lab: dict = field(default_factory=dict)
    delta_E: dict = field(default_factory=dict)


def _read_tiff(path: Path) -> np.ndarray:
    import tifffile

    return np.asarray(tifffile.imread(path), np.float64)


def _tiff_pixels(path: Path) -> np.ndarray:
    """The pixels of a float32 TIFF without reading it whole where its data lie in one piece (the
    full-size outputs: 24 MP is 288 MB, and a chart needs 24 small boxes of it); else read."""
    import tifffile

    try:
        return tifffile.memmap(path, mode="r")
    except ValueError:  # compressed or in pieces
        return _read_tiff(path)


def card_check(
    spec: CaptureSpec, name: str, corrected: Path, camera: Path, white_XYZ, *, raw_size=None
) -> CardCheck | None:
    """The marked card of ``[white] method = "patch"`` seen in view ``name``, or None when no card was
    marked there.

    Parameters
    ----------
    corrected, camera : Path
        Linear XYZ images (H, W, 3), scene white at Y = 1: the corrected photograph and the camera's own
        development of its RAW file, at any size (the box is scaled to each).
    white_XYZ : array_like of shape (3,)
    raw_size : (H, W), optional
        The RAW file's size, whose pixel grid the box is given in; default: ``camera``'s size (the
        development at the file's own resolution). A box that falls outside an image leaves that
        image's key out, never a NaN.

    Why: the card is the one reference a real capture has; its colour is known from its reflectance
    alone, without any ground truth.
    """
    import colour

    w = spec.white
    if w.method != "patch" or w.image is None or Path(w.image).as_posix() != name:
        return None
    white_XYZ = np.asarray(white_XYZ, float)
    xy = colour.XYZ_to_xy(white_XYZ)
    expected = np.asarray(colour.XYZ_to_Lab(w.reflectance * white_XYZ, illuminant=xy))
    check = CardCheck(w.reflectance, expected)
    images = {key: _read_tiff(p) for key, p in (("corrected", corrected), ("camera", camera)) if p.is_file()}
    base = raw_size if raw_size is not None else (images["camera"].shape[:2] if "camera" in images else None)
    for key, img in images.items():  # each read once
        H, W = img.shape[:2]
        h0, w0 = base if base is not None else (H, W)
        x0, y0, x1, y1 = w.box
        sx, sy = W / w0, H / h0
        box = img[
            int(y0 * sy) : max(int(np.ceil(y1 * sy)), int(y0 * sy) + 1),
            int(x0 * sx) : max(int(np.ceil(x1 * sx)), int(x0 * sx) + 1),
        ]
        if box.size == 0:  # the box lies outside this image: nothing measured there
            continue
        mean = box.reshape(-1, 3).mean(0)
        lab = np.asarray(colour.XYZ_to_Lab(mean, illuminant=xy))
        check.Lab[key] = lab
        check.delta_E[key] = float(colour.delta_E(lab, expected, method="CIE 2000"))
    return check


@dataclass
class ChartCheck:
    """The marked ColorChecker (``[chart]``) in the photograph that shows it: each patch's known
    L*a*b* (its reflectance under the light the correction renders colours under, seen by the target
    observer) and its ΔE00 in the corrected image and in the camera's own development.

    Attributes
    ----------
    names : list of str
    expected_Lab : ndarray of shape (24, 3)
    delta_E : dict
        ``"corrected"`` / ``"full"`` / ``"camera"`` → ΔE00 per patch (24,), NaN where the patch's box
        falls outside that image; a key is absent when the image is not in ``OUT``.
    corners : tuple or None
        The corner patches' centres measured at (given, or found by the poses step); None when
        neither is known.
    boxes : list
        Each patch's box, ``(x0, y0, x1, y1)`` pixel edges in the RAW file's pixels.
    """

    names: list
    expected_Lab: np.ndarray
    delta_E: dict = field(default_factory=dict)
    corners: tuple | None = None
    boxes: list = field(default_factory=list)


def chart_check(
    spec: CaptureSpec,
    out: Path,
    name: str,
    corrected: Path,
    camera: Path,
    *,
    raw_size=None,
    full: Path | None = None,
) -> ChartCheck | None:
    """The ``[chart]`` ColorChecker measured in view ``name`` (None unless it is the chart's photograph).

    Each patch is read as the mean of a box around its centre (a quarter of the distance to the nearest
    patch centre on each side), in each image scaled from the RAW file's grid (``raw_size``,
    (H, W); default the camera development's size): the working-size ``corrected`` image, the same
    correction at the photograph's full size (``full``, when given and written) and the camera's own
    development. Its known colour is the chart's reflectance
    (colour-science's "ColorChecker N Ohta") seen through the correction's target: the capture's
    observer under the light colours are rendered under (``[reference]``, else the scene light,
    estimated or named), white Y = 1, the same as the corrected images'.

    Why: a chart of known reflectances is a reference a real capture can have for many colours, where
    the white card is one grey.
    """
    import colour

    import zonotope
    from isp.profiles.chart import chart_patch_centres

    from .capture.chart import recorded_corners
    from .capture.correct import correction_problem_of
    from .capture.illuminant import illuminant_of

    if spec.chart is None or Path(spec.chart.image).as_posix() != name:
        return None
    corners = spec.chart.corners or recorded_corners(spec, out)
    spec, _ = illuminant_of(spec, out)
    problem = correction_problem_of(spec, [0])  # the target: observer and rendering light, any camera
    msds = zonotope.reflectances("ColorChecker N Ohta")
    R = np.asarray(zonotope.resample(msds, problem.wavelengths), float).T  # (24, n)
    white = np.asarray(problem.white_XYZ, float)
    xy = colour.XYZ_to_xy(white)
    expected = np.asarray(colour.XYZ_to_Lab(problem.target_of(R) @ problem.XYZ_from_target, illuminant=xy))
    check = ChartCheck(list(msds.labels), expected, corners=corners)
    if corners is None:
        return check
    centres = chart_patch_centres(corners, 4, 6)  # (24, 2) x, y in RAW pixels
    gaps = np.linalg.norm(centres[:, None] - centres[None], axis=-1) + np.diag(np.full(len(centres), np.inf))
    reach = gaps.min(1) / 4  # a quarter of each patch's distance to its nearest: inside it under perspective
    # RAW pixel j spans edges [j, j + 1]: a box of half-width r about centre c spans c + ½ ± r
    check.boxes = [(x + 0.5 - r, y + 0.5 - r, x + 0.5 + r, y + 0.5 + r) for (x, y), r in zip(centres, reach)]
    for key, p in (("corrected", corrected), ("full", full), ("camera", camera)):
        if p is None or not p.is_file():
            continue
        img = _tiff_pixels(p)
        H, W = img.shape[:2]
        h0, w0 = raw_size if raw_size is not None else (H, W)
        sx, sy = W / w0, H / h0
        means = np.full((len(centres), 3), np.nan)
        # pixel j of the RAW grid is centred at j: at (j + ½)·s − ½ on a grid s times as fine
        for j, ((x, y), r) in enumerate(zip((centres + 0.5) * (sx, sy) - 0.5, reach, strict=True)):
            half = max(r * min(sx, sy), 0.5)
            y0, y1 = int(np.floor(y - half + 0.5)), int(np.floor(y + half + 0.5))
            x0, x1 = int(np.floor(x - half + 0.5)), int(np.floor(x + half + 0.5))
            if 0 <= y0 < y1 <= H and 0 <= x0 < x1 <= W:  # else outside this image: NaN
                means[j] = np.asarray(img[y0:y1, x0:x1], np.float64).reshape(-1, 3).mean(0)
        lab = np.asarray(colour.XYZ_to_Lab(means, illuminant=xy))
        check.delta_E[key] = np.asarray(colour.delta_E(lab, expected, method="CIE 2000"), float)
    return check


# ------------------------------------------------------------------------------------------- helpers


def _e(x) -> str:
    return html.escape(str(x))


def _src(out: Path, p: Path) -> str:
    return _e(quote(p.relative_to(out).as_posix()))


def _rel(out: Path, p: Path) -> str:
    return f"<code>{_e(p.relative_to(out).as_posix())}</code>"


def _duration(seconds) -> str:
    s = float(seconds)
    if s < 60:
        return f"{s:.0f} s" if s >= 10 else f"{s:.1f} s"
    if s < 3600:
        return f"{int(s // 60)} min {int(s % 60):02d} s"
    return f"{int(s // 3600)} h {int(s % 3600 // 60):02d} min"


def _size(p: Path) -> tuple[int, int] | None:
    from PIL import Image

    try:
        with Image.open(p) as im:
            return im.size
    except OSError:
        return None


def _figure(
    out: Path, path: Path | None, title: str, caption: str, missing: str, *, boxes=(), base=None
) -> str:
    """One image of a pair, as large as fits half the page and 48 % of the window's height; each of
    ``boxes`` ((x0, y0, x1, y1) pixel edges in an image of size ``base``, W × H, with its CSS class and
    title) is outlined on it."""
    if path is None or not path.is_file():
        return (
            f"<figure><div class='missing'>{_e(missing)}</div>"
            f"<figcaption><b>{_e(title)}</b></figcaption></figure>"
        )
    size = _size(path)
    if size is None:
        return f"<figure><div class='missing'>{_e(path.name)} is not a readable image.</div></figure>"
    W, H = size
    cls = " class='small'" if W < 600 else ""
    bw, bh = base or size
    marks = []
    for box, kind, tip in boxes:
        x0, y0, x1, y1 = (c * f for c, f in zip(box, (W / bw, H / bh, W / bw, H / bh)))
        marks.append(
            f"<span class='{kind}' title='{_e(tip)}' style='left:{100 * x0 / W:.3f}%;"
            f"top:{100 * y0 / H:.3f}%;width:{100 * (x1 - x0) / W:.3f}%;height:{100 * (y1 - y0) / H:.3f}%'>"
            "</span>"
        )
    frame = f"aspect-ratio:{W}/{H};width:min(100%,calc(48vh*{W}/{H}))"
    return (
        f"<figure><div class='frame' style='{frame}'><img{cls} src='{_src(out, path)}' alt='{_e(title)}'>"
        f"{''.join(marks)}</div><figcaption><b>{_e(title)} ({W}×{H} px)</b>{caption}</figcaption></figure>"
    )


def _raw_size(run: _Run, name: str, camera: str) -> tuple[int, int] | None:
    """``(H, W)`` of view ``name``'s RAW file as the correct step recorded it (its full-resolution
    output, else its camera's full size), or None when not recorded: the grid of ``[white] box``, which
    the working-resolution images are scaled from."""
    c = run.correct or {}
    for size in (
        ((c.get("full_resolution") or {}).get("per_view") or {}).get(name, {}).get("size"),
        ((c.get("working") or {}).get(camera) or {}).get("full"),
    ):
        if (
            isinstance(size, list | tuple)
            and len(size) == 2
            and all(isinstance(v, int) and v > 0 for v in size)
        ):
            return int(size[1]), int(size[0])
    return None


def _coverage(render_dir: Path, k: int | None) -> float | None:
    """Share of the view's pixels that at least one photograph of a camera other than ``k`` (of any
    camera when ``k`` is None) sees, or None when the render step wrote no counts."""
    import tifffile

    p = render_dir / "reprojected_count.tiff"
    if not p.is_file():
        return None
    try:
        count = tifffile.memmap(p, mode="r")
    except (ValueError, OSError):
        count = tifffile.imread(p)
    count = np.asarray(count[::2, ::2])  # every 4th pixel: a share to the percent
    others = [c for c in range(count.shape[-1]) if c != k]
    return float((count[..., others] > 0).any(-1).mean()) if others else None


def _fmt_sigma(s) -> str:
    return "(" + ", ".join(f"{float(x):.2g}" for x in np.ravel(s)) + ")"


def _json_or_none(path: Path):
    return read_json(path) if path.is_file() else None


# ---------------------------------------------------------------------------------------------- page


@dataclass
class _Run:
    """What the report reads once from ``OUT``."""

    spec: CaptureSpec
    out: Path
    poses: dict | None
    train: dict | None
    correct: dict | None
    fusion: dict | None
    index: dict
    default_steps: int

    @property
    def mname(self) -> str | None:
        return None if self.correct is None else str(self.correct["method"]).replace(" ", "")


def _step_doc(run: _Run, step: str) -> dict | None:
    """The step's summary JSON (``<step>/summary.json``), or None."""
    known = {"poses": run.poses, "train": run.train, "correct": run.correct}
    if step in known:
        return known[step]
    p = run.out / step / "summary.json"
    try:
        return _json_or_none(p)
    except CaptureError:
        return None


def _times(run: _Run) -> str:
    """Per step "took N s, peak M MiB" from its summary's ``duration_s`` (or ``seconds``) and
    ``peak_rss_mib``, whichever are recorded."""
    parts = []
    for step in ("poses", "train", "render", "correct"):
        doc = _step_doc(run, step)
        done = doc is not None or (step == "render" and bool(run.index))
        took = None if doc is None else doc.get("duration_s", doc.get("seconds"))
        rss = None if doc is None else doc.get("peak_rss_mib")
        bits = []
        if isinstance(took, int | float):
            bits.append(f"took {_duration(took)}")
        if isinstance(rss, int | float):
            bits.append(f"peak {float(rss):.0f} MiB")
        if bits:
            parts.append(f"{step} {', '.join(bits)}")
        else:
            parts.append(f"{step} {'time not recorded' if done else 'not run'}")
    return " · ".join(parts)


def _made(run: _Run, photo: tuple[int, int] | None) -> str:
    spec = run.spec
    cams = []
    for c in spec.cameras:
        reg = (run.poses or {}).get("cameras", {}).get(c.folder)
        cams.append(f"{_e(c.folder)} ({reg['registered']} of {reg['views']} placed)" if reg else _e(c.folder))
    bits = [f"{len(spec.cameras)} cameras: " + ", ".join(cams) + "."]
    if run.train is not None:
        W, H = run.train.get("size", [None, None])
        bits.append(
            f"Model: {run.train.get('gaussians')} Gaussians, {run.train.get('steps')} training steps on "
            f"{run.train.get('views')} photographs at {W}×{H} px, {run.train.get('channels')} channels."
        )
    if photo is not None:
        bits.append(f"This output: {photo[0]}×{photo[1]} px.")
    if run.correct is not None:
        bits.append(
            f"Colour: {_e(run.correct['method'])} estimator for the {_e(spec.observer)}, white from "
            + (
                "the marked card"
                if spec.white.method == "patch"
                else "the brightest neutral surface (assumed a perfect white)"
            )
            + "."
        )
        est = {f: d for f, d in (run.correct.get("ssf") or {}).items() if "estimated" in d}
        if est:
            bits.append(
                "Sensitivities not measured: estimated from the "
                + ", ".join(
                    f"{_e(d['estimated'])} of {_e(f)} ({_e(d['file'])}, response σ "
                    f"{_per_channel(d['sigma'], 3)})"
                    for f, d in est.items()
                )
                + "; the fit is told that σ as noise."
            )
        unit = {
            f: d
            for f, d in (run.correct.get("ssf") or {}).items()
            if "measured" in d and any(d.get("sigma") or ())
        }
        if unit:
            bits.append(
                "Published sensitivities of "
                + ", ".join(_e(f) for f in unit)
                + ": measured on another unit of the model, so the fit is told the spread between units "
                f"(response σ {_per_channel(next(iter(unit.values()))['sigma'], 3)}); "
                "<code>ssf_exact = true</code> if they were measured on this very camera."
            )
        levels = np.asarray((run.correct.get("white") or {}).get("levels") or [], float)
        tinted = [
            (run.spec.cameras[k].folder, lv)
            for k, lv in enumerate(levels.reshape(-1, 3))
            if k < len(run.spec.cameras) and np.ptp(np.log(lv)) > np.log(REPORT_WHITE_TINT)
        ]
        if tinted:  # a white per channel corrected by more than a few per cent: say by how much
            bits.append(
                "White per channel measured against the other cameras' photographs: "
                + ", ".join(f"{_e(f)} × {_per_channel(lv / lv[1], 2)}" for f, lv in tinted)
                + " (R / G / B, relative to G) of what its sensitivities gave."
            )
        loose = (run.correct.get("white") or {}).get("from_curves") or []
        if loose:
            bits.append(
                "<strong>The white of "
                + ", ".join(_e(f) for f in loose)
                + " rests on its sensitivities alone</strong>: no plain surface was seen by both it and "
                "another camera, where its level per channel would be measured, and published or estimated "
                "curves can put a camera's channels 5–25 % apart, which its colours then carry. Include a "
                "plain surface (the white card, a wall) that every camera sees, or say "
                "<code>ssf_exact = true</code> if its curves were measured on this very camera."
            )
        light = run.correct.get("illuminant")
        if light:
            est = light.get("estimate")
            how = ""
            if est:
                unc = est.get("angular_uncertainty_deg")
                src = {"grey card": "the marked card"}.get(est["method"], "the rendered pixels")
                how = f" (estimated from {src}" + ("" if unc is None else f", ±{unc:.1f}°") + ")"
            bits.append(f"Light: {_e(light['light'])}{how}; colours as under {_e(light['reference'])}.")
    return " ".join(bits)


def _per_channel(values, digits: int) -> str:
    """``"a / b / c"``: one number per channel (R / G / B)."""
    return " / ".join(f"{float(v):.{digits}f}" for v in values)


def _noise(run: _Run, name: str, fused: bool, cdir: Path, raw_size: tuple[int, int] | None = None) -> str:
    c = run.correct
    if c is None:
        return "Not corrected yet."
    f = run.fusion or {}
    v = f.get("views", {}).get(name)
    if fused and v is not None:
        k = v["camera"]
        others = [
            f"{float(s):.2g} ({_e(run.spec.cameras[j].folder)})"
            for j, s in enumerate(f.get("reprojected_sigma") or [])
            if j != k
        ]
        return (
            f"<p>Noise assumed (white = 1): own channels σ = {_fmt_sigma(v['own_sigma'])}, measured in "
            "this RAW file; the other cameras' photographs reprojected here σ = "
            f"{', '.join(others) or 'none'}, from their error against each camera's own views; the model's "
            f"render σ = {float(f['render_sigma']):.2g}, from its error against the photographs.</p>"
            f"{_uncertainty(run, cdir, raw_size)}"
        )
    if fused and f.get("reprojected_sigma"):  # a novel view corrected from the photographs
        every = [
            f"{float(x):.2g} ({_e(run.spec.cameras[j].folder)})" for j, x in enumerate(f["reprojected_sigma"])
        ]
        return (
            "<p>Noise assumed (white = 1): the photographs reprojected here σ = "
            f"{', '.join(every)}, from their error against each camera's own views; the model's render "
            f"σ = {float(f['render_sigma']):.2g}, from its error against the photographs.</p>"
            f"{_uncertainty(run, cdir)}"  # a novel view has no full-size photograph
        )
    return (
        f"<p>Noise tolerance δ = {float(c['delta']):.3g} (white = 1): the "
        f"{_e(c['noise'].get('rule', ''))}; the model's training residual "
        f"{float(c.get('training_residual', float('nan'))):.2g}.</p>"
        "<p>No per-pixel uncertainty map is written.</p>"
    )


def _uncertainty(run: _Run, cdir: Path, raw_size: tuple[int, int] | None = None) -> str:
    """The fused correction's per-pixel uncertainty map (``<method>_fused_uncertainty``), or a line
    saying there is none. Where the photograph's size ``raw_size`` ``(H, W)`` is not the map's, the
    page says that the map is of the working answer: a reader must not take it for the full-size
    photograph's."""
    m = run.mname
    tiff, png = (cdir / f"{m}_fused_uncertainty.{ext}" for ext in ("tiff", "png"))
    if m is None or not (tiff.is_file() and png.is_file()):
        return "<p>No per-pixel uncertainty map was written for this view.</p>"
    r = _read_tiff(tiff)
    h, w = r.shape[:2]
    r = r[np.isfinite(r)]
    if not r.size:
        return "<p>The uncertainty map of this view holds no value.</p>"
    working = ""
    if raw_size is not None and tuple(raw_size) != (h, w):
        working = (
            f" The map is of the working answer ({w}×{h} px), where each pixel averages a block of "
            f"the RAW file; the {raw_size[1]}×{raw_size[0]} px photograph, read pixel by pixel, has "
            "no map of its own."
        )
    return (
        "<p><b>Uncertainty per pixel</b> (the map below; dark purple 0, yellow ≥ "
        f"{UNCERTAINTY_PNG_MAX:g} ΔE00): the radius around each corrected colour within which the true "
        "colour lies with 95 % probability, for natural surfaces seen with the noise above. It grows "
        "where the cameras cannot tell surfaces apart, where only one camera or the model saw the "
        "pixel, and where the model disagrees with this photograph around the pixel; it does not know "
        "of errors the photograph cannot show. Median "
        f"{np.median(r):.2g} ΔE00, 90th percentile {np.percentile(r, 90):.2g}; {np.mean(r <= 2.0):.0%} "
        f"of the pixels within 2 ΔE00.{working}</p>"
        f"<img class='umap' src='{_src(run.out, png)}' alt='uncertainty map' "
        "title='95 % credible radius per pixel, ΔE00'>"
    )


def _chart_reference(run: _Run, chart: ChartCheck) -> str:
    """The marked ColorChecker's ΔE00 per patch in both images: mean and largest up front, every patch
    in a collapsed table."""
    got = {k: v for k, v in chart.delta_E.items() if np.isfinite(v).any()}
    if chart.corners is None:
        return (
            "<p>The marked ColorChecker's corners are not known yet: <code>splat run</code> finds them "
            "(or give <code>[chart] corners</code> in capture.toml).</p>"
        )
    if not got:
        return (
            "<p>The marked ColorChecker's patches fall outside this photograph's images; check "
            "<code>[chart] corners</code> in capture.toml.</p>"
        )
    labels = (
        ("corrected", "corrected (left)"),
        ("full", "corrected, full size"),
        ("camera", "camera's development (right)"),
    )
    rows = "".join(
        f"<tr><td>{label}</td><td>{np.nanmean(got[k]):.2f}</td><td>{np.nanmax(got[k]):.2f}</td>"
        f"<td>{int(np.isfinite(got[k]).sum())}</td></tr>"
        for k, label in labels
        if k in got
    )
    ratio = ""
    if {"corrected", "camera"} <= set(got) and np.nanmean(got["camera"]) > CARD_DELTA_E_FLOOR:
        times = np.nanmean(got["corrected"]) / np.nanmean(got["camera"])
        full = ""
        if "full" in got:
            full = f" ({np.nanmean(got['full']) / np.nanmean(got['camera']):.2f}× at full size)"
        ratio = f"The corrected image's mean is {times:.2f}× the camera's{full}. "
    where = (
        "Its corners were found in the photograph (recorded in <code>poses/chart.json</code>); if the "
        "boxes on the images miss the patches, give <code>[chart] corners</code> in capture.toml."
        if run.spec.chart is not None and (run.spec.chart.corners is None or run.spec.chart.found)
        else "The boxes on the images show where each patch was read."
    )
    head = "".join(f"<th>{_e(lb)}</th>" for k, lb in labels if k in got)
    patches = "".join(
        f"<tr><td>{_e(n)}</td><td>{L:.1f}, {a:+.1f}, {b:+.1f}</td>"
        + "".join(f"<td>{got[k][j]:.2f}</td>" for k, _ in labels if k in got)
        + "</tr>"
        for j, (n, (L, a, b)) in enumerate(zip(chart.names, np.round(chart.expected_Lab, 1) + 0.0))
    )
    return (
        "<p>Marked ColorChecker (<code>[chart]</code>; its 24 patches' known colours under the light the "
        "colours are rendered under), ΔE00 per patch:</p>"
        "<table><tr><th>image</th><th>mean ΔE00</th><th>largest</th><th>patches</th></tr>"
        f"{rows}</table><p>{ratio}The chart took no part in the correction. {where}</p>"
        "<details><summary>Every patch (known L*a*b*, ΔE00)</summary><table><tr><th>patch</th>"
        f"<th>known L*a*b*</th>{head}</tr>{patches}</table></details>"
    )


def _reference(run: _Run, name: str, check: CardCheck | None, chart: ChartCheck | None = None) -> str:
    if chart is not None:
        return _chart_reference(run, chart) + (_reference(run, name, check) if check is not None else "")
    if check is None:
        where = []
        if run.spec.chart is not None:
            where.append(f"the marked ColorChecker is in <code>{_e(run.spec.chart.image)}</code>")
        if run.spec.white.method == "patch":
            where.append(f"the marked white card is in <code>{_e(run.spec.white.image)}</code>")
        if where:
            return (
                f"<p>No reference in this photograph ({'; '.join(where)}): accuracy here is not measured.</p>"
            )
        return (
            "<p>No reference in the capture (no marked white card or ColorChecker): accuracy is not "
            "measured.</p>"
        )
    rows = []
    for key, label in (("corrected", "corrected (left)"), ("camera", "camera's development (right)")):
        if key in check.delta_E:
            L, a, b = np.round(check.Lab[key], 1) + 0.0  # no "-0.0"
            rows.append(
                f"<tr><td>{label}</td><td>{L:.1f}, {a:+.1f}, {b:+.1f}</td>"
                f"<td>{check.delta_E[key]:.2f}</td></tr>"
            )
    L, a, b = np.round(check.expected_Lab, 1) + 0.0
    return (
        f"<p>Marked white card (outlined in red; reflectance {check.reflectance:g}, box "
        f"{list(run.spec.white.box)} px of this photograph), known L*a*b* {L:.1f}, {a:+.1f}, {b:+.1f}:</p>"
        "<table><tr><th>image</th><th>card mean L*a*b*</th><th>ΔE00</th></tr>"
        + "".join(rows)
        + f"</table><p>{_gain(check)}The card set the white of both images, and it is one grey patch: it "
        "measures how neutral a white stays, not how accurate other colours are.</p>"
    )


def _gain(check: CardCheck) -> str:
    """The corrected image's ΔE00 on the card as a multiple of the camera development's, when both exist
    and the latter is not ~0 (a ratio to nothing says nothing)."""
    d = check.delta_E
    if "corrected" not in d or "camera" not in d or d["camera"] < CARD_DELTA_E_FLOOR:
        return ""
    return f"On the card the corrected image's ΔE00 is {d['corrected'] / d['camera']:.2f}× the camera's. "


def _worse_than_camera(name: str, chart: ChartCheck | None) -> str | None:
    """A warning when the marked chart puts the photograph to keep (the full-size one, else the working
    answer) further from the patches' known colours than the camera's own development; else None.
    Why: the page's first advice is to keep the corrected photograph, which the one reference of many
    colours then contradicts (an under-trained model, a wrong white or wrong curves)."""
    if chart is None or "camera" not in chart.delta_E:
        return None
    key = "full" if "full" in chart.delta_E else "corrected"
    ours, theirs = chart.delta_E.get(key), chart.delta_E["camera"]
    if ours is None or not (np.isfinite(ours).any() and np.isfinite(theirs).any()):
        return None
    ours, theirs = float(np.nanmean(ours)), float(np.nanmean(theirs))
    if ours <= theirs:
        return None
    return (
        f"<strong>On the marked chart the corrected photograph is worse than the camera's own "
        f"development</strong> (mean ΔE00 {ours:.2f} against {theirs:.2f}): for this photograph prefer "
        f"the development (<code>isp develop {_e(name)} -o {_e(Path(name).stem)}.tiff</code> in the capture "
        "folder) until the model is better — train longer, "
        "and check the marked white card and each camera's <code>ssf</code>."
    )


def _next(
    run: _Run,
    name: str,
    info: dict,
    answer: Path | None,
    coverage: float | None,
    raw_size=None,
    chart: ChartCheck | None = None,
) -> list[str]:
    todo = []
    worse = _worse_than_camera(name, chart)
    if worse is not None:
        todo.append(worse)
    full = None if answer is None else answer.parent / "full_XYZ.tiff"
    if full is not None and full.is_file():  # the photograph at its own size: what to keep
        at = f" ({raw_size[1]} × {raw_size[0]} px, the RAW file's size)" if raw_size is not None else ""
        png = _rel(run.out, full.with_name("full_sRGB.png"))
        keep = "Keep the corrected photograph" if worse is None else "The corrected photograph is"
        todo.append(
            f"{keep} at full size{at}: {png} (8-bit sRGB) or {_rel(run.out, full)} "
            "(linear XYZ, float32, scene white Y = 1). The images above are at the working size."
        )
    if answer is not None:
        tiff = answer.with_suffix(".tiff")
        xyz = answer.with_name(answer.name.replace("_sRGB.png", "_XYZ.tiff"))
        todo.append(
            f"Use {_rel(run.out, tiff)} (16-bit sRGB) or, for further editing, {_rel(run.out, xyz)} "
            "(linear XYZ, scene white Y = 1)."
        )
    else:
        todo.append("Run <code>splat correct</code> (or <code>splat run</code>) to correct this view.")
    if info["kind"] == "novel":
        todo.append("This view was not photographed: for accurate colour use the photographs' sections.")
    if run.spec.white.method != "patch":
        todo.append(
            'Mark a white card in <code>capture.toml</code> (<code>[white] method = "patch"</code>, '
            "<code>image</code>, <code>box</code>, <code>reflectance</code>): the white is now the "
            "brightest neutral surface, and the card gives this report a reference."
        )
    if coverage is not None and coverage < 0.5:
        whose = "the other cameras" if info["kind"] != "novel" else "every camera"
        todo.append(
            f"Take more photographs of this part of the scene with {whose}: photographs see "
            f"{coverage:.0%} of this view; elsewhere its channels come from the model."
        )
    sat = (run.poses or {}).get("saturated", {}).get(name)
    if sat:
        todo.append(f"Expose less: {sat} pixels of this photograph are saturated.")
    steps = (run.train or {}).get("steps")
    if steps is not None and steps < run.default_steps:
        todo.append(f"Train longer (<code>--steps {run.default_steps}</code>): the model had {steps} steps.")
    return todo


def _others(run: _Run, cdir: Path, rdir: Path, used: set) -> str:
    figs = []
    m = run.mname
    candidates = []
    if m is not None:
        candidates.append(
            (cdir / f"{m}_sRGB.png", "Corrected from the model's render alone (no photograph).")
        )
    for k, c in enumerate(run.spec.cameras):
        candidates.append(
            (
                cdir / f"dng_{run.spec.label(k)}_sRGB.png",
                f"The model's {c.folder} channels developed with that camera's colour matrix.",
            )
        )
    candidates.append((rdir / "pca.png", "False colour of the model's channels (their 3 main components)."))
    for p, text in candidates:
        if p.is_file() and p not in used:
            figs.append(
                f"<figure><img class='small' src='{_src(run.out, p)}' alt='{_e(p.name)}'><figcaption>"
                f"{_e(text)} {_rel(run.out, p)}</figcaption></figure>"
            )
    if not figs:
        return ""
    return (
        f"<details class='others'><summary>Other images of this view ({len(figs)})</summary>"
        f"{''.join(figs)}</details>"
    )


def _section(run: _Run, i: int, name: str, info: dict) -> str:
    spec, out = run.spec, run.out
    cdir, rdir = out / "correct" / info["dir"], out / "render" / info["dir"]
    k = spec.camera_index(info["camera"])
    m = run.mname
    answer, fused = None, False
    if m is not None:
        for stem, is_fused in ((f"{m}_fused", True), (m, False)):
            if (cdir / f"{stem}_sRGB.png").is_file():
                answer, fused = cdir / f"{stem}_sRGB.png", is_fused
                break
    photographed = info["kind"] != "novel"
    if fused and photographed:
        how = f"{_e(run.correct['method'])}, from this RAW file and the other cameras' photographs."
    elif fused:
        how = f"{_e(run.correct['method'])}, from the photographs reprojected into this view."
    elif answer is not None:
        how = f"{_e(run.correct['method'])}, from the model's render."
    else:
        how = ""
    photo = _size(answer) if answer is not None else None
    coverage = _coverage(rdir, k if photographed else None)
    check = None
    raw_size = _raw_size(run, name, info["camera"])
    if answer is not None and photographed and run.correct is not None:
        check = card_check(
            spec,
            name,
            answer.with_name(answer.name.replace("_sRGB.png", "_XYZ.tiff")),
            cdir / "raw_dng_XYZ.tiff",
            run.correct["white_XYZ"],
            raw_size=raw_size,
        )
    chart = None
    if answer is not None and photographed and run.correct is not None:
        chart = chart_check(
            spec,
            out,
            name,
            answer.with_name(answer.name.replace("_sRGB.png", "_XYZ.tiff")),
            cdir / "raw_dng_XYZ.tiff",
            raw_size=raw_size,
            full=cdir / "full_XYZ.tiff" if fused else None,
        )
    right_p = cdir / ("raw_dng_sRGB.png" if photographed else f"dng_{spec.label(k)}_sRGB.png")
    boxes = []  # given in the RAW file's pixels (W × H for the figures)
    if check is not None:
        boxes.append((spec.white.box, "card", "marked white card"))
    if chart is not None:
        boxes += [(b, "patch", f"ColorChecker patch: {n}") for b, n in zip(chart.boxes, chart.names)]
    marks = {}
    if boxes:
        base = raw_size[::-1] if raw_size is not None else None
        marks = {"boxes": boxes, "base": base or (_size(right_p) if right_p.is_file() else photo)}
    left = _figure(out, answer, "Corrected — the answer", f" {how}", "Not corrected yet.", **marks)
    if photographed:
        right = _figure(
            out,
            right_p,
            f"The camera's own development ({info['camera']})",
            " This RAW file, its DNG colour matrix, the same white.",
            "No camera development: the RAW file carries no colour matrix.",
            **marks,
        )
    else:
        right = _figure(
            out,
            right_p,
            f"The model seen as {info['camera']}",
            " Its channels for this camera, developed with that camera's colour matrix.",
            "No development of this view.",
        )
    made = _made(run, photo)
    if coverage is not None:
        whose = "Other cameras' photographs" if photographed else "Photographs"
        made += f" {whose} see {coverage:.0%} of this view."
    todo = "".join(f"<li>{t}</li>" for t in _next(run, name, info, answer, coverage, raw_size, chart))
    facts = (
        f"<div><h3>Accuracy</h3>{_reference(run, name, check, chart)}"
        f"{_noise(run, name, fused, cdir, raw_size)}</div>"
        f"<div><h3>Next</h3><ul>{todo}</ul><h3>What was done</h3><p>{made}</p>"
        f"<h3>Time</h3><p>{_times(run)}</p></div>"
    )
    used = {p for p in (answer, right_p) if p is not None}
    return (
        f"<section class='photo' id='view-{i}'><h2>{_e(name)} "
        f"<small>{_e(_KIND.get(info['kind'], info['kind']))}</small></h2>"
        f"<div class='pair'>{left}{right}</div><div class='facts'>{facts}</div>"
        f"{_others(run, cdir, rdir, used)}</section>"
    )


def _scene(run: _Run) -> str:
    """The section with the interactive view of the corrected scene (:mod:`splat.viewer`), from
    :data:`splat.viewer.SCENE` when it belongs to the trained model; otherwise how to make it."""
    from .viewer import SCENE, viewer_html

    out = run.out
    model = out / "train" / "model.npz"
    if not model.is_file() or run.correct is None:
        return ""
    head = "<section id='scene'><h2>The corrected scene in 3-D</h2>"
    hint = (
        f"{head}<p>No interactive view yet: <code>splat export OUT --capture CAPTURE --ply scene.ply</code> "
        "corrects every Gaussian's colour (as <code>splat run</code> does before the report), writes the "
        "scene for any 3DGS viewer, and the next report shows it here.</p></section>"
    )
    try:
        with np.load(out / SCENE, allow_pickle=False) as z:
            doc = {k: z[k] for k in z.files}
        st = model.stat()
        if [int(v) for v in doc["model_stamp"]] != [st.st_size, st.st_mtime_ns]:
            return hint  # made from another model
        with np.load(model, allow_pickle=False) as m:
            alive = np.asarray(m["alive"], bool)
            arrays = {k: np.asarray(m[k])[alive] for k in ("means", "quats", "log_scales", "opacity_logits")}
        rgb = np.asarray(doc["sRGB"], float)
        cams = [
            {"name": n, "R": R, "t": t, "focal": f, "principal": c, "size": s}
            for n, R, t, f, c, s in zip(
                doc["camera_names"],
                doc["camera_R"],
                doc["camera_t"],
                doc["camera_focal"],
                doc["camera_principal"],
                doc["camera_size"],
            )
        ]
    except (OSError, ValueError, KeyError):
        return hint
    if len(rgb) != len(arrays["means"]) or not cams:
        return hint
    caption = (
        f"The {len(rgb)} Gaussians of the model, each coloured by its own channels corrected with "
        f"{_e(str(doc['method']))} (the estimator of the images above) and shown in sRGB; the view starts "
        f"at {_e(cams[0]['name'])} and the arrows step through the {len(cams)} placed photographs. A splat "
        "viewer blends the Gaussians' corrected colours, not corrected pixels: for colour, use the images "
        "above."
    )
    return f"{head}{viewer_html(arrays, rgb, cams, caption=caption)}</section>"


def _diagnostics(out: Path) -> str:
    parts = ["<section id='diagnostics'><h2>Diagnostics</h2>"]
    for rel, text in DIAGNOSTICS:
        p = out / rel
        if not p.is_file():
            continue
        try:
            body = json.dumps(json.loads(p.read_text()), indent=1)
        except (OSError, UnicodeDecodeError, json.JSONDecodeError):
            body = "(not readable as JSON)"
        parts.append(
            f"<details><summary><code>{_e(rel)}</code> — {_e(text)}</summary><pre>{_e(body)}</pre></details>"
        )
    parts.append("</section>")
    return "".join(parts)


def report_html(spec: CaptureSpec, out: str | Path, index: dict, *, default_steps: int = 3000) -> str:
    """The report page of the run in ``out`` (see the module notes).

    Parameters
    ----------
    spec : CaptureSpec
    out : path
        The run's output folder; image sources are relative to it.
    index : dict
        The checked render index (view name → {camera, kind, dir}); empty when nothing was rendered.
    default_steps : int
        Training steps below which the page advises training longer (the pipeline's default).
    """
    out = Path(out)
    run = _Run(
        spec,
        out,
        _json_or_none(out / "poses" / "summary.json"),
        _json_or_none(out / "train" / "summary.json"),
        _json_or_none(out / "correct" / "summary.json"),
        _json_or_none(out / "correct" / "fusion.json"),
        index,
        default_steps,
    )
    return _page(run)


def _page(run: _Run) -> str:
    spec = run.spec
    n_photo = sum(1 for v in run.index.values() if v["kind"] != "novel")
    n_novel = len(run.index) - n_photo
    method = f"corrected with {_e(run.correct['method'])}" if run.correct is not None else "not corrected yet"
    lead = (
        f"{n_photo} photograph{'s' if n_photo != 1 else ''}"
        + (f" and {n_novel} novel view{'s' if n_novel != 1 else ''}" if n_novel else "")
        + f" from {len(spec.cameras)} cameras ({', '.join(_e(c.folder) for c in spec.cameras)}), "
        f"{method}. In each section the corrected image (left, the file to use) stands "
        "beside the camera's own development (right). Time: " + _times(run) + "."
    )
    nav = " ".join(f"<a href='#view-{i}'>{_e(n)}</a>" for i, n in enumerate(run.index))
    body = [
        "<!doctype html><html lang='en'><head><meta charset='utf-8'>",
        f"<title>splat report: {_e(spec.root.name)}</title><style>{_CSS}</style></head><body>",
        f"<header><h1>Capture report: {_e(spec.root)}</h1><p>{lead}</p>",
        f"<nav><details><summary>All views ({len(run.index)})</summary>{nav}</details></nav>"
        if len(run.index) > 1
        else "",
        "</header>",
    ]
    if not run.index:
        body.append(
            "<section class='photo'><h2>Nothing rendered yet</h2><p>Run "
            "<code>splat run CAPTURE -o OUT</code> (or the render and correct steps) and then this "
            "report again.</p></section>"
        )
    for i, (name, info) in enumerate(run.index.items()):
        body.append(_section(run, i, name, info))
    body.append(_scene(run))
    body.append(_diagnostics(run.out))
    body.append("</body></html>")
    return "\n".join(body)


def write_report(spec: CaptureSpec, out: str | Path, index: dict, *, default_steps: int = 3000) -> Path:
    """Write :func:`report_html` to ``out/report.html`` atomically (a reader never sees half a page);
    returns the path."""
    from zonotope.utilities import atomic_write_text

    path = Path(out) / "report.html"
    atomic_write_text(path, report_html(spec, out, index, default_steps=default_steps))
    return path
