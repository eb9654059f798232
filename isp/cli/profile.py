"""``isp profile``: a DNG camera profile (and optionally an ICC profile, a 3-D LUT and a saved
correction) for a camera, from its spectral sensitivities or from a photographed chart.

Registered on the ``isp`` command by :func:`add_command`. From sensitivities (``--camera``) the DCP
is fitted by :func:`isp.profiles.fitting.fit_dcp`, the LUT sampled by
:func:`isp.profiles.lut.profile_LUT` and the saved correction written by
:mod:`zonotope.correct.profile`; from a chart (``--chart``) by :mod:`isp.profiles.chart`, the chart found by
:mod:`isp.profiles.chart_detect` unless ``--chart-corners`` gives it. The ICC
profile (:mod:`isp.profiles.icc`) holds the matrix part of either.
(It is an ``isp`` command, not a ``zonotope`` one, because ``zonotope`` never imports ``isp``.)
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np

from zonotope import ZonotopeError

from .._tol import LUT_OUTSIDE_QUANTUM, LUT_QUANTUM

__all__ = ["add_command"]


def _status(console, message: str):
    """Rich's spinner on a terminal; piped (where the spinner prints nothing), the message as a line."""
    import contextlib

    if console.is_terminal:
        return console.status(message)
    console.print(message, soft_wrap=True)
    return contextlib.nullcontext()


def _written_by_isp_profile(path: Path) -> bool:
    """Whether ``path`` is a DCP, ICC, LUT, report or saved correction that ``isp profile`` wrote (what
    --overwrite may replace): our DCPs carry the TIFF Software tag "zonotope profile", our ICC
    profiles the creator "zono", our LUTs a "zonotope:" comment, our reports their header line, our
    saved corrections the zonotope-correction format header."""
    suffix = path.suffix.lower()
    try:
        if suffix in (".icc", ".icm"):
            from ..profiles.icc import ICC_CREATOR

            with open(path, "rb") as fh:
                head = fh.read(128)
            return head[36:40] == b"acsp" and head[80:84] == ICC_CREATOR
        if suffix in (".csv", ".html"):
            from ..profiles.chart import REPORT_CSV_HEADER, REPORT_MARK

            with open(path, "rb") as fh:
                head = fh.read(4096)
            columns = REPORT_CSV_HEADER.rsplit(",", 1)[0]  # an earlier version's report lacks the last
            return head.startswith(columns.encode()) or REPORT_MARK.encode() in head
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


def _check_targets(args: argparse.Namespace, targets: list[Path]) -> None:
    """Refuse an existing output (without --overwrite) or one this command did not write."""
    for p in targets:
        if p.exists() and not args.overwrite:
            raise ZonotopeError(f"{p} exists; use --overwrite or another name.")
        if p.exists() and not _written_by_isp_profile(p):  # a third-party DCP, the user's own LUT, ...
            raise ZonotopeError(
                f"{p} exists and was not written by isp profile; --overwrite replaces only this "
                "command's outputs: choose another name."
            )


def _corners(values) -> list[tuple[float, float]]:
    """``--chart-corners X,Y X,Y X,Y X,Y`` as four (x, y) points."""
    import math

    try:
        pts = [tuple(float(v) for v in str(item).split(",")) for item in values]
    except ValueError:
        pts = []
    if len(pts) != 4 or any(len(p) != 2 or not all(map(math.isfinite, p)) for p in pts):
        raise ZonotopeError(
            f"--chart-corners {' '.join(map(str, values or []))}: give four X,Y pixel positions, the centres "
            "of the top-left, top-right, bottom-right and bottom-left patches (e.g. 712,624 1250,624 "
            "1250,930 712,930)."
        )
    return pts


def _tone_curve(args: argparse.Namespace):
    from ..profiles.tone import camera_tone_curve

    return None if args.no_tone_curve else camera_tone_curve()


