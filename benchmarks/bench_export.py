"""Scene export and the report's viewer on a finished run: bytes per Gaussian of each exported file, the
cost of correcting every Gaussian, and the viewer's load time in headless Chromium.

    python benchmarks/bench_export.py CAPTURE OUT [--repeats 5]

``OUT`` is a trained and corrected run of ``CAPTURE`` (e.g. the CI capture: ``python -m splat.sim.capture
cap`` then ``splat run cap -o out``). Prints, for each file, its size and bytes per Gaussian (per view
for the poses); the time of :func:`splat.export.prepare_scene` with the estimator fitted
(``--fit-repeats`` runs) and with the colours cached (same process); the report page's size with the
viewer against the same page without it (the baseline); and, medians of ``--repeats`` headless Chromium
runs, the viewer's own time from the start of its script to its first frame (decode, shader compile, depth
sort, draw: the page's ``data-load-ms``) and the wall time of Chromium loading the page with the viewer
against without it.
"""

from __future__ import annotations

import argparse
import re
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path


def _chromium() -> str | None:
    for name in ("chromium", "chromium-browser", "google-chrome"):
        if shutil.which(name):
            return shutil.which(name)
    return None


def _load(exe: str, page: Path, profile: Path) -> tuple[float, float | None]:
    """Wall seconds of a headless Chromium loading ``page`` and the viewer's ``data-load-ms`` (None
    without a viewer)."""
    flags = ["--headless", "--no-sandbox", "--use-angle=swiftshader", "--enable-unsafe-swiftshader"]
    t = time.perf_counter()
    dom = subprocess.run(
        [
            exe,
            *flags,
            f"--user-data-dir={profile}",
            "--virtual-time-budget=5000",
            "--dump-dom",
            page.as_uri(),
        ],
        capture_output=True,
        text=True,
        timeout=300,
    ).stdout
    wall = time.perf_counter() - t
    m = re.search(r'data-load-ms="([0-9.]+)"', dom)
    return wall, float(m.group(1)) if m else None


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("capture")
    p.add_argument("out")
    p.add_argument("--repeats", type=int, default=5)
    p.add_argument(
        "--fit-repeats", type=int, default=1, help="runs of prepare_scene with the estimator fitted"
    )
    a = p.parse_args(argv)

    from splat.capture import read_capture
    from splat.export import PlyOptions, export_scene, prepare_scene
    from splat.report import report_html
    from splat.viewer import SCENE

    out = Path(a.out)
    scene = out / SCENE
    runs = []
    for _ in range(a.fit_repeats):
        scene.unlink(missing_ok=True)
        t = time.perf_counter()
        prepare_scene(a.capture, out)
        runs.append(time.perf_counter() - t)
    t = time.perf_counter()
    prepare_scene(a.capture, out)
    warm = time.perf_counter() - t
    print(
        f"prepare_scene: {statistics.median(runs):.1f} s with the estimator fitted (median of "
        f"{a.fit_repeats}: {', '.join(f'{x:.1f}' for x in runs)}), {warm:.2f} s with the colours cached"
    )

    with tempfile.TemporaryDirectory() as d:
        d = Path(d)
        done = export_scene(
            a.capture,
            out,
            ply=d / "scene.ply",
            ply_channels=d / "scene_n.ply",
            transforms=d / "transforms.json",
            colmap=d / "colmap",
        )
        done["ply, --sh-degree 0"] = export_scene(
            a.capture, out, ply=d / "s0.ply", options=PlyOptions(sh_degree=0)
        )["ply"]
        done["ply, --sh-degree 0 --no-xyz"] = export_scene(
            a.capture, out, ply=d / "s00.ply", options=PlyOptions(sh_degree=0, xyz=False)
        )["ply"]
        G = done["ply"]["gaussians"]
        print(f"{G} Gaussians")
        print("| file | bytes | bytes per Gaussian (per view) |\n|---|---:|---:|")
        for what, r in done.items():
            n = r.get("gaussians", r.get("views"))
            print(f"| {what} | {r['bytes']:,} | {r['bytes'] / n:.1f} |")

        spec = read_capture(a.capture)
        index = {}
        if (out / "render" / "index.json").is_file():
            from splat.capture import read_index

            index = read_index(spec, out / "render" / "index.json")
        page = report_html(spec, out, index)
        with_viewer, without = d / "with.html", d / "without.html"
        with_viewer.write_text(page)
        # the baseline: the same page without the viewer's section
        without.write_text(re.sub(r"<section id='scene'>.*?</section>", "", page, flags=re.S))
        sw, so = with_viewer.stat().st_size, without.stat().st_size
        print(
            f"report.html: {sw:,} bytes with the viewer, {so:,} without "
            f"({(sw - so) / G:.1f} bytes per Gaussian)"
        )
        exe = _chromium()
        if exe is None:
            print("no Chromium: load times not measured")
            return 0
        runs = {"with": [], "without": [], "viewer_ms": []}
        for i in range(a.repeats):
            w, ms = _load(exe, with_viewer, d / f"p{i}a")
            runs["with"].append(w)
            runs["viewer_ms"].append(ms)
            runs["without"].append(_load(exe, without, d / f"p{i}b")[0])
        if any(m is None for m in runs["viewer_ms"]):
            print("the viewer drew no frame in some runs:", runs["viewer_ms"])
            return 1
        med = {k: statistics.median(v) for k, v in runs.items()}
        print(
            f"viewer, script start to first frame: {med['viewer_ms']:.0f} ms (median of {a.repeats}; "
            f"runs {', '.join(f'{m:.0f}' for m in runs['viewer_ms'])})"
        )
        print(
            f"Chromium load to DOM dump: {med['with']:.2f} s with the viewer, {med['without']:.2f} s "
            f"without (medians of {a.repeats})"
        )
    return 0


if __name__ == "__main__":
    sys.exit(main())
