"""Spectral data layer: one wavelength grid, built-in curves by name, loaders, generator matrices.

Every curve in the library is a :class:`colour.MultiSpectralDistributions` (or a
:class:`colour.SpectralDistribution` for one curve). Arrays follow colour's layout:
``(n_wavelengths, n_channels)``.

Grid policy (read this once)
----------------------------
Curves measured by different people cover different ranges (camspec stops at 720 nm, the
Sigma SD Merrill data at 680 nm, Stockman & Sharpe start at 390 nm). :func:`common_shape`
returns the **intersection** of the ranges, stepped at the **coarsest** interval among the
inputs unless one is given, with both ends snapped *inwards* to multiples of the interval.
Curves are then resampled onto that grid by **linear interpolation only**:

- nothing is ever extrapolated; a grid that leaves a curve's measured range raises
  :class:`SpectralDataError` naming the curve and both ranges;
- linear interpolation cannot ring, so non-negative data stay non-negative, and a grid that is a
  subset of the measured wavelengths returns the measured values exactly.

Generators
----------
:func:`generators` multiplies sensitivities by an illuminant and Δλ on the grid. With the
default ``normalise="channel"`` every channel is scaled so that the perfect white reflector
(x = 1 at every wavelength) gives exactly 1, which makes the object-colour solid of any camera
live in the unit cube corner ``[0, 1]^k`` with white at ``(1, …, 1)``.
"""

from __future__ import annotations

import csv
import io
import json
import math
import os
import re
from collections.abc import Callable, Iterable, Sequence
from importlib import resources
from pathlib import Path
from typing import Any

import colour
import numpy as np

from .._errors import SpectralDataError
from .._errors import float_array as float_array  # used as spectra.float_array by other modules
from .._tol import GRID, NEGATIVE_NOISE

#: The most wavelengths a grid built here may have: 20,000 steps of 0.02 nm cover 380–780 nm, five
#: times finer than any spectroradiometer resolves; a finer step only multiplies memory (every
#: spectral matrix, training set and solid grows with it) — 1e-6 nm would be 4·10⁸ points.
GRID_POINTS_MAX = 20_001

__all__ = [
    "CAMERAS",
    "GRID_POINTS_MAX",
    "ILLUMINANTS",
    "OBSERVERS",
    "REFLECTANCES",
    "camera",
    "common_shape",
    "generators",
    "illuminant",
    "list_builtin",
    "observer",
    "read_camera",
    "read_reflectances",
    "read_sfu1995",
    "read_spectral_csv",
    "reflectances",
    "resample",
    "spectral_matrix",
]

Curve = colour.MultiSpectralDistributions | colour.SpectralDistribution
CurveLike = Curve | str | tuple[Any, Any]


# ---------------------------------------------------------------------------------------------
# Validation
# ---------------------------------------------------------------------------------------------


def _check(wavelengths: np.ndarray, values: np.ndarray, what: str, *, allow_negative: bool):
    """Validate one curve or set of curves; return float64 arrays ``(n,)`` and ``(n, k)``."""
    w = np.asarray(wavelengths, dtype=np.float64)
    v = np.asarray(values, dtype=np.float64)
    if v.ndim == 1:
        v = v[:, None]
    if w.ndim != 1 or v.ndim != 2 or v.shape[0] != w.shape[0]:
        raise SpectralDataError(
            f"{what}: wavelengths of shape {w.shape} and values of shape {v.shape} do not match; "
            "expected wavelengths (n,) and values (n,) or (n, k)."
        )
    if w.size < 2:
        raise SpectralDataError(f"{what}: needs at least 2 wavelengths, got {w.size}.")
    if not np.all(np.isfinite(w)):
        raise SpectralDataError(f"{what}: wavelengths contain NaN or inf.")
    if not np.all(np.diff(w) > 0):
        bad = int(np.argmin(np.diff(w)))
        raise SpectralDataError(
            f"{what}: wavelengths must increase strictly; {w[bad]} nm is followed by "
            f"{w[bad + 1]} nm. Sort the rows (and drop duplicates) before loading."
        )
    if not np.all(np.isfinite(v)):
        rows, cols = np.nonzero(~np.isfinite(v))
        raise SpectralDataError(
            f"{what}: {rows.size} values are NaN or inf (first at {w[rows[0]]} nm, column "
            f"{cols[0]}). Fill or trim the gaps before use; nothing is guessed here."
        )
    if not allow_negative:
        # interpolation in colour leaves values like -3e-22 where a curve reaches 0: that is
        # float noise, not a negative lobe, so it is cleared (_tol.NEGATIVE_NOISE of the peak)
        noise = (v < 0) & (v >= -NEGATIVE_NOISE * max(float(np.abs(v).max()), 1e-300))
        if np.any(noise):
            v = np.where(noise, 0.0, v)
    if not allow_negative and np.any(v < 0):
        rows, cols = np.nonzero(v < 0)
        raise SpectralDataError(
            f"{what}: {rows.size} negative values (most negative {v.min():.4g} at "
            f"{w[rows[np.argmin(v[rows, cols])]]} nm). Clip them, or pass allow_negative=True "
            "if the negative lobes are real (e.g. RGB colour-matching functions)."
        )
    return w, v


