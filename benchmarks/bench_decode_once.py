"""CPU cost of a run's RAW decoding for the poses and train steps: each file decoded by both (before) or
decoded once by the poses step and read back from ``OUT/decoded`` by the train step (now).

    python benchmarks/bench_decode_once.py --capture /tmp/realsize/capture_12mp \\
        --files nikon/DSC_0005.dng sigma/SDIM0005.dng --runs 5

Per file, in one process and alternating, the median CPU seconds (``time.process_time``, every thread)
of the two steps' reading at the automatic working resolution:

- before: the poses step decodes and bins the file (:func:`splat.capture.raw.load_view`); the train
  step decodes and bins it again and keeps it in the cache;
- now: the poses step decodes, bins and keeps it; the train step reads the kept entry.

The entries are written to a temporary folder (the capture is only read). The render and correct steps
read the entries in both cases and are not timed here.
"""

from __future__ import annotations

import argparse
import statistics
import sys
import tempfile
import time
from pathlib import Path


def _timed(fn):
    """``(fn(), CPU s)``."""
    t0 = time.process_time()
    out = fn()
    return out, time.process_time() - t0


def _one_file(spec, k: int, p: Path, name: str, entry: Path, runs: int) -> tuple[dict, object]:
    """Per run, CPU s of before (two decodings, one stored) and now (one decoding stored, then read),
    alternated; and the parts of now."""
    from splat.capture import preview_binning
    from splat.capture.raw import _read_decoded, _store_decoded, load_view

    def decode():
        return load_view(spec, k, p, binning=lambda shape, full: preview_binning(k, shape, full))

    t = {"before": [], "now": [], "decode": [], "store": [], "read": []}
    v = None
    for _ in range(runs):
        # before: the poses step decodes; the train step decodes again and keeps its decoding
        t0 = time.process_time()
        decode()
        v = decode()
        _store_decoded(entry, v)
        t["before"].append(time.process_time() - t0)
        entry.unlink()
        # now: the poses step decodes and keeps it; the train step reads the kept entry
        v, a = _timed(decode)
        _, b = _timed(lambda v=v: _store_decoded(entry, v))
        r, c = _timed(lambda: _read_decoded(entry, name, k, p))
        if r is None:
            raise RuntimeError(f"{name}: the kept entry did not read back")
        t["now"].append(a + b + c)
        t["decode"].append(a)
        t["store"].append(b)
        t["read"].append(c)
        entry.unlink()
    return {key: statistics.median(x) for key, x in t.items()}, v


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--capture", type=Path, required=True, help="a capture folder (capture.toml)")
    ap.add_argument("--files", nargs="+", required=True, help="RAW files as <folder>/<file>")
    ap.add_argument("--runs", type=int, default=5)
    a = ap.parse_args(argv)

    from splat.capture import read_capture
    from splat.capture.raw import _decoded_key

    spec = read_capture(a.capture)
    folders = [c.folder for c in spec.cameras]
    print(
        "| file | size | binning | before: CPU s | now: CPU s | saved CPU s | decode / store / read CPU s |"
    )
    print("|---|---|---:|---:|---:|---:|---|")
    with tempfile.TemporaryDirectory() as tmp:
        for name in a.files:
            folder, file = name.rsplit("/", 1)
            if folder not in folders:
                print(f"{name}: no camera folder {folder!r} in {a.capture}", file=sys.stderr)
                return 2
            k = folders.index(folder)
            p = spec.root / folder / file
            if not p.is_file():
                print(f"{p}: no such file", file=sys.stderr)
                return 2
            entry = Path(tmp) / _decoded_key(spec, k, p, {"bench": 1})
            med, v = _one_file(spec, k, p, name, entry, a.runs)
            H, W = v.size
            print(
                f"| {name} | {W} × {H} | {v.binning} | {med['before']:.2f} | {med['now']:.2f} | "
                f"{med['before'] - med['now']:.2f} | {med['decode']:.2f} / {med['store']:.3f} / "
                f"{med['read']:.3f} |",
                flush=True,
            )
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
