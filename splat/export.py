"""The trained scene and its poses for other tools: a standard 3DGS ``.ply`` of the *corrected* colours,
an N-channel ``.ply``, nerfstudio ``transforms.json`` and a COLMAP model of the recovered poses.

The ``.ply`` follows the file of Kerbl et al.'s reference implementation (INRIA), which every 3DGS viewer
reads: per Gaussian ``x y z nx ny nz f_dc_0..2 f_rest_0..44 opacity scale_0..2 rot_0..3`` as
little-endian float32, with ``opacity`` a logit, ``scale_*`` natural logarithms of the standard deviations,
``rot_*`` a unit quaternion ``(w, x, y, z)`` and the zeroth spherical-harmonic coefficient
``f_dc = (colour − 0.5) / C0`` (``C0 = 1 / (2√π)``) of the sRGB-encoded colour that viewers display.
That colour is each Gaussian's N-channel response corrected by the capture's estimator — the same one,
with the same noise tolerance δ, that the correct step applied to the rendered views — to XYZ (scene
white Y = 1), then Bradford-adapted to D65 and sRGB-encoded. The linear XYZ follows as the extra
properties ``XYZ_X XYZ_Y XYZ_Z`` and the header's comments name both colour spaces and the white.
The N-channel file adds ``f_<camera>_<channel>``: the model's own linear responses at exposure 1, in raw
units, with each channel's white (the response a perfect white gives) in a comment.

Why: a multispectral reconstruction should open in any splat viewer with its corrected colours, and the
colour-managed splat work (OpenColorIO's colour management of Gaussian splats, the Khronos
``KHR_gaussian_splatting`` drafts) asks for scene-linear, colour-tagged splats.

References
----------
Kerbl, B., Kopanas, G., Leimkühler, T., Drettakis, G. (2023). 3D Gaussian Splatting for Real-Time
Radiance Field Rendering. ACM TOG 42(4); ``scene/gaussian_model.py::save_ply`` of its code.
"""

from __future__ import annotations

import json
import os
import re
import tempfile
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ._errors import DataFormatError, SplatError
from .capture import CaptureError, CaptureSpec, read_capture
from .capture.workspace import MARKER as OUT_MARKER
from .capture.workspace import read_json
from .viewer import SCENE

__all__ = [
    "SCENE",
    "SH_C0",
    "SIGNATURE",
    "PlyOptions",
    "SceneColours",
    "check_export_path",
    "corrected_colours",
    "export_scene",
    "gaussians_from_ply",
    "ply_properties",
    "posed_capture",
    "prepare_scene",
    "read_ply",
    "rgb_from_sh_dc",
    "scene_corrector",
    "sh_dc_from_rgb",
    "write_ply",
]

#: The zeroth real spherical-harmonic basis function, 1 / (2√π) (3DGS ``utils/sh_utils.py``).
SH_C0 = 0.28209479177387814
#: What marks a file or folder written by :func:`export_scene` (a PLY comment; the COLMAP folder's
#: marker; a key of ``transforms.json``): only those are replaced, and only when asked to.
SIGNATURE = "written by splat export"


def sh_dc_from_rgb(rgb) -> np.ndarray:
    """3DGS' ``RGB2SH``: the zeroth SH coefficient ``(rgb − 0.5) / C0`` of a displayed colour.

    Parameters
    ----------
    rgb : array_like of shape (..., 3)
    """
    return (np.asarray(rgb, np.float64) - 0.5) / SH_C0


def rgb_from_sh_dc(dc) -> np.ndarray:
    """3DGS' ``SH2RGB``, the inverse of :func:`sh_dc_from_rgb`: ``C0 · dc + 0.5``, shape of ``dc``."""
    return SH_C0 * np.asarray(dc, np.float64) + 0.5


# ------------------------------------------------------------------------------------------ the file


def _inria_names(sh_degree: int) -> list[str]:
    rest = 3 * ((sh_degree + 1) ** 2 - 1)
    return [
        *"x y z nx ny nz f_dc_0 f_dc_1 f_dc_2".split(),
        *(f"f_rest_{i}" for i in range(rest)),
        "opacity",
        *(f"scale_{i}" for i in range(3)),
        *(f"rot_{i}" for i in range(4)),
    ]


