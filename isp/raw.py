"""RAW input: a camera mosaic and the metadata needed to develop it.

Pixels are decoded by rawpy (LibRaw), which reads every common RAW format and DNG. The colour tags
of DNG files are read with tifffile (:mod:`isp.dng`) because rawpy's ``rgb_xyz_matrix`` is all zeros
for DNG (LibRaw #425, #751). For other formats the XYZ → camera matrix is LibRaw's built-in one
(Adobe's ColorMatrix2, measured under D65) and the as-shot white balance is the camera's.
"""

from __future__ import annotations

import os
import struct
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ._errors import InputFileNotFoundError, RawFormatError
from ._tol import NEUTRAL_MIN, STRIPPED_BITS_PER_PIXEL, STRIPPED_NONZERO
from .cfa import check_cfa
from .dng import DNGProfile, camera_neutral_to_xy, read_dng_tags

__all__ = ["RawImage", "auto_white_balance", "read_raw"]


@dataclass(frozen=True, eq=False)
class RawImage:
    """A RAW mosaic with its metadata.

    Attributes
    ----------
    mosaic : ndarray of shape (H, W), uint16
        Raw values of the active (visible) area, black level included.
    cfa : str
        Bayer pattern of ``mosaic``, e.g. ``"RGGB"`` (see :data:`CFA_PATTERNS`).
    black_level : ndarray of shape (2, 2)
        Black level per CFA site (same layout as ``cfa``).
    white_level : float
        Saturation value of ``mosaic``.
    linearisation_table : ndarray of shape (n,) or None
        DNG LinearizationTable (raw value → linear value). LibRaw applies it while decoding, so
        :attr:`table_applied` is True for files read by :func:`read_raw`.
    table_applied : bool
        Whether ``mosaic`` already went through ``linearisation_table``.
    as_shot_neutral : ndarray of shape (3,)
        Camera response to the scene white (DNG AsShotNeutral; for non-DNG files the inverse of the
        camera's white-balance multipliers), normalised to max 1.
    profile : DNGProfile
        ColorMatrix1/2, CalibrationIlluminant1/2, CameraCalibration1/2, ForwardMatrix1/2,
        AnalogBalance.
    make, model : str
    path : Path or None
    baseline_exposure : float
        DNG BaselineExposure (EV), 0 when absent.
    tags : dict
        Every tag read (DNG files), for inspection.
    white_balance_source : str
        Where :attr:`as_shot_neutral` came from: ``"AsShotNeutral"``, ``"AsShotWhiteXY"`` (DNG tags),
        ``"camera"`` (the camera's as-shot multipliers, non-DNG), ``"auto"`` (the file records no
        as-shot white: LibRaw's automatic grey world, :func:`auto_white_balance`, which LibRaw's camera
        white balance also falls back to), ``"daylight"`` (LibRaw's daylight multipliers, when no
        block is unclipped) or ``"none"`` (unit gains).
    orientation : int
        TIFF/EXIF Orientation code 1–8 of the picture (1 = as stored, 6 = rotate 90° clockwise).
    capture : dict
        Shooting metadata when recorded: ``exposure_time`` (s), ``f_number``, ``iso``, ``datetime``
        (``"YYYY:MM:DD HH:MM:SS"``).
    """

    mosaic: np.ndarray
    cfa: str
    black_level: np.ndarray
    white_level: float
    profile: DNGProfile
    as_shot_neutral: np.ndarray
    linearisation_table: np.ndarray | None = None
    table_applied: bool = True
    make: str = ""
    model: str = ""
    path: Path | None = None
    baseline_exposure: float = 0.0
    tags: dict = field(default_factory=dict, repr=False)
    white_balance_source: str = "AsShotNeutral"
    orientation: int = 1
    capture: dict = field(default_factory=dict, repr=False)

    def __post_init__(self) -> None:
        m = np.asarray(self.mosaic)
        if m.ndim != 2 or m.shape[0] < 2 or m.shape[1] < 2:
            raise RawFormatError(f"mosaic: expected an (H, W) array with H, W ≥ 2; got shape {m.shape}.")
        object.__setattr__(self, "cfa", check_cfa(self.cfa))
        black = np.broadcast_to(np.asarray(self.black_level, dtype=np.float64), (2, 2)).copy()
        where = f"{self.path}: " if self.path else ""
        if not float(self.white_level) > black.max():
            raise RawFormatError(
                f"{where}white_level={self.white_level} must exceed the black level {black.max()} "
                "(WhiteLevel and BlackLevel); the file's levels are damaged."
            )
        object.__setattr__(self, "black_level", black)
        n = _checked_neutral(self.as_shot_neutral, where, "as_shot_neutral")
        object.__setattr__(self, "as_shot_neutral", n / n.max())

    @property
    def shape(self) -> tuple[int, int]:
        """(H, W) of the mosaic."""
        return self.mosaic.shape  # type: ignore[return-value]

    @property
    def is_dng(self) -> bool:
        """Whether the metadata came from DNG tags."""
        return bool(self.tags)

    def crop(self, top: int, left: int, height: int, width: int) -> RawImage:
        """A copy restricted to ``mosaic[top:top+height, left:left+width]`` (CFA phase kept).

        ``top`` and ``left`` must be even so the Bayer pattern stays the same.
        """
        if top % 2 or left % 2 or top < 0 or left < 0:
            raise RawFormatError(f"crop origin ({top}, {left}) must be even and ≥ 0 to keep the CFA phase.")
        sub = self.mosaic[top : top + height, left : left + width]
        if sub.shape[0] < 2 or sub.shape[1] < 2:
            raise RawFormatError(
                f"crop ({top}, {left}, {height}, {width}) leaves {sub.shape}; the mosaic is {self.shape}."
            )
        from dataclasses import replace

        return replace(self, mosaic=np.ascontiguousarray(sub))


