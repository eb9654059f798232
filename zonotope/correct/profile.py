"""Take a fitted correction out of Python: 3-D LUTs and saved corrections.

3-D LUT
-------
:func:`correction_LUT` samples an estimator (white-balanced camera RGB → XYZ) on a lattice and
returns a colour-science :class:`colour.LUTSequence` of a per-channel **shaper** and a
:class:`colour.LUT3D`; :func:`write_correction_LUT` writes it with :func:`colour.write_LUT`
(Resolve ``.cube`` with its 1-D shaper, or Cinespace ``.csp``, whose pre-LUT is the shaper).

Domain and shaper (documented so nothing is clipped silently):

* input: white-balanced camera RGB, the perfect white reflector at (1, 1, 1);
* domain ``[0, headroom]`` per channel (default ``headroom = 16``: four stops above the white
  for highlights and specular reflections). Negative inputs (noise, demosaicing overshoot) clamp to
  0 and inputs above ``headroom`` clamp to it — the only clipping, stated in the file's comments;
* shaper ``"log2"`` (default): ``y = log2(1 + x / τ) / log2(1 + headroom / τ)``, ``τ ≈ 2⁻⁸``
  (lattice nodes spaced evenly in stops down to ≈ 8 stops below the white, linear below), τ
  adjusted (:func:`white_node_toe`) so that the white (1, 1, 1) is a lattice node and comes out
  exactly as the estimator maps it; ``"linear"``: ``y = x / headroom`` (exact for the matrix part,
  coarse in the shadows; the white is a node when ``(size − 1) / headroom`` is an integer, as for
  33 nodes and headroom 16);
* the estimator sees a response brighter than the white (max channel > 1) at the exposure that
  brings it to the white's level and is scaled back (exposure-linear above the white, as
  :class:`isp.MetamerCorrection` does); responses outside the camera's object-colour solid go to
  the estimator as they are (the MMV-based ones take the nearest feasible response);
* output: ``"XYZ"`` (the scene illuminant's white at Y = 1), ``"sRGB"`` (linear, D65) or
  ``"ACES2065-1"`` (linear AP0), the white chromatically adapted (Bradford) to the space's white.

Saved corrections
-----------------
:func:`save_correction` writes a fitted :class:`zonotope.correct.Corrector` to one ``.npz`` file:
a JSON header ``meta`` (format version, method, sources/cameras, target, illuminant, training
name, fitting options) and the arrays of the problem (``Phi``, ``Psi``, ``wavelengths``,
``training``, ``XYZ_from_target``) and of the fitted parameters (``param_M`` for the linear and
root-polynomial estimators). :func:`load_correction` rebuilds the estimator without the camera
files or the training set: regressions from their stored coefficients, the MMV- and prior-based
estimators (Centroid, Projection, MAP, Prior) from the stored problem, which *is* their parameter
set (their deterministic fitting — prior mean/covariance, regression, solid volume — reruns in
well under a second).
"""

from __future__ import annotations

import json
import math
import os
from collections.abc import Callable
from dataclasses import dataclass, replace
from pathlib import Path

import colour
import numpy as np

from .._errors import SpectralDataError, ZonotopeError
from ..spectra.builtin import float_array
from ..utilities.io import atomic_path
from ..utilities.progress import ProgressCallback

__all__ = [
    "LUT_SHAPERS",
    "LUT_SPACES",
    "LUTConfig",
    "SavedCorrectionNotFoundError",
    "apply_correction_LUT",
    "correction_LUT",
    "load_correction",
    "save_correction",
    "write_correction_LUT",
]

#: Output spaces of :func:`correction_LUT` → colour-science RGB colourspace (None for XYZ).
LUT_SPACES: dict[str, str | None] = {"XYZ": None, "sRGB": "sRGB", "ACES2065-1": "ACES2065-1"}
#: Shaper names of :func:`correction_LUT`.
LUT_SHAPERS = ("log2", "linear")
#: The log2 shaper's linear toe τ: nodes evenly spaced in stops down to ≈ 8 stops below the white.
_TOE = 2.0**-8


class SavedCorrectionNotFoundError(ZonotopeError, FileNotFoundError):
    """:func:`load_correction` of a path that does not exist (also a ``FileNotFoundError``)."""


