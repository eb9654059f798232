"""Vora-value report of a camera set: HTML and Markdown with tables and pictures.

:func:`write_report` computes, for the given cameras (1 or more; channels stacked):

1. the Vora value of each camera and of every combination, and the greedy order;
2. metamer mismatch volumes (MMVs) along the grey axis and for the ColorChecker patches, for each
   camera alone and for the whole stack;
3. the evaluation table of every colour-correction estimator (:func:`zonotope.evaluate.evaluate`);
4. pictures: sensitivities against the target, Vora value vs number of channels, the object-colour
   solid with its spectral locus, MMVs along the grey axis, one MMV with one camera vs all.

Everything is written into a temporary folder next to the output, which is renamed into place
only when complete (:func:`zonotope.utilities.io.atomic_dir`): an interrupted run never replaces (or
half-writes) a good report and leaves no temporary folder behind. An existing folder is replaced only
with ``force=True`` and only if it is a report (it holds the ``.zonotope-output`` marker this function
writes) that holds only what the report wrote (listed in :data:`FILES`); any other folder, or a report
to which a file was added, is never touched. Both are checked before the long computation starts.
"""

from __future__ import annotations

import html
from collections.abc import Sequence
from dataclasses import dataclass
from itertools import combinations
from pathlib import Path

import numpy as np

from ._errors import OptionError, SpectralDataError
from ._tol import LABEL_INK, REPORT_MMV_EPS
from .utilities.config import check_bool, check_count, with_options
from .utilities.io import OutputExistsError, atomic_dir, check_output
from .utilities.progress import ProgressCallback

__all__ = ["ReportConfig", "ReportExistsError", "write_report"]

GREY_LEVELS = (0.05, 0.1, 0.2, 0.4, 0.6, 0.8, 0.9)


#: First line of the marker file inside every report folder (what ``force`` may replace).
SIGNATURE = "zonotope report"

#: File inside every report folder listing the paths the report wrote (one per line, relative):
#: ``force`` replaces a report only when it holds nothing else, so a user's added file is never deleted.
FILES = ".zonotope-report-files"


class ReportExistsError(OutputExistsError):
    """The output folder exists and ``force`` was not given, or it exists and is not a report."""


def _written_by_report(folder: Path) -> set[str]:
    """The paths (relative, POSIX) that the report in ``folder`` wrote: its :data:`FILES` list, or, for
    a report written before that list existed, the marker, the two pages and the pictures the page shows."""
    listed = folder / FILES
    if listed.is_file():
        return {line for line in listed.read_text(encoding="utf-8").splitlines() if line} | {FILES}
    import re

    from .utilities.io import MARKER

    page = folder / "index.html"
    text = page.read_text(encoding="utf-8", errors="replace") if page.is_file() else ""
    return {MARKER, "index.html", "report.md", *re.findall(r"<img src='([^'<>]+)'", text)}


def _check_only_report_files(folder: Path) -> None:
    """Refuse to replace ``folder`` when it holds a path the report did not write (a user's file)."""
    if not folder.is_dir():
        return
    ours = _written_by_report(folder)
    for p in sorted(folder.rglob("*")):
        rel = p.relative_to(folder).as_posix()
        if rel not in ours:
            raise ReportExistsError(
                f"{p}: not written by zonotope report, so --force would delete it; move it out of "
                f"{folder} or choose another output folder."
            )


def _num(x: float) -> str:
    """Volumes for tables: thousands separators above 100, three significant digits below."""
    return f"{x:,.0f}" if abs(x) >= 100 else f"{x:.3g}"


def _table_md(header: Sequence[str], rows: Sequence[Sequence[str]]) -> str:
    out = "| " + " | ".join(header) + " |\n|" + "---|" * len(header) + "\n"
    return out + "".join("| " + " | ".join(r) + " |\n" for r in rows)


def _table_html(header: Sequence[str], rows: Sequence[Sequence[str]]) -> str:
    h = "".join(f"<th>{html.escape(c)}</th>" for c in header)
    body = "".join("<tr>" + "".join(f"<td>{html.escape(c)}</td>" for c in r) + "</tr>" for r in rows)
    return f"<table><thead><tr>{h}</tr></thead><tbody>{body}</tbody></table>"