_COLOUR_LETTER = {0: "R", 1: "G", 2: "B", 3: "G"}


def _checked_neutral(neutral, where: str, name: str) -> np.ndarray:
    """``neutral`` as 3 finite positive values whose smallest is ≥ NEUTRAL_MIN × the largest.

    Raises
    ------
    RawFormatError
        ``where`` (the file) and ``name`` (the tag) in the message, with what to do.
    """
    n = np.asarray(neutral, dtype=np.float64).reshape(-1)
    shown = "(" + ", ".join(f"{v:.3g}" for v in n[:4]) + ")"
    if n.shape != (3,) or not np.all(np.isfinite(n)) or np.any(n <= 0):
        raise RawFormatError(
            f"{where}{name} = {shown}: expected 3 positive finite values; the white-balance metadata is "
            "damaged: convert the camera's original RAW again or correct the tag (exiftool)."
        )
    if n.min() < NEUTRAL_MIN * n.max():
        raise RawFormatError(
            f"{where}{name} = {shown}: a channel below {NEUTRAL_MIN:g} × the largest would need a gain of "
            f"{n.max() / n.min():.3g}; the white-balance metadata is damaged: convert the camera's "
            "original RAW again or correct the tag (exiftool)."
        )
    return n


def _check_layout_tags(path: Path, width: int, height: int, bits: int, active) -> None:
    """Refuse raw-IFD layout tags LibRaw would accept and decode into garbage.

    Raises
    ------
    RawFormatError
        Naming the file and the tag: image dimensions below 2 × 2 (no CFA period), BitsPerSample
        outside 1–32, or an ActiveArea that is empty or leaves the image.
    """

    def bad(tag: str, value, detail: str) -> RawFormatError:
        return RawFormatError(
            f"{path}: {tag} = {value}: {detail}; the file is damaged: convert the camera's "
            "original RAW again."
        )

    if width < 2 or height < 2:
        raise bad(
            "ImageWidth × ImageLength", f"{width} × {height}", "a CFA mosaic needs at least 2 × 2 pixels"
        )
    if not 1 <= bits <= 32:
        raise bad("BitsPerSample", bits, "raw samples have 1 to 32 bits")
    if active is not None:
        a = [int(x) for x in np.ravel(active)]
        if len(a) != 4:
            raise bad("ActiveArea", a, "expected 4 values (top, left, bottom, right)")
        top, left, bottom, right = a
        if (
            not (0 <= top < bottom <= height and 0 <= left < right <= width)
            or min(bottom - top, right - left) < 2
        ):
            raise bad(
                "ActiveArea",
                tuple(a),
                f"(top, left, bottom, right) must be a non-empty area of at least 2 × 2 pixels "
                f"inside the {width} × {height} image",
            )


