"""The capture file ``capture.toml``: :func:`read_capture` reads and validates it into a
:class:`CaptureSpec` (stdlib ``tomllib``), refusing bad input with a one-line :class:`CaptureError`.
"""

from __future__ import annotations

import functools
import math
import os
import tomllib
from dataclasses import dataclass, field
from pathlib import Path

from isp.batch import RAW_SUFFIXES, raw_files  # one list of RAW suffixes for isp folders and captures

from .._errors import SplatError

__all__ = [
    "ESTIMATE",
    "PROVISIONAL_LIGHT",
    "CameraSpec",
    "CaptureError",
    "CaptureSpec",
    "WhiteSpec",
    "maker_warnings",
    "read_capture",
]

_WHITE_METHODS = ("patch", "brightest-neutral")

#: ``illuminant = "estimate"``: the scene light is estimated from the capture's own responses at the
#: correct step (:mod:`splat.capture.illuminant`).
ESTIMATE = "estimate"

#: The light assumed for an ``illuminant = "estimate"`` capture before the correct step estimates it
#: (the previews' white balance of the poses step; nothing colorimetric).
PROVISIONAL_LIGHT = "D65"


class CaptureError(SplatError):
    """A capture folder or ``capture.toml`` that cannot be used (names the file, the key and the fix)."""


@dataclass(frozen=True)
class CameraSpec:
    """One ``[[camera]]`` table of ``capture.toml``.

    Attributes
    ----------
    folder : str
        Folder of this camera's RAW files, relative to the capture file.
    ssf : str
        Built-in camera name of :func:`zonotope.camera`, a path (resolved) to an SSF file, or
        ``"estimate"``: estimated from the colour matrices of the folder's first DNG
        (:func:`zonotope.estimate_ssf`).
    cfa : str or None
        Bayer pattern override (default: from the file).
    black_level, white_level : float or None
        Overrides in raw DN.
    exposure : dict
        ``file name -> exposure`` overrides (any scale; made relative with the EXIF ones).
    ssf_exact : bool
        ``ssf_exact = true``: the measured curves are of this very camera (a lab measurement of the
        unit), so the correct step does not add the spread between units of one model
        (:func:`zonotope.unit_sigma`) to its noise. Default false: published curves of the model.
    """

    folder: str
    ssf: str
    cfa: str | None = None
    black_level: float | None = None
    white_level: float | None = None
    exposure: dict = field(default_factory=dict)
    ssf_exact: bool = False


@dataclass(frozen=True)
class WhiteSpec:
    """The ``[white]`` table: how responses are put on the white → 1 scale (see module notes)."""

    method: str = "brightest-neutral"
    image: str | None = None
    box: tuple[int, int, int, int] | None = None
    reflectance: float = 1.0


@dataclass(frozen=True)
class ChartSpec:
    """The ``[chart]`` table: a photograph of the capture that shows a ColorChecker Classic (24
    patches, colour-science's "ColorChecker N Ohta" reflectances), the reference the report measures
    that photograph's corrections against, ΔE00 per patch. ``corners``: (x, y) of the centres of the
    top-left (dark skin), top-right (bluish green), bottom-right (black) and bottom-left (white)
    patches, in the RAW file's pixels, as ``isp profile --chart-corners`` takes them; None when left
    out, for the poses step to find (:func:`splat.capture.chart_of`, which sets ``found``)."""

    image: str
    corners: tuple[tuple[float, float], ...] | None = None
    found: bool = False


