"""Pictures: object-colour solids, spectral locus and metamer mismatch volumes (pyvista), charts (matplotlib).

Every pyvista function draws into a ``pyvista.Plotter`` (a new off-screen one unless ``plotter`` is
given) and returns it; ``filename`` saves a PNG. Without a display, set
``VTK_DEFAULT_OPENGL_WINDOW=vtkEGLRenderWindow`` before the first import of pyvista (this module
does so when ``DISPLAY`` is unset). For an interactive window, pass
``plotter=pyvista.Plotter()`` and call ``.show()`` on the result.

Solids and MMVs are drawn in the target space of a :class:`zonotope.correct.CorrectionProblem`
(XYZ, Y_white = 1 by default), coloured by their sRGB appearance (``colour.XYZ_to_sRGB``, clipped).
"""

from __future__ import annotations

import os
from collections.abc import Sequence

import numpy as np

from ._tol import LOCUS_ZERO

__all__ = [
    "mmv_polytope",
    "plot_grey_mmvs",
    "plot_mmv",
    "plot_mmv_band",
    "plot_mmv_comparison",
    "plot_object_colour_solid",
    "plot_sensitivities",
    "plot_spectral_locus",
    "plot_vora_chain",
]


#: MMVs are small: light them mostly ambiently so their sRGB colour reads, outline the silhouette.
_MMV_STYLE = {
    "ambient": 0.55,
    "diffuse": 0.5,
    "specular": 0.0,
    "silhouette": {"color": "black", "line_width": 1.5},
}


def _pv():
    if not os.environ.get("DISPLAY"):
        os.environ.setdefault("VTK_DEFAULT_OPENGL_WINDOW", "vtkEGLRenderWindow")
    import pyvista as pv

    return pv


def _plotter(plotter, shape=(1, 1), window_size=(900, 700)):
    if plotter is not None:
        return plotter
    return _pv().Plotter(off_screen=True, shape=shape, window_size=window_size)


def _axis_names(problem) -> tuple[str, str, str]:
    """Channel names of the target space: L, M, S for cone fundamentals, else X, Y, Z."""
    target = str(getattr(problem, "target", "")).lower()
    return ("L", "M", "S") if any(k in target for k in ("stockman", "lms", "cone")) else ("X", "Y", "Z")


#: Grid tick labels: two decimals, and ``z`` prints a value that rounds to zero as 0.00, never -0.00
#: (the solid's lower bounds are -1e-16 after floating-point sums).
_TICK_FORMAT = "{:z.2f}"
#: After the camera fits the grid's box, step back so that the labels outside the box's corners and
#: the title fit too (0.82: the lowest tick labels of the solid were still cut at 1.0; looked at).
_FRAME_ZOOM = 0.82
#: Largest title width, as a share of its panel's width (a 2 % margin each side); longer titles shrink.
_TITLE_WIDTH = 0.96


def _finish(
    plotter,
    filename,
    *,
    axes: bool = True,
    names: Sequence[str] = ("X", "Y", "Z"),
    title: str | None = None,
    bounds=None,
):
    """Title, labelled grid and a camera that frames the grid with its labels, then save.

    ``bounds`` (xmin, xmax, ymin, ymax, zmin, zmax) is the box the grid spans and the camera frames
    (default: everything drawn); the camera keeps the view direction already set.
    """
    if title:
        _title(plotter, title)
    if axes:  # a labelled orientation widget and a grid with the channel names and their scale
        x, y, z = names
        if tuple(plotter.shape) == (1, 1):
            # not in multi-panel plotters: there VTK segfaulted now and then inside render(), in
            # vtkOrientationMarkerWidget::ExecuteCameraUpdateEvent → vtkRenderer::GetActiveCamera
            # (gdb backtrace); the grid below still names the axes of every panel
            plotter.add_axes(xlabel=x, ylabel=y, zlabel=z)
        plotter.show_grid(
            xtitle=x, ytitle=y, ztitle=z, font_size=12, color="grey", fmt=_TICK_FORMAT, bounds=bounds
        )
    if axes or bounds is not None:
        # VTK fits the box's bounding sphere to the view angle: the box's corners, and so the tick
        # labels and axis titles next to them, stay inside the picture (the fixed camera distance
        # used before cut the X and Y labels off)
        plotter.reset_camera(bounds=bounds)
        plotter.camera.zoom(_FRAME_ZOOM)
    if filename is not None:
        from .utilities.io import atomic_path

        atomic_path(filename, lambda tmp: plotter.screenshot(str(tmp)))
    return plotter