def _mmv_volumes(problem, responses: np.ndarray) -> np.ndarray:
    from .mismatch.volume import metamer_mismatch_bounds

    vols = []
    for c in responses:
        mmv = metamer_mismatch_bounds(
            problem.Phi, problem.Psi, c, eps=REPORT_MMV_EPS, on_infeasible="nearest"
        )
        vols.append(float(np.mean(mmv.volume_bounds)))
    return np.array(vols)


@dataclass(frozen=True)
class ReportConfig:
    """Options of :func:`write_report` (checked when made; see :mod:`zonotope.utilities.config`).

    Attributes
    ----------
    illuminant : str
        Scene illuminant.
    shape : colour.SpectralShape, optional
        Wavelength grid (default 400–700 nm / 10 nm).
    data_dir : path, optional
        Folder laid out like ``../shared/data`` for the natural test sets.
    atypical : int
        Number of atypical spectra in the evaluation (≥ 0).
    size : int or None
        Subsample size of large natural sets (≥ 1; None: all).
    pictures : bool
        Render the pyvista and matplotlib pictures (needs an OpenGL context, e.g. EGL).
    methods : tuple of str, optional
        Estimators to evaluate (default all of :data:`zonotope.evaluate.DEFAULT_METHODS`).
    volumes : bool
        Compute the MMV volume tables (one MMV per grey level and ColorChecker patch and set).

    Raises
    ------
    OptionError
        A value out of range (named, with what is allowed).
    UnknownMethodError
        An unknown estimator name.
    """

    illuminant: str = "D65"
    shape: object = None
    data_dir: str | Path | None = None
    atypical: int = 100
    size: int | None = 150
    pictures: bool = True
    methods: tuple[str, ...] | None = None
    volumes: bool = True

    def __post_init__(self):
        from .correct.methods import CORRECTION_METHODS

        name = "ReportConfig"
        if self.shape is not None and type(self.shape).__name__ != "SpectralShape":
            raise OptionError(
                f"{name}.shape={self.shape!r}: give a colour.SpectralShape, e.g. "
                "colour.SpectralShape(400, 700, 10)."
            )
        if self.methods is not None:
            m = self.methods
            if isinstance(m, str) or not isinstance(m, Sequence) or not m:
                raise OptionError(f"{name}.methods={m!r}: give a non-empty list of estimator names or None.")
            for x in m:
                CORRECTION_METHODS.resolve(x)
            object.__setattr__(self, "methods", tuple(m))
        if self.data_dir is not None and not isinstance(self.data_dir, str | Path):
            raise OptionError(f"{name}.data_dir={self.data_dir!r}: give a folder path or None.")
        check_count(name, "atypical", self.atypical)
        check_count(name, "size", self.size, minimum=1, allow_none=True)
        check_bool(name, "pictures", self.pictures)
        check_bool(name, "volumes", self.volumes)