@dataclass(frozen=True)
class CaptureSpec:
    """A validated ``capture.toml``.

    Attributes
    ----------
    root : Path
        Folder of the capture file.
    illuminant : str
        The scene light: a colour-science illuminant name, a candidate name of
        :func:`zonotope.spectra.illuminant_estimate.candidate_illuminants` (``"daylight 5500 K"``,
        ``"Planckian 3000 K"``), a path to an SPD CSV, or ``"estimate"``: estimated from the
        capture's responses at the correct step (:func:`splat.capture.illuminant_of` resolves it).
    observer : str
        Target observer of colour correction.
    cameras : tuple of CameraSpec
    white : WhiteSpec
    holdout : tuple of str
        ``"<folder>/<file>"`` names kept out of training.
    colmap, transforms : Path or None
        User-supplied poses.
    train_size : int or None
        Longer side (pixels) of the working resolution of training (``train_size = 640`` at the top
        level; ``--train-size`` overrides it); None: automatic (:mod:`splat.resolution`).
    chart : ChartSpec or None
        A photographed ColorChecker the report measures against (``[chart]``).
    """

    root: Path
    illuminant: str
    observer: str
    cameras: tuple[CameraSpec, ...]
    white: WhiteSpec = WhiteSpec()
    holdout: tuple[str, ...] = ()
    colmap: Path | None = None
    transforms: Path | None = None
    train_size: int | None = None
    reference: str | None = None
    chart: ChartSpec | None = None

    @property
    def white_camera(self) -> int | None:
        """Index of the camera that photographed the white patch (``[white] method = "patch"``: its
        white is measured per channel, the others' levels are relative to it), else None."""
        if self.white.method != "patch":
            return None
        return self.camera_index(Path(self.white.image).parent.as_posix())

    @property
    def file(self) -> Path:
        """The capture's ``capture.toml``."""
        return self.root / "capture.toml"

    def camera_index(self, folder: str) -> int:
        """Index in :attr:`cameras` of the camera whose folder is ``folder``."""
        for k, c in enumerate(self.cameras):
            if c.folder == folder:
                return k
        raise CaptureError(
            f"{self.file}: no [[camera]] has folder {folder!r}; folders are "
            f"{[c.folder for c in self.cameras]}."
        )

    def label(self, k: int) -> str:
        """The folder of camera ``k``'s results inside the output folder: its ``folder`` when that is a
        plain relative path inside the capture, else ``camera<k+1>-<last part>`` (so that an absolute or
        ``..`` folder is never written next to)."""
        f = self.cameras[k].folder
        p = Path(f)
        if not p.is_absolute() and ".." not in p.parts and p.parts and p.as_posix() == f:
            return f
        return f"camera{k + 1}-{p.name or 'folder'}"

    def out_stem(self, name: str) -> str:
        """``"<label>/<stem>"`` of a view ``"<folder>/<file>"`` (or a novel view ``"<folder>/novel_..."``):
        where its results go inside the output folder."""
        for k in sorted(range(len(self.cameras)), key=lambda k: -len(self.cameras[k].folder)):
            folder = self.cameras[k].folder
            if name.startswith(f"{folder}/") and "/" not in name[len(folder) + 1 :]:
                return f"{self.label(k)}/{Path(name).stem}"
        raise CaptureError(f"{name!r} is not a view of a camera folder {[c.folder for c in self.cameras]}.")

    def raw_files(self, k: int) -> list[Path]:
        """The RAW files of camera ``k``, sorted by name."""
        folder = self.root / self.cameras[k].folder
        return raw_files(folder)

    def first_dng(self, k: int) -> Path | None:
        """The first DNG file (by name) of camera ``k``'s folder, whose colour matrices ``ssf =
        "estimate"`` reads and whose Make :func:`maker_warnings` checks; None when it has none."""
        return next((f for f in self.raw_files(k) if f.suffix.lower() == ".dng"), None)

    def ssf_estimate(self, k: int):
        """Camera ``k``'s :class:`zonotope.SSFEstimate`: from the colour matrices of its first DNG file
        (``ssf = "estimate"``), or the one a ``zonotope ssf estimate`` file named by ``ssf`` holds (from a
        DNG, chart photographs or both); None for measured curves. Why: the estimate's band is a
        response error that the correct step adds to the sensor noise (:func:`splat.capture.ssf_sigma`),
        and the report must not call estimated curves measured ones."""
        import zonotope

        s = self.cameras[k].ssf
        if s != "estimate":
            return _estimate_file(s)
        dng = self.first_dng(k)
        if dng is None:
            raise CaptureError(
                f'{self.file}: camera {self.cameras[k].folder!r}: ssf = "estimate" needs a DNG file in '
                "the folder (its colour matrices); convert one RAW with Adobe DNG Converter."
            )
        try:
            return _estimate_ssf(str(dng), dng.stat().st_mtime_ns)
        except zonotope.ZonotopeError as e:
            raise CaptureError(f"{self.file}: camera {self.cameras[k].folder!r}: {e}") from e

    def load_ssf(self, k: int):
        """The spectral sensitivities of camera ``k`` (a colour MSDS with 3 channels)."""
        import zonotope

        s = self.cameras[k].ssf
        if s == "estimate":  # estimated from the colour matrices of the camera's first DNG
            return self.ssf_estimate(k).sensitivities.copy()
        try:
            cam = zonotope.load_camera(s)
        except (OSError, KeyError, TypeError, ValueError) as e:
            raise CaptureError(
                f"{self.file}: camera {self.cameras[k].folder!r}: ssf = {s!r} is neither a "
                f"built-in camera nor a readable SSF file ({e}). Use a name from "
                "zonotope.list_builtin()['cameras'] or a rawtoaces/camspec JSON or CSV file."
            ) from e
        if len(cam.labels) != 3:
            raise CaptureError(f"{self.file}: ssf {s!r} has {len(cam.labels)} channels; RAW cameras have 3.")
        return cam

    @property
    def estimates_illuminant(self) -> bool:
        """Whether the scene light is still to be estimated (``illuminant = "estimate"``)."""
        return self.illuminant == ESTIMATE

    def load_illuminant(self):
        """The capture's illuminant (a colour SD): a built-in or candidate name, or an SPD CSV next to the
        capture file. ``"estimate"`` before the correct step resolved it: :data:`PROVISIONAL_LIGHT`."""
        return self._light("illuminant", PROVISIONAL_LIGHT if self.estimates_illuminant else self.illuminant)

    def load_reference(self):
        """The light the output colours are for (a colour SD), or None: the scene light itself."""
        return None if self.reference is None else self._light("reference", self.reference)

    def _light(self, key: str, name: str):
        try:
            return _load_light(self.root, name)
        except (OSError, KeyError, ValueError) as e:
            raise CaptureError(
                f"{self.file}: {key} = {name!r} is neither a light name nor a readable SPD CSV "
                f"({' '.join(str(e).split())[:200]})."
            ) from e