_FORMAT = "zonotope-correction/1"


def _space(name: str) -> str:
    key = "".join(ch for ch in str(name).lower() if ch.isalnum())
    for s in LUT_SPACES:
        if "".join(ch for ch in s.lower() if ch.isalnum()) in (key, key.replace("linear", "")):
            return s
    raise ZonotopeError(f"space={name!r}: choose one of {list(LUT_SPACES)} (linear RGB or XYZ).")


def shaper_encode(x, *, headroom: float, shaper: str, toe: float = _TOE) -> np.ndarray:
    """The shaper ``[0, headroom] → [0, 1]`` of :func:`correction_LUT` (see module notes)."""
    x = np.clip(np.asarray(x, dtype=np.float64), 0.0, headroom)
    if shaper == "linear":
        return x / headroom
    return np.log2(1.0 + x / toe) / np.log2(1.0 + headroom / toe)


def shaper_decode(y, *, headroom: float, shaper: str, toe: float = _TOE) -> np.ndarray:
    """Inverse of :func:`shaper_encode`."""
    y = np.asarray(y, dtype=np.float64)
    if shaper == "linear":
        return y * headroom
    return toe * (np.exp2(y * np.log2(1.0 + headroom / toe)) - 1.0)


def white_node_toe(headroom: float, size: int) -> float:
    """The log2 shaper's toe τ nearest 2⁻⁸ that puts the white (x = 1) exactly on a lattice node.

    Between nodes the 3-D LUT interpolates linearly in shaper space, which is exact only for
    estimators linear in that space; with τ = 2⁻⁸, 33 nodes and headroom 16 the white fell between
    nodes 21 and 22, and Prior's white came out 3.2 ΔE00 off. ``y(1) = log2(1 + 1/τ) / log2(1 +
    headroom/τ)`` falls monotonically from 1 (τ → 0) to 1/headroom (τ → ∞), so τ solves
    ``y(1) = j / (size − 1)`` for the node ``j`` nearest the white's position at 2⁻⁸. Returns 2⁻⁸
    when no node between 1/headroom and 1 can be reached (``headroom = 1``: the white is the last
    node already).
    """
    from scipy.optimize import brentq

    def y_white(toe: float) -> float:
        return float(np.log2(1.0 + 1.0 / toe) / np.log2(1.0 + headroom / toe))

    if headroom <= 1 or size < 3:
        return _TOE
    lo, hi = _TOE * 2.0**-30, _TOE * 2.0**30  # headroom 16: y(1) = 0.905 … 1/16 + 1e-7
    at = y_white(_TOE) * (size - 1)
    for j in sorted({round(at), math.floor(at), math.ceil(at)}, key=lambda j: abs(j - at)):
        target = j / (size - 1)
        if y_white(hi) < target < y_white(lo):
            return float(brentq(lambda t, y=target: y_white(t) - y, lo, hi))
    return _TOE


def _exposure_safe(fn: Callable[[np.ndarray], np.ndarray]) -> Callable[[np.ndarray], np.ndarray]:
    if not callable(fn):
        raise ZonotopeError(
            f"XYZ_from_balanced={fn!r:.60}: give a callable (N, 3) → (N, 3), e.g. a fitted Corrector."
        )

    def g(c):
        c = np.maximum(np.asarray(c, dtype=np.float64), 0.0)
        over = np.maximum(c.max(axis=-1, keepdims=True), 1.0)
        out = float_array(fn(c / over), "XYZ_from_balanced's output", ZonotopeError)
        if out.shape != c.shape:
            raise ZonotopeError(
                f"XYZ_from_balanced maps {c.shape} responses to shape {out.shape}; it must return "
                "one XYZ per response, (N, 3)."
            )
        return out * over

    return g