def _chart_profile(args: argparse.Namespace, console) -> int:
    """``isp profile --chart RAW``: a one-illuminant DCP (and ICC) fitted to a photographed chart."""
    from ..profiles.chart import chart_dcp, chart_reference, fit_chart, read_chart, write_chart_report
    from ..profiles.dcp import write_dcp
    from ..profiles.models import canonical_model
    from ..raw import read_raw
    from ..simulate import ILLUMINANT_LIGHT_SOURCE

    for option, value in (
        ("--camera", args.camera),
        ("--lut", args.lut),
        ("--save-correction", args.save_correction),
        ("--noise-dng", args.noise_dng),
        ("--method", args.method),
    ):
        if value:
            raise ZonotopeError(
                f"{option} applies to a profile from sensitivities (--camera), not to --chart: remove it."
            )
    illuminant = args.illuminant or "D50"
    chart_reference(args.chart_type, illuminant)  # an unknown illuminant: refused before reading
    if illuminant.upper().replace(" ", "") not in ILLUMINANT_LIGHT_SOURCE:
        raise ZonotopeError(
            f"--illuminant {illuminant}: a DCP names its illuminant by an EXIF LightSource code; use one of "
            f"{sorted(ILLUMINANT_LIGHT_SOURCE)}."
        )
    corners = _corners(args.chart_corners) if args.chart_corners else None
    if corners is None and args.chart_type != "colorchecker":
        raise ZonotopeError(
            f"--chart-type {args.chart_type}: only a ColorChecker is found automatically; "
            "give --chart-corners."
        )
    if corners is None:
        from ..profiles.chart_detect import require_detector

        require_detector()  # a missing optional package is said before reading the file
    out = Path(args.output)
    report = Path(args.report) if args.report else out.with_name(out.stem + "_patches.csv")
    if report.suffix.lower() != ".csv":
        raise ZonotopeError(
            f"--report {report}: the per-patch report is a .csv file (an .html is written next to it)."
        )
    targets = [out, report, report.with_suffix(".html")] + ([Path(args.icc)] if args.icc else [])
    _check_targets(args, targets)
    raw = read_raw(args.chart)
    found = None
    if corners is None:
        from ..profiles.chart_detect import detect_chart

        with _status(console, f"finding the chart in {args.chart}…"):
            found = detect_chart(raw, chart=args.chart_type, illuminant=illuminant)
        corners = found.corners
    reading = read_chart(raw, corners, chart=args.chart_type)
    fit = fit_chart(reading, illuminant=illuminant)
    model = canonical_model(args.unique_camera_model or reading.camera)  # Adobe's name: what readers match
    dcp = chart_dcp(
        fit, unique_camera_model=model, profile_name=args.profile_name or "", copyright=args.copyright or ""
    )
    dcp = dcp.with_options(tone_curve=_tone_curve(args), embed_policy=args.embed_policy)
    write_dcp(out, dcp, overwrite=args.overwrite)
    if args.icc:
        _write_icc(
            args, dcp.forward_matrix_1, chart_reference(args.chart_type, illuminant)[2], dcp.profile_name
        )
    write_chart_report(fit, report, overwrite=args.overwrite)
    if found is not None:  # the user checks, and can correct, what was found
        console.print(
            f"chart found: --chart-corners {found.corner_args()} (patches 1, 6, 24, 19; chart turned "
            f"{found.angle:.0f}°{', mirrored' if found.mirrored else ''}, {found.squares} of 24 patches "
            "segmented)",
            soft_wrap=True,
        )
    e = fit.delta_E
    worst = np.argsort(e)[::-1][:3]
    console.print(
        f"camera profile written to {out} (UniqueCameraModel {model!r}, {args.chart_type} under "
        f"{illuminant}, "
        f"{'no tone curve' if dcp.tone_curve is None else 'tone curve'})",
        soft_wrap=True,
    )
    console.print(
        f"ΔE00 over {e.size} patches: mean {e.mean():.2f}, max {e.max():.2f}; worst "
        + ", ".join(f"{k + 1} {fit.names[k]} {e[k]:.2f}" for k in worst)
        + f"; per-patch report {report} and {report.with_suffix('.html').name}",
        soft_wrap=True,
    )
    return 0


def _write_icc(args: argparse.Namespace, forward_matrix, white_XYZ, name: str) -> None:
    from ..profiles.icc import icc_profile, write_icc

    data = icc_profile(
        forward_matrix, description=name, copyright=args.copyright or "", illuminant_XYZ=white_XYZ
    )
    write_icc(args.icc, data, overwrite=args.overwrite)


