"""A physically based simulated capture rendered by Mitsuba 3 (optional: ``pip install mitsuba``).

The same cameras, poses, EXIF, noise model, DNG writer and folder layout as :mod:`splat.sim.capture`, but
the images come from Mitsuba's spectral path tracer (``scalar_spectral`` variant, ``path`` integrator,
``max_depth`` 6): inter-reflection, soft shadows, a rough-plastic sphere and a rough-conductor (gold)
sphere beside diffuse boxes, a ColorChecker chart and a white card on a floor inside a three-wall room,
lit by a rectangular area light and a constant environment that both emit the scene illuminant's
spectrum. Every diffuse reflectance is a measured spectrum from the simulator's library; the floor and
walls mix one with the chart's black per point (a seeded two-scale cell texture) so that SIFT finds
features, as on the ray-caster's capture.

Mitsuba's ``specfilm`` integrates the spectral radiance ``L(λ)`` against any curves, so one render gives
each camera's raw channels and the XYZ truth at once: the film's channels are ``S_c(λ) / m`` (the
camera's sensitivities, ``m`` their largest white response under the illuminant) and ``x̄ȳz̄(λ) / Σ ȳE``.
One scale ``k`` for all views maps the rendered values to the ray-caster's units (white card's largest
channel 0.9, Y of a perfect white under the illuminant 1): it is fitted on the white card of the first
training view that sees it whole. Then :func:`splat.sim.capture._raw_values` applies gain, exposure,
the CFA, shot and read noise (seeded) and saturation, and :func:`splat.sim.capture.write_view_dng`
writes the files.

``truth/`` holds the true poses (COLMAP text model, no 3-D points), float32 XYZ TIFFs of the held-out
views and ``truth.toml`` (``generator = "splat.sim.mitsuba"``).
"""

from __future__ import annotations

import os
import shutil
import tempfile
from dataclasses import replace
from pathlib import Path

import numpy as np

from .._errors import SplatError
from .._tol import MITSUBA_DECAL_LIFT, MITSUBA_TRUTH_CHUNKS, MITSUBA_WHITE_PEAK
from .capture import (
    _OBSERVER,
    SimCaptureConfig,
    _color_matrices,
    _qvec,
    _raw_values,
    _toml_table,
    _toml_value,
    build_scene,
    write_view_dng,
)
from .geometry import CARD, CHART, chart_in_view

__all__ = [
    "LABEL_CHART",
    "LABEL_OTHER",
    "LABEL_UNIFORM",
    "mitsuba_config",
    "mitsuba_scene",
    "surface_labels",
    "truth_xyz",
    "write_mitsuba_capture",
    "write_surface_labels",
    "write_truth",
]

_GENERATOR = "splat.sim.mitsuba"
_VARIANT = "scalar_spectral"  # the LLVM variants need a JIT these CPUs' builds lack
_MAX_DEPTH = 6  # path length: light → up to four bounces → camera
_CARD_REFLECTANCE = 0.9
_TRUTH_SEED = 1 << 20  # the truth's sampler seeds start here: never a photograph's (seed · 1009 + view)
_MAX_CHUNKS = 1024  # a truth's renders per view (one seed each; the next view's seeds follow)


def _mitsuba():
    try:
        import mitsuba as mi
    except ImportError as exc:  # pragma: no cover - depends on the environment
        raise SplatError(
            "splat.sim.mitsuba needs Mitsuba 3: pip install mitsuba (or the project's 'sim' extra)."
        ) from exc
    if mi.variant() != _VARIANT:
        mi.set_variant(_VARIANT)
    return mi


def _spectrum(grid: np.ndarray, values) -> dict:
    """A Mitsuba ``regular`` spectrum on the (evenly spaced) grid; zero outside it."""
    values = np.asarray(values, float)
    return {
        "type": "regular",
        "wavelength_min": float(grid[0]),
        "wavelength_max": float(grid[-1]),
        "values": ", ".join(f"{v:.8g}" for v in values),
    }


def _film(grid, curves: np.ndarray, width: int, height: int) -> dict:
    film = {"type": "specfilm", "width": width, "height": height, "rfilter": {"type": "box"}}
    for j in range(curves.shape[1]):
        film[f"ch{j:02d}"] = _spectrum(grid, curves[:, j])  # zero-padded: the channels keep their order
    return film


def _curves(scene, illuminant: str):
    """The illuminant ``E`` (peak 1) on the scene's grid, each camera's film curves ``S_c / m`` and the
    observer's ``x̄ȳz̄ / Σ ȳ E Δλ`` (both: the simulator's generators ``G / (E Δλ)``)."""
    import zonotope

    grid = scene.wavelengths
    spd = zonotope.illuminant(illuminant)
    E = np.interp(grid, np.asarray(spd.wavelengths, float), np.asarray(spd.values, float))
    E = E / E.max()
    step = float(grid[1] - grid[0])
    curves = [np.asarray(g, float) / (E[:, None] * step) for g in scene.camera_generators]
    return E, curves, np.asarray(scene.observer, float) / (E[:, None] * step)