def write_report(
    cameras: Sequence,
    output: str | Path,
    config: ReportConfig | None = None,
    *,
    force: bool = False,
    progress: ProgressCallback | None = None,
    **options,
) -> Path:
    """Write ``index.html`` and ``report.md`` (plus PNGs) for a camera set into ``output``.

    Parameters
    ----------
    cameras
        Camera names or files (at least one; duplicates are refused).
    output
        Folder to create.
    config : ReportConfig, optional
        What the report contains (illuminant, grid, test data, estimators, pictures, volume
        tables); default ``ReportConfig()``.
    force
        Replace an existing ``output`` that an earlier report wrote and that holds nothing else (a
        file added to it is never deleted: the call is refused).
    progress
        ``progress(stage, 0, n)`` as each step starts (:class:`~zonotope.utilities.ProgressCallback`; a new
        stage name closes the previous one).
    **options
        :class:`ReportConfig` fields as keywords, alone or overriding those of ``config``
        (e.g. ``write_report(cams, out, pictures=False)``).

    Returns
    -------
    Path
        The output folder.

    Raises
    ------
    OptionError
        An unknown option or a value out of range (before anything is written).
    ReportExistsError
        ``output`` exists and ``force`` is False, or it holds a file the report did not write.
    SpectralDataError
        No camera, duplicated cameras, or curves without a common range.
    """
    cfg = with_options(ReportConfig, config, options, where="write_report")
    illuminant, shape, data_dir, atypical = cfg.illuminant, cfg.shape, cfg.data_dir, cfg.atypical
    size, pictures, methods, volumes = cfg.size, cfg.pictures, cfg.methods, cfg.volumes
    import colour

    from .correct.methods import correction_problem
    from .evaluate import DEFAULT_METHODS, evaluate, natural_test_sets
    from .spectra import builtin as spectra
    from .spectra.loading import load_camera
    from .vora import rank_camera_sets, vora_value

    output = Path(output)
    cameras = list(cameras)
    try:
        check_output(
            output,
            overwrite=force,
            signature=SIGNATURE,
            what="output",
            inputs=[c for c in cameras if isinstance(c, str | Path) and Path(c).is_file()],
        )
    except OutputExistsError as error:
        raise ReportExistsError(str(error)) from None
    if force:
        _check_only_report_files(output)
    if not cameras:
        raise SpectralDataError("write_report needs at least one camera.")
    shape = colour.SpectralShape(400, 700, 10) if shape is None else shape
    w = np.asarray(shape.wavelengths, dtype=np.float64)

    def step(stage: str, n: int) -> None:
        if progress is not None:
            progress(stage, 0, n)

    step("loading cameras", len(cameras))
    curves = [load_camera(c) for c in cameras]
    full = correction_problem(curves, illuminant=illuminant, shape=shape)  # also checks duplicates
    names = list(full.sources)
    singles = [correction_problem([c], illuminant=illuminant, shape=shape) for c in curves]
    sets = [*singles, full] if len(curves) > 1 else [full]

    with atomic_dir(output, signature=SIGNATURE, overwrite=force) as tmp:
        md: list[str] = [
            f"# Camera set report: {' + '.join(names)}\n",
            f"Illuminant {illuminant}, grid {w[0]:g}–{w[-1]:g} nm / {w[1] - w[0]:g} nm, "
            "target CIE 2015 2° XYZ (Y_white = 1); Vora values against Stockman & Sharpe "
            "2° LMS (the same space).\n",
        ]
        parts: list[str] = [
            f"<h1>Camera set report: {html.escape(' + '.join(names))}</h1>",
            f"<p>{html.escape(md[1])}</p>",
        ]
        bands = _estimated_bands(cameras, curves, full, illuminant, w)
        notes, band_k = bands[0]["notes"], bands[1]
        for i in sorted(notes):
            note = (
                f"{names[i]}: curves estimated, not measured ({notes[i]}). Every figure below is "
                "for the estimated curves; the sensitivity plot shades "
                f"±{band_k:.2g} σ of their uncertainty (where held-out measured curves lay at 90 % of "
                "wavelengths)."
            )
            md.append(note + "\n")
            parts.append(f"<p><b>{html.escape(note)}</b></p>")

        def section(title: str, header, rows, note: str = "") -> None:
            md.append(f"\n## {title}\n\n" + (note + "\n\n" if note else "") + _table_md(header, rows))
            parts.append(
                f"<h2>{html.escape(title)}</h2>"
                + (f"<p>{html.escape(note)}</p>" if note else "")
                + _table_html(header, rows)
            )

        # 1. Vora values
        step("Vora values", 1)
        X = spectra.generators("Stockman & Sharpe 2°", illuminant, shape).values
        rows = []
        for r in range(1, len(curves) + 1):
            for idx in combinations(range(len(curves)), r):
                Q = np.concatenate([singles[i].Phi for i in idx], axis=1)
                rows.append((" + ".join(names[i] for i in idx), str(Q.shape[1]), vora_value(Q, X)))
        rows.sort(key=lambda t: -t[2])
        section("Vora values", ("cameras", "channels", "Vora"), [(a, b, f"{v:.4f}") for a, b, v in rows])
        chain = rank_camera_sets(curves, "Stockman & Sharpe 2°", illuminant, shape, method="greedy")
        section(
            "Greedy order",
            ("step", "cameras", "channels", "Vora"),
            [
                (str(i + 1), " + ".join(s.cameras), str(s.channels), f"{s.vora:.4f}")
                for i, s in enumerate(chain)
            ],
        )

        # 2. MMV volumes
        step("MMV volumes along the grey axis", len(sets) * len(GREY_LEVELS))
        grey = (
            {" + ".join(pb.sources): _mmv_volumes(pb, np.outer(GREY_LEVELS, np.ones(pb.k))) for pb in sets}
            if volumes
            else {}
        )
        if volumes:
            section(
                "MMV volume along the grey axis (XYZ units, × 10⁻⁶)",
                ("cameras", *[f"grey {g:g}" for g in GREY_LEVELS]),
                [(k, *[_num(1e6 * x) for x in v]) for k, v in grey.items()],
            )
            step("MMV volumes of the ColorChecker", len(sets) * 24)
            cc = np.clip(spectra.resample(spectra.reflectances("ColorChecker N Ohta"), w).T, 0, 1)
            labels = list(spectra.reflectances("ColorChecker N Ohta").labels)
            vols = {" + ".join(pb.sources): _mmv_volumes(pb, pb.source_of(cc)) for pb in sets}
            section(
                "MMV volume of the ColorChecker patches (XYZ units, × 10⁻⁶)",
                ("patch", *vols),
                [(labels[i], *[_num(1e6 * v[i]) for v in vols.values()]) for i in range(len(labels))],
            )

        # 3. evaluation
        step("evaluation", len(sets))
        tests = natural_test_sets(w, data_dir=data_dir, size=size)
        if atypical:  # the same set, seed and label as 'zonotope evaluate' (was another seed)
            from .evaluate import atypical_test_sets

            tests.extend(atypical_test_sets(w, atypical))  # generators A and B
        camera_sets = [[c] for c in curves] + ([curves] if len(curves) > 1 else [])
        ev = evaluate(
            camera_sets,
            methods=methods or DEFAULT_METHODS,
            illuminant=illuminant,
            shape=shape,
            test_sets=tests,
            noise=0.0,  # the report's tables are noise-free; 'zonotope evaluate' compares noise levels
        )
        md.append("\n## Colour-correction evaluation (CIEDE2000)\n\n" + ev.to_markdown())
        rows = [r.cells() for r in ev.rows]
        parts.append(
            "<h2>Colour-correction evaluation (CIEDE2000)</h2>"
            + _table_html(
                (
                    "cameras",
                    "test set",
                    "noise",
                    "estimator",
                    "n",
                    "mean",
                    "median",
                    "p95",
                    "max",
                    "in MMV",
                    "radius (95 %)",
                    "covered",
                ),
                rows,
            )
            + "<p>radius: median 95 % credible radius (ΔE00) of the estimator's uncertainty model (a "
            "confidence map per pixel: Corrector.with_uncertainty); covered: share of samples whose true "
            "error lies within their radius.</p>"
            + _pooled_html(ev)
            + "".join(f"<p>{html.escape(n)}</p>" for n in ev.notes)
        )

        # 4. pictures
        if pictures:
            pics = _pictures(tmp, curves, full, singles, chain, step, bands)
            md.append("\n## Pictures\n\n" + "".join(f"![{t}]({f})\n\n" for f, t in pics))
            parts.append(
                "<h2>Pictures</h2>"
                + "".join(
                    f"<figure><img src='{html.escape(f)}' alt='{html.escape(t)}'>"
                    f"<figcaption>{html.escape(t)}</figcaption></figure>"
                    for f, t in pics
                )
            )

        (tmp / "report.md").write_text("".join(md), encoding="utf-8")
        style = (
            "body{font-family:sans-serif;max-width:1100px;margin:auto}table{border-collapse:collapse;"
            "margin:1em 0}td,th{border:1px solid #ccc;padding:2px 8px;text-align:right}"
            "img{max-width:100%}"
        )
        (tmp / "index.html").write_text(
            f"<!doctype html><html><head><meta charset='utf-8'><title>zonotope report</title>"
            f"<style>{style}</style></head><body>{''.join(parts)}</body></html>",
            encoding="utf-8",
        )
        from .utilities.io import MARKER

        written = sorted(p.relative_to(tmp).as_posix() for p in tmp.rglob("*"))
        (tmp / FILES).write_text("\n".join([MARKER, *written]) + "\n", encoding="utf-8")
        if force:  # a file added to the old report during the computation is kept too
            _check_only_report_files(output)
    return output


