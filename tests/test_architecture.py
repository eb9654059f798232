"""The shape of the code, checked by parsing every import (``ast``), plus the public surface.

No import circles anywhere in ``zonotope``, ``isp`` and ``splat`` (every ``.py`` file, subpackages
included; an import inside a function body counts too). ``zonotope``'s layers come from its folders,
lowest first: ``_errors``/``_tol`` → ``utilities`` → ``spectra`` → ``geometry`` → ``mismatch`` →
``correct`` → the flat applications (``vora``, ``parallel``, ``evaluate``, ``report``, ``survey``,
``viz``) → ``cli``; a module imports its own layer (siblings of its folder) or lower ones only.
``isp`` and ``splat`` use only public ``zonotope`` names; ``zonotope`` never imports ``isp`` or
``splat``, ``isp`` never imports ``splat``; no library module imports its package's command line.
"""

from __future__ import annotations

import ast
import importlib
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
PACKAGES = ("zonotope", "isp", "splat")

#: zonotope's layers, by first component below ``zonotope`` (folder or flat module), lowest first.
LAYERS: dict[int, set[str]] = {
    0: {"_errors", "_tol"},
    1: {"utilities"},
    2: {"spectra"},
    3: {"geometry"},
    4: {"mismatch"},
    5: {"correct"},
    6: {"vora", "parallel", "evaluate", "report", "survey", "viz", "ssf_band"},
    7: {"cli"},
    8: {"__init__", "__main__"},
}
RANK = {m: r for r, mods in LAYERS.items() for m in mods}

#: Private zonotope modules isp/splat may still import, each with its reason (keep this empty).
ALLOWED_PRIVATE: dict[str, str] = {}


def _module_name(path: Path, root: Path = ROOT) -> str:
    return ".".join(path.relative_to(root).with_suffix("").parts).removesuffix(".__init__")


def _modules(package: str, root: Path = ROOT) -> dict[str, Path]:
    """Every module of ``package`` (subpackages included): dotted name -> file."""
    return {_module_name(p, root): p for p in sorted((root / package).rglob("*.py"))}


def _imports(
    path: Path, module: str, known: set[str] | frozenset[str] = frozenset()
) -> list[tuple[int, str]]:
    """``(line, absolute module)`` of every import in a file, function bodies included.

    ``from X import a`` names ``X.a`` when that is a module (a file in ``known`` or on disk), and names
    ``X`` itself only when some imported name is not a module: ``from . import sibling`` runs the
    parent package only as a parent, which every import of a submodule does.
    """
    package = module if path.name == "__init__.py" else module.rpartition(".")[0]
    out = []
    for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
        if isinstance(node, ast.Import):
            out += [(node.lineno, a.name) for a in node.names]
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                base = package if node.level == 1 else package.rsplit(".", node.level - 1)[0]
                source = f"{base}.{node.module}" if node.module else base
            else:
                source = node.module
            subs = [f"{source}.{a.name}" for a in node.names]
            found = [m for m in subs if m in known or _on_disk(m)]
            out += [(node.lineno, m) for m in found]
            if len(found) < len(subs):
                out.append((node.lineno, source))
    return out


def _on_disk(module: str) -> bool:
    p = ROOT / module.replace(".", "/")
    return p.with_suffix(".py").exists() or (p / "__init__.py").exists()


def _resolve(target: str, known: set[str]) -> str | None:
    """The longest known module that ``target`` names (``None`` for modules outside ``known``)."""
    parts = target.split(".")
    for n in range(len(parts), 0, -1):
        if ".".join(parts[:n]) in known:
            return ".".join(parts[:n])
    return None


def import_graph(packages=PACKAGES, root: Path = ROOT) -> dict[str, set[str]]:
    """Module -> the modules of ``packages`` it imports (lazy imports included)."""
    files: dict[str, Path] = {}
    for package in packages:
        files.update(_modules(package, root))
    known = set(files)
    graph: dict[str, set[str]] = {}
    for module, path in files.items():
        targets = {_resolve(t, known) for _, t in _imports(path, module, known)}
        graph[module] = {t for t in targets if t and t != module}
    return graph


