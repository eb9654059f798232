"""Evaluation harness: CIEDE2000 of every estimator on natural and atypical reflectance sets.

For a camera set (1–3 cameras, channels stacked), an illuminant and a training set, every estimator
of :data:`zonotope.correct.CORRECTION_METHODS` is fitted once and applied to the responses of each
test set; the table reports ΔE00 mean / median / 95th percentile / max against the true target
colours, the fraction of regression estimates that lie inside the metamer mismatch volume (MMV),
the share of every estimator's answers that lie outside the MMV of its input (physically impossible
colours: no reflectance gives both, by the exact test
:func:`zonotope.mismatch.membership.outside_mmv_fraction`;
noise-free level only) and MMV volume statistics (XYZ units, Y_white = 1).

Noise levels
------------
Every row belongs to one noise level: noise-free, a constant σ, or a shot + read
:class:`~zonotope.correct.NoiseModel` (default :data:`DEFAULT_NOISE`: noise-free and two shot-limited
levels, low and high ISO). At each level every estimator is fitted for that noise through
:func:`zonotope.correct.noise_options` (so the regressions "Cheung 2004" and "Finlayson 2015" are the
noise-aware baselines) and applied to noisy held-out responses. The noise draws are seeded per camera
set and test set and shared by every method and every level (the same standard normal draws, scaled by
each level's σ per response): comparisons between methods and between levels are paired.

Test sets
---------
Built in (always available): ColorChecker N Ohta, CIE 1995 TCS, NIST CQS 9.0, and the seeded
atypical generator :func:`zonotope.spectra.atypical.atypical_reflectances`. With a data folder laid out
like ``../shared/data`` (see its README) also: a seeded subset of the 1269 matte Munsell chips,
the SFU 1995 Krinov natural surfaces and Vrhel objects (subsets), and the CIE 224:2017 colour
evaluation samples. Test reflectances are clipped to [0, 1] (a few measured values exceed 1 by
fluorescence or gloss; they would be outside the object-colour solid). A second, independently written
atypical generator (:func:`zonotope.spectra.atypical.structured_reflectances`: multi-transition steps,
thin-film fringes, rough spectra) is the set "atypical B", so that an estimator tuned on one atypical
family can be checked on another.

Evaluation that cannot be tuned to
----------------------------------
Training and test reflectances are split by source: every test spectrum within ``exclude_within``
(default 0.02) of a training spectrum at every wavelength (L∞ distance) is removed from the test set
before anything is computed (the rawtoaces 190 training set holds ColorChecker, Munsell and Vrhel-like
samples; the notes say how many were removed per set). Besides the per-set rows, :class:`Evaluation`
keeps every sample's ΔE00, so it reports pooled mean / 95th percentile / max over all sets of one kind
(:meth:`Evaluation.pooled_stats`) and paired comparisons on the same samples
(:meth:`Evaluation.paired`: how often A beats B, and by how much).
"""

from __future__ import annotations

import inspect
import time
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ._errors import OptionError, SpectralDataError, ZonotopeError
from .correct.methods import (
    CORRECTION_METHODS,
    DELTA_SIGMAS,
    CorrectionProblem,
    NoiseModel,
    correction_problem,
    fit_correction,
    noise_model,
    noise_options,
)
from .correct.prior import project_to_mmv
from .mismatch.membership import outside_mmv_fraction
from .spectra import builtin as spectra
from .spectra.atypical import atypical_reflectances, structured_reflectances
from .utilities.config import check_count, check_nonnegative, with_options
from .utilities.progress import ProgressCallback

__all__ = [
    "ATYPICAL_SEED",
    "DEFAULT_METHODS",
    "Evaluation",
    "EvaluationConfig",
    "EvaluationRow",
    "PairedComparison",
    "TestSet",
    "atypical_test_set",
    "atypical_test_sets",
    "evaluate",
    "natural_test_sets",
    "source_split",
]

#: Seed of the atypical test set of ``zonotope evaluate``, ``zonotope report`` and :func:`evaluate`
#: (the one of the README's table): one label, "atypical (n)", always means the same spectra.
ATYPICAL_SEED = 0