def _pooled_html(ev) -> str:
    """Pooled statistics per camera set and kind, with paired comparisons against the default."""
    methods = list(dict.fromkeys(r.method for r in ev.rows))
    ref = "Prior" if "Prior" in methods else methods[0]
    rows = []
    for cams in dict.fromkeys(r.cameras for r in ev.rows):
        for kind in dict.fromkeys(r.kind for r in ev.rows if r.cameras == cams):
            for m, (n, mean, p95, mx) in ev.pooled_stats(kind, cams).items():
                pc = ("", "", "")
                if m != ref:
                    p = ev.paired(ref, m, kind=kind, cameras=cams)
                    pc = (f"{100 * p.a_better:.0f} %", f"{100 * p.b_better:.0f} %", f"{p.mean_diff:+.3f}")
                rows.append((cams, kind, m, str(n), f"{mean:.3f}", f"{p95:.3f}", f"{mx:.2f}", *pc))
    header = ("cameras", "kind", "estimator", "n", "pooled mean", "p95", "max")
    header += (f"{ref} better", f"{ref} worse", "mean difference")
    return "<h3>Pooled over the test sets, and paired comparisons</h3>" + _table_html(header, rows)


def _estimated_bands(cameras, curves, full, illuminant, w) -> tuple[dict, float]:
    """``({"notes": {camera index: description}, "phi": (n, k) half-widths in Phi's units or None},
    band_k)`` for the cameras whose files carry an uncertainty (:func:`read_ssf_band`): ± band_k σ,
    carried to ``full.Phi``'s units by each channel's own normalisation (white → 1)."""
    from .spectra import builtin as spectra
    from .spectra.estimate import read_ssf_band, ssf_basis

    notes, phi = {}, np.zeros_like(np.asarray(full.Phi, dtype=np.float64))
    E = spectra.resample(spectra.illuminant(illuminant), w)[:, 0]
    band_k = float(ssf_basis().band_k)
    for i, c in enumerate(cameras):
        found = read_ssf_band(c, w)
        if found is None or not found[0].any():
            continue
        sigma, notes[i] = found
        S = np.clip(spectra.resample(curves[i], w), 0, None)
        cols = slice(3 * i, 3 * i + 3)
        scale = np.asarray(full.Phi, dtype=np.float64)[:, cols].sum(0) / np.maximum(
            (S * E[:, None]).sum(0), 1e-300
        )
        phi[:, cols] = band_k * sigma * E[:, None] * scale
    return {"notes": notes, "phi": phi if notes else None}, band_k