def truth_xyz(scene, view, spp: int, *, scale: float, seed: int, illuminant: str = "D65", chunks=None):
    """A held-out view's true XYZ rendered on its own, and its Monte Carlo standard error per pixel.

    ``spp`` samples per pixel in ``chunks`` independent renders (default
    :data:`splat._tol.MITSUBA_TRUTH_CHUNKS`, at most ``spp``) of an XYZ-only film, seeds from
    ``seed``; ``scale`` is the capture's ``render_scale``. Returns ``(mean, se)``, float arrays
    (H, W, 3): the chunks' mean and its standard error (their spread / √chunks).

    Why: the photograph's own render is one noisy sample of the scene (at 32 spp a pixel's Y varies by
    ~14 %), and a truth that shares its noise with the view's photograph, or carries as much, is
    no truth for a region's mean over a few pixels."""
    mi = _mitsuba()
    E, _, xyz = _curves(scene, illuminant)
    chunks = max(1, min(int(MITSUBA_TRUTH_CHUNKS if chunks is None else chunks), int(spp), _MAX_CHUNKS))
    per = int(spp) // chunks
    sc = mitsuba_scene(scene, view, xyz, E, spp=per, seed=seed)
    stack = np.stack([np.asarray(mi.render(sc, seed=seed + c, spp=per), float) for c in range(chunks)])
    stack *= scale
    se = stack.std(0, ddof=1) / np.sqrt(chunks) if chunks > 1 else np.full(stack.shape[1:], np.nan)
    return stack.mean(0), se


def mitsuba_scene(
    scene, view, curves: np.ndarray, light: np.ndarray, *, spp: int, seed: int = 0, film: dict | None = None
):
    """The Mitsuba scene of ``view`` (a :class:`splat.sim.capture.SimView` of ``scene``) lit by the
    spectrum ``light`` with a specfilm whose channels are the columns of ``curves`` (both on
    ``scene.wavelengths``), or with ``film`` (a Mitsuba film's dictionary) when given."""
    mi = _mitsuba()
    T = mi.ScalarTransform4f
    grid = scene.wavelengths
    lib = scene.library
    cc = scene.palettes["colorchecker"]
    wall = scene.palettes["wall"]
    light = np.asarray(light, float)
    cam = scene.config.cameras[view.camera]
    centre = -view.R.T @ view.t
    ahead, down = view.R[2], view.R[1]  # camera +z (viewing) and +y (image down) in world coordinates

    def diffuse(row):
        return {"type": "diffuse", "reflectance": _spectrum(grid, row)}

    def textured(a, b, key, cells):
        """A per-point convex mix of two measured reflectances (blend weight: :func:`_texture`)."""
        weight = mi.Bitmap(_texture(scene.config.seed, key, cells))
        return {
            "type": "blendbsdf",
            "weight": {"type": "bitmap", "bitmap": weight, "raw": True, "filter_type": "nearest"},
            "bsdf_0": diffuse(lib[a]),
            "bsdf_1": diffuse(lib[b]),
        }

    def patch(cx, cy, sx, sy, z, bsdf):
        return {
            "type": "rectangle",
            "to_world": T().translate([cx, cy, z]).scale([sx / 2, sy / 2, 1.0]),
            "bsdf": bsdf,
        }

    d: dict = {
        "type": "scene",
        "integrator": {"type": "path", "max_depth": _MAX_DEPTH},
        "sensor": {
            "type": "perspective",
            "fov": float(cam.fov_deg),
            "fov_axis": "x",
            "to_world": T().look_at(
                origin=[float(x) for x in centre],
                target=[float(x) for x in centre + ahead],
                up=[float(x) for x in -down],
            ),
            "sampler": {"type": "independent", "sample_count": int(spp), "seed": int(seed)},
            "film": _film(grid, curves, cam.width, cam.height) if film is None else film,
        },
        "env": {"type": "constant", "radiance": _spectrum(grid, 0.25 * light)},
        "lamp": {
            "type": "rectangle",
            "to_world": T().translate([0.0, -0.5, 3.2]).rotate([1, 0, 0], 180).scale([1.2, 1.2, 1.0]),
            "emitter": {"type": "area", "radiance": _spectrum(grid, 1.5 * light)},
        },
        "floor": patch(0.0, 0.0, 8.0, 8.0, 0.0, textured(wall[3], 1, 0, 48)),
        "back": {
            "type": "rectangle",
            "to_world": T().translate([0.0, 2.5, 1.5]).rotate([1, 0, 0], 90).scale([4.0, 1.5, 1.0]),
            "bsdf": textured(wall[7], 1, 1, 32),
        },
        "left": {
            "type": "rectangle",
            "to_world": T().translate([-3.0, 0.0, 1.5]).rotate([0, 1, 0], 90).scale([1.5, 4.0, 1.0]),
            "bsdf": textured(wall[11], 1, 2, 32),
        },
        "right": {
            "type": "rectangle",
            "to_world": T().translate([3.0, 0.0, 1.5]).rotate([0, 1, 0], -90).scale([1.5, 4.0, 1.0]),
            "bsdf": textured(wall[19], 1, 3, 32),
        },
        "box": {
            "type": "cube",
            "to_world": T().translate([0.75, 0.45, 0.3]).rotate([0, 0, 1], 20).scale([0.32, 0.26, 0.3]),
            "bsdf": diffuse(lib[cc[14]]),
        },
        "box2": {
            "type": "cube",
            "to_world": T().translate([-0.8, 0.7, 0.2]).rotate([0, 0, 1], -30).scale([0.25, 0.25, 0.2]),
            "bsdf": diffuse(lib[cc[7]]),
        },
        "plastic": {
            "type": "sphere",
            "center": [0.1, 0.5, 0.3],
            "radius": 0.3,
            "bsdf": {
                "type": "roughplastic",
                "distribution": "ggx",
                "alpha": 0.15,
                "diffuse_reflectance": _spectrum(grid, lib[cc[11]]),
            },
        },
        "metal": {
            "type": "sphere",
            "center": [-0.35, 0.05, 0.18],
            "radius": 0.18,
            "bsdf": {"type": "roughconductor", "material": "Au", "distribution": "ggx", "alpha": 0.2},
        },
        "card": patch(
            CARD[0] + CARD[2] / 2,
            CARD[1] + CARD[2] / 2,
            CARD[2],
            CARD[2],
            2 * MITSUBA_DECAL_LIFT,
            diffuse(lib[0]),
        ),
        "chart_body": patch(
            CHART[0] + (6 * (CHART[2] + CHART[3]) + CHART[3]) / 2,
            CHART[1] + (4 * (CHART[2] + CHART[3]) + CHART[3]) / 2,
            6 * (CHART[2] + CHART[3]) + CHART[3],
            4 * (CHART[2] + CHART[3]) + CHART[3],
            MITSUBA_DECAL_LIFT,
            diffuse(lib[1]),
        ),
    }
    x0, y0, side, gap = CHART
    for i in range(6):
        for j in range(4):
            k = (3 - j) * 6 + i  # as the ray-caster: row 0 (dark skin …) farthest from the cameras
            cx = x0 + gap + i * (side + gap) + side / 2
            cy = y0 + gap + j * (side + gap) + side / 2
            d[f"patch{k:02d}"] = patch(cx, cy, side, side, 2 * MITSUBA_DECAL_LIFT, diffuse(lib[cc[k]]))
    return mi.load_dict(d)


