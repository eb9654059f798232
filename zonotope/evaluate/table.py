"""The evaluation's result: rows of ΔE00 statistics, pooled statistics, paired comparisons, tables."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from .._errors import SpectralDataError

__all__ = ["Evaluation", "EvaluationRow", "PairedComparison"]


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