def _pictures(folder: Path, curves, full, singles, chain, step, bands=None) -> list[tuple[str, str]]:
    from . import viz

    pics: list[tuple[str, str]] = []
    step("pictures: charts", 2)
    phi = None if bands is None else bands[0]["phi"]
    viz.plot_sensitivities(
        full,
        bands=phi,
        band_label=None if phi is None else f"±{bands[1]:.2g} σ of the estimated curves",
        filename=folder / "sensitivities.png",
    )
    pics.append(("sensitivities.png", "Camera sensitivities against the target"))
    viz.plot_vora_chain(chain, filename=folder / "vora_channels.png")
    pics.append(("vora_channels.png", "Vora value vs number of channels (greedy order)"))
    import matplotlib.pyplot as plt

    plt.close("all")
    step("pictures: solid", 1)
    viz.plot_object_colour_solid(full, filename=folder / "solid.png", opacity=0.9).close()
    pics.append(("solid.png", "Object-colour solid (CIE 2015 XYZ) and spectral locus"))
    step("pictures: MMVs", 3)
    viz.plot_grey_mmvs(full, filename=folder / "grey_mmvs.png").close()
    pics.append(("grey_mmvs.png", f"MMVs along the grey axis, {' + '.join(full.sources)}"))
    from .spectra import builtin as spectra

    x = np.clip(spectra.resample(spectra.reflectances("ColorChecker N Ohta"), full.wavelengths)[:, 2], 0, 1)
    problems = [singles[0], full] if len(singles) > 1 else [full]
    viz.plot_mmv_comparison(problems, x, filename=folder / "mmv_comparison.png").close()
    pics.append(("mmv_comparison.png", "MMV of ColorChecker 'blue sky': one camera vs all cameras"))
    light, other = _illuminant_mmvs(curves, full, x, folder / "illuminant_mmv.png")
    pics.append(
        (
            "illuminant_mmv.png",
            f"MMV of ColorChecker 'blue sky' in XYZ under {light}: observer-induced (the cameras under "
            f"{light}), illuminant-induced (the eye under {other}) and both (the cameras under {other})",
        )
    )
    step("pictures: confidence map", 1)
    _confidence_map(full, folder / "confidence_map.png")
    pics.append(
        (
            "confidence_map.png",
            "Confidence map of the default estimator: estimates and their 95 % credible radius (ΔE00) "
            "for the ColorChecker and 24 atypical spectra",
        )
    )
    return pics


