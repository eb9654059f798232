"""``isp develop`` (a RAW file or a folder of them) and ``isp info``.

The folder branch builds the options and calls :func:`isp.batch.develop_folder`; the single-file
branch shows the development stage by stage.
"""

from __future__ import annotations

import argparse
import math
from pathlib import Path

from ._console import _fail, _progress

__all__ = ["add_develop", "add_info"]

_ORIENTATION = {
    1: "as stored",
    2: "mirrored",
    3: "rotated 180°",
    4: "mirrored top–bottom",
    5: "transposed",
    6: "rotate 90° clockwise",
    7: "transverse",
    8: "rotate 90° counter-clockwise",
}

#: Options of ``isp develop`` that only the metamer correction uses (argparse dest → flag).
_METAMER_OPTIONS = {
    "camera": "--camera",
    "method": "--method",
    "illuminant": "--illuminant",
    "reference": "--reference",
    "training": "--training",
    "scene_white": "--scene-white",
    "quantum": "--quantum",
    "noise": "--noise",
}


def _noise_request(text: str | None):
    """``(noise, None)`` from ``--noise`` (``"auto"``, a NoiseModel, or None for noise-free), or
    ``(None, message)``; the syntax is ``zonotope correct --noise``'s, parsed by zonotope."""
    from zonotope.correct import NoiseModel, NoiseModelError, noise_model, parse_noise

    if text is None:
        return "auto", None
    try:
        value = parse_noise(text)  # one --noise syntax for every command
    except NoiseModelError as exc:
        return None, str(exc)
    if value == "auto":
        return "auto", None
    try:
        model = noise_model(value, 3)
    except NoiseModelError as exc:
        return None, f"--noise {text}: {exc}"
    return (None if model is None else NoiseModel(model.shot, model.read, "--noise")), None


def _resolve_noise(raw, args: argparse.Namespace, config, noise):
    """``config`` with the noise of ``raw`` (:func:`isp.metamer.metamer_noise`), and its note."""
    import dataclasses

    from ..metamer import metamer_noise

    model, note = metamer_noise(raw, white_balance=args.wb, white_level=config.white_level, noise=noise)
    return dataclasses.replace(config, noise=model), note


def _noise_line(model, note: str) -> str:
    """What ``noise:`` says: the model and its source, or none, and why a source was passed over."""
    text = "none (noise-free fit)" if model is None else model.describe()
    return text + (f" ({note})" if note else "")


def _metamer_config(args: argparse.Namespace):
    """``(MetamerConfig, noise, None)`` for ``--correction metamer`` (``noise``: ``"auto"``, a model or
    None, resolved against the file by :func:`_resolve_noise`), ``(None, None, None)`` without it, or
    ``(None, None, message)`` (exit 2) when the options are wrong; checked before any fit."""
    config, error = _metamer_options(args)
    if config is None:
        return None, None, error
    noise, error = _noise_request(args.noise)
    return (None, None, error) if error else (config, noise, None)


def _metamer_options(args: argparse.Namespace):
    """``(MetamerConfig, None)``, ``(None, None)`` or ``(None, message)`` (see :func:`_metamer_config`)."""
    from .._tol import EXPOSURE_STOPS_MAX
    from ..metamer import MetamerConfig

    if args.correction != "metamer":
        given = [flag for dest, flag in _METAMER_OPTIONS.items() if getattr(args, dest) is not None]
        return None, (
            f"{', '.join(given)} appl{'ies' if len(given) == 1 else 'y'} to --correction metamer only."
            if given
            else None
        )
    if args.camera is None:
        import zonotope

        return None, (
            "--correction metamer needs --camera NAME_OR_FILE (the camera's spectral "
            "sensitivities: a built-in name — "
            + ", ".join(zonotope.list_builtin()["cameras"])
            + " — or a file zonotope.load_camera reads)."
        )
    if args.quantum is not None and not 0 <= args.quantum < float("inf"):
        return None, f"--quantum {args.quantum}: must be a finite number ≥ 0."
    if args.scene_white is not None and not (
        0 < args.scene_white < float("inf") and abs(math.log2(args.scene_white)) <= EXPOSURE_STOPS_MAX
    ):
        return None, (
            f"--scene-white {args.scene_white:g}: must be > 0 and within ±{EXPOSURE_STOPS_MAX:g} stops of 1 "
            "(1 when a white reflector just saturates)."
        )
    error = _light_error(args)
    if error:
        return None, error
    defaults = MetamerConfig()
    config = MetamerConfig(
        method=args.method or defaults.method,
        illuminant=args.illuminant or defaults.illuminant,
        reference=args.reference,
        training=args.training or defaults.training,
        white_level=defaults.white_level if args.scene_white is None else args.scene_white,
        quantum=defaults.quantum if args.quantum is None else args.quantum,
    )
    return config, None