def _profile(args: argparse.Namespace) -> int:
    from rich.console import Console

    console = Console(stderr=True)
    out = Path(args.output)
    if out.suffix.lower() != ".dcp":
        raise ZonotopeError(f"-o {out}: a camera profile is written as a .dcp file.")
    if args.icc and Path(args.icc).suffix.lower() not in (".icc", ".icm"):
        raise ZonotopeError(f"--icc {args.icc}: an ICC profile is a .icc (or .icm) file.")
    if bool(args.camera) == bool(args.chart):
        raise ZonotopeError(
            "give --camera NAME_OR_FILE (a profile from spectral sensitivities) or --chart RAW (from a "
            "photographed chart), one of the two."
        )
    if args.chart:
        return _chart_profile(args, console)
    if args.report or args.chart_corners:
        raise ZonotopeError("--report and --chart-corners apply to --chart RAW: remove them or give --chart.")
    return _camera_profile(args, console)


def _camera_profile(args: argparse.Namespace, console) -> int:
    from zonotope.correct.profile import LUTConfig, save_correction, write_correction_LUT

    from ..profiles.dcp import write_dcp
    from ..profiles.fitting import ProfileConfig, fit_dcp
    from ..profiles.lut import lut_header, profile_LUT
    from ..profiles.models import canonical_model

    out = Path(args.output)
    targets = [out] + [Path(p) for p in (args.lut, args.save_correction, args.icc) if p]
    if args.lut and Path(args.lut).suffix.lower() not in (".cube", ".csp"):
        raise ZonotopeError(f"--lut {args.lut}: use a .cube (Resolve) or .csp (Cinespace) file.")
    if args.save_correction and Path(args.save_correction).suffix.lower() != ".npz":  # before the fit
        raise ZonotopeError(f"--save-correction {args.save_correction}: a saved correction is a .npz file.")
    _check_targets(args, targets)
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
    keys = [i.upper().replace(" ", "") for i in args.illuminants]
    illuminant = args.illuminant or args.illuminants[1]
    if illuminant.upper().replace(" ", "") not in keys:
        raise ZonotopeError(
            f"--illuminant {illuminant}: the LUT and ICC profile are fitted under one of the calibration "
            f"illuminants ({' and '.join(args.illuminants)}); give one of them, or change --illuminants."
        )
    which = keys.index(illuminant.upper().replace(" ", ""))
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
            unique_camera_model=canonical_model(args.unique_camera_model)
            if args.unique_camera_model
            else None,
            profile_name=args.profile_name,
            copyright=args.copyright or "",
            embed_policy=args.embed_policy,
        )
    except ZonotopeError as error:  # ProfileConfig names its field: say which option it came from
        if not str(error).startswith("ProfileConfig.illuminants="):
            raise
        raise type(error)(f"--illuminants {' '.join(args.illuminants)}: {error}") from error
    lut_config = None
    if not (args.lut_quantum >= 0 and np.isfinite(args.lut_quantum)):
        raise ZonotopeError(
            f"--lut-quantum {args.lut_quantum:g}: give a grouping radius ≥ 0 (0: every node)."
        )
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
    profile = fit.profile.with_options(tone_curve=_tone_curve(args))
    write_dcp(out, profile, overwrite=args.overwrite)
    console.print(
        f"camera profile written to {out} (UniqueCameraModel {profile.unique_camera_model!r}, "
        f"{'matrices only' if dims is None else f'HueSatMap {dims[0]}×{dims[1]}'}"
        f"{'' if look is None else f', LookTable {look[0]}×{look[1]}×{look[2]}'}"
        f"{'' if profile.tone_curve is None else ', tone curve'})",
        soft_wrap=True,
    )
    mc = fit.corrections[which]  # the estimator under --illuminant
    if args.icc:
        FM = (profile.forward_matrix_1, profile.forward_matrix_2)[which]
        white = np.asarray(mc(np.ones((1, 3))), dtype=np.float64)[0]  # what the ForwardMatrix adapts from
        _write_icc(args, FM, white, f"{profile.profile_name} {fit.illuminants[which]}")
        console.print(
            f"ICC profile written to {args.icc} (matrix under {fit.illuminants[which]})", soft_wrap=True
        )
    if args.lut:
        from ._console import _progress  # rich's bar on a terminal, plain timed lines when piped

        quantum = args.lut_quantum
        with _progress(console, quiet=False) as bar:
            task = bar.add_task(f"sampling a {args.lut_size}³ LUT", total=1)
            lut = profile_LUT(
                mc,
                lut_config,
                quantum=quantum,
                progress=lambda _, done, total: bar.update(task, completed=done, total=total),
            )
        lut_header(
            lut,
            camera=str(args.camera),
            method=mc.method,
            illuminant=fit.illuminants[which],
            space=lut_config.space,
            headroom=args.headroom,
            quantum=quantum,
            outside_quantum=LUT_OUTSIDE_QUANTUM,
        )
        write_correction_LUT(args.lut, lut, overwrite=args.overwrite)
        console.print(
            f"3-D LUT written to {args.lut} (camera RGB white-balanced for {fit.illuminants[which]} → "
            f"linear {args.lut_space}, input 0…{args.headroom:g})",
            soft_wrap=True,
        )
    if args.save_correction:
        save_correction(args.save_correction, mc.corrector, overwrite=args.overwrite)
        console.print(f"correction saved to {args.save_correction}")
    return 0