def _load_light(root: Path, name: str):
    """A light by name (colour-science, then the estimation candidates) or SPD CSV path under ``root``."""
    import zonotope

    p = root / name
    if p.is_file():
        import colour

        m = zonotope.read_spectral_csv(p)
        if isinstance(m, colour.MultiSpectralDistributions):
            m = m.to_sds()[0]
        return m
    try:
        return zonotope.illuminant(name)
    except (KeyError, ValueError):
        from zonotope.spectra.illuminant_estimate import candidate_illuminants

        cand = candidate_illuminants()
        if name in cand:
            return cand[name]
        raise


def _light(doc: dict, key: str, default, root: Path, file: Path, *, estimate: bool):
    """``doc[key]``: a light by built-in or candidate name or SPD CSV file (``"estimate"`` where
    allowed), checked now so that a typo fails before any RAW file is read."""
    name = _optional_str(doc, key, default, "", file)
    if name is None or (estimate and name == ESTIMATE):
        return name
    try:
        _load_light(root, name)
    except (OSError, KeyError, ValueError) as e:
        import zonotope

        also = f'"{ESTIMATE}" (the light estimated from the photographs), ' if estimate else ""
        raise CaptureError(
            f"{file}: {key} = {name!r} names no light and no readable SPD CSV next to capture.toml; use "
            f"{also}a built-in illuminant ({', '.join(zonotope.list_builtin()['illuminants'])}), a "
            "candidate light ('daylight 4000 K' … 'daylight 10000 K' by 500 K, 'Planckian 2500 K' … "
            "'Planckian 6500 K' by 500 K) or the path of an SPD CSV."
        ) from e
    return name


