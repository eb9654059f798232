"""One rule for "a built-in name or a file?": :func:`load_camera` and :func:`load_reflectances`.

Every entry point that accepts a camera or a reflectance set (``zonotope.correct``, the CLIs,
``isp.metamer_correction``, ``isp.simulate``, ``splat`` captures) resolves it here:

1. a colour ``MultiSpectralDistributions`` is returned as it is;
2. an existing file is read (the readers ``read_camera`` / ``read_reflectances`` of
   ``zonotope.spectra.builtin``); wavelengths must be in nanometres (a file in µm, 0.38–0.78, is
   refused with the factor to apply rather than guessed);
3. a string that looks like a path (a spectral-file suffix or a path separator) but names no file
   raises :class:`SpectralFileNotFoundError`;
4. anything else is looked up among the built-in curves (:func:`zonotope.camera` /
   :func:`zonotope.reflectances`), whose errors list the valid names.
"""

from __future__ import annotations

import os
from collections.abc import Callable
from pathlib import Path

import colour

from .._errors import SpectralDataError
from . import builtin as spectra

__all__ = ["SPECTRAL_SUFFIXES", "SpectralFileNotFoundError", "load_camera", "load_reflectances"]

#: File suffixes (lower case) that mark a string as a path to a spectral file.
SPECTRAL_SUFFIXES = (".json", ".csv", ".txt", ".reflect", ".spd")


class SpectralFileNotFoundError(SpectralDataError, FileNotFoundError):
    """A camera or reflectance argument that names a file which does not exist."""


def _load(source, builtin: Callable, read: Callable, what: str):
    if isinstance(source, colour.MultiSpectralDistributions):
        return source
    if not isinstance(source, str | os.PathLike):
        raise SpectralDataError(
            f"{what}: expected a built-in name, a file path or a colour MultiSpectralDistributions; "
            f"got {type(source).__name__}."
        )
    path = Path(source)
    if path.is_file():
        try:
            curves = read(path)
        except (OSError, KeyError, TypeError, ValueError, UnicodeDecodeError) as exc:
            raise SpectralDataError(f"cannot read {what} file {path}: {exc}") from exc
        _check_nanometres(curves, path, what)
        return curves
    if path.suffix.lower() in SPECTRAL_SUFFIXES or os.sep in str(source) or isinstance(source, os.PathLike):
        raise SpectralFileNotFoundError(
            f"{what} file {path} not found; give an existing file or a "
            f"built-in name (zonotope.list_builtin())."
        )
    return builtin(str(source))


def _check_nanometres(curves, path: Path, what: str) -> None:
    """Refuse a file whose wavelengths are not in nanometres (e.g. µm: 0.38–0.78), naming the file."""
    import numpy as np

    from .._tol import WAVELENGTH_NM_MIN

    w = np.asarray(curves.wavelengths, dtype=np.float64)
    if w.size and float(np.max(w)) < WAVELENGTH_NM_MIN:
        raise SpectralDataError(
            f"{what} file {path}: wavelengths {float(w.min()):g}–{float(w.max()):g} are not in nanometres, "
            "which zonotope reads (a table in µm, such as 0.38–0.78: multiply the wavelength column by 1000)."
        )


def load_camera(source) -> colour.MultiSpectralDistributions:
    """A camera's spectral sensitivities from a built-in name, a file or a colour MSDS.

    Parameters
    ----------
    source : str, os.PathLike or colour.MultiSpectralDistributions
        Built-in name (``"Nikon 5100 (NPL)"``, case and punctuation ignored), path to a
        rawtoaces / dcamprof JSON or CSV file, or curves already loaded.

    Returns
    -------
    colour.MultiSpectralDistributions
        One column per channel.

    Raises
    ------
    SpectralFileNotFoundError
        A path-like string that names no file.
    SpectralDataError
        A file that cannot be read or whose wavelengths are not in nm (e.g. µm), or an unknown
        built-in name (the message lists the valid ones).

    Examples
    --------
    >>> import zonotope
    >>> zonotope.load_camera("nikon 5100 (npl)").values.shape[1]
    3
    """
    return _load(source, spectra.camera, spectra.read_camera, "camera")


def load_reflectances(source) -> colour.MultiSpectralDistributions:
    """A reflectance set from a built-in name, a file or a colour MSDS.

    Parameters
    ----------
    source : str, os.PathLike or colour.MultiSpectralDistributions
        Built-in name (``"rawtoaces 190"``, ``"ColorChecker N Ohta"``, ...), path to a CSV/TXT
        table, a rawtoaces JSON or an SFU ``.reflect`` file, or curves already loaded.

    Returns
    -------
    colour.MultiSpectralDistributions
        One column per reflectance.

    Raises
    ------
    SpectralFileNotFoundError
        A path-like string that names no file.
    SpectralDataError
        A file that cannot be read or whose wavelengths are not in nm (e.g. µm), or an unknown
        built-in name.

    Examples
    --------
    >>> import zonotope
    >>> zonotope.load_reflectances("ColorChecker N Ohta").values.shape[1]
    24
    """
    return _load(source, spectra.reflectances, spectra.read_reflectances, "reflectances")