def _as_curve(obj: CurveLike, what: str, lookup: Callable[[str], Curve] | None = None) -> Curve:
    """Accept a colour curve, a built-in name or a ``(wavelengths, values)`` pair."""
    if isinstance(obj, colour.MultiSpectralDistributions | colour.SpectralDistribution):
        return obj
    if isinstance(obj, str):
        if lookup is None:
            raise SpectralDataError(f"{what}: names are not accepted here, pass a curve.")
        return lookup(obj)
    if isinstance(obj, tuple) and len(obj) == 2:
        w, v = _check(obj[0], obj[1], what, allow_negative=True)
        return colour.MultiSpectralDistributions(v, w, name=what)
    raise SpectralDataError(
        f"{what}: expected a colour SpectralDistribution / MultiSpectralDistributions, a built-in "
        f"name or a (wavelengths, values) tuple, got {type(obj).__name__}."
    )


def _arrays(curve: Curve) -> tuple[np.ndarray, np.ndarray]:
    if not (hasattr(curve, "values") and hasattr(curve, "wavelengths")):
        raise SpectralDataError(
            f"expected a colour SpectralDistribution or MultiSpectralDistributions; got "
            f"{type(curve).__name__} {curve!r:.60}. Load names and files with zonotope.load_camera, "
            "observer, illuminant or load_reflectances first."
        )
    try:
        v = np.asarray(curve.values, dtype=np.float64)
        w = np.asarray(curve.wavelengths, dtype=np.float64)
    except (TypeError, ValueError) as exc:
        raise SpectralDataError(
            f"{getattr(curve, 'name', 'curve')}: values are not numbers ({exc})."
        ) from None
    return w, v if v.ndim == 2 else v[:, None]


# ---------------------------------------------------------------------------------------------
# Grid
# ---------------------------------------------------------------------------------------------


def common_shape(*curves: Curve, interval: float | None = None) -> colour.SpectralShape:
    """Largest grid on which every curve is measured (the intersection of the ranges).

    Parameters
    ----------
    *curves
        colour spectral distributions (single or multi).
    interval
        Grid step in nm. Default: the coarsest sampling step among ``curves``, so no detail is
        invented.

    Returns
    -------
    colour.SpectralShape
        ``start`` and ``end`` are multiples of ``interval`` snapped inwards.

    Raises
    ------
    SpectralDataError
        When the ranges do not overlap by at least two grid steps.
    """
    if not curves:
        raise SpectralDataError("common_shape needs at least one curve.")
    arrays = [_arrays(c)[0] for c in curves]
    start = max(w[0] for w in arrays)
    end = min(w[-1] for w in arrays)
    step = float(interval) if interval is not None else max(float(np.max(np.diff(w))) for w in arrays)
    if not step > 0:
        raise SpectralDataError(f"interval must be positive, got {interval}.")
    if not math.isfinite(step):
        raise SpectralDataError(f"interval must be a finite number of nm, got {interval}.")
    _check_grid_size(start, end, step, "common_shape(interval=...)")
    lo = math.ceil(start / step - GRID) * step
    hi = math.floor(end / step + GRID) * step
    if hi - lo < step:
        ranges = ", ".join(
            f"{getattr(c, 'name', '?')}: {w[0]:g}–{w[-1]:g} nm" for c, w in zip(curves, arrays)
        )
        raise SpectralDataError(
            f"the curves share no common wavelength range at {step:g} nm steps ({ranges}). "
            "Use curves that overlap, or pass a finer interval."
        )
    return colour.SpectralShape(lo, hi, step)


def _check_grid_size(start: float, end: float, step: float, what: str) -> None:
    """Refuse a grid of more than :data:`GRID_POINTS_MAX` wavelengths before it is built.

    Raises
    ------
    SpectralDataError
        Naming ``what``, the number of points and the finest step allowed over that range.
    """
    points = (end - start) / step + 1 if step > 0 else math.inf
    if not points <= GRID_POINTS_MAX:
        finest = (end - start) / (GRID_POINTS_MAX - 1)
        raise SpectralDataError(
            f"{what}: a {step:g} nm grid over {start:g}–{end:g} nm has {points:.3g} wavelengths "
            f"(> GRID_POINTS_MAX = {GRID_POINTS_MAX}); use an interval of at least {finest:.2g} nm."
        )


