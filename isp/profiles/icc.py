"""ICC v4 input profiles (matrix/TRC) of a camera, for raw developers that use ICC rather than DCP.

:func:`icc_profile` encodes a white-balanced camera RGB → XYZ D50 matrix (a DCP's ForwardMatrix,
or a matrix fitted from a chart) as an ICC.1:2022 (v4.4) *input* profile: device class ``scnr``,
colour space ``RGB``, PCS ``XYZ`` (D50), tags ``desc``, ``cprt`` (multiLocalizedUnicode),
``wtpt`` (D50), ``rXYZ``/``gXYZ``/``bXYZ`` (the matrix columns), ``rTRC``/``gTRC``/``bTRC``
(identity curves: the input is linear) and ``chad`` (the Bradford adaptation from the scene
illuminant's white to D50 the matrix includes), and the MD5 profile ID. :func:`write_icc` writes
it atomically; :func:`read_icc_matrix` reads the matrix back (for tests and checks).

Input of the profile: **linear, white-balanced camera RGB**, the scene white at (1, 1, 1) — what
darktable's *input color profile* and RawTherapee's *input profile* steps receive. A matrix/TRC
profile holds the matrix part only: a DCP's HueSatMap, LookTable and tone curve are not in it.

References
----------
.. [1] International Color Consortium (2022). ICC.1:2022, Image technology colour management —
   Architecture, profile format, and data structure (profile version 4.4), sections 7 (header,
   tag table), 9.2 (tags) and 10 (tag types: ``curv``, ``mluc``, ``sf32``, ``XYZ``).
"""

from __future__ import annotations

import datetime
import hashlib
import os
import struct
from pathlib import Path

import colour
import numpy as np

from .._config import float_array
from .._errors import RawFormatError

__all__ = ["ICC_CREATOR", "ICC_D50", "ICCError", "icc_profile", "read_icc_matrix", "write_icc"]

#: The PCS illuminant of every ICC profile: D50 as the ICC specification rounds it (s15Fixed16).
ICC_D50 = np.array([0.9642, 1.0, 0.8249])

#: Marker of the profiles this module writes (the header's profile creator field).
ICC_CREATOR = b"zono"


class ICCError(RawFormatError):
    """An ICC profile that cannot be written (bad matrix or text) or is not one this module reads."""


def _s15f16(values) -> bytes:
    v = np.asarray(values, dtype=np.float64).ravel()
    return struct.pack(f">{v.size}i", *(round(x * 65536.0) for x in v))


def _xyz_type(xyz) -> bytes:
    return b"XYZ \x00\x00\x00\x00" + _s15f16(xyz)


def _mluc(text: str) -> bytes:
    data = text.encode("utf-16-be")
    return (
        b"mluc\x00\x00\x00\x00"
        + struct.pack(">II", 1, 12)
        + b"enUS"
        + struct.pack(">II", len(data), 28)
        + data
    )


def _pad4(b: bytes) -> bytes:
    return b + b"\x00" * (-len(b) % 4)