def _light_error(args: argparse.Namespace) -> str | None:
    """One line for an unknown ``--illuminant`` or ``--reference`` (listing the lights), or None."""
    import zonotope

    for flag, name in (("--illuminant", args.illuminant), ("--reference", args.reference)):
        if name is not None:
            try:
                zonotope.illuminant(name)
            except zonotope.ZonotopeError as exc:
                return f"{flag} {name}: {exc}"
    return None


def _pipeline(args: argparse.Namespace):
    """``(pipeline, None)`` built from the develop options (without a metamer fit), or ``(None, message)``."""
    from ..pipeline import default_pipeline
    from ..stages import DEMOSAIC_METHODS, TONEMAP_METHODS

    tonemap = None if args.tonemap.lower() == "none" else args.tonemap
    DEMOSAIC_METHODS.resolve(args.demosaic, argument="--demosaic")  # unknown names: before any work
    if tonemap is not None:
        TONEMAP_METHODS.resolve(tonemap, argument="--tonemap")
    options = {}
    if args.exposure is not None:
        import inspect

        takes = [n for n in TONEMAP_METHODS if "exposure" in inspect.signature(TONEMAP_METHODS[n]).parameters]
        if tonemap is None or TONEMAP_METHODS.resolve(tonemap) not in takes:
            return None, (
                f"--exposure applies to --tonemap {' or '.join(takes)} only "
                "(Reinhard 2002 sets the exposure from the image's log-average luminance)."
            )
        from .._tol import EXPOSURE_STOPS_MAX

        if not abs(args.exposure) <= EXPOSURE_STOPS_MAX:  # NaN fails too
            return None, (
                f"--exposure {args.exposure:g}: give a finite gain within ±{EXPOSURE_STOPS_MAX:g} stops."
            )
        options = {"exposure": args.exposure}
    pipeline = default_pipeline(
        demosaic=args.demosaic,
        tonemap=tonemap,
        tonemap_options=options,
        white_balance=args.wb,
    )
    if getattr(args, "profile", None):  # a DNG camera profile (isp.profiles.dcp) replaces camera_to_XYZ
        if args.correction != "dng":
            return None, (
                "--profile replaces the DNG ColorMatrix; it cannot be combined with --correction metamer."
            )
        from ..profiles.dcp import profile_pipeline

        pipeline = profile_pipeline(pipeline, args.profile, white_balance=args.wb)
    return pipeline, None


