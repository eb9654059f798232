"""A capture's RAW files as linear mosaics, and the scale that puts a perfect white at 1.

A capture on disk is ``capture.toml`` (read by :func:`splat.capture.spec.read_capture`) plus one
folder of RAW files per physical camera. :func:`load_views` turns every RAW file into a linear mosaic
through :mod:`isp` — black and white level (and the DNG linearisation table, which LibRaw applies),
**no** white balance and **no** demosaicing — with a per-pixel, per-channel weight that is 0 where a
channel is not measured (the camera's own CFA phase), where the sensor saturated, and on dead pixels.
Full-colour sensors (Foveon-type, ``LinearRaw`` DNG) measure all three channels at every pixel.

Units
-----
Training uses the linear values as they are (0 at black, 1 at saturation, un-balanced), so the
RawNeRF loss's clip at 1 is the sensor's saturation. Each view carries its relative exposure
``ExposureTime × ISO / FNumber²`` (EXIF) divided by the median over all views. For colour
correction the rendered responses (at exposure 1) are put on the scale :mod:`zonotope.correct`
expects — a perfect white reflector under the capture's illuminant gives 1 in every channel — by
:func:`white_scale`: ``c = raw / (k_cam · n_cam)`` with ``n_cam`` the camera's white response from
its spectral sensitivities (max 1) and ``k_cam`` the raw level of the perfect white's largest channel
at exposure 1, found by one of:

``"patch"``
    the user marks a box on a white/grey patch of known flat reflectance ρ in one image: that
    camera's ``k`` is the patch's mean response / (ρ · exposure · n) (per channel, then the mean over
    channels); the other cameras get theirs through the ratio of their brightest-neutral levels to
    that camera's (the same bright surfaces are seen by every camera).
``"brightest-neutral"`` (default)
    the brightest neutral surface in each camera's views is taken for a perfect white: the 99.5th
    percentile of the level of pixels (2 × 2 super-pixels behind a Bayer mosaic) whose channel ratios
    are within 5 % of the white's. If that surface really has reflectance ρ < 1 every estimate is
    too bright by 1/ρ: for ρ = 0.9 a lightness error of 2.3 ΔE00 on greys from Y = 0.2 to 0.9 (4.0 ΔL* at
    Y = 0.9, 2.4 at 0.2; computed with colour-science), 1.1 ΔE00 at Y = 0.05, plus the small chromaticity
    change of the estimators that are not exposure-invariant. Mark a patch when accuracy matters.
"""

from __future__ import annotations

import math
import os
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from isp import batch

from .._errors import SplatError
from .spec import CameraSpec, CaptureError, CaptureSpec

__all__ = [
    "RAW_SUFFIXES",
    "RawSource",
    "RawView",
    "brightest_neutral",
    "camera_white",
    "check_white_box",
    "exif_exposure",
    "load_view",
    "load_views",
    "open_raw",
    "read_linear",
    "relative_exposures",
    "white_box",
    "white_patch",
    "white_scale",
]


#: Suffixes of the RAW files read from a camera folder: isp's one list, for isp folders and captures.
RAW_SUFFIXES = batch.RAW_SUFFIXES


# ---------------------------------------------------------------------------------------------
# RAW → linear mosaic
# ---------------------------------------------------------------------------------------------