def _illuminant_mmvs(curves, full, x: np.ndarray, filename: Path) -> tuple[str, str]:
    """The observer-induced MMV of ``x`` next to the illuminant-induced one (the eye under a second
    light, A, or D65 when the report's light is A) and the combined one (the cameras under it), all in
    the target's XYZ under the report's light (Logvinenko, Funt & Godau 2014)."""
    from . import viz
    from .correct.methods import correction_problem
    from .spectra import builtin as spectra

    light = full.illuminant
    other = "D65" if str(light).upper() == "A" else "A"
    eye = spectra.observer(full.target)
    shape = full.wavelengths
    problems = [
        full,
        correction_problem(eye, target=full.target, illuminant=other, reference=light, shape=shape),
        correction_problem(list(curves), target=full.target, illuminant=other, reference=light, shape=shape),
    ]
    titles = [f"cameras ({light}) to eye ({light})", f"eye ({other}) to eye ({light})"]
    titles.append(f"cameras ({other}) to eye ({light})")
    viz.plot_mmv_comparison(problems, x, titles=titles, filename=filename, window_size=(1500, 560)).close()
    return str(light), other


def _confidence_map(problem, filename: Path) -> None:
    """Estimates of ``"Prior"`` and their credible radii (:meth:`Corrector.with_uncertainty`) as
    two patch charts: the ColorChecker (natural) and 24 spectra of the atypical generator B."""
    import colour
    import matplotlib.pyplot as plt

    from .correct.methods import fit_correction
    from .evaluate import atypical_test_set
    from .spectra import builtin as spectra

    w = problem.wavelengths
    cc = np.clip(spectra.resample(spectra.reflectances("ColorChecker N Ohta"), w).T, 0, 1)[:24]
    X = np.vstack([cc, atypical_test_set(w, 24, generator="B").reflectances])
    est, radius = fit_correction(problem, method="Prior").with_uncertainty(problem.source_of(X))
    white = problem.white_XYZ
    rgb = colour.XYZ_to_sRGB(problem.to_XYZ(est) / white[1], illuminant=colour.XYZ_to_xy(white))
    rgb = np.clip(rgb, 0, 1).reshape(2, 4, 6, 3)
    rad = radius.reshape(2, 4, 6)
    fig, axes = plt.subplots(2, 2, figsize=(9, 5.6), constrained_layout=True)
    top = float(np.max(rad))
    for row, name in enumerate(("ColorChecker", "atypical B")):
        axes[row, 0].imshow(rgb[row], interpolation="nearest")
        axes[row, 0].set_title(f"{name}: estimate (sRGB)")
        im = axes[row, 1].imshow(rad[row], cmap="magma", vmin=0, vmax=top, interpolation="nearest")
        axes[row, 1].set_title(f"{name}: credible radius (ΔE00)")
        for j, i in np.ndindex(4, 6):
            ink = "k" if rad[row, j, i] > LABEL_INK * top else "w"
            axes[row, 1].text(i, j, f"{rad[row, j, i]:.1f}", ha="center", va="center", color=ink, fontsize=7)
        for ax in axes[row]:
            ax.set_xticks([])
            ax.set_yticks([])
    fig.colorbar(im, ax=axes[:, 1], shrink=0.8, label="ΔE00")
    fig.suptitle(f"{' + '.join(problem.sources)}: Prior estimates and their 95 % credible radius")
    fig.savefig(filename, dpi=110)
    plt.close(fig)
