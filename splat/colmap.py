"""COLMAP sparse models, text and binary, read and write (cameras, images, points3D, rigs, frames).

The ``rigs`` and ``frames`` files of COLMAP ≥ 3.12 are read and written when present; poses are taken
from ``images`` (COLMAP writes every image's composed ``cam_from_world`` there), so older models
without rigs/frames work the same. Formats: https://colmap.github.io/format.html
"""

from __future__ import annotations

import struct
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ._errors import DataFormatError, SplatError
from ._tol import QUATERNION_NORM_MAX, QUATERNION_NORM_MIN

__all__ = [
    "CAMERA_MODELS",
    "ColmapCamera",
    "ColmapFrame",
    "ColmapImage",
    "ColmapModel",
    "ColmapPoint3D",
    "ColmapRig",
    "read_colmap",
    "write_colmap",
]

#: COLMAP camera models: name -> (model id, number of parameters).
CAMERA_MODELS = {
    "SIMPLE_PINHOLE": (0, 3),
    "PINHOLE": (1, 4),
    "SIMPLE_RADIAL": (2, 4),
    "RADIAL": (3, 5),
    "OPENCV": (4, 8),
    "OPENCV_FISHEYE": (5, 8),
    "FULL_OPENCV": (6, 12),
    "FOV": (7, 5),
    "SIMPLE_RADIAL_FISHEYE": (8, 4),
    "RADIAL_FISHEYE": (9, 5),
    "THIN_PRISM_FISHEYE": (10, 12),
    "RAD_TAN_THIN_PRISM_FISHEYE": (11, 16),
}
_MODEL_BY_ID = {i: (name, n) for name, (i, n) in CAMERA_MODELS.items()}
_SENSOR_TYPES = {"INVALID": -1, "CAMERA": 0, "IMU": 1}
_SENSOR_BY_ID = {v: k for k, v in _SENSOR_TYPES.items()}
_POINT2D = np.dtype([("x", "<f8"), ("y", "<f8"), ("id", "<i8")])


@dataclass(frozen=True)
class ColmapCamera:
    """Intrinsics ``id``, ``model`` (a key of :data:`CAMERA_MODELS`), ``width``, ``height``, ``params``."""

    id: int
    model: str
    width: int
    height: int
    params: tuple[float, ...]

    def pinhole(self) -> tuple[float, float, float, float]:
        """``(fx, fy, cx, cy)``; raises :class:`SplatError` for a model with non-zero distortion."""
        p = self.params
        if self.model == "SIMPLE_PINHOLE" or (self.model in ("SIMPLE_RADIAL", "RADIAL") and not any(p[3:])):
            return p[0], p[0], p[1], p[2]
        if self.model == "PINHOLE" or (self.model in ("OPENCV", "FULL_OPENCV") and not any(p[4:])):
            return p[0], p[1], p[2], p[3]
        raise SplatError(
            f"camera {self.id} uses the {self.model} model with distortion {p}; the renderer "
            "is a pinhole: undistort the images first (colmap image_undistorter)."
        )


@dataclass(frozen=True)
class ColmapImage:
    """A registered image: ``qvec`` (w, x, y, z) and ``tvec`` of ``cam_from_world``, keypoints.

    ``xys`` has shape (n, 2) and ``point3D_ids`` shape (n,) (−1 where the keypoint has no 3-D point).
    """

    id: int
    qvec: np.ndarray
    tvec: np.ndarray
    camera_id: int
    name: str
    xys: np.ndarray = field(default_factory=lambda: np.zeros((0, 2)))
    point3D_ids: np.ndarray = field(default_factory=lambda: np.zeros((0,), np.int64))


@dataclass(frozen=True)
class ColmapPoint3D:
    """A 3-D point: ``xyz`` (3,), ``rgb`` (3,) uint8, ``error``, track ``image_ids`` / ``point2D_idxs``."""

    id: int
    xyz: np.ndarray
    rgb: np.ndarray
    error: float
    image_ids: np.ndarray
    point2D_idxs: np.ndarray