def import_circles(graph: dict[str, set[str]]) -> list[list[str]]:
    """Every import circle: the strongly connected components with more than one module (Tarjan)."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on_stack: set[str] = set()
    circles: list[list[str]] = []

    def visit(v: str) -> None:
        index[v] = low[v] = len(index)
        stack.append(v)
        on_stack.add(v)
        for w in sorted(graph.get(v, ())):
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on_stack:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            component = []
            while True:
                w = stack.pop()
                on_stack.discard(w)
                component.append(w)
                if w == v:
                    break
            if len(component) > 1:
                circles.append(sorted(component))

    for v in sorted(graph):
        if v not in index:
            visit(v)
    return circles


@pytest.mark.parametrize("package", PACKAGES)
def test_no_import_circles(package):
    circles = [c for c in import_circles(import_graph()) if c[0].split(".")[0] == package]
    assert not circles, f"import circles in {package}:\n" + "\n".join(" <-> ".join(c) for c in circles)


def test_circle_detector_finds_a_planted_circle(tmp_path):
    """The checker itself: a circle through a lazy import in a subpackage is found, a chain is not."""
    pkg = tmp_path / "pkg"
    (pkg / "sub").mkdir(parents=True)
    (pkg / "__init__.py").write_text("")
    (pkg / "sub" / "__init__.py").write_text("from .a import f\n")
    (pkg / "sub" / "a.py").write_text("from ..b import g\n\ndef f():\n    return g()\n")
    (pkg / "b.py").write_text("def g():\n    from .sub import a\n    return a\n")
    (pkg / "c.py").write_text("from . import b\n")
    assert import_circles(import_graph(["pkg"], tmp_path)) == [["pkg.b", "pkg.sub.a"]]
    (pkg / "b.py").write_text("def g():\n    return 1\n")
    assert import_circles(import_graph(["pkg"], tmp_path)) == []


def _rank(module: str) -> int:
    parts = module.split(".")
    return RANK["__init__"] if len(parts) == 1 else RANK[parts[1]]


def test_every_zonotope_module_has_a_layer():
    missing = sorted(m for m in _modules("zonotope") if "." in m and m.split(".")[1] not in RANK)
    assert not missing, f"place these folders/modules in LAYERS: {missing}"


@pytest.mark.parametrize("module", sorted(_modules("zonotope")))
def test_zonotope_layers(module):
    me = _rank(module)
    known = set(_modules("zonotope"))
    bad = []
    for line, target in _imports(_modules("zonotope")[module], module, known):
        top = target.split(".")[0]
        if top in ("isp", "splat"):
            bad.append(f"line {line}: {target} (zonotope never imports isp/splat)")
        elif top == "zonotope" and "." in target and _rank(target) > me:
            bad.append(f"line {line}: {target} (layer {_rank(target)} > {me})")
    assert not bad, f"{module} imports a higher layer:\n" + "\n".join(bad)


def _is_cli(module: str) -> bool:
    return any(part == "cli" or part.endswith("_cli") or part == "__main__" for part in module.split(".")[1:])


def _library_modules():
    return sorted(m for package in PACKAGES for m in _modules(package) if not _is_cli(m) and "." in m)


@pytest.mark.parametrize("module", _library_modules())
def test_libraries_never_import_their_command_line(module):
    package = module.split(".")[0]
    path = ROOT / (module.replace(".", "/") + ".py")
    if not path.exists():
        path = ROOT / module.replace(".", "/") / "__init__.py"
    bad = [
        f"line {line}: {t}" for line, t in _imports(path, module) if t.split(".")[0] == package and _is_cli(t)
    ]
    assert not bad, f"{module} imports a command line:\n" + "\n".join(bad)


@pytest.mark.parametrize("module", sorted([*_modules("isp"), *_modules("splat")]))
def test_isp_and_splat_use_public_names(module):
    package = module.split(".")[0]
    path = {**_modules("isp"), **_modules("splat")}[module]
    bad = []
    for line, target in _imports(path, module):
        parts = target.split(".")
        if parts[0] == "zonotope" and any(p.startswith("_") for p in parts[1:]):
            if target not in ALLOWED_PRIVATE:
                bad.append(f"line {line}: {target} (private; use a public zonotope name)")
        if package == "isp" and parts[0] == "splat":
            bad.append(f"line {line}: {target} (isp never imports splat)")
        if package == "splat" and parts[0] == "isp" and any(p.startswith("_") for p in parts[1:]):
            bad.append(f"line {line}: {target} (private isp module)")
    assert not bad, f"{module}:\n" + "\n".join(bad)


def test_layer_checker_catches_a_violation(tmp_path):
    """The checker itself: a lazy relative import of a higher layer and an absolute import are found."""
    f = tmp_path / "builtin.py"
    f.write_text("def f():\n    from ..correct import fit_correction\n    import zonotope.geometry.lp\n")
    found = _imports(f, "zonotope.spectra.builtin")
    assert (2, "zonotope.correct") in found and (3, "zonotope.geometry.lp") in found
    assert _rank("zonotope.correct") > _rank("zonotope.spectra.builtin")


#: Public module names that are *not* re-exported as attributes of ``zonotope``, with the reason.
NOT_REEXPORTED = {
    "correct": "zonotope.correct is the module; the function stays zonotope.correct.correct",
    "evaluate": "zonotope.evaluate is the module; the function stays zonotope.evaluate.evaluate",
    "main": "the CLI entry point",
}


#: Public modules used through their module path, with the reason.
MODULE_NAMESPACES = {
    "utilities": "plumbing, kept out of the top-level namespace: zonotope.utilities.atomic_path, ...",
    "parallel": "the execution layer: zonotope.parallel.executor(...)",
    "survey": "an application (zonotope survey), used as zonotope.survey",
    "cli": "the command line",
    "__main__": "python -m zonotope",
}


@pytest.mark.parametrize(
    "module",
    sorted(m for m in RANK if not m.startswith("_") and m not in MODULE_NAMESPACES),
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
    "zonotope.correct.image.correct_image": "the one-call photo path: the image, the cameras and the fit's "
    "method and noise, the grouping knobs (quantum, base, batch_size, cache_dir), progress and return_info",
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