def _title(plotter, text: str) -> None:
    """``text`` centred at the top of the active panel, its font shrunk until it fits the panel's width."""
    actor = plotter.add_text(
        text, position=(0.5, 0.985), viewport=True, font_size=10, color="black", name="title"
    )
    prop = actor.GetTextProperty()
    prop.SetJustificationToCentered()
    prop.SetVerticalJustificationToTop()
    width = plotter.renderer.GetSize()[0]
    box = np.zeros(4)
    while True:
        actor.GetBoundingBox(plotter.renderer, box)
        if box[1] - box[0] <= _TITLE_WIDTH * width or prop.GetFontSize() <= 8:
            break
        prop.SetFontSize(prop.GetFontSize() - 1)


def _names(problem) -> str:
    return " + ".join(problem.sources)


def _srgb(problem, target: np.ndarray) -> np.ndarray:
    import colour

    white = problem.white_XYZ
    rgb = colour.XYZ_to_sRGB(problem.to_XYZ(target) / white[1], colour.XYZ_to_xy(white))
    return np.clip(rgb, 0.0, 1.0)


def _mesh(problem, polytope_or_zonotope, *, colour_by_srgb: bool = True):
    mesh = polytope_or_zonotope.to_pyvista()
    if colour_by_srgb:
        mesh.point_data["sRGB"] = (255 * _srgb(problem, np.asarray(mesh.points))).astype(np.uint8)
    return mesh


def _camera(plotter, problem) -> None:
    w = problem.Psi.sum(axis=0)  # the white in target coordinates (white_XYZ is XYZ even for an LMS target)
    plotter.camera_position = [tuple(w * np.array([2.6, -1.2, 1.9])), tuple(0.45 * w), (0, 0, 1)]


def plot_object_colour_solid(
    problem,
    *,
    plotter=None,
    filename=None,
    opacity: float = 1.0,
    locus: bool = True,
    show_edges: bool = False,
    title: str | None = None,
):
    """The object-colour solid of the target (all colours of reflectances in [0, 1]).

    Parameters
    ----------
    problem : zonotope.correct.CorrectionProblem
        Its target generators Ψ (n, 3) span the solid.
    plotter : pyvista.Plotter, optional
    filename : str or Path, optional
        PNG to write.
    opacity, show_edges
        Mesh style.
    locus
        Also draw the spectral locus (:func:`plot_spectral_locus`).
    title
        Shown above the picture; default names the target and the illuminant, ``""`` shows none.

    Returns
    -------
    pyvista.Plotter
    """
    from .geometry.solid import Zonotope

    p = _plotter(plotter)
    p.add_mesh(
        _mesh(problem, Zonotope(problem.Psi)),
        scalars="sRGB",
        rgb=True,
        opacity=opacity,
        show_edges=show_edges,
        smooth_shading=False,
    )
    if locus:
        plot_spectral_locus(problem, plotter=p, title="")
    _camera(p, problem)
    if title is None:
        title = f"Object-colour solid: {problem.target} under {problem.illuminant}"
    return _finish(p, filename, names=_axis_names(problem), title=title)


def plot_spectral_locus(
    problem, *, plotter=None, filename=None, scale: float = 0.6, title: str | None = None
):
    """The spectral locus: the direction of each monochromatic light, as a curve on a cone.

    Each wavelength's generator ``ψ_λ`` is scaled to ``scale × |white| / |ψ_λ|`` so that the curve
    traces the cone of spectral directions in which the solid's edges lie. ``title`` is shown above
    the picture (default names the target; ``""`` shows none).
    """
    pv = _pv()
    p = _plotter(plotter)
    G = problem.Psi
    norms = np.linalg.norm(G, axis=1)
    keep = norms > LOCUS_ZERO * norms.max()
    pts = G[keep] / norms[keep, None] * scale * np.linalg.norm(problem.white_XYZ)
    line = pv.lines_from_points(pts)
    line.point_data["sRGB"] = (255 * _srgb(problem, pts / pts[:, 1:2].clip(1e-9) * 0.5)).astype(np.uint8)
    p.add_mesh(line, scalars="sRGB", rgb=True, line_width=4)
    rays = pv.PolyData(np.vstack([np.zeros(3), pts[::3]]))
    rays.lines = np.hstack([[2, 0, i] for i in range(1, rays.n_points)])
    p.add_mesh(rays, color="grey", opacity=0.4, line_width=1)
    _camera(p, problem)
    title = f"Spectral locus: {problem.target}" if title is None else title
    return _finish(p, filename, names=_axis_names(problem), title=title)