@dataclass(frozen=True)
class ColmapRig:
    """A rig: ``sensors[0]`` is the reference; each is ``(type, id, pose)`` with ``pose`` either None or
    the 7 numbers ``(qw, qx, qy, qz, tx, ty, tz)`` of ``sensor_from_rig``."""

    id: int
    sensors: tuple[tuple[str, int, tuple[float, ...] | None], ...]


@dataclass(frozen=True)
class ColmapFrame:
    """A frame: ``rig_from_world`` as 7 numbers and ``data_ids`` as ``(sensor type, sensor id, data id)``."""

    id: int
    rig_id: int
    rig_from_world: tuple[float, ...]
    data_ids: tuple[tuple[str, int, int], ...]


@dataclass
class ColmapModel:
    """A sparse model: dicts keyed by id (``rigs`` and ``frames`` empty for pre-3.12 models)."""

    cameras: dict[int, ColmapCamera]
    images: dict[int, ColmapImage]
    points3D: dict[int, ColmapPoint3D] = field(default_factory=dict)
    rigs: dict[int, ColmapRig] = field(default_factory=dict)
    frames: dict[int, ColmapFrame] = field(default_factory=dict)

    def points(self) -> tuple[np.ndarray, np.ndarray]:
        """All 3-D points as arrays: ``xyz`` (P, 3) float and ``rgb`` (P, 3) uint8."""
        pts = list(self.points3D.values())
        return (
            np.array([p.xyz for p in pts]).reshape(-1, 3),
            np.array([p.rgb for p in pts], dtype=np.uint8).reshape(-1, 3),
        )


# ----------------------------------------------------------------------------------------- text
def _lines(path: Path):
    for n, line in enumerate(path.read_text().splitlines(), 1):
        line = line.strip()
        if line and not line.startswith("#"):
            yield n, line.split()


def _fail(path, n, what, exc=None):
    raise DataFormatError(f"{path}:{n}: cannot read {what}" + (f" ({exc})" if exc else "")) from exc


def _read_text(folder: Path) -> ColmapModel:
    cameras, images, points, rigs, frames = {}, {}, {}, {}, {}
    path = folder / "cameras.txt"
    for n, t in _lines(path):
        try:
            if t[1] not in CAMERA_MODELS:
                raise ValueError(f"unknown model {t[1]!r}")
            camera = ColmapCamera(int(t[0]), t[1], int(t[2]), int(t[3]), tuple(map(float, t[4:])))
        except (ValueError, IndexError) as e:
            _fail(path, n, "a camera", e)
        _put(cameras, camera.id, camera, f"{path}:{n}", "camera")
    path = folder / "images.txt"
    lines = [(n, line) for n, line in _lines_keep_empty(path)]
    for k in range(0, len(lines), 2):
        (n, head), (_, pts) = lines[k], lines[k + 1]
        try:
            t = head.split()
            p = np.array(pts.split(), dtype=float).reshape(-1, 3)
            if int(t[0]) in images:
                _put(images, int(t[0]), None, f"{path}:{n}", "image")
            images[int(t[0])] = ColmapImage(
                int(t[0]),
                np.array(t[1:5], float),
                np.array(t[5:8], float),
                int(t[8]),
                " ".join(t[9:]),
                p[:, :2],
                p[:, 2].astype(np.int64),
            )
        except (ValueError, IndexError) as e:
            _fail(path, n, "an image", e)
    path = folder / "points3D.txt"
    if path.exists():
        for n, t in _lines(path):
            try:
                track = np.array(t[8:], dtype=np.int64).reshape(-1, 2)
                if int(t[0]) in points:
                    _put(points, int(t[0]), None, f"{path}:{n}", "3-D point")
                points[int(t[0])] = ColmapPoint3D(
                    int(t[0]),
                    np.array(t[1:4], float),
                    np.array(t[4:7], np.uint8),
                    float(t[7]),
                    track[:, 0],
                    track[:, 1],
                )
            except (ValueError, IndexError) as e:
                _fail(path, n, "a 3-D point", e)
    path = folder / "rigs.txt"
    if path.exists():
        for n, t in _lines(path):
            try:
                ns, sensors, i = int(t[1]), [], 4
                if ns:
                    sensors.append((t[2], int(t[3]), None))
                for _ in range(ns - 1):
                    has = int(t[i + 2])
                    sensors.append(
                        (t[i], int(t[i + 1]), tuple(map(float, t[i + 3 : i + 10])) if has else None)
                    )
                    i += 10 if has else 3
                rigs[int(t[0])] = ColmapRig(int(t[0]), tuple(sensors))
            except (ValueError, IndexError) as e:
                _fail(path, n, "a rig", e)
    path = folder / "frames.txt"
    if path.exists():
        for n, t in _lines(path):
            try:
                nd = int(t[9])
                ids = tuple((t[10 + 3 * j], int(t[11 + 3 * j]), int(t[12 + 3 * j])) for j in range(nd))
                frames[int(t[0])] = ColmapFrame(int(t[0]), int(t[1]), tuple(map(float, t[2:9])), ids)
            except (ValueError, IndexError) as e:
                _fail(path, n, "a frame", e)
    return ColmapModel(cameras, images, points, rigs, frames)