#: Estimators evaluated by default (every one of CORRECTION_METHODS).
DEFAULT_METHODS: tuple[str, ...] = tuple(CORRECTION_METHODS)

#: Noise levels evaluated by default: noise-free, and shot-limited noise of σ 0.002 and 0.005 at white
#: (low and high ISO of a current sensor, white-balanced; variance σ² · c per channel), the levels of
#: the decision record on the correction defaults, so that its table can be reproduced.
DEFAULT_NOISE: tuple = (
    0.0,
    NoiseModel.shot_limited(0.002, 1, source="shot-limited, σ 0.002 at white"),
    NoiseModel.shot_limited(0.005, 1, source="shot-limited, σ 0.005 at white"),
)


def noise_label(level) -> str:
    """Short name of a noise level in tables: ``"0"``, ``"σ 0.005"`` (constant σ), ``"shot σw 0.005"``
    (shot-limited, σ at white) or ``"SHOT:READ"`` (the ``--noise`` syntax), per channel if they differ."""
    if level is None or (isinstance(level, NoiseModel) and level.is_zero):
        return "0"
    if not isinstance(level, NoiseModel):
        s = np.atleast_1d(np.asarray(level, dtype=np.float64))
        return "0" if not np.any(s > 0) else "σ " + "/".join(f"{x:g}" for x in np.unique(s))
    shot, read = np.unique(level.shot), np.unique(level.read)
    if shot.size == 1 and read.size == 1:
        if read[0] == 0:
            return f"shot σw {np.sqrt(shot[0]):.3g}"
        if shot[0] == 0:
            return f"σ {np.sqrt(read[0]):.3g}"
        return f"{shot[0]:.3g}:{read[0]:.3g}"
    return "/".join(f"{a:.3g}:{b:.3g}" for a, b in zip(level.shot, level.read, strict=True))


def _noise_levels(what: str, noise) -> tuple:
    """``noise`` (one level: a number, a mapping, a NoiseModel; or a sequence of them) as a tuple of
    levels: None (noise-free), a σ or σ per channel, a NoiseModel. ``what`` names it in errors."""
    from .correct.noise import NoiseModelError

    single = noise is None or isinstance(noise, int | float | dict | NoiseModel | np.ndarray)
    levels = [noise] if single else list(noise) if isinstance(noise, Sequence) else None
    if not levels or isinstance(noise, str):
        raise OptionError(
            f"{what}={noise!r}: give a noise level (0, a σ, a NoiseModel or "
            "{'shot': .., 'read': ..}) or a non-empty list of them."
        )
    out = []
    for level in levels:
        try:
            if isinstance(level, NoiseModel):
                k = level.k
            elif isinstance(level, dict):
                k = np.broadcast(
                    np.atleast_1d(level.get("shot", 0)), np.atleast_1d(level.get("read", 0))
                ).size
            else:
                k = max(np.size(level), 1)
            model = noise_model(level, k)
        except (TypeError, ValueError) as error:
            name = f"{what} {level!r}" if what.startswith("--") else f"{what}={level!r}"
            raise NoiseModelError(f"{name}: {str(error).split(': ', 1)[-1]}") from None
        if model is None:
            out.append(None)
        elif isinstance(level, NoiseModel | dict):
            out.append(model)
        else:
            out.append(float(level) if np.ndim(level) == 0 else np.asarray(level, dtype=np.float64))
    labels = [noise_label(level) for level in out]
    if len(set(labels)) != len(labels):
        raise OptionError(f"{what}: the levels {labels} repeat one; give each level once.")
    return tuple(out)


def _seed_of(seed: int, *names: str) -> list[int]:
    """Seed sequence of one (camera set, test set): stable across runs, methods and noise levels."""
    import zlib

    return [seed, *(zlib.crc32(n.encode()) for n in names)]


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
    w = np.asarray(wavelengths, dtype=np.float64)
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
    w = np.asarray(wavelengths, dtype=np.float64)
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


