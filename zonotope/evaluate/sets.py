"""Test sets of the evaluation: natural (built-ins and ../shared/data), atypical (two generators), and
the split that keeps them away from the training set."""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from .._errors import SpectralDataError
from ..spectra import builtin as spectra
from ..spectra.atypical import atypical_reflectances, structured_reflectances

__all__ = [
    "ATYPICAL_SEED",
    "TestSet",
    "atypical_test_set",
    "atypical_test_sets",
    "natural_test_sets",
    "source_split",
]

#: Seed of the atypical test set of ``zonotope evaluate``, ``zonotope report`` and :func:`evaluate`
#: (the one of the README's table): one label, "atypical (n)", always means the same spectra.
ATYPICAL_SEED = 0


@dataclass(frozen=True, eq=False)
class TestSet:
    """Reflectances to evaluate on.

    Attributes
    ----------
    name : str
    reflectances : ndarray of shape (N, n)
        On the evaluation grid, in [0, 1].
    kind : str
        ``"natural"`` or ``"atypical"``.
    """

    name: str
    reflectances: np.ndarray
    kind: str = "natural"
    __test__ = False  # not a pytest class, despite the name


def _check_grid(wavelengths, what: str = "wavelengths") -> np.ndarray:
    """The grid as a float array, or a one-line error when it has more than ``GRID_POINTS_MAX`` points
    (every test set, solid and kernel matrix grows with it: 0.001 nm over 400–700 nm would need
    hundreds of GiB), before anything is built."""
    w = np.asarray(wavelengths, dtype=np.float64)
    if w.size > spectra.GRID_POINTS_MAX:
        finest = (w[-1] - w[0]) / (spectra.GRID_POINTS_MAX - 1)
        raise SpectralDataError(
            f"{what}: {w.size} wavelengths over {w[0]:g}–{w[-1]:g} nm (> GRID_POINTS_MAX = "
            f"{spectra.GRID_POINTS_MAX}); use an interval of at least {finest:.2g} nm."
        )
    return w


def _evaluation_shape(cameras, *, start=None, end=None, interval: float = 10.0):
    """The evaluation grid: 400–700 nm by default, narrowed to the range every camera is measured on.

    Raises
    ------
    SpectralDataError
        The cameras' common range and 400–700 nm do not overlap (e.g. wavelengths given in µm; the
        message names the range found), or the grid would exceed ``GRID_POINTS_MAX`` points (it names
        the finest interval allowed), before the grid is built.
    """
    import colour

    from ..spectra.loading import load_camera

    cams = [cameras] if isinstance(cameras, str) else list(cameras)
    lo = hi = None
    if start is None or end is None:
        common = spectra.common_shape(*(load_camera(c) for c in cams))
        lo, hi = float(common.start), float(common.end)
        start = max(400.0, lo) if start is None else start
        end = min(700.0, hi) if end is None else end
    if not (np.isfinite(start) and np.isfinite(end) and end > start):
        found = f"; the cameras' common range is {lo:g}–{hi:g}" if lo is not None else ""
        unit = " (wavelengths in µm? give them in nm)" if hi is not None and hi < 100 else ""
        raise SpectralDataError(
            f"--camera {', '.join(map(str, cams))}: no grid from {start:g} to {end:g} nm{found}{unit}; "
            "give cameras measured over the visible range in nm, or --start/--end inside it."
        )
    if not (np.isfinite(interval) and interval > 0):
        raise SpectralDataError(f"interval={interval!r}: give a wavelength step > 0 nm.")
    points = (end - start) / interval + 1
    if points > spectra.GRID_POINTS_MAX:
        finest = (end - start) / (spectra.GRID_POINTS_MAX - 1)
        raise SpectralDataError(
            f"interval={interval:g} nm: {points:.3g} wavelengths over {start:g}–{end:g} nm "
            f"(> GRID_POINTS_MAX = {spectra.GRID_POINTS_MAX}); use an interval of at least {finest:.2g} nm."
        )
    return colour.SpectralShape(start, end, interval)


def _subset(R: np.ndarray, n: int | None, seed: int) -> np.ndarray:
    if n is None or n >= R.shape[0]:
        return R
    return R[np.sort(np.random.default_rng(seed).choice(R.shape[0], n, replace=False))]