def mmv_polytope(problem, response, *, eps: float = 1e-3):
    """The metamer mismatch volume of one source response as a :class:`zonotope.geometry.polytope.Polytope`.

    Parameters
    ----------
    problem : zonotope.correct.CorrectionProblem
    response : array_like of shape (k,)
    eps
        Certification tolerance; the certified inner polytope is returned.
    """
    from .mismatch.volume import metamer_mismatch_bounds

    return metamer_mismatch_bounds(
        problem.Phi, problem.Psi, np.asarray(response, dtype=np.float64), eps=eps, on_infeasible="nearest"
    ).inner


def plot_mmv(
    problem,
    response,
    *,
    plotter=None,
    filename=None,
    solid_opacity: float = 0.12,
    truth=None,
    estimates: dict | None = None,
    title: str | None = None,
):
    """An MMV (opaque, sRGB-coloured) inside the translucent object-colour solid.

    The grid labels and the view frame the MMV's bounding box (with the truth and estimates),
    widened by a third of its size.

    Parameters
    ----------
    problem : zonotope.correct.CorrectionProblem
    response : array_like of shape (k,)
    truth : array_like of shape (3,), optional
        True target colour, drawn as a white sphere.
    estimates : dict of str → array_like of shape (3,), optional
        Estimates drawn as labelled points.
    title : str, optional
        Shown above the picture; default names the cameras and the target, ``""`` shows none.
    """
    return _plot_mmv(
        problem,
        response,
        plotter=plotter,
        filename=filename,
        solid_opacity=solid_opacity,
        truth=truth,
        estimates=estimates,
        title=title,
    )


def _plot_mmv(
    problem,
    response,
    *,
    plotter,
    filename,
    solid_opacity=0.12,
    truth=None,
    estimates=None,
    title,
    bounds=None,
):
    """:func:`plot_mmv`; ``bounds`` (xmin, xmax, ..., zmax) is the box to label and frame (default the
    MMV's, see :func:`_mmv_box`): the panels of :func:`plot_mmv_comparison` share one."""
    from .geometry.solid import Zonotope

    pv = _pv()
    p = _plotter(plotter)
    p.add_mesh(Zonotope(problem.Psi).to_pyvista(), color="lightgrey", opacity=solid_opacity)
    mmv = mmv_polytope(problem, response)
    p.add_mesh(_mesh(problem, mmv), scalars="sRGB", rgb=True, **_MMV_STYLE)
    scale = float(np.linalg.norm(problem.white_XYZ))
    if truth is not None:
        p.add_mesh(pv.Sphere(radius=0.008 * scale, center=np.asarray(truth, float)), color="white")
    for name, point in (estimates or {}).items():
        p.add_point_labels(
            np.asarray(point, float)[None], [name], point_size=10, font_size=12, render_points_as_spheres=True
        )
    if bounds is None:
        bounds = _mmv_box(problem, [mmv], [truth, *(estimates or {}).values()])
    p.camera.focal_point = tuple(mmv.centroid)
    p.camera.position = tuple(np.asarray(mmv.centroid) + scale * np.array([0.9, -0.5, 0.6]))
    p.camera.up = (0, 0, 1)
    if title is None:
        title = f"MMV: {_names(problem)} to {problem.target}"
    return _finish(p, filename, names=_axis_names(problem), title=title, bounds=bounds)


def _mmv_box(problem, mmvs, points=()) -> tuple[float, ...]:
    """Bounding box of MMVs (and points), widened by a third of its size, within the solid's box."""
    pts = [np.asarray(m.vertices, float) for m in mmvs]
    pts += [np.asarray(q, float).reshape(1, 3) for q in points if q is not None]
    allp = np.vstack(pts)
    lo, hi = allp.min(axis=0), allp.max(axis=0)
    pad = (hi - lo).max() / 3
    Psi = np.asarray(problem.Psi, float)
    lo = np.maximum(lo - pad, np.minimum(Psi, 0).sum(axis=0))
    hi = np.minimum(hi + pad, np.maximum(Psi, 0).sum(axis=0))
    return tuple(float(v) for pair in zip(lo, hi, strict=True) for v in pair)


