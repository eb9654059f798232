"""Atomic writes and reads of the files the steps leave in ``OUT`` (JSON, float TIFF, 8-bit PNG) and
the index of views a render step wrote.
"""

from __future__ import annotations

import json
from collections.abc import Callable
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from .._errors import SplatError

if TYPE_CHECKING:
    pass
from .spec import CaptureError, CaptureSpec
from .workspace import read_json

__all__ = [
    "atomic_write",
    "read_index",
    "read_tiff",
    "write_json",
    "write_png8",
    "write_tiff",
]


def atomic_write(path: Path, write: Callable[[Path], object]) -> Path:
    """Write through a temporary sibling and rename (zonotope's shared atomic writer)."""
    from zonotope.utilities import atomic_path

    return atomic_path(path, write)


def write_json(path: Path, doc) -> Path:
    """Write ``doc`` as indented JSON, atomically (numpy scalars as floats)."""
    return atomic_write(path, lambda p: p.write_text(json.dumps(doc, indent=1, default=float)))


def write_tiff(path: Path, a: np.ndarray) -> Path:
    """Write ``a`` as a float32 TIFF, atomically, refusing NaN/inf; read back by :func:`read_tiff`."""
    import tifffile

    a = np.asarray(a, np.float32)
    if not np.all(np.isfinite(a)):
        raise SplatError(f"{path}: refusing to write NaN/inf values.")
    return atomic_write(
        path, lambda p: tifffile.imwrite(p, a, photometric="minisblack", planarconfig="contig", metadata=None)
    )


def write_png8(path: Path, rgb: np.ndarray, *, upscale: int = 1) -> Path:
    """Write an 8-bit PNG of ``rgb`` in [0, 1], atomically, enlarged ``upscale`` times for viewing."""
    from PIL import Image

    img = Image.fromarray((np.clip(rgb, 0, 1) * 255 + 0.5).astype(np.uint8))
    if upscale > 1:
        img = img.resize((img.width * upscale, img.height * upscale), Image.Resampling.BICUBIC)
    return atomic_write(path, lambda p: img.save(p, format="PNG"))


def read_tiff(path: Path) -> np.ndarray:
    """Read a TIFF written by :func:`write_tiff`."""
    import tifffile

    return np.asarray(tifffile.imread(path), np.float64)


def read_index(spec: CaptureSpec, path: Path) -> dict:
    """``render/index.json``: view name → {camera, kind, dir}, each ``dir`` the view's own folder
    (:meth:`splat.capture.CaptureSpec.out_stem`), so that no path read from the file leads elsewhere."""
    index = read_json(path, what="render index")
    for name, info in index.items():
        try:
            ok = isinstance(info, dict) and info.get("dir") == spec.out_stem(name) and "kind" in info
        except CaptureError:
            ok = False
        if not ok:
            raise CaptureError(
                f"{path}: not a render index of this capture (entry {name!r}); run the render step."
            )
    return index
