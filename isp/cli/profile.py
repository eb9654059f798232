"""``isp profile``: a DNG camera profile (and optionally a 3-D LUT and a saved correction) for a camera.

Registered on the ``isp`` command by :func:`add_command`. The DCP is fitted by
:func:`isp.profiles.fitting.fit_dcp`; the LUT and the saved correction come from
:mod:`zonotope.correct.profile`.
(It is an ``isp`` command, not a ``zonotope`` one, because ``zonotope`` never imports ``isp``.)
"""

from __future__ import annotations

import argparse
from pathlib import Path

__all__ = ["add_command"]


def _status(console, message: str):
    """Rich's spinner on a terminal; piped (where the spinner prints nothing), the message as a line."""
    import contextlib

    if console.is_terminal:
        return console.status(message)
    console.print(message, soft_wrap=True)
    return contextlib.nullcontext()


def _written_by_isp_profile(path: Path) -> bool:
    """Whether ``path`` is a DCP, LUT or saved correction that ``isp profile`` wrote (what --overwrite may
    replace): our DCPs carry the TIFF Software tag "zonotope profile", our LUTs a "zonotope:" comment,
    our saved corrections the zonotope-correction format header."""
    suffix = path.suffix.lower()
    try:
        if suffix == ".dcp":
            return b"zonotope profile\x00" in path.read_bytes()
        if suffix in (".cube", ".csp"):
            with open(path, "rb") as fh:
                return b"zonotope:" in fh.read(4096)
        if suffix == ".npz":
            import json

            import numpy as np

            with np.load(path, allow_pickle=False) as z:
                return str(json.loads(str(z["meta"])).get("format", "")).startswith("zonotope-correction/")
    except (OSError, ValueError, KeyError, AttributeError):
        return False
    return False


def _profile_noise(args: argparse.Namespace):
    """The noise the profile's estimator is fitted for, from ``--noise`` and ``--noise-dng``, and a note.

    ``auto`` takes it from ``--noise-dng`` (its NoiseProfile, else an estimate from its flat
    regions: :func:`isp.metamer.metamer_noise`); without a file there is nothing to measure, and
    the fit is noise-free (said in the note).
    """
    from zonotope import ZonotopeError

    from ..metamer import metamer_noise
    from .develop import _noise_request

    noise, error = _noise_request(args.noise)
    if error:
        raise ZonotopeError(error)
    if noise != "auto":
        if args.noise_dng:
            raise ZonotopeError("--noise-dng applies to --noise auto only: give one of the two.")
        return noise, ""
    if not args.noise_dng:
        return None, "no RAW file to measure it in: give --noise-dng FILE or --noise"
    from ..raw import read_raw

    model, note = metamer_noise(read_raw(args.noise_dng))
    return model, f"{note}; " * bool(note) + f"from {Path(args.noise_dng).name}"