def ply_properties(arrays: dict[str, np.ndarray], rgb, *, sh_degree: int = 3) -> dict[str, np.ndarray]:
    """The INRIA 3DGS vertex properties, in their order, of Gaussians given by their raw parameters.

    Parameters
    ----------
    arrays : dict
        ``means`` (G, 3), ``quats`` (G, 4) ``(w, x, y, z)``, ``log_scales`` (G, 3), ``opacity_logits`` (G,)
        (:meth:`splat.Gaussians.to_numpy`).
    rgb : array_like of shape (G, 3)
        Displayed (sRGB-encoded) colours in [0, 1].
    sh_degree : int
        0 writes no ``f_rest_*``; 1–3 write ``3((d + 1)² − 1)`` zeros (the reference code's loader insists
        on 45, its degree 3).
    """
    if sh_degree not in (0, 1, 2, 3):
        raise SplatError(f"sh_degree={sh_degree!r}: 3DGS files have SH degree 0, 1, 2 or 3.")
    m = np.asarray(arrays["means"], np.float32)
    G = len(m)
    q = np.asarray(arrays["quats"], np.float64)
    q = q / np.maximum(np.linalg.norm(q, axis=-1, keepdims=True), np.finfo(np.float64).tiny)
    dc = sh_dc_from_rgb(rgb)
    cols = {"x": m[:, 0], "y": m[:, 1], "z": m[:, 2]}
    cols.update({n: np.zeros(G, np.float32) for n in ("nx", "ny", "nz")})
    cols.update({f"f_dc_{i}": dc[:, i] for i in range(3)})
    cols.update({n: np.zeros(G, np.float32) for n in _inria_names(sh_degree) if n.startswith("f_rest_")})
    cols["opacity"] = np.asarray(arrays["opacity_logits"]).reshape(G)
    ls = np.asarray(arrays["log_scales"])
    cols.update({f"scale_{i}": ls[:, i] for i in range(3)})
    cols.update({f"rot_{i}": q[:, i] for i in range(4)})
    return {k: np.asarray(v, np.float32) for k, v in cols.items()}


def _header(names: list[str], n: int, comments: list[str]) -> bytes:
    lines = ["ply", "format binary_little_endian 1.0", f"comment {SIGNATURE}"]
    lines += [f"comment {' '.join(c.split())}" for c in comments]
    lines += [f"element vertex {n}", *(f"property float {p}" for p in names), "end_header"]
    return ("\n".join(lines) + "\n").encode("ascii")


def write_ply(path: str | os.PathLike, properties: dict[str, np.ndarray], *, comments=()) -> Path:
    """Write float32 vertex properties (each of shape (G,), in the given order) as a binary PLY,
    atomically; ``comments`` become header comment lines (ASCII).

    Raises
    ------
    SplatError
        A property name that PLY cannot hold (not ``[A-Za-z0-9_]+``), a duplicate, or a non-ASCII comment.
    """
    from zonotope.utilities import atomic_write_bytes

    names = list(properties)
    bad = [n for n in names if not re.fullmatch(r"[A-Za-z0-9_]+", n)]
    if bad:
        raise SplatError(f"PLY property names must be letters, digits and '_'; got {bad}.")
    try:
        header = _header(names, len(next(iter(properties.values()))) if names else 0, list(comments))
    except UnicodeEncodeError as e:
        raise SplatError(f"PLY comments must be ASCII ({e}).") from None
    dt = np.dtype([(n, "<f4") for n in names])
    G = len(properties[names[0]]) if names else 0
    rec = np.empty(G, dt)
    for n in names:
        rec[n] = properties[n]
    return atomic_write_bytes(path, header + rec.tobytes())


