"""A realistic simulated multi-camera capture written as real files (DNG + ``capture.toml`` + ``truth/``).

A textured 3-D scene — a floor carrying a ColorChecker chart and a flat white reference card, boxes, spheres
and a capped cylinder inside a textured backdrop — is ray-cast exactly in numpy (``supersample²`` rays per
pixel, box-filtered) from views on an arc around it, by three cameras with measured spectral sensitivities.
Every surface point carries a real reflectance: a convex mix of at most three measured spectra (Voronoi
cells of a palette, a smooth noise mixing two of them, dark cell borders) times a Lambertian shading factor
in [0.4, 1] (1 on the floor), so each pixel's spectrum is a convex combination of measured reflectances.

Per pixel, the spectrum ``R(λ)`` (on the cameras' common grid) gives each camera's raw response and the
true XYZ::

    response_c = R @ G_c / max(white @ G_c),  G_c = S_c(λ) E(λ) Δλ            (white's largest channel → 1)
    XYZ        = R @ Ψ,                      Ψ = x̄ȳz̄(λ) E(λ) Δλ / Σ ȳ E Δλ   (Y_white = 1)
    fraction   = gain · k · response_c,      k = (t · ISO / N²) / median over all views
    e⁻         ~ Poisson(fraction · full_well · 100 / ISO)                       (shot noise)
    DN         = black + e⁻ / (full_well · 100 / ISO) · (white − black) + N(0, read_noise²)

rounded and clipped to [0, white] (saturation). One ``gain`` for all cameras, so EXIF exposure alone relates
the brightness of every view of every camera. Bayer cameras are written as CFA DNGs, the full-colour
(Foveon-type) camera as a LinearRaw DNG, with ColorMatrix1/2 (fitted for illuminants A and D65 on the
ColorChecker, :func:`isp.fit_color_matrix`), CalibrationIlluminant1/2, AsShotNeutral, BlackLevel,
WhiteLevel, EXIF ExposureTime / ISOSpeedRatings / FNumber, Make / Model / UniqueCameraModel.

The folder follows ``CAPTURE_FORMAT`` (see the README): ``capture.toml``, one folder per camera,
``truth/`` (COLMAP text model of the true poses, float32 XYZ TIFFs of the held-out views, ``truth.toml``).
"""

from __future__ import annotations

import json
import os
import shutil
import tempfile
from dataclasses import asdict, dataclass, field, replace
from pathlib import Path

import numpy as np

from .._errors import SplatError
from .._tol import GRID_NM, PURE_WEIGHT, TRACK_VISIBLE_ATOL, TRACK_VISIBLE_RTOL
from .geometry import CARD, CHART, chart_in_view, shade

__all__ = [
    "SimCamera",
    "SimCaptureConfig",
    "SimScene",
    "SimView",
    "build_scene",
    "write_synthetic_capture",
    "write_view_dng",
]

_GENERATOR = "splat.simcapture"  # the id written into truth.json; captures on disk carry it
_OBSERVER = "CIE 1931 2 Degree Standard Observer"


@dataclass(frozen=True)
class SimCamera:
    """One simulated physical camera.

    Attributes
    ----------
    folder : str
        Sub-folder of the capture.
    ssf : str
        Built-in camera name (``zonotope.CAMERAS``).
    make, model : str
        DNG Make / Model tags.
    prefix : str
        File name prefix (``DSC_`` → ``DSC_0001.dng``).
    width, height : int
        Image size in pixels (even; ≥ 22 so LibRaw reads it).
    fov_deg : float
        Horizontal field of view (sets the focal length in pixels).
    cfa : str or None
        Bayer pattern, or None for a full-colour sensor (LinearRaw DNG).
    black_level, white_level : int
        In DN.
    full_well : float
        Electrons at saturation at ISO 100.
    read_noise : float
        Read noise standard deviation in DN.
    radius, eye_height : float
        Orbit radius and camera height (m).
    azimuth_offset : float
        Degrees added to the orbit's azimuths (the cameras' views interleave).
    """

    folder: str
    ssf: str
    make: str
    model: str
    prefix: str
    width: int
    height: int
    fov_deg: float
    cfa: str | None
    black_level: int
    white_level: int
    full_well: float = 30000.0
    read_noise: float = 2.0
    radius: float = 3.0
    eye_height: float = 1.6
    azimuth_offset: float = 0.0


def _default_cameras(scale: float) -> tuple[SimCamera, ...]:
    def size(w, h):
        return 2 * round(w * scale / 2), 2 * round(h * scale / 2)

    nw, nh = size(128, 96)
    sw, sh = size(112, 84)
    cw, ch = size(136, 90)
    return (
        SimCamera(
            "nikon",
            "Nikon 5100 (NPL)",
            "NIKON CORPORATION",
            "NIKON D5100",
            "DSC_",
            nw,
            nh,
            62.0,
            "RGGB",
            0,
            16383,
            25000.0,
            3.0,
            3.0,
            2.0,
            0.0,
        ),
        SimCamera(
            "sigma",
            "Sigma SDMerill (NPL)",
            "SIGMA",
            "SIGMA SD1 Merrill",
            "SDIM",
            sw,
            sh,
            54.0,
            None,
            64,
            4095,
            12000.0,
            1.5,
            3.3,
            2.2,
            4.0,
        ),
        SimCamera(
            "canon",
            "Canon EOS 5D Mark II",
            "Canon",
            "Canon EOS 5D Mark II",
            "IMG_",
            cw,
            ch,
            48.0,
            "GBRG",
            1024,
            15520,
            60000.0,
            4.0,
            3.6,
            1.9,
            -4.0,
        ),
    )