@dataclass(frozen=True)
class LUTConfig:
    """The options of :func:`correction_LUT`, checked when the object is made.

    Attributes
    ----------
    size : int
        3-D lattice size per axis, 2…129 (17, 33 and 65 are the usual ones).
    space : str
        Output: ``"XYZ"``, ``"sRGB"`` (linear) or ``"ACES2065-1"`` (spelling is forgiving:
        ``"srgb"``, ``"linear sRGB"``); stored as the key of :data:`LUT_SPACES`.
    headroom : float
        Largest input per channel, in units of the white (default 16 = 4 stops), ≥ 1.
    shaper : str
        ``"log2"`` or ``"linear"``.
    shaper_size : int
        Entries of the 1-D shaper, ≥ 2.
    white_XYZ : array_like of shape (3,), optional
        XYZ of the scene white (default: the estimator's output for (1, 1, 1)); finite, Y > 0.
    batch : int
        Lattice nodes per call of the estimator, ≥ 1.
    name : str
        LUT name (written into the file).

    Raises
    ------
    ZonotopeError
        A field out of range (an :class:`~zonotope.OptionError` naming it).
    """

    size: int = 33
    space: str = "sRGB"
    headroom: float = 16.0
    shaper: str = "log2"
    shaper_size: int = 4096
    white_XYZ: object = None
    batch: int = 4096
    name: str = "zonotope correction"

    def __post_init__(self) -> None:
        from .._errors import OptionError
        from ..utilities.config import check_count

        if not (
            isinstance(self.size, int | np.integer)
            and not isinstance(self.size, bool)
            and 2 <= self.size <= 129
        ):
            raise OptionError(f"size={self.size!r}: a 3-D LUT needs 2…129 nodes per axis (33 is usual).")
        try:
            headroom_ok = not isinstance(self.headroom, bool) and bool(
                np.isfinite(self.headroom) and self.headroom >= 1
            )
        except TypeError:
            headroom_ok = False
        if not headroom_ok:
            raise OptionError(
                f"headroom={self.headroom!r}: must be ≥ 1 (the white is 1; 16 = four stops above)."
            )
        if self.shaper not in LUT_SHAPERS:
            raise OptionError(f"shaper={self.shaper!r}: choose one of {list(LUT_SHAPERS)}.")
        object.__setattr__(self, "space", _space(self.space))
        check_count("LUTConfig", "shaper_size", self.shaper_size, minimum=2)
        check_count("LUTConfig", "batch", self.batch, minimum=1)
        if not isinstance(self.name, str):
            raise OptionError(f"LUTConfig.name={self.name!r}: give a text.")
        if self.white_XYZ is not None:
            try:
                w = np.asarray(self.white_XYZ, dtype=np.float64)
            except (TypeError, ValueError):
                w = np.full(1, np.nan)
            if w.shape != (3,) or not (np.all(np.isfinite(w)) and w[1] > 0):
                raise OptionError(f"white_XYZ={self.white_XYZ!r}: give 3 finite XYZ values with Y > 0.")