def _texture(seed: int, key: int, cells: int) -> np.ndarray:
    """Blend weights in [0, 1] (float32, ``8·cells`` square): random values on a ``cells`` grid plus
    half as much on a grid twice as fine, constant in each cell. Corners at two scales for SIFT; the same
    for every view (seeded by the capture's seed and the surface)."""
    rng = np.random.default_rng([seed, key])
    n = 8 * cells
    coarse = np.kron(rng.uniform(0, 1, (cells, cells)), np.ones((8, 8)))
    fine = np.kron(rng.uniform(0, 1, (2 * cells, 2 * cells)), np.ones((4, 4)))
    return ((2 * coarse + fine) / 3).reshape(n, n, 1).astype(np.float32)


def _card_box(scene, view):
    """The largest pixel box [x0, y0, x1, y1) around the white card's centre whose pixels lie wholly on
    the card's projection (occluders aside: the objects stand behind the card), or None."""
    cam = scene.config.cameras[view.camera]
    x0, y0, s = CARD
    corners = np.array([[x0, y0, 0], [x0 + s, y0, 0], [x0 + s, y0 + s, 0], [x0, y0 + s, 0]], float)
    p = corners @ view.R.T + view.t
    if np.any(p[:, 2] <= 0):
        return None
    uv = view.f * p[:, :2] / p[:, 2:] + np.array([cam.width, cam.height]) / 2
    jj, ii = np.meshgrid(np.arange(cam.width + 1), np.arange(cam.height + 1))
    pts = np.stack([jj, ii], -1).astype(float)
    inside = np.ones(pts.shape[:2], bool)
    nxt = np.roll(uv, -1, axis=0)
    sign = np.sign(np.sum(uv[:, 0] * nxt[:, 1] - nxt[:, 0] * uv[:, 1]))  # the quad's orientation
    for a in range(4):
        e = nxt[a] - uv[a]
        c = e[0] * (pts[..., 1] - uv[a, 1]) - e[1] * (pts[..., 0] - uv[a, 0])
        inside &= c * sign >= 0
    full = inside[:-1, :-1] & inside[1:, :-1] & inside[:-1, 1:] & inside[1:, 1:]  # all four corners
    centre = p.mean(0)
    cu, cv = (view.f * centre[:2] / centre[2] + np.array([cam.width, cam.height]) / 2).astype(int)
    if not (0 <= cv < full.shape[0] and 0 <= cu < full.shape[1] and full[cv, cu]):
        return None
    bx0, by0, bx1, by1 = cu, cv, cu + 1, cv + 1
    grown = True
    while grown:
        grown = False
        for a, b, c, dd in ((-1, 0, 0, 0), (0, -1, 0, 0), (0, 0, 1, 0), (0, 0, 0, 1)):
            u0, v0, u1, v1 = bx0 + a, by0 + b, bx1 + c, by1 + dd
            if (
                u0 >= 0
                and v0 >= 0
                and u1 <= full.shape[1]
                and v1 <= full.shape[0]
                and full[v0:v1, u0:u1].all()
            ):
                bx0, by0, bx1, by1, grown = u0, v0, u1, v1, True
    return [bx0, by0, bx1, by1]


