"""The scene light of an ``illuminant = "estimate"`` capture, estimated at the correct step from the
capture's own stacked responses (:mod:`zonotope.spectra.illuminant_estimate`) and cached in
``OUT/correct/illuminant.json``.

With ``[white] method = "patch"`` the marked card is read in its view's render (every camera's
channels at the card), or in the photograph itself when that view was not rendered (its own camera's
channels), and the light is the candidate that explains its colour
(:func:`zonotope.spectra.illuminant_estimate.grey_card`, the card spectrally flat). Otherwise the
light is the most likely candidate for pixels sampled from the photographed views' renders
(:func:`zonotope.spectra.illuminant_estimate.estimate_illuminant`, one exposure per camera, its angular
uncertainty by bootstrap over the sampled pixels: the sampling part only, which a light outside the
candidates, e.g. CIE A, does not enter).

Why here and not in the spec: the estimate needs the rendered, pixel-aligned responses of every camera,
which exist only after the render step.
"""

from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np

from .._tol import LIGHT_BOOTSTRAP, LIGHT_DARK, LIGHT_PIXELS, LIGHT_SPECULAR
from .files import read_tiff, write_json
from .raw import white_box, white_patch
from .spec import CaptureError, CaptureSpec
from .workspace import read_json

__all__ = ["estimate_scene_light", "illuminant_of"]


def _grid(spec: CaptureSpec, curves) -> np.ndarray:
    """400–700 nm / 10 nm narrowed to the curves' common range (as the correction problem's grid)."""
    import zonotope

    common = zonotope.common_shape(*curves, zonotope.observer(spec.observer), interval=10)
    return np.arange(max(common.start, 400.0), min(common.end, 700.0) + 5, 10.0)


def _sample(out: Path, index: dict, k: int, rng) -> np.ndarray:
    """Up to :data:`LIGHT_PIXELS` rendered pixels (N, k), raw units, spread evenly over the views; the
    darkest (noise) and the brightest (highlights) left out."""
    per = max(LIGHT_PIXELS // max(len(index), 1), 1)
    pool = []
    for info in index.values():
        img = read_tiff(out / "render" / info["dir"] / "render.tiff").reshape(-1, k)
        img = img[np.all(np.isfinite(img), -1) & np.all(img > 0, -1)]
        if len(img):
            pool.append(img[rng.choice(len(img), min(per, len(img)), replace=False)])
    if not pool:
        return np.zeros((0, k))
    R = np.concatenate(pool)
    level = R.mean(-1)
    lo, hi = np.percentile(level, [0, 100 - LIGHT_SPECULAR])
    lo = max(lo, LIGHT_DARK * np.percentile(level, 99))
    return R[(level >= lo) & (level <= hi)]


def estimate_scene_light(spec: CaptureSpec, out: Path, index: dict, raws: dict) -> dict:
    """Estimate the scene light (see the module notes); returns the record written to
    ``illuminant.json``: ``light`` (the candidate's name), ``how``, ``angular_uncertainty_deg``, ….

    Raises
    ------
    CaptureError
        Too few usable rendered pixels (a capture of a dark or flat scene): mark a card instead.
    """
    from zonotope.spectra.illuminant_estimate import estimate_illuminant, grey_card

    cams = [spec.load_ssf(k) for k in range(len(spec.cameras))]
    grid = _grid(spec, cams)
    k = 3 * len(cams)
    card = spec.white.image if spec.white.method == "patch" else None
    if card is not None and card in raws:
        v = raws[card]
        x0, y0, x1, y1 = white_box(spec, v)
        if card in index:  # rendered: every camera's channels at the card
            img = read_tiff(out / "render" / index[card]["dir"] / "render.tiff")[y0:y1, x0:x1].reshape(-1, k)
            n = len(img)
            used, where = cams, f"its view's render ({n} pixels, every camera)"
        else:  # not rendered: the photograph's own channels (valid sites only)
            mean, sites = white_patch(spec, v)  # a channel without a site (NaN): refused below
            img = mean[None]
            n = int(sites.sum())
            used, where = (
                [cams[v.camera]],
                f"the photograph ({n} sites, {spec.cameras[v.camera].folder} only)",
            )
        try:
            est = grey_card(img, used, reflectance=1.0, shape=grid)
        except ValueError as e:
            raise CaptureError(f"{spec.file}: [white] card in {card!r}: {e}") from e
        return _record(est, "grey card", f"the marked card in {card}, read in {where}", n)
    R = _sample(out, index, k, np.random.default_rng(0))
    if len(R) <= 10 * k:
        raise CaptureError(
            f'{spec.file}: illuminant = "estimate" found {len(R)} usable rendered pixels; the light is '
            'estimated from many surfaces: mark a grey or white card ([white] method = "patch") or name '
            "the light."
        )
    est = estimate_illuminant(R, cams, shape=grid, exposures="per camera", bootstrap=LIGHT_BOOTSTRAP)
    return _record(
        est,
        "likelihood",
        f"{len(R)} pixels sampled from {len(index)} photographed views' renders, "
        f"{len(est.names)} candidates (daylight, Planckian, CIE F, CIE LED), one exposure per camera",
        len(R),
    )


def _record(est, method: str, source: str, n: int) -> dict:
    order = np.argsort(est.scores)[::-1][:3]
    return {
        "light": est.name,
        "method": method,
        "source": source,
        "pixels": n,
        "angular_uncertainty_deg": None
        if np.isnan(est.angular_uncertainty)
        else round(float(est.angular_uncertainty), 3),
        "uncertainty": (
            f"RMS angle of the first camera's white over {LIGHT_BOOTSTRAP} bootstrap resamples of the "
            "pixels (sampling only; a light far from every candidate is not in it)"
            if method == "likelihood"
            else "RMS angle over the cameras read between the card's response and the chosen light's "
            "prediction of it (what no candidate explains)"
        ),
        "agreement": None if np.isnan(est.agreement) else round(float(est.agreement), 3),
        "best": {est.names[i]: round(float(est.scores[i]), 4) for i in order},
        "white": np.asarray(est.white).round(6).tolist(),
    }


def illuminant_of(spec: CaptureSpec, out: Path, index: dict | None = None, raws: dict | None = None):
    """The capture with its light resolved, and the estimate's record (None for a named light).

    For ``illuminant = "estimate"``: the record cached in ``OUT/correct/illuminant.json``, else
    :func:`estimate_scene_light` (needs the render ``index`` and the working-resolution ``raws``) and
    written there; the spec returned names the chosen candidate, so that every later
    :meth:`~splat.capture.CaptureSpec.load_illuminant` loads it.

    Raises
    ------
    CaptureError
        Not estimated yet and no ``index`` to estimate from (run the correct step first).
    """
    if not spec.estimates_illuminant:
        return spec, None
    out = Path(out)
    path = out / "correct" / "illuminant.json"
    if path.is_file():
        rec = read_json(path, what="illuminant estimate")
    elif index is None:
        raise CaptureError(
            f'{spec.file}: illuminant = "estimate" is estimated at the correct step; run it first '
            f"(no {path})."
        )
    else:
        rec = estimate_scene_light(spec, out, index, raws or {})
        write_json(path, rec)
    return dataclasses.replace(spec, illuminant=rec["light"]), rec