def atypical_test_set(wavelengths, n: int, *, seed: int = ATYPICAL_SEED, generator: str = "A") -> TestSet:
    """An atypical test set: ``n`` spectra of one of the two independent generators.

    Every caller (evaluate, report, the CLI) builds it here, so one label names one set: "atypical
    (n)" / "atypical B (n)" with the default seed, "atypical (n, seed s)" otherwise.

    Parameters
    ----------
    wavelengths : array_like
        The grid (nm).
    n
        Number of spectra.
    seed
        Generator seed.
    generator
        ``"A"``: :func:`zonotope.spectra.atypical.atypical_reflectances` (band-pass/stop, narrow-band,
        spiky); ``"B"``: :func:`zonotope.spectra.atypical.structured_reflectances` (steps, thin-film
        fringes, rough).

    Returns
    -------
    TestSet
    """
    w = _check_grid(wavelengths)
    if generator == "A":
        X, _ = atypical_reflectances(w, n, seed=seed)
        name = "atypical"
    elif generator == "B":
        X, _ = structured_reflectances(w, n, seed=1_000_003 + seed)
        name = "atypical B"
    else:
        raise SpectralDataError(f"generator={generator!r}: choose 'A' or 'B'.")
    label = f"{name} ({n})" if seed == ATYPICAL_SEED else f"{name} ({n}, seed {seed})"
    return TestSet(label, X, "atypical")


def atypical_test_sets(wavelengths, n: int, *, seed: int = ATYPICAL_SEED) -> list[TestSet]:
    """Both atypical test sets (generators A and B, :func:`atypical_test_set`), ``n`` spectra each."""
    return [atypical_test_set(wavelengths, n, seed=seed, generator=g) for g in ("A", "B")]


def source_split(
    test_sets: Sequence[TestSet], training, *, exclude_within: float = 0.02
) -> tuple[list[TestSet], list[str]]:
    """Remove from each test set the spectra that (nearly) occur in the training set.

    A test spectrum is removed when some training spectrum is within ``exclude_within`` of it at
    every wavelength (L∞ distance ≤ ``exclude_within``): the same physical sample measured twice, or
    a near-duplicate, would otherwise reward an estimator for memorising its training set.

    Parameters
    ----------
    test_sets : sequence of TestSet
    training : ndarray of shape (N, n)
        Training reflectances on the same grid.
    exclude_within
        Tolerance (reflectance units); ``None`` or a negative value disables the split.

    Returns
    -------
    sets : list of TestSet
        The filtered sets (a set left empty is dropped).
    notes : list of str
        One line per set that lost spectra.
    """
    if exclude_within is None or exclude_within < 0:
        return list(test_sets), []
    T = np.asarray(training, dtype=np.float64)
    out, notes = [], []
    for ts in test_sets:
        X = ts.reflectances
        near = np.zeros(X.shape[0], dtype=bool)
        for start in range(0, X.shape[0], 256):
            block = X[start : start + 256]
            near[start : start + 256] = (
                np.abs(block[:, None, :] - T[None]).max(axis=-1).min(axis=1) <= exclude_within
            )
        if near.any():
            notes.append(
                f"{ts.name}: {int(near.sum())} of {X.shape[0]} spectra removed (within "
                f"{exclude_within:g} of a training spectrum at every wavelength)."
            )
        if (~near).any():
            out.append(TestSet(ts.name, X[~near], ts.kind) if near.any() else ts)
    return out, notes


def natural_test_sets(
    wavelengths, *, data_dir: str | Path | None = None, size: int | None = 150, seed: int = 0
) -> list[TestSet]:
    """Natural reflectance sets on a grid: built-ins, plus real data from ``data_dir`` if given.

    Parameters
    ----------
    wavelengths : array_like of shape (n,)
    data_dir
        A folder laid out like ``../shared/data``; missing sub-folders are skipped.
    size
        Large sets (Munsell, SFU subsets, CIE 224) are subsampled to this many spectra (seeded).
    seed
        Subsampling seed.

    Returns
    -------
    list of TestSet
    """
    w = _check_grid(wavelengths)
    out = []
    for name in ("ColorChecker N Ohta", "CIE 1995 TCS", "NIST CQS 9.0"):
        out.append(TestSet(name, np.clip(spectra.resample(spectra.reflectances(name), w).T, 0, 1)))
    if data_dir is None:
        return out
    root = Path(data_dir)
    munsell = root / "reflectance_munsell_matte_joensuu_5nm" / "munsell_matte_1269_380_780_5nm.csv"
    if munsell.is_file():
        R = spectra.resample(spectra.read_reflectances(munsell), w).T
        out.append(
            TestSet(
                f"Munsell matte ({min(size or R.shape[0], R.shape[0])})",
                np.clip(_subset(R, size, seed), 0, 1),
            )
        )
    sfu = root / "reflectance_sfu1995" / "reflect_db.reflect"
    if sfu.is_file():
        R = spectra.resample(spectra.read_sfu1995(sfu), w).T
        for name, first, count in (("SFU Krinov", 201, 355), ("SFU Vrhel", 1825, 170)):
            block = R[first : first + count]
            out.append(
                TestSet(f"{name} ({min(size or count, count)})", np.clip(_subset(block, size, seed), 0, 1))
            )
    ces = root / "reflectance_cie_test_colour_samples" / "CIE_224_2017_CES99_5nm.csv"
    if ces.is_file():
        R = spectra.resample(spectra.read_reflectances(ces), w).T
        out.append(TestSet("CIE 224 CES", np.clip(_subset(R, size, seed), 0, 1)))
    return out
