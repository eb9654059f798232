"""The layers of the code, checked by parsing every import (``ast``), plus the public surface.

zonotope, in data-flow order: infrastructure → spectra → solid / polytope → mismatch →
correct → image → applications (evaluate, report, viz, cli). A module may import modules of its
own layer or of lower ones, never a higher one (a lazy import inside a function counts too).
``isp`` and ``splat`` use only public ``zonotope`` names (no ``zonotope._private`` module);
``zonotope`` never imports ``isp`` or ``splat``, ``isp`` never imports ``splat``.
"""

from __future__ import annotations

import ast
import importlib
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]

#: zonotope's modules by layer (0 = lowest). A new module must be placed here.
LAYERS: dict[int, set[str]] = {
    0: {"_errors", "_tol", "_registry", "_io", "_progress", "_config", "parallel", "_cubemap"},
    1: {"spectra", "_loading", "_generators", "_bvls", "_noise"},
    2: {"_zonohedron", "_lp", "solid", "polytope", "vora", "macadam", "_mmv_walk_kernel", "membership"},
    3: {"_oracle", "_mmv_refine", "_mmv_walk", "mismatch"},
    4: {"prior", "atypical", "_correction_problem", "_regressions", "_mmv_estimators", "correct"},
    5: {"image", "profile"},
    6: {"evaluate", "report", "viz", "survey", "_batch_cli", "_profile_cli", "cli", "__main__", "__init__"},
}
RANK = {m: r for r, mods in LAYERS.items() for m in mods}

#: Private zonotope modules isp/splat may still import, each with its reason (keep this empty).
ALLOWED_PRIVATE: dict[str, str] = {}


def _imports(path: Path, package: str) -> list[tuple[int, str]]:
    """``(line, absolute module)`` of every import in a file, function bodies included."""
    out = []
    for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
        if isinstance(node, ast.Import):
            out += [(node.lineno, a.name) for a in node.names]
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                base = package if node.level == 1 else package.rsplit(".", node.level - 1)[0]
                if node.module:
                    out.append((node.lineno, f"{base}.{node.module}"))
                else:
                    out += [(node.lineno, f"{base}.{a.name}") for a in node.names]
            elif node.module:
                out.append((node.lineno, node.module))
                out += [
                    (node.lineno, f"{node.module}.{a.name}")
                    for a in node.names
                    if (ROOT / node.module.replace(".", "/") / f"{a.name}.py").exists()
                ]
    return out


def _modules(package: str) -> list[Path]:
    return sorted((ROOT / package).glob("*.py"))


def test_every_zonotope_module_has_a_layer():
    missing = sorted(p.stem for p in _modules("zonotope") if p.stem not in RANK)
    assert not missing, f"place these modules in LAYERS: {missing}"


@pytest.mark.parametrize("path", _modules("zonotope"), ids=lambda p: p.stem)
def test_zonotope_layers(path):
    me = RANK.get(path.stem, 0)
    bad = []
    for line, mod in _imports(path, "zonotope"):
        top, _, rest = mod.partition(".")
        if top in ("isp", "splat"):
            bad.append(f"line {line}: {mod} (zonotope never imports isp/splat)")
        elif top == "zonotope" and rest:
            sub = rest.split(".")[0]
            if RANK.get(sub, 0) > me:
                bad.append(f"line {line}: {mod} (layer {RANK[sub]} > {me})")
    assert not bad, f"zonotope/{path.name} imports a higher layer:\n" + "\n".join(bad)


@pytest.mark.parametrize(
    "path", [*_modules("isp"), *_modules("splat")], ids=lambda p: f"{p.parent.name}.{p.stem}"
)
def test_isp_and_splat_use_public_names(path):
    package = path.parent.name
    bad = []
    for line, mod in _imports(path, package):
        parts = mod.split(".")
        if parts[0] == "zonotope" and len(parts) > 1 and parts[1].startswith("_"):
            if ".".join(parts[:2]) not in ALLOWED_PRIVATE:
                bad.append(f"line {line}: {mod} (private; use a name from `zonotope`)")
        if package == "isp" and parts[0] == "splat":
            bad.append(f"line {line}: {mod} (isp never imports splat)")
        if package == "splat" and parts[0] == "isp" and len(parts) > 1 and parts[1].startswith("_"):
            bad.append(f"line {line}: {mod} (private isp module)")
    assert not bad, f"{package}/{path.name}:\n" + "\n".join(bad)


def test_layer_checker_catches_a_violation(tmp_path):
    """The checker itself: a relative import of a higher layer and a private import are found."""
    f = tmp_path / "spectra.py"
    f.write_text("def f():\n    from .correct import fit_correction\n    import zonotope._lp\n")
    found = _imports(f, "zonotope")
    assert (2, "zonotope.correct") in found and (3, "zonotope._lp") in found


#: Public module names that are *not* re-exported as attributes of ``zonotope``, with the reason.
NOT_REEXPORTED = {
    "correct": "zonotope.correct is the module; the function stays zonotope.correct.correct",
    "evaluate": "zonotope.evaluate is the module; the function stays zonotope.evaluate.evaluate",
    "main": "the CLI entry point",
}


#: Public modules used through their module path, with the reason.
MODULE_NAMESPACES = {
    "parallel": "the execution layer: zonotope.parallel.executor(...)",
    "survey": "an application (zonotope survey), used as zonotope.survey",
    "cli": "the command line",
    "__main__": "python -m zonotope",
}