def _grid(shape: colour.SpectralShape | Sequence[float] | np.ndarray) -> np.ndarray:
    if isinstance(shape, colour.SpectralShape):
        _check_grid_size(float(shape.start), float(shape.end), float(shape.interval), "shape")
        return np.asarray(shape.wavelengths, dtype=np.float64)
    w = np.asarray(shape, dtype=np.float64)
    if w.ndim != 1 or w.size < 2 or not np.all(np.diff(w) > 0) or not np.all(np.isfinite(w)):
        raise SpectralDataError(
            "a wavelength grid must be a colour.SpectralShape or a strictly increasing 1-D array "
            f"of at least 2 finite wavelengths; got {w!r}."
        )
    return w


def resample(
    curve: Curve, shape: colour.SpectralShape | np.ndarray, *, allow_negative: bool = False
) -> np.ndarray:
    """Values of ``curve`` on the grid, by linear interpolation, never extrapolating.

    Returns
    -------
    ndarray of shape (n_wavelengths, n_channels)
    """
    name = getattr(curve, "name", "curve")
    w, v = _check(*_arrays(curve), name, allow_negative=allow_negative)
    grid = _grid(shape)
    slack = GRID * max(1.0, abs(w[-1]))
    if grid[0] < w[0] - slack or grid[-1] > w[-1] + slack:
        raise SpectralDataError(
            f"{name}: measured on {w[0]:g}–{w[-1]:g} nm but the grid asks for "
            f"{grid[0]:g}–{grid[-1]:g} nm. Nothing is extrapolated: use common_shape(...) or a "
            "grid inside the measured range."
        )
    grid = np.clip(grid, w[0], w[-1])
    return np.stack([np.interp(grid, w, v[:, j]) for j in range(v.shape[1])], axis=1)


# ---------------------------------------------------------------------------------------------
# Built-in curves
# ---------------------------------------------------------------------------------------------


def _key(name: str) -> str:
    return re.sub(r"[^0-9a-z]+", "", name.lower().replace("°", "deg"))


def _rawtoaces_5d_mark_ii() -> colour.MultiSpectralDistributions:
    path = resources.files("colour.characterisation") / "datasets/rawtoaces"
    path = path / "CANON_EOS_5DMark_II_RGB_Sensitivities.csv"
    data = np.loadtxt(io.StringIO(path.read_text()), delimiter=",", skiprows=1)
    return colour.MultiSpectralDistributions(
        data[:, 1:], data[:, 0], labels=["red", "green", "blue"], name="Canon EOS 5D Mark II"
    )


def _sds_to_msds(sds: dict, name: str) -> colour.MultiSpectralDistributions:
    msds = colour.colorimetry.sds_and_msds_to_msds(list(sds.values()))
    msds.name = name
    return msds


#: Built-in cameras: canonical name → loader. Sources: Darrodi et al. 2015 (NPL) and the
#: rawtoaces CSV, both as shipped by colour-science.
CAMERAS: dict[str, Callable[[], colour.MultiSpectralDistributions]] = {
    "Nikon 5100 (NPL)": lambda: colour.MSDS_CAMERA_SENSITIVITIES["Nikon 5100 (NPL)"].copy(),
    "Sigma SDMerill (NPL)": lambda: colour.MSDS_CAMERA_SENSITIVITIES["Sigma SDMerill (NPL)"].copy(),
    "Canon EOS 5D Mark II": _rawtoaces_5d_mark_ii,
}
_CAMERA_ALIASES = {
    "nikon5100": "Nikon 5100 (NPL)",
    "nikond5100": "Nikon 5100 (NPL)",
    "sigmasdmerrill": "Sigma SDMerill (NPL)",
    "sigmasd1merrill": "Sigma SDMerill (NPL)",
    "sigmasdmerill": "Sigma SDMerill (NPL)",
    "canon5dmarkii": "Canon EOS 5D Mark II",
    "canoneos5dmarkii": "Canon EOS 5D Mark II",
}