def _develop_folder(args: argparse.Namespace) -> int:
    """The folder branch of ``isp develop`` (prints; returns the exit status).

    Exit status 0 when every file was developed (now or by an earlier run), 1 when some failed
    (listed, and in the manifest), 2 for bad options.
    """
    from rich.console import Console

    from ..batch import develop_folder

    console = Console(stderr=True)
    out_dir = Path(args.output)
    if getattr(args, "overwrite", False):
        return _fail(
            "--overwrite does not apply to folders: a rerun keeps finished "
            "outputs (delete them to develop again)."
        )
    config, noise, error = _metamer_config(args)
    if error:
        return _fail(error)
    pipeline, error = _pipeline(args)
    if error:
        return _fail(error)
    # what the outputs depend on: a rerun into this folder (which skips finished files) must ask for the same
    ignore = {"func", "scheduler", "quiet", "input", "output", "overwrite", "command"}
    settings = {k: v for k, v in sorted(vars(args).items()) if k not in ignore}
    if settings.get("reference") is None:  # absent: as under the scene light (older folders resume)
        settings.pop("reference", None)
    else:
        settings["reference"] = f"colours as under {settings['reference']}"
    if config is not None:  # one fit for the folder: the noise of its first file
        other = _folder_makers(args)
        if other:
            console.print(f"[yellow]warning:[/] {other}", soft_wrap=True)
        config, note, origin = _folder_noise(args, config, noise)  # develop_folder records it in settings
        if not args.quiet or note:
            said = "; ".join(x for x in (note, origin) if x)
            console.print(f"noise: {_noise_line(config.noise, said)}", soft_wrap=True)
    with _progress(console, args.quiet) as bar:  # plain timed lines when stderr is not a terminal
        task: list[int] = []

        def on_progress(description: str, done: int, total: int) -> None:
            if not task:
                task.append(bar.add_task(description, total=total))
            else:
                bar.update(task[0], completed=done)

        rows = develop_folder(
            args.input,
            out_dir,
            pipeline=pipeline,
            metamer=None if config is None else (args.camera, config),
            executor=getattr(args, "scheduler", None),
            crop=args.crop,
            save_stages=args.save_stages,
            settings=settings,
            progress=on_progress,
        )
    failed = [r for r in rows if r["status"] == "failed"]
    counts = {s: sum(r["status"] == s for r in rows) for s in ("ok", "done", "failed")}
    for r in failed:
        console.print(f"[red]failed:[/] {r['input']}: {r['error']}", soft_wrap=True)
    if not args.quiet or failed:
        console.print(
            f"{counts['ok']} developed, {counts['done']} already done, {counts['failed']} failed "
            f"→ {out_dir} (manifest: {out_dir / 'manifest.csv'})",
            soft_wrap=True,
        )
    return 1 if failed else 0


def _folder_makers(args: argparse.Namespace) -> str | None:
    """A warning naming the DNG files of the folder made by another manufacturer than the one
    ``--camera``'s sensitivities name (:func:`isp.metamer.maker_mismatch`), else None. Why: one fit
    serves the whole folder, so a folder that mixes cameras gets one camera's colours for all; only
    the DNG tags are read (other RAW files record no make here)."""
    from .._errors import PipelineError, RawFormatError
    from ..batch import raw_files
    from ..dng import read_dng_tags
    from ..metamer import maker_mismatch, sensitivities_maker

    if sensitivities_maker(args.camera) is None:
        return None
    makes: dict[str, list[str]] = {}
    try:
        files = [f for f in raw_files(args.input) if f.suffix.lower() == ".dng"]
    except PipelineError:
        return None
    for f in files:
        try:
            make = str(read_dng_tags(f).get("Make", "") or "").strip()
        except (OSError, RawFormatError):
            continue  # the development says what is wrong with it
        makes.setdefault(make, []).append(f.name)
    others = {make: v for make, v in makes.items() if maker_mismatch(args.camera, make)}  # once a make
    if not others:
        return None
    n = sum(len(v) for v in others.values())
    listed = ", ".join(
        f"{make} ({len(v)}: {', '.join(v[:3])}{', …' if len(v) > 3 else ''})" for make, v in others.items()
    )
    return (
        f"{n} of {len(files)} DNG files are not from a {sensitivities_maker(args.camera)} camera, the maker "
        f"--camera {args.camera!r} names: {listed}; their colours are right only if these are their "
        "sensor's curves (develop each camera's files with its own --camera, in its own folder)."
    )