def _seen_chart(scene, candidates: list):
    """``(image, corners)`` of the largest candidate ``(area, image, corners, view, ij)`` whose 24 patch
    centres each see their patch (:func:`surface_labels`), or None. A patch that Mitsuba merged with
    another shape of its reflectance has no label of its own: there a uniform surface's label passes."""
    codes = LABEL_CHART + np.arange(24)
    for _, image, corners, view, ij in sorted(candidates, key=lambda c: -c[0]):
        labels = surface_labels(scene, view)
        at = labels[ij[:, 0], ij[:, 1]].astype(int)
        merged = ~np.isin(codes, labels) & (at >= LABEL_UNIFORM) & (at < LABEL_OTHER)
        if ((at == codes) | merged).all():
            return image, corners
    return None


def _check(folder: Path, size: float, views: int | None, holdout: int | None, spp: int) -> None:
    if folder.exists() and (not folder.is_dir() or any(folder.iterdir())):
        raise SplatError(f"folder {folder} exists and is not empty; choose a new or empty folder.")
    if not (np.isfinite(size) and size > 0):
        raise SplatError(f"size={size!r}: must be a positive scale of the CI image sizes (e.g. 0.25).")
    if views is not None and views < 2:
        raise SplatError(f"views={views!r}: need at least 2 training views per camera (or None).")
    if holdout is not None and holdout < 0:
        raise SplatError(f"holdout={holdout!r}: must be 0 or more held-out views per camera (or None).")
    if not (isinstance(spp, int | np.integer) and spp >= 1):
        raise SplatError(f"spp={spp!r}: must be a positive whole number of samples per pixel.")


def mitsuba_config(
    *,
    size: float = 1.0,
    views: int | None = None,
    holdout: int | None = None,
    seed: int = 0,
    noise: bool = True,
    illuminant: str = "D65",
) -> SimCaptureConfig:
    """The :class:`~splat.sim.capture.SimCaptureConfig` that :func:`write_mitsuba_capture` renders with
    these options (the CI configuration's cameras scaled by ``size`` to even sizes ≥ 22 px)."""
    base = SimCaptureConfig.ci()
    cams = tuple(
        replace(
            c, width=max(22, 2 * round(c.width * size / 2)), height=max(22, 2 * round(c.height * size / 2))
        )
        for c in base.cameras
    )
    changes = {"cameras": cams, "seed": seed, "noise": noise, "illuminant": illuminant}
    if views is not None:
        changes["n_train"] = views
    if holdout is not None:
        changes["n_holdout"] = holdout
    return replace(base, **changes)


#: Code of ColorChecker patch ``k`` in :func:`surface_labels`: ``LABEL_CHART + k``.
LABEL_CHART = 1
#: Code of a surface of one Lambertian reflectance (white card, chart body, the two boxes):
#: ``LABEL_UNIFORM + i`` (``i`` the shape's index); 0 where no surface is hit.
LABEL_UNIFORM = 100
#: Code of a textured, glossy or emitting surface (floor, walls, spheres, lamp): ``LABEL_OTHER + i``.
LABEL_OTHER = 200
_NOT_UNIFORM = ("floor", "back", "left", "right", "plastic", "metal", "lamp")