#: Built-in observers / cone fundamentals (colour.MSDS_CMFS), with short aliases.
OBSERVERS: dict[str, str] = {
    "Stockman & Sharpe 2°": "Stockman & Sharpe 2 Degree Cone Fundamentals",
    "Stockman & Sharpe 10°": "Stockman & Sharpe 10 Degree Cone Fundamentals",
    "CIE 1931 2°": "CIE 1931 2 Degree Standard Observer",
    "CIE 1964 10°": "CIE 1964 10 Degree Standard Observer",
    "CIE 2015 2°": "CIE 2015 2 Degree Standard Observer",
    "CIE 2015 10°": "CIE 2015 10 Degree Standard Observer",
}
_OBSERVER_ALIASES = {
    "lms": "Stockman & Sharpe 2°",
    "lms2": "Stockman & Sharpe 2°",
    "lms10": "Stockman & Sharpe 10°",
    "xyz": "CIE 1931 2°",
    "cie1931": "CIE 1931 2°",
    "cie1964": "CIE 1964 10°",
}

#: Every illuminant colour-science ships (``colour.SDS_ILLUMINANTS``), by its colour name.
ILLUMINANTS: tuple[str, ...] = tuple(colour.SDS_ILLUMINANTS)

#: Built-in reflectance sets: name → loader returning one column per sample.
REFLECTANCES: dict[str, Callable[[], colour.MultiSpectralDistributions]] = {
    "ColorChecker N Ohta": lambda: _sds_to_msds(
        colour.SDS_COLOURCHECKERS["ColorChecker N Ohta"], "ColorChecker N Ohta"
    ),
    "BabelColor Average": lambda: _sds_to_msds(
        colour.SDS_COLOURCHECKERS["BabelColor Average"], "BabelColor Average"
    ),
    "rawtoaces 190": lambda: colour.characterisation.read_training_data_rawtoaces_v1(),
    "CIE 1995 TCS": lambda: _sds_to_msds(colour.quality.datasets.SDS_TCS["CIE 1995"], "CIE 1995 TCS"),
    "NIST CQS 9.0": lambda: _sds_to_msds(colour.quality.datasets.SDS_VS["NIST CQS 9.0"], "NIST CQS 9.0"),
}
_REFLECTANCE_ALIASES = {
    "colorchecker": "ColorChecker N Ohta",
    "cc24": "ColorChecker N Ohta",
    "babelcolor": "BabelColor Average",
    "rawtoaces": "rawtoaces 190",
    "training190": "rawtoaces 190",
    "tcs": "CIE 1995 TCS",
}


def _resolve(name: str, table: Iterable[str], aliases: dict[str, str], kind: str) -> str:
    if not isinstance(name, str):
        raise SpectralDataError(
            f"{kind} must be a built-in name or spectral data (colour MultiSpectralDistributions); "
            f"got {type(name).__name__} {name!r:.40}."
        )
    keys = {_key(k): k for k in table}
    k = _key(name)
    if k in keys:
        return keys[k]
    if k in aliases:
        return aliases[k]
    raise SpectralDataError(
        f"unknown {kind} {name!r}. Built-in {kind}s: {', '.join(table)}. "
        f"Give a file path instead "
        f"(zonotope.load_{'camera' if kind == 'camera' else 'reflectances'} reads it)."
        if kind in ("camera", "reflectance set")
        else f"unknown {kind} {name!r}. Built-in {kind}s: {', '.join(table)}."
    )


def camera(name: str | colour.MultiSpectralDistributions) -> colour.MultiSpectralDistributions:
    """A built-in camera's RGB sensitivities by name (case and punctuation ignored).

    >>> camera("nikon 5100").labels
    ['red', 'green', 'blue']
    """
    if isinstance(name, colour.MultiSpectralDistributions):
        return name
    resolved = _resolve(name, CAMERAS, _CAMERA_ALIASES, "camera")
    msds = CAMERAS[resolved]()
    msds.name = resolved
    return msds


def observer(name: str | colour.MultiSpectralDistributions = "Stockman & Sharpe 2°"):
    """Colour-matching functions or cone fundamentals by name (e.g. ``"lms"``, ``"CIE 1931 2°"``).

    Any key of ``colour.MSDS_CMFS`` is accepted as well.
    """
    if isinstance(name, colour.MultiSpectralDistributions):
        return name
    if name in colour.MSDS_CMFS:
        return colour.MSDS_CMFS[name].copy()
    return colour.MSDS_CMFS[OBSERVERS[_resolve(name, OBSERVERS, _OBSERVER_ALIASES, "observer")]].copy()


def illuminant(name: str | colour.SpectralDistribution = "D65") -> colour.SpectralDistribution:
    """Any colour-science illuminant by name (``"D65"``, ``"A"``, ``"FL2"``, ``"LED-B1"``, ...)."""
    if isinstance(name, colour.SpectralDistribution):
        return name
    return colour.SDS_ILLUMINANTS[_resolve(name, ILLUMINANTS, {}, "illuminant")].copy()