def read_ply(path: str | os.PathLike) -> tuple[dict[str, np.ndarray], list[str]]:
    """The vertex properties (name → (G,) array, in file order) and comment lines of a binary
    little-endian PLY with one ``vertex`` element of scalar properties.

    Raises
    ------
    DataFormatError
        Not such a file, or truncated.
    """
    path = Path(path)
    types = {
        "float": "<f4", "float32": "<f4", "double": "<f8", "float64": "<f8", "uchar": "u1", "uint8": "u1",
        "char": "i1", "int8": "i1", "ushort": "<u2", "uint16": "<u2", "short": "<i2", "int16": "<i2",
        "uint": "<u4", "uint32": "<u4", "int": "<i4", "int32": "<i4",
    }  # fmt: skip
    try:
        data = path.read_bytes()
    except OSError as e:
        raise DataFormatError(f"{path}: cannot read ({e.strerror or e}).") from None
    end = data.find(b"end_header\n")
    if not data.startswith(b"ply\n") or end < 0:
        raise DataFormatError(f"{path}: not a PLY file (no 'ply' line or no 'end_header').")
    comments, fields, n, fmt = [], [], None, None
    for line in data[:end].decode("ascii", "replace").splitlines()[1:]:
        w = line.split()
        if not w:
            continue
        if w[0] == "comment":
            comments.append(line[len("comment ") :])
        elif w[0] == "format":
            fmt = w[1:2]
        elif w[0] == "element":
            if n is not None or w[1:2] != ["vertex"]:
                raise DataFormatError(f"{path}: only one 'vertex' element is read here, got {line!r}.")
            n = int(w[2])
        elif w[0] == "property":
            if len(w) != 3 or w[1] not in types:
                raise DataFormatError(f"{path}: unsupported property line {line!r}.")
            fields.append((w[2], types[w[1]]))
    if fmt != ["binary_little_endian"] or n is None:
        raise DataFormatError(f"{path}: expected a binary_little_endian PLY with a vertex element.")
    dt = np.dtype(fields)
    body = data[end + len(b"end_header\n") :]
    if len(body) < n * dt.itemsize:
        raise DataFormatError(f"{path}: truncated ({len(body)} bytes for {n} vertices of {dt.itemsize}).")
    rec = np.frombuffer(body, dt, count=n)
    return {name: np.array(rec[name]) for name, _ in fields}, comments


def gaussians_from_ply(properties: dict[str, np.ndarray], *, channels: list[str] | None = None):
    """:class:`splat.Gaussians` from 3DGS vertex properties (:func:`read_ply`): colours from the named
    ``channels`` (linear values), or by default the displayed colour ``C0 · f_dc + 0.5`` (clipped at 0,
    as 3DGS viewers do), shape (G, 3)."""
    from .gaussians import Gaussians, inverse_softplus

    p = properties
    try:
        cols = (
            np.stack([p[c] for c in channels], -1)
            if channels
            else np.maximum(rgb_from_sh_dc(np.stack([p[f"f_dc_{i}"] for i in range(3)], -1)), 0)
        )
        arrays = {
            "means": np.stack([p["x"], p["y"], p["z"]], -1),
            "quats": np.stack([p[f"rot_{i}"] for i in range(4)], -1),
            "log_scales": np.stack([p[f"scale_{i}"] for i in range(3)], -1),
            "opacity_logits": p["opacity"],
            "colour_params": np.asarray(inverse_softplus(cols)),
        }
    except KeyError as e:
        raise DataFormatError(f"not a 3DGS PLY: no property {e.args[0]!r}.") from None
    return Gaussians.from_numpy(arrays)


@dataclass(frozen=True)
class PlyOptions:
    """What an exported ``.ply`` holds besides the reference properties.

    Attributes
    ----------
    sh_degree : int
        SH degree (0: no ``f_rest_*``; 3, the default, 45 zeros: the reference code's loader insists).
    xyz : bool
        Whether to add ``XYZ_X XYZ_Y XYZ_Z`` (readers with a fixed record layout, such as the reference
        code's SIBR viewer, need False).
    """

    sh_degree: int = 3
    xyz: bool = True

    def __post_init__(self):
        if self.sh_degree not in (0, 1, 2, 3):
            raise SplatError(f"sh_degree={self.sh_degree!r}: 3DGS files have SH degree 0, 1, 2 or 3.")


# ---------------------------------------------------------------------------------------- colours


@dataclass(frozen=True)
class SceneColours:
    """The corrected colour of every alive Gaussian.

    Attributes
    ----------
    XYZ : ndarray of shape (G, 3)
        Linear CIE XYZ of the capture's observer, scene white at Y = 1.
    sRGB : ndarray of shape (G, 3)
        sRGB-encoded in [0, 1] (Bradford from the scene white to D65, clipped).
    white_XYZ : ndarray of shape (3,)
        The scene white.
    white_scale : ndarray of shape (k,)
        Each model channel's response to a perfect white (model units at exposure 1).
    method : str
        The estimator.
    delta : float
        Its noise tolerance δ (white = 1), the correct step's.
    """

    XYZ: np.ndarray
    sRGB: np.ndarray
    white_XYZ: np.ndarray
    white_scale: np.ndarray
    method: str
    delta: float