@dataclass(frozen=True)
class EvaluationRow:
    """ΔE00 statistics of one estimator on one test set.

    ``noise``: the noise level's label (:func:`noise_label`);
    ``inside``: fraction of its estimates in the MMV (regressions, tolerant projection test);
    ``outside``: exact share of its estimates outside the MMV of their responses (every estimator,
    noise-free level; :func:`zonotope.mismatch.membership.outside_mmv_fraction`); ``radius`` and
    ``coverage``: for
    estimators with an uncertainty model (:meth:`~zonotope.correct.Corrector.with_uncertainty`),
    the median 95 % credible radius (ΔE00) and the fraction of samples whose true error is within it.
    """

    cameras: str
    test_set: str
    kind: str
    method: str
    n: int
    mean: float
    median: float
    p95: float
    max: float
    inside: float | None = None
    seconds: float = 0.0
    radius: float | None = None
    coverage: float | None = None
    outside: float | None = None
    noise: str = "0"

    def cells(self) -> tuple[str, ...]:
        """The row as the ``zonotope evaluate`` and report tables print it: cameras, test set, noise,
        estimator, n, mean, median, p95, max, in MMV, radius, covered."""
        return (
            self.cameras,
            self.test_set,
            self.noise,
            self.method,
            str(self.n),
            f"{self.mean:.3f}",
            f"{self.median:.3f}",
            f"{self.p95:.3f}",
            f"{self.max:.2f}",
            "" if self.inside is None else f"{100 * self.inside:.0f} %",
            "" if self.radius is None else f"{self.radius:.2f}",
            "" if self.coverage is None else f"{100 * self.coverage:.0f} %",
        )


@dataclass(frozen=True)
class PairedComparison:
    """Method ``a`` against method ``b`` on the same samples (:meth:`Evaluation.paired`).

    Attributes
    ----------
    a, b : str
    n : int
        Samples compared.
    a_better, b_better : float
        Fraction of samples where a's ΔE00 is lower by more than 0.01 (b's, resp.); the rest are ties.
    mean_diff : float
        Mean of ``ΔE00(a) − ΔE00(b)`` (negative: a is better on average).
    p95_diff, max_diff : float
        95th percentile and maximum of that difference (how much worse a can be than b).
    min_diff : float
        Its minimum (how much better a can be).
    """

    a: str
    b: str
    n: int
    a_better: float
    b_better: float
    mean_diff: float
    p95_diff: float
    max_diff: float
    min_diff: float


