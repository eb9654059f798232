"""Colour correction of whole images: unique-colour deduplication, batching, disk cache.

Estimators that solve a small optimisation per colour (``"Prior"``, ``"Projection"``, ``"MAP"``,
``"Centroid"``) cost milliseconds per colour, but real images hold far fewer distinct colours than
pixels. :func:`correct_image` quantises the responses, corrects each distinct colour once, in
batches, and scatters the results back; with ``cache_dir`` the per-colour results persist between
calls (keyed by the estimator and the quantised colour).
"""

from __future__ import annotations

import hashlib
import zipfile
from pathlib import Path

import numpy as np

from .._errors import OptionError, SpectralDataError
from ..spectra.builtin import float_array
from ..utilities.progress import ProgressCallback
from .methods import CORRECTION_METHODS, IMAGE_METHOD, Corrector, fit_correction, noise_options
from .noise import NoiseModelError, estimate_noise, noise_model

__all__ = ["correct_image"]


def _fingerprint(corrector: Corrector, quantum: float) -> str:
    h = hashlib.sha256()
    p = corrector.problem
    for a in (p.Phi, p.Psi, p.training):
        h.update(np.ascontiguousarray(a).tobytes())
    h.update(
        repr(
            (
                corrector.method,
                sorted((k, repr(v)) for k, v in corrector.params.items() if isinstance(v, int | float | str)),
                quantum,
            )
        ).encode()
    )
    return h.hexdigest()[:24]


def _load_cache(path: Path, k: int, m: int) -> dict[bytes, np.ndarray]:
    if not path.is_file():
        return {}
    try:
        with open(path, "rb") as fh, np.load(fh) as data:  # our handle: closed even when np.load fails
            keys, values = data["keys"], data["values"]
    except (OSError, ValueError, KeyError, EOFError, zipfile.BadZipFile):
        return {}  # a damaged cache (e.g. from an older, non-atomic writer) is rebuilt, not trusted
    if keys.ndim != 2 or keys.shape[1] != k or values.shape != (keys.shape[0], m):
        return {}
    return {row.tobytes(): v for row, v in zip(keys, values)}


def _save_cache(path: Path, cache: dict[bytes, np.ndarray], k: int, m: int) -> None:
    keys = np.frombuffer(b"".join(cache), dtype=np.int64).reshape(-1, k)
    values = np.array(list(cache.values()), dtype=np.float64).reshape(-1, m)
    from ..utilities.io import atomic_path

    def write(tmp: Path) -> None:
        with open(tmp, "wb") as fh:
            np.savez(fh, keys=keys, values=values)

    atomic_path(path, write)  # a crash never leaves a half-written cache, Ctrl-C no temporary