def _correct_summary(out: Path) -> dict:
    path = out / "correct" / "summary.json"
    if not path.is_file():
        raise CaptureError(
            f"{out}: not corrected yet; run the correct step first (splat correct CAPTURE -o OUT)."
        )
    doc = read_json(path)
    try:
        scale = np.concatenate([np.asarray(s, float).ravel() for s in doc["white"]["scale"]])
        return {
            "method": str(doc["method"]),
            "delta": float(doc["delta"]),
            "scale": scale,
            "white_XYZ": np.asarray(doc["white_XYZ"], float).reshape(3),
        }
    except (KeyError, TypeError, ValueError) as e:
        raise CaptureError(f"{path}: not a splat correct summary ({type(e).__name__}: {e}).") from None


def _quantum(out: Path) -> float:
    """The correct step's colour deduplication step (its recorded setting; the default otherwise)."""
    from .capture import PipelineConfig

    try:
        s = read_json(out / "settings.json", what="settings record")["steps"]["correct"]["settings"]
        return float(s["quantum"])
    except (CaptureError, KeyError, TypeError, ValueError):
        return PipelineConfig.quantum


def scene_corrector(spec: CaptureSpec, method: str, delta: float):
    """The correct step's estimator for rendered responses: :func:`splat.capture.fit_corrector` on all
    cameras with ``method``, tolerance ``delta`` and the step's λ (:func:`splat.capture.pipeline_mix`),
    so that a Gaussian's colour is corrected as a rendered view's pixel is."""
    from .capture import fit_corrector, pipeline_mix

    return fit_corrector(spec, list(range(len(spec.cameras))), method, delta, mix=pipeline_mix(method))