_TOP_KEYS = (
    "illuminant",
    "reference",
    "observer",
    "camera",
    "white",
    "holdout",
    "poses",
    "train_size",
    "chart",
)
_CAMERA_KEYS = ("folder", "ssf", "cfa", "black_level", "white_level", "exposure", "ssf_exact")
_WHITE_KEYS = ("method", "image", "box", "reflectance")
_HOLDOUT_KEYS = ("images",)
_CHART_KEYS = ("image", "corners")
_POSES_KEYS = ("colmap", "transforms")


def _table(doc: dict, key: str, allowed: tuple[str, ...], file: Path) -> dict:
    """``doc[key]`` as a table (empty when absent) whose keys are all in ``allowed``."""
    t = doc.get(key, {})
    if not isinstance(t, dict):
        raise CaptureError(f"{file}: {key} = {t!r} must be a table ([{key}]).")
    _known(t, allowed, f"[{key}]", file)
    return t


def _known(t: dict, allowed: tuple[str, ...], where: str, file: Path) -> None:
    extra = sorted(set(t) - set(allowed))
    if extra:
        raise CaptureError(f"{file}: {where} has unknown key(s) {extra}; allowed keys are {list(allowed)}.")


def _is_number(v) -> bool:
    return isinstance(v, int | float) and not isinstance(v, bool)


def _need(doc: dict, key: str, kind, where: str, file: Path):
    if key not in doc:
        raise CaptureError(f"{file}: {where} lacks the key {key!r}.")
    v = doc[key]
    if not isinstance(v, kind) or isinstance(v, bool):
        raise CaptureError(f"{file}: {where}.{key} = {v!r} must be a {getattr(kind, '__name__', kind)}.")
    return v


def _optional_str(doc: dict, key: str, default, where: str, file: Path):
    v = doc.get(key, default)
    if v is not None and not isinstance(v, str):
        raise CaptureError(f"{file}: {where}{key} = {v!r} must be a string.")
    return v


def _level(c: dict, key: str, where: str, file: Path) -> float | None:
    v = c.get(key)
    if v is None:
        return None
    if not _is_number(v) or not math.isfinite(v) or v < 0:
        raise CaptureError(f"{file}: {where}.{key} = {v!r} must be a finite number ≥ 0 (raw DN).")
    return float(v)


def _camera(c, i: int, root: Path, file: Path) -> CameraSpec:
    where = f"[[camera]] #{i + 1}"
    if not isinstance(c, dict):
        raise CaptureError(f"{file}: {where} must be a table.")
    _known(c, _CAMERA_KEYS, where, file)
    folder = _need(c, "folder", str, where, file)
    ssf = _need(c, "ssf", str, where, file)
    if (root / ssf).suffix.lower() in (".json", ".csv", ".txt") or "/" in ssf:
        if not (root / ssf).is_file():
            raise CaptureError(
                f"{file}: {where}: SSF file {root / ssf} does not exist; give a path "
                "relative to capture.toml or a built-in camera name."
            )
        ssf = str(root / ssf)
    if not (root / folder).is_dir():
        raise CaptureError(f"{file}: {where}: folder {root / folder} does not exist.")
    black, white = _level(c, "black_level", where, file), _level(c, "white_level", where, file)
    if black is not None and white is not None and black >= white:
        raise CaptureError(f"{file}: {where}: black_level = {black:g} must be below white_level = {white:g}.")
    exp = c.get("exposure", {})
    if not isinstance(exp, dict):
        raise CaptureError(f"{file}: {where}.exposure = {exp!r} must map file names to positive numbers.")
    for name, v in exp.items():
        if not _is_number(v) or not math.isfinite(v) or v <= 0:
            raise CaptureError(
                f"{file}: {where}.exposure[{name!r}] = {v!r} must be a finite positive number "
                "(time × ISO / f-number²)."
            )
        if not (root / folder / name).is_file():
            raise CaptureError(
                f"{file}: {where}.exposure names {name!r}, which is not a file in {root / folder}."
            )
    cfa = _optional_str(c, "cfa", None, f"{where}.", file)
    if cfa is not None:
        from isp.cfa import check_cfa

        try:
            cfa = check_cfa(cfa)
        except ValueError as e:
            raise CaptureError(f"{file}: {where}: {e}") from e
    exact = c.get("ssf_exact", False)
    if not isinstance(exact, bool):
        raise CaptureError(f"{file}: {where}.ssf_exact = {exact!r} must be true or false.")
    if exact and ssf == "estimate":
        raise CaptureError(
            f"{file}: {where}: ssf_exact = true is for curves measured on this very camera, "
            'not for ssf = "estimate".'
        )
    if exact and _estimate_file(ssf) is not None:
        raise CaptureError(
            f"{file}: {where}: ssf_exact = true is for curves measured on this very camera, not for "
            f"{Path(ssf).name}, which zonotope ssf estimate wrote."
        )
    return CameraSpec(folder, ssf, cfa, black, white, {k: float(v) for k, v in exp.items()}, exact)