def correct_image(
    image,
    cameras_or_corrector,
    *,
    method: str = IMAGE_METHOD,
    noise="auto",
    quantum: float = 2e-3,
    base: Corrector | str | None = "auto",
    batch_size: int = 2048,
    cache_dir: str | Path | None = None,
    progress: ProgressCallback | None = None,
    return_info: bool = False,
    reference=None,
    **options,
):
    """Correct a linear multi-camera image to target XYZ.

    Parameters
    ----------
    image : array_like of shape (H, W, k) or (..., k)
        Linear, white-balanced responses (the perfect white gives 1 per channel), channels of
        the cameras stacked on the last axis. NaN pixels stay NaN.
    cameras_or_corrector
        A fitted :class:`~zonotope.correct.Corrector`, or the camera(s) to fit one for (with
        ``method`` and ``**options``, see :func:`~zonotope.correct.fit_correction`).
    method
        Estimator when cameras are given: default :data:`~zonotope.correct.IMAGE_METHOD`
        (``"Guarded"``: the noise-aware root-polynomial with a linear fallback outside its
        training support, fitted for the image's noise; it corrects a photograph in seconds;
        ``"Prior"`` is as accurate on natural colours and better on atypical ones, at a per-colour
        cost).
    noise
        Noise of the image's responses, which the estimator is fitted for when cameras are given:
        ``"auto"`` (default) estimates it from the image's flat regions
        (:func:`~zonotope.correct.estimate_noise`; noise-free where the image is too small, an
        implausible estimate is reported and ignored) or, with a fitted corrector, takes the one it
        was fitted for; a :class:`~zonotope.correct.NoiseModel` (e.g. from the DNG ``NoiseProfile``,
        :meth:`~zonotope.correct.NoiseModel.from_noise_profile`), a σ, or None / 0 for noise-free.
        The curves are taken as exact: for stacked cameras whose measured curves are published ones
        of their models, add :func:`zonotope.unit_sigma` to σ in quadrature (as ``zonotope
        correct`` does), or a noise-free fit leans on differences between units.
    quantum
        Pixels whose responses round to the same multiples of ``quantum`` form one group,
        corrected once at the response of its first pixel (0: exact deduplication only). For
        estimators with closed-form rows (``"Prior"``: ``params["closed_form"]``, which returns the
        closed-form estimates and the rows that need a solver in one vectorised pass) only the pixels
        that need a solver are grouped — each with the responses within ``quantum`` of a leader
        response in every channel (greedy leader clustering, so the noise cloud of one surface is
        not cut into up to 2ᵏ grid cells) — and the others are corrected exactly, pixel by pixel:
        noisy photos (as many distinct colours as pixels) cost little more than the regression plus
        one solve per cluster. Use a ``quantum`` of about 2–4σ on noisy images (measurements:
        ``docs/notes/2026-11-28-image-correction-clusters.md``).
    base
        A cheap estimator used to carry each group's result to its pixels:
        ``out = est(c₀) + base(c) − base(c₀)`` (``c₀`` the group's representative response), which
        removes the first-order error of grouping and allows a coarse ``quantum`` on images with
        smooth shading. ``"auto"``: the estimator's own closed-form part where it has one
        (``params["closed_form"]``: for ``"Prior"`` it follows the gate and the MAP estimate of every
        pixel, so only the centroid and the bounded solves are carried over), else its regression
        (``params["regression"]``) or a root-polynomial fit; ``None``: no transfer
        (``out = est(c₀)``). Regression estimators are applied to every pixel directly (they are
        cheap), with no grouping.
    batch_size
        Distinct colours corrected per call of the estimator.
    cache_dir
        Folder for a persistent per-colour cache (one ``.npz`` per estimator and grid), written
        atomically after each batch.
    progress
        Called as ``progress("distinct colours", done, total)`` after each batch
        (:class:`~zonotope.utilities.ProgressCallback`).
    reference
        With cameras: the light whose colours the output holds (e.g. ``"D65"``), the estimator being
        fitted scene light (``illuminant``) → ``reference``
        (:func:`~zonotope.correct.correction_problem`); None (default): the scene light. A fitted
        corrector already holds its reference (``corrector.problem.target_illuminant``).
    return_info
        Also return a dict saying what was done: ``"method"``, ``"noise"`` (the
        :class:`~zonotope.correct.NoiseModel` or None), ``"noise_source"`` (where it came from) and
        ``"noise_note"`` (why an estimate was not used, or "").

    Returns
    -------
    ndarray of shape (..., m)
        With ``return_info``: ``(ndarray, dict)``.

    Raises
    ------
    SpectralDataError
        ``image`` is not an array of numbers, has the wrong channel count, or ``batch_size`` is not
        positive.
    OptionError
        ``quantum`` is negative or not finite, or ``reference`` given with a fitted corrector.
    NoiseModelError
        A given ``noise`` that is negative, NaN or of the wrong channel count.

    Examples
    --------
    >>> import numpy as np
    >>> img = np.full((4, 5, 3), 0.18)
    >>> correct_image(img, "Nikon 5100 (NPL)", method="root-polynomial",
    ...               shape=np.arange(400, 701, 10)).shape
    (4, 5, 3)
    """
    img = np.asarray(image) if isinstance(image, np.ndarray) and image.dtype == np.float32 else None
    img = float_array(image, "image") if img is None else img  # float32 photos stay float32 (memory)
    if isinstance(cameras_or_corrector, Corrector):
        corrector = cameras_or_corrector
        if reference is not None:
            raise OptionError(
                f"reference={reference!r}: a fitted corrector already holds its reference light "
                f"({corrector.problem.target_illuminant or corrector.problem.illuminant}); fit one with "
                "fit_correction(..., reference=...) or pass the cameras."
            )
        model, source, note = _corrector_noise(corrector, noise)
    else:
        k_img = img.shape[-1] if img.ndim else 0
        model, source, note = _resolve_noise(noise, img, k_img)
        corrector = fit_correction(
            cameras_or_corrector,
            method=method,
            reference=reference,
            **noise_options(method, model),
            **options,
        )
    info = {"method": corrector.method, "noise": model, "noise_source": source, "noise_note": note}
    out = _correct_image(img, corrector, quantum, base, batch_size, cache_dir, progress)
    return (out, info) if return_info else out


