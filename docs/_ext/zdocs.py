"""Sphinx extension of this project: API pages, CLI reference and gallery copies, generated at build.

* **API reference**: one page per package and one per defining module, listing *every* name in the
  package's ``__all__`` (the lazy exports included) under its public path (``zonotope.Zonotope``).
  A public function or class without a docstring, or a public constant without a ``#:`` comment in
  the module that defines it, is a Sphinx warning, so ``sphinx-build -W`` fails on it.
* **CLI reference**: the ``--help`` text of every command and sub-command, taken from the parsers
  themselves (``zonotope.cli._parser`` and friends), so it cannot drift from the code.
* **Gallery**: ``notebooks/*.ipynb`` copied into ``docs/gallery/``. A notebook whose code cells all
  carry an execution count (already executed, e.g. by ``pytest --nbmake --overwrite`` earlier in the
  same CI run) is rendered as it is; the others are executed once by myst-nb during the build (or not
  at all with ``-D nb_execution_mode=off``). The gallery's table (``docs/gallery/table.inc``) says for
  each notebook which of these happened, shows the first figure of an executed notebook as its
  thumbnail, and says when a notebook that reads ``../shared/data`` runs without it (the notebook page
  then opens with the same note) instead of leaving the measured data silently out.

Everything generated lives in ignored paths (``docs/api/generated``, ``docs/guide/cli_help``,
``docs/gallery/*.ipynb``, ``docs/gallery/_thumbs``, ``docs/gallery/table.inc``) and is rewritten on
every build.
"""

from __future__ import annotations

import base64
import contextlib
import importlib
import inspect
import io
import json
import os
import pkgutil
import re
import shutil
from pathlib import Path

from sphinx.pycode import ModuleAnalyzer
from sphinx.util import logging

logger = logging.getLogger(__name__)

DOCS = Path(__file__).resolve().parents[1]
ROOT = DOCS.parent
PACKAGES = ("zonotope", "isp", "splat")

#: Command-line programs: (title, module, how to get the parser).
CLIS = (
    ("zonotope", "zonotope.cli", "_parser"),
    ("isp", "isp.cli", "_parser"),
    ("splat", "splat.cli", "_parser"),
    ("python -m splat.sim.capture", "splat.sim.capture", "main"),
)

#: Gallery notebooks in reading order, with the thesis figures each reproduces.
GALLERY = (
    ("fig1_colour_vision", "1.1 cone fundamentals; 1.2 spectral locus (LMS, XYZ, xy)"),
    ("fig1_cameras_and_eye", "1.4 camera vs eye in XYZ, gamuts; 1.5 the eye's object-colour solid"),
    ("object_colour_solids", "solids of the built-in cameras"),
    ("raw_pipeline", "1.3 Bayer mosaic and demosaicing; 3.4 ISP stages of one RAW file"),
    ("fig3_multispectral", "3.2 one view, three cameras (splat); 3.3 PCA false colour"),
    ("fig4_mmv", "4.1 MMV vs per-channel intersection; 4.2 MMVs of several pixel values"),
    ("fig5_sanity_vora", "5.1 sanity cases; 5.2 Vora value"),
    ("fig5_cameras_added", "MMV volume and ΔE00 as cameras are added (not in the thesis)"),
    ("colour_correction", "estimators compared (fig. 5.2 again)"),
)


def _write(path: Path, text: str) -> None:
    """Write ``text`` only when it changed (keeps Sphinx's incremental build incremental)."""
    path.parent.mkdir(parents=True, exist_ok=True)
    if not path.exists() or path.read_text() != text:
        path.write_text(text)


def _title(text: str, char: str = "=") -> str:
    return f"{text}\n{char * len(text)}\n"


def _summary(doc: str | None) -> str:
    """First sentence-ish line of a docstring, safe inside a list-table cell."""
    if not doc:
        return ""
    line = doc.strip().split("\n\n")[0].replace("\n", " ").strip()
    # roles become literals: a table row has no module or class context to resolve short names in
    line = re.sub(r":(?:py:)?\w+:`~?([^`]+)`", r"``\1``", line)
    return line.replace("|", "\\|")


def _modules(package: str) -> list[str]:
    """Dotted names of ``package`` and every module below it, subpackages included."""
    pkg = importlib.import_module(package)
    found = [package]
    for info in pkgutil.walk_packages(pkg.__path__, prefix=f"{package}."):
        if info.name.rsplit(".", 1)[-1] != "__main__":
            found.append(info.name)
    return found


