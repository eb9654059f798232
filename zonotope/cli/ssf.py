"""``zonotope ssf estimate``: spectral sensitivities of a camera from its DNG and/or a chart photograph."""

from __future__ import annotations

import argparse
import sys

__all__ = ["add_commands"]


def _read_chart_csv(path: str):
    """``(means (N, 3), light or None)`` from a CSV/TXT file: one row per patch, R, G, B (a header line
    is skipped).

    A header naming ``raw_R, raw_G, raw_B`` (the per-patch report ``isp profile --chart`` writes) or
    ``R, G, B`` picks those columns; otherwise the last three cells of each row are read. An
    ``illuminant`` column (the report has one) gives the light the chart was photographed under. Why:
    the profile's report is where a photographer already has the patch means of a chart photograph.
    """
    from pathlib import Path

    import numpy as np

    from .._errors import SpectralDataError

    p = Path(path)
    if not p.is_file():
        raise SpectralDataError(
            f"--chart {path}: no such file; give a CSV of raw patch means (R,G,B per row)."
        )
    rows, lights = [], set()
    try:
        lines = p.read_text(encoding="utf-8").splitlines()
    except (OSError, UnicodeDecodeError) as error:
        raise SpectralDataError(f"--chart {path}: cannot read it ({error}).") from None
    columns = light = None  # the header's R, G, B (None: the last three cells) and illuminant columns
    for i, line in enumerate(lines):
        cells = [c.strip() for c in line.replace(";", ",").replace("\t", ",").split(",")]
        if not any(cells) or line.lstrip().startswith("#"):
            continue
        if not rows and columns is None:
            names = [c.lower() for c in cells]
            for want in (("raw_r", "raw_g", "raw_b"), ("r", "g", "b")):
                if all(w in names for w in want):
                    columns = [names.index(w) for w in want]
                    light = names.index("illuminant") if "illuminant" in names else None
                    break
            if columns is not None:
                continue
        try:
            picked = [cells[j] for j in columns] if columns is not None else [c for c in cells if c][-3:]
            rows.append([float(c) for c in picked])
            if light is not None:
                lights.add(cells[light])
        except (ValueError, IndexError):
            if rows or i > 0 or columns is not None:
                raise SpectralDataError(
                    f"--chart {path}, line {i + 1}: not three numbers ({line.strip()!r})."
                ) from None
    if not rows or any(len(r) != 3 for r in rows):
        raise SpectralDataError(f"--chart {path}: expected one row of three numbers (R, G, B) per patch.")
    if len(lights) > 1:
        raise SpectralDataError(
            f"--chart {path}: its illuminant column names {sorted(lights)}; give one light."
        )
    return np.array(rows), (lights.pop() or None) if lights else None


#: The light of a chart photograph when neither ``--illuminant`` nor the CSV names one.
DEFAULT_CHART_LIGHT = "D65"


def _light_key(name: str) -> str:
    return "".join(str(name).upper().split())


def _estimate(args: argparse.Namespace) -> int:
    from .._errors import SpectralDataError
    from ..spectra.estimate import Chart, estimate_ssf, write_ssf_json
    from ..utilities.io import check_output

    csvs, given = args.chart or [], args.illuminant or []
    if args.file is None and not csvs:
        raise SpectralDataError("give a DNG file, --chart CSV, or both.")
    if given and not csvs:
        raise SpectralDataError(
            f"--illuminant {given[0]}: the light of a chart photograph; it applies to --chart only."
        )
    if len(given) > 1 and len(given) != len(csvs):
        raise SpectralDataError(
            f"{len(given)} --illuminant for {len(csvs)} --chart; give one light for every chart, or one "
            "per chart in the same order."
        )
    inputs = [args.file, *csvs]
    check_output(
        args.output,
        overwrite=args.force,
        signature='"document_creator": "zonotope.estimate_ssf"',
        what="-o",
        inputs=inputs,
    )
    charts = []
    for i, csv in enumerate(csvs):
        means, light = _read_chart_csv(csv)
        told = given[i if len(given) > 1 else 0] if given else None
        if told is not None and light is not None and _light_key(told) != _light_key(light):
            raise SpectralDataError(
                f"--chart {csv} was photographed under {light} (its illuminant column) but "
                f"--illuminant is {told}; leave --illuminant out or give {light}."
            )
        illuminant = told or light or DEFAULT_CHART_LIGHT
        charts.append(Chart(means, args.reflectances, illuminant, name=f"--chart {csv}"))
    under = ""
    if charts:
        lights = ", ".join(str(c.illuminant) for c in charts)
        under = f", the chart{'s' if len(charts) > 1 else ''} under {lights}"
    est = estimate_ssf(args.file, chart=charts or None, name=args.name)
    write_ssf_json(est, args.output, overwrite=args.force)
    peaks = est.wavelengths[est.values.argmax(axis=0)]
    print(
        f"{est.name}: sensitivities from {' + '.join(est.sources)}{under} (peaks R {peaks[0]:g}, "
        f"G {peaks[1]:g}, B {peaks[2]:g} nm; relative misfit {est.residual:.3g}; band calibrated on "
        f"{est.calibration}) → {args.output}",
        file=sys.stdout,
    )
    return 0


def add_commands(sub) -> None:
    """Register ``ssf`` (with its ``estimate`` action) on the ``zonotope`` sub-parser collection."""
    p = sub.add_parser("ssf", help="spectral sensitivities of cameras nobody measured")
    actions = p.add_subparsers(dest="ssf_command", metavar="estimate", required=True)
    e = actions.add_parser(
        "estimate",
        help="estimate a camera's sensitivities from its DNG colour matrices and/or a chart photograph",
        description="Write rawtoaces JSON sensitivities (zonotope.load_camera reads them) estimated from a "
        "DNG's ColorMatrix/ForwardMatrix tags, from raw patch means of a photographed chart, or both.",
    )
    e.add_argument(
        "file", nargs="?", help="a DNG file of the camera (Adobe DNG Converter writes one from any RAW)"
    )
    e.add_argument("-o", "--output", required=True, help="output JSON file (must not exist unless --force)")
    e.add_argument(
        "--chart",
        action="append",
        help="CSV of raw patch means, one row R,G,B per patch in chart order, black subtracted and divided "
        "by WhiteLevel − BlackLevel (the _patches.csv `isp profile --chart` writes is read as it is); "
        "repeat for photographs under other lights, each with an exposure of its own",
    )
    e.add_argument(
        "--reflectances", default="ColorChecker N Ohta", help="the chart's reflectances (name or file)"
    )
    e.add_argument(
        "--illuminant",
        action="append",
        help="the light the chart was photographed under (default: the CSV's illuminant column, which "
        f"isp profile --chart writes, else {DEFAULT_CHART_LIGHT}); once for every chart, or once per "
        "--chart in the same order",
    )
    e.add_argument("--name", help="camera name written into the file (default the DNG's make and model)")
    e.add_argument("--force", action="store_true", help="replace an output file an earlier estimate wrote")
    e.set_defaults(func=_estimate)