def surface_labels(scene, view) -> np.ndarray:
    """Which surface each pixel of ``view`` sees (one sample at the pixel's centre region, Mitsuba's
    ``shape_index`` AOV), coded as :data:`LABEL_CHART`, :data:`LABEL_UNIFORM` and :data:`LABEL_OTHER` say;
    uint16 of shape (H, W).

    Why: a path-traced truth is never constant over a surface (soft shadows, inter-reflection, Monte
    Carlo noise), so its uniform regions and chart patches cannot be found from the colours as on the
    ray-caster's capture; the geometry says where they are."""
    mi = _mitsuba()
    cam = scene.config.cameras[view.camera]
    film = {"type": "hdrfilm", "width": cam.width, "height": cam.height, "rfilter": {"type": "box"}}
    ones = np.ones((len(scene.wavelengths), 1))
    sc = mitsuba_scene(scene, view, ones, ones[:, 0], spp=1, film=film)
    index = np.asarray(mi.render(sc, integrator=mi.load_dict({"type": "aov", "aovs": "s:shape_index"})))
    index = np.rint(index[..., -1]).astype(int)  # 1 + the shape's index in sc.shapes(); 0: nothing hit
    codes = np.zeros(len(sc.shapes()) + 1, np.uint16)
    for i, shape in enumerate(sc.shapes()):
        name = shape.id()
        if name.startswith("patch"):
            codes[i + 1] = LABEL_CHART + int(name[5:])
        elif name in _NOT_UNIFORM:
            codes[i + 1] = LABEL_OTHER + i
        else:  # the card, and the chart body and boxes (Mitsuba keeps no id for these)
            codes[i + 1] = LABEL_UNIFORM + i
    return codes[index]


def write_surface_labels(capture: str | os.PathLike, **options) -> list[Path]:
    """Write ``truth/labels/<folder>/<stem>.tiff`` (:func:`surface_labels`) for every held-out view of a
    capture written by :func:`write_mitsuba_capture` with ``options`` (its ``size``, ``views``,
    ``holdout``, ``seed``: the scene and views are rebuilt from them); returns the files.

    Raises
    ------
    SplatError
        The folder has no ``truth/`` of this generator, or the rebuilt views' sizes differ from its
        cameras' (other options than it was written with).
    """
    import tifffile

    root = Path(capture)
    doc_path, doc = _truth_doc(root, "labels are rendered for its scene only")
    scene = build_scene(mitsuba_config(**options))
    sizes = {c["folder"]: (c["width"], c["height"]) for c in doc.get("camera", [])}
    if sizes != {c.folder: (c.width, c.height) for c in scene.config.cameras}:
        raise SplatError(
            f"{doc_path}: its camera sizes are not those of {options}; give the capture's options."
        )
    files = []
    for v in scene.views:
        if v.holdout:
            folder = scene.config.cameras[v.camera].folder
            f = root / "truth" / "labels" / folder / f"{v.stem}.tiff"
            f.parent.mkdir(parents=True, exist_ok=True)
            tifffile.imwrite(f, surface_labels(scene, v))
            files.append(f)
    return files


def _truth_doc(root: Path, why: str) -> tuple[Path, dict]:
    """``root/truth/truth.toml`` read and checked to be this generator's (else a one-line error ending
    with ``why``)."""
    import tomllib

    doc_path = root / "truth" / "truth.toml"
    try:
        doc = tomllib.loads(doc_path.read_text())
    except (OSError, tomllib.TOMLDecodeError) as e:
        raise SplatError(f"{doc_path}: not readable ({type(e).__name__}); give a Mitsuba capture.") from e
    if doc.get("generator") != _GENERATOR:
        raise SplatError(f"{doc_path}: not written by {_GENERATOR}; {why}.")
    return doc_path, doc


def _check_truth_spp(spp) -> None:
    if not (isinstance(spp, int | np.integer) and spp >= 2):
        raise SplatError(f"truth_spp={spp!r}: must be a whole number of samples per pixel, at least 2.")


def _truth_seed(seed: int, vi: int) -> int:
    """The first sampler seed of view ``vi``'s truth chunks (never a photograph's, nor another view's)."""
    return _TRUTH_SEED + (seed * 1009 + vi) * _MAX_CHUNKS


def _truth_lines(truth_spp: int | None) -> list[str]:
    if truth_spp is None:
        return ['truth = "the photograph\'s own render: its Monte Carlo noise shared with the held-out file"']
    return [
        f"truth_spp = {truth_spp}",
        'truth = "rendered on its own (splat.sim.mitsuba.truth_xyz), standard error per pixel in xyz_se/"',
    ]


def _write_xyz(path: Path, xyz: np.ndarray) -> None:
    import tifffile

    path.parent.mkdir(parents=True, exist_ok=True)
    tifffile.imwrite(path, np.asarray(xyz, np.float32), photometric="rgb")