def _lines_keep_empty(path: Path):
    """images.txt: two lines per image, the second may be empty (no keypoints).

    A file whose last image has no keypoints may end without that empty line (the last line is then
    an image line): the empty points line is supplied, so the last image is not lost."""
    lines = [
        (n, line.strip())
        for n, line in enumerate(path.read_text().splitlines(), 1)
        if not line.startswith("#")
    ]
    while lines and not lines[-1][1] and len(lines) % 2:
        lines.pop()  # extra trailing blank lines
    if len(lines) % 2:
        lines.append((lines[-1][0] + 1, ""))
    yield from lines


def _f(x) -> str:
    return repr(float(x))


def _write_text(m: ColmapModel, folder: Path) -> None:
    out = ["# Camera list with one line of data per camera:", "#   CAMERA_ID, MODEL, WIDTH, HEIGHT, PARAMS[]"]
    out += [
        " ".join([str(c.id), c.model, str(c.width), str(c.height), *map(_f, c.params)])
        for c in m.cameras.values()
    ]
    (folder / "cameras.txt").write_text("\n".join(out) + "\n")
    out = [
        "# Image list with two lines of data per image:",
        "#   IMAGE_ID, QW, QX, QY, QZ, TX, TY, TZ, CAMERA_ID, NAME",
        "#   POINTS2D[] as (X, Y, POINT3D_ID)",
    ]
    for im in m.images.values():
        out.append(" ".join([str(im.id), *map(_f, im.qvec), *map(_f, im.tvec), str(im.camera_id), im.name]))
        out.append(" ".join(f"{_f(x)} {_f(y)} {int(i)}" for (x, y), i in zip(im.xys, im.point3D_ids)))
    (folder / "images.txt").write_text("\n".join(out) + "\n")
    out = [
        "# 3D point list with one line of data per point:",
        "#   POINT3D_ID, X, Y, Z, R, G, B, ERROR, TRACK[] as (IMAGE_ID, POINT2D_IDX)",
    ]
    for p in m.points3D.values():
        track = " ".join(f"{int(a)} {int(b)}" for a, b in zip(p.image_ids, p.point2D_idxs))
        words = [str(p.id), *map(_f, p.xyz), *map(str, map(int, p.rgb)), _f(p.error), track]
        out.append(" ".join(words).strip())
    (folder / "points3D.txt").write_text("\n".join(out) + "\n")
    if m.rigs or m.frames:
        out = [
            "# Rig calib list with one line of data per calib:",
            "#   RIG_ID, NUM_SENSORS, REF_SENSOR_TYPE, REF_SENSOR_ID, SENSORS[] as "
            "(SENSOR_TYPE, SENSOR_ID, HAS_POSE, [QW, QX, QY, QZ, TX, TY, TZ])",
        ]
        for r in m.rigs.values():
            words = [str(r.id), str(len(r.sensors))]
            for k, (typ, sid, pose) in enumerate(r.sensors):
                words += [typ, str(sid)]
                if k:
                    words += ["0"] if pose is None else ["1", *map(_f, pose)]
            out.append(" ".join(words))
        (folder / "rigs.txt").write_text("\n".join(out) + "\n")
        out = [
            "# Frame list with one line of data per frame:",
            "#   FRAME_ID, RIG_ID, RIG_FROM_WORLD[QW, QX, QY, QZ, TX, TY, TZ], NUM_DATA_IDS, "
            "DATA_IDS[] as (SENSOR_TYPE, SENSOR_ID, DATA_ID)",
        ]
        for f in m.frames.values():
            words = [str(f.id), str(f.rig_id), *map(_f, f.rig_from_world), str(len(f.data_ids))]
            for typ, sid, did in f.data_ids:
                words += [typ, str(sid), str(did)]
            out.append(" ".join(words))
        (folder / "frames.txt").write_text("\n".join(out) + "\n")