def _cfa_from_rawpy(raw) -> str:
    desc = raw.color_desc.decode()
    if desc not in ("RGBG", "RGB"):
        raise RawFormatError(
            f"colour filter array {desc!r} is not a Bayer RGB array; only RGGB-type "
            "Bayer sensors are supported (no X-Trans, CYGM or Foveon)."
        )
    colors = raw.raw_colors_visible[:2, :2]
    return "".join(_COLOUR_LETTER[int(c)] for c in colors.ravel())


#: LibRaw's ``flip`` (dcraw's: bit 4 transpose, 2 flip rows, 1 flip columns) → TIFF Orientation.
_FLIP_TO_ORIENTATION = {0: 1, 1: 2, 3: 3, 2: 4, 4: 5, 6: 6, 7: 7, 5: 8}


def _capture_info(other) -> dict:
    """Exposure, aperture, ISO and time from rawpy's ``other`` (only the values it recorded)."""
    out: dict = {}
    recorded = other.timestamp.year > 1970  # LibRaw's defaults when nothing is recorded: 1 s, f/1, the epoch
    if other.shutter_speed > 0 and (recorded or other.shutter_speed != 1.0):
        out["exposure_time"] = float(other.shutter_speed)
    if other.aperture > 0 and other.aperture != 1.0:
        out["f_number"] = round(float(other.aperture), 1)
    if other.iso_speed > 0:
        out["iso"] = round(other.iso_speed)
    if other.timestamp.year > 1970:
        out["datetime"] = other.timestamp.strftime("%Y:%m:%d %H:%M:%S")
    return out


def _capture_from_tags(tags: dict) -> dict:
    """The same from DNG IFD 0 tags (they win over LibRaw's values)."""
    out: dict = {}
    for key, name in (("exposure_time", "ExposureTime"), ("f_number", "FNumber")):
        v = tags.get(name)
        if v is not None and np.size(v) and float(np.ravel(v)[0]) > 0:
            out[key] = float(np.ravel(v)[0])
    iso = tags.get("ISOSpeedRatings")
    if iso is not None and np.size(iso) and float(np.ravel(iso)[0]) > 0:
        out["iso"] = int(np.ravel(iso)[0])
    for name in ("DateTimeOriginal", "DateTime"):
        v = tags.get(name)
        if isinstance(v, str) and v.strip(" \x00:"):
            out["datetime"] = v.strip()
            break
    return out


#: DNG Compression values LibRaw decodes: none, lossless JPEG, Deflate, lossy JPEG, JPEG XL.
_DNG_COMPRESSIONS = {
    1: "uncompressed",
    7: "lossless JPEG",
    8: "Deflate",
    34892: "lossy JPEG",
    52546: "JPEG XL",
}


