"""Plumbing shared by the project's packages: method registries, atomic output files, config checks,
progress callbacks and lazy exports.

Why a folder apart: these are not colour science, so they stay out of the top-level ``zonotope``
namespace, but ``isp`` and ``splat`` import them from here as public names.
"""

from __future__ import annotations

from .config import check_bool, check_count, check_nonnegative, with_options
from .io import (
    OutputExistsError,
    atomic_dir,
    atomic_file,
    atomic_path,
    atomic_write_bytes,
    atomic_write_text,
    check_output,
)
from .lazy import install_moved_modules, lazy_exports
from .progress import ProgressCallback
from .registry import Method, MethodRegistry

__all__ = [
    "Method",
    "MethodRegistry",
    "OutputExistsError",
    "ProgressCallback",
    "atomic_dir",
    "atomic_file",
    "atomic_path",
    "atomic_write_bytes",
    "atomic_write_text",
    "check_bool",
    "check_count",
    "check_nonnegative",
    "check_output",
    "install_moved_modules",
    "lazy_exports",
    "with_options",
]