def _rebuilt_scene(root: Path, doc: dict):
    """The scene and views of a capture from its ``truth.toml`` (``doc``): its size, views and held-out
    views as recorded (older files: from the first camera's width and the view rows)."""
    folder = doc["camera"][0]["folder"]
    rows = [r for r in doc.get("view", []) if r["image"].startswith(f"{folder}/")]
    size = doc.get("size", doc["camera"][0]["width"] / mitsuba_config().cameras[0].width)
    config = mitsuba_config(
        size=size,
        views=doc.get("views", sum(not r["holdout"] for r in rows)),
        holdout=doc.get("holdout", sum(bool(r["holdout"]) for r in rows)),
        seed=doc["seed"],
        noise=doc["noise"],
        illuminant=doc["illuminant"],
    )
    scene = build_scene(config)
    sizes = {c["folder"]: (c["width"], c["height"]) for c in doc["camera"]}
    names = {r["image"] for r in doc.get("view", [])}
    mine = {f"{config.cameras[v.camera].folder}/{v.stem}.dng" for v in scene.views}
    if sizes != {c.folder: (c.width, c.height) for c in config.cameras} or names != mine:
        raise SplatError(f"{root / 'truth' / 'truth.toml'}: its cameras or views are not this generator's.")
    return scene


def write_truth(capture: str | os.PathLike, spp: int, *, chunks: int | None = None) -> list[Path]:
    """Render again, on its own, the true XYZ of every held-out view of a capture written by
    :func:`write_mitsuba_capture` (:func:`truth_xyz` at ``spp`` samples per pixel); write it over
    ``truth/xyz/…``, its standard error to ``truth/xyz_se/…`` and ``truth_spp`` to ``truth.toml``.
    Returns the XYZ files.

    Raises
    ------
    SplatError
        A bad ``spp``, no ``truth/`` of this generator, or a ``truth.toml`` whose cameras or views the
        generator does not rebuild — before anything is rendered or written.
    """
    _check_truth_spp(spp)
    root = Path(capture)
    doc_path, doc = _truth_doc(root, "its truth cannot be rendered again")
    scene = _rebuilt_scene(root, doc)
    xyz = {}
    for vi, v in enumerate(scene.views):
        if v.holdout:
            name = f"{scene.config.cameras[v.camera].folder}/{v.stem}.tiff"
            xyz[name] = truth_xyz(
                scene,
                v,
                spp,
                scale=float(doc["render_scale"]),
                seed=_truth_seed(doc["seed"], vi),
                illuminant=doc["illuminant"],
                chunks=chunks,
            )
    files = []
    for name, (mean, se) in xyz.items():  # each file whole: written beside, then renamed
        for sub, img in (("xyz", mean), ("xyz_se", se)):
            f = root / "truth" / sub / name
            tmp = f.with_name(f".{f.name}.tmp")
            _write_xyz(tmp, img)
            os.replace(tmp, f)
        files.append(root / "truth" / "xyz" / name)
    lines = [
        ln for ln in doc_path.read_text().splitlines() if not ln.startswith(("truth_spp = ", "truth = "))
    ]
    at = next(i for i, ln in enumerate(lines) if ln.startswith("spp = ")) + 1
    text = "\n".join([*lines[:at], *_truth_lines(spp), *lines[at:]]) + "\n"
    tmp = doc_path.with_name(".truth.toml.tmp")
    tmp.write_text(text)
    os.replace(tmp, doc_path)
    return files