def _check_dng_data(path: Path, size: int) -> None:
    """Check that the raw IFD's pixel data exist and look like what its Compression tag says.

    LibRaw does not report a decoder that fails to start (e.g. Compression=7 on data that are not
    lossless JPEG): it returns its raw buffer unwritten, i.e. zeros the first time and leftover heap
    memory afterwards. So the structure is checked before LibRaw is asked for pixels: every strip or
    tile lies inside the file and starts with its codec's signature, and uncompressed data are large
    enough for the image. Files tifffile cannot parse are left to LibRaw.
    """
    import logging

    import tifffile

    log = logging.getLogger("tifffile")  # a damaged file is our error to report, not tifffile's log
    level = log.level
    log.setLevel(logging.CRITICAL)
    try:
        with tifffile.TiffFile(path) as tif:
            ifd0 = tif.pages[0]
            if 50706 not in ifd0.tags:  # DNGVersion: other TIFF-based RAW formats are LibRaw's job
                return
            raw_ifd = None
            for page in [ifd0, *(getattr(ifd0, "pages", None) or [])]:
                sub = page.tags.get(254)
                photometric = int(page.tags[262].value) if 262 in page.tags else -1
                if (sub is None or int(sub.value) == 0) and photometric in (32803, 34892):
                    raw_ifd = page
                    break
            if raw_ifd is None:
                return
            t = raw_ifd.tags
            compression = int(t[259].value) if 259 in t else 1
            offsets = t.get(324) or t.get(273)
            counts = t.get(325) or t.get(279)
            offsets = [int(x) for x in np.ravel(offsets.value)] if offsets is not None else []
            counts = [int(x) for x in np.ravel(counts.value)] if counts is not None else []
            width, height = int(raw_ifd.imagewidth), int(raw_ifd.imagelength)
            bits = int(np.ravel(t[258].value)[0]) if 258 in t else 16
            spp = int(t[277].value) if 277 in t else 1
            active = t[50829].value if 50829 in t else ifd0.tags[50829].value if 50829 in ifd0.tags else None
            heads = []
            with open(path, "rb") as fh:
                for off in offsets[:4096]:
                    fh.seek(off)
                    heads.append(fh.read(2))
    except (tifffile.TiffFileError, OSError, ValueError, TypeError, KeyError, IndexError, struct.error):
        return
    finally:
        log.setLevel(level)

    _check_layout_tags(path, width, height, bits, active)

    def bad(detail: str) -> RawFormatError:
        return RawFormatError(
            f"{path}: not a readable RAW file (no pixel data LibRaw can decode: {detail}). "
            "The file is truncated or corrupt; read_raw(..., metadata_only=True) reads its "
            "metadata only."
        )

    if compression not in _DNG_COMPRESSIONS:
        raise bad(f"Compression={compression} is not a DNG compression, known: {_DNG_COMPRESSIONS}")
    if not offsets or len(offsets) != len(counts):
        raise bad(f"{len(offsets)} strip/tile offsets for {len(counts)} byte counts")
    if any(o < 8 or c <= 0 or o + c > size for o, c in zip(offsets, counts)):
        raise bad(f"a strip or tile lies outside the file of {size} bytes")
    if compression == 1 and sum(counts) * 8 < width * height * spp * bits:
        raise bad(
            f"{sum(counts)} bytes of uncompressed data for a {width}×{height} image of {bits}-bit samples"
        )
    if compression in (7, 34892) and any(h != b"\xff\xd8" for h in heads):
        raise bad(
            f"Compression={compression} ({_DNG_COMPRESSIONS[compression]}) but the data do not start "
            "with a JPEG marker"
        )
    if compression == 8 and any(
        len(h) < 2 or h[0] & 0x0F != 8 or int.from_bytes(h, "big") % 31 for h in heads
    ):
        raise bad("Compression=8 (Deflate) but the data are not a zlib stream")