@dataclass(frozen=True)
class SimCaptureConfig:
    """Options of :func:`write_synthetic_capture`; :meth:`ci` and :meth:`benchmark` give the two sizes.

    Attributes
    ----------
    cameras : tuple of SimCamera
    n_train : int
        Training views per camera.
    n_holdout : int
        Held-out views per camera (between training views).
    arc_deg : float
        Azimuth span of each camera's views.
    supersample : int
        Rays per pixel along each axis (≥ 2 for anti-aliasing).
    illuminant : str
        Built-in illuminant (``zonotope.illuminant``).
    interval : float
        Wavelength step (nm) of the common grid.
    gain : float
        Fraction of the raw range reached by the white's largest channel at relative exposure 1.
    noise : bool
        Shot and read noise (False: the noise-free forward model, rounded to DN).
    max_stops : float
        Exposures vary within about ±``max_stops`` stops around the median.
    cell : float or None
        Voronoi cell size (m) of the floor texture; the other surfaces scale from it. Default (None):
        0.2 for the fine texture, 0.5 for the coarse one (:attr:`cell_size`).
    texture : {"fine", "coarse"}
        ``"fine"`` (default): cells mixed with smaller cells and a smooth noise, dark borders — texture at
        the pixel scale, which SIFT likes and demosaicing does not. ``"coarse"``: one constant measured
        reflectance per cell with a thin dark border, and floor cells that grow with the distance from the
        centre (``1 + r/1 m`` times), so that with ``cell ≈ 0.5`` most pixels of every view lie inside a
        flat patch several Bayer periods wide (a fair test of colour rather than of demosaicing): at the CI
        size about 25 % of the pixels have a constant true colour over their 5 × 5 neighbourhood, against
        1 % with the fine texture.
    seed : int
    extra_reflectances : tuple of str
        More reflectance sets (built-in names or files ``zonotope.load_reflectances`` reads, e.g. the
        Munsell or SFU sets in ``../shared/data``) added to the palettes of the floor, the backdrop and
        the natural-coloured objects. Default none, so the capture depends on the package alone.
    """

    cameras: tuple[SimCamera, ...] = field(default_factory=lambda: _default_cameras(1.0))
    n_train: int = 6
    n_holdout: int = 2
    arc_deg: float = 100.0
    supersample: int = 2
    illuminant: str = "D65"
    interval: float = 5.0
    gain: float = 0.6
    noise: bool = True
    max_stops: float = 1.0
    cell: float | None = None
    texture: str = "fine"
    seed: int = 0
    extra_reflectances: tuple[str, ...] = ()

    @property
    def cell_size(self) -> float:
        """The texture's cell size in metres (``cell``, or its default for the texture)."""
        if self.cell is not None:
            return float(self.cell)
        return 0.5 if self.texture == "coarse" else 0.2

    @classmethod
    def ci(cls, **changes) -> SimCaptureConfig:
        """3 cameras × (6 training + 2 held-out) views at about 128 × 96 (writes in a few seconds)."""
        return replace(cls(), **changes)

    @classmethod
    def benchmark(cls, **changes) -> SimCaptureConfig:
        """3 cameras × (16 training + 4 held-out) views at about 480 × 360."""
        return replace(cls(cameras=_default_cameras(3.75), n_train=16, n_holdout=4, arc_deg=150.0), **changes)


@dataclass(frozen=True, eq=False)
class SimView:
    """One view: camera index, file stem, pose ``cam_from_world`` (R, t), intrinsics, EXIF, role."""

    camera: int
    stem: str
    R: np.ndarray
    t: np.ndarray
    f: float
    exposure_time: float
    iso: int
    f_number: float
    holdout: bool
    relative_exposure: float = 1.0