def plot_grey_mmvs(
    problem,
    levels: Sequence[float] = (0.1, 0.3, 0.5, 0.7, 0.9),
    *,
    plotter=None,
    filename=None,
    solid_opacity: float = 0.1,
    title: str | None = None,
):
    """MMVs of the greys ``c = level × (1, …, 1)`` along the achromatic axis (thesis fig. 4.2).

    ``title`` is shown above the picture (default names the cameras, the target and the levels;
    ``""`` shows none).
    """
    from .geometry.solid import Zonotope

    pv = _pv()
    p = _plotter(plotter)
    p.add_mesh(Zonotope(problem.Psi).to_pyvista(), color="lightgrey", opacity=solid_opacity)
    for level in levels:
        mmv = mmv_polytope(problem, np.full(problem.k, float(level)))
        p.add_mesh(_mesh(problem, mmv), scalars="sRGB", rgb=True, **_MMV_STYLE)
    p.add_mesh(pv.Line((0, 0, 0), tuple(problem.Psi.sum(axis=0))), color="black", line_width=2)
    _camera(p, problem)
    if title is None:
        shown = ", ".join(f"{float(v):g}" for v in levels)
        title = f"Grey MMVs ({shown}): {_names(problem)} to {problem.target}"
    return _finish(p, filename, names=_axis_names(problem), title=title)


def plot_mmv_comparison(
    problems: Sequence,
    reflectance,
    *,
    titles: Sequence[str] | None = None,
    filename=None,
    window_size=(1400, 650),
):
    """The MMV of one reflectance seen by different camera sets, side by side (e.g. 1 vs 2 cameras).

    Parameters
    ----------
    problems : sequence of CorrectionProblem
        Same target and grid, different sources.
    reflectance : array_like of shape (n,)
    titles : sequence of str, optional
        One per panel (default the camera names); every panel frames and labels the same box (all
        panels' MMVs and the truth), so sizes compare.
    """
    p = _plotter(None, shape=(1, len(problems)), window_size=window_size)
    x = np.asarray(reflectance, dtype=np.float64)
    mmvs = [mmv_polytope(pb, x @ pb.Phi) for pb in problems]
    box = _mmv_box(problems[0], mmvs, [x @ pb.Psi for pb in problems])
    for i, pb in enumerate(problems):
        p.subplot(0, i)
        title = titles[i] if titles else _names(pb)
        _plot_mmv(pb, x @ pb.Phi, plotter=p, filename=None, truth=x @ pb.Psi, title=title, bounds=box)
        if i:
            p.camera = p.renderers[0].camera  # same view in every panel
    return _finish(p, filename, axes=False)  # every panel already has its labelled grid (plot_mmv)


def plot_mmv_band(
    band, *, reference=None, filename=None, title: str | None = None, sample_opacity: float = 0.18
):
    """The MMV of one reflectance with estimated sensitivities (opaque, sRGB) inside the MMVs with
    cameras drawn within their uncertainty band (translucent, one colour each), seen along the MMV's
    thinnest direction; the reflectance's true colour is a white sphere.

    Parameters
    ----------
    band : zonotope.BandMMVs
        From :func:`zonotope.band_mmvs`.
    reference : Polytope, optional
        Another MMV of the same reflectance (e.g. with the measured camera), drawn as a black outline.
    title : str, optional
        Default: the number of drawn cameras and the samples' volume range relative to the estimate's.
    """
    import matplotlib

    pv = _pv()
    problem = band.problem
    p = _plotter(None)
    p.add_mesh(_solid_mesh(problem), color="lightgrey", opacity=0.08)
    p.add_mesh(_mesh(problem, band.mmv), scalars="sRGB", rgb=True, **_MMV_STYLE)
    colours = matplotlib.colormaps["tab10"]
    for i, m in enumerate(band.sample_mmvs):
        p.add_mesh(m.to_pyvista(), color=colours(i % 10)[:3], opacity=sample_opacity, **_MMV_STYLE)
    extra = []
    if reference is not None:
        p.add_mesh(
            reference.to_pyvista(),
            color="white",
            opacity=0.05,
            silhouette={"color": "black", "line_width": 3},
        )
        extra = [reference]
    truth = band.reflectance @ problem.Psi
    scale = float(np.linalg.norm(problem.white_XYZ))
    p.add_mesh(pv.Sphere(radius=0.006 * scale, center=truth), color="white")
    box = _mmv_box(problem, [band.mmv, *band.sample_mmvs, *extra], [truth])
    c = np.asarray(band.mmv.centroid)
    vertices = np.asarray(band.mmv.vertices, dtype=np.float64)
    thin = np.linalg.eigh(np.cov((vertices - c).T))[1][:, 0]  # the MMVs are plates: look at the face
    thin = thin * np.copysign(1.0, thin @ np.array([0.9, -0.5, 0.6]))  # from the side plot_mmv views
    p.camera.focal_point = tuple(c)
    p.camera.position = tuple(c + scale * thin)
    p.camera.up = tuple(np.eye(3)[np.argmin(np.abs(thin))])  # the axis most across the view: upright
    if title is None:
        v = band.sample_volumes / band.volume
        title = f"MMV: estimate (sRGB) and {v.size} band samples (volume x{v.min():.2f}-{v.max():.2f})"
    return _finish(p, filename, names=_axis_names(problem), title=title, bounds=box)