_illuminant = illuminant


def reflectances(name: str | colour.MultiSpectralDistributions) -> colour.MultiSpectralDistributions:
    """A built-in reflectance set, one column per sample."""
    if isinstance(name, colour.MultiSpectralDistributions):
        return name
    resolved = _resolve(name, REFLECTANCES, _REFLECTANCE_ALIASES, "reflectance set")
    msds = REFLECTANCES[resolved]()
    values = np.asarray(msds.values, dtype=np.float64)
    if np.any(values < -NEGATIVE_NOISE):  # pragma: no cover - colour's data are non-negative (peak ≈ 1)
        raise SpectralDataError(f"built-in set {resolved} has negative reflectances.")
    # a few entries of colour's tables are -2e-16 (float noise, e.g. rawtoaces 190): clear them
    return colour.MultiSpectralDistributions(
        np.maximum(values, 0.0), msds.wavelengths, labels=list(msds.labels), name=resolved
    )


def list_builtin() -> dict[str, list[str]]:
    """Names of every built-in curve, by kind: cameras, observers, illuminants, reflectances."""
    return {
        "cameras": list(CAMERAS),
        "observers": list(OBSERVERS),
        "illuminants": list(ILLUMINANTS),
        "reflectances": list(REFLECTANCES),
    }


# ---------------------------------------------------------------------------------------------
# Loaders
# ---------------------------------------------------------------------------------------------


def _is_number(s: str) -> bool:
    try:
        float(s)
    except ValueError:
        return False
    return True


def _read_text(path: Path, what: str) -> str:
    """The text of ``path``, or a :class:`SpectralDataError` for unreadable or binary files."""
    try:
        data = path.read_bytes()
    except OSError as error:
        raise SpectralDataError(f"cannot read {what} {path}: {error.strerror or error}.") from error
    if b"\x00" in data[:65536]:  # text tables never hold NUL bytes; images and binaries do
        raise SpectralDataError(
            f"{path} is not a text file (binary data, e.g. an image); {what} must be a CSV/TXT table "
            "or a JSON file."
        )
    try:
        return data.decode("utf-8-sig")
    except UnicodeDecodeError:
        return data.decode("latin-1")  # old instrument exports


def _float(cell, path: Path, where: str) -> float:
    try:
        return float(cell)
    except (TypeError, ValueError):
        raise SpectralDataError(
            f"{path}: {where}: {cell!r} is not a number. Fix or remove the row; "
            "rows are never skipped silently."
        ) from None


#: A header cell naming the wavelength column (``wavelength``, ``Wavelength (nm)``, ``nm``, ``λ``).
_WAVELENGTH_HEADER = re.compile(r"^\s*(wave\s*length|wl|nm|lambda|λ)\b", re.IGNORECASE)


def read_spectral_csv(
    path: str | Path, *, name: str | None = None, allow_negative: bool = False
) -> colour.MultiSpectralDistributions:
    """Read a spectral table in either orientation.

    Accepted layouts (``#`` comment lines and free-text preambles are skipped):

    - one row per wavelength: ``wavelength,ch1,ch2,...`` with or without a header
      (camspec / dcamprof CSV, ``wavelength,R,G,B``, colour-science exports);
    - one row per sample: header ``name,380,390,...`` then ``label,v1,v2,...``
      (Munsell tables).

    Raises
    ------
    SpectralDataError
        Unreadable or binary file, no table found, or a malformed row inside the table (a missing or
        extra cell, a non-numeric value): such rows are never dropped, since dropping them changes the
        grid silently.
    """
    path = Path(path)
    name = name or path.stem
    text = _read_text(path, "a spectral table")
    numbered = [
        (n + 1, line)
        for n, line in enumerate(text.splitlines())
        if line.strip() and not line.lstrip().startswith("#")
    ]
    rows, lines = [], []
    for n, line in numbered:
        r = next(csv.reader([line]))
        rows.append([c.strip() for c in r if c.strip() != ""])
        lines.append(n)
    start = next(
        (
            i
            for i in range(len(rows) - 1)
            if len(rows[i]) >= 2
            and len(rows[i + 1]) == len(rows[i])
            and all(_is_number(c) for c in rows[i + 1][1:])
        ),
        None,
    )
    if start is None:
        raise SpectralDataError(
            f"{path}: no table of numbers found. Expected comma-separated rows such as "
            "'wavelength,R,G,B' then '400,0.01,0.02,0.10'."
        )
    header = None if all(_is_number(c) for c in rows[start]) else rows[start]
    first = start + (header is not None)
    width = len(rows[start])
    above = rows[start - 1] if start else []
    if header is None and len(above) >= 2 and _WAVELENGTH_HEADER.match(above[0]):
        # a header whose width differs from the rows' would otherwise pass for a free-text preamble
        raise SpectralDataError(
            f"{path}: line {lines[start - 1]}: the header names {len(above)} columns "
            f"({','.join(above)[:60]!r}) but the rows below have {width} values. Fix the header or the "
            "rows; columns are never guessed."
        )
    for r, n in zip(rows[first:], lines[first:]):
        if len(r) != width:
            raise SpectralDataError(
                f"{path}: line {n} has {len(r)} values where the table has {width} ({','.join(r)[:60]!r}). "
                "Fix or remove the row; rows are never skipped silently."
            )
    body = rows[first:]
    body_lines = lines[first:]
    if header is not None and all(_is_number(c) for c in header[1:]):
        wavelengths = np.array([_float(c, path, f"line {lines[start]}") for c in header[1:]])
        labels = [r[0] for r in body]
        values = np.array([[_float(c, path, f"line {n}") for c in r[1:]] for r, n in zip(body, body_lines)]).T
    else:
        data = np.array([[_float(c, path, f"line {n}") for c in r] for r, n in zip(body, body_lines)])
        wavelengths, values = data[:, 0], data[:, 1:]
        labels = header[1:] if header is not None else [str(i + 1) for i in range(values.shape[1])]
    w, v = _check(wavelengths, values, f"{path}", allow_negative=allow_negative)
    return colour.MultiSpectralDistributions(v, w, labels=list(labels), name=name)