def _white(w: dict, root: Path, file: Path) -> WhiteSpec:
    method = _optional_str(w, "method", "brightest-neutral", "[white].", file)
    if method not in _WHITE_METHODS:
        raise CaptureError(f"{file}: [white].method = {method!r}; use one of {list(_WHITE_METHODS)}.")
    refl = w.get("reflectance", 1.0)
    if not _is_number(refl) or not 0 < refl <= 1.5:
        raise CaptureError(f"{file}: [white].reflectance = {refl!r} must be a number in (0, 1.5].")
    if method != "patch":
        given = sorted({"image", "box"} & set(w))
        if given:
            raise CaptureError(
                f'{file}: [white] {given} apply only to method = "patch" (method is {method!r}).'
            )
        return WhiteSpec(method, None, None, float(refl))
    image = _need(w, "image", str, "[white]", file)
    box = _need(w, "box", list, "[white]", file)
    if (
        len(box) != 4
        or not all(type(b) is int for b in box)
        or box[2] <= box[0]
        or box[3] <= box[1]
        or min(box) < 0
    ):
        raise CaptureError(
            f"{file}: [white].box = {box} must be [x0, y0, x1, y1] integers ≥ 0, x1 > x0, "
            "y1 > y0 (pixels, end exclusive)."
        )
    if not (root / image).is_file():
        raise CaptureError(f"{file}: [white].image = {image!r} does not exist.")
    return WhiteSpec(method, image, tuple(box), float(refl))


def _in_camera_folder(name: str, folders: list[str]) -> bool:
    """``name`` is ``"<folder>/<file>"`` of one of the camera ``folders`` (no deeper path)."""
    return any(name.startswith(f"{f}/") and "/" not in name[len(f) + 1 :] for f in folders)


def _chart(t: dict, root: Path, file: Path, folders: list[str]) -> ChartSpec | None:
    if not t:
        return None
    image = _need(t, "image", str, "[chart]", file)
    if not (root / image).is_file():
        raise CaptureError(f"{file}: [chart].image = {image!r} does not exist.")
    if not _in_camera_folder(image, folders):
        raise CaptureError(
            f"{file}: [chart].image = {image!r} is not a file of a camera folder {folders}; "
            'name it "<folder>/<file>".'
        )
    if "corners" not in t:
        return ChartSpec(image)  # found in the photograph by the poses step
    corners = _need(t, "corners", list, "[chart]", file)
    if (
        len(corners) != 4
        or not all(isinstance(c, list) and len(c) == 2 and all(_is_number(x) for x in c) for c in corners)
        or not all(math.isfinite(x) and x >= 0 for c in corners for x in c)
    ):
        raise CaptureError(
            f"{file}: [chart].corners = {corners!r} must be four [x, y] pixel positions ≥ 0: the centres "
            "of the top-left, top-right, bottom-right and bottom-left patches."
        )
    turns = [  # the z of each corner's cross product: one sign all round for a convex quadrilateral
        (b[0] - a[0]) * (c[1] - b[1]) - (b[1] - a[1]) * (c[0] - b[0])
        for a, b, c in zip(corners, corners[1:] + corners[:1], corners[2:] + corners[:2], strict=True)
    ]
    if not (all(t > 0 for t in turns) or all(t < 0 for t in turns)):
        raise CaptureError(
            f"{file}: [chart].corners = {corners!r} do not make a four-sided chart (three on one line, or "
            "out of order); give the top-left, top-right, bottom-right and bottom-left patch centres."
        )
    return ChartSpec(image, tuple((float(x), float(y)) for x, y in corners))