def _data_docs(package: str) -> dict[str, tuple[str, str]]:
    """``name → (module, doc)`` for every ``#:`` documented module-level name in ``package``."""
    found: dict[str, tuple[str, str]] = {}
    for mod in _modules(package):
        try:
            docs = ModuleAnalyzer.for_module(mod).find_attr_docs()
        except Exception:  # a module the analyzer cannot parse has no #: docs for us
            continue
        for (scope, name), lines in docs.items():
            if scope == "" and name not in found:
                found[name] = (mod, "\n".join(lines).strip())
    return found


def _kind(obj) -> str:
    if inspect.isclass(obj):
        return "exception" if issubclass(obj, BaseException) else "class"
    if inspect.isroutine(obj):
        return "function"
    return "data"


def _public_names(package: str, names: list[str] | None = None):
    """``[(name, obj, kind, defining module, doc)]`` for ``names`` (default: ``package.__all__``)."""
    pkg = importlib.import_module(package)
    data = _data_docs(package)
    lazy = getattr(pkg, "_WHERE", {})
    out = []
    for name in pkg.__all__ if names is None else names:
        obj = getattr(pkg, name)
        kind = _kind(obj)
        if kind == "data":
            module, doc = data.get(name, (f"{package}.{lazy[name]}" if name in lazy else package, ""))
        else:
            module, doc = obj.__module__, inspect.getdoc(obj) or ""
        if not doc.strip():
            logger.warning(
                "public name %s.%s has no docstring (%s); document it in %s",
                package,
                name,
                "a '#:' comment above its assignment" if kind == "data" else "a numpydoc docstring",
                module,
            )
        out.append((name, obj, kind, module, doc))
    return out


def _subpackage_names(package: str) -> dict[str, list[str]]:
    """``subpackage → names`` of its ``__all__`` that ``package.__all__`` does not re-export.

    Plumbing (``zonotope.utilities``: registries, atomic writers, progress types) is public in its
    subpackage only; those names get a page of their own, under their subpackage's path.
    """
    top = set(importlib.import_module(package).__all__)
    found = {}
    for name in _modules(package)[1:]:
        mod = importlib.import_module(name)
        if hasattr(mod, "__path__") and hasattr(mod, "__all__"):
            extra = [n for n in mod.__all__ if n not in top]
            if extra:
                found[name] = extra
    return found


def _module_group(module: str) -> str:
    """Page name of a defining module's names (``zonotope._tol`` → ``zonotope-tol``)."""
    if "." not in module:
        return f"{module}-package"
    return module.replace("._", ".").replace(".", "-")


def _api_page(namespace: str, rows, out: Path, written: set[str], intro: str, suffix: str = "") -> list[str]:
    """Write ``namespace``'s summary page and one page per defining module; the summary's lines."""
    groups: dict[str, list] = {}
    for row in rows:
        groups.setdefault(row[3], []).append(row)
    lines = [
        f".. _api-{namespace}:\n",
        _title(f"``{namespace}``"),
        f".. automodule:: {namespace}\n   :no-members:\n",
        _title("Public names", "-"),
        intro,
    ]
    toc = []
    for module in sorted(groups, key=lambda m: (m.split(".")[-1].lstrip("_"), m)):
        group = sorted(groups[module], key=lambda r: r[0].lower())
        page = _module_group(module) + suffix
        toc.append(page)
        lines += [
            f".. list-table:: from ``{module}`` — :doc:`details <{page}>`",
            "   :widths: 30 12 58\n   :header-rows: 0\n",
        ]
        for name, _obj, kind, _m, doc in group:
            lines += [
                f"   * - :py:{'obj'}:`~{namespace}.{name}`",
                f"     - {kind}",
                f"     - {_summary(doc)}",
            ]
        lines.append("")
        mod_doc = _summary(inspect.getdoc(importlib.import_module(module)))
        body = [
            _title(f"``{module}``"),
            f".. currentmodule:: {module}\n",  # short references in the module's summary
            f"{mod_doc}\n" if mod_doc else "",
            f".. currentmodule:: {namespace}\n",
        ]
        for name, _obj, kind, _m, doc in group:
            if kind == "data":
                body += [f".. py:data:: {name}\n", _indent(doc) + "\n"]
            elif kind in ("class", "exception"):
                members = "" if kind == "exception" else "   :members:\n   :show-inheritance:\n"
                body += [f".. autoclass:: {name}\n{members}"]
            else:
                body += [f".. autofunction:: {name}\n"]
        _write(out / f"{page}.rst", "\n".join(body))
        written.add(f"{page}.rst")
    return lines + [".. toctree::\n   :hidden:\n"] + [f"   {t}" for t in toc] + [""]


