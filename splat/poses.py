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

__all__ = ["PoseConfig", "recover_poses"]


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
    pycolmap.match_exhaustive(db, device=device)
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