@dataclass(frozen=True, eq=False)
class SimScene:
    """The scene and its spectral setup (built by :func:`build_scene`).

    Attributes
    ----------
    config : SimCaptureConfig
    wavelengths : ndarray of shape (n,)
    library : ndarray of shape (K, n)
        Every reflectance the scene uses (row 0: the flat white card, row 1: the chart's black).
    library_names : list of str
    camera_generators : list of ndarray of shape (n, 3)
        Un-balanced, white's largest channel = 1.
    neutrals : list of ndarray of shape (3,)
        White response of each camera (AsShotNeutral).
    observer : ndarray of shape (n, 3)
        XYZ generators, Y_white = 1.
    views : list of SimView
    palettes : dict
    """

    config: SimCaptureConfig
    wavelengths: np.ndarray
    library: np.ndarray
    library_names: list
    camera_generators: list
    neutrals: list
    observer: np.ndarray
    views: list
    palettes: dict

    # -------------------------------------------------------------------------------- rendering
    def rays(self, view: SimView, u, v) -> tuple[np.ndarray, np.ndarray]:
        """The camera centre (3,) and the unit world directions (n, 3) of the rays through pixel
        positions ``u``, ``v`` (n,) (pixel ``(i, j)`` spans ``[j, j + 1) × [i, i + 1)``)."""
        cam = self.config.cameras[view.camera]
        u, v = np.asarray(u, float), np.asarray(v, float)
        d_cam = np.stack([(u - cam.width / 2) / view.f, (v - cam.height / 2) / view.f, np.ones_like(u)], -1)
        d = d_cam @ view.R  # world directions (R^T d)
        d /= np.linalg.norm(d, axis=1, keepdims=True)
        return -view.R.T @ view.t, d

    def trace(self, view: SimView) -> tuple[np.ndarray, np.ndarray]:
        """Ray-cast a view: per sample ray the library indices and weights of its spectrum.

        Returns
        -------
        idx : ndarray of shape (H, W, s², 3), int
        wts : ndarray of shape (H, W, s², 3)
            The spectrum of a sample is ``Σ_k wts[..., k] · library[idx[..., k]]`` (shading included).
        """
        cam = self.config.cameras[view.camera]
        s = self.config.supersample
        H, W = cam.height, cam.width
        off = (np.arange(s) + 0.5) / s
        u = np.arange(W)[None, :, None, None] + off[None, None, None, :]
        v = np.arange(H)[:, None, None, None] + off[None, None, :, None]
        u, v = np.broadcast_arrays(u, v)
        o, d = self.rays(view, u.ravel(), v.ravel())
        idx, wts, _ = shade(self, o, d)
        return idx.reshape(H, W, s * s, 3), wts.reshape(H, W, s * s, 3)

    def render(self, view: SimView, functional) -> np.ndarray:
        """Box-filtered image of a linear functional of the spectrum.

        Parameters
        ----------
        view : SimView
        functional : array_like of shape (K, c)
            Its value for each library reflectance (e.g. ``library @ G``; ``library`` itself gives the
            pixels' mean spectra).

        Returns
        -------
        ndarray of shape (H, W, c)
        """
        F = np.asarray(functional, dtype=np.float64)
        idx, wts = self.trace(view)
        return np.einsum("hwsk,hwskc->hwc", wts, F[idx]) / idx.shape[2]

    def responses(self, view: SimView) -> np.ndarray:
        """Noise-free raw responses (H, W, 3) of the view's camera at relative exposure 1."""
        return self.render(view, self.library @ self.camera_generators[view.camera])

    def XYZ(self, view: SimView) -> np.ndarray:
        """True CIE 1931 XYZ (H, W, 3), Y_white = 1."""
        return self.render(view, self.library @ self.observer)


# ----------------------------------------------------------------------------------- spectral setup
def _resample(msds, grid: np.ndarray) -> np.ndarray:
    w = np.asarray(msds.wavelengths, dtype=np.float64)
    v = np.asarray(msds.values, dtype=np.float64).reshape(len(w), -1)
    if grid[0] < w[0] - GRID_NM or grid[-1] > w[-1] + GRID_NM:
        raise SplatError(
            f"reflectance set {msds.name!r} covers {w[0]:g}–{w[-1]:g} nm, not the grid "
            f"{grid[0]:g}–{grid[-1]:g} nm; choose another set."
        )
    return np.clip(np.stack([np.interp(grid, w, v[:, j]) for j in range(v.shape[1])], 0), 0.0, 1.0)


def _look_at(eye, target):
    eye, target = np.asarray(eye, float), np.asarray(target, float)
    z = target - eye
    z /= np.linalg.norm(z)
    x = np.cross(z, [0.0, 0.0, 1.0])
    x /= np.linalg.norm(x)
    y = np.cross(z, x)
    R = np.stack([x, y, z])
    return R, -R @ eye


_TIMES = (1 / 25, 1 / 30, 1 / 40, 1 / 50, 1 / 60, 1 / 80, 1 / 100, 1 / 125, 1 / 160, 1 / 200, 1 / 250)
_ISOS = (100, 200, 400, 800)
_FNUMBERS = (4.0, 5.6, 8.0)


def build_scene(config: SimCaptureConfig = SimCaptureConfig()) -> SimScene:
    """The scene, its reflectance library, the cameras' generators and every view's pose and EXIF.

    Raises
    ------
    SplatError
        A configuration that cannot be simulated (too few views, odd or tiny image sizes, unknown names).
    """
    import zonotope
    from isp.simulate import spectral_setup

    _check_config(config)
    cams = [zonotope.camera(c.ssf) for c in config.cameras]
    light = zonotope.illuminant(config.illuminant)
    obs = zonotope.observer("CIE 1931 2°")
    sets = {name: zonotope.reflectances(name) for name in zonotope.list_builtin()["reflectances"]}
    extra = []
    for source in config.extra_reflectances:
        try:
            extra.append(zonotope.load_reflectances(source))
        except (zonotope.ZonotopeError, OSError) as exc:
            raise SplatError(f"extra_reflectances: cannot load {source!r} ({exc}).") from exc
    shape = zonotope.common_shape(*cams, obs, light, *sets.values(), *extra, interval=config.interval)
    grid = np.asarray(shape.wavelengths, dtype=np.float64)
    setups = [spectral_setup(c, illuminant=config.illuminant, shape=shape) for c in cams]
    rows, names = [np.full(grid.size, 0.9)], ["flat white 0.9"]
    cc = _resample(sets["ColorChecker N Ohta"], grid)
    rows.append(cc[18 + 5])  # the chart's black patch: the dark cell borders and the chart body
    names.append("ColorChecker N Ohta: black")
    palettes: dict[str, list[int]] = {}
    for key, name in [
        ("colorchecker", "ColorChecker N Ohta"),
        ("babel", "BabelColor Average"),
        ("natural", "rawtoaces 190"),
        ("tcs", "CIE 1995 TCS"),
        ("cqs", "NIST CQS 9.0"),
    ]:
        R = _resample(sets[name], grid)
        palettes[key] = list(range(len(rows), len(rows) + len(R)))
        rows += list(R)
        names += [f"{name}: {lab}" for lab in sets[name].labels]
    for k, msds in enumerate(extra):
        R = _resample(msds, grid)
        palettes["natural"] += list(range(len(rows), len(rows) + len(R)))
        rows += list(R)
        names += [f"{config.extra_reflectances[k]}: {lab}" for lab in msds.labels]
    pal = {k: np.asarray(v) for k, v in palettes.items()}
    pal["chart"] = np.concatenate([pal["colorchecker"], pal["babel"]])
    pal["test"] = np.concatenate([pal["tcs"], pal["cqs"], pal["babel"]])
    pal["wall"] = np.concatenate([pal["natural"], pal["cqs"], pal["colorchecker"][18:]])
    library = np.asarray(rows)
    views = _views(config)
    return SimScene(
        config=config,
        wavelengths=grid,
        library=library,
        library_names=names,
        camera_generators=[s.camera for s in setups],
        neutrals=[s.neutral for s in setups],
        observer=setups[0].observer,
        views=views,
        palettes=pal,
    )


