"""Source and target generators on one wavelength grid: the object every analysis starts from.

A camera (or several, stacked) sees a reflectance ``x`` (n wavelengths) as ``x @ Phi`` (k
channels); the eye (or any target) as ``x @ Psi`` (m channels). :class:`GeneratorPair` holds the
two matrices on one grid with their names. :class:`zonotope.correct.CorrectionProblem` extends it
with training reflectances, :class:`zonotope.mismatch.MetamerMismatch` computes metamer mismatch
volumes of one, and :mod:`isp.simulate` and :mod:`splat` build theirs with :func:`generator_pair`.
"""

from __future__ import annotations

import os
from dataclasses import dataclass

import numpy as np

from .._errors import SpectralDataError
from . import builtin as spectra
from .loading import load_camera

__all__ = ["GeneratorPair", "generator_pair"]


@dataclass(frozen=True, eq=False, kw_only=True)
class GeneratorPair:
    """Source and target generators on one wavelength grid.

    Attributes
    ----------
    Phi : ndarray of shape (n, k)
        Source generators (camera channels stacked), white → 1 per channel.
    Psi : ndarray of shape (n, m)
        Target generators (an observer: LMS or XYZ).
    wavelengths : ndarray of shape (n,)
        The grid, nm.
    sources : tuple of str
        Names of the source cameras, in stacking order.
    target, illuminant : str
        Names, for reports (``illuminant``: the light the sources see).
    target_illuminant : str
        Name of the light the target sees when it differs from ``illuminant`` (an
        illuminant-induced, or combined observer- and illuminant-induced, mismatch); ``""`` when
        both see ``illuminant``.
    source_channels, target_channels : tuple of str
        Channel labels (k and m of them), empty when unknown.
    """

    Phi: np.ndarray
    Psi: np.ndarray
    wavelengths: np.ndarray
    sources: tuple[str, ...] = ()
    target: str = ""
    illuminant: str = ""
    target_illuminant: str = ""
    source_channels: tuple[str, ...] = ()
    target_channels: tuple[str, ...] = ()

    def __post_init__(self) -> None:
        n = np.shape(self.wavelengths)[0]
        if (
            np.ndim(self.Phi) != 2
            or np.ndim(self.Psi) != 2
            or np.shape(self.Phi)[0] != n
            or np.shape(self.Psi)[0] != n
        ):
            raise SpectralDataError(
                f"Phi {np.shape(self.Phi)} and Psi {np.shape(self.Psi)} must both have one row per "
                f"wavelength ({n})."
            )

    @property
    def k(self) -> int:
        """Number of source channels."""
        return self.Phi.shape[1]

    @property
    def m(self) -> int:
        """Number of target channels."""
        return self.Psi.shape[1]

    def source_of(self, reflectances) -> np.ndarray:
        """Source responses ``(..., k)`` of reflectances ``(..., n)``."""
        return self._reflectances(reflectances) @ self.Phi

    def target_of(self, reflectances) -> np.ndarray:
        """Target values ``(..., m)`` of reflectances ``(..., n)``."""
        return self._reflectances(reflectances) @ self.Psi

    def _reflectances(self, reflectances) -> np.ndarray:
        R = np.asarray(reflectances, dtype=np.float64)
        if R.shape[-1:] != (self.wavelengths.size,):
            raise SpectralDataError(
                f"reflectances must have shape (..., {self.wavelengths.size}) on this grid; got "
                f"{R.shape}. Resample them with zonotope.resample."
            )
        return R


def _name(obj, default: str) -> str:
    return obj if isinstance(obj, str) else str(getattr(obj, "name", default))


def generator_pair(
    sources,
    target="Stockman & Sharpe 2°",
    illuminant="D65",
    shape=None,
    *,
    target_normalise: str | int | None = "channel",
    target_illuminant=None,
) -> GeneratorPair:
    """Build the source and target generators of cameras and an observer on one grid.

    Parameters
    ----------
    sources : camera or list of cameras
        Built-in names, files (:func:`zonotope.load_camera`), colour MSDS or
        ``(wavelengths, values)`` pairs; a list stacks the channels in the given order.
    target : str or colour.MultiSpectralDistributions
        Observer (default Stockman & Sharpe 2° LMS).
    illuminant : str or colour.SpectralDistribution
        Scene illuminant, default D65.
    shape : colour.SpectralShape or array_like of shape (n,), optional
        Wavelength grid; default the common range of every curve (:func:`zonotope.common_shape`).
    target_normalise : {"channel"} or int or None
        ``normalise=`` of :func:`zonotope.generators` for the target: ``"channel"`` (default)
        scales each channel so the white gives 1; ``1`` scales all channels by one factor so that
        Y of the white is 1 (XYZ targets).
    target_illuminant : str or colour.SpectralDistribution, optional
        The light the target sees, when it is not ``illuminant``: Φ is built under
        ``illuminant`` and Ψ under ``target_illuminant`` (camera under light 1 → eye under
        light 2; Logvinenko et al. 2014's illuminant-induced mismatch when the source is the
        observer itself). ``target_normalise`` then applies to the target's white *under that
        light*. None (default): the target sees ``illuminant``.

    Returns
    -------
    GeneratorPair
        ``Phi`` with every source channel's white = 1.

    Examples
    --------
    >>> import numpy as np
    >>> pair = generator_pair("Nikon 5100 (NPL)", shape=np.arange(400, 701, 10.0))
    >>> pair.k, pair.m, pair.source_of(np.ones(31)).round(12).tolist()
    (3, 3, [1.0, 1.0, 1.0])
    """
    items = list(sources) if isinstance(sources, list) else [sources]
    if not items:
        raise SpectralDataError("sources: give at least one camera (built-in name, file or MSDS).")
    curves = [load_camera(c) if isinstance(c, str | os.PathLike) else c for c in items]
    if shape is None:
        grid = spectra.generators([*curves, target], illuminant).wavelengths
        if target_illuminant is not None:  # measured under both lights: the common points
            grid = np.intersect1d(grid, spectra.generators([*curves, target], target_illuminant).wavelengths)
    else:
        grid = getattr(shape, "wavelengths", shape)
    grid = np.asarray(grid, dtype=np.float64)
    G = spectra.generators(curves, illuminant, grid)
    lit = illuminant if target_illuminant is None else target_illuminant
    T = spectra.generators(target, lit, grid, normalise=target_normalise)
    return GeneratorPair(
        Phi=np.array(G.values, dtype=np.float64),
        Psi=np.array(T.values, dtype=np.float64),
        wavelengths=np.array(G.wavelengths, dtype=np.float64),
        sources=tuple(_name(c, "camera") for c in curves),
        target=_name(target, "target"),
        illuminant=_name(illuminant, "illuminant"),
        target_illuminant="" if target_illuminant is None else _name(target_illuminant, "illuminant"),
        source_channels=tuple(G.labels),
        target_channels=tuple(T.labels),
    )
