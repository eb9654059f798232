"""Writes small RAW captures (real DNG files + capture.toml) from the synthetic Gaussian scene, for the
capture and pipeline tests (the full simulator with true XYZ lives in splat.sim.capture)."""

from __future__ import annotations

from pathlib import Path

import numpy as np

CAMERAS = (
    ("nikon", "Nikon 5100 (NPL)", "RGGB", (48, 36), 45.0),
    ("sigma", "Sigma SDMerill (NPL)", None, (40, 30), 40.0),
    ("canon", "Canon EOS 5D Mark II", "GRBG", (56, 42), 50.0),
)


def write_dng_exif(
    path, data, *, cfa, black, white, neutral, exposure_time, iso, fnumber, color_matrix=None, make="zonotope"
):
    """A DNG (CFA when ``cfa`` is given, else LinearRaw (H, W, 3)) with EXIF exposure tags in IFD 0."""
    import tifffile

    from isp.dng import _rational, _srational

    cm = np.eye(3) if color_matrix is None else color_matrix
    tags = [
        (254, "I", 1, 0, True),
        (271, "s", 0, make, True),
        (272, "s", 0, "test", True),
        (50706, "B", 4, (1, 4, 0, 0), True),
        (50707, "B", 4, (1, 1, 0, 0), True),
        (50708, "s", 0, "zonotope test", True),
        (50717, "I", 1, int(white), True),
        (50721, 10, 9, _srational(cm), True),
        (50728, 5, 3, _rational(neutral), True),
        (50778, "H", 1, 21, True),
        (33434, 5, 1, _rational([exposure_time]), True),
        (34855, "H", 1, int(iso), True),
        (33437, 5, 1, _rational([fnumber]), True),
    ]
    if cfa is not None:
        codes = {"R": 0, "G": 1, "B": 2}
        tags += [
            (33421, "H", 2, (2, 2), True),
            (33422, "B", 4, tuple(codes[c] for c in cfa), True),
            (50713, "H", 2, (2, 2), True),
            (50714, "I", 4, (black,) * 4, True),
        ]
        photometric = 32803
    else:
        tags += [(50714, "I", 3, (black,) * 3, True)]
        photometric = 34892
    tifffile.imwrite(
        path,
        np.ascontiguousarray(data, np.uint16),
        photometric=photometric,
        extratags=tags,
        metadata=None,
        planarconfig="contig" if cfa is None else None,
    )


def write_capture(
    root: Path,
    *,
    views=4,
    holdout=1,
    seed=0,
    cameras=CAMERAS,
    colmap=True,
    white_gain=0.7,
    extra_toml="",
    ssf_exact=True,
):
    """Render the synthetic scene from an orbit, camera by camera, into DNG files. ``ssf_exact``: the
    cameras' tables say ``ssf_exact = true`` (true: the photographs are rendered with those very curves).

    Returns
    -------
    dict with ``truth`` (Gaussians), ``cams`` {name: splat.Camera}, ``exposure`` {name: relative},
    ``balanced`` {name: (H, W, 3) white → 1 responses at exposure 1}, ``names`` held-out names.
    """
    import jax.numpy as jnp

    import zonotope
    from isp.stages import cfa_masks
    from splat import SceneConfig, look_at, render_reference, synthetic_scene
    from splat.camera import rotmat_to_qvec
    from splat.colmap import ColmapCamera, ColmapImage, ColmapModel, ColmapPoint3D, write_colmap

    rng = np.random.default_rng(seed)
    names = tuple(c[1] for c in cameras)
    scene = synthetic_scene(
        SceneConfig(cameras=names, views_per_camera=1, test_views_per_camera=1, width=8, height=8, seed=seed)
    )
    truth = scene.truth
    root.mkdir(parents=True, exist_ok=True)
    out = {"truth": truth, "cams": {}, "exposure": {}, "balanced": {}, "holdout": []}
    toml = ['illuminant = "D65"', ""]
    ccams, cimgs = {}, {}
    for c, (folder, ssf, cfa, (W, H), fov) in enumerate(cameras):
        (root / folder).mkdir(exist_ok=True)
        cam_ssf = zonotope.camera(ssf)
        g = zonotope.generators(
            cam_ssf, "D65", zonotope.common_shape(cam_ssf, interval=5), normalise=None
        ).values.sum(0)
        neutral = g / g.max()
        toml += ["[[camera]]", f'folder = "{folder}"', f'ssf = "{ssf}"']
        toml += ["ssf_exact = true", ""] if ssf_exact else [""]
        for k in range(views + holdout):
            a = 2 * np.pi * (k + c / len(cameras)) / (views + holdout)
            elev = 0.6 + 0.2 * np.sin(3 * a + c)
            eye = 3.2 * np.array([np.cos(a) * np.cos(elev), np.sin(a) * np.cos(elev), np.sin(elev)])
            cam = look_at(eye, (0, 0, 0.1), width=W, height=H, fov_deg=fov)
            img = np.asarray(render_reference(truth, cam).image)[..., 3 * c : 3 * c + 3]
            t, iso, f = float(rng.choice([1 / 60, 1 / 125, 1 / 250])), int(rng.choice([100, 200])), 4.0
            e = t * iso / f**2 / (1 / 125 * 100 / 16)
            raw = np.clip(e * img * neutral * white_gain, 0, None)
            raw = raw + rng.normal(0, 2e-3, raw.shape)
            black, white = 256, 4095
            dn = np.clip(np.round(black + raw * (white - black)), 0, white)
            name = f"IMG_{k:04d}.dng"
            if cfa is None:
                data = dn
            else:
                data = np.sum(dn * cfa_masks((H, W), cfa), -1)
            write_dng_exif(
                root / folder / name,
                data,
                cfa=cfa,
                black=black,
                white=white,
                neutral=neutral,
                exposure_time=t,
                iso=iso,
                fnumber=f,
                make=ssf.split()[0],  # the maker its curves name (splat.capture.maker_warnings)
            )
            full = f"{folder}/{name}"
            out["cams"][full] = cam
            out["exposure"][full] = e
            out["balanced"][full] = img
            if k >= views:
                out["holdout"].append(full)
            ccams[c + 1] = ColmapCamera(
                c + 1,
                "PINHOLE",
                W,
                H,
                (*map(float, np.asarray(cam.focal)), *map(float, np.asarray(cam.principal))),
            )
            i = len(cimgs) + 1
            cimgs[i] = ColmapImage(
                i, rotmat_to_qvec(np.asarray(cam.R, float)), np.asarray(cam.t, float), c + 1, full
            )
    if out["holdout"]:
        toml += ["[holdout]", "images = [" + ", ".join(f'"{h}"' for h in out["holdout"]) + "]", ""]
    if colmap:
        m = np.asarray(truth.means)
        pts = {
            i + 1: ColmapPoint3D(
                i + 1,
                m[i],
                np.array([128, 128, 128], np.uint8),
                0.5,
                np.zeros(0, np.int64),
                np.zeros(0, np.int64),
            )
            for i in range(0, len(m), 3)
        }
        write_colmap(ColmapModel(ccams, cimgs, pts), root / "sparse", binary=False)
        toml += ["[poses]", 'colmap = "sparse"', ""]
    (root / "capture.toml").write_text("\n".join(toml) + extra_toml)
    _ = jnp
    return out