def _resolve_noise(noise, image, k: int):
    """The noise model for ``image (..., k)`` from a ``noise`` argument of :func:`correct_image`.

    Returns
    -------
    model : NoiseModel or None
    source : str
        Where it came from (``"estimated from image"``, ``"given"``, ``"none"``, ...).
    note : str
        Why an image estimate was not used ("" otherwise).
    """
    if isinstance(noise, str) and noise == "auto":
        img = np.asarray(image)
        if img.ndim != 3:
            return None, "none", f"noise not estimated: the image has shape {img.shape}, not (H, W, k)"
        try:
            model = estimate_noise(img)
        except NoiseModelError as exc:
            return None, "none", f"noise not estimated: {exc}"
        return (None, "none", "estimated noise is zero") if model.is_zero else (model, model.source, "")
    model = noise_model(noise, k)
    return model, ("none" if model is None else model.source), ""


def _corrector_noise(corrector: Corrector, noise):
    """The noise a fitted corrector was fitted for (``noise="auto"``), or a contradiction error."""
    fitted = corrector.params.get("noise_model", corrector.params.get("noise"))
    model = noise_model(fitted, corrector.problem.k) if fitted is not None else None
    if not (isinstance(noise, str) and noise == "auto") and noise is not None:
        raise OptionError(
            "noise: a fitted Corrector already holds its noise; fit it with noise=... "
            "(fit_correction) instead of passing noise to correct_image."
        )
    return model, ("corrector" if model is not None else "none"), ""


def _correct_image(img, corrector, quantum, base, batch_size, cache_dir, progress) -> np.ndarray:
    """:func:`correct_image` with a fitted ``corrector``."""
    k, m = corrector.problem.k, corrector.problem.m
    if img.shape[-1:] != (k,):
        raise SpectralDataError(
            f"image: last axis must hold the {k} stacked channels of {list(corrector.problem.sources)}; "
            f"got shape {img.shape}."
        )
    if batch_size < 1:
        raise SpectralDataError(f"batch_size must be >= 1, got {batch_size}.")
    if not (np.isfinite(quantum) and quantum >= 0):
        raise OptionError(f"quantum={quantum!r}: give a grouping step >= 0 in response units (0: exact).")
    if cache_dir and Path(cache_dir).exists() and not Path(cache_dir).is_dir():
        from ..utilities.io import OutputExistsError

        raise OutputExistsError(f"cache_dir={str(cache_dir)!r} is a file, not a folder; give a folder path.")
    if CORRECTION_METHODS.properties(corrector.method)["closed_form"]:
        return corrector(img)
    if isinstance(base, str):
        if base != "auto":
            raise OptionError(f"base={base!r}: give a Corrector, 'auto' or None.")
        closed = corrector.params.get("closed_form")
        if closed is not None:  # the estimator's own closed-form part: follows its gate per pixel
            base = lambda c: closed(c)[0]  # noqa: E731
        else:
            base = corrector.params.get("regression") or fit_correction(
                corrector.problem, method="Finlayson 2015"
            )
    flat = img.reshape(-1, k)
    out = np.full((flat.shape[0], m), np.nan)
    closed_form = corrector.params.get("closed_form")
    needs_solver = corrector.params.get("needs_solver")
    leaders = (closed_form is not None or needs_solver is not None) and quantum > 0
    tag = ("leaders", quantum) if leaders else quantum
    cache_path = Path(cache_dir) / f"{_fingerprint(corrector, tag)}.npz" if cache_dir else None
    memo = _Memo(_load_cache(cache_path, k, m) if cache_path else {}, cache_path, k, m, progress)
    for i in range(0, flat.shape[0], _PIXEL_CHUNK):  # working memory: one chunk, whatever the image size
        rows = flat[i : i + _PIXEL_CHUNK]
        ok = np.all(np.isfinite(rows), axis=1)
        if not ok.any():
            continue
        pixels = np.asarray(rows[ok], dtype=np.float64)
        if not leaders:
            out[i : i + rows.shape[0]][ok] = _grouped(pixels, corrector, quantum, base, batch_size, memo)
            continue
        # exact per pixel where the estimator is a closed form; grouping only where it solves
        res = np.empty((pixels.shape[0], m))
        slow = np.empty(pixels.shape[0], dtype=bool)
        for j in range(0, pixels.shape[0], _CHUNK):
            part = pixels[j : j + _CHUNK]
            if closed_form is not None:  # estimates and solver rows in one vectorised pass
                res[j : j + _CHUNK], slow[j : j + _CHUNK] = closed_form(part)
            else:
                slow[j : j + _CHUNK] = needs_solver(part)
                fast = np.flatnonzero(~slow[j : j + _CHUNK])
                res[j + fast] = corrector(part[fast])
        if slow.any():
            res[slow] = _grouped(pixels[slow], corrector, quantum, base, batch_size, memo, leaders=True)
        out[i : i + rows.shape[0]][ok] = res
    return out.reshape(*img.shape[:-1], m)