@dataclass(frozen=True, eq=False)
class Evaluation:
    """Result of :func:`evaluate`.

    Attributes
    ----------
    rows : list of EvaluationRow
    volumes : dict
        ``(cameras, test_set, noise) → (mean, median, max)`` MMV volume (XYZ units, Y_white = 1).
    notes : list of str
        Estimators skipped and why, infeasible responses, settings.
    errors : dict
        ``(cameras, test_set, method, noise) → ndarray`` of per-sample ΔE00 (same sample order, and
        the same noise draws, for every method), for pooled statistics and paired comparisons.
    """

    rows: list[EvaluationRow]
    volumes: dict = field(default_factory=dict)
    notes: list[str] = field(default_factory=list)
    errors: dict = field(default_factory=dict)

    @property
    def noise_levels(self) -> list[str]:
        """Labels of the noise levels evaluated, in order."""
        return list(dict.fromkeys(r.noise for r in self.rows))

    def _pooled_errors(
        self, method: str, kind: str | None, cameras: str | None, noise: str | None
    ) -> np.ndarray:
        kinds = {r.test_set: r.kind for r in self.rows}
        parts = [
            e
            for (c, t, m, z), e in self.errors.items()
            if m == method
            and (cameras is None or c == cameras)
            and (kind is None or kinds.get(t) == kind)
            and (noise is None or z == noise)
        ]
        return np.concatenate(parts) if parts else np.zeros(0)

    def pooled_stats(
        self, kind: str | None = None, cameras: str | None = None, noise: str | None = None
    ) -> dict[str, tuple]:
        """Pooled ``(n, mean, p95, max)`` ΔE00 of each method over every sample of the test sets of
        one kind (``None``: all kinds), camera set and noise level (label; ``None``: all)."""
        out = {}
        for m in dict.fromkeys(r.method for r in self.rows):
            e = self._pooled_errors(m, kind, cameras, noise)
            if e.size:
                out[m] = (int(e.size), float(e.mean()), float(np.percentile(e, 95)), float(e.max()))
        return out

    def paired(
        self,
        a: str,
        b: str,
        *,
        kind: str | None = None,
        cameras: str | None = None,
        noise: str | None = None,
        tie: float = 0.01,
    ) -> PairedComparison:
        """Compare methods ``a`` and ``b`` sample by sample (ties: ``|difference| ≤ tie`` ΔE00).

        Raises
        ------
        SpectralDataError
            When either method has no samples in the selection.
        """
        ea, eb = self._pooled_errors(a, kind, cameras, noise), self._pooled_errors(b, kind, cameras, noise)
        if ea.size == 0 or ea.size != eb.size:
            raise SpectralDataError(
                f"paired: methods {a!r} and {b!r} were not both evaluated on the selected sets "
                f"(kind={kind!r}, cameras={cameras!r}, noise={noise!r}); evaluated: "
                f"{sorted({k[2] for k in self.errors})}."
            )
        d = ea - eb
        return PairedComparison(
            a,
            b,
            int(d.size),
            float(np.mean(d < -tie)),
            float(np.mean(d > tie)),
            float(d.mean()),
            float(np.percentile(d, 95)),
            float(d.max()),
            float(d.min()),
        )

    def summary(self, kind: str, cameras: str | None = None, noise: str | None = None) -> dict[str, float]:
        """Mean of the per-set ΔE00 means of each method over test sets of one kind (and noise level)."""
        out: dict[str, list[float]] = {}
        for r in self.rows:
            if r.kind == kind and (cameras is None or r.cameras == cameras) and noise in (None, r.noise):
                out.setdefault(r.method, []).append(r.mean)
        return {m: float(np.mean(v)) for m, v in out.items()}

    def pooled(self, kind: str, cameras: str, noise: str | None = None) -> dict[str, tuple[float, float]]:
        """Sample-weighted mean and the max ΔE00 of each method over test sets of one kind (and noise
        level)."""
        acc: dict[str, list] = {}
        for r in self.rows:
            if r.kind == kind and r.cameras == cameras and noise in (None, r.noise):
                a = acc.setdefault(r.method, [0.0, 0, 0.0])
                a[0] += r.mean * r.n
                a[1] += r.n
                a[2] = max(a[2], r.max)
        return {m: (a[0] / a[1], a[2]) for m, a in acc.items()}

    def to_markdown(self) -> str:
        """The table as GitHub Markdown (a ``noise`` column unless every row is noise-free)."""
        col = self._noise_column()
        head = (
            f"| cameras | test set |{col('noise')} estimator | n | mean | median | p95 | max | in MMV "
            "| outside MMV (exact) | radius (95 %) | covered |\n"
            f"|---|---|{col('---')}---|---:|---:|---:|---:|---:|---:|---:|---:|---:|\n"
        )
        body = "".join(
            f"| {r.cameras} | {r.test_set} |{col(r.noise)} {r.method} | {r.n} | {r.mean:.3f} | "
            f"{r.median:.3f} | "
            f"{r.p95:.3f} | {r.max:.2f} | {'' if r.inside is None else f'{100 * r.inside:.0f} %'} | "
            f"{'' if r.outside is None else f'{100 * r.outside:.1f} %'} | "
            f"{'' if r.radius is None else f'{r.radius:.2f}'} | "
            f"{'' if r.coverage is None else f'{100 * r.coverage:.0f} %'} |\n"
            for r in self.rows
        )
        vol = ""
        if self.volumes:
            vol = (
                f"\n| cameras | test set |{col('noise')} MMV volume mean | median | max |\n"
                f"|---|---|{col('---')}---:|---:|---:|\n"
                + "".join(
                    f"| {c} | {t} |{col(z)} {v[0]:.3g} | {v[1]:.3g} | {v[2]:.3g} |\n"
                    for (c, t, z), v in self.volumes.items()
                )
            )
        notes = "".join(f"\n- {n}" for n in self.notes)
        return (
            head
            + body
            + self.noise_markdown()
            + self.pooled_markdown()
            + vol
            + (f"\nNotes:{notes}\n" if notes else "")
        )

    def _noise_column(self):
        """``cell(text) → " text |"`` when some row is noisy, else ``""``: noise-free tables keep their
        columns."""
        noisy = any(z != "0" for z in self.noise_levels)
        return (lambda text: f" {text} |") if noisy else (lambda text: "")

    def noise_markdown(self) -> str:
        """ΔE00 mean / p95 / max of every method (columns) per camera set, test set and noise level
        (rows): the table that compares the estimators across noise levels at a glance ("" for one
        level, which the per-row table already shows)."""
        if len(self.noise_levels) < 2:
            return ""
        methods = list(dict.fromkeys(r.method for r in self.rows))
        cell = {(r.cameras, r.test_set, r.noise, r.method): r for r in self.rows}
        keys = dict.fromkeys((r.cameras, r.test_set, r.kind, r.noise) for r in self.rows)
        first = {k[:2]: i for i, k in reversed(list(enumerate(keys)))}  # a set's rows together
        order = sorted(keys, key=lambda k: first[k[:2]])
        lines = [
            "\n| cameras | test set | kind | noise | "
            + " | ".join(methods)
            + " |\n|---|---|---|---|"
            + "---|" * len(methods)
            + "\n"
        ]
        for c, t, kind, z in order:
            vals = []
            for m in methods:
                r = cell.get((c, t, z, m))
                vals.append("" if r is None else f"{r.mean:.3f}/{r.p95:.2f}/{r.max:.1f}")
            lines.append(f"| {c} | {t} | {kind} | {z} | " + " | ".join(vals) + " |\n")
        return "".join(lines) + "\n(mean / p95 / max ΔE00)\n"

    def pooled_markdown(self, reference: str | None = None) -> str:
        """Pooled statistics per camera set and kind, and paired comparisons of ``reference`` (default:
        the default estimator if evaluated, else the first method) against every other method."""
        if not self.errors:
            return ""
        methods = list(dict.fromkeys(r.method for r in self.rows))
        if reference is None:
            reference = "Prior" if "Prior" in methods else methods[0]
        col = self._noise_column()
        lines = [
            f"\n| cameras | kind |{col('noise')} estimator | n | pooled mean | p95 | max |"
            f" {reference} better | worse | mean diff | p95 diff |\n"
            f"|---|---|{col('---')}---|---:|---:|---:|---:|---:|---:|---:|---:|\n"
        ]
        groups = dict.fromkeys((r.cameras, r.kind, r.noise) for r in self.rows)
        first = {g[:2]: i for i, g in reversed(list(enumerate(groups)))}  # a kind's levels together
        for cams, kind, z in sorted(groups, key=lambda g: first[g[:2]]):
            for m, (n, mean, p95, mx) in self.pooled_stats(kind, cams, z).items():
                pc = ""
                if m != reference and reference in methods:
                    try:
                        p = self.paired(reference, m, kind=kind, cameras=cams, noise=z)
                        pc = (
                            f"{100 * p.a_better:.0f} % | {100 * p.b_better:.0f} % | {p.mean_diff:+.3f} | "
                            f"{p.p95_diff:+.2f}"
                        )
                    except SpectralDataError:
                        pc = ""
                lines.append(
                    f"| {cams} | {kind} |{col(z)} {m} | {n} | {mean:.3f} | {p95:.3f} | {mx:.2f} | "
                    + (pc or " | | | ")
                    + " |\n"
                )
        return "".join(lines)