def _check_config(config: SimCaptureConfig) -> None:
    import zonotope

    if not config.cameras:
        raise SplatError("SimCaptureConfig.cameras is empty; give at least one SimCamera.")
    if len({c.folder for c in config.cameras}) != len(config.cameras):
        raise SplatError(
            f"SimCaptureConfig.cameras: folders must differ; got {[c.folder for c in config.cameras]}."
        )
    if config.n_train < 2 or config.n_holdout < 0 or config.n_holdout > config.n_train - 1:
        raise SplatError(
            f"n_train={config.n_train}, n_holdout={config.n_holdout}: need n_train ≥ 2 and "
            "0 ≤ n_holdout ≤ n_train − 1 (held-out views lie between training views)."
        )
    if config.supersample < 1:
        raise SplatError(f"supersample={config.supersample}: must be ≥ 1 (2 or more anti-aliases).")
    if config.texture not in ("fine", "coarse"):
        raise SplatError(f"texture={config.texture!r}: choose 'fine' or 'coarse'.")
    if config.cell is not None and not (np.isfinite(config.cell) and config.cell > 0):
        raise SplatError(f"cell={config.cell!r}: must be a positive size in metres (e.g. 0.2).")
    if not 0 < config.gain <= 1:
        raise SplatError(f"gain={config.gain}: must lie in (0, 1] (fraction of the raw range).")
    for c in config.cameras:
        if c.width % 2 or c.height % 2 or min(c.width, c.height) < 22:
            raise SplatError(
                f"camera {c.folder!r}: size {c.width} × {c.height} must be even and ≥ 22 px "
                "a side (LibRaw refuses smaller DNGs)."
            )
        if c.ssf not in zonotope.CAMERAS:
            raise SplatError(
                f"camera {c.folder!r}: ssf={c.ssf!r} is not a built-in camera; choose one of "
                f"{sorted(zonotope.CAMERAS)}."
            )
        if not 0 <= c.black_level < c.white_level <= 65535:
            raise SplatError(
                f"camera {c.folder!r}: need 0 ≤ black_level ({c.black_level}) < white_level "
                f"({c.white_level}) ≤ 65535."
            )


def _views(config: SimCaptureConfig) -> list[SimView]:
    rng = np.random.default_rng(config.seed)
    views: list[SimView] = []
    nt, nh = config.n_train, config.n_holdout
    # held-out views at the midpoints of evenly spread gaps between training views
    gaps = np.unique(np.round(np.linspace(0, nt - 2, nh)).astype(int)) if nh else np.array([], int)
    for ci, cam in enumerate(config.cameras):
        positions = [(float(k), False) for k in range(nt)] + [(g + 0.5, True) for g in gaps]
        positions.sort()
        for num, (pos, hold) in enumerate(positions, start=1):
            az = np.radians(cam.azimuth_offset - 90 + config.arc_deg * (pos / (nt - 1) - 0.5))
            eye = (
                cam.radius * np.cos(az),
                cam.radius * np.sin(az),
                cam.eye_height + 0.15 * np.sin(2.3 * pos + ci),
            )
            target = (0.05 * np.sin(1.7 * pos), -0.2 + 0.05 * np.cos(1.3 * pos + ci), 0.25)
            R, t = _look_at(eye, target)
            f = 0.5 * cam.width / np.tan(np.radians(cam.fov_deg) / 2)
            views.append(
                SimView(
                    ci,
                    f"{cam.prefix}{num:04d}",
                    R,
                    t,
                    float(f),
                    float(rng.choice(_TIMES)),
                    int(rng.choice(_ISOS)),
                    float(rng.choice(_FNUMBERS)),
                    hold,
                )
            )
    # keep every exposure within ±max_stops of the median by re-drawing the time
    P = np.array([v.exposure_time * v.iso / v.f_number**2 for v in views])
    med = np.median(P)
    out = []
    for v in views:
        p = v.exposure_time * v.iso / v.f_number**2
        if abs(np.log2(p / med)) > config.max_stops:
            target = med * 2.0 ** rng.uniform(-config.max_stops, config.max_stops)
            ts = np.array(_TIMES)
            t = float(ts[np.argmin(np.abs(np.log2(ts * v.iso / v.f_number**2 / target)))])
            v = replace(v, exposure_time=t)
        out.append(v)
    P = np.array([v.exposure_time * v.iso / v.f_number**2 for v in out])
    med = np.median(P)
    return [replace(v, relative_exposure=float(p / med)) for v, p in zip(out, P)]