def _json(path: Path, what: str):
    try:
        return json.loads(_read_text(path, what))
    except (json.JSONDecodeError, RecursionError) as error:
        raise SpectralDataError(f"cannot read {what} {path}: not valid JSON ({error}).") from None


def _wrong_shape(path: Path, expected: str, error: Exception) -> SpectralDataError:
    return SpectralDataError(
        f"{path}: JSON of an unexpected shape ({type(error).__name__}: {error}); expected {expected}."
    )


_RAWTOACES = (
    "rawtoaces/AMPAS JSON: {'header': {...}, 'spectral_data': {'index': {'main': [labels]}, "
    "'data': {'main': {'<nm>': [values]}}}}"
)


def _rawtoaces(doc, path: Path, allow_negative: bool):
    """(wavelengths, values, labels, header) of a rawtoaces / AMPAS spectral JSON document."""
    try:
        header = doc.get("header", {}) or {}
        data = doc["spectral_data"]["data"]["main"]
        labels = [str(x) for x in doc["spectral_data"]["index"]["main"]]
        w = np.array([float(k) for k in data])
        rows = [np.ravel(np.asarray(data[k], dtype=np.float64)) for k in data]
        if len({r.size for r in rows}) > 1:
            raise ValueError(f"rows of unequal lengths {sorted({r.size for r in rows})}")
        v = np.array(rows, dtype=np.float64)
        if not isinstance(header, dict):
            raise TypeError("'header' is not an object")
    except (KeyError, TypeError, ValueError, AttributeError, IndexError) as error:
        raise _wrong_shape(path, _RAWTOACES, error) from None
    if v.ndim != 2 or v.shape[0] == 0 or len(labels) != v.shape[1]:
        raise SpectralDataError(
            f"{path}: {len(labels)} labels in 'index' for values of shape {v.shape}; "
            "expected one label per column."
        )
    order = np.argsort(w)
    w, v = _check(w[order], v[order], f"{path}", allow_negative=allow_negative)
    return w, v, labels, header