def icc_profile(
    XYZ_D50_from_balanced,
    *,
    description: str,
    copyright: str = "",
    illuminant_XYZ=None,
    when: datetime.datetime | None = None,
) -> bytes:
    """An ICC v4 matrix/TRC input profile for linear, white-balanced camera RGB.

    Parameters
    ----------
    XYZ_D50_from_balanced : array_like of shape (3, 3)
        White-balanced camera RGB → XYZ D50 (e.g. a DCP ForwardMatrix); its columns become the
        ``rXYZ``/``gXYZ``/``bXYZ`` tags. ``M @ (1, 1, 1)`` should be D50 (a ForwardMatrix is).
    description, copyright
        The ``desc`` and ``cprt`` texts.
    illuminant_XYZ : array_like of shape (3,), optional
        White of the scene illuminant the matrix was fitted under (any scale): the ``chad`` tag
        is the Bradford matrix from it to D50. Default D50 (identity ``chad``).
    when
        Creation time in the header (default now, UTC).

    Returns
    -------
    bytes
        The profile.

    Raises
    ------
    ICCError
        A matrix that is not a finite, invertible 3 × 3 with entries in the s15Fixed16 range, or a
        white that is not finite and positive.
    """
    M = float_array(XYZ_D50_from_balanced, "XYZ_D50_from_balanced", ICCError)
    if M.size != 9 or not np.all(np.isfinite(M)) or np.any(np.abs(M) >= 32767):
        raise ICCError(f"XYZ_D50_from_balanced: need a finite 3 × 3 matrix, got shape {M.shape}.")
    M = M.reshape(3, 3)
    white = M @ np.ones(3)
    if np.all(white > 0):  # the white exactly on the PCS white (a DCP's D50 differs in the 4th decimal)
        M = np.diag(ICC_D50 / white) @ M
    if abs(np.linalg.det(M)) < np.finfo(np.float64).eps * np.abs(M).max() ** 3:
        raise ICCError("XYZ_D50_from_balanced: the matrix is singular; an input profile must be invertible.")
    if illuminant_XYZ is None:
        chad = np.eye(3)
    else:
        w = float_array(illuminant_XYZ, "illuminant_XYZ", ICCError).ravel()
        if w.shape != (3,) or not np.all(np.isfinite(w)) or np.any(w <= 0):
            raise ICCError(f"illuminant_XYZ={w.tolist()}: give a finite white XYZ with positive values.")
        chad = colour.adaptation.matrix_chromatic_adaptation_VonKries(w / w[1], ICC_D50, transform="Bradford")
    curve = b"curv\x00\x00\x00\x00" + struct.pack(">I", 0)  # 0 entries: identity (linear input)
    tags: list[tuple[bytes, bytes]] = [
        (b"desc", _mluc(description or "camera")),
        (b"cprt", _mluc(copyright or " ")),
        (b"wtpt", _xyz_type(ICC_D50)),
        (b"rXYZ", _xyz_type(M[:, 0])),
        (b"gXYZ", _xyz_type(M[:, 1])),
        (b"bXYZ", _xyz_type(M[:, 2])),
        (b"rTRC", curve),
        (b"gTRC", curve),
        (b"bTRC", curve),
        (b"chad", b"sf32\x00\x00\x00\x00" + _s15f16(chad)),
    ]
    table_size = 4 + 12 * len(tags)
    offset = 128 + table_size
    table, data, seen = [struct.pack(">I", len(tags))], b"", {}
    for sig, body in tags:
        if body not in seen:  # identical tag data is stored once (the three TRCs)
            seen[body] = offset + len(data)
            data += _pad4(body)
        table.append(sig + struct.pack(">II", seen[body], len(body)))
    size = offset + len(data)
    t = when or datetime.datetime.now(datetime.UTC)
    header = bytearray(128)
    struct.pack_into(">I", header, 0, size)
    header[8:12] = bytes([4, 0x40, 0, 0])  # version 4.4
    header[12:24] = b"scnrRGB XYZ "
    struct.pack_into(">6H", header, 24, t.year, t.month, t.day, t.hour, t.minute, t.second)
    header[36:40] = b"acsp"
    header[68:80] = _s15f16(ICC_D50)
    header[80:84] = ICC_CREATOR
    profile = bytearray(bytes(header) + b"".join(table) + data)
    # profile ID: MD5 of the profile with flags, rendering intent and the ID field zeroed (7.2.18)
    profile[84:100] = hashlib.md5(bytes(profile)).digest()  # those fields are zero here already
    return bytes(profile)


def write_icc(path: str | os.PathLike, profile: bytes, *, overwrite: bool = False) -> Path:
    """Write an :func:`icc_profile` atomically (temporary file, then rename).

    Raises
    ------
    ICCError
        ``path`` exists (and not ``overwrite``), or ``profile`` is not an ICC profile.
    """
    from zonotope.utilities import atomic_path

    path = Path(path)
    if not isinstance(profile, bytes | bytearray) or bytes(profile[36:40]) != b"acsp":
        raise ICCError("profile: expected the bytes of an ICC profile (isp.profiles.icc.icc_profile).")
    if path.exists() and not overwrite:
        raise ICCError(f"{path} exists; pass overwrite=True (--overwrite) or choose another name.")

    def write(tmp: Path) -> None:
        tmp.write_bytes(bytes(profile))

    atomic_path(path, write)
    return path


def read_icc_matrix(path: str | os.PathLike) -> tuple[np.ndarray, np.ndarray]:
    """The matrix (columns ``rXYZ``, ``gXYZ``, ``bXYZ``) and ``chad`` of a matrix/TRC ICC profile.

    Returns
    -------
    ndarray of shape (3, 3), ndarray of shape (3, 3)
        Camera RGB → XYZ D50, and the chromatic adaptation (identity when there is no ``chad``).

    Raises
    ------
    ICCError
        Not an ICC profile, or one without the three colorant tags.
    """
    b = Path(path).read_bytes()
    if len(b) < 132 or b[36:40] != b"acsp":
        raise ICCError(f"{path}: not an ICC profile (no 'acsp' signature).")
    (n,) = struct.unpack_from(">I", b, 128)
    tags = {}
    for i in range(min(n, (len(b) - 132) // 12)):
        sig, off, size = struct.unpack_from(">4sII", b, 132 + 12 * i)
        tags[sig] = b[off : off + size]

    def s15(body: bytes, count: int) -> np.ndarray:
        return np.array(struct.unpack_from(f">{count}i", body, 8), dtype=np.float64) / 65536.0

    try:
        M = np.stack([s15(tags[k], 3) for k in (b"rXYZ", b"gXYZ", b"bXYZ")], axis=1)
    except (KeyError, struct.error) as exc:
        raise ICCError(f"{path}: no rXYZ/gXYZ/bXYZ colorant tags (not a matrix/TRC profile).") from exc
    chad = s15(tags[b"chad"], 9).reshape(3, 3) if b"chad" in tags else np.eye(3)
    return M, chad