def write_mitsuba_capture(
    folder: str | os.PathLike,
    *,
    size: float = 1.0,
    views: int | None = None,
    holdout: int | None = None,
    spp: int = 64,
    seed: int = 0,
    noise: bool = True,
    illuminant: str = "D65",
    truth_spp: int | None = None,
) -> Path:
    """Render a three-camera capture with Mitsuba 3 and write it as DNG files, ``capture.toml``, ``truth/``.

    ``capture.toml`` marks the white card (``[white]``, the training view that sees it largest, whole
    and unclipped) and, as the ray-caster's capture does, the ColorChecker (``[chart]``: the view that
    shows it largest with every patch centre on its patch and the white patch unclipped), so that the
    report measures that photograph against the chart.

    Parameters
    ----------
    folder : path
        The capture folder to create (must be new or empty; built in a temporary sibling, renamed at the end).
    size : float
        Scale of the CI image sizes (128 × 96, 112 × 84, 136 × 90 at 1); sizes round to even pixels.
    views : int, optional
        Training views per camera (default: the CI configuration's).
    holdout : int, optional
        Held-out views per camera (their XYZ truth is rendered; default: the CI configuration's).
    spp : int
        Samples per pixel.
    seed : int
        Seeds the poses and exposures, Mitsuba's sampler and the sensor noise.
    noise : bool
        Shot and read noise (as :mod:`splat.sim.capture`).
    illuminant : str
        Built-in illuminant of both emitters (``"D65"`` or ``"A"``, any ``zonotope.illuminant`` name).
    truth_spp : int, optional
        Render the held-out views' true XYZ on their own at this many samples per pixel
        (:func:`truth_xyz`; its standard error goes to ``truth/xyz_se``). Default: the XYZ channels of
        the photograph's own render, whose Monte Carlo noise the truth then shares.

    Returns
    -------
    Path
        ``folder``.

    Raises
    ------
    SplatError
        Mitsuba missing, a non-empty ``folder``, or a bad option.
    """
    import tifffile

    import splat.colmap as cm

    out = Path(folder)
    _check(out, size, views, holdout, spp)
    if truth_spp is not None:
        _check_truth_spp(truth_spp)
    mi = _mitsuba()
    config = mitsuba_config(
        size=size, views=views, holdout=holdout, seed=seed, noise=noise, illuminant=illuminant
    )
    scene = build_scene(config)
    # film curves: G_c / (E Δλ) = S_c / m (white's largest channel 1); the observer likewise (Y_white 1)
    E, curves, xyz_curve = _curves(scene, illuminant)

    out.parent.mkdir(parents=True, exist_ok=True)
    tmp = Path(tempfile.mkdtemp(prefix=f".{out.name}.", suffix=".tmp", dir=out.parent))
    try:
        rng = np.random.default_rng(seed + 1)
        renders, k, white, charts = [], None, None, []
        for vi, v in enumerate(scene.views):
            film = np.concatenate([curves[v.camera], xyz_curve], axis=1)
            img = np.asarray(
                mi.render(mitsuba_scene(scene, v, film, E, spp=spp, seed=seed * 1009 + vi)), float
            )
            renders.append(img)
            if k is None and not v.holdout:
                box = _card_box(scene, v)
                if box is not None:
                    x0, y0, x1, y1 = box
                    # the ray-caster's units: the white card reads 0.9 in its camera's largest channel
                    k = _CARD_REFLECTANCE / float(np.median(np.max(img[y0:y1, x0:x1, :3], axis=-1)))
        if k is None:
            raise SplatError("the white card is seen whole in no training view; change size or views.")
        (tmp / "truth" / "xyz").mkdir(parents=True)
        cameras, images, view_rows = {}, {}, []
        for ci, cam in enumerate(config.cameras):
            (tmp / cam.folder).mkdir()
            f = next(v.f for v in scene.views if v.camera == ci)
            cameras[ci + 1] = cm.ColmapCamera(
                ci + 1, "PINHOLE", cam.width, cam.height, (f, f, cam.width / 2, cam.height / 2)
            )
            cm1, cm2 = _color_matrices(scene, ci)
            for vi, v in ((i, v) for i, v in enumerate(scene.views) if v.camera == ci):
                resp = k * renders[vi][..., :3]
                box = None if v.holdout else _card_box(scene, v)
                if box is not None:
                    x0, y0, x1, y1 = box
                    peak = float(np.max(v.relative_exposure * config.gain * resp[y0:y1, x0:x1]))
                    area = (x1 - x0) * (y1 - y0)
                    if peak < MITSUBA_WHITE_PEAK and (white is None or area > white[0]):
                        white = (area, f"{cam.folder}/{v.stem}.dng", box)
                seen = chart_in_view(v, cam.width, cam.height)
                if seen is not None:  # the chart's white patch unclipped, as the card
                    i, j = seen[0][18]
                    if float(np.max(v.relative_exposure * config.gain * resp[i, j])) < MITSUBA_WHITE_PEAK:
                        charts.append((seen[2], f"{cam.folder}/{v.stem}.dng", seen[1], v, seen[0]))
                dn = _raw_values(scene, v, resp, rng)
                write_view_dng(tmp / cam.folder / f"{v.stem}.dng", dn, scene, ci, v, (cm1, cm2), noise=noise)
                if v.holdout:
                    (tmp / "truth" / "labels" / cam.folder).mkdir(parents=True, exist_ok=True)
                    tifffile.imwrite(
                        tmp / "truth" / "labels" / cam.folder / f"{v.stem}.tiff", surface_labels(scene, v)
                    )
                    xyz = k * renders[vi][..., 3:]
                    if truth_spp is not None:  # rendered on its own: see truth_xyz
                        xyz, se = truth_xyz(
                            scene, v, truth_spp, scale=k, seed=_truth_seed(seed, vi), illuminant=illuminant
                        )
                        _write_xyz(tmp / "truth" / "xyz_se" / cam.folder / f"{v.stem}.tiff", se)
                    _write_xyz(tmp / "truth" / "xyz" / cam.folder / f"{v.stem}.tiff", xyz)
                iid = len(images) + 1
                images[iid] = cm.ColmapImage(
                    iid, _qvec(v.R), np.asarray(v.t, float), ci + 1, f"{cam.folder}/{v.stem}.dng"
                )
                view_rows.append(
                    {
                        "image": f"{cam.folder}/{v.stem}.dng",
                        "holdout": v.holdout,
                        "exposure_time": v.exposure_time,
                        "iso": v.iso,
                        "f_number": v.f_number,
                        "relative_exposure": v.relative_exposure,
                    }
                )
        if white is None:
            raise SplatError("the white card is seen whole and unsaturated in no training view.")
        cm.write_colmap(cm.ColmapModel(cameras, images, {}), tmp / "truth", binary=False)
        held = [f"{config.cameras[v.camera].folder}/{v.stem}.dng" for v in scene.views if v.holdout]
        text = [
            f"# Simulated capture rendered by {_GENERATOR} (seed {seed}); ground truth in truth/.",
            "# ssf_exact = true: rendered with exactly these curves. Leave it out for real cameras, whose",
            "# published curves are another unit's measurement (docs/guide/capture.rst).",
            f"illuminant = {_toml_value(illuminant)}",
            f"observer = {_toml_value(_OBSERVER)}",
            "",
        ]
        for cam in config.cameras:
            text.append(
                _toml_table("camera", {"folder": cam.folder, "ssf": cam.ssf, "ssf_exact": True}, array=True)
            )
        text.append(
            _toml_table(
                "white",
                {"method": "patch", "image": white[1], "box": white[2], "reflectance": _CARD_REFLECTANCE},
            )
        )
        chart = _seen_chart(scene, charts)
        if chart is not None:  # the photograph that shows the ColorChecker largest, whole and unoccluded
            text.append(_toml_table("chart", {"image": chart[0], "corners": chart[1]}))
        if held:
            text.append(_toml_table("holdout", {"images": held}))
        (tmp / "capture.toml").write_text("\n".join(text))
        truth = [
            f"generator = {_toml_value(_GENERATOR)}",
            f"mitsuba = {_toml_value(mi.__version__)}",
            f"variant = {_toml_value(_VARIANT)}",
            f"max_depth = {_MAX_DEPTH}",
            f"spp = {spp}",
            *_truth_lines(truth_spp),
            f"size = {size!r}",
            f"views = {config.n_train}",
            f"holdout = {config.n_holdout}",
            f"seed = {seed}",
            f"illuminant = {_toml_value(illuminant)}",
            f"observer = {_toml_value(_OBSERVER)}",
            f"gain = {config.gain}",
            f"noise = {_toml_value(noise)}",
            f"render_scale = {k!r}",
            'xyz_scale = "render_scale * rendered XYZ; perfect white under the illuminant, fully lit as the '
            'card, has Y = 1 / 0.9 of the card"',
            "",
        ]
        for ci, cam in enumerate(config.cameras):
            dc = {
                "folder": cam.folder,
                "ssf": cam.ssf,
                "cfa": cam.cfa,
                "width": cam.width,
                "height": cam.height,
            }
            dc["as_shot_neutral"] = [float(x) for x in scene.neutrals[ci]]
            dc["focal_px"] = cameras[ci + 1].params[0]
            truth.append(_toml_table("camera", dc, array=True))
        for row in view_rows:
            truth.append(_toml_table("view", row, array=True))
        (tmp / "truth" / "truth.toml").write_text("\n".join(truth))
        if out.exists():
            out.rmdir()
        os.replace(tmp, out)
    finally:
        if tmp.exists():
            shutil.rmtree(tmp, ignore_errors=True)
    return out