def generate_api(app, config) -> None:
    """Write ``docs/api/generated/*.rst``: one page per package, one per defining module.

    Names public only in a subpackage (``zonotope.utilities.MethodRegistry``) get a page per
    subpackage, linked from the package's page.
    """
    out = DOCS / "api" / "generated"
    written: set[str] = set()
    for package in PACKAGES:
        names = _public_names(package)
        lines = _api_page(
            package,
            names,
            out,
            written,
            f"All {len(names)} names of ``{package}.__all__``, by the module that defines them "
            f"(import them from ``{package}``).\n",
        )
        subpackages = _subpackage_names(package)
        if subpackages:
            lines += (
                [
                    _title("Names public in a subpackage only", "-"),
                    "Import these from their subpackage (``from zonotope.utilities import atomic_path``).\n",
                    ".. toctree::\n   :maxdepth: 1\n",
                ]
                + [f"   {sub}" for sub in subpackages]
                + [""]
            )
            for sub, extra in subpackages.items():
                rows = _public_names(sub, extra)
                sub_lines = _api_page(
                    sub,
                    rows,
                    out,
                    written,
                    f"The {len(rows)} names of ``{sub}.__all__`` that ``{package}`` does not re-export.\n",
                    suffix="-sub",
                )
                _write(out / f"{sub}.rst", "\n".join(sub_lines))
                written.add(f"{sub}.rst")
        _write(out / f"{package}.rst", "\n".join(lines))
        written.add(f"{package}.rst")
    for stale in out.glob("*.rst"):  # a module that no longer defines public names
        if stale.name not in written:
            stale.unlink()


def _indent(text: str, n: int = 3) -> str:
    return "\n".join((" " * n + line) if line.strip() else "" for line in text.splitlines())


def _parsers(module: str, builder: str):
    """``[(command line, help text)]`` of a program and each of its sub-commands."""
    import argparse

    mod = importlib.import_module(module)
    if builder == "main":  # a program without a parser builder: capture what --help prints
        buf = io.StringIO()
        with contextlib.redirect_stdout(buf), contextlib.suppress(SystemExit):
            mod.main(["--help"])
        return [(None, buf.getvalue())]
    parser = getattr(mod, builder)()
    out = [(None, parser.format_help())]
    seen = set()
    for action in parser._actions:
        if isinstance(action, argparse._SubParsersAction):
            for name, sub in action.choices.items():
                if id(sub) in seen:
                    continue  # an alias of a command already listed
                seen.add(id(sub))
                out.append((name, sub.format_help()))
    return out


def generate_cli(app, config) -> None:
    """Write ``docs/guide/cli_help/*.rst`` from the programs' own argparse parsers."""
    os.environ["COLUMNS"] = "100"  # argparse wraps to the terminal; fix it for a stable page
    out = DOCS / "guide" / "cli_help"
    for title, module, builder in CLIS:
        lines = [_title(f"``{title}``", "-")]
        for sub, text in _parsers(module, builder):
            if sub is not None:
                lines.append(_title(f"``{title} {sub}``", "~"))
            lines += [".. code-block:: text\n", _indent(text.rstrip()), ""]
        _write(out / f"{module.split('.')[-1] if '.' in title else title}.rst", "\n".join(lines))


def _executed(nb: dict) -> bool:
    cells = [c for c in nb["cells"] if c["cell_type"] == "code"]
    return bool(cells) and all(c.get("execution_count") is not None for c in cells)


def _shared_data() -> Path | None:
    """``../shared/data`` (or ``$ZONOTOPE_SHARED_DATA``) as the notebooks find it, else None."""
    env = os.environ.get("ZONOTOPE_SHARED_DATA")
    candidates = [Path(env)] if env else []
    candidates += [p / "shared" / "data" for p in (ROOT, *ROOT.parents)]
    return next((p for p in candidates if p.is_dir()), None)


def _uses_shared_data(nb: dict) -> bool:
    return any("shared_data" in "".join(c["source"]) for c in nb["cells"] if c["cell_type"] == "code")


def _thumbnail(nb: dict, target: Path) -> bool:
    """Write the notebook's first PNG output to ``target``; False when it has none."""
    for cell in nb["cells"]:
        for output in cell.get("outputs", []):
            png = output.get("data", {}).get("image/png")
            if png:
                data = base64.b64decode("".join(png) if isinstance(png, list) else png)
                if not target.exists() or target.read_bytes() != data:
                    target.parent.mkdir(parents=True, exist_ok=True)
                    target.write_bytes(data)
                return True
    return False