#: Pixels per chunk of :func:`correct_image` for estimators that are not closed forms: bounds the
#: working memory of deduplication and grouping (about 200 MiB per 2²⁰ pixels of two cameras)
#: whatever the image size, while large enough that a noise cloud is rarely split across chunks.
_PIXEL_CHUNK = 1 << 20

#: Pixels per vectorised call of the closed-form path (bounds the memory of (N, n) reflectances).
_CHUNK = 65_536

#: Distinct colours kept in memory between chunks (about 50 MiB; beyond it the in-memory results are
#: dropped and recomputed when met again; a ``cache_dir`` file keeps them all).
_MEMO_MAX = 1 << 18


class _Memo:
    """Per-colour results shared by the chunks of one :func:`correct_image` call: the ``cache_dir``
    file's content (written back atomically after each batch) or an in-memory dict of bounded size,
    plus the progress counts over all chunks."""

    def __init__(self, cache: dict, path: Path | None, k: int, m: int, progress):
        self.cache, self.path, self.k, self.m, self.progress = cache, path, k, m, progress
        self.done = self.total = 0

    def get(self, key: bytes):
        return self.cache.get(key)

    def add(self, keys, values) -> None:
        if self.path is None and len(self.cache) + len(keys) > _MEMO_MAX:
            self.cache.clear()
        self.cache.update(zip(keys, values))
        if self.path is not None:
            _save_cache(self.path, self.cache, self.k, self.m)


def _leader_groups(pixels: np.ndarray, radius: float) -> tuple[np.ndarray, np.ndarray]:
    """Greedy leader clustering: in lexicographic order, each response not yet grouped leads a group
    of every ungrouped response within ``radius`` of it in every channel (L∞). Deterministic.

    Returns ``first`` (leader index per group) and ``inverse`` (group per response). Unlike rounding
    to a grid, a noise cloud around one surface colour is not cut into up to 2ᵏ cells by grid lines.
    """
    from scipy.spatial import cKDTree

    tree = cKDTree(pixels)
    label = np.full(pixels.shape[0], -1, dtype=np.intp)
    first = []
    for i in np.lexsort(pixels.T[::-1]):
        if label[i] >= 0:
            continue
        near = np.asarray(tree.query_ball_point(pixels[i], radius, p=np.inf), dtype=np.intp)
        near = near[label[near] < 0]
        label[near] = len(first)
        label[i] = len(first)
        first.append(i)
    return np.asarray(first, dtype=np.intp), label


def _grouped(pixels, corrector, quantum, base, batch_size, memo: _Memo, leaders: bool = False) -> np.ndarray:
    """Correct ``pixels (N, k)`` once per group of responses equal after rounding to ``quantum``
    (``leaders``: within ``quantum`` of a leader response, :func:`_leader_groups`), reusing the results
    in ``memo``."""
    k = corrector.problem.k
    if leaders:
        first, inverse = _leader_groups(pixels, quantum)
        keys = np.ascontiguousarray(pixels).view(np.int64)  # cache key: the leader's exact response
        uniq = keys[first]
    else:
        keys = (
            np.round(pixels / quantum).astype(np.int64)
            if quantum > 0
            else np.ascontiguousarray(pixels).view(np.int64)
        )
        rows = np.ascontiguousarray(keys).view(np.dtype((np.void, 8 * k))).reshape(-1)
        _, first, inverse = np.unique(rows, return_index=True, return_inverse=True)
        uniq = keys[first]
    del keys
    # each group is corrected at one of its actual responses, not at the rounded one: rounding
    # every channel independently would leave the (low-dimensional) set of real responses and
    # change estimators that weigh how plausible a response is.
    colours = pixels[first]
    result = np.empty((uniq.shape[0], corrector.problem.m))
    todo = []
    for i, row in enumerate(uniq):
        hit = memo.get(row.tobytes())
        if hit is None:
            todo.append(i)
        else:
            result[i] = hit
    todo = np.asarray(todo, dtype=np.intp)
    memo.total += todo.size
    for start in range(0, todo.size, batch_size):
        idx = todo[start : start + batch_size]
        result[idx] = corrector(colours[idx])
        memo.add([uniq[i].tobytes() for i in idx], result[idx].copy())
        memo.done += idx.size
        if memo.progress is not None:
            memo.progress("distinct colours", memo.done, memo.total)
    inverse = inverse.reshape(-1)
    res = result[inverse]
    if base is not None and quantum > 0:
        res += base(pixels) - base(colours)[inverse]
    return res