def main(argv: list[str] | None = None) -> int:
    """``python -m splat.sim.mitsuba OUT [--size S] [--spp N] [--views N] [--holdout N] [--seed N] …``."""
    import argparse
    import sys
    import time

    parser = argparse.ArgumentParser(
        prog="python -m splat.sim.mitsuba",
        description="Render a physically based three-camera RAW capture with Mitsuba 3 "
        "(DNG, capture.toml, truth/).",
    )
    parser.add_argument("out", help="capture folder to create (new or empty)")
    parser.add_argument("--size", type=float, default=1.0, help="scale of the CI image sizes (default 1)")
    parser.add_argument("--spp", type=int, default=64, help="samples per pixel (default 64)")
    parser.add_argument("--views", type=int, default=None, help="training views per camera")
    parser.add_argument("--holdout", type=int, default=None, help="held-out views per camera")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--illuminant", default="D65")
    parser.add_argument("--no-noise", action="store_true", help="noise-free forward model")
    parser.add_argument(
        "--truth-spp",
        type=int,
        default=None,
        help="render the held-out views' true XYZ on their own at this many samples per pixel "
        "(default: the photograph's own render, with its noise)",
    )
    args = parser.parse_args(argv)
    t = time.perf_counter()
    try:
        out = write_mitsuba_capture(
            args.out,
            size=args.size,
            views=args.views,
            holdout=args.holdout,
            spp=args.spp,
            seed=args.seed,
            noise=not args.no_noise,
            illuminant=args.illuminant,
            truth_spp=args.truth_spp,
        )
    except (SplatError, OSError) as exc:  # one line on stderr, no traceback
        print(f"splat.sim.mitsuba: error: {' '.join(str(exc).split())}", file=sys.stderr)
        return 2
    n = sum(1 for _ in out.glob("*/*.dng"))
    print(f"wrote {out} ({n} DNG files) in {time.perf_counter() - t:.1f} s")
    return 0


if __name__ == "__main__":  # pragma: no cover
    raise SystemExit(main())
