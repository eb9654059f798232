"""Illuminant-induced metamer mismatch: the colours a surface seen as ``c`` under one light can have
under another.

For an observer (or cameras) seeing reflectances under light E₁ through Φ = S·E₁·Δλ and the eye
seeing them under light E₂ through Ψ = T·E₂·Δλ, the metamer mismatch volume of a response ``c``

    MMV(c) = {Ψᵀx : Φᵀx = c, 0 ≤ x ≤ 1}

is the illuminant-induced MMV of Logvinenko, Funt & Godau (2014) when S = T (one observer, two
lights), the observer-induced MMV when E₁ = E₂ (the default everywhere else in
:mod:`zonotope.mismatch`), and both combined for a camera under E₁ and the eye under E₂ — the
question a photographer asks who wants the colours of a tungsten-lit scene as under daylight. The
support LP and its dual do not care where Φ and Ψ come from, so the exact vertex walk, facet
refinement and the HiGHS twin compute all three alike; this module only builds the generators.

Why its own module: which light each side sees is a property of the generators, not of the
algorithm; the algorithms stay in :mod:`zonotope.mismatch.volume`.

References
----------
.. [1] Logvinenko, A. D., Funt, B., & Godau, C. (2014). Metamer mismatching. IEEE Trans. Image
   Process. 23(1), 34–43.
.. [2] Logvinenko, A. D., Funt, B., Mirzaei, H., & Tokunaga, R. (2015). Rethinking colour
   constancy. PLoS ONE 10(9), e0135029.
"""

from __future__ import annotations

import numpy as np

from .._errors import GeometryError
from ..spectra import builtin as spectra
from ..spectra.pair import GeneratorPair, generator_pair
from .volume import MetamerMismatch

__all__ = ["illuminant_mismatch", "illuminant_pair", "relative_volume"]


def _name(obj, default: str) -> str:
    return obj if isinstance(obj, str) else str(getattr(obj, "name", default))


def illuminant_pair(
    illuminant="D65",
    target_illuminant="A",
    *,
    observer="CIE 1931 2°",
    sources=None,
    shape=None,
    normalise: str | int | None = 1,
) -> GeneratorPair:
    """Generators of a source under one light and an observer under another, on one grid.

    Parameters
    ----------
    illuminant : str or colour.SpectralDistribution
        Light 1, the one the sources see (default D65).
    target_illuminant : str or colour.SpectralDistribution
        Light 2, the one the observer sees (default A).
    observer : str or colour.MultiSpectralDistributions
        The target observer (default CIE 1931 2° XYZ).
    sources : camera or list of cameras, optional
        Cameras under light 1 (built-in names, files, MSDS; a list stacks the channels): Φ is then
        per-channel normalised (white → 1), as :func:`zonotope.generator_pair` builds it. None
        (default): the observer itself under light 1, the illuminant-induced mismatch of
        Logvinenko et al. (2014).
    shape : colour.SpectralShape or array_like of shape (n,), optional
        Wavelength grid; default the wavelengths every curve and both lights share.
    normalise : {"channel"} or int or None
        ``normalise=`` of :func:`zonotope.generators` for the observer, under each light
        separately: ``1`` (default) Y of the white = 1 under each light (the white point's
        chromaticity kept; a fixed rescaling, so relative volumes do not depend on it).

    Returns
    -------
    GeneratorPair
        ``Phi`` (n, k) under light 1, ``Psi`` (n, m) under light 2, ``illuminant`` and
        ``target_illuminant`` named.

    Examples
    --------
    >>> import numpy as np
    >>> pair = illuminant_pair("D65", "A", shape=np.arange(400, 701, 10.0))
    >>> grey = np.full(31, 0.5)
    >>> pair.source_of(grey).round(3).tolist(), pair.target_of(grey).round(3).tolist()
    ([0.475, 0.5, 0.544], [0.548, 0.5, 0.178])
    """
    if sources is not None:
        return generator_pair(
            list(sources) if isinstance(sources, list | tuple) else sources,
            observer,
            illuminant,
            shape,
            target_normalise=normalise,
            target_illuminant=target_illuminant,
        )
    if shape is None:
        g1 = spectra.generators(observer, illuminant, normalise=normalise).wavelengths
        g2 = spectra.generators(observer, target_illuminant, normalise=normalise).wavelengths
        shape = np.intersect1d(g1, g2)
    grid = np.asarray(getattr(shape, "wavelengths", shape), dtype=np.float64)
    S = spectra.generators(observer, illuminant, grid, normalise=normalise)
    T = spectra.generators(observer, target_illuminant, grid, normalise=normalise)
    name = _name(observer, "observer")
    return GeneratorPair(
        Phi=np.array(S.values, dtype=np.float64),
        Psi=np.array(T.values, dtype=np.float64),
        wavelengths=np.array(S.wavelengths, dtype=np.float64),
        sources=(name,),
        target=name,
        illuminant=_name(illuminant, "illuminant"),
        target_illuminant=_name(target_illuminant, "illuminant"),
        source_channels=tuple(S.labels),
        target_channels=tuple(T.labels),
    )