@dataclass(frozen=True, eq=False)
class RawView:
    """One RAW file as a linear mosaic.

    Attributes
    ----------
    name : str
        ``"<folder>/<file>"`` (the COLMAP image name).
    camera : int
        Index of the camera in :attr:`CaptureSpec.cameras`.
    values : ndarray of shape (H, W, 3), float32
        Linear values (0 black, 1 saturation), un-balanced; 0 where a channel is not measured.
    weight : ndarray of shape (H, W, 3), float32
        1 where the channel is measured and valid, 0 elsewhere (other CFA sites, saturated, dead).
    exif : float or None
        ``ExposureTime × ISO / FNumber²`` (or the capture file's override); None when unknown.
    profile : isp.DNGProfile or None
        The file's colour matrices (for the DNG-matrix development).
    neutral : ndarray of shape (3,)
        AsShotNeutral (max 1).
    full_colour : bool
    n_saturated, n_dead : int
        Pixels given zero weight.
    noise_profile : ndarray of shape (3, 2) or None
        The file's DNG NoiseProfile as rows ``(S, O)`` for R, G, B: the noise variance of
        :attr:`values` is ``S·x + O`` at value ``x`` (a single pair in the file is repeated). None when
        the file has none.
    binning : int
        The file's mosaic binned by this factor (:mod:`splat.resolution`; 1: the mosaic itself). A
        binned view is full-colour: each channel the mean of its block's valid sites, the weight the
        valid fraction, the noise profile scaled to the mean.
    full_shape : tuple of int or None
        ``(H, W)`` of the file at full resolution (None: :attr:`shape`).
    path : Path or None
        The file (for full-resolution work).
    source_cfa : str or None
        The file's 2 × 2 Bayer pattern (None: a full-colour file), also once binned.
    """

    name: str
    camera: int
    values: np.ndarray
    weight: np.ndarray
    exif: float | None
    profile: object
    neutral: np.ndarray
    full_colour: bool
    n_saturated: int = 0
    n_dead: int = 0
    noise_profile: np.ndarray | None = None
    binning: int = 1
    full_shape: tuple[int, int] | None = None
    path: Path | None = None
    source_cfa: str | None = None

    @property
    def shape(self) -> tuple[int, int]:
        """Image size ``(H, W)``."""
        return self.values.shape[:2]

    @property
    def size(self) -> tuple[int, int]:
        """Image size ``(H, W)`` of the file at full resolution."""
        return self.shape if self.full_shape is None else tuple(self.full_shape)

    @property
    def cfa(self) -> str:
        """The 2 × 2 CFA pattern of the mosaic's top-left corner, e.g. ``"RGGB"`` (the channel measured
        at each site, read off the mosaic itself so that no second source of the pattern can disagree)."""
        m = self.values[:2, :2] != 0
        w = self.weight[:2, :2] > 0
        site = np.argmax(m | w, axis=-1)
        return "".join("RGB"[int(site[i, j])] for i in range(2) for j in range(2))


def _exif_from_tags(tags) -> dict:
    out = {}
    for code, name in ((33434, "ExposureTime"), (34855, "ISO"), (33437, "FNumber")):
        t = tags.get(code)
        if t is not None:
            out[name] = t.value
    exif = tags.get(34665)
    if exif is not None and isinstance(exif.value, dict):
        for name in ("ExposureTime", "ISOSpeedRatings", "PhotographicSensitivity", "FNumber"):
            if name in exif.value:
                out.setdefault(
                    "ISO" if name in ("ISOSpeedRatings", "PhotographicSensitivity") else name,
                    exif.value[name],
                )
    return out


def _number(v) -> float:
    if isinstance(v, tuple | list) and len(v) == 2 and all(isinstance(x, int) for x in v):
        return v[0] / v[1] if v[1] else float("nan")
    if isinstance(v, tuple | list):
        return _number(v[0])
    return float(v)


def exif_exposure(path: str | os.PathLike) -> float | None:
    """``ExposureTime × ISO / FNumber²`` from a TIFF-based RAW file's tags (IFD 0 or the EXIF IFD).

    Returns None when the file is not TIFF-based or a tag is missing (a missing FNumber counts as
    unknown, not as 1).
    """
    import tifffile

    try:
        with tifffile.TiffFile(path) as tif:
            e = _exif_from_tags(tif.pages[0].tags)
    except (tifffile.TiffFileError, OSError, ValueError, IndexError, KeyError):
        return None
    if not {"ExposureTime", "ISO", "FNumber"} <= set(e):
        return None
    t, iso, f = _number(e["ExposureTime"]), _number(e["ISO"]), _number(e["FNumber"])
    if not all(math.isfinite(x) and x > 0 for x in (t, iso, f)):
        return None
    return t * iso / f**2