# ------------------------------------------------------------------------------------------ writing
def _raw_values(scene: SimScene, view: SimView, responses: np.ndarray, rng) -> np.ndarray:
    """DN image (H, W) for a Bayer camera, (H, W, 3) for a full-colour one (uint16)."""
    from isp.cfa import cfa_masks

    cam = scene.config.cameras[view.camera]
    frac = scene.config.gain * view.relative_exposure * responses
    if cam.cfa is not None:
        frac = np.sum(frac * cfa_masks(frac.shape[:2], cam.cfa), axis=-1)
    span = cam.white_level - cam.black_level
    if scene.config.noise:
        well = cam.full_well * 100.0 / view.iso
        frac = rng.poisson(np.clip(frac, 0, None) * well) / well
        dn = cam.black_level + frac * span + rng.normal(0.0, cam.read_noise, size=frac.shape)
    else:
        dn = cam.black_level + frac * span
    return np.clip(np.round(dn), 0, cam.white_level).astype(np.uint16)


def _noise_profile(cam: SimCamera, view: SimView) -> tuple[float, float]:
    """The exact DNG NoiseProfile ``(S, O)`` of :func:`_raw_values`' noise (one pair for every colour).

    In units of the linear signal ``x = (DN − black) / (white − black)``: shot noise
    ``Var(Poisson(x·well) / well) = x / well`` (``well = full_well · 100 / ISO``), so ``S = 1 / well``;
    read noise and the rounding to DN (uniform, 1/12 DN²), ``O = (read_noise² + 1/12) / span²``.
    Clipping at 0 and at the white level lowers the noise within a few σ of black (cameras without a
    black offset) and at saturation.
    """
    well = cam.full_well * 100.0 / view.iso
    span = cam.white_level - cam.black_level
    return 1.0 / well, (cam.read_noise**2 + 1.0 / 12.0) / span**2


def _color_matrices(scene: SimScene, ci: int):
    import zonotope
    from isp.simulate import fit_color_matrix, spectral_setup

    cam = zonotope.camera(scene.config.cameras[ci].ssf)
    training = scene.library[scene.palettes["colorchecker"]]
    grid = scene.wavelengths
    out = []
    for name in ("A", "D65"):
        setup = spectral_setup(cam, illuminant=name, shape=grid)
        out.append(fit_color_matrix(setup, training))
    return out


def _chart_corners(scene, view, idx: np.ndarray):
    """The ``[chart] corners`` of ``view`` and the chart's area in pixels (:func:`chart_in_view`); None
    unless every patch's centre pixel sees that patch alone (the chart whole and unoccluded)."""
    cam = scene.config.cameras[view.camera]
    seen = chart_in_view(view, cam.width, cam.height)
    if seen is None:
        return None
    (i, j), chart = seen[0].T, scene.palettes["colorchecker"]
    if not all((idx[i[n], j[n], :, 0] == chart[n]).all() for n in range(24)):
        return None
    return seen[1], seen[2]


def _white_box(idx: np.ndarray, wts: np.ndarray):
    """The largest pixel box [x0, y0, x1, y1) grown from the white card's centre with every sample ray on
    the card, or None where the card is not seen whole."""
    pure = (idx[..., 0] == 0) & (wts[..., 0] > PURE_WEIGHT) & (wts[..., 1] == 0) & (wts[..., 2] == 0)
    full = np.all(pure, axis=2)
    ys, xs = np.nonzero(full)
    if not len(ys):
        return None
    cy, cx = int(np.median(ys)), int(np.median(xs))
    if not full[cy, cx]:
        return None
    x0, y0, x1, y1 = cx, cy, cx + 1, cy + 1
    grown = True
    while grown:
        grown = False
        for dx0, dy0, dx1, dy1 in ((-1, 0, 0, 0), (0, -1, 0, 0), (0, 0, 1, 0), (0, 0, 0, 1)):
            a, b, c, d = x0 + dx0, y0 + dy0, x1 + dx1, y1 + dy1
            if a >= 0 and b >= 0 and c <= full.shape[1] and d <= full.shape[0] and full[b:d, a:c].all():
                x0, y0, x1, y1, grown = a, b, c, d, True
    return [x0, y0, x1, y1]


def _toml_value(v) -> str:
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, int | np.integer):
        return str(int(v))
    if isinstance(v, float | np.floating):
        return repr(float(v))
    if isinstance(v, str):
        return json.dumps(v, ensure_ascii=False)
    if isinstance(v, list | tuple | np.ndarray):
        return "[" + ", ".join(_toml_value(x) for x in v) + "]"
    if isinstance(v, dict):
        return "{" + ", ".join(f"{json.dumps(str(k))} = {_toml_value(x)}" for k, x in v.items()) + "}"
    raise TypeError(f"no TOML form for {type(v).__name__}")