def illuminant_mismatch(
    illuminant="D65",
    target_illuminant="A",
    *,
    observer="CIE 1931 2°",
    sources=None,
    shape=None,
    normalise: str | int | None = 1,
    oracle: str = "walk",
) -> MetamerMismatch:
    """Metamer mismatch volumes for a change of light (and, with ``sources``, of observer).

    ``mm = illuminant_mismatch("D65", "A")``; ``mm(c)`` is the exact polytope of every XYZ under A
    of a reflectance whose XYZ under D65 is ``c``. Parameters as :func:`illuminant_pair`;
    ``oracle`` as :class:`~zonotope.mismatch.MetamerMismatch`.

    Returns
    -------
    MetamerMismatch
        On the generators of :func:`illuminant_pair`: ``mm(c)``, ``mm.bounds``, ``mm.batch``
        work unchanged.

    Examples
    --------
    >>> import numpy as np
    >>> mm = illuminant_mismatch("D65", "A", shape=np.arange(400, 701, 10.0))
    >>> grey = np.full(31, 0.5)
    >>> mmv = mm(mm.source_of(grey))
    >>> bool(mmv.contains(mm.target_of(grey))), round(relative_volume(mmv, mm), 5)
    (True, 0.0013)
    """
    pair = illuminant_pair(
        illuminant, target_illuminant, observer=observer, sources=sources, shape=shape, normalise=normalise
    )
    return MetamerMismatch(pair, oracle=oracle)


def relative_volume(mmv, mm: MetamerMismatch) -> float | np.ndarray:
    """MMV volume as a fraction of the target's object-colour solid (the scale-free size).

    Parameters
    ----------
    mmv : Polytope, CertifiedMMV, MMVBatch or float or array_like
        An MMV (its ``volume``, or the midpoint of ``volume_bounds``), a batch (its ``volumes``), or
        volumes.
    mm : MetamerMismatch
        Whose target solid (:attr:`~zonotope.mismatch.MetamerMismatch.target_solid`) is the unit.

    Returns
    -------
    float or ndarray
        Volume / target solid volume: independent of how the target's channels are scaled, so
        comparable across normalisations and with published figures given that way.

    Raises
    ------
    GeometryError
        A target with other than 3 channels (volumes are 3-D here).
    """
    if mm.m != 3:
        raise GeometryError(f"relative_volume: the target has {mm.m} channels; volumes here are 3-D.")
    if hasattr(mmv, "volumes"):
        vol = np.asarray(mmv.volumes, dtype=np.float64)
    elif hasattr(mmv, "volume_bounds") and not hasattr(mmv, "volume"):
        vol = float(np.mean(mmv.volume_bounds))
    elif hasattr(mmv, "volume"):
        vol = float(mmv.volume)
    else:
        vol = np.asarray(mmv, dtype=np.float64)
    out = vol / float(mm.target_solid.volume)
    return float(out) if np.ndim(out) == 0 else out