def _read_linear_raw_dng(path: Path):
    """(H, W, 3) data, black (3,), white, tags of a LinearRaw (full-colour) DNG, or None."""
    import tifffile

    from isp.dng import read_dng_tags

    try:
        with tifffile.TiffFile(path) as tif:
            page = None
            for p in [tif.pages[0], *(getattr(tif.pages[0], "pages", None) or [])]:
                ph = int(p.tags[262].value) if 262 in p.tags else -1
                sub = p.tags.get(254)
                if ph == 34892 and (sub is None or int(sub.value) == 0):
                    page = p
                    break
            if page is None:
                return None
            data = page.asarray()
    except (tifffile.TiffFileError, OSError, ValueError, IndexError, KeyError):
        return None
    tags = read_dng_tags(path)
    if data.ndim != 3 or data.shape[-1] != 3:
        raise CaptureError(f"{path}: LinearRaw DNG with {data.shape} samples; expected (H, W, 3).")
    black = np.broadcast_to(np.ravel(tags.get("BlackLevel", [0.0]))[:3], (3,)).astype(float)
    white = float(
        np.ravel(tags.get("WhiteLevel", [np.iinfo(data.dtype).max if data.dtype.kind == "u" else 1.0]))[0]
    )
    return data, black, white, tags


@dataclass(frozen=True, eq=False)
class RawSource:
    """One RAW file as stored (its samples kept in the file's own integer type) and what turns any rows
    of it into the linear values and weights of :class:`RawView`: full-resolution work reads it strip by
    strip (:meth:`rows`), so that memory holds the file's samples once, never the float mosaic whole.

    Attributes
    ----------
    path : Path
    data : ndarray of shape (H, W) (Bayer) or (H, W, 3) (full colour)
        The samples, black level included.
    black : ndarray of shape (2, 2) (per CFA site) or (3,) (per channel)
    white : float
    cfa : str or None
        The 2 × 2 Bayer pattern of the top-left corner; None for a full-colour file.
    info : dict
        ``profile``, ``neutral`` (max 1), ``full_colour``, ``cfa``, ``noise_profile`` (see
        :class:`RawView`).
    """

    path: Path
    data: np.ndarray
    black: np.ndarray
    white: float
    cfa: str | None
    info: dict

    @property
    def shape(self) -> tuple[int, int]:
        """Image size ``(H, W)``."""
        return self.data.shape[:2]

    @property
    def full_colour(self) -> bool:
        """Whether every pixel measures all three channels."""
        return self.cfa is None

    def rows(self, r0: int, r1: int, *, counts: bool = False):
        """Linear values and weights (each (r1 − r0, W, 3), float32) of rows ``r0:r1``, exactly as
        :func:`read_linear` gives them for the whole file; ``r0`` even on a Bayer mosaic (so that the
        rows start with the file's own pattern). With ``counts``, also the numbers of saturated and dead
        pixels among them."""
        if self.cfa is not None and r0 % 2:
            raise SplatError(f"{self.path}: rows of a Bayer mosaic start at an even row, got {r0}.")
        raw_dn = self.data[r0:r1].astype(np.float64)
        white = self.white
        if self.cfa is None:
            black = self.black
            values = np.clip((raw_dn - black) / (white - black), -0.05, 1.0).astype(np.float32)
            saturated = np.any(raw_dn >= white, axis=-1)
            dead = np.all(raw_dn <= 0, axis=-1) & bool(np.all(black > 0))
            weight = np.broadcast_to(~(saturated | dead)[..., None], values.shape).astype(np.float32)
        else:
            from isp.cfa import cfa_masks

            H, W = raw_dn.shape
            black_px = np.tile(self.black, ((H + 1) // 2, (W + 1) // 2))[:H, :W]
            # per pixel (its one site), then spread over the channels: the same values as clipping the
            # (H, W, 3) product, at a third of the work
            v = np.clip((raw_dn - black_px) / (white - black_px), -0.05, 1.0).astype(np.float32)
            measured = cfa_masks((H, W), self.cfa)
            values = np.where(measured, v[..., None], np.float32(0))
            saturated = raw_dn >= white
            dead = (raw_dn <= 0) & (black_px > 0)
            weight = (measured & ~(saturated | dead)[..., None]).astype(np.float32)
        out = values, weight
        if counts:
            return (*out, int(saturated.sum()), int(dead.sum()))
        return out


def open_raw(path: str | os.PathLike, camera: CameraSpec | None = None) -> RawSource:
    """Read one RAW file's samples and levels (:class:`RawSource`), the capture file's black and white
    level overrides applied; :meth:`RawSource.rows` gives its linear values.

    Raises
    ------
    CaptureError
        An unreadable file, or a malformed NoiseProfile tag (the message says which and why).
    """
    from isp import DNGProfile, RawFormatError, noise_profile, read_raw

    path = Path(path)
    camera = camera or CameraSpec("", "")
    lin = _read_linear_raw_dng(path) if path.suffix.lower() == ".dng" else None
    if lin is not None:
        data, black, white, tags = lin
        if camera.black_level is not None:
            black = np.full(3, float(camera.black_level))
        if camera.white_level is not None:
            white = float(camera.white_level)
        try:
            profile = DNGProfile.from_tags(tags)
        except RawFormatError:
            profile = None
        neutral = np.asarray(tags.get("AsShotNeutral", np.ones(3)), float)
        cfa = None
        levels = (float(np.mean(lin[1])), lin[2], float(np.mean(black)), white)
    else:
        try:
            raw = read_raw(path)
        except (RawFormatError, FileNotFoundError) as e:
            raise CaptureError(
                f"{path}: cannot read this RAW file ({e}). Remove it from the folder or convert it to DNG."
            ) from e
        cfa = camera.cfa or raw.cfa
        black = raw.black_level if camera.black_level is None else np.full((2, 2), float(camera.black_level))
        white = raw.white_level if camera.white_level is None else float(camera.white_level)
        data = raw.mosaic
        profile, neutral = raw.profile, raw.as_shot_neutral
        tags = raw.tags
        levels = (float(np.mean(raw.black_level)), float(raw.white_level), float(np.mean(black)), white)
    try:
        noise = noise_profile(tags, path)
    except RawFormatError as e:
        raise CaptureError(str(e)) from e
    if noise is not None and levels[:2] != levels[2:]:
        noise = _relevel_noise(noise, *levels)
    info = dict(
        profile=profile,
        neutral=neutral / np.max(neutral),
        full_colour=cfa is None,
        cfa=cfa,
        noise_profile=noise,
    )
    return RawSource(path, data, np.asarray(black, float), float(white), cfa, info)


def read_linear(path: str | os.PathLike, camera: CameraSpec | None = None):
    """Read one RAW file as a linear mosaic (see :class:`RawView` for the fields).

    Returns
    -------
    values, weight : ndarray of shape (H, W, 3), float32
    info : dict
        ``profile``, ``neutral``, ``full_colour``, ``n_saturated``, ``n_dead``, ``cfa``,
        ``noise_profile`` (:attr:`RawView.noise_profile`).

    Raises
    ------
    CaptureError
        An unreadable file, or a malformed NoiseProfile tag (the message says which and why).
    """
    src = open_raw(path, camera)
    values, weight, n_sat, n_dead = src.rows(0, src.shape[0], counts=True)
    return values, weight, dict(src.info, n_saturated=n_sat, n_dead=n_dead)


def _relevel_noise(P: np.ndarray, black: float, white: float, new_black: float, new_white: float):
    """A NoiseProfile ``(S, O)`` rows of the file's levels re-expressed for other black/white levels
    (the capture file's overrides): the variance in DN, ``span²·(S·(DN − black)/span + O)``, divided
    by the new span² at ``DN = new_black + x·new_span``; ``O`` floored at 0 (the DNG range)."""
    span, new = white - black, new_white - new_black
    S = P[:, 0] * span / new
    O = (P[:, 0] * span * (new_black - black) + P[:, 1] * span**2) / new**2
    return np.stack([S, np.maximum(O, 0.0)], axis=1)


def load_view(spec: CaptureSpec, k: int, path: Path, *, binning=None) -> RawView:
    """One RAW file of camera ``k`` as a :class:`RawView`, with its EXIF exposure (not yet relative).

    ``binning``: ``binning(shape, full_colour) → f``, the factor to bin the mosaic by
    (:func:`splat.resolution.working_factor`); the file is then read and binned strip by strip
    (:func:`splat.resolution.bin_mosaic`), so memory never holds its float mosaic whole.
    """
    from ..resolution import bin_mosaic, binned_noise_profile

    cam = spec.cameras[k]
    src = open_raw(path, cam)
    f = 1 if binning is None else int(binning(src.shape, src.full_colour))
    n_sat = n_dead = 0
    if f == 1:
        values, weight, n_sat, n_dead = src.rows(0, src.shape[0], counts=True)
        noise = src.info["noise_profile"]
    else:
        tally = [0, 0]

        def rows(r0, r1):
            v, w, a, b = src.rows(r0, r1, counts=True)
            tally[0] += a
            tally[1] += b
            return v, w

        values, weight = bin_mosaic(rows, src.shape, f, cfa=src.cfa)
        n_sat, n_dead = tally
        noise = binned_noise_profile(src.info["noise_profile"], src.cfa, f)
    e = cam.exposure.get(path.name)
    e = float(e) if e is not None else exif_exposure(path)
    return RawView(
        f"{cam.folder}/{path.name}",
        k,
        values,
        weight,
        e,
        src.info["profile"],
        src.info["neutral"],
        src.info["full_colour"] or f > 1,
        n_sat,
        n_dead,
        noise,
        binning=f,
        full_shape=tuple(src.shape),
        path=Path(path),
        source_cfa=src.cfa,
    )


#: Format of a decoded file in a :func:`load_views` cache (part of each file's key).
DECODED_FORMAT = 1


def _decoded_key(spec: CaptureSpec, k: int, path: Path, options: dict) -> str:
    """The name of RAW file ``path``'s decoded form in a cache: a hash of what it was made from — the
    file (absolute path, size, modification time), the camera's level and CFA overrides, the decoding
    options and :data:`DECODED_FORMAT`."""
    import hashlib
    import json

    cam = spec.cameras[k]
    st = path.stat()
    doc = {
        "file": [str(path.resolve()), st.st_size, st.st_mtime_ns],
        "camera": [cam.black_level, cam.white_level, cam.cfa],
        "options": options,
        "format": DECODED_FORMAT,
    }
    return hashlib.sha256(json.dumps(doc, sort_keys=True, default=str).encode()).hexdigest()[:32] + ".npz"


def _profile_doc(profile):
    """A :class:`isp.DNGProfile` as JSON (None: no profile; False: a profile JSON cannot hold)."""
    import dataclasses

    from isp import DNGProfile

    if profile is None:
        return None
    if type(profile) is not DNGProfile:
        return False
    return {
        f.name: (np.asarray(x).tolist() if isinstance(x, np.ndarray) else x)
        for f in dataclasses.fields(profile)
        for x in [getattr(profile, f.name)]
    }


def _store_decoded(file: Path, v: RawView) -> None:
    """Write ``v`` (but its exposure, which the capture file may override) to ``file``, atomically."""
    import json

    from zonotope.utilities import atomic_path

    prof = _profile_doc(v.profile)
    if prof is False:  # not a DNG profile: not kept (every read decodes the file)
        return
    meta = {
        "name": v.name,
        "camera": v.camera,
        "profile": prof,
        "neutral": np.asarray(v.neutral, float).tolist(),
        "full_colour": bool(v.full_colour),
        "n_saturated": int(v.n_saturated),
        "n_dead": int(v.n_dead),
        "noise_profile": None if v.noise_profile is None else np.asarray(v.noise_profile, float).tolist(),
        "binning": int(v.binning),
        "full_shape": None if v.full_shape is None else [int(x) for x in v.full_shape],
        "source_cfa": v.source_cfa,
    }
    file.parent.mkdir(parents=True, exist_ok=True)

    def write(p):
        with open(p, "wb") as fh:
            np.savez(fh, values=v.values, weight=v.weight, meta=np.array(json.dumps(meta)))

    atomic_path(file, write)


def _read_decoded(file: Path, name: str, k: int, path: Path) -> RawView | None:
    """The view kept in ``file`` (exposure None), or None when there is none or it is not readable as
    one (it is then decoded again and replaced)."""
    import json
    import zipfile

    from isp import DNGProfile

    if not file.is_file():
        return None
    try:
        with np.load(file, allow_pickle=False) as z:
            values, weight, meta = z["values"], z["weight"], json.loads(str(z["meta"]))
        prof = meta["profile"]
        if prof is not None:
            prof = DNGProfile(
                **{a: np.asarray(b, float) if isinstance(b, list) else b for a, b in prof.items()}
            )
        view = RawView(
            name,
            k,
            values,
            weight,
            None,
            prof,
            np.asarray(meta["neutral"], float),
            bool(meta["full_colour"]),
            int(meta["n_saturated"]),
            int(meta["n_dead"]),
            None if meta["noise_profile"] is None else np.asarray(meta["noise_profile"], float),
            binning=int(meta["binning"]),
            full_shape=None if meta["full_shape"] is None else tuple(meta["full_shape"]),
            path=Path(path),
            source_cfa=meta["source_cfa"],
        )
    except (OSError, ValueError, KeyError, TypeError, zipfile.BadZipFile, json.JSONDecodeError):
        return None
    ok = (
        meta["name"] == name
        and meta["camera"] == k
        and values.dtype == weight.dtype == np.float32
        and values.ndim == 3
        and values.shape == weight.shape
        and values.shape[-1] == 3
    )
    return view if ok else None


def load_views(spec: CaptureSpec, *, progress=None, binning=None, cache=None) -> list[RawView]:
    """Read every RAW file of the capture (all cameras), with relative exposures.

    Parameters
    ----------
    spec : CaptureSpec
    progress : callable, optional
        ``progress("read", done, total)`` after each file (:class:`zonotope.ProgressCallback`).
    binning : callable, optional
        ``binning(k, shape, full_colour) → f``: read camera ``k``'s files binned by ``f``
        (:func:`load_view`), one file at a time; default the mosaics themselves.
    cache : (folder, options), optional
        Keep each file's decoded (and binned) view in ``folder`` and read it from there when the file,
        its camera's overrides and ``options`` (everything ``binning`` depends on: the caller's
        statement) are unchanged (:func:`_decoded_key`); files of ``folder`` no file of the capture
        names any more are removed. The folder must be one splat owns
        (:meth:`splat.capture.Workspace.decode_cache`). Why: decoding a 12 MP RAW file costs 2–3 s of
        CPU, and each step of a run reads every file.

    Returns
    -------
    list of RawView
        In camera order, then file order; ``exif`` is the relative exposure (median over all views
        = 1), or 1 for every view when no file has EXIF exposure tags.

    Raises
    ------
    CaptureError
        Unreadable file; files of one camera with different sizes or full-colour/Bayer mixed; some
        files with EXIF exposure and some without (give ``exposure`` overrides for those).
    """
    import dataclasses
    import functools

    jobs = [(k, p) for k in range(len(spec.cameras)) for p in spec.raw_files(k)]
    views: list[RawView] = []
    used = set()
    for i, (k, p) in enumerate(jobs):
        cam = spec.cameras[k]
        view = None
        if cache is not None:
            folder, options = cache
            file = Path(folder) / _decoded_key(spec, k, p, options)
            used.add(file.name)
            view = _read_decoded(file, f"{cam.folder}/{p.name}", k, p)
            if view is not None:
                e = cam.exposure.get(p.name)
                view = dataclasses.replace(view, exif=float(e) if e is not None else exif_exposure(p))
        if view is None:
            view = load_view(spec, k, p, binning=None if binning is None else functools.partial(binning, k))
            if cache is not None:
                _store_decoded(file, view)
        views.append(view)
        if progress is not None:
            progress("read", i + 1, len(jobs))
    if cache is not None and Path(cache[0]).is_dir():
        for f in Path(cache[0]).glob("*.npz"):
            if f.name not in used:
                f.unlink()
    for k, cam in enumerate(spec.cameras):
        mine = [v for v in views if v.camera == k]
        sizes = sorted({v.size for v in mine})
        if len(sizes) > 1:
            ex = {s: next(v.name for v in mine if v.size == s) for s in sizes}
            raise CaptureError(
                f"camera folder {cam.folder!r} mixes image sizes {ex}; one physical camera "
                "has one resolution: move the odd files to a folder of their own (a "
                "separate [[camera]]) or remove them."
            )
        if len({v.source_cfa is None for v in mine}) > 1:
            raise CaptureError(f"camera folder {cam.folder!r} mixes Bayer and full-colour files.")
    known = [v.exif for v in views if v.exif is not None]
    if known and len(known) < len(views):
        missing = [v.name for v in views if v.exif is None][:5]
        raise CaptureError(
            f"no EXIF exposure (ExposureTime, ISO, FNumber) in {missing}...; give them "
            "'exposure = {<file> = <value>}' in their [[camera]] table, in the units "
            "time × ISO / f-number²."
        )
    med = float(np.median(known)) if known else 1.0
    return [dataclasses.replace(v, exif=(v.exif / med) if known else 1.0) for v in views]


def relative_exposures(spec: CaptureSpec) -> dict[str, float]:
    """Every RAW file's relative exposure as :func:`load_views` gives it (``"<folder>/<file>"`` →
    exposure), read from the files' tags and the capture file's overrides only (no pixel data)."""
    names, values = [], []
    for k, cam in enumerate(spec.cameras):
        for p in spec.raw_files(k):
            e = cam.exposure.get(p.name)
            names.append(f"{cam.folder}/{p.name}")
            values.append(float(e) if e is not None else exif_exposure(p))
    known = [e for e in values if e is not None]
    med = float(np.median(known)) if known else 1.0
    return {n: (e / med if known and e is not None else 1.0) for n, e in zip(names, values)}


# ---------------------------------------------------------------------------------------------
# White → 1 scale
# ---------------------------------------------------------------------------------------------


def camera_white(spec: CaptureSpec, k: int) -> np.ndarray:
    """The un-balanced response of camera ``k`` to the perfect white under the illuminant, max 1, (3,)."""
    import zonotope

    cam = spec.load_ssf(k)
    light = spec.load_illuminant()
    shape = zonotope.common_shape(cam, light, interval=5)
    g = zonotope.generators(cam, light, shape, normalise=None).values.sum(0)
    return g / g.max()


def _superpixels(v: RawView) -> tuple[np.ndarray, np.ndarray]:
    """(M, 3) responses and (M,) validity of 2 × 2 super-pixels (or pixels of full-colour views)."""
    if v.full_colour:
        return v.values.reshape(-1, 3), np.all(v.weight > 0, -1).reshape(-1)
    H, W = (v.shape[0] // 2) * 2, (v.shape[1] // 2) * 2
    w = v.weight[:H, :W]
    s = (v.values[:H, :W] * w).reshape(H // 2, 2, W // 2, 2, 3).sum((1, 3))
    n = w.reshape(H // 2, 2, W // 2, 2, 3).sum((1, 3))
    ok = np.all(n == np.array([1, 2, 1]), -1)  # every site of the Bayer quad valid (none saturated)
    return (s / np.maximum(n, 1)).reshape(-1, 3), ok.reshape(-1)


def brightest_neutral(
    views: list[RawView], white: np.ndarray, *, tolerance: float = 0.05, percentile: float = 99.5
) -> float:
    """Raw level (largest channel, exposure 1) of the brightest neutral surface in ``views``.

    Parameters
    ----------
    views : list of RawView
        Views of one camera.
    white : array_like of shape (3,)
        The camera's white response (max 1).
    tolerance : float
        A pixel is neutral when each channel / white ratio is within this fraction of their mean.
    percentile : float
        Percentile of the neutral pixels' levels taken for the white.
    """
    white = np.asarray(white, float)
    levels = []
    for v in views:
        c, ok = _superpixels(v)
        r = c / white / v.exif
        mean = r.mean(-1)
        neutral = ok & (mean > 0) & np.all(np.abs(r / np.maximum(mean, 1e-12)[:, None] - 1) < tolerance, -1)
        levels.append(mean[neutral])
    lv = np.concatenate(levels) if levels else np.zeros(0)
    if lv.size < 10:
        raise CaptureError(
            "too few neutral (grey/white) pixels to estimate the white level; mark a "
            'white patch in capture.toml ([white] method = "patch").'
        )
    return float(np.percentile(lv, percentile))


def check_white_box(spec: CaptureSpec, views: list[RawView]) -> RawView | None:
    """The view of ``[white] image`` once its ``box`` is known to lie inside it with a valid pixel in
    every channel (None without ``method = "patch"``); checked as soon as the files are read, so that a
    bad box is refused before poses and training rather than at the correct step.

    Raises
    ------
    CaptureError
        The image is no camera's view; the box is outside it or has no valid pixel in some channel.
    """
    if spec.white.method != "patch":
        return None
    return _checked_white(spec, views)[0]


def _checked_white(spec: CaptureSpec, views: list[RawView]) -> tuple[RawView, np.ndarray]:
    """:func:`check_white_box`'s view and the box's mean (:func:`white_patch`), read once."""
    v = next((v for v in views if v.name == Path(spec.white.image).as_posix()), None)
    if v is None:
        raise CaptureError(
            f"{spec.file}: [white].image {spec.white.image!r} is not one of the capture's views."
        )
    H, W = v.size
    _, _, x1, y1 = spec.white.box
    if x1 > W or y1 > H:
        raise CaptureError(f"{spec.file}: [white].box {list(spec.white.box)} lies outside the {W}×{H} image.")
    mean, sites = white_patch(spec, v)
    if np.any(sites == 0):
        raise CaptureError(
            f"{spec.file}: [white].box {list(spec.white.box)} has no valid pixel in some channel "
            "(saturated or too small); choose a larger, unsaturated patch."
        )
    return v, mean


def white_box(spec: CaptureSpec, v: RawView) -> tuple[int, int, int, int]:
    """``[white] box`` (full-resolution pixels) in ``v``'s pixels: the blocks of a binned view that lie
    wholly inside the box (along an axis where none does, the blocks it touches), the box itself
    otherwise. Why: a block that straddles the box's edge averages in sites beyond it, usually the
    card's dark surround (2–4 % off the green and blue of a tight box at binning 2)."""
    x0, y0, x1, y1 = spec.white.box
    f = v.binning
    if f == 1:
        return x0, y0, x1, y1
    a0, a1 = -(-x0 // f), x1 // f
    b0, b1 = -(-y0 // f), y1 // f
    if a1 <= a0:
        a0, a1 = x0 // f, max(-(-x1 // f), x0 // f + 1)
    if b1 <= b0:
        b0, b1 = y0 // f, max(-(-y1 // f), y0 // f + 1)
    return a0, b0, a1, b1


def white_patch(spec: CaptureSpec, v: RawView) -> tuple[np.ndarray, np.ndarray]:
    """The mean linear value per channel (3,) of ``[white] box`` in ``v``, and the number of valid
    sites (3,) it averages (a channel without one has mean NaN): over the box's own sites at full
    resolution (the RAW file read again for a binned view), so that the white does not depend on the
    working resolution."""
    x0, y0, x1, y1 = spec.white.box
    if v.binning == 1 or v.path is None:
        a0, b0, a1, b1 = white_box(spec, v)
        val, wt = v.values[b0:b1, a0:a1], v.weight[b0:b1, a0:a1]
    else:
        source = open_raw(v.path, spec.cameras[v.camera])
        r0 = y0 - y0 % 2  # a Bayer mosaic's rows are read from an even row
        val, wt = source.rows(r0, y1)
        val, wt = val[y0 - r0 :, x0:x1], wt[y0 - r0 :, x0:x1]
    val = np.asarray(val, float).reshape(-1, 3)
    wt = np.asarray(wt, float).reshape(-1, 3)
    sites = wt.sum(0)
    with np.errstate(invalid="ignore", divide="ignore"):
        return (val * wt).sum(0) / sites, sites


def white_scale(spec: CaptureSpec, views: list[RawView]) -> dict:
    """Per camera, the divisor that puts raw responses (exposure 1) on the white → 1 scale.

    With ``[white] method = "patch"`` the camera that photographed the patch gets its white per channel
    from the patch (mean ÷ reflectance ÷ exposure); the others ``k · n``, ``n`` their SSF's white and
    ``k`` the patch's level carried over by the ratio of the cameras' brightest-neutral levels. Without
    a patch every camera gets ``k · n`` with ``k`` its brightest-neutral level.

    Returns
    -------
    dict
        ``scale``: list of arrays (3,), ``c = raw / scale[k]``; ``method``; ``levels``: the
        brightest-neutral level per camera; ``whites``: each camera's SSF white (max 1).
    """
    whites = [camera_white(spec, k) for k in range(len(spec.cameras))]
    levels = [
        brightest_neutral([v for v in views if v.camera == k], whites[k]) for k in range(len(spec.cameras))
    ]
    ks = list(levels)
    if spec.white.method == "patch":
        k0 = spec.white_camera
        v, mean = _checked_white(spec, views)  # the RAW file read once for the check and the mean
        patch = mean / (spec.white.reflectance * v.exif)  # the patch camera's white, per channel
        k_patch = float(np.mean(patch / whites[k0]))
        ks = [k_patch * levels[k] / levels[k0] for k in range(len(spec.cameras))]
    scale = [ks[k] * whites[k] for k in range(len(ks))]
    if spec.white.method == "patch":
        # measured per channel rather than through the SSF's white (which carries the SSF's calibration
        # error: 0.7 % in the simulated Canon's red, worth 0.09 ΔE00 of the fused three-camera estimate)
        scale[k0] = patch
    return {
        "scale": scale,
        "method": spec.white.method,
        "levels": levels,
        "whites": whites,
    }