def correction_LUT(
    XYZ_from_balanced: Callable[[np.ndarray], np.ndarray],
    config: LUTConfig | None = None,
    *,
    progress: ProgressCallback | None = None,
    **options,
) -> colour.LUTSequence:
    """Sample an estimator into a shaper + 3-D LUT (see the module notes for domain and shaper).

    Parameters
    ----------
    XYZ_from_balanced
        ``(N, 3) → (N, 3)``: white-balanced camera RGB (white = 1) → XYZ under the scene
        illuminant (e.g. a fitted ``zonotope.correct`` Corrector, or ``isp.MetamerCorrection``).
    config
        The options (:class:`LUTConfig`: size, space, headroom, shaper, shaper_size, white_XYZ,
        batch, name); default all defaults.
    progress
        Called as ``progress("LUT nodes", done, size³)`` after each batch of lattice nodes
        (:class:`~zonotope.utilities.ProgressCallback`; a 33³ Prior LUT takes minutes).
    **options
        Fields of :class:`LUTConfig` as keywords (override those of ``config``), e.g. ``size=17``.

    Returns
    -------
    colour.LUTSequence
        ``LUT3x1D`` shaper (domain ``[0, headroom]``) followed by ``LUT3D`` (domain [0, 1]).

    Raises
    ------
    ZonotopeError
        Bad size, headroom, shaper or space (:class:`~zonotope.OptionError`), or an estimator that
        returns NaN.
    """
    from ..utilities.config import with_options

    cfg = with_options(LUTConfig, config, options, where="correction_LUT")
    size, headroom, shaper, white_XYZ = cfg.size, cfg.headroom, cfg.shaper, cfg.white_XYZ
    shaper_size, batch, name, sp = cfg.shaper_size, cfg.batch, cfg.name, cfg.space
    f = _exposure_safe(XYZ_from_balanced)
    w = np.asarray(f(np.ones((1, 3)))[0] if white_XYZ is None else white_XYZ, dtype=np.float64)
    if not (np.all(np.isfinite(w)) and w[1] > 0):
        raise ZonotopeError(
            f"the estimator maps the white (1, 1, 1) to XYZ {w}: need a finite white with Y > 0."
        )
    if LUT_SPACES[sp] is None:
        M = np.eye(3) / w[1]
    else:
        cs = colour.RGB_COLOURSPACES[LUT_SPACES[sp]]
        cat = colour.adaptation.matrix_chromatic_adaptation_VonKries(
            w / w[1], colour.xy_to_XYZ(cs.whitepoint), transform="Bradford"
        )
        M = cs.matrix_XYZ_to_RGB @ cat / w[1]
    toe = white_node_toe(headroom, size)  # the white on a lattice node (log2 shaper)
    nodes = shaper_decode(np.linspace(0.0, 1.0, size), headroom=headroom, shaper=shaper, toe=toe)
    grid = np.stack(np.meshgrid(nodes, nodes, nodes, indexing="ij"), axis=-1).reshape(-1, 3)
    out = np.empty_like(grid)
    for i in range(0, grid.shape[0], batch):
        out[i : i + batch] = f(grid[i : i + batch])
        if progress is not None:
            progress("LUT nodes", min(i + batch, grid.shape[0]), grid.shape[0])
    if not np.all(np.isfinite(out)):
        raise ZonotopeError("the estimator returned NaN or inf on some lattice nodes; it cannot be sampled.")
    table = (out @ M.T).reshape(size, size, size, 3)
    x = np.linspace(0.0, headroom, shaper_size)
    shaper_table = np.repeat(shaper_encode(x, headroom=headroom, shaper=shaper, toe=toe)[:, None], 3, axis=1)
    comments = [
        f"zonotope: white-balanced camera RGB (white = 1) -> linear {sp}",
        f"input domain [0, {headroom:g}] per channel; below 0 and above {headroom:g} clamp",
        f"shaper {shaper}" + (f" (toe {toe:.9g}: the white is a lattice node)" if shaper == "log2" else ""),
    ]
    return colour.LUTSequence(
        colour.LUT3x1D(shaper_table, name=f"{name} shaper", domain=np.array([[0.0] * 3, [headroom] * 3])),
        colour.LUT3D(table, name=name, comments=comments),
    )


def apply_correction_LUT(lut: colour.LUTSequence, rgb) -> np.ndarray:
    """Apply a :func:`correction_LUT` result with colour-science (trilinear), shape (..., 3)."""
    rgb = float_array(rgb, "rgb", ZonotopeError)
    if rgb.ndim < 1 or rgb.shape[-1] != 3:
        raise ZonotopeError(f"rgb: expected white-balanced camera RGB of shape (..., 3), got {rgb.shape}.")
    return lut.apply(rgb)


def write_correction_LUT(
    path: str | os.PathLike, lut: colour.LUTSequence, *, overwrite: bool = False, decimals: int = 7
) -> Path:
    """Write a :func:`correction_LUT` atomically with colour-science's writer for the extension.

    ``.cube`` → Resolve Cube (1-D shaper + 3-D LUT in one file, read by OpenColorIO, Resolve,
    darktable's LUT 3D module; the TITLE line colour writes is dropped because OpenColorIO's Resolve
    reader rejects it, the comments keep the description); ``.csp`` → Cinespace (shaper as pre-LUT).

    Raises
    ------
    ZonotopeError
        ``path`` exists, or an extension whose format cannot hold a shaper + 3-D LUT.
    """
    path = Path(path)
    methods = {".cube": "Resolve Cube", ".csp": "Cinespace"}
    method = methods.get(path.suffix.lower())
    if method is None:
        raise ZonotopeError(
            f"{path}: LUT format {path.suffix!r} cannot hold a shaper + 3-D LUT; use {' or '.join(methods)}."
        )
    if path.exists() and not overwrite:
        raise ZonotopeError(f"{path} exists; pass overwrite=True (--overwrite) or choose another name.")

    def write(tmp: Path) -> None:
        colour.write_LUT(lut, str(tmp), decimals=decimals, method=method)
        if method == "Resolve Cube":  # OpenColorIO's Resolve reader rejects the TITLE line: drop it
            text = tmp.read_text(encoding="utf-8").splitlines(keepends=True)
            tmp.write_text("".join(t for t in text if not t.startswith("TITLE")), encoding="utf-8")

    atomic_path(path, write)  # temporary sibling, fsync, umask permissions, rename
    return path