# --------------------------------------------------------------------------------------- binary
class _Reader:
    def __init__(self, path: Path):
        self.path, self.buf, self.pos = path, path.read_bytes(), 0

    def __call__(self, fmt: str):
        fmt = "<" + fmt
        size = struct.calcsize(fmt)
        if self.pos + size > len(self.buf):
            raise DataFormatError(f"{self.path}: truncated at byte {self.pos} (wanted {size} more bytes).")
        out = struct.unpack_from(fmt, self.buf, self.pos)
        self.pos += size
        return out

    def array(self, dtype, count: int) -> np.ndarray:
        dt = np.dtype(dtype).newbyteorder("<")
        if self.pos + dt.itemsize * count > len(self.buf):
            raise DataFormatError(f"{self.path}: truncated at byte {self.pos}.")
        out = np.frombuffer(self.buf, dt, count, self.pos).copy()
        self.pos += dt.itemsize * count
        return out

    def count(self, what: str, record_bytes: int) -> int:
        """The record count of a file's header, refused when its records cannot fit the file."""
        n = self("Q")[0]
        if n * record_bytes > len(self.buf) - self.pos:
            raise DataFormatError(
                f"{self.path}: declares {n} {what}, more than its {len(self.buf)} bytes can hold."
            )
        return n

    def end(self, n: int, what: str) -> None:
        """Refuse bytes after the last declared record (a count one too low, or appended garbage)."""
        if self.pos != len(self.buf):
            raise DataFormatError(
                f"{self.path}: {len(self.buf) - self.pos} bytes follow the {n} {what} its header "
                "declares; the count is wrong or the file is damaged: export the model again."
            )

    def string(self) -> str:
        end = self.buf.find(b"\0", self.pos)
        if end < 0:
            raise DataFormatError(f"{self.path}: unterminated string at byte {self.pos}.")
        s = self.buf[self.pos : end].decode()
        self.pos = end + 1
        return s


def _put(table: dict, key: int, value, path: Path | str, what: str) -> None:
    """``table[key] = value``, refusing a second record with the same id (it would replace the first)."""
    if key in table:
        raise DataFormatError(
            f"{path}: {what} id {key} appears twice; ids must be unique: export the model again."
        )
    table[key] = value