def _stats(dE: np.ndarray) -> tuple[float, float, float, float]:
    return (float(np.mean(dE)), float(np.median(dE)), float(np.percentile(dE, 95)), float(np.max(dE)))


def _mmv_batch(problem: CorrectionProblem, C: np.ndarray, *, eps: float, delta: float, executor=None):
    """Centroids (N, m) and volumes (N,) of the MMVs of responses C (N, k)."""
    from .mismatch.volume import metamer_mismatch_batch

    out = metamer_mismatch_batch(
        problem.Phi, problem.Psi, C, eps=eps, delta=delta, on_infeasible="nearest", executor=executor
    )
    return out.centroids, out.volumes


def _outside_solid(problem: CorrectionProblem, C: np.ndarray, atol: float = 1e-6) -> np.ndarray:
    """Which responses (N, k) no reflectance in [0, 1] can produce: the nearest producible response
    is farther than ``atol`` (an absolute slack in response units, white = 1) in some channel."""
    from .correct.prior import fiber_lsq

    n = problem.Phi.shape[0]
    x = fiber_lsq(problem.Phi, C, np.eye(n), np.full(n, 0.5))
    return np.abs(x @ problem.Phi - C).max(axis=1) > atol


@dataclass(frozen=True, eq=False)
class EvaluationConfig:
    """Options of :func:`evaluate` (checked when made; see :mod:`zonotope.utilities.config`).

    Attributes
    ----------
    methods : tuple of str
        Estimators (keys or aliases of :data:`zonotope.correct.CORRECTION_METHODS`); those that do
        not apply (the ACES IDT with stacked cameras) are skipped with a note.
    illuminant, target, training
        See :func:`zonotope.correct.correction_problem`.
    shape : colour.SpectralShape or array_like of wavelengths, optional
        Wavelength grid; default 400–700 nm / 10 nm.
    test_sets : tuple of TestSet, optional
        Default: :func:`natural_test_sets` (built-ins) and ``atypical`` atypical spectra.
    atypical : int
        Number of atypical spectra added when ``test_sets`` is None (0 for none).
    noise : noise level or sequence of noise levels
        Each level: 0 (noise-free), a σ (constant Gaussian noise, white = 1; one or one per channel),
        a :class:`~zonotope.correct.NoiseModel` or ``{"shot": .., "read": ..}`` (variance
        ``shot · c + read`` per channel). Default :data:`DEFAULT_NOISE`. At each level the estimators
        are fitted for that noise (:func:`~zonotope.correct.noise_options` of the σ as given, or of
        the model; the MMVs with tolerance ``delta = DELTA_SIGMAS · σ`` at white) and applied to
        noisy held-out responses.
    seed : int
        Seed of the atypical spectra and of the noise (the same draws for every method and level).
    centroid_eps : float
        Certification tolerance of the MMVs.
    exclude_within : float or None
        Test spectra within this L∞ distance of a training spectrum are removed
        (:func:`source_split`, per camera set's training data); ``None`` keeps every test spectrum.

    Raises
    ------
    OptionError
        A value out of range (named, with what is allowed).
    UnknownMethodError
        An unknown estimator name (the valid ones are listed).
    """

    methods: tuple[str, ...] = DEFAULT_METHODS
    illuminant: object = "D65"
    target: object = "CIE 2015 2°"
    shape: object = None
    training: object = "rawtoaces 190"
    test_sets: tuple[TestSet, ...] | None = None
    atypical: int = 100
    noise: object = DEFAULT_NOISE
    seed: int = 0
    centroid_eps: float = 1e-3
    exclude_within: float | None = 0.02

    def __post_init__(self):
        name = "EvaluationConfig"
        methods = self.methods
        if isinstance(methods, str) or not isinstance(methods, Sequence) or not methods:
            raise OptionError(f"{name}.methods={methods!r}: give a non-empty list of estimator names.")
        for m in methods:
            CORRECTION_METHODS.resolve(m)
        object.__setattr__(self, "methods", tuple(methods))
        if self.test_sets is not None:
            sets = self.test_sets
            if not isinstance(sets, Sequence) or not all(isinstance(t, TestSet) for t in sets):
                raise OptionError(
                    f"{name}.test_sets: give a list of TestSet objects (or None for the defaults)."
                )
            object.__setattr__(self, "test_sets", tuple(sets))
        _check_shape(name, self.shape)
        check_count(name, "atypical", self.atypical)
        check_count(name, "seed", self.seed)
        object.__setattr__(self, "noise", _noise_levels(f"{name}.noise", self.noise))
        object.__setattr__(self, "centroid_eps", check_nonnegative(name, "centroid_eps", self.centroid_eps))
        object.__setattr__(
            self,
            "exclude_within",
            check_nonnegative(name, "exclude_within", self.exclude_within, allow_none=True),
        )