def corrected_colours(
    spec: CaptureSpec, out: str | os.PathLike, arrays: dict[str, np.ndarray], *, progress=None
) -> SceneColours:
    """Each Gaussian's N-channel colour corrected as the correct step corrects a rendered view: divided
    by the white scale (white → 1), through :func:`splat.capture.fit_corrector` with the step's method
    and δ (cameras stacked), deduplicated at the step's ``quantum``; cached in :data:`SCENE` with the
    registered cameras (the report's viewer reads it), recomputed when the model, method (and its λ), δ,
    white, curves or lights changed.

    Parameters
    ----------
    spec : CaptureSpec
    out : path
        The run's output folder (trained and corrected).
    arrays : dict
        The Gaussians' raw parameters (:meth:`splat.Gaussians.to_numpy`), alive ones only: G rows.
    progress : zonotope.utilities.ProgressCallback, optional
        Called as ``progress("scene", done, total)``: 0 and G Gaussians at the start and the end, the
        distinct colours done in between where the estimator solves per colour.

    Raises
    ------
    CaptureError
        Not corrected yet, or the model's channel count is not three per camera.
    """
    import hashlib

    import jax

    from zonotope.correct.image import correct_image
    from zonotope.utilities import atomic_path

    from .capture import XYZ_to_sRGB, curves_fingerprint, pipeline_mix

    out = Path(out)
    c = _correct_summary(out)
    colours = np.asarray(jax.nn.softplus(np.asarray(arrays["colour_params"], np.float32)), np.float64)
    k = 3 * len(spec.cameras)
    if colours.shape[-1] != k or c["scale"].size != k:
        raise CaptureError(
            f"{out}: the model has {colours.shape[-1]} channels and the white {c['scale'].size}, but the "
            f"capture's {len(spec.cameras)} cameras need {k}; run the train and correct steps again."
        )
    key = np.concatenate([colours.ravel(), c["scale"], c["white_XYZ"], [c["delta"], _quantum(out)]])
    # the estimator's λ and the curves and lights too, so that colours made with another rule are not reused
    rule = repr((c["method"], pipeline_mix(c["method"]), curves_fingerprint(spec))).encode()
    digest = hashlib.sha256(key.tobytes() + rule).hexdigest()
    done = lambda XYZ: SceneColours(  # noqa: E731
        XYZ, XYZ_to_sRGB(XYZ, c["white_XYZ"]), c["white_XYZ"], c["scale"], c["method"], c["delta"]
    )
    cache = out / SCENE
    if cache.is_file():
        try:
            with np.load(cache, allow_pickle=False) as z:
                if str(z["key"]) == digest:
                    return done(np.asarray(z["XYZ"], float))
        except (OSError, ValueError, KeyError):
            pass  # unreadable or foreign: recomputed and replaced (the file is splat's own cache name)
    corrector = scene_corrector(spec, c["method"], c["delta"])
    balanced = np.maximum(colours / c["scale"], 0)
    XYZ = np.zeros((0, 3))
    if len(balanced):
        tell = None if progress is None else (lambda _stage, d, n: progress("scene", d, n))
        if tell is not None:
            tell("", 0, len(balanced))
        XYZ = correct_image(balanced[:, None], corrector, quantum=_quantum(out), progress=tell)[:, 0]
        if tell is not None:
            tell("", len(balanced), len(balanced))
    result = done(XYZ)
    cams = posed_capture(spec, out).views if (out / "poses" / "summary.json").is_file() else ()
    model = out / "train" / "model.npz"
    doc = {
        "key": np.asarray(digest),
        "model_stamp": np.asarray([model.stat().st_size, model.stat().st_mtime_ns], np.int64),
        "XYZ": XYZ,
        "sRGB": result.sRGB,
        "white_XYZ": result.white_XYZ,
        "method": np.asarray(result.method),
        "camera_names": np.asarray([v.name for v in cams], dtype=str),
        "camera_R": np.asarray([np.asarray(v.camera.R, float) for v in cams]).reshape(-1, 3, 3),
        "camera_t": np.asarray([np.asarray(v.camera.t, float) for v in cams]).reshape(-1, 3),
        "camera_focal": np.asarray([np.asarray(v.camera.focal, float) for v in cams]).reshape(-1, 2),
        "camera_principal": np.asarray([np.asarray(v.camera.principal, float) for v in cams]).reshape(-1, 2),
        "camera_size": np.asarray([(v.camera.width, v.camera.height) for v in cams], np.int64).reshape(-1, 2),
    }
    atomic_path(cache, lambda p: np.savez(p, **doc))
    return result


def prepare_scene(capture: str | os.PathLike, out: str | os.PathLike, *, progress=None) -> Path | None:
    """Write :data:`SCENE` (the corrected colour of every alive Gaussian and the registered cameras, which
    the report's viewer shows) when ``out`` holds a trained and corrected run; returns its path, or None
    when the run is not that far yet. ``progress``: as :func:`corrected_colours`'.

    Why here and not in the report: the colours need the correct step's estimator, and the report is a
    reader of ``OUT`` that never fits one."""
    from .capture import load_gaussians
    from .capture.workspace import Workspace

    spec, out = read_capture(capture), Path(out)
    if not (out / OUT_MARKER).is_file():
        return None
    Workspace(spec, out).check_made_from(spec)  # OUT's checks, and its results made from this capture
    if not ((out / "train" / "model.npz").is_file() and (out / "correct" / "summary.json").is_file()):
        return None
    g, alive = load_gaussians(out)
    corrected_colours(
        spec, out, {k: v[np.asarray(alive, bool)] for k, v in g.to_numpy().items()}, progress=progress
    )
    return out / SCENE


# ----------------------------------------------------------------------------------------- export