def _read_binary(folder: Path) -> ColmapModel:
    cameras, images, points, rigs, frames = {}, {}, {}, {}, {}
    r = _Reader(folder / "cameras.bin")
    count = r.count("cameras", 24)
    for _ in range(count):
        cid, mid, w, h = r("iiQQ")
        if mid not in _MODEL_BY_ID:
            raise DataFormatError(f"{r.path}: camera {cid} has unknown model id {mid}.")
        name, n = _MODEL_BY_ID[mid]
        _put(cameras, cid, ColmapCamera(cid, name, w, h, r(f"{n}d")), r.path, "camera")
    r.end(count, "cameras")
    r = _Reader(folder / "images.bin")
    count = r.count("images", 73)
    for _ in range(count):
        iid, *pose, cid = r("I7dI")
        name = r.string()
        n = r("Q")[0]
        raw = np.frombuffer(r.array(np.uint8, 24 * n).tobytes(), dtype=_POINT2D)
        if iid in images:
            _put(images, iid, None, r.path, "image")
        images[iid] = ColmapImage(
            iid,
            np.array(pose[:4]),
            np.array(pose[4:]),
            cid,
            name,
            np.stack([raw["x"], raw["y"]], -1),
            raw["id"].astype(np.int64),
        )
    r.end(count, "images")
    path = folder / "points3D.bin"
    if path.exists():
        r = _Reader(path)
        count = r.count("points", 51)
        for _ in range(count):
            pid, x, y, z, cr, cg, cb, err = r("Q3d3Bd")
            track = r.array(np.uint32, 2 * r("Q")[0]).reshape(-1, 2)
            point = ColmapPoint3D(
                pid,
                np.array([x, y, z]),
                np.array([cr, cg, cb], np.uint8),
                err,
                track[:, 0].astype(np.int64),
                track[:, 1].astype(np.int64),
            )
            _put(points, pid, point, r.path, "3-D point")
        r.end(count, "points")
    path = folder / "rigs.bin"
    if path.exists():
        r = _Reader(path)
        for _ in range(r.count("rigs", 8)):
            rid, ns = r("II")
            sensors = []
            if ns:
                typ, sid = r("iI")
                sensors.append((_SENSOR_BY_ID.get(typ, str(typ)), sid, None))
            for _ in range(ns - 1):
                typ, sid, has = r("iIB")
                sensors.append((_SENSOR_BY_ID.get(typ, str(typ)), sid, r("7d") if has else None))
            rigs[rid] = ColmapRig(rid, tuple(sensors))
    path = folder / "frames.bin"
    if path.exists():
        r = _Reader(path)
        for _ in range(r.count("frames", 68)):
            fid, rid, *pose, nd = r("II7dI")
            ids = tuple((lambda t, s, d: (_SENSOR_BY_ID.get(t, str(t)), s, d))(*r("iIQ")) for _ in range(nd))
            frames[fid] = ColmapFrame(fid, rid, tuple(pose), ids)
    return ColmapModel(cameras, images, points, rigs, frames)


def _write_binary(m: ColmapModel, folder: Path) -> None:
    out = [struct.pack("<Q", len(m.cameras))]
    for c in m.cameras.values():
        mid, n = CAMERA_MODELS[c.model]
        if len(c.params) != n:
            raise SplatError(f"camera {c.id}: the {c.model} model has {n} parameters, got {len(c.params)}.")
        out.append(struct.pack(f"<iiQQ{n}d", c.id, mid, c.width, c.height, *c.params))
    (folder / "cameras.bin").write_bytes(b"".join(out))
    out = [struct.pack("<Q", len(m.images))]
    for im in m.images.values():
        out.append(struct.pack("<I7dI", im.id, *im.qvec, *im.tvec, im.camera_id))
        out.append(im.name.encode() + b"\0" + struct.pack("<Q", len(im.point3D_ids)))
        rec = np.zeros(len(im.point3D_ids), dtype=_POINT2D)
        rec["x"], rec["y"], rec["id"] = im.xys[:, 0], im.xys[:, 1], im.point3D_ids
        out.append(rec.tobytes())
    (folder / "images.bin").write_bytes(b"".join(out))
    out = [struct.pack("<Q", len(m.points3D))]
    for p in m.points3D.values():
        out.append(struct.pack("<Q3d3BdQ", p.id, *p.xyz, *map(int, p.rgb), p.error, len(p.image_ids)))
        out.append(np.stack([p.image_ids, p.point2D_idxs], -1).astype("<u4").tobytes())
    (folder / "points3D.bin").write_bytes(b"".join(out))
    if m.rigs or m.frames:
        out = [struct.pack("<Q", len(m.rigs))]
        for r in m.rigs.values():
            out.append(struct.pack("<II", r.id, len(r.sensors)))
            for k, (typ, sid, pose) in enumerate(r.sensors):
                out.append(struct.pack("<iI", _SENSOR_TYPES[typ], sid))
                if k:
                    out.append(struct.pack("<B", pose is not None))
                    out.append(struct.pack("<7d", *pose) if pose else b"")
        (folder / "rigs.bin").write_bytes(b"".join(out))
        out = [struct.pack("<Q", len(m.frames))]
        for f in m.frames.values():
            out.append(struct.pack("<II7dI", f.id, f.rig_id, *f.rig_from_world, len(f.data_ids)))
            out += [struct.pack("<iIQ", _SENSOR_TYPES[t], s, d) for t, s, d in f.data_ids]
        (folder / "frames.bin").write_bytes(b"".join(out))


