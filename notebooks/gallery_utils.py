"""Small plotting helpers shared by the gallery notebooks (not part of the library).

Colours in the figures are the sRGB appearance of the colour shown (``colour.XYZ_to_sRGB`` of its
XYZ, D65, clipped), so a red patch is red because the data say so, not because a colormap says so.
"""

from __future__ import annotations

import os
from pathlib import Path

import colour
import numpy as np

CMFS_1931 = "CIE 1931 2 Degree Standard Observer"


def shared_data() -> Path | None:
    """``../shared/data`` (or ``$ZONOTOPE_SHARED_DATA``) when it exists, else None."""
    env = os.environ.get("ZONOTOPE_SHARED_DATA")
    here = Path.cwd().resolve()
    candidates = [Path(env)] if env else []
    candidates += [p / "shared" / "data" for p in (here, *here.parents)]
    return next((p for p in candidates if p.is_dir()), None)


def XYZ_to_display(XYZ, white_Y: float = 1.0) -> np.ndarray:
    """sRGB (D65, encoded, clipped to [0, 1]) of XYZ scaled so that the white has ``Y = white_Y``."""
    XYZ = np.asarray(XYZ, dtype=float) / white_Y
    rgb = colour.XYZ_to_sRGB(XYZ, colour.CCS_ILLUMINANTS["CIE 1931 2 Degree Standard Observer"]["D65"])
    return np.clip(rgb, 0.0, 1.0)


def spectral_colours(wavelengths) -> np.ndarray:
    """Display colour of each monochromatic light: its sRGB chromaticity at full brightness, clipped."""
    cmfs = colour.MSDS_CMFS[CMFS_1931]
    XYZ = np.stack([np.interp(wavelengths, cmfs.wavelengths, cmfs.values[:, i]) for i in range(3)], -1)
    rgb = colour.XYZ_to_RGB(XYZ, "sRGB", apply_cctf_encoding=False)
    rgb = np.clip(rgb, 0, None)
    rgb = rgb / np.maximum(rgb.max(axis=-1, keepdims=True), 1e-12)
    return np.clip(colour.cctf_encoding(rgb, "sRGB"), 0, 1)


def spectrum_strip(ax, wavelengths, height: float = 0.05) -> None:
    """Draw the colours of the spectrum as a strip inside the bottom of a wavelength axis.

    Leave room for it: the strip covers the lowest ``height`` of the axes (axes fraction).
    """
    w = np.asarray(wavelengths, dtype=float)
    ax.imshow(
        spectral_colours(w)[None],
        extent=(w[0], w[-1], 0, height),
        aspect="auto",
        transform=ax.get_xaxis_transform(),
        zorder=0,
    )
    ax.set_xlim(w[0], w[-1])


def chromaticity_locus(ax, wavelengths=None, label: str = "spectral locus (CIE 1931 2°)") -> None:
    """The CIE 1931 horseshoe, coloured, closed by the purple line, with a few wavelengths marked."""
    cmfs = colour.MSDS_CMFS[CMFS_1931]
    w = np.arange(380, 701, 1.0) if wavelengths is None else np.asarray(wavelengths, float)
    XYZ = np.stack([np.interp(w, cmfs.wavelengths, cmfs.values[:, i]) for i in range(3)], -1)
    xy = XYZ[:, :2] / XYZ.sum(-1, keepdims=True)
    ax.scatter(xy[:, 0], xy[:, 1], c=spectral_colours(w), s=6, zorder=2, label=label)
    ax.plot([xy[0, 0], xy[-1, 0]], [xy[0, 1], xy[-1, 1]], color="purple", lw=1, ls=":")
    for lam in (450, 480, 500, 520, 550, 580, 600, 650):
        i = np.argmin(abs(w - lam))
        ax.annotate(f"{lam}", xy[i], textcoords="offset points", xytext=(4, 2), fontsize=7)
    ax.set_xlabel("x")
    ax.set_ylabel("y")
    ax.set_aspect("equal")


def draw_mesh(ax, vertices, faces, colours, *, alpha: float = 1.0, edge: str | None = None) -> None:
    """Triangles on a matplotlib 3-D axis, one colour per triangle."""
    from mpl_toolkits.mplot3d.art3d import Poly3DCollection

    tris = np.asarray(vertices)[np.asarray(faces)]
    rgba = np.concatenate([np.asarray(colours, float), np.full((len(tris), 1), alpha)], axis=1)
    # edges in the face colour cover the white seams antialiasing leaves between triangles
    coll = Poly3DCollection(tris, facecolors=rgba, edgecolors=edge or rgba, linewidths=0.3)
    ax.add_collection3d(coll)


def draw_convex(
    ax, vertices, faces, normals, colours, *, elev: float, azim: float, alpha: float = 1.0
) -> None:
    """A convex mesh seen from (elev, azim): back faces culled (matplotlib does not z-buffer), shaded."""
    e, a = np.radians(elev), np.radians(azim)
    eye = np.array([np.cos(e) * np.cos(a), np.cos(e) * np.sin(a), np.sin(e)])
    visible = np.asarray(normals) @ eye > 0
    draw_mesh(ax, vertices, np.asarray(faces)[visible], shade(colours, normals)[visible], alpha=alpha)
    ax.view_init(elev=elev, azim=azim)


def shade(colours, normals, light=(0.4, -0.5, 0.75), ambient: float = 0.65) -> np.ndarray:
    """Lambert shading of per-face colours so a convex solid reads as 3-D (ambient keeps the colour)."""
    n = np.asarray(normals, float)
    n = n / np.linalg.norm(n, axis=1, keepdims=True)
    lam = np.clip(n @ (np.asarray(light) / np.linalg.norm(light)), 0, 1)
    return np.clip(np.asarray(colours) * (ambient + (1 - ambient) * lam)[:, None], 0, 1)


def set_box(ax, lo, hi, labels=("X", "Y", "Z")) -> None:
    """Equal-aspect limits around [lo, hi] and axis labels."""
    lo, hi = np.asarray(lo, float), np.asarray(hi, float)
    ax.set_xlim(lo[0], hi[0])
    ax.set_ylim(lo[1], hi[1])
    ax.set_zlim(lo[2], hi[2])
    ax.set_box_aspect(hi - lo)
    ax.set_xlabel(labels[0])
    ax.set_ylabel(labels[1])
    ax.set_zlabel(labels[2])


def fill_projection(ax, points, dims, colour, *, label=None, fill=True, **style) -> None:
    """Convex hull of ``points[:, dims]`` as a filled (or outlined) polygon on a 2-D axis."""
    from scipy.spatial import ConvexHull

    p = np.asarray(points)[:, list(dims)]
    h = p[ConvexHull(p).vertices]
    h = np.vstack([h, h[:1]])
    if fill:
        ax.fill(*h.T, color=colour, label=label, **style)
    else:
        ax.plot(*h.T, color=colour, label=label, **style)