def check_export_path(dest, *, what: str, spec: CaptureSpec, force: bool, folder: bool = False) -> Path:
    """``dest`` as a Path, refused (one-line :class:`zonotope.utilities.io.OutputExistsError`) when it lies
    inside the capture, or exists and is not an output of ``splat export`` or ``force`` is not given."""
    from zonotope.utilities import check_output
    from zonotope.utilities.io import OutputExistsError

    dest = Path(dest)
    root = spec.root.resolve()
    if dest.resolve() == root or root in dest.resolve().parents:
        raise OutputExistsError(
            f"{what}={str(dest)!r} lies inside the capture {root}, which is never written to."
        )
    if folder:
        return check_output(dest, overwrite=force, signature=SIGNATURE, what=what)
    if not force or not (dest.exists() or dest.is_symlink()):
        return check_output(dest, overwrite=False, what=what)
    ok = False
    try:
        if dest.is_symlink() or not dest.is_file():
            raise OSError("not a plain file")
        with open(dest, "rb") as fh:
            head = fh.read(4096)
        if dest.suffix.lower() == ".json":
            ok = json.loads(dest.read_text()).get("written_by") == SIGNATURE
        else:
            ok = f"comment {SIGNATURE}".encode() in head.split(b"end_header", 1)[0]
    except (OSError, ValueError, AttributeError):
        ok = False
    if not ok:
        raise OutputExistsError(
            f"{what}={str(dest)!r} exists but was not written by splat export; it is never replaced. Choose "
            "another path, or move it away yourself."
        )
    return dest


def _channel_names(spec: CaptureSpec) -> list[str]:
    names = []
    for k in range(len(spec.cameras)):
        cam = re.sub(r"[^A-Za-z0-9]+", "_", spec.label(k)).strip("_") or f"camera{k + 1}"
        names += [f"f_{cam}_{ch}" for ch in "RGB"]
    if len(set(names)) != len(names):  # two folders that differ only in punctuation
        names = [f"f_camera{k + 1}_{ch}" for k in range(len(spec.cameras)) for ch in "RGB"]
    return names


def posed_capture(spec: CaptureSpec, out: Path):
    """The registered views (learned pose corrections applied) as a :class:`splat.data.Capture`."""
    from .capture import load_model_capture, refined_views
    from .data import Capture

    _, cap = load_model_capture(spec, out)
    return Capture(tuple(refined_views(cap.views, out)), cap.channels, cap.labels)


