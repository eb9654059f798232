"""Image output: 16-bit TIFF and PNG, written atomically, never over an input file.

Files are written to a temporary file in the destination folder, synced and moved into place with
``os.replace`` (:func:`zonotope.atomic_path`), so a crash never leaves a half-written image,
readers never see one, an interruption leaves no temporary behind and files get the usual
umask-based permissions.
"""

from __future__ import annotations

import os
import struct
import zlib
from collections.abc import Iterable
from pathlib import Path

import numpy as np

from ._errors import PipelineError

__all__ = ["IMAGE_FORMATS", "to_uint16", "write_image"]

#: File suffixes :func:`write_image` understands.
IMAGE_FORMATS: tuple[str, ...] = (".tif", ".tiff", ".png")


def to_uint16(image) -> np.ndarray:
    """Quantise an image in [0, 1] to 16 bits (values outside are clipped; NaN is an error).

    Parameters
    ----------
    image : array_like of shape (H, W) or (H, W, c)

    Returns
    -------
    ndarray of the same shape, uint16
    """
    from ._config import float_array
    from ._tol import CHUNK_PIXELS

    a = np.asarray(image)
    if a.dtype not in (np.float32, np.float64):
        a = float_array(a, "image")
    out = np.empty(a.shape, dtype=np.uint16)
    flat, flat_out = a.reshape(-1), out.reshape(-1)
    step = 3 * CHUNK_PIXELS  # in chunks: float64 temporaries of one chunk, whatever the image size
    for i in range(0, flat.size, step):
        c = flat[i : i + step].astype(np.float64, copy=False)
        if not np.all(np.isfinite(c)):
            raise PipelineError("image: contains NaN or inf; it cannot be written.")
        flat_out[i : i + step] = np.round(np.clip(c, 0.0, 1.0) * 65535.0)
    return out


SOFTWARE = "isp (zonotope)"  # written into every image, so that --overwrite recognises our own outputs


def _is_our_output(path: Path) -> bool:
    """Whether ``path`` is an image :func:`write_image` wrote (TIFF Software tag or PNG tEXt chunk)."""
    import tifffile

    try:
        with open(path, "rb") as fh:
            head = fh.read(8)
            if head == b"\x89PNG\r\n\x1a\n":
                while True:  # walk the chunks before the pixel data
                    size_kind = fh.read(8)
                    if len(size_kind) < 8 or size_kind[4:] in (b"IDAT", b"IEND"):
                        return False
                    size = struct.unpack(">I", size_kind[:4])[0]
                    data = fh.read(size)
                    fh.read(4)
                    if size_kind[4:] == b"tEXt" and data == b"Software\0" + SOFTWARE.encode():
                        return True
        if head[:4] in (b"II*\x00", b"MM\x00*"):
            with tifffile.TiffFile(path) as tif:
                tag = tif.pages.first.tags.get("Software")
                return tag is not None and tag.value == SOFTWARE
    except (OSError, ValueError, IndexError, struct.error, tifffile.TiffFileError):
        return False
    return False


def _png_bytes(img: np.ndarray) -> bytes:
    """Encode a uint16 (H, W) or (H, W, 1|3|4) array as a 16-bit PNG (ISO/IEC 15948)."""
    if img.ndim == 2:
        img = img[..., None]
    H, W, c = img.shape
    colour_type = {1: 0, 2: 4, 3: 2, 4: 6}[c]
    rows = img.astype(">u2").reshape(H, W * c).view(np.uint8).reshape(H, -1)
    raw = np.concatenate([np.zeros((H, 1), np.uint8), rows], axis=1).tobytes()  # filter 0 per row

    def chunk(kind: bytes, data: bytes) -> bytes:
        return struct.pack(">I", len(data)) + kind + data + struct.pack(">I", zlib.crc32(kind + data))

    header = struct.pack(">IIBBBBB", W, H, 16, colour_type, 0, 0, 0)
    return (
        b"\x89PNG\r\n\x1a\n"
        + chunk(b"IHDR", header)
        + chunk(b"tEXt", b"Software\0" + SOFTWARE.encode())
        + chunk(b"IDAT", zlib.compress(raw, 6))
        + chunk(b"IEND", b"")
    )