def add_command(sub) -> None:
    """Register ``profile`` on the ``isp`` sub-parser collection."""
    from zonotope.correct.profile import LUT_SPACES

    from ..profiles.chart import CHART_TYPES

    p = sub.add_parser(
        "profile",
        help="camera profile (.dcp, .icc) and 3-D LUT from a camera's sensitivities or a photographed chart",
    )
    p.add_argument(
        "--camera",
        metavar="NAME_OR_FILE",
        help="built-in camera name or a rawtoaces JSON / CSV sensitivity file (or give --chart)",
    )
    p.add_argument(
        "--chart",
        metavar="RAW",
        help="fit from a RAW/DNG photograph of a chart instead (with --illuminant; the ColorChecker is "
        "found automatically, or give --chart-corners)",
    )
    p.add_argument(
        "--chart-corners",
        nargs=4,
        metavar="X,Y",
        help="pixel centres of the top-left, top-right, bottom-right and bottom-left patches "
        "(ColorChecker: dark skin, bluish green, black, white) in the RAW file's frame (default: found "
        "automatically, with the 'chart' extra)",
    )
    p.add_argument(
        "--chart-type",
        default="colorchecker",
        choices=sorted(CHART_TYPES),
        help="chart (default colorchecker)",
    )
    p.add_argument(
        "--report",
        metavar="FILE.csv",
        help="per-patch ΔE00 report of --chart (an .html table is written next to it; default "
        "<output>_patches.csv)",
    )
    p.add_argument(
        "--illuminant",
        help="with --chart: the light the chart was shot under (default D50); with --camera: the "
        "calibration illuminant the ICC profile and the LUT are for (default the second of --illuminants)",
    )
    p.add_argument("-o", "--output", required=True, help="output .dcp file")
    p.add_argument(
        "--icc",
        metavar="FILE.icc",
        help="also write an ICC v4 input profile (matrix/TRC: darktable, RawTherapee, other ICC users)",
    )
    p.add_argument(
        "--no-tone-curve",
        action="store_true",
        help="no ProfileToneCurve in the DCP (default: a camera-like curve, mid-grey 0.18 → 0.39)",
    )
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
        "the file's camera (e.g. 'Canon EOS 550D'; regional names such as 'Kiss X4' are written as "
        "Adobe's); default the name",
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
    p.add_argument(
        "--lut-quantum",
        type=float,
        default=LUT_QUANTUM,
        metavar="Q",
        help=f"LUT nodes that need a solver within Q of each other are solved once (default {LUT_QUANTUM:g}; "
        f"nodes no surface colour uses within {LUT_OUTSIDE_QUANTUM:g}; 0: every node, several "
        "times slower for MMV-based estimators; 0.005: faster, less exact on atypical colours)",
    )
    p.add_argument("--save-correction", metavar="FILE.npz", help="also save the fitted estimator")
    p.add_argument("--overwrite", action="store_true", help="replace existing output files")
    p.set_defaults(func=_profile)