# ---------------------------------------------------------------------------------------------
# Saved corrections
# ---------------------------------------------------------------------------------------------

_PROBLEM_ARRAYS = ("Phi", "Psi", "wavelengths", "training", "XYZ_from_target")

#: The largest saved correction :func:`load_correction` decompresses (all members, as declared in
#: the archive). A correction on a 1 nm grid with 10⁵ training spectra is ≈ 380 MB; 512 MiB keeps
#: that and refuses a few-MB archive that would inflate to gigabytes before being found wrong.
SAVED_CORRECTION_MAX_BYTES = 512 * 2**20

#: The members a saved correction holds (``meta`` is the JSON header as a 0-d text array).
_MEMBERS = ("meta", *_PROBLEM_ARRAYS, "param_M")


def _option_keys(method: str) -> tuple[str, ...]:
    """The fitting options a saved correction records: shape options and the method's noise option
    (its registry entry's ``noise_option``), so that a reload refits with the same noise."""
    from .methods import CORRECTION_METHODS

    option = CORRECTION_METHODS.properties(method).get("noise_option")
    return ("degree", "eps", "white_point", *((option,) if option else ()))


def save_correction(
    path: str | os.PathLike, corrector, *, options: dict | None = None, overwrite: bool = False
) -> Path:
    """Save a fitted estimator to a ``.npz`` file (format in the module notes), atomically.

    Parameters
    ----------
    path
        Output file (``.npz``).
    corrector : zonotope.correct.Corrector
    options
        Fitting options to record (default: those the estimator keeps in ``params``: degree, eps
        and its noise option, ``noise`` or ``delta``). Give non-default options of Prior/MAP (odds,
        shrinkage) here.
    overwrite
        Replace an existing file.

    Returns
    -------
    Path
    """
    path = Path(path)
    if path.suffix.lower() != ".npz":
        raise ZonotopeError(f"{path}: a saved correction is a .npz file; use that extension.")
    if path.exists() and not overwrite:
        raise ZonotopeError(f"{path} exists; pass overwrite=True or choose another name.")
    prob = corrector.problem
    keys = _option_keys(corrector.method)
    opts = {k: v for k, v in corrector.params.items() if k in keys and np.isscalar(v)}
    opts.update(options or {})
    meta = {
        "format": _FORMAT,
        "method": corrector.method,
        "sources": list(prob.sources),
        "target": prob.target,
        "illuminant": prob.illuminant,
        "target_illuminant": prob.target_illuminant,
        "training": prob.training_name,
        "options": {k: (v.item() if isinstance(v, np.generic) else v) for k, v in opts.items()},
    }
    arrays = {name: np.asarray(getattr(prob, name), dtype=np.float64) for name in _PROBLEM_ARRAYS}
    M = corrector.params.get("M")
    if M is not None:
        arrays["param_M"] = np.asarray(M, dtype=np.float64)

    def write(tmp: Path) -> None:
        with open(tmp, "wb") as fh:
            np.savez_compressed(fh, meta=np.array(json.dumps(meta)), **arrays)

    atomic_path(path, write)  # temporary sibling, fsync, umask permissions, rename
    return path