def _folder_noise(args: argparse.Namespace, config, noise):
    """``config`` with the noise of the folder's first RAW file, the note of :func:`_resolve_noise` and
    which file it came from ("" when the noise was given)."""
    import dataclasses

    from .._errors import PipelineError, RawFormatError
    from ..batch import raw_files
    from ..raw import read_raw

    if noise != "auto":
        return dataclasses.replace(config, noise=noise), "", ""
    try:
        files = raw_files(args.input)
        raw = read_raw(files[0])
        if args.crop:
            raw = raw.crop(*args.crop)
    except (IndexError, OSError, PipelineError, RawFormatError) as exc:
        return dataclasses.replace(config, noise=None), f"noise not measured: {exc}", ""
    config, note = _resolve_noise(raw, args, config, noise)
    return config, note, f"from {files[0].name}, for every file of the folder"


def _develop(args: argparse.Namespace) -> int:
    """``isp develop``; running out of memory is a one-line error naming the file, not a traceback."""
    from .._errors import PipelineError

    try:
        return _develop_one_or_folder(args)
    except MemoryError:
        raise PipelineError(
            f"{args.input}: out of memory while developing it; close other programs, develop a part "
            "of it with --crop, or use a machine with more memory."
        ) from None


def _develop_one_or_folder(args: argparse.Namespace) -> int:
    from rich.console import Console

    from ..exif import output_tags, srgb_icc_profile
    from ..io import write_image
    from ..pipeline import correction_stage
    from ..raw import read_raw
    from ..whitebalance import describe_white_balance

    console = Console(stderr=True)
    src = Path(args.input)
    out = Path(args.output)
    if src.is_dir():  # a folder batch: every RAW file, the same options (isp.batch)
        return _develop_folder(args)
    from .._errors import PipelineError
    from .._tol import NEUTRAL_MISMATCH
    from ..io import IMAGE_FORMATS, _is_our_output

    if out.suffix.lower() not in IMAGE_FORMATS:  # before the development, not when writing it
        raise PipelineError(f"{out}: unknown image format {out.suffix!r}; use one of {list(IMAGE_FORMATS)}.")
    if out.exists() and (not args.overwrite or (src.exists() and out.resolve() == src.resolve())):
        # checked before the long work (a metamer fit takes minutes), not only when writing
        raise PipelineError(f"{out} exists; pass --overwrite or choose another name (never the input).")
    if out.exists() and not _is_our_output(out):
        raise PipelineError(
            f"{out} exists and was not written by isp; --overwrite replaces only isp outputs."
        )
    config, noise, error = _metamer_config(args)
    if error:
        return _fail(error)
    pipeline, error = _pipeline(args)
    if error:
        return _fail(error)
    metamer = raw = None
    if config is not None:  # the file is read first: the fit is for its noise
        from ..metamer import metamer_correction

        raw = read_raw(src)
        if args.crop:
            raw = raw.crop(*args.crop)
        config, note = _resolve_noise(raw, args, config, noise)
        if not args.quiet or note:
            console.print(f"noise: {_noise_line(config.noise, note)}", soft_wrap=True)
        metamer = metamer_correction(args.camera, config)
        pipeline = pipeline.replace("camera_to_XYZ", correction_stage(metamer))
    if args.save_stages:
        stage_dir = Path(args.save_stages)
        if stage_dir.exists() and any(stage_dir.iterdir()) and not args.overwrite:
            return _fail(f"--save-stages {stage_dir} is not empty; use --overwrite or another folder.")
    with _progress(console, args.quiet) as progress:
        task = progress.add_task(f"reading {src.name}", total=len(pipeline) + 2)
        if raw is None:
            raw = read_raw(src)
            if args.crop:
                raw = raw.crop(*args.crop)
        wb = describe_white_balance(raw, args.wb)
        progress.advance(task)
        other = _profile_camera_mismatch(getattr(args, "profile", None), raw)
        if other:
            console.print(f"[yellow]warning:[/] {other}", soft_wrap=True)
        if metamer is not None:
            from ..metamer import maker_mismatch

            other = maker_mismatch(args.camera, raw.make)
            if other:
                console.print(f"[yellow]warning:[/] {src.name}: {other}", soft_wrap=True)
            mismatch = metamer.neutral_mismatch(raw.as_shot_neutral)
            if mismatch > NEUTRAL_MISMATCH:
                console.print(
                    f"[yellow]warning:[/] the file's AsShotNeutral differs by "
                    f"{100 * mismatch:.0f} % from the white of {args.camera!r} under "
                    f"{args.illuminant or 'D65'}: the light was not that illuminant (set "
                    "--illuminant) or the sensitivities are not this camera's.",
                    soft_wrap=True,
                )

            colour_task = []

            def on_colours(stage: str, done: int, total: int) -> None:  # a second bar: distinct colours
                if not colour_task:
                    colour_task.append(
                        progress.add_task(f"  {metamer.method}: distinct colours", total=total)
                    )
                progress.update(colour_task[0], completed=done, total=total)

            metamer.progress = on_colours

        def on_stage(stage: str, done: int, total: int) -> None:  # zonotope.ProgressCallback
            name = pipeline.stages[done].name if done < total else "developed"
            progress.update(task, completed=done + 1, description=name)

        dev = pipeline(raw, progress=on_stage, keep=bool(args.save_stages))
        progress.update(task, completed=len(pipeline) + 1, description=f"writing {out.name}")
        encoded = "encode_sRGB" in pipeline.names
        write_image(
            out,
            dev.image,
            overwrite=args.overwrite,
            protect=[src],
            icc_profile=srgb_icc_profile() if encoded else None,
            tiff_tags=output_tags(raw),
        )
        if args.save_stages:
            stage_dir.mkdir(parents=True, exist_ok=True)
            for i, (name, arr) in enumerate(dev.intermediates.items()):
                write_image(
                    stage_dir / f"{i:02d}_{name}.tif",
                    arr,
                    dtype="float32",
                    overwrite=args.overwrite,
                    protect=[src],
                )
        progress.update(task, completed=len(pipeline) + 2, description="done")
    if metamer is not None and metamer.fallbacks:
        console.print(
            f"[yellow]note:[/] {metamer.fallbacks} colour(s) had no {metamer.method} estimate "
            "(response on or outside the camera's object-colour solid); root-polynomial "
            "regression used for them.",
            soft_wrap=True,
        )
    if not args.quiet:
        how = (
            f"metamer correction {metamer.method}, {args.camera}, {args.illuminant or 'D65'}, "
            f"colours as under {args.reference or args.illuminant or 'D65'}, "
            f"noise {metamer.describe_noise()}"
            if metamer is not None
            else ("DNG ColorMatrix" if raw.is_dng else "LibRaw's built-in camera matrix")
        )
        if getattr(args, "profile", None):
            how = f"camera profile {args.profile}"
        turned = "" if raw.orientation == 1 else f", Orientation {raw.orientation} applied"
        console.print(
            f"{src} → {out} ({dev.image.shape[1]}×{dev.image.shape[0]}{turned}, "
            f"{' → '.join(pipeline.names)}; {how}; white balance: {wb})",
            soft_wrap=True,  # one line however narrow the terminal (or 80 columns when piped)
        )
    return 0