def _colliding_stems(files: list[Path]) -> list[str] | None:
    seen: dict[str, str] = {}
    for f in files:
        if f.stem in seen:
            return [seen[f.stem], f.name]
        seen[f.stem] = f.name
    return None


def read_capture(path: str | os.PathLike) -> CaptureSpec:
    """Read and validate ``capture.toml``.

    Parameters
    ----------
    path : path
        The capture folder or its ``capture.toml``.

    Returns
    -------
    CaptureSpec

    Raises
    ------
    CaptureError
        Missing or invalid TOML; an unknown key in any table (the allowed ones named) or a value of the
        wrong type; a camera folder that does not exist, holds no RAW files or holds two files with one
        stem (``DSC_0003.dng`` and ``DSC_0003.nef``: their outputs would collide); a duplicated folder;
        levels that are not finite, negative, or black ≥ white; exposure overrides that are not finite
        positive numbers or name no file; an unknown white method, a bad box, or ``image``/``box``
        without ``method = "patch"``; a hold-out image that does not exist or is no camera's file; a pose
        file that does not exist, or both kinds given; an ``illuminant`` or ``reference`` that names no
        light (``"estimate"`` is an illuminant only). Every check runs here, before any RAW file is read.
    """
    path = Path(path)
    file = path / "capture.toml" if path.is_dir() else path
    if not file.is_file():
        raise CaptureError(
            f"{file}: no capture file; write a capture.toml (see the README, 'Multi-camera capture')."
        )
    try:
        doc = tomllib.loads(file.read_text())
    except (tomllib.TOMLDecodeError, UnicodeDecodeError) as e:
        raise CaptureError(f"{file}: not valid TOML ({e}).") from e
    root = file.parent
    _known(doc, _TOP_KEYS, "the top level", file)
    illuminant = _light(doc, "illuminant", "D65", root, file, estimate=True)
    reference = _light(doc, "reference", None, root, file, estimate=False)
    observer = _optional_str(doc, "observer", "CIE 1931 2 Degree Standard Observer", "", file)
    cams = doc.get("camera")
    if not isinstance(cams, list) or not cams:
        raise CaptureError(f"{file}: needs at least one [[camera]] table with folder and ssf.")
    specs = [_camera(c, i, root, file) for i, c in enumerate(cams)]
    folders = [s.folder for s in specs]
    if len(set(folders)) != len(folders):
        raise CaptureError(f"{file}: a camera folder is listed twice ({folders}); one [[camera]] per folder.")
    white = _white(_table(doc, "white", _WHITE_KEYS, file), root, file)
    h = _table(doc, "holdout", _HOLDOUT_KEYS, file).get("images", [])
    if not isinstance(h, list) or not all(isinstance(x, str) for x in h):
        raise CaptureError(
            f'{file}: [holdout].images = {h!r} must be a list of "<folder>/<file>" strings, '
            'e.g. images = ["nikon/DSC_0003.NEF"].'
        )
    holdout = tuple(h)
    for name in holdout:
        if not (root / name).is_file():
            raise CaptureError(f"{file}: [holdout] image {name!r} does not exist.")
        if not _in_camera_folder(name, folders):
            raise CaptureError(
                f"{file}: [holdout] image {name!r} is not a file of a camera folder {folders}; "
                'name it "<folder>/<file>".'
            )
    poses = _table(doc, "poses", _POSES_KEYS, file)
    colmap = transforms = None
    if "colmap" in poses and "transforms" in poses:
        raise CaptureError(f"{file}: [poses] gives both colmap and transforms; give one.")
    if "colmap" in poses:
        colmap = root / _need(poses, "colmap", str, "[poses]", file)
        if not colmap.is_dir():
            raise CaptureError(f"{file}: [poses].colmap = {poses['colmap']!r} is not a folder.")
    if "transforms" in poses:
        transforms = root / _need(poses, "transforms", str, "[poses]", file)
        if not transforms.is_file():
            raise CaptureError(f"{file}: [poses].transforms = {poses['transforms']!r} does not exist.")
    train_size = doc.get("train_size")
    if train_size is not None and (
        isinstance(train_size, bool) or not isinstance(train_size, int) or train_size < 16
    ):
        raise CaptureError(
            f"{file}: train_size = {train_size!r} must be a whole number of pixels ≥ 16 (the longer side of "
            "the working resolution of training), e.g. train_size = 640; leave it out for the automatic one."
        )
    chart = _chart(_table(doc, "chart", _CHART_KEYS, file), root, file, folders)
    spec = CaptureSpec(
        root,
        illuminant,
        observer,
        tuple(specs),
        white,
        holdout,
        colmap,
        transforms,
        train_size,
        reference,
        chart,
    )
    for k, c in enumerate(specs):
        files = spec.raw_files(k)
        if not files:
            raise CaptureError(
                f"{file}: folder {root / c.folder} holds no RAW files "
                f"({', '.join(sorted(RAW_SUFFIXES)[:4])}, ...)."
            )
        clash = _colliding_stems(files)
        if clash:
            raise CaptureError(
                f"{file}: folder {root / c.folder} holds {clash[0]} and {clash[1]}, one photograph's "
                "name twice (their outputs would collide); keep one of them in the folder."
            )
    return spec