def _check_model(m: ColmapModel, folder: Path) -> None:
    """Values a renderer cannot use raise here, not as NaN Gaussians later."""
    for c in m.cameras.values():
        n = CAMERA_MODELS[c.model][1]
        if len(c.params) != n or not np.all(np.isfinite(c.params)):
            raise DataFormatError(
                f"{folder}: camera {c.id} ({c.model}) needs {n} finite parameters, got {c.params}."
            )
        if not (0 < c.width < 2**31 and 0 < c.height < 2**31):
            raise DataFormatError(
                f"{folder}: camera {c.id} has size {c.width}×{c.height}; expected positive "
                "integers below 2³¹."
            )
        if c.params[0] <= 0 or (c.model in ("PINHOLE", "OPENCV", "FULL_OPENCV") and c.params[1] <= 0):
            raise DataFormatError(f"{folder}: camera {c.id} has focal length {c.params[:2]}; it must be > 0.")
    for im in m.images.values():
        q, t = np.asarray(im.qvec, float), np.asarray(im.tvec, float)
        if q.shape != (4,) or t.shape != (3,) or not (np.all(np.isfinite(q)) and np.all(np.isfinite(t))):
            raise DataFormatError(
                f"{folder}: image {im.id} ({im.name!r}) has a non-finite pose qvec={q} tvec={t}."
            )
        if not QUATERNION_NORM_MIN < np.linalg.norm(q) < QUATERNION_NORM_MAX:
            raise DataFormatError(
                f"{folder}: image {im.id} ({im.name!r}) has qvec={q}, not a rotation (norm 0 or huge)."
            )
        if im.camera_id not in m.cameras:
            raise DataFormatError(
                f"{folder}: image {im.id} ({im.name!r}) refers to camera {im.camera_id}, "
                f"which the model does not hold (cameras {sorted(m.cameras)})."
            )


def read_colmap(folder: str | Path) -> ColmapModel:
    """Read a COLMAP sparse model folder (``*.bin`` preferred when both formats are present).

    Parameters
    ----------
    folder : path
        Folder with ``cameras``, ``images`` and optionally ``points3D``, ``rigs``, ``frames``.

    Returns
    -------
    ColmapModel

    Raises
    ------
    DataFormatError
        Missing files or unreadable content (the message names the file and line or byte).
    """
    folder = Path(folder)
    binary = (folder / "cameras.bin").exists() and (folder / "images.bin").exists()
    if binary or ((folder / "cameras.txt").exists() and (folder / "images.txt").exists()):
        try:
            model = (_read_binary if binary else _read_text)(folder)
        except DataFormatError:
            raise
        except (
            ValueError,
            IndexError,
            OverflowError,
            TypeError,
            UnicodeDecodeError,
            struct.error,
            MemoryError,
            OSError,
        ) as error:  # anything else a damaged file can make the parsers hit
            raise DataFormatError(
                f"{folder}: cannot read the COLMAP model ({type(error).__name__}: "
                f"{error}). The files are damaged or not a COLMAP model."
            ) from None
        _check_model(model, folder)
        return model
    raise DataFormatError(
        f"{folder} holds no COLMAP model (need cameras.bin + images.bin or cameras.txt + images.txt)."
    )


def write_colmap(model: ColmapModel, folder: str | Path, *, binary: bool = True) -> Path:
    """Write a COLMAP sparse model (binary by default, ``binary=False`` for text); returns the folder."""
    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    (_write_binary if binary else _write_text)(model, folder)
    return folder