def _info(args: argparse.Namespace) -> int:
    import numpy as np
    from rich.console import Console
    from rich.table import Table

    from .._errors import RawFormatError
    from ..raw import read_raw
    from ..whitebalance import describe_white_balance

    try:
        raw = read_raw(args.input, metadata_only=args.metadata_only)
    except RawFormatError as error:
        if args.metadata_only:
            raise
        raise RawFormatError(f"{error} On the command line: isp info --metadata-only FILE.") from error
    p = raw.profile
    table = Table(title=str(args.input), show_header=False)
    # DNG Model tags often repeat the make ("Canon" + "Canon EOS Kiss X4"): print it once
    model = raw.model if raw.make and raw.model.startswith(raw.make) else f"{raw.make} {raw.model}"
    rows = {
        "make / model": model.strip() or "(not recorded)",
        "size (H × W)": f"{raw.shape[0]} × {raw.shape[1]}",
        "CFA": raw.cfa,
        "black level": str(raw.black_level.ravel().tolist()),
        "white level": f"{raw.white_level:g}",
        "as-shot neutral": np.array2string(raw.as_shot_neutral, precision=4),
        "white balance source": describe_white_balance(raw, "as-shot"),
        "orientation": f"{raw.orientation} ({_ORIENTATION[raw.orientation]})",
        "capture": ", ".join(
            f"{k} {v:g}" if isinstance(v, float) else f"{k} {v}" for k, v in raw.capture.items()
        )
        or "(not recorded)",
        "AnalogBalance": np.array2string(p.analog_balance, precision=4),
        "CalibrationIlluminant1/2": f"{p.calibration_illuminant_1} / {p.calibration_illuminant_2}",
    }
    for name in (
        "color_matrix_1",
        "color_matrix_2",
        "camera_calibration_1",
        "camera_calibration_2",
        "forward_matrix_1",
        "forward_matrix_2",
    ):
        m = getattr(p, name)
        rows[name] = "—" if m is None else np.array2string(m, precision=4)
    for k, v in rows.items():
        table.add_row(k, v)
    Console().print(table)
    return 0


