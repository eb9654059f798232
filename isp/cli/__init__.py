"""``isp`` command line: develop RAW files.

- ``isp develop IN -o OUT``: develop a RAW/DNG file to a 16-bit TIFF (with an sRGB ICC profile and
  the camera's metadata) or PNG; ``--wb as-shot|daylight|5000K|D65|spot:x0,y0,x1,y1`` picks the
  white balance; the picture is rotated as the file's Orientation tag says;
  ``--correction metamer --camera NAME_OR_FILE [--method NAME] [--illuminant D65] [--noise auto]``
  replaces the file's ColorMatrix by a ``zonotope.correct`` estimator fitted on the camera's
  sensitivities and for the file's noise (DNG NoiseProfile, else estimated from the mosaic);
- ``isp info IN``: print the RAW metadata the pipeline uses;
- ``isp profile --camera NAME_OR_FILE -o camera.dcp [--lut camera.cube]``: a DNG camera profile
  (and 3-D LUT, saved correction) fitted to a ``zonotope.correct`` estimator; ``isp develop
  --profile camera.dcp`` applies any DCP.

Runnable as ``isp ...`` (console script) or ``python -m isp ...``.
"""

from __future__ import annotations

import argparse
import sys
from collections.abc import Sequence

__all__ = ["main"]


def _version() -> str:
    from importlib.metadata import PackageNotFoundError, version

    try:
        return version("zonotope")
    except PackageNotFoundError:  # pragma: no cover - running from a source tree without install
        return "0+unknown"


def _parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(prog="isp", description="Develop camera RAW files, one stage at a time.")
    parser.add_argument("--version", action="version", version=f"%(prog)s {_version()}")
    sub = parser.add_subparsers(dest="command", required=True)
    from .develop import add_develop, add_info
    from .profile import add_command as add_profile  # 'isp profile': DCP / 3-D LUT export

    add_develop(sub)
    add_profile(sub)
    add_info(sub)
    return parser


def _stdout_gone() -> int:
    """Exit status after the reader of stdout closed it (``isp info F | head``): 128 + SIGPIPE, quietly."""
    import os
    import signal

    try:
        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())  # no second error at exit
    except (OSError, ValueError, AttributeError):  # stdout without a file descriptor (captured)
        pass
    return 128 + signal.SIGPIPE


def main(argv: Sequence[str] | None = None) -> int:
    """Entry point of the ``isp`` command; returns the exit status (2 for bad input)."""
    from zonotope import ZonotopeError

    args = _parser().parse_args(argv)
    try:
        status = args.func(args)
        sys.stdout.flush()  # a closed pipe shows here, not in the interpreter's exit
        return status
    except KeyboardInterrupt:
        print("isp: interrupted (no output was written or replaced)", file=sys.stderr)
        return 130
    except BrokenPipeError:
        return _stdout_gone()
    except (ZonotopeError, OSError, ValueError) as exc:  # one line, no traceback
        print("isp: error: " + " ".join(str(exc).split()), file=sys.stderr)
        return 2