def _profile(args: argparse.Namespace) -> int:
    from rich.console import Console

    from zonotope import ZonotopeError
    from zonotope.correct.profile import LUTConfig, correction_LUT, save_correction, write_correction_LUT

    from ..profiles.dcp import write_dcp
    from ..profiles.fitting import ProfileConfig, fit_dcp

    console = Console(stderr=True)
    out = Path(args.output)
    targets = [out] + [Path(p) for p in (args.lut, args.save_correction) if p]
    if out.suffix.lower() != ".dcp":
        raise ZonotopeError(f"-o {out}: a camera profile is written as a .dcp file.")
    if args.lut and Path(args.lut).suffix.lower() not in (".cube", ".csp"):
        raise ZonotopeError(f"--lut {args.lut}: use a .cube (Resolve) or .csp (Cinespace) file.")
    if args.save_correction and Path(args.save_correction).suffix.lower() != ".npz":  # before the fit
        raise ZonotopeError(f"--save-correction {args.save_correction}: a saved correction is a .npz file.")
    for p in targets:
        if p.exists() and not args.overwrite:
            raise ZonotopeError(f"{p} exists; use --overwrite or another name.")
        if p.exists() and not _written_by_isp_profile(p):  # a third-party DCP, the user's own LUT, ...
            raise ZonotopeError(
                f"{p} exists and was not written by isp profile; --overwrite replaces only this "
                "command's outputs: choose another name."
            )
    dims = None if args.matrix_only else (args.hue_sat_size[0], args.hue_sat_size[1], 1)
    if dims is not None and (dims[0] < 1 or dims[1] < 2):  # named as on the command line, not ProfileConfig
        raise ZonotopeError(
            f"--hue-sat-size {dims[0]} {dims[1]}: need hues ≥ 1 and saturations ≥ 2 (default 90 30)."
        )
    look = None if args.matrix_only or args.no_look_table else tuple(args.look_table_size)
    if look is not None and (look[0] < 1 or look[1] < 2 or look[2] < 1):
        raise ZonotopeError(
            f"--look-table-size {' '.join(map(str, look))}: need hues ≥ 1, saturations ≥ 2, values ≥ 1."
        )
    noise, note = _profile_noise(args)
    # both configs are checked before the (long) fit starts
    try:
        config = ProfileConfig(
            method=args.method,
            noise=noise,
            illuminants=tuple(args.illuminants),
            training=args.training,
            dims=dims,
            look_table_dims=look,
            unique_camera_model=args.unique_camera_model,
            profile_name=args.profile_name,
            copyright=args.copyright or "",
            embed_policy=args.embed_policy,
        )
    except ZonotopeError as error:  # ProfileConfig names its field: say which option it came from
        if not str(error).startswith("ProfileConfig.illuminants="):
            raise
        raise type(error)(f"--illuminants {' '.join(args.illuminants)}: {error}") from error
    lut_config = None
    if args.lut:
        try:
            lut_config = LUTConfig(size=args.lut_size, space=args.lut_space, headroom=args.headroom)
        except ZonotopeError as error:  # LUTConfig names its fields (size=, headroom=): add the option
            option = {"size": "--lut-size", "headroom": "--headroom"}.get(str(error).split("=")[0], "--lut")
            raise type(error)(f"{option}: {error}") from error
    import zonotope

    zonotope.load_camera(args.camera)  # an unknown name or a bad file: refused before "fitting …"
    from ..metamer import photograph_method

    method = args.method or photograph_method()
    what = "none (noise-free fit)" if config.noise is None else config.noise.describe()
    console.print(f"noise: {what}" + (f" ({note})" if note else ""), soft_wrap=True)
    with _status(console, f"fitting {method} for {args.camera} under {' and '.join(args.illuminants)}…"):
        fit = fit_dcp(args.camera, config)
    write_dcp(out, fit.profile, overwrite=args.overwrite)
    console.print(
        f"camera profile written to {out} (UniqueCameraModel {fit.profile.unique_camera_model!r}, "
        f"{'matrices only' if dims is None else f'HueSatMap {dims[0]}×{dims[1]}'}"
        f"{'' if look is None else f', LookTable {look[0]}×{look[1]}×{look[2]}'})",
        soft_wrap=True,
    )
    mc = fit.corrections[-1]  # the estimator under the second (daylight) calibration illuminant
    if args.lut:
        from ._console import _progress  # rich's bar on a terminal, plain timed lines when piped

        with _progress(console, quiet=False) as bar:
            task = bar.add_task(f"sampling a {args.lut_size}³ LUT", total=args.lut_size**3)
            lut = correction_LUT(
                mc, lut_config, progress=lambda _, done, total: bar.update(task, completed=done, total=total)
            )
        write_correction_LUT(args.lut, lut, overwrite=args.overwrite)
        console.print(
            f"3-D LUT written to {args.lut} (white-balanced camera RGB under "
            f"{fit.illuminants[-1]} → linear {args.lut_space}, input 0…{args.headroom:g})",
            soft_wrap=True,
        )
    if args.save_correction:
        save_correction(args.save_correction, mc.corrector, overwrite=args.overwrite)
        console.print(f"correction saved to {args.save_correction}")
    return 0