_NO_DATA_NOTE = (
    "```{note}\nThis page was built without `../shared/data` (set `ZONOTOPE_SHARED_DATA` to point to "
    "it): the figures below that need its measured data sets are left out or drawn from the built-in "
    "sets only, as the notebook says where it checks for the data.\n```"
)


def copy_gallery(app, config) -> None:
    """Copy ``notebooks/*.ipynb`` into ``docs/gallery`` and write the gallery's table.

    Executed notebooks are not executed again. Where a notebook reads ``../shared/data`` and this
    build runs it without that folder, its copy opens with a note saying so.
    """
    dst = DOCS / "gallery"
    dst.mkdir(exist_ok=True)
    data = _shared_data()
    mode = config.nb_execution_mode
    names = set()
    excluded = []
    rows = []
    order = [name for name, _ in GALLERY]
    notebooks = sorted(
        (ROOT / "notebooks").glob("*.ipynb"),
        key=lambda p: (order.index(p.stem) if p.stem in order else len(order), p.stem),
    )
    figures = dict(GALLERY)
    for path in notebooks:
        names.add(path.name)
        nb = json.loads(path.read_text())
        executed = _executed(nb)
        no_data = _uses_shared_data(nb) and data is None
        if executed:
            excluded.append(f"gallery/{path.name}")
            how = "shown with the outputs it carries (executed before this build)"
        elif mode in ("force", "auto", "cache", "inline"):
            how = "executed during this build"
        else:
            how = "**not executed** in this build (``nb_execution_mode = off``): code only"
        if no_data and not executed:
            nb["cells"].insert(0, {"cell_type": "markdown", "metadata": {}, "source": _NO_DATA_NOTE})
            how += "; **without** ``../shared/data``: its measured-data figures are left out"
        elif _uses_shared_data(nb):
            how += "; reads ``../shared/data`` when present"
        text = json.dumps(nb, indent=1, ensure_ascii=False) + "\n"
        target = dst / path.name
        if not target.exists() or target.read_text() != text:
            target.write_text(text)
        thumb = _thumbnail(nb, dst / "_thumbs" / f"{path.stem}.png")
        rows.append((path.stem, figures.get(path.stem, ""), how, thumb))
    for helper in sorted((ROOT / "notebooks").glob("*.py")):  # modules the notebooks import
        names.add(helper.name)
        if not (dst / helper.name).exists() or (dst / helper.name).read_bytes() != helper.read_bytes():
            shutil.copyfile(helper, dst / helper.name)
    for stale in [*dst.glob("*.ipynb"), *dst.glob("*.py")]:
        if stale.name not in names:
            stale.unlink()
    for stale in (dst / "_thumbs").glob("*.png") if (dst / "_thumbs").is_dir() else ():
        if not any(stem == stale.stem and thumb for stem, _, _, thumb in rows):
            stale.unlink()
    lines = [
        ".. list-table::",
        "   :header-rows: 1",
        "   :widths: 22 48 30",
        "   :class: zdocs-gallery",
        "",
        "   * - figure",
        "     - notebook and thesis figures",
        "     - in this build",
    ]
    for stem, figs, how, thumb in rows:
        cell = (
            f".. image:: /gallery/_thumbs/{stem}.png\n          :width: 180px\n          :alt: {stem}"
            if thumb
            else "*(no figure yet: the notebook has no outputs)*"
        )
        lines += [f"   * - {cell}", f"     - :doc:`/gallery/{stem}`", "", f"       {figs}", f"     - {how}"]
    _write(dst / "table.inc", "\n".join(lines) + "\n")
    config.nb_execution_excludepatterns = list(config.nb_execution_excludepatterns) + excluded
    if data is None and any(_uses_shared_data(json.loads(p.read_text())) for p in notebooks):
        logger.info("gallery: ../shared/data not found; the notebooks that read it say so on their pages")
    logger.info("gallery: %d files, %d notebooks already executed", len(names), len(excluded))


#: ``|x|`` written as an absolute value (``|det|``, ``|Φᵀx − c| ≤ δ``): reStructuredText would read it
#: as a substitution reference and fail the build. Docstrings here never use substitutions, so such
#: spans are escaped outside inline literals (``...``) before numpydoc and docutils see them.
_ABS = re.compile(r"(?<![\\`|\w])\|(?=[^\s|])([^|`\n]*?[^\s|\\])\|(?![`|\w])")
_LITERAL = re.compile(r"(``.*?``)")