def auto_white_balance(mosaic, cfa: str, black_level, white_level: float) -> np.ndarray | None:
    """The camera neutral LibRaw's automatic white balance picks: a grey-world mean per channel.

    As dcraw/LibRaw's ``use_auto_wb`` (and ``use_camera_wb`` on a file without an as-shot white):
    the mosaic is cut into 8 × 8 blocks from its top-left corner; a block holding any raw value above
    ``white_level − black −`` :data:`isp._tol.AUTO_WB_MARGIN` is left out (LibRaw compares the raw
    value with its maximum less the black level); in the others every value minus its site's black
    level (negative → 0) is summed per channel. The neutral is the per-channel mean.

    Parameters
    ----------
    mosaic : array_like of shape (H, W)
        Raw values (black level included).
    cfa
        2 × 2 pattern.
    black_level : float or array_like of shape (2, 2)
        Black level per CFA site.
    white_level
        Saturation value.

    Returns
    -------
    ndarray of shape (3,) or None
        The neutral normalised to max 1; None when no block is unsaturated or a channel sums to 0.
    """
    from ._tol import AUTO_WB_MARGIN
    from .cfa import CHANNEL_INDEX, check_cfa

    m = np.asarray(mosaic)
    H, W = m.shape
    black = np.broadcast_to(np.asarray(black_level, dtype=np.float64), (2, 2))
    site = np.array([CHANNEL_INDEX[c] for c in check_cfa(cfa)]).reshape(2, 2)
    Wp = -(-W // 8) * 8
    sums, counts = np.zeros(3), np.zeros(3)
    # LibRaw compares the raw value (black included) with its maximum after the black was taken off it
    limit = float(white_level) - float(black.max()) - AUTO_WB_MARGIN
    for r0 in range(0, H, 512):  # 8-row multiples: bounded temporaries at any size
        rows = m[r0 : r0 + 512]
        h = rows.shape[0]
        Hp = -(-h // 8) * 8
        sat = np.zeros((Hp, Wp), bool)
        sat[:h, :W] = rows > limit
        keep = ~sat.reshape(Hp // 8, 8, Wp // 8, 8).any(axis=(1, 3))  # unsaturated blocks
        keep_px = np.repeat(np.repeat(keep, 8, axis=0), 8, axis=1)[:h, :W]
        for dy in (0, 1):
            for dx in (0, 1):
                v = rows[dy::2, dx::2].astype(np.float64) - black[(r0 + dy) % 2, dx]
                k = keep_px[dy::2, dx::2]
                c = site[(r0 + dy) % 2, dx]
                sums[c] += np.maximum(v, 0.0)[k].sum()
                counts[c] += k.sum()
    if np.any(counts == 0) or np.any(sums <= 0):
        return None
    neutral = sums / counts
    return neutral / neutral.max()


def _auto_or_none(mosaic, cfa: str, black, white: float) -> np.ndarray | None:
    if not np.any(mosaic):  # metadata-only files: no pixels to average
        return None
    return auto_white_balance(mosaic, cfa, black, white)


def read_raw(path: str | os.PathLike, *, metadata_only: bool = False) -> RawImage:
    """Read a RAW or DNG file.

    Parameters
    ----------
    path
        Any format LibRaw reads (DNG, CR2, CRW, NEF, ARW, ...).
    metadata_only
        Accept files whose pixel data are absent (decode to zeros), e.g. metadata test files.

    Returns
    -------
    RawImage

    Raises
    ------
    FileNotFoundError
        ``path`` does not exist.
    RawFormatError
        Not a RAW file, truncated or corrupt data, a non-Bayer sensor, an image with no pixel data
        (unless ``metadata_only``), or colour metadata that cannot be used.

    Examples
    --------
    >>> raw = read_raw("photo.dng")  # doctest: +SKIP
    >>> raw.cfa, raw.black_level, raw.profile.color_matrix_1  # doctest: +SKIP
    """
    import rawpy

    path = Path(path)
    if not path.is_file():
        raise InputFileNotFoundError(f"{path}: no such file.")
    size = path.stat().st_size
    if not metadata_only:
        _check_dng_data(path, size)
    try:
        with rawpy.imread(str(path)) as raw:
            mosaic = np.array(raw.raw_image_visible, dtype=np.uint16, copy=True)
            cfa = _cfa_from_rawpy(raw)
            idx = raw.raw_colors_visible[:2, :2]
            black = np.asarray(raw.black_level_per_channel, dtype=np.float64)[idx]
            white = float(raw.white_level)
            cam_wb = np.asarray(raw.camera_whitebalance[:3], dtype=np.float64)
            day_wb = np.asarray(raw.daylight_whitebalance[:3], dtype=np.float64)
            libraw_cm = np.asarray(raw.rgb_xyz_matrix[:3], dtype=np.float64)
            orientation = _FLIP_TO_ORIENTATION.get(int(raw.sizes.flip), 1)
            capture = _capture_info(raw.other)
    except RuntimeError as exc:
        if "not flat" not in str(exc):
            raise
        raise RawFormatError(
            f"{path}: a full-colour RAW (e.g. a LinearRaw DNG) has no CFA mosaic; read_raw reads mosaiced "
            "sensors only. Read its pixels with tifffile, or splat.capture for multispectral captures."
        ) from exc
    except rawpy.LibRawError as exc:
        msg = exc.args[0].decode() if exc.args and isinstance(exc.args[0], bytes) else str(exc)
        raise RawFormatError(
            f"{path}: not a readable RAW file ({type(exc).__name__}: {msg}). The file "
            "may be truncated, corrupt or of a format LibRaw does not know."
        ) from exc
    # Stripped pixel data decode to zeros or to whatever LibRaw's buffers held, so judge by size
    # (_tol.STRIPPED_BITS_PER_PIXEL) and by the share of non-zero pixels (_tol.STRIPPED_NONZERO).
    too_small = path.stat().st_size < mosaic.size * STRIPPED_BITS_PER_PIXEL / 8
    stripped = too_small or np.count_nonzero(mosaic) < STRIPPED_NONZERO * mosaic.size
    if not metadata_only and stripped:
        raise RawFormatError(
            f"{path}: the image has no pixel data (file too small or all zeros). Use "
            "read_raw(..., metadata_only=True) to read its metadata only."
        )
    if stripped:
        mosaic[:] = 0  # never hand out LibRaw's stale buffer contents
    tags: dict = {}
    with open(path, "rb") as fh:
        magic = fh.read(4)
    if magic in (b"II*\x00", b"MM\x00*"):
        try:
            tags = read_dng_tags(path)
        except RawFormatError:
            tags = {}  # a TIFF-based RAW (CR2, NEF, ...) that is not DNG
    try:  # a damaged file can carry tags of the wrong type or shape
        if stripped:  # LibRaw's black of a file without pixels is whatever its buffers held: the tag's
            level = np.ravel(np.asarray(tags.get("BlackLevel", [0.0]), dtype=np.float64))
            black = np.broadcast_to(level.reshape(2, 2) if level.size == 4 else level[:1], (2, 2)).copy()
        if tags:
            try:
                profile = DNGProfile.from_tags(tags)
            except RawFormatError as exc:  # names the tag; add the file
                raise RawFormatError(f"{path}: {exc}") from exc
            source = "AsShotNeutral" if "AsShotNeutral" in tags else "AsShotWhiteXY"
            if "AsShotNeutral" in tags:
                neutral = np.asarray(tags["AsShotNeutral"], dtype=np.float64)
            elif "AsShotWhiteXY" in tags:
                import colour

                xy = np.asarray(tags["AsShotWhiteXY"], dtype=np.float64)
                neutral = profile.XYZ_to_camera(xy) @ colour.xy_to_XYZ(xy)
            else:
                source = "camera" if np.all(cam_wb > 0) else "auto"
                neutral = 1.0 / cam_wb if np.all(cam_wb > 0) else _auto_or_none(mosaic, cfa, black, white)
                source = "none" if neutral is None else source
                neutral = np.ones(3) if neutral is None else neutral
            if source != "none":
                neutral = _checked_neutral(neutral, f"{path}: ", source)
                try:  # the white the development will interpolate the matrices for, checked now
                    camera_neutral_to_xy(neutral, profile)
                except RawFormatError as exc:
                    raise RawFormatError(f"{path}: {source} with ColorMatrix: {exc}") from exc
            capture.update(_capture_from_tags(tags))
            table = tags.get("LinearizationTable")
            table = None if table is None else np.asarray(table, dtype=np.float64)
            make = str(tags.get("Make", "") or "")
            model = str(tags.get("Model", tags.get("UniqueCameraModel", "")) or "")
            baseline = float(np.ravel(tags.get("BaselineExposure", [0.0]))[0])
        else:
            if not np.any(libraw_cm):
                raise RawFormatError(
                    f"{path}: LibRaw has no colour matrix for this camera; pass a DNGProfile "
                    "or use a correction callable."
                )
            profile = DNGProfile(color_matrix_1=libraw_cm, calibration_illuminant_1=21)
            # LibRaw marks a missing as-shot white balance with cam_mul[0] = -1 (e.g. the EOS D30's CRW);
            # then LibRaw's camera white balance is its automatic one (a grey world), and so is ours
            auto = None if np.all(cam_wb > 0) else _auto_or_none(mosaic, cfa, black, white)
            source = (
                "camera"
                if np.all(cam_wb > 0)
                else "auto"
                if auto is not None
                else "daylight"
                if np.all(day_wb > 0)
                else "none"
            )
            neutral = (
                auto
                if source == "auto"
                else 1.0 / {"camera": cam_wb, "daylight": day_wb}.get(source, np.ones(3))
            )
            table, make, model, baseline = None, "", "", 0.0
    except RawFormatError:
        raise
    except (ValueError, TypeError, IndexError, KeyError, ZeroDivisionError, np.linalg.LinAlgError) as exc:
        raise RawFormatError(
            f"{path}: malformed DNG metadata ({type(exc).__name__}: {exc}); the file may be damaged."
        ) from exc
    return RawImage(
        mosaic=mosaic,
        cfa=cfa,
        black_level=black,
        white_level=white,
        profile=profile,
        as_shot_neutral=neutral,
        linearisation_table=table,
        table_applied=True,
        make=make,
        model=model,
        path=path,
        baseline_exposure=baseline,
        tags=tags,
        white_balance_source=source,
        orientation=orientation,
        capture=capture,
    )