def read_camera(path: str | Path, *, allow_negative: bool = False) -> colour.MultiSpectralDistributions:
    """Read camera sensitivities: rawtoaces JSON, dcamprof/camspec JSON or any CSV layout.

    The channel count is not restricted to three (multispectral cameras load too).

    Raises
    ------
    SpectralDataError
        Unreadable, binary or malformed files, JSON of another layout, bad values.
    """
    path = Path(path)
    if path.suffix.lower() != ".json":
        return read_spectral_csv(path, allow_negative=allow_negative)
    doc = _json(path, "camera JSON")
    if isinstance(doc, dict) and "spectral_data" in doc:  # rawtoaces / AMPAS schema
        w, v, labels, header = _rawtoaces(doc, path, allow_negative)
        name = " ".join(str(x) for x in (header.get("manufacturer"), header.get("model")) if x)
        return colour.MultiSpectralDistributions(v, w, labels=labels, name=name or path.stem)
    if isinstance(doc, dict) and "ssf_bands" in doc:  # dcamprof
        keys = [k for k in ("red_ssf", "green_ssf", "blue_ssf") if k in doc]
        if not keys:
            raise SpectralDataError(f"{path}: dcamprof JSON without 'red_ssf', 'green_ssf' or 'blue_ssf'.")
        try:
            v = np.stack([np.ravel(np.asarray(doc[k], dtype=np.float64)) for k in keys], axis=1)
            bands = np.ravel(np.asarray(doc["ssf_bands"], dtype=np.float64))
        except (TypeError, ValueError) as error:
            raise _wrong_shape(
                path,
                "dcamprof JSON: 'ssf_bands' and 'red_ssf'/'green_ssf'/'blue_ssf' lists "
                "of numbers of one length",
                error,
            ) from None
        w, v = _check(bands, v, f"{path}", allow_negative=allow_negative)
        return colour.MultiSpectralDistributions(
            v,
            w,
            labels=[k.removesuffix("_ssf") for k in keys],  # a missing channel shifts no label
            name=str(doc.get("camera_name", path.stem)),
        )
    raise SpectralDataError(
        f"{path}: unknown JSON layout; expected rawtoaces ('spectral_data') or dcamprof "
        "('ssf_bands', 'red_ssf', ...)."
    )


def read_sfu1995(path: str | Path) -> colour.MultiSpectralDistributions:
    """Read the SFU 1995-reflectance database (``reflect_db.reflect``, Barnard et al. 2002).

    Spectra are blank-line separated blocks of one value per line on 380–780 nm / 4 nm.
    """
    path = Path(path)
    spectra: list[list[float]] = []
    current: list[float] = []
    origin, step = 380.0, 4.0
    for n, line in enumerate(_read_text(path, "an SFU reflectance file").splitlines(), start=1):
        line = line.strip()
        if line.startswith("#!"):
            o = re.search(r"o=([\d.]+)", line)
            s = re.search(r"s=([\d.]+)", line)
            if o is None or s is None:
                raise SpectralDataError(f"{path}: line {n}: a '#!' header needs o=<origin> and s=<step>.")
            origin, step = _float(o.group(1), path, f"line {n}"), _float(s.group(1), path, f"line {n}")
        if not line or line.startswith("#"):
            if current:
                spectra.append(current)
                current = []
            continue
        current.append(_float(line, path, f"line {n}"))
    if current:
        spectra.append(current)
    if not spectra:
        raise SpectralDataError(f"{path}: no spectra found (blocks of one value per line).")
    lengths = {len(s) for s in spectra}
    if len(lengths) != 1:
        raise SpectralDataError(f"{path}: spectra of unequal lengths {sorted(lengths)}.")
    values = np.array(spectra).T
    w = origin + step * np.arange(values.shape[0])
    w, values = _check(w, values, str(path), allow_negative=False)
    return colour.MultiSpectralDistributions(
        values, w, labels=[f"sfu{i:04d}" for i in range(values.shape[1])], name="SFU 1995"
    )


def read_reflectances(path: str | Path) -> colour.MultiSpectralDistributions:
    """Read a reflectance set from a CSV/TXT table (either orientation), a rawtoaces-style JSON or an
    SFU ``.reflect`` file.

    Raises
    ------
    SpectralDataError
        Unreadable, binary or malformed files, JSON of another layout, negative or non-finite values.
    """
    path = Path(path)
    if path.suffix == ".reflect":
        return read_sfu1995(path)
    if path.suffix.lower() == ".json":
        doc = _json(path, "reflectance JSON")
        if not isinstance(doc, dict):
            raise _wrong_shape(path, _RAWTOACES, TypeError(f"top level is a {type(doc).__name__}"))
        w, v, labels, _ = _rawtoaces(doc, path, allow_negative=False)
        return colour.MultiSpectralDistributions(v, w, labels=labels, name=path.stem)
    return read_spectral_csv(path)


# ---------------------------------------------------------------------------------------------
# Generator matrices
# ---------------------------------------------------------------------------------------------


def _flatten_sensitivities(sensitivities) -> list[Curve]:
    items = (
        [sensitivities]
        if isinstance(
            sensitivities,
            str | os.PathLike | colour.MultiSpectralDistributions | colour.SpectralDistribution | tuple,
        )
        else list(sensitivities)
    )
    if not items:
        raise SpectralDataError("no sensitivities given; pass a camera, an observer or a list.")
    out = []
    for item in items:
        if isinstance(item, os.PathLike) or (isinstance(item, str) and Path(item).is_file()):
            # a camera file, as every entry point accepts (zonotope.load_camera's rule)
            path = Path(item)
            if not path.is_file():
                raise SpectralDataError(
                    f"camera file {path} not found; give an existing file or a built-in name."
                )
            try:
                out.append(read_camera(path))
            except (OSError, KeyError, TypeError, ValueError, UnicodeDecodeError) as exc:
                if isinstance(exc, SpectralDataError):
                    raise
                raise SpectralDataError(f"cannot read camera file {path}: {exc}") from exc
        elif isinstance(item, str):
            try:
                out.append(camera(item))
            except SpectralDataError:
                out.append(observer(item))
        else:
            out.append(_as_curve(item, "sensitivities"))
    return out