def _toml_table(name: str, d: dict, array: bool = False) -> str:
    head = f"[[{name}]]" if array else f"[{name}]"
    return "\n".join([head, *(f"{k} = {_toml_value(v)}" for k, v in d.items() if v is not None)]) + "\n"


def _qvec(R: np.ndarray) -> np.ndarray:
    from scipy.spatial.transform import Rotation

    x, y, z, w = Rotation.from_matrix(R).as_quat()
    q = np.array([w, x, y, z])
    return -q if q[0] < 0 else q


def _is_simulator_output(path: Path) -> bool:
    import tomllib

    truth = path / "truth" / "truth.toml"
    try:
        return tomllib.loads(truth.read_text()).get("generator") == _GENERATOR
    except (OSError, ValueError):
        return False


def write_view_dng(
    path, values: np.ndarray, scene: SimScene, camera: int, view: SimView, matrices, *, noise: bool
):
    """Write one simulated photograph as a DNG file: its raw values (:func:`_raw_values`), camera
    ``camera``'s CFA, levels, make and model, the two colour matrices ``matrices`` (standard illuminant
    A, D65: :func:`_color_matrices`), the white's neutral, the view's EXIF exposure and, when ``noise``,
    its NoiseProfile.

    Why one writer: both simulators (the ray-caster here and :mod:`splat.sim.mitsuba`) must write their
    files the same way, so that a difference between their captures is one of the images alone.

    Parameters
    ----------
    path : path
    values : ndarray of shape (H, W) or (H, W, 3)
        Digital numbers (a CFA mosaic, or three values per pixel for a full-colour camera).
    scene : SimScene
    camera : int
        Index of the camera in ``scene.config.cameras``.
    view : SimView
    matrices : pair of arrays of shape (3, 3)
        ColorMatrix1 and ColorMatrix2.
    noise : bool
        Whether the values carry sensor noise. Noise-free files carry no NoiseProfile: the DNG SDK
        requires S > 0, and the rounding alone is not sensor noise (readers then estimate it).
    """
    from isp.dng import write_dng

    cam = scene.config.cameras[camera]
    write_dng(
        path,
        values,
        cfa=cam.cfa or "RGGB",
        black_level=cam.black_level,
        white_level=cam.white_level,
        color_matrix_1=matrices[0],
        calibration_illuminant_1=17,
        color_matrix_2=matrices[1],
        calibration_illuminant_2=21,
        as_shot_neutral=scene.neutrals[camera],
        make=cam.make,
        model=cam.model,
        exposure_time=view.exposure_time,
        iso=view.iso,
        f_number=view.f_number,
        noise_profile=_noise_profile(cam, view) if noise else None,
    )