def _read_members(path: Path) -> dict[str, np.ndarray]:
    """The arrays of a saved correction, each checked before it is decompressed.

    Every member must be one of :data:`_MEMBERS` (``.npy``), all of them together at most
    :data:`SAVED_CORRECTION_MAX_BYTES` as declared by the archive, each a float (or, for ``meta``,
    text) array whose header's shape fits its declared size: a hostile archive is refused before
    it allocates, since zip members declare sizes that ``np.load`` would otherwise trust.
    """
    import zipfile
    import zlib

    fmt = np.lib.format
    try:
        with zipfile.ZipFile(path) as zf:
            infos = zf.infolist()
            total = sum(info.file_size for info in infos)
            if total > SAVED_CORRECTION_MAX_BYTES:
                raise ZonotopeError(
                    f"{path}: declares {total / 2**20:.0f} MiB of arrays, more than a saved correction "
                    f"holds (SAVED_CORRECTION_MAX_BYTES = {SAVED_CORRECTION_MAX_BYTES // 2**20} MiB); "
                    "refused unread."
                )
            out = {}
            for info in infos:
                name = info.filename.removesuffix(".npy")
                if name not in _MEMBERS or name in out:
                    raise ZonotopeError(
                        f"{path}: not a saved correction (member {info.filename!r}); one holds "
                        f"{', '.join(_MEMBERS)} (.npy) once each."
                    )
                with zf.open(info) as fh:
                    version = fmt.read_magic(fh)
                    read_header = (
                        fmt.read_array_header_1_0 if version == (1, 0) else fmt.read_array_header_2_0
                    )
                    shape, _, dtype = read_header(fh)
                kinds = "U" if name == "meta" else "fiu"
                if dtype.hasobject or dtype.kind not in kinds:
                    raise ZonotopeError(
                        f"{path}: member {name!r} has dtype {dtype}; a saved correction stores "
                        f"{'text' if name == 'meta' else 'numbers'} only (pickled objects are never loaded)."
                    )
                if math.prod(shape) * dtype.itemsize > info.file_size:
                    raise ZonotopeError(
                        f"{path}: member {name!r} declares shape {shape}, larger than its stored "
                        f"{info.file_size} bytes; the file is damaged."
                    )
                with zf.open(info) as fh:
                    out[name] = fmt.read_array(fh, allow_pickle=False)
    except ZonotopeError:
        raise
    except (OSError, EOFError, ValueError, zipfile.BadZipFile, zlib.error, NotImplementedError) as exc:
        raise ZonotopeError(
            f"{path}: not a saved correction (an .npz written by save_correction): "
            f"{type(exc).__name__}: {exc}."
        ) from exc
    return out


def _checked_arrays(path: Path, members: dict[str, np.ndarray]) -> dict[str, np.ndarray]:
    """The problem's arrays (and ``param_M``) as float64, finite and of consistent shapes.

    Why: a NaN or inf in any of them would make every corrected response NaN without an error.
    """
    arrays = {name: np.asarray(a, dtype=np.float64) for name, a in members.items()}
    for name, a in arrays.items():
        if not np.all(np.isfinite(a)):
            raise SpectralDataError(
                f"{path}: array {name!r} contains NaN or inf; the saved correction is damaged, "
                "fit and save it again."
            )
    n = arrays["wavelengths"].shape[0] if arrays["wavelengths"].ndim == 1 else -1
    m = arrays["Psi"].shape[1] if arrays["Psi"].ndim == 2 else -1
    want = {
        "wavelengths": (n,),
        "Phi": (n, arrays["Phi"].shape[-1] if arrays["Phi"].ndim == 2 else -1),
        "Psi": (n, m),
        "training": (arrays["training"].shape[0] if arrays["training"].ndim == 2 else -1, n),
        "XYZ_from_target": (m, 3),
    }
    for name, shape in want.items():
        if arrays[name].shape != shape or min(shape) < 1:
            raise SpectralDataError(
                f"{path}: array {name!r} has shape {arrays[name].shape}; expected {shape} "
                f"(n = {n} wavelengths, m = {m} target channels)."
            )
    return arrays