def _check_shape(owner: str, shape) -> None:
    """A wavelength grid: None, a colour.SpectralShape or an increasing finite 1-D array (≥ 2 nm)."""
    if shape is None or type(shape).__name__ == "SpectralShape":
        return
    try:
        w = np.asarray(shape, dtype=np.float64)
    except (TypeError, ValueError):
        w = None
    if w is None or w.ndim != 1 or w.size < 2 or not np.all(np.isfinite(w)) or np.any(np.diff(w) <= 0):
        raise OptionError(
            f"{owner}.shape={shape!r}: give a colour.SpectralShape or increasing wavelengths (nm), "
            "e.g. numpy.arange(400, 701, 10)."
        )


def evaluate(
    camera_sets: Sequence,
    config: EvaluationConfig | None = None,
    *,
    executor=None,
    progress: ProgressCallback | None = None,
    **options,
) -> Evaluation:
    """ΔE00 of each estimator, for each camera set and test set.

    Parameters
    ----------
    camera_sets
        Sequence of camera sets; each is one camera or a list of 1–3 cameras (names or files).
    config : EvaluationConfig, optional
        The options (estimators, illuminant, target, grid, training and test sets, noise, ...);
        default ``EvaluationConfig()``.
    executor
        Where the MMV batches run (:func:`zonotope.parallel.executor`; also given to the estimators
        that compute MMVs); None: this process. The table is identical either way.
    progress
        Called as ``progress(stage, 0, n)`` before and ``progress(stage, n, n)`` after each step
        (n test responses; :class:`~zonotope.utilities.ProgressCallback`).
    **options
        :class:`EvaluationConfig` fields as keywords, alone or overriding those of ``config``
        (e.g. ``evaluate(sets, noise=0.01, atypical=0)``).

    Returns
    -------
    Evaluation

    Raises
    ------
    OptionError
        An unknown option or a value out of range.
    UnknownMethodError
        An unknown estimator name.
    SpectralDataError
        An empty test set, or an invalid camera set (see :func:`correction_problem`).
    """
    cfg = with_options(EvaluationConfig, config, options, where="evaluate")
    methods, illuminant, target, shape, training = (
        cfg.methods,
        cfg.illuminant,
        cfg.target,
        cfg.shape,
        cfg.training,
    )
    test_sets, atypical, noise, seed = cfg.test_sets, cfg.atypical, cfg.noise, cfg.seed
    centroid_eps, exclude_within = cfg.centroid_eps, cfg.exclude_within
    import colour

    shape = colour.SpectralShape(400, 700, 10) if shape is None else shape
    w = np.asarray(shape.wavelengths if isinstance(shape, colour.SpectralShape) else shape, float)
    if test_sets is None:
        test_sets = natural_test_sets(w)
        if atypical:
            test_sets.extend(atypical_test_sets(w, atypical, seed=seed))
    for ts in test_sets:
        if ts.reflectances.ndim != 2 or ts.reflectances.shape[0] == 0:
            raise SpectralDataError(f"test set {ts.name!r} is empty; give at least one reflectance.")
        if ts.reflectances.shape[1] != w.size:
            raise SpectralDataError(
                f"test set {ts.name!r} has {ts.reflectances.shape[1]} wavelengths; the grid has {w.size}."
            )
    rows: list[EvaluationRow] = []
    volumes: dict = {}
    notes: list[str] = []
    errors: dict = {}
    all_sets = list(test_sets)
    for cams in camera_sets:
        cams = [cams] if isinstance(cams, str) or not isinstance(cams, Sequence) else list(cams)
        problem = correction_problem(
            cams, target=target, illuminant=illuminant, shape=shape, training=training
        )
        label = " + ".join(problem.sources)
        test_sets, split_notes = source_split(all_sets, problem.training, exclude_within=exclude_within)
        notes.extend(n for n in split_notes if n not in notes)
        data = []  # per test set: noise-free responses, targets, the shared standard normal draws
        for ts in test_sets:
            C, T = problem.source_of(ts.reflectances), problem.target_of(ts.reflectances)
            z = np.random.default_rng(_seed_of(seed, label, ts.name)).standard_normal(C.shape)
            data.append((ts, C, T, z))
        fits: dict = {}  # (method, level) → Corrector; a fit that noise does not change is made once
        for level in noise:
            model = noise_model(level, problem.k)  # what the responses get
            told = model if isinstance(level, NoiseModel) else level  # a σ is passed as given
            zlabel = noise_label(level)
            fitted = {}
            for m in dict.fromkeys(CORRECTION_METHODS.resolve(m) for m in methods):
                opts = noise_options(m, told)
                if CORRECTION_METHODS.properties(m)["centroid"]:
                    opts["eps"] = centroid_eps
                key = (m, zlabel if noise_options(m, told) else "0")
                if key not in fits:
                    if (
                        executor is not None
                        and "executor" in inspect.signature(CORRECTION_METHODS[m]).parameters
                    ):
                        opts["executor"] = executor
                    try:
                        fits[key] = fit_correction(problem, method=m, **opts)
                    except ZonotopeError as error:
                        fits[key] = None
                        notes.append(f"{label} · noise {zlabel}: {m} skipped ({error})")
                if fits[key] is not None:
                    fitted[m] = fits[key]
            for ts, C0, T, z in data:
                C = C0 if model is None else C0 + z * model.sigma(C0)
                if model is not None:
                    far = _outside_solid(problem, C)
                    if far.any():
                        notes.append(
                            f"{label} · {ts.name} · noise {zlabel}: {int(far.sum())} of {len(C)} noisy "
                            "responses lie outside the camera's object-colour solid (no reflectance "
                            "produces them); the MMV estimators used the nearest feasible response "
                            f"(delta = {DELTA_SIGMAS:g}σ), the others extrapolate."
                        )
                sigma = 0.0 if model is None else model.effective_sigma(C0)
                where = f"{label} · {ts.name} · noise {zlabel}"
                centroid = next((m for m in fitted if CORRECTION_METHODS.properties(m)["centroid"]), None)
                if centroid is not None:
                    if progress:
                        progress(f"{where}: MMVs", 0, len(C))
                    t0 = time.perf_counter()
                    delta = noise_options(centroid, told).get("delta", 0.0)
                    cents, vols = _mmv_batch(problem, C, eps=centroid_eps, delta=delta, executor=executor)
                    if progress:
                        progress(f"{where}: MMVs", len(C), len(C))
                    volumes[label, ts.name, zlabel] = (
                        float(np.mean(vols)),
                        float(np.median(vols)),
                        float(np.max(vols)),
                    )
                    mmv_time = time.perf_counter() - t0
                for m, est in fitted.items():
                    if progress:
                        progress(f"{where}: {m}", 0, len(C))
                    t0 = time.perf_counter()
                    radius = None
                    if m == centroid:
                        E = cents
                    elif est.predict_with_radius is not None:
                        E, radius = est.with_uncertainty(C)
                    else:
                        E = est(C)
                    if progress:
                        progress(f"{where}: {m}", len(C), len(C))
                    secs = time.perf_counter() - t0 + (mmv_time if m == centroid else 0.0)
                    dE = problem.delta_E(E, T)
                    errors[label, ts.name, m, zlabel] = np.asarray(dE, dtype=np.float64)
                    unc = {}
                    if radius is not None:
                        unc = {"radius": float(np.median(radius)), "coverage": float(np.mean(dE <= radius))}
                    inside = None
                    if CORRECTION_METHODS.properties(m)["closed_form"]:
                        inside = float(np.mean(project_to_mmv(problem, C, E, noise=sigma)[1]))
                    if model is None:  # exact responses: is each answer possible at all?
                        unc["outside"] = outside_mmv_fraction(problem.Phi, problem.Psi, C, E)
                    rows.append(
                        EvaluationRow(
                            label,
                            ts.name,
                            ts.kind,
                            m,
                            len(C),
                            *_stats(dE),
                            inside=inside,
                            seconds=secs,
                            noise=zlabel,
                            **unc,
                        )
                    )
    levels = ", ".join(noise_label(level) for level in noise)
    notes.append(
        f"grid {w[0]:g}–{w[-1]:g} nm / {w[1] - w[0]:g} nm, illuminant {illuminant}, target "
        f"{target} (XYZ, Y_white = 1), training {training}, noise levels {levels} (shot σw: "
        "shot-limited noise of that σ at white; the same seeded draws for every method and level)."
    )
    return Evaluation(rows, volumes, notes, errors)