def escape_absolute_values(app, what, name, obj, options, lines) -> None:
    r"""``autodoc-process-docstring`` hook: escape ``|x|`` as ``\|x\|`` outside ``inline literals``."""
    for i, line in enumerate(lines):
        if "|" in line:
            parts = _LITERAL.split(line)
            lines[i] = "".join(p if p.startswith("``") else _ABS.sub(r"\\|\1\\|", p) for p in parts)


#: Packages whose objects cannot be linked (no intersphinx: CI reaches only package registries).
EXTERNAL = (
    "colour",
    "trimesh",
    "pyvista",
    "manifold3d",
    "numpy",
    "scipy",
    "jax",
    "concurrent",
    "collections",
)


def _lookup(dotted: str):
    """The Python object a dotted path names (module, then attributes), or None."""
    parts = dotted.split(".")
    for cut in range(len(parts), 0, -1):
        try:
            obj = importlib.import_module(".".join(parts[:cut]))
        except Exception:  # not a module (or not importable): try a shorter module path
            continue
        try:
            for attr in parts[cut:]:
                obj = getattr(obj, attr)
        except AttributeError:
            return None
        return obj
    return None


def resolve_public(app, env, node, contnode):
    """``missing-reference`` hook: link module paths and short names to the public API pages.

    The API pages document every name once, under its public path (``zonotope.fit_correction``);
    docstrings often write the defining module's path (``zonotope.correct.fit_correction``), a short
    name relative to their module or class, or an attribute listed in a class's Attributes section.
    Those are linked to the public object; a reference to an existing but undocumented object
    (private helpers, external packages: no intersphinx in CI) becomes plain text; a reference to a
    name that does not exist at all stays a warning, so ``-W`` fails on it.
    """
    if node.get("refdomain") != "py":
        return None
    domain = env.get_domain("py")
    target = node["reftarget"].lstrip("~.")
    module, klass = node.get("py:module") or "", node.get("py:class") or ""
    objects = domain.objects
    contexts = [target]
    if klass:
        contexts.append(f"{module}.{klass}.{target}" if module else f"{klass}.{target}")
    if module:
        contexts.append(f"{module}.{target}")
    for full in contexts:
        obj = _lookup(full)
        if obj is None:
            continue
        # the same object documented under a public path?
        name = getattr(obj, "__qualname__", None) or full.rsplit(".", 1)[-1]
        package = full.split(".")[0]
        for public in (f"{package}.{name}", f"{package}.{full.rsplit('.', 1)[-1]}"):
            if public in objects and _lookup(public) is obj:
                return domain.resolve_xref(env, node["refdoc"], app.builder, "obj", public, node, contnode)
        return contnode  # exists, but is not part of the documented API: plain text
    if klass and node["reftype"] in ("attr", "meth", "obj"):
        owner = f"{module}.{klass}" if module else klass
        if _lookup(owner) is not None:  # an attribute listed in the class's Attributes section
            return contnode
    if target.split(".")[0] in EXTERNAL:
        return contnode
    # a short name written in a docstring of another module (documented under the package's path):
    # link it when exactly one public object has that name, else plain text if it exists anywhere
    short = target.rsplit(".", 1)[-1]
    public = [f"{p}.{short}" for p in PACKAGES if f"{p}.{short}" in objects]
    if len(public) == 1:
        return domain.resolve_xref(env, node["refdoc"], app.builder, "obj", public[0], node, contnode)
    if short in _module_names():
        return contnode
    return None


_NAMES: set[str] = set()


def _module_names() -> set[str]:
    """Every top-level name defined in any module of the three packages (built once)."""
    if not _NAMES:
        for package in PACKAGES:
            for name in _modules(package)[1:]:
                try:
                    mod = importlib.import_module(name)
                except Exception:  # an optional dependency missing: its names are simply unknown
                    continue
                _NAMES.update(n for n in vars(mod) if not n.startswith("__"))
    return _NAMES


def setup(app):
    """Register the generators (they run once the configuration is read, before sources are found)."""
    app.connect("config-inited", generate_api)
    app.connect("config-inited", generate_cli)
    app.connect("config-inited", copy_gallery)
    app.connect("autodoc-process-docstring", escape_absolute_values, priority=400)
    app.connect("missing-reference", resolve_public)
    return {"version": "1", "parallel_read_safe": True, "parallel_write_safe": True}
