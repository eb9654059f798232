"""Optional pose recovery with COLMAP (pycolmap, CPU SIFT) from 8-bit previews of the RAW images.

Previews (e.g. made by ``isp``) are laid out one folder per physical camera,
``image_dir/<camera>/<image>``, so that each camera gets its own COLMAP camera id (and, through the
capture's channel map, its channels). Poses come out in COLMAP's arbitrary frame and scale.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

from ._errors import SplatError
from .colmap import ColmapModel, read_colmap

__all__ = ["PoseConfig", "recover_poses", "triangulate_points"]


@dataclass(frozen=True)
class PoseConfig:
    """Options of :func:`recover_poses`.

    Attributes
    ----------
    camera_model : str
        COLMAP model of the recovered intrinsics; ``"SIMPLE_PINHOLE"`` (default) or ``"PINHOLE"``
        render directly, a distorted model needs undistortion before training.
    max_image_size : int
        Images are downscaled to this size for SIFT (−1: full size).
    max_num_features : int
    min_num_matches : int
    num_threads : int
        −1 for all cores.
    seed : int
        Seed of COLMAP's RANSAC and mapper (for reproducible results).
    """

    camera_model: str = "SIMPLE_PINHOLE"
    max_image_size: int = 1600
    max_num_features: int = 8192
    min_num_matches: int = 15
    num_threads: int = -1
    seed: int = 0


def recover_poses(
    image_dir: str | Path, workdir: str | Path, *, config: PoseConfig = PoseConfig()
) -> ColmapModel:
    """Recover camera poses and a sparse point cloud: SIFT features, exhaustive matching, incremental
    mapping (pycolmap on the CPU).

    Parameters
    ----------
    image_dir : path
        One sub-folder per physical camera holding its 8-bit previews (PNG, JPEG, TIFF).
    workdir : path
        Receives ``database.db`` and the model in ``sparse/`` (binary).
    config : PoseConfig

    Returns
    -------
    ColmapModel
        The largest reconstruction; its image names are ``<camera folder>/<file>``.

    Raises
    ------
    SplatError
        No images found, or COLMAP registered no model (too little texture or overlap).
    """
    import pycolmap

    image_dir, workdir = Path(image_dir), Path(workdir)
    if not any(p.is_file() for p in image_dir.glob("*/*")):
        raise SplatError(f"{image_dir} has no images in camera sub-folders ({image_dir}/<camera>/<image>).")
    db = _features(image_dir, workdir, config)
    pycolmap.match_exhaustive(db, device=pycolmap.Device.cpu)
    options = pycolmap.IncrementalPipelineOptions()
    options.min_num_matches = config.min_num_matches
    options.num_threads = config.num_threads
    options.random_seed = config.seed
    options.ba_refine_principal_point = False
    out = workdir / "sparse"
    models = pycolmap.incremental_mapping(db, image_dir, out, options=options)
    if not models:
        raise SplatError(
            f"COLMAP registered no model from {image_dir}: the previews need more texture "
            "or overlap (or lower PoseConfig.min_num_matches)."
        )
    best = max(models.values(), key=lambda r: r.num_reg_images())
    folder = out / "best"
    folder.mkdir(parents=True, exist_ok=True)
    best.write_binary(str(folder))
    return read_colmap(folder)


def _features(image_dir: Path, workdir: Path, config: PoseConfig) -> Path:
    """``workdir/database.db`` (made anew) with SIFT features of every image under ``image_dir`` (one
    COLMAP camera per sub-folder), on the CPU."""
    import pycolmap

    workdir.mkdir(parents=True, exist_ok=True)
    db = workdir / "database.db"
    if db.exists():
        db.unlink()
    reader = pycolmap.ImageReaderOptions()
    reader.camera_model = config.camera_model
    extraction = pycolmap.FeatureExtractionOptions()
    extraction.max_image_size = config.max_image_size
    extraction.num_threads = config.num_threads
    extraction.sift.max_num_features = config.max_num_features
    device = pycolmap.Device.cpu
    pycolmap.extract_features(
        db,
        image_dir,
        camera_mode=pycolmap.CameraMode.PER_FOLDER,
        reader_options=reader,
        extraction_options=extraction,
        device=device,
    )
    return db


def triangulate_points(
    image_dir: str | Path, workdir: str | Path, model: ColmapModel, *, config: PoseConfig = PoseConfig()
) -> ColmapModel:
    """3-D points for known poses: SIFT features and exhaustive matches of the images (as
    :func:`recover_poses`), triangulated by pycolmap with the poses and intrinsics held fixed.

    Parameters
    ----------
    image_dir : path
        One sub-folder per physical camera, as for :func:`recover_poses`.
    workdir : path
        Receives ``database.db``, the given model (``given/``) and the result (``triangulated/``).
    model : ColmapModel
        The known poses: its images named as the files under ``image_dir`` (``<camera>/<file>``), each
        sub-folder's images sharing one camera, its intrinsics in those files' pixels.

    Returns
    -------
    ColmapModel
        ``model``'s cameras and poses (COLMAP's ids) with the triangulated points and their tracks.

    Raises
    ------
    SplatError
        An image of ``model`` is not under ``image_dir``, or one sub-folder's images have cameras of
        different ids.

    Why: a model of poses alone (a ``transforms.json``, a rig calibration) gives training no points to
    start from nor sparse depth; matching the photographs against the known poses gives both.
    """
    import pycolmap

    from .colmap import ColmapCamera, ColmapImage, write_colmap

    image_dir, workdir = Path(image_dir), Path(workdir)
    db = _features(image_dir, workdir, config)
    cams, images = {}, {}
    with pycolmap.Database.open(str(db)) as d:
        found = {im.name: im for im in d.read_all_images()}
        for im in model.images.values():
            got = found.get(im.name)
            if got is None:
                raise SplatError(f"triangulate_points: {im.name!r} is not an image under {image_dir}.")
            c = model.cameras[im.camera_id]
            mine = ColmapCamera(got.camera_id, c.model, c.width, c.height, tuple(c.params))
            if cams.setdefault(got.camera_id, mine) != mine:
                where = Path(im.name).parent
                raise SplatError(f"triangulate_points: the images of {where} have different cameras.")
            images[got.image_id] = ColmapImage(got.image_id, im.qvec, im.tvec, got.camera_id, im.name)
        for c in cams.values():  # the known intrinsics, for matching and triangulating
            known = pycolmap.Camera(
                model=c.model, width=c.width, height=c.height, params=list(c.params), camera_id=c.id
            )
            known.has_prior_focal_length = True
            d.update_camera(known)
    pycolmap.match_exhaustive(db, device=pycolmap.Device.cpu)
    given = workdir / "given"
    write_colmap(ColmapModel(cams, images, {}), given, binary=False)
    options = pycolmap.IncrementalPipelineOptions()
    options.num_threads = config.num_threads
    options.random_seed = config.seed
    out = workdir / "triangulated"
    out.mkdir(parents=True, exist_ok=True)
    rec = pycolmap.triangulate_points(
        pycolmap.Reconstruction(str(given)), db, image_dir, out, options=options, refine_intrinsics=False
    )
    rec.write_binary(str(out))
    return read_colmap(out)