@pytest.mark.parametrize(
    "module", sorted(m for m in RANK if not m.startswith("_") and m not in MODULE_NAMESPACES)
)
def test_zonotope_reexports_every_public_name(module):
    import zonotope

    mod = importlib.import_module(f"zonotope.{module}")
    names = getattr(mod, "__all__", [])
    missing = [n for n in names if n not in zonotope.__all__ and n not in NOT_REEXPORTED]
    assert not missing, f"zonotope.{module} names missing from zonotope.__all__: {missing}"
    for name in getattr(mod, "__all__", []):
        if name not in NOT_REEXPORTED:
            assert getattr(zonotope, name) is getattr(mod, name)


@pytest.mark.parametrize("package", ["zonotope", "isp", "splat"])
def test_package_all_resolves_and_opens_with_a_map(package):
    pkg = importlib.import_module(package)
    assert [n for n in pkg.__all__ if not hasattr(pkg, n)] == []
    assert len(pkg.__doc__.splitlines()) > 5  # a module map, not a one-liner


def test_import_zonotope_stays_light():
    """``import zonotope`` must not load the heavy or higher layers (checked in a fresh process)."""
    import subprocess
    import sys

    code = (
        "import sys, zonotope; print(sorted(m for m in ('pyvista', 'jax', 'zonotope.mismatch', "
        "'zonotope.correct', 'zonotope.viz', 'isp', 'splat') if m in sys.modules))"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "[]"


#: isp's public modules (data-flow order) whose names ``isp`` re-exports; ``cli`` is the command.
ISP_MODULES = [
    "raw",
    "dng",
    "exif",
    "stages",
    "whitebalance",
    "pipeline",
    "metamer",
    "dcp",
    "profile_fit",
    "io",
    "batch",
    "simulate",
]


@pytest.mark.parametrize("module", ISP_MODULES)
def test_isp_reexports_every_public_name(module):
    import isp

    mod = importlib.import_module(f"isp.{module}")
    missing = [n for n in mod.__all__ if n not in isp.__all__]
    assert not missing, f"isp.{module} names missing from isp.__all__: {missing}"
    assert all(getattr(isp, n) is getattr(mod, n) for n in mod.__all__)


#: Public functions with more than 8 parameters (besides ``*args``/``**options``), with the reason
#: each may stay (issue 13 item 6: more than ~8 options go into a frozen config dataclass).
MANY_PARAMETERS_ALLOWED = {
    "splat.training.train": "already takes splat.TrainConfig; the other 9 are its inputs (capture, "
    "images, weights, bounds, points, colours) and runtime objects (resume, callback, reference_views)",
    "zonotope.image.correct_image": "the one-call photo path: the image, the cameras and the fit's method "
    "and noise, the grouping knobs (quantum, base, batch_size, cache_dir), progress and return_info",
}


def _public_callables():
    """``(qualified name, function)`` of every public function and public method of a public class
    named in the ``__all__`` of ``zonotope``, ``isp``, ``splat`` or one of their modules."""
    import inspect
    import pkgutil

    out = {}
    for package in ("zonotope", "isp", "splat"):
        pkg = importlib.import_module(package)
        modules = [pkg] + [
            importlib.import_module(f"{package}.{m.name}")
            for m in pkgutil.iter_modules(pkg.__path__)
            if m.name != "__main__"
        ]
        for mod in modules:
            for name in getattr(mod, "__all__", []):
                obj = getattr(mod, name, None)
                if inspect.isfunction(obj):
                    out[f"{obj.__module__}.{obj.__qualname__}"] = obj
                elif inspect.isclass(obj) and obj.__module__.split(".")[0] == package:
                    for attr, fn in vars(obj).items():
                        if inspect.isfunction(fn) and not attr.startswith("_"):
                            out[f"{obj.__module__}.{obj.__qualname__}.{attr}"] = fn
    return out


def _n_parameters(fn) -> int:
    import inspect

    skip = (inspect.Parameter.VAR_POSITIONAL, inspect.Parameter.VAR_KEYWORD)
    params = inspect.signature(fn).parameters.values()
    return sum(p.kind not in skip and p.name not in ("self", "cls") for p in params)


def test_no_public_function_has_more_than_8_parameters():
    """Functions with more than ~8 options take a config dataclass (``f(data, config=None, *,
    <runtime keywords>, **options)``); the allow-list says why each exception stays."""
    functions = _public_callables()
    assert len(functions) > 200  # the walk found the packages' surface (guards against a silent no-op)
    many = {name: _n_parameters(fn) for name, fn in functions.items() if _n_parameters(fn) > 8}
    unexplained = {n: k for n, k in many.items() if n not in MANY_PARAMETERS_ALLOWED}
    assert not unexplained, f"take a config dataclass (or allow-list with a reason): {unexplained}"
    stale = [n for n in MANY_PARAMETERS_ALLOWED if n not in many]
    assert not stale, f"no longer over 8 parameters: remove from MANY_PARAMETERS_ALLOWED: {stale}"


def test_parameter_counter_counts_keywords_not_options():
    def f(a, b, /, c, *args, d=1, e=2, **options):
        return a

    assert _n_parameters(f) == 5