def export_scene(
    capture: str | os.PathLike,
    out: str | os.PathLike,
    *,
    ply: str | os.PathLike | None = None,
    ply_channels: str | os.PathLike | None = None,
    transforms: str | os.PathLike | None = None,
    colmap: str | os.PathLike | None = None,
    options: PlyOptions = PlyOptions(),
    force: bool = False,
) -> dict[str, dict]:
    """Write the run's scene and poses in other tools' formats (see the module notes).

    Parameters
    ----------
    capture : path
        The capture folder (its cameras' curves fit the estimator; its folders name the channels).
    out : path
        The run's output folder (``splat run CAPTURE -o OUT``); only read, except the colour cache
        (:func:`corrected_colours`).
    ply, ply_channels : path, optional
        The 3DGS file of the corrected colours; the same with the ``f_<camera>_<channel>`` properties.
    transforms : path, optional
        nerfstudio ``transforms.json`` of the registered views (:func:`splat.data.write_transforms`).
    colmap : path, optional
        A folder for the COLMAP binary model of the registered views (PINHOLE cameras, no points).
    options : PlyOptions
        What the ``.ply`` files hold besides the reference properties.
    force : bool
        Replace outputs of an earlier ``splat export`` (never other files).

    Returns
    -------
    dict
        Per written output (``"ply"``, ...): ``path``, ``bytes``, ``gaussians`` or ``views``.

    Raises
    ------
    CaptureError, OutputExistsError
        No trained model, poses or correction in ``out``; an output path inside the capture, or one that
        exists (and is not a previous export, or ``force`` is not given) — all before any work.
    """
    from .capture import load_gaussians
    from .capture.workspace import Workspace

    spec = read_capture(capture)
    out = Path(out)
    if not (out / OUT_MARKER).is_file():
        raise CaptureError(f"{out}: not a splat output folder (no {OUT_MARKER}); give the OUT of splat run.")
    Workspace(spec, out).check_made_from(spec)  # OUT's checks, and its results made from this capture
    todo = {"ply": ply, "ply_channels": ply_channels, "transforms": transforms, "colmap": colmap}
    todo = {k: v for k, v in todo.items() if v is not None}
    if not todo:
        raise SplatError("nothing to export: give --ply, --ply-channels, --transforms or --colmap.")
    dests = {
        k: check_export_path(v, what=f"--{k.replace('_', '-')}", spec=spec, force=force, folder=k == "colmap")
        for k, v in todo.items()
    }
    if len({d.resolve() for d in dests.values()}) != len(dests):
        raise SplatError(f"two exports name the same path: {sorted(map(str, dests.values()))}.")
    done: dict[str, dict] = {}
    if ("transforms" in dests or "colmap" in dests) and not (out / "poses" / "summary.json").is_file():
        raise CaptureError(f"{out}: no poses yet; run the poses step first (splat poses CAPTURE -o OUT).")
    if "ply" in dests or "ply_channels" in dests:
        _correct_summary(out)  # these three before the long work
        g, alive = load_gaussians(out)
        arrays = {k: v[np.asarray(alive, bool)] for k, v in g.to_numpy().items()}
        colours = corrected_colours(spec, out, arrays)
        props = ply_properties(arrays, colours.sRGB, sh_degree=options.sh_degree)
        w = colours.white_XYZ
        comments = [
            f"zonotope version {_version()}",
            f"colour f_dc is sRGB (IEC 61966-2-1) encoded, D65, f_dc = (colour - 0.5) / C0, C0 = {SH_C0!r}",
            f"colour corrected by {colours.method} (delta {colours.delta:.6g}) from "
            f"{len(spec.cameras)} cameras: " + ", ".join(c.folder for c in spec.cameras),
            f"colour scene white XYZ {w[0]:.6f} {w[1]:.6f} {w[2]:.6f} (observer {spec.observer}, illuminant "
            f"{spec.illuminant}), adapted to D65 by Bradford",
        ]
        if options.xyz:
            comments.append("colour XYZ_X XYZ_Y XYZ_Z are linear CIE XYZ of that observer, scene white Y = 1")
            props.update({f"XYZ_{a}": colours.XYZ[:, i].astype(np.float32) for i, a in enumerate("XYZ")})
        if "ply" in dests:
            p = write_ply(dests["ply"], props, comments=comments)
            done["ply"] = {"path": str(p), "bytes": p.stat().st_size, "gaussians": len(arrays["means"])}
        if "ply_channels" in dests:
            import jax

            names = _channel_names(spec)
            lin = np.asarray(jax.nn.softplus(arrays["colour_params"]), np.float32)
            extra = {n: lin[:, i] for i, n in enumerate(names)}
            more = [
                *comments,
                "channels " + " ".join(names) + " are the model's linear responses at exposure 1 (raw units)",
                "channels white "
                + " ".join(f"{n}={s:.6g}" for n, s in zip(names, colours.white_scale))
                + " (a perfect white's response: divide for white = 1)",
            ]
            p = write_ply(dests["ply_channels"], {**props, **extra}, comments=more)
            done["ply_channels"] = {
                "path": str(p),
                "bytes": p.stat().st_size,
                "gaussians": len(arrays["means"]),
            }
    if "transforms" in dests or "colmap" in dests:
        cap = posed_capture(spec, out)
        if "transforms" in dests:
            p = _write_transforms(cap, dests["transforms"])
            done["transforms"] = {"path": str(p), "bytes": p.stat().st_size, "views": len(cap.views)}
        if "colmap" in dests:
            from zonotope.utilities import atomic_dir

            from .colmap import write_colmap
            from .data import colmap_from_capture

            model = colmap_from_capture(cap)
            with atomic_dir(dests["colmap"], signature=SIGNATURE, overwrite=force) as tmp:
                write_colmap(model, tmp, binary=True)
            size = sum(f.stat().st_size for f in Path(dests["colmap"]).iterdir() if f.is_file())
            done["colmap"] = {"path": str(dests["colmap"]), "bytes": size, "views": len(cap.views)}
    return done


def _write_transforms(cap, dest: Path) -> Path:
    """:func:`splat.data.write_transforms` with the top-level key ``written_by`` (:data:`SIGNATURE`)."""
    from zonotope.utilities import atomic_write_text

    from .data import write_transforms

    with tempfile.TemporaryDirectory() as d:
        doc = json.loads(write_transforms(cap, Path(d) / "transforms.json").read_text())
    return atomic_write_text(dest, json.dumps({"written_by": SIGNATURE, **doc}, indent=1))


def _version() -> str:
    from importlib.metadata import PackageNotFoundError, version

    try:
        return version("zonotope")
    except PackageNotFoundError:  # pragma: no cover - a source tree that was never installed
        return "0+unknown"