def _profile_camera_mismatch(profile, raw) -> str | None:
    """A warning when ``--profile FILE`` was made for another camera than the RAW file's, else None.

    Raw developers offer a DCP only for the camera named by its UniqueCameraModel; ``--profile``
    applies any file, so a Nikon profile on a Canon file would go unnoticed. Names are compared
    without case and spacing, and one may contain the other ("Canon EOS 550D" in "Canon Canon EOS
    550D") or be its regional name (Kiss X4, Rebel T2i: :func:`isp.profiles.models.same_camera`); files
    without a recorded model (non-DNG RAW) are not checked.
    """
    if not profile or str(profile).lower() == "embedded":
        return None
    from ..profiles.dcp import read_dcp
    from ..profiles.models import same_camera

    made_for = read_dcp(profile).unique_camera_model
    tags = getattr(raw, "tags", None) or {}
    model = str(tags.get("UniqueCameraModel", "") or "") or f"{raw.make} {raw.model}".strip()

    def norm(name: str) -> str:
        return "".join(name.lower().split())

    a, b = norm(made_for), norm(model)
    if not a or not b or a in b or b in a or same_camera(made_for, model):  # regional names too
        return None
    return (
        f"{profile} is a profile for {made_for!r} (its UniqueCameraModel) but this file is from "
        f"{model!r}: the colours are right only for that camera."
    )