def write_synthetic_capture(
    out_dir: str | os.PathLike, config: SimCaptureConfig | None = None, *, overwrite: bool = False
) -> Path:
    """Simulate a three-camera capture and write it as RAW files, ``capture.toml`` and ``truth/``.

    Parameters
    ----------
    out_dir : path
        The capture folder to create (built in a temporary sibling folder, renamed at the end).
    config : SimCaptureConfig, optional
        Default :meth:`SimCaptureConfig.ci`; :meth:`SimCaptureConfig.benchmark` for the large size.
    overwrite : bool
        Replace ``out_dir`` if it holds a previous output of this simulator (never anything else).

    Returns
    -------
    Path
        ``out_dir``.

    Raises
    ------
    SplatError
        ``out_dir`` exists and is not empty (and is not a simulator output with ``overwrite=True``), or a
        bad configuration.

    Examples
    --------
    >>> from splat.sim.capture import SimCaptureConfig, write_synthetic_capture
    >>> write_synthetic_capture("capture", SimCaptureConfig.ci())  # doctest: +SKIP
    """
    import tifffile

    import splat.colmap as cm

    config = SimCaptureConfig.ci() if config is None else config
    out = Path(out_dir)
    if out.exists() and (not out.is_dir() or any(out.iterdir())):
        if not (overwrite and out.is_dir() and _is_simulator_output(out)):
            raise SplatError(
                f"out_dir {out} exists and is not empty"
                + (
                    " and is not an output of splat.sim.capture; choose an empty or new folder."
                    if overwrite
                    else "; choose a new folder, or pass overwrite=True to replace a previous"
                    " simulator output."
                )
            )
    scene = build_scene(config)
    out.parent.mkdir(parents=True, exist_ok=True)
    tmp = Path(tempfile.mkdtemp(prefix=f".{out.name}.", suffix=".tmp", dir=out.parent))
    try:
        rng = np.random.default_rng(config.seed + 1)
        (tmp / "truth" / "xyz").mkdir(parents=True)
        cameras, images, view_rows, white, chart = {}, {}, [], None, None
        image_ids = {}  # index in scene.views → COLMAP image id
        for ci, cam in enumerate(config.cameras):
            (tmp / cam.folder).mkdir()
            cameras[ci + 1] = cm.ColmapCamera(ci + 1, "PINHOLE", cam.width, cam.height, ())
            cm1, cm2 = _color_matrices(scene, ci)
            for vi, v in ((i, v) for i, v in enumerate(scene.views) if v.camera == ci):
                idx, wts = scene.trace(v)
                resp = (
                    np.einsum("hwsk,hwskc->hwc", wts, (scene.library @ scene.camera_generators[ci])[idx])
                    / idx.shape[2]
                )
                dn = _raw_values(scene, v, resp, rng)
                box = None if v.holdout else _white_box(idx, wts)
                if box is not None:
                    x0, y0, x1, y1 = box
                    peak = float(np.max(v.relative_exposure * config.gain * resp[y0:y1, x0:x1]))
                    area = (x1 - x0) * (y1 - y0)
                    if peak < 0.9 and (white is None or area > white[0]):
                        white = (area, f"{cam.folder}/{v.stem}.dng", box)
                seen = _chart_corners(scene, v, idx)
                if seen is not None and (chart is None or seen[1] > chart[0]):
                    chart = (seen[1], f"{cam.folder}/{v.stem}.dng", seen[0])
                write_view_dng(
                    tmp / cam.folder / f"{v.stem}.dng", dn, scene, ci, v, (cm1, cm2), noise=config.noise
                )
                if v.holdout:
                    XYZ = (
                        np.einsum("hwsk,hwskc->hwc", wts, (scene.library @ scene.observer)[idx])
                        / idx.shape[2]
                    )
                    (tmp / "truth" / "xyz" / cam.folder).mkdir(exist_ok=True)
                    tifffile.imwrite(
                        tmp / "truth" / "xyz" / cam.folder / f"{v.stem}.tiff",
                        XYZ.astype(np.float32),
                        photometric="rgb",
                    )
                iid = len(images) + 1
                image_ids[vi] = iid
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
        # intrinsics (one COLMAP camera per physical camera: all its views share the focal length)
        for ci, cam in enumerate(config.cameras):
            f = next(v.f for v in scene.views if v.camera == ci)
            cameras[ci + 1] = cm.ColmapCamera(
                ci + 1, "PINHOLE", cam.width, cam.height, (f, f, cam.width / 2, cam.height / 2)
            )
        points, keypoints = _surface_points(scene, image_ids)
        for iid, (xys, pids) in keypoints.items():
            images[iid] = replace(images[iid], xys=xys, point3D_ids=pids)
        cm.write_colmap(cm.ColmapModel(cameras, images, points), tmp / "truth", binary=False)
        if white is None:
            raise SplatError(
                "the white card is seen whole and unsaturated in no training view; change the "
                "cameras' orbits or lower SimCaptureConfig.gain."
            )
        holdout = [f"{config.cameras[v.camera].folder}/{v.stem}.dng" for v in scene.views if v.holdout]
        text = [
            f"# Simulated capture written by {_GENERATOR} (seed {config.seed}); ground truth in truth/.",
            "# ssf_exact = true: rendered with exactly these curves. Leave it out for real cameras, whose",
            "# published curves are another unit's measurement (docs/guide/capture.rst).",
            f"illuminant = {_toml_value(config.illuminant)}",
            f"observer = {_toml_value(_OBSERVER)}",
            "",
        ]
        for cam in config.cameras:
            text.append(
                _toml_table("camera", {"folder": cam.folder, "ssf": cam.ssf, "ssf_exact": True}, array=True)
            )
        text.append(
            _toml_table("white", {"method": "patch", "image": white[1], "box": white[2], "reflectance": 0.9})
        )
        if chart is not None:  # the photograph that shows the ColorChecker largest, whole and unoccluded
            text.append(_toml_table("chart", {"image": chart[1], "corners": chart[2]}))
        if holdout:
            text.append(_toml_table("holdout", {"images": holdout}))
        (tmp / "capture.toml").write_text("\n".join(text))
        truth = [
            f"generator = {_toml_value(_GENERATOR)}",
            f"seed = {config.seed}",
            f"illuminant = {_toml_value(config.illuminant)}",
            f"observer = {_toml_value(_OBSERVER)}",
            "wavelengths = "
            + _toml_value([float(scene.wavelengths[0]), float(scene.wavelengths[-1]), config.interval]),
            f"gain = {config.gain}",
            f"supersample = {config.supersample}",
            f"noise = {_toml_value(config.noise)}",
            f"texture = {_toml_value(config.texture)}",
            f"cell = {_toml_value(config.cell_size)}",
            'xyz_scale = "perfect white reflector under the illuminant has Y = 1 (exposure 1)"',
            'exposure_model = "raw fraction of (white - black) = gain * relative_exposure * response; '
            "relative_exposure = t*ISO/N^2 / median over all views; "
            "response: white's largest channel = 1\"",
            "white_card = "
            + _toml_value({"reflectance": 0.9, "x0": CARD[0], "y0": CARD[1], "side": CARD[2]}),
            "chart = "
            + _toml_value(
                {
                    "set": "ColorChecker N Ohta",
                    "x0": CHART[0],
                    "y0": CHART[1],
                    "side": CHART[2],
                    "gap": CHART[3],
                }
            ),
            "",
        ]
        for ci, cam in enumerate(config.cameras):
            d = {k: v for k, v in asdict(cam).items() if v is not None}
            d["kind"] = "bayer" if cam.cfa else "full-colour (LinearRaw)"
            d["as_shot_neutral"] = [float(x) for x in scene.neutrals[ci]]
            d["focal_px"] = cameras[ci + 1].params[0]
            truth.append(_toml_table("camera", d, array=True))
        for row in view_rows:
            truth.append(_toml_table("view", row, array=True))
        (tmp / "truth" / "truth.toml").write_text("\n".join(truth))
        old = None
        if out.exists():
            if any(out.iterdir()):
                old = out.with_name(f".{out.name}.old-{os.getpid()}")
                os.replace(out, old)
            else:
                out.rmdir()
        os.replace(tmp, out)
        if old is not None:
            shutil.rmtree(old, ignore_errors=True)
    finally:
        if tmp.exists():
            shutil.rmtree(tmp, ignore_errors=True)
    return out