def _solid_mesh(problem):
    from .geometry.solid import Zonotope

    return Zonotope(problem.Psi).to_pyvista()


# -- matplotlib ------------------------------------------------------------------------------------


def _figure(ax, figsize=(7, 4)):
    if ax is None:
        # No backend is forced: matplotlib falls back to Agg without a display by itself, and
        # Jupyter's inline backend (figures in executed notebooks) must be left alone.
        import matplotlib.pyplot as plt

        fig, ax = plt.subplots(figsize=figsize, constrained_layout=True)
        return fig, ax
    return ax.figure, ax


def _save(fig, filename):
    if filename is not None:
        from .utilities.io import atomic_path

        atomic_path(filename, lambda tmp: fig.savefig(tmp, dpi=110))


def plot_sensitivities(problem, *, bands=None, band_label=None, ax=None, filename=None):
    """Source channels against the target (both × illuminant, white-normalised), matplotlib.

    ``bands``: optional (n, k) half-widths in the units of ``problem.Phi`` (0 where a channel's curve
    is known exactly), shaded around each channel, e.g. an estimated camera's uncertainty band
    (:func:`zonotope.spectra.estimate.read_ssf_band`); ``band_label`` names it in the legend.

    Returns
    -------
    matplotlib.figure.Figure
    """
    fig, ax = _figure(ax)
    w = problem.wavelengths
    peak = problem.Phi.max(axis=0)
    Phi = problem.Phi / peak
    if bands is not None:
        half = np.asarray(bands, dtype=np.float64) / peak
        shaded = False
        for j in range(problem.k):
            if np.any(half[:, j] > 0):
                colour_j = ["tab:red", "tab:green", "tab:blue"][j % 3]
                label = band_label if not shaded else None
                ax.fill_between(
                    w,
                    np.maximum(Phi[:, j] - half[:, j], 0),  # sensitivities are never negative
                    Phi[:, j] + half[:, j],
                    color=colour_j,
                    alpha=0.15,
                    lw=0,
                    label=label,
                )
                shaded = True
    Psi = problem.Psi / problem.Psi.max(axis=0)
    colours = ["tab:red", "tab:green", "tab:blue"]
    per = 3 if problem.k % 3 == 0 else problem.k
    styles = ["-", "--", ":", "-."]
    for j in range(problem.k):
        cam = j // per
        name = problem.sources[cam] if cam < len(problem.sources) else f"channel {j}"
        ax.plot(
            w,
            Phi[:, j],
            styles[cam % 4],
            color=colours[j % 3] if per == 3 else None,
            lw=1.4,
            label=name if j % per == 0 else None,
        )
    for j in range(problem.m):
        ax.plot(
            w,
            Psi[:, j],
            color="black",
            lw=2.2,
            alpha=0.5,
            label=f"target ({problem.target})" if j == 0 else None,
        )
    ax.set_xlabel("wavelength (nm)")
    ax.set_ylabel(f"sensitivity × {problem.illuminant} (peak = 1)")
    ax.legend(fontsize=8)
    ax.set_title("Camera sensitivities against the target observer")
    _save(fig, filename)
    return fig


def plot_vora_chain(chain, *, ax=None, filename=None):
    """Vora value against the number of channels for a greedy camera chain (thesis fig. 5.2).

    Parameters
    ----------
    chain : sequence of zonotope.vora.CameraSetScore
        From ``rank_camera_sets(..., method="greedy")``.
    """
    fig, ax = _figure(ax, figsize=(6, 4))
    ch = [s.channels for s in chain]
    v = [s.vora for s in chain]
    ax.plot(ch, v, "o-", color="tab:blue")
    for s in chain:
        ax.annotate(
            s.cameras[-1], (s.channels, s.vora), textcoords="offset points", xytext=(4, -12), fontsize=8
        )
    ax.set_xlabel("number of channels (cameras stacked, greedy order)")
    ax.set_ylabel("Vora value")
    ax.set_ylim(min(v) - 0.02, 1.0)
    ax.set_xticks(ch)
    ax.set_xlim(min(ch) - 0.6, max(ch) + 2.4)
    ax.grid(alpha=0.3)
    ax.set_title("Vora value vs number of channels")
    _save(fig, filename)
    return fig