def spectral_matrix(
    curves, shape: colour.SpectralShape | np.ndarray | None = None, *, allow_negative: bool = False
):
    """Stack curves (cameras, observers, ...) channel-wise on one grid.

    Returns
    -------
    wavelengths : ndarray of shape (n,)
    values : ndarray of shape (n, k)
        ``k`` = total number of channels.
    labels : list of str
    """
    curves = _flatten_sensitivities(curves)
    shape = shape if shape is not None else common_shape(*curves)
    grid = _grid(shape)
    blocks, labels = [], []
    many = len(curves) > 1
    for c in curves:
        blocks.append(resample(c, grid, allow_negative=allow_negative))
        names = getattr(c, "labels", None) or [c.name]
        labels += [f"{c.name}: {lab}" if many else str(lab) for lab in names]
    return grid, np.concatenate(blocks, axis=1), labels


def generators(
    sensitivities,
    illuminant: CurveLike | None = "D65",
    shape: colour.SpectralShape | np.ndarray | None = None,
    *,
    normalise: str | int | None = "channel",
    allow_negative: bool = False,
) -> colour.MultiSpectralDistributions:
    """Generator matrix G = S(λ)·E(λ)·Δλ of one or more cameras/observers under an illuminant.

    Parameters
    ----------
    sensitivities
        A camera or observer (colour MSDS, built-in name, path to a camera file as
        :func:`zonotope.load_camera` reads it, ``(wavelengths, values)``), or a list of them: their
        channels are stacked (two cameras give 6 channels).
    illuminant
        Illuminant (SD or name, default ``"D65"``); ``None`` for an equal-energy illuminant.
    shape
        Wavelength grid; default :func:`common_shape` of all the curves.
    normalise
        ``"channel"`` (default): each channel scaled so the perfect white reflector gives 1.
        An integer ``i``: one common factor so that channel ``i`` of the white gives 1 (e.g.
        ``1`` for XYZ with Y_white = 1, keeping the white point's chromaticity).
        ``None``: raw S·E·Δλ.
    allow_negative
        Accept negative sensitivities (e.g. RGB colour-matching functions).

    Returns
    -------
    colour.MultiSpectralDistributions of shape (n_wavelengths, k)
        The generators as columns; ``values[i]`` is the response to a unit reflectance at
        wavelength i alone, so a reflectance ``x`` (n,) gives the response ``x @ values``.

    Raises
    ------
    SpectralDataError
        Bad curves (see module docs), disjoint ranges, or a channel that is zero on the grid.
    """
    curves = _flatten_sensitivities(sensitivities)
    light = None if illuminant is None else _as_curve(illuminant, "illuminant", _illuminant)
    if shape is None:
        shape = common_shape(*curves, *([light] if light is not None else []))
    grid, S, labels = spectral_matrix(curves, shape, allow_negative=allow_negative)
    E = np.ones(grid.size) if light is None else resample(light, grid)[:, 0]
    dl = np.gradient(grid)
    G = S * (E * dl)[:, None]
    white = G.sum(axis=0)
    dead = np.nonzero(np.abs(G).sum(axis=0) == 0)[0]
    if dead.size:
        raise SpectralDataError(
            f"channel(s) {[labels[i] for i in dead]} are zero on {grid[0]:g}–{grid[-1]:g} nm "
            "under this illuminant; such a channel measures nothing. Drop it or widen the grid."
        )
    if normalise == "channel":
        if np.any(white <= 0):
            raise SpectralDataError(
                "per-channel normalisation needs a positive white response in every channel; "
                f"got {white}. Use normalise=None for signed sensitivities."
            )
        G = G / white
    elif isinstance(normalise, int | np.integer) and not isinstance(normalise, bool):
        if not 0 <= normalise < G.shape[1]:
            raise SpectralDataError(f"normalise={normalise} is not a channel index (k={G.shape[1]}).")
        G = G / white[normalise]
    elif normalise is not None:
        raise SpectralDataError(f"normalise={normalise!r}: use 'channel', a channel index or None.")
    return colour.MultiSpectralDistributions(G, grid, labels=labels, name="generators")