def maker_warnings(spec: CaptureSpec) -> list[str]:
    """One line per camera whose named curves are another maker's than its first DNG's Make
    (:func:`isp.maker_mismatch`); cameras with ``ssf = "estimate"``, curves that name no maker and
    folders without a DNG are not checked. Why: two ``[[camera]]`` tables with their ``ssf`` lines
    swapped develop every photograph with another camera's curves, and nothing else would say so."""
    from isp import RawFormatError, maker_mismatch, read_dng_tags

    out = []
    for k, cam in enumerate(spec.cameras):
        if cam.ssf == "estimate":
            continue
        dng = spec.first_dng(k)
        if dng is None:
            continue
        try:
            make = str(read_dng_tags(dng).get("Make", "") or "")
        except (OSError, RawFormatError):
            continue  # the steps say what is wrong with the file
        other = maker_mismatch(cam.ssf, make)
        if other:
            out.append(
                f"{spec.file}: camera {cam.folder!r} ({dng.name}): {other} Check that each [[camera]] "
                "names its own curves."
            )
    return out


def _estimate_file(ssf: str):
    """The :class:`zonotope.SSFEstimate` an ``ssf`` file holds (written by ``zonotope ssf estimate``),
    else None (a built-in name, measured curves)."""
    p = Path(ssf)
    return _read_estimate(ssf, p.stat().st_mtime_ns) if p.is_file() else None


@functools.lru_cache(maxsize=16)
def _read_estimate(path: str, mtime_ns: int):
    """:func:`zonotope.read_ssf_estimate` of an SSF file, once per file version (None: measured curves);
    a malformed estimate block is a :class:`CaptureError` naming the file."""
    import zonotope

    try:
        return zonotope.read_ssf_estimate(path)
    except zonotope.ZonotopeError as e:
        raise CaptureError(str(e)) from e


@functools.lru_cache(maxsize=16)
def _estimate_ssf(path: str, mtime_ns: int):
    """:func:`zonotope.estimate_ssf` of a DNG, once per file version (the capture asks for a camera's
    curves for every fit)."""
    import zonotope

    return zonotope.estimate_ssf(path)