def load_correction(path: str | os.PathLike):
    """Load an estimator saved by :func:`save_correction`.

    Returns
    -------
    zonotope.correct.Corrector
        Same method, problem and outputs as the saved one.

    Raises
    ------
    ZonotopeError
        Not a saved correction (not a zip archive, missing arrays or header, unknown format version
        or method), a member that is not a plain numeric array (pickles are never loaded), or an
        archive larger than :data:`SAVED_CORRECTION_MAX_BYTES` once decompressed.
    SpectralDataError
        Arrays of inconsistent shapes, NaN or inf values, or a damaged header.
    """
    from .methods import (
        CORRECTION_METHODS,
        CorrectionProblem,
        Corrector,
        root_polynomial_terms,
    )

    path = Path(path)
    if not path.is_file():
        raise SavedCorrectionNotFoundError(f"saved correction {path} not found.")
    members = _read_members(path)
    try:
        meta = json.loads(str(members.pop("meta")))
    except (KeyError, ValueError) as exc:
        raise ZonotopeError(f"{path}: not a saved correction (no JSON header 'meta': {exc}).") from exc
    if not isinstance(meta, dict) or meta.get("format") != _FORMAT:
        found = meta.get("format") if isinstance(meta, dict) else type(meta).__name__
        raise ZonotopeError(f"{path}: format {found!r}; this version reads {_FORMAT!r}.")
    method = meta.get("method")
    if not isinstance(method, str) or method not in CORRECTION_METHODS:
        raise ZonotopeError(f"{path}: method {method!r} is not one of {list(CORRECTION_METHODS)}.")
    missing = [name for name in _PROBLEM_ARRAYS if name not in members]
    if missing:
        raise ZonotopeError(f"{path}: not a saved correction (array(s) {', '.join(missing)} missing).")
    arrays = _checked_arrays(path, members)
    M = arrays.pop("param_M", None)
    names = {key: meta.get(key) for key in ("target", "illuminant", "training")}
    names["target_illuminant"] = meta.get("target_illuminant", "")  # absent in files before it existed
    sources = meta.get("sources")
    opts = meta.get("options", {})
    if (
        not all(isinstance(v, str) for v in names.values())
        or not isinstance(sources, list)
        or not all(isinstance(v, str) for v in sources)
        or not isinstance(opts, dict)
        or not all(isinstance(v, int | float | str | bool) for v in opts.values())
    ):
        raise SpectralDataError(
            f"{path}: header 'meta' needs text target, illuminant, training, a list of source names "
            "and scalar options; the file is damaged or was not written by save_correction."
        )
    try:
        prob = CorrectionProblem(
            **arrays,
            sources=tuple(sources),
            target=names["target"],
            illuminant=names["illuminant"],
            training_name=names["training"],
            target_illuminant=names["target_illuminant"],
        )
    except (TypeError, KeyError) as exc:
        raise SpectralDataError(f"{path}: incomplete problem ({exc}).") from exc
    opts = dict(opts)
    degree = opts.get("degree", 2)
    if isinstance(degree, bool) or not isinstance(degree, int | float) or degree != int(degree) or degree < 1:
        raise SpectralDataError(f"{path}: option degree={degree!r}; a polynomial degree is an integer ≥ 1.")
    degree = int(degree)
    if M is not None and method in ("Cheung 2004", "Dyer 2017", "Finlayson 2015"):
        k = prob.k
        rows = k
        if method == "Finlayson 2015":  # channels + the mixed products of each degree d ≤ degree
            rows += sum(math.comb(k + d - 1, d) - k for d in range(2, degree + 1))
        if M.shape != (rows, prob.m):
            raise SpectralDataError(
                f"{path}: param_M has shape {M.shape}; {method!r} on {k} channels needs ({rows}, {prob.m})."
            )
    # files written before the option have none: they were not white-point preserving
    white_point = opts.pop("white_point", False)
    if not isinstance(white_point, bool):
        raise SpectralDataError(f"{path}: option white_point={white_point!r}; it is True or False.")
    if method in ("Cheung 2004", "Dyer 2017", "Finlayson 2015") and M is not None:
        from .neutral import white_point_preserving

        if method == "Finlayson 2015":
            corrector = Corrector(
                method, prob, lambda c: root_polynomial_terms(c, degree=degree) @ M, {"M": M, **opts}
            )
        else:
            corrector = Corrector(method, prob, lambda c: c @ M, {"M": M, **opts})
        if white_point:  # the offset is the saved matrix's own: recomputed exactly from it
            return white_point_preserving(corrector)
        return replace(corrector, params={**corrector.params, "white_point": False})
    if "white_point" in CORRECTION_METHODS.properties(method):  # the entry takes the option
        opts["white_point"] = white_point
    elif white_point:
        raise SpectralDataError(f"{path}: white_point=True, but {method!r} has no white_point option.")
    try:
        return CORRECTION_METHODS[method](prob, **opts)
    except TypeError as exc:  # an option the method does not take
        raise SpectralDataError(
            f"{path}: options {sorted(opts)} do not fit {method!r} ({exc}); the file is damaged "
            "or was written by another version."
        ) from exc