def add_command(sub) -> None:
    """Register ``profile`` on the ``isp`` sub-parser collection."""
    from zonotope.correct.profile import LUT_SPACES

    p = sub.add_parser("profile", help="DNG camera profile (.dcp) and 3-D LUT from a camera's sensitivities")
    p.add_argument(
        "--camera",
        required=True,
        metavar="NAME_OR_FILE",
        help="built-in camera name or a rawtoaces JSON / CSV sensitivity file",
    )
    p.add_argument("-o", "--output", required=True, help="output .dcp file")
    from ..metamer import photograph_method

    p.add_argument(
        "--method",
        help=f"zonotope.correct estimator (default {photograph_method()}, zonotope's estimator for "
        "photographs, fitted for the noise)",
    )
    p.add_argument(
        "--noise",
        metavar="auto|σ|SHOT:READ",
        help="noise of the white-balanced responses (white = 1) the estimator is fitted for: auto "
        "(default: from --noise-dng, else noise-free), a σ such as 0.005 (0: noise-free), or shot "
        "and read variances per unit response as SHOT:READ",
    )
    p.add_argument(
        "--noise-dng",
        metavar="RAW",
        help="a RAW/DNG file of the camera whose noise the fit is for (its NoiseProfile when "
        "plausible, else estimated from its flat regions)",
    )
    p.add_argument(
        "--illuminants",
        nargs=2,
        default=["A", "D65"],
        metavar=("ILLUM1", "ILLUM2"),
        help="the two calibration illuminants (default A D65)",
    )
    p.add_argument("--training", default="rawtoaces 190", help="training reflectances (name or file)")
    p.add_argument(
        "--unique-camera-model",
        help="UniqueCameraModel, the string a raw developer matches to "
        "the file's camera (e.g. 'Canon EOS 550D'); default the name",
    )
    p.add_argument("--profile-name", help="ProfileName (default '<camera> <method> (zonotope)')")
    p.add_argument("--copyright", help="ProfileCopyright")
    p.add_argument(
        "--embed-policy",
        type=int,
        default=3,
        choices=[0, 1, 2, 3],
        help="ProfileEmbedPolicy: 0 allow copying, 1 embed if used, 2 never, 3 no restrictions",
    )
    p.add_argument(
        "--hue-sat-size",
        type=int,
        nargs=2,
        default=[90, 30],
        metavar=("HUES", "SATS"),
        help="ProfileHueSatMap divisions (default 90 30)",
    )
    p.add_argument(
        "--look-table-size",
        type=int,
        nargs=3,
        default=[36, 12, 8],
        metavar=("HUES", "SATS", "VALUES"),
        help="ProfileLookTable divisions, sRGB-encoded value axis (default 36 12 8)",
    )
    p.add_argument(
        "--no-look-table",
        action="store_true",
        help="no LookTable (exposure-invariant profile: matrices + HueSatMap only)",
    )
    p.add_argument(
        "--matrix-only", action="store_true", help="no HueSatMap or LookTable: ColorMatrix/ForwardMatrix only"
    )
    p.add_argument("--lut", help="also write a 3-D LUT (.cube or .csp) of the estimator")
    p.add_argument(
        "--lut-space",
        default="sRGB",
        choices=list(LUT_SPACES),
        help="LUT output space (linear; default sRGB)",
    )
    p.add_argument("--lut-size", type=int, default=33, help="LUT lattice size (default 33)")
    p.add_argument(
        "--headroom",
        type=float,
        default=16.0,
        help="largest LUT input in units of the white (default 16 = 4 stops)",
    )
    p.add_argument("--save-correction", metavar="FILE.npz", help="also save the fitted estimator")
    p.add_argument("--overwrite", action="store_true", help="replace existing output files")
    p.set_defaults(func=_profile)