def write_image(
    path: str | os.PathLike,
    image,
    *,
    overwrite: bool = False,
    protect: Iterable[str | os.PathLike] = (),
    dtype: str = "uint16",
    icc_profile: bytes | None = None,
    tiff_tags: Iterable[tuple] = (),
) -> Path:
    """Write an image in [0, 1] as a 16-bit TIFF or PNG (or a float32 TIFF), atomically.

    Parameters
    ----------
    path
        Destination; the suffix picks the format (:data:`IMAGE_FORMATS`).
    image : array_like of shape (H, W) or (H, W, 3)
        Values in [0, 1] (clipped), e.g. sRGB-encoded output.
    overwrite
        Replace an existing file (never one of ``protect``).
    protect
        Paths that must never be written (the input RAW files).
    dtype
        ``"uint16"`` (values clipped to [0, 1] and quantised) or ``"float32"`` (TIFF only, values kept
        as they are, e.g. pipeline intermediates).
    icc_profile
        ICC profile of the pixel values, embedded in a TIFF (tag 34675); ignored for PNG.
    tiff_tags
        Extra TIFF tags as tifffile ``extratags`` tuples ``(code, dtype, count, value, writeonce)``,
        e.g. :func:`isp.output_tags` (camera make, model, exposure); ignored for PNG.

    Returns
    -------
    Path

    Raises
    ------
    PipelineError
        Unknown suffix, existing file without ``overwrite``, ``path`` is a protected input, bad shape
        or NaN values.
    """
    path = Path(path)
    suffix = path.suffix.lower()
    if suffix not in IMAGE_FORMATS:
        raise PipelineError(f"{path}: unknown image format {suffix!r}; use one of {list(IMAGE_FORMATS)}.")
    for p in map(Path, protect):
        if p.resolve() == path.resolve() or (p.exists() and path.exists() and os.path.samefile(p, path)):
            raise PipelineError(f"{path} is an input file; refusing to overwrite it.")
    if path.exists() and not overwrite:
        raise PipelineError(f"{path} exists; pass overwrite=True (CLI: --overwrite) or choose another name.")
    if path.exists() and not _is_our_output(path):
        raise PipelineError(
            f"{path} exists and was not written by isp; overwrite replaces only a previous isp output. "
            "Choose another name."
        )
    if dtype not in ("uint16", "float32") or (dtype == "float32" and suffix == ".png"):
        raise PipelineError(f"dtype={dtype!r}: use 'uint16', or 'float32' with a .tif path.")
    if dtype == "float32":
        img = np.asarray(image, dtype=np.float32)
        if not np.all(np.isfinite(img)):
            raise PipelineError("image: contains NaN or inf; it cannot be written.")
    else:
        img = to_uint16(image)
    if img.ndim not in (2, 3) or (img.ndim == 3 and img.shape[-1] not in (1, 3, 4)):
        raise PipelineError(f"image: expected shape (H, W) or (H, W, 3); got {img.shape}.")
    from zonotope.utilities import atomic_path

    def write(tmp: Path) -> None:
        if suffix == ".png":
            tmp.write_bytes(_png_bytes(img))
        else:
            import tifffile

            rgb = img.ndim == 3 and img.shape[-1] == 3
            tifffile.imwrite(
                tmp,
                img,
                photometric="rgb" if rgb else "minisblack",
                metadata=None,
                software=SOFTWARE,
                iccprofile=icc_profile,
                extratags=list(tiff_tags),
            )

    atomic_path(path, write)  # temporary sibling, fsync, rename; no temporary survives an interruption
    return path
