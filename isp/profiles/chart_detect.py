"""Find a ColorChecker Classic in a photograph, so that ``isp profile --chart`` needs no corners.

The patches are segmented by colour-science's ``colour-checker-detection`` (the optional
``chart`` extra, on OpenCV): its default segmenter finds square, near-uniform regions and groups
them into candidate charts. The rest is this module's: the 4 × 6 grid is fitted to the segmented
squares of each candidate (a homography from the patch indices to their centres, so perspective
is allowed), and the chart's orientation (rotated by 180°, mirrored, or seen with its rows and
columns swapped) is chosen by fitting the patch means to the reference chart's colours
(:func:`isp.profiles.chart.fit_chart`): the one orientation that gives a ColorChecker's colours.

A detection is accepted only if the chart is consistent: its six neutral patches grow darker
from white to black and the white-preserving least-squares matrix reproduces the 24 reference
colours within :data:`isp._tol.CHART_DETECT_MAX_DE` (mean ΔE00). Otherwise :class:`ChartError`
says the chart was not found and to give the corners by hand.

Limits: the chart must be a ColorChecker Classic (or the Classic side of a Passport), its patches
unobstructed and not clipped, most of their edges visible to the segmenter (a chart seen at a
grazing angle or badly out of focus is not found). Synthetic scenes
(``benchmarks/bench_chart_detect.py``): found in 40 of 40 at a patch pitch of 30–65 px in the searched
image (a RAW file's half resolution), 8 of 12 at 12–20 px.
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass

import numpy as np

from .._tol import (
    CHART_BOX,
    CHART_DETECT_AREA,
    CHART_DETECT_CELL,
    CHART_DETECT_LINK,
    CHART_DETECT_MAX_DE,
    CHART_DETECT_MIN_SQUARES,
    CHART_DETECT_PATCH,
    CHART_DETECT_SHIFT,
    CHART_DETECT_SIMILAR,
    CHART_DETECT_WHITE_PERCENTILE,
)
from .chart import ChartError, ChartReading, _chart_type, fit_chart

__all__ = [
    "ChartDetection",
    "detect_chart",
    "detect_chart_rgb",
    "raw_preview",
    "require_detector",
    "white_scaled",
]

#: What to tell a user whose chart was not found (every failure ends with it).
_BY_HAND = (
    "give --chart-corners X,Y X,Y X,Y X,Y (the centres of the top-left, top-right, bottom-right and "
    "bottom-left patches)"
)


@dataclass(frozen=True, eq=False)
class ChartDetection:
    """A chart found in an image.

    Attributes
    ----------
    corners : ndarray of shape (4, 2)
        (x, y) centres of patches 1, 6, 24 and 19 (top-left, top-right, bottom-right and
        bottom-left of the chart as printed), in the frame of the image searched (for
        :func:`detect_chart`, the RAW file's mosaic: what ``--chart-corners`` takes).
    centres : ndarray of shape (24, 2)
        (x, y) of every patch centre, patch 1 first, same frame.
    delta_E : float
        Mean ΔE00 of the white-preserving least-squares fit of the patch means to the reference.
    angle : float
        Direction from patch 1 to patch 6 in degrees, counter-clockwise from the image's x axis
        (0: the chart upright, ±180: upside down).
    mirrored : bool
        Whether the chart is seen mirrored (patch 19 clockwise of patch 6 from patch 1).
    squares : int
        Segmented squares the grid was fitted to.
    """

    corners: np.ndarray
    centres: np.ndarray
    delta_E: float
    angle: float
    mirrored: bool
    squares: int

    def corner_args(self) -> str:
        """The corners as ``--chart-corners`` takes them (``X,Y X,Y X,Y X,Y``, rounded to 0.1 px)."""
        return " ".join(f"{x:.1f},{y:.1f}" for x, y in self.corners)


def require_detector(*, by_hand: str = _BY_HAND) -> None:
    """Raise :class:`ChartError` (one line: how to install it, or ``by_hand``, how to give the corners)
    when the optional ``colour-checker-detection`` package is missing, before any long work."""
    _detector(by_hand)


def _detector(by_hand: str = _BY_HAND):
    try:
        from colour_checker_detection import SETTINGS_SEGMENTATION_COLORCHECKER_CLASSIC, segmenter_default
    except ImportError:
        raise ChartError(
            "finding the chart automatically needs the package colour-checker-detection: pip install "
            f"'zonotope[chart]', or {by_hand}."
        ) from None
    return segmenter_default, SETTINGS_SEGMENTATION_COLORCHECKER_CLASSIC


def raw_preview(raw) -> np.ndarray:
    """The half-resolution linear camera RGB of a Bayer RAW image, white-balanced, white ≈ 1.

    Each 2 × 2 CFA block becomes one pixel (its R, mean G, B; black level subtracted, divided by
    the as-shot neutral); pixel (u, v) is centred on mosaic position (2u + 0.5, 2v + 0.5). Scaled so
    that the :data:`isp._tol.CHART_DETECT_WHITE_PERCENTILE` percentile of the green is 1.
    """
    from ..cfa import cfa_masks

    m = np.asarray(raw.mosaic, dtype=np.float64)
    H, W = (s // 2 * 2 for s in m.shape)
    m = m[:H, :W] - np.tile(np.asarray(raw.black_level, dtype=np.float64), (H // 2, W // 2))
    masks = cfa_masks((H, W), raw.cfa)
    out = np.zeros((H // 2, W // 2, 3))
    for ch in range(3):
        site = masks[..., ch]
        total = (m * site).reshape(H // 2, 2, W // 2, 2).sum((1, 3))
        out[..., ch] = total / site.reshape(H // 2, 2, W // 2, 2).sum((1, 3))
    out /= np.asarray(raw.as_shot_neutral, dtype=np.float64)
    return white_scaled(out)


def white_scaled(rgb: np.ndarray) -> np.ndarray:
    """White-balanced linear ``rgb`` on the scale :func:`detect_chart_rgb` expects: divided by the
    :data:`isp._tol.CHART_DETECT_WHITE_PERCENTILE` percentile of its green (white ≈ 1), clipped at 0."""
    top = np.percentile(rgb[..., 1], CHART_DETECT_WHITE_PERCENTILE)
    return np.clip(rgb / top, 0, None) if top > 0 else rgb


def _homography(src, dst) -> np.ndarray:
    """Least-squares homography (h₃₃ = 1) taking the (x, y) points ``src`` to ``dst``."""
    A, b = [], []
    for (u, v), (x, y) in zip(src, dst, strict=True):
        A += [[u, v, 1, 0, 0, 0, -u * x, -v * x], [0, 0, 0, u, v, 1, -u * y, -v * y]]
        b += [x, y]
    h = np.linalg.lstsq(np.array(A), np.array(b), rcond=None)[0]
    return np.append(h, 1.0).reshape(3, 3)


def _apply(H, pts) -> np.ndarray:
    """The (x, y) points ``pts`` through the homography ``H`` (non-finite where it sends them to
    infinity: such a grid fails the checks that follow)."""
    p = np.column_stack([pts, np.ones(len(pts))]) @ H.T
    with np.errstate(divide="ignore", invalid="ignore"):
        return p[:, :2] / p[:, 2:]


def _inverse(H) -> np.ndarray | None:
    try:
        Hi = np.linalg.inv(H)
    except np.linalg.LinAlgError:
        return None
    return Hi if np.all(np.isfinite(Hi)) else None


def _fit_grid(quad, squares, rows: int, cols: int):
    """The patch grid of one candidate chart: (H, inliers), H taking (column, row) to pixels.

    ``quad`` is the candidate's outline and ``squares`` the segmented squares' centres inside it.
    Each square is assigned to the nearest grid cell through the current homography, and the
    homography refitted to the assigned squares' centres, until the assignment is stable; both
    ways of laying the 6 columns along the outline's sides are tried and the one that explains
    more squares (then the smaller residual) kept.
    """
    best = None
    box = np.array([[0, 0], [cols, 0], [cols, rows], [0, rows]], dtype=np.float64)
    for q in (quad, np.roll(quad, 1, axis=0)):
        H = _homography(box, q)
        if not np.all(np.isfinite(H)) or abs(np.linalg.det(H)) == 0:
            continue
        used = np.zeros(0, dtype=int)
        for _ in range(5):
            Hi = _inverse(H)
            if Hi is None:
                break
            uv = _apply(Hi, squares) - 0.5
            idx = np.nan_to_num(np.round(uv), nan=-1.0, posinf=-1.0, neginf=-1.0)
            ok = (
                np.all(np.abs(uv - idx) < CHART_DETECT_CELL, axis=1)
                & (idx[:, 0] >= 0)
                & (idx[:, 0] < cols)
                & (idx[:, 1] >= 0)
                & (idx[:, 1] < rows)
            )
            cell = (idx[:, 1] * cols + idx[:, 0]).astype(int)
            keep = []
            for c in np.unique(cell[ok]):  # one square per cell: the one nearest its centre
                k = np.flatnonzero(ok & (cell == c))
                keep.append(k[np.argmin(np.linalg.norm(uv[k] - idx[k], axis=1))])
            keep = np.array(keep, dtype=int)
            if (
                keep.size < CHART_DETECT_MIN_SQUARES
                or np.unique(idx[keep, 0]).size < 3
                or np.unique(idx[keep, 1]).size < 2
            ):
                break  # too few squares, or all in two columns or one row: no homography to trust
            H = _homography(idx[keep] + 0.5, squares[keep])
            if np.array_equal(keep, used):
                break
            used = keep
        Hi = _inverse(H)
        if used.size < CHART_DETECT_MIN_SQUARES or Hi is None:
            continue
        uv = _apply(Hi, squares[used]) - 0.5
        score = (used.size, -float(np.abs(uv - np.round(uv)).mean()))
        if best is None or score > best[0]:
            best = (score, H, used.size)
    return None if best is None else (best[1], best[2])


#: The four symmetries of a 4 × 6 grid: the ways to reorder a (rows, cols) array of centres so
#: that one corner comes first.
_SYMMETRIES = (
    lambda C: C,
    lambda C: C[::-1, ::-1],
    lambda C: C[:, ::-1],
    lambda C: C[::-1, :],
)


def _box_means(image: np.ndarray, centres: np.ndarray, half: int) -> np.ndarray | None:
    H, W = image.shape[:2]
    c = np.round(centres).astype(int)
    if half < 1 or (c - half).min() < 0 or c[:, 0].max() + half >= W or c[:, 1].max() + half >= H:
        return None
    return np.array([image[y - half : y + half + 1, x - half : x + half + 1].mean((0, 1)) for x, y in c])


def _neutrals_ordered(rgb: np.ndarray, neutrals) -> bool:
    """Whether the neutral patches (white first) grow strictly darker in every channel's sum."""
    s = rgb[list(neutrals)].sum(1)
    return bool(np.all(np.diff(s) < 0))


def detect_chart_rgb(
    image,
    *,
    chart: str = "colorchecker",
    illuminant: str = "D50",
    path: str = "image",
    by_hand: str = _BY_HAND,
) -> ChartDetection:
    """Find a ColorChecker Classic in a linear RGB image.

    Parameters
    ----------
    image : array_like of shape (H, W, 3)
        Linear, roughly white-balanced RGB (camera RGB divided by its neutral, or linear sRGB), the
        white near 1.
    chart
        Chart type (``"colorchecker"``, the only one with a detector).
    illuminant
        The light the chart was photographed under: the reference colours the patches are checked
        against.
    path
        Name of the image in error messages.
    by_hand
        How the caller's user gives the corners instead, ending every failure's message (default:
        ``isp profile``'s ``--chart-corners``).

    Returns
    -------
    ChartDetection
        In the image's pixel frame (x to the right, y down, pixel centres at integers).

    Raises
    ------
    ChartError
        ``colour-checker-detection`` is not installed, or no chart consistent with a ColorChecker
        was found (the message says to give the corners).
    """
    t = _chart_type(chart)
    if (t.rows, t.cols) != (4, 6):
        raise ChartError(
            f"--chart-type {chart}: only a ColorChecker Classic is found automatically; {by_hand}."
        )
    segment, settings = _detector(by_hand)
    img = np.asarray(image, dtype=np.float64)
    if img.ndim != 3 or img.shape[2] < 3 or min(img.shape[:2]) < 8:
        raise ChartError(
            f"{path}: expected an RGB image (H, W, 3) of at least 8 × 8 pixels, got {img.shape}."
        )
    img = np.nan_to_num(img[..., :3], nan=0.0, posinf=0.0, neginf=0.0)
    transposed = img.shape[0] > img.shape[1]  # the segmenter turns portrait images itself: do it here
    work = np.ascontiguousarray(img.transpose(1, 0, 2) if transposed else img)
    # the segmenter resizes to its working width (1440, its thresholds' scale); a smaller image is
    # segmented as it is, not upsampled: on 24 scenes 900 px wide as often found and as exact after
    # _refine (0.16 px mean), median 1.4 s against 1.7 s (benchmarks/bench_chart_detect.py)
    width = min(int(settings["working_width"]), work.shape[1])
    scale = work.shape[1] / width
    with warnings.catch_warnings():  # its own numerics on a flat image (0/0 in its normalisation)
        warnings.simplefilter("ignore", RuntimeWarning)
        data = segment(np.clip(work, 0, 1).astype(np.float32), additional_data=True, working_width=width)
    boxes = np.asarray(data.swatches, dtype=np.float64).reshape(-1, 4, 2)
    squares = boxes.mean(1)
    quads = list(np.asarray(data.rectangles, dtype=np.float64).reshape(-1, 4, 2)) + _square_groups(boxes)
    found: list[ChartDetection] = []
    candidates = 0
    for quad in quads:
        inside = _inside(quad, squares)
        grid = _fit_grid(quad, squares[inside], t.rows, t.cols)
        if grid is None:
            continue
        candidates += 1
        Hg, n = grid
        j, i = np.meshgrid(np.arange(t.cols) + 0.5, np.arange(t.rows) + 0.5)
        C = _apply(Hg, np.column_stack([j.ravel(), i.ravel()]))
        C = (C + 0.5) * scale - 0.5  # cv2.resize's pixel-centre convention, back to the image
        if transposed:
            C = C[:, ::-1]
        C = _refine(img, C, t.rows, t.cols).reshape(t.rows, t.cols, 2)
        for flip in _SYMMETRIES:
            centres = flip(C).reshape(-1, 2)
            corners = centres[[0, t.cols - 1, t.rows * t.cols - 1, (t.rows - 1) * t.cols]]
            pitch = min(np.linalg.norm(centres[1] - centres[0]), np.linalg.norm(centres[t.cols] - centres[0]))
            rgb = _box_means(img, centres, int(CHART_BOX * pitch))
            if rgb is None or not _neutrals_ordered(rgb, t.neutrals):
                continue
            reading = ChartReading(
                rgb=rgb, std=np.zeros_like(rgb), centres=centres, half=0, chart=str(chart).lower(), camera=""
            )
            try:
                fit = fit_chart(reading, illuminant=illuminant, refine=False)
            except ChartError:
                continue
            found.append(ChartDetection(corners, centres, float(fit.delta_E.mean()), *_pose(corners), n))
    if not found:
        what = "no patch grid" if not candidates else "no grid whose neutral patches run from white to black"
        raise ChartError(f"{path}: no ColorChecker found ({what}); {by_hand}.")
    best = min(found, key=lambda d: d.delta_E)
    if not best.delta_E <= CHART_DETECT_MAX_DE:
        raise ChartError(
            f"{path}: no ColorChecker found (the best grid's colours are {best.delta_E:.1f} ΔE00 from the "
            f"chart's, over {CHART_DETECT_MAX_DE:g}); {by_hand}."
        )
    return best


def _refine(img: np.ndarray, centres: np.ndarray, rows: int, cols: int) -> np.ndarray:
    """Patch centres ``(rows · cols, 2)`` refitted to the patches' own pixels.

    Around each centre, the pixels within :data:`isp._tol.CHART_DETECT_SIMILAR` (relative RGB
    distance) of the colour at its middle are the patch; their centroid is its centre when their
    area is a patch's (within :data:`isp._tol.CHART_DETECT_AREA`; a patch that does not stand out
    from the chart's body, such as the black one, or a window cut by the image's edge, is left
    out). The grid's homography is refitted to those centroids, so that the few-pixel error of the
    segmented squares averages out.
    """
    grid = np.array([(j + 0.5, i + 0.5) for i in range(rows) for j in range(cols)])
    pitch = float(
        np.median(
            np.concatenate(
                [
                    np.linalg.norm(np.diff(centres.reshape(rows, cols, 2), axis=1), axis=-1).ravel(),
                    np.linalg.norm(np.diff(centres.reshape(rows, cols, 2), axis=0), axis=-1).ravel(),
                ]
            )
        )
    )
    w, inner = int(np.ceil(0.55 * pitch)), max(int(CHART_BOX * pitch), 1)
    H, W = img.shape[:2]
    good, found = [], []
    for k, (x, y) in enumerate(np.round(centres).astype(int)):
        if x - w < 0 or y - w < 0 or x + w >= W or y + w >= H:
            continue
        win = img[y - w : y + w + 1, x - w : x + w + 1]
        m = np.median(img[y - inner : y + inner + 1, x - inner : x + inner + 1].reshape(-1, 3), axis=0)
        mask = np.linalg.norm(win - m, axis=-1) < CHART_DETECT_SIMILAR * max(float(np.linalg.norm(m)), 1e-12)
        area = (CHART_DETECT_PATCH * pitch) ** 2
        if not abs(mask.sum() / area - 1) < CHART_DETECT_AREA:
            continue
        yy, xx = np.nonzero(mask)
        good.append(k)
        found.append((x - w + xx.mean(), y - w + yy.mean()))
    if len(good) < CHART_DETECT_MIN_SQUARES:
        return centres
    Hr = _homography(grid[good], np.array(found))
    refined = _apply(Hr, grid)
    if not np.all(np.isfinite(refined)) or np.abs(refined - centres).max() > CHART_DETECT_SHIFT * pitch:
        return centres  # the refit moved the grid by more than the squares' error: keep the squares'
    return refined


def _square_groups(boxes: np.ndarray) -> list[np.ndarray]:
    """Outlines of groups of neighbouring, equal-sized segmented squares (a chart the segmenter's
    own grouping missed, e.g. in strong perspective): squares whose centres are within
    :data:`isp._tol.CHART_DETECT_LINK` of their sides apart and whose sides differ by less than
    that ratio are linked; each group of at least :data:`isp._tol.CHART_DETECT_MIN_SQUARES` gives
    the rectangle along its principal axes around its centres, widened by half a pitch."""
    n = len(boxes)
    if n < CHART_DETECT_MIN_SQUARES:
        return []
    centres = boxes.mean(1)
    side = np.sqrt(np.abs(_area(boxes)))
    d = np.linalg.norm(centres[:, None] - centres[None], axis=2)
    ratio = np.maximum(side[:, None], side[None]) / np.maximum(np.minimum(side[:, None], side[None]), 1e-9)
    link = (d < CHART_DETECT_LINK * np.maximum(side[:, None], side[None])) & (ratio < CHART_DETECT_LINK)
    label = np.arange(n)
    for _ in range(n):  # connected components by label propagation
        new = np.where(link, label[None], n).min(1)
        if np.array_equal(new, label):
            break
        label = new
    quads = []
    for g in np.unique(label):
        pts = centres[label == g]
        if len(pts) < CHART_DETECT_MIN_SQUARES:
            continue
        mean = pts.mean(0)
        axes = np.linalg.svd(pts - mean, full_matrices=False)[2]
        local = (pts - mean) @ axes.T
        dd = np.linalg.norm(pts[:, None] - pts[None], axis=2)
        np.fill_diagonal(dd, np.inf)
        half = 0.5 * float(np.median(dd.min(1)))  # half the pitch
        lo, hi = local.min(0) - half, local.max(0) + half
        corners = np.array([[lo[0], lo[1]], [hi[0], lo[1]], [hi[0], hi[1]], [lo[0], hi[1]]])
        quads.append(corners @ axes + mean)
    return quads


def _area(boxes: np.ndarray) -> np.ndarray:
    """Shoelace areas of quadrilaterals ``(N, 4, 2)``."""
    x, y = boxes[..., 0], boxes[..., 1]
    return 0.5 * (x * np.roll(y, -1, axis=1) - np.roll(x, -1, axis=1) * y).sum(1)


def _pose(corners: np.ndarray) -> tuple[float, bool]:
    """(angle, mirrored) of a chart from its corner patches 1, 6, 24, 19 (image frame, y down)."""
    across, down = corners[1] - corners[0], corners[3] - corners[0]
    angle = float(np.degrees(np.arctan2(-across[1], across[0])))
    return angle, bool(across[0] * down[1] - across[1] * down[0] < 0)


def _inside(quad: np.ndarray, pts: np.ndarray) -> np.ndarray:
    """Which points lie inside the convex quadrilateral ``quad`` (either winding)."""
    if pts.size == 0:
        return np.zeros(0, dtype=bool)
    d = np.roll(quad, -1, axis=0) - quad
    cross = d[None, :, 0] * (pts[:, None, 1] - quad[None, :, 1]) - d[None, :, 1] * (
        pts[:, None, 0] - quad[None, :, 0]
    )
    return np.all(cross >= 0, axis=1) | np.all(cross <= 0, axis=1)


def detect_chart(
    raw, *, chart: str = "colorchecker", illuminant: str = "D50", by_hand: str = _BY_HAND
) -> ChartDetection:
    """Find a ColorChecker Classic in a RAW file: :func:`detect_chart_rgb` on its :func:`raw_preview`.

    Parameters
    ----------
    raw : isp.RawImage or path
    chart, illuminant, by_hand
        As :func:`detect_chart_rgb`.

    Returns
    -------
    ChartDetection
        In the mosaic's pixel frame: ``corners`` is what :func:`isp.profiles.chart.read_chart` takes.

    Raises
    ------
    ChartError
        As :func:`detect_chart_rgb`, the message naming the file.
    """
    from ..raw import read_raw

    if not hasattr(raw, "mosaic"):
        raw = read_raw(raw)
    require_detector(by_hand=by_hand)  # the missing package is said before the preview is computed
    name = str(getattr(raw, "path", None) or "RAW file")
    d = detect_chart_rgb(raw_preview(raw), chart=chart, illuminant=illuminant, path=name, by_hand=by_hand)
    return ChartDetection(  # preview pixel (u, v) is centred on mosaic (2u + 0.5, 2v + 0.5)
        corners=2 * d.corners + 0.5,
        centres=2 * d.centres + 0.5,
        delta_E=d.delta_E,
        angle=d.angle,
        mirrored=d.mirrored,
        squares=d.squares,
    )