def _surface_points(scene: SimScene, image_ids: dict, per_view: int = 400):
    """True 3-D points on the visible surfaces (a sparse grid of pixels of each training view), with
    COLMAP tracks: every training view that sees a point unoccluded inside its frame observes it.

    ``image_ids`` maps a view's index in ``scene.views`` to its COLMAP image id. Returns the points
    (id → :class:`ColmapPoint3D`) and the keypoints of each image (id → ``(xys (n, 2), point3D_ids
    (n,))``, in COLMAP's pixel convention: the first pixel's centre at 0.5)."""
    import colour

    from ..colmap import ColmapPoint3D

    rng = np.random.default_rng(scene.config.seed + 2)
    train = [(i, v) for i, v in enumerate(scene.views) if not v.holdout]
    xyz, rgb = [], []
    for _, v in train:
        cam = scene.config.cameras[v.camera]
        u = rng.uniform(0, cam.width, per_view)
        w = rng.uniform(0, cam.height, per_view)
        o, d = scene.rays(v, u, w)
        idx, wts, t = shade(scene, o, d)
        XYZ = np.einsum("nk,nkc->nc", wts, (scene.library @ scene.observer)[idx])
        ok = np.isfinite(t)
        xyz.append(o + t[ok, None] * d[ok])
        rgb.append(np.clip(colour.XYZ_to_sRGB(XYZ[ok]), 0, 1))
    xyz, rgb = np.concatenate(xyz), np.concatenate(rgb)
    tracks = [[] for _ in xyz]
    keypoints = {}
    for i, v in train:
        cam = scene.config.cameras[v.camera]
        p = xyz @ v.R.T + v.t
        z = p[:, 2]
        with np.errstate(divide="ignore", invalid="ignore"):
            uv = v.f * p[:, :2] / z[:, None] + np.array([cam.width, cam.height]) / 2
        inside = (z > 0) & np.all((uv >= 0) & (uv < [cam.width, cam.height]), axis=1)
        sel = np.nonzero(inside)[0]
        o = -v.R.T @ v.t
        dist = np.linalg.norm(xyz[sel] - o, axis=1)
        _, _, t = shade(scene, o, (xyz[sel] - o) / dist[:, None])
        seen = sel[np.abs(t - dist) <= TRACK_VISIBLE_ATOL + TRACK_VISIBLE_RTOL * dist]  # hit: the point
        keypoints[image_ids[i]] = (uv[seen], seen + 1)
        for j, pid in enumerate(seen):
            tracks[pid].append((image_ids[i], j))
    points = {}
    for k, (p, c) in enumerate(zip(xyz, rgb)):
        tr = np.asarray(tracks[k], np.int64).reshape(-1, 2)
        points[k + 1] = ColmapPoint3D(k + 1, p, np.round(c * 255).astype(np.uint8), 0.0, tr[:, 0], tr[:, 1])
    return points, keypoints


def main(argv: list[str] | None = None) -> int:
    """``python -m splat.sim.capture OUT [--size ci|benchmark] [--seed N] [--no-noise] [--overwrite]``."""
    import argparse
    import sys
    import time

    import zonotope

    parser = argparse.ArgumentParser(
        prog="python -m splat.sim.capture",
        description="Write a simulated three-camera RAW capture (DNG files, capture.toml, truth/).",
    )
    parser.add_argument("out", help="capture folder to create")
    parser.add_argument("--size", choices=("ci", "benchmark"), default="ci")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--no-noise", action="store_true", help="noise-free forward model")
    parser.add_argument(
        "--texture",
        choices=("fine", "coarse"),
        default="fine",
        help="coarse: flat cells several Bayer periods wide (cell 0.5 m unless --cell is given)",
    )
    parser.add_argument("--cell", type=float, default=None, help="texture cell size in metres")
    parser.add_argument(
        "--extra-reflectances",
        nargs="*",
        default=[],
        metavar="SET",
        help="more reflectance sets (built-in names or files)",
    )
    parser.add_argument("--overwrite", action="store_true", help="replace a previous simulator output")
    args = parser.parse_args(argv)
    make = SimCaptureConfig.ci if args.size == "ci" else SimCaptureConfig.benchmark
    config = make(
        seed=args.seed,
        noise=not args.no_noise,
        extra_reflectances=tuple(args.extra_reflectances),
        texture=args.texture,
        cell=args.cell,
    )
    t = time.perf_counter()
    try:
        out = write_synthetic_capture(args.out, config, overwrite=args.overwrite)
    except (SplatError, zonotope.ZonotopeError, OSError) as exc:  # one line on stderr, no traceback
        print(f"splat.sim.capture: error: {' '.join(str(exc).split())}", file=sys.stderr)
        return 2
    n = sum(1 for _ in out.glob("*/*.dng"))
    print(f"wrote {out} ({n} DNG files, {len(config.cameras)} cameras) in {time.perf_counter() - t:.1f} s")
    return 0


if __name__ == "__main__":  # pragma: no cover
    raise SystemExit(main())