def add_develop(sub) -> None:
    """Register ``develop`` on the ``isp`` sub-parser collection."""
    from zonotope.correct import CORRECTION_METHODS
    from zonotope.parallel import SCHEDULER_HELP

    from .._tol import EXPOSURE_STOPS_MAX
    from ..metamer import photograph_method
    from ..stages import DEMOSAIC_METHODS, TONEMAP_METHODS, default_method

    d = sub.add_parser("develop", help="develop a RAW/DNG file to a 16-bit TIFF or PNG")
    d.add_argument("input", help="RAW or DNG file, or a folder of them (then -o is a folder)")
    d.add_argument("-o", "--output", required=True, help="output .tif/.tiff/.png (never the input)")
    d.add_argument(
        "--scheduler",
        help="folders only: where to run; " + SCHEDULER_HELP,
    )
    d.add_argument(
        "--demosaic",
        default=default_method(DEMOSAIC_METHODS),
        help=f"demosaicing method: {', '.join(DEMOSAIC_METHODS)} (default %(default)s)",
    )
    d.add_argument(
        "--correction",
        default="dng",
        choices=["dng", "metamer"],
        help="colour correction: dng = the file's ColorMatrix/ForwardMatrix, CCT-interpolated "
        "(default); metamer = a zonotope.correct estimator fitted on the camera's "
        "spectral sensitivities (needs --camera)",
    )
    d.add_argument(
        "--profile",
        metavar="DCP|embedded",
        help="apply a DNG camera profile (.dcp: matrices, HueSatMap, LookTable, tone curve, in "
        "the DNG spec's order) instead of the ColorMatrix; 'embedded' = the DNG's own "
        "profile tags",
    )
    m = d.add_argument_group("metamer correction (with --correction metamer)")
    m.add_argument(
        "--camera",
        metavar="NAME_OR_FILE",
        help="the camera's spectral sensitivities: a built-in name (zonotope.list_builtin()) or "
        "a rawtoaces/camspec JSON or CSV file",
    )
    m.add_argument(
        "--method",
        help=f"zonotope.correct estimator: {', '.join(CORRECTION_METHODS)} or an "
        "alias such as root-polynomial (case and punctuation ignored; default "
        f"{photograph_method()}, zonotope's estimator for photographs, fitted for the noise)",
    )
    m.add_argument(
        "--illuminant",
        help="scene illuminant of the fit (default D65); the file's white balance should be for this light",
    )
    m.add_argument(
        "--reference",
        metavar="LIGHT",
        help="develop the colours as under this light (e.g. D65: the estimator is fitted scene light "
        "→ LIGHT; default: as under the scene light, --illuminant); the sRGB output stays D65-referred",
    )
    m.add_argument(
        "--training",
        metavar="NAME_OR_FILE",
        help="training reflectances: built-in set or file (default rawtoaces 190)",
    )
    m.add_argument(
        "--scene-white",
        type=float,
        metavar="FRACTION",
        help="response of a perfect white reflector after white balance, as a fraction of "
        "saturation (default 1); the metamer-based estimators (not the regressions) "
        "depend on the exposure",
    )
    m.add_argument(
        "--noise",
        metavar="auto|σ|SHOT:READ",
        help="noise of the responses (white = 1) the estimator is fitted for: auto (default: the "
        "DNG NoiseProfile when present and plausible, else estimated from the mosaic's flat "
        "regions; for a folder, from its first file), a σ such as 0.005 (0: noise-free), or shot "
        "and read variances per unit response as SHOT:READ",
    )
    m.add_argument(
        "--quantum",
        type=float,
        help="responses that round to the same multiple of this are corrected once "
        "(default 0.002, white = 1; 0 = exact colours only)",
    )
    d.add_argument(
        "--wb",
        default="as-shot",
        metavar="WHITE_BALANCE",
        help="white balance: as-shot (default, the file's), daylight (5500 K), a temperature "
        "such as 3200K, a CIE illuminant (D65, A, FL2, ...) or spot:x0,y0,x1,y1 (mean of a "
        "grey patch, pixel coordinates of the developed image, x1 and y1 excluded)",
    )
    d.add_argument(
        "--tonemap",
        default=default_method(TONEMAP_METHODS),
        help=f"global tone mapping: {', '.join(TONEMAP_METHODS)} or none (default %(default)s)",
    )
    d.add_argument(
        "--exposure",
        type=float,
        default=None,
        help=f"gain in stops before clipping, within ±{EXPOSURE_STOPS_MAX:g} (after auto-bright's scaling; "
        "with --tonemap auto-bright or clip)",
    )
    d.add_argument(
        "--crop",
        type=int,
        nargs=4,
        metavar=("TOP", "LEFT", "HEIGHT", "WIDTH"),
        help="develop only this part of the mosaic (TOP and LEFT even)",
    )
    d.add_argument("--save-stages", metavar="DIR", help="also write every intermediate as float32 TIFF")
    d.add_argument("--overwrite", action="store_true", help="replace existing output files")
    d.add_argument("-q", "--quiet", action="store_true", help="no progress display")
    d.set_defaults(func=_develop)


def add_info(sub) -> None:
    """Register ``info`` on the ``isp`` sub-parser collection."""
    i = sub.add_parser("info", help="print the metadata of a RAW/DNG file")
    i.add_argument("input")
    i.add_argument("--metadata-only", action="store_true", help="accept files without pixel data")
    i.set_defaults(func=_info)
