"""One tolerance module: each object honours its own tolerances, and the named values are used."""

from __future__ import annotations

import ast
from pathlib import Path

import numpy as np
import pytest

from zonotope import Polytope, Tolerances, Zonotope, _tol


@pytest.mark.parametrize("k", [3, 4])
def test_contains_uses_the_solids_own_tolerances(k):
    """Regression: ``contains`` used the global TOL instead of the solid's ``tol``."""
    point = np.full(k, 0.5)
    point[0] = 1.05  # 0.05 outside the unit cube
    loose = Zonotope(np.eye(k), tol=Tolerances(contains=0.1))  # slack 0.1 × scale (scale = 1)
    strict = Zonotope(np.eye(k))
    assert loose.scale == 1.0
    assert bool(loose.contains(point)) and not bool(strict.contains(point))
    if k == 3:
        assert bool(loose.contains_reference(point)) and not bool(strict.contains_reference(point))
    # just inside the loose slack / just outside it
    point[0] = 1.0 + 0.1 * 0.999
    assert bool(loose.contains(point))
    point[0] = 1.0 + 0.1 * 1.001
    assert not bool(loose.contains(point))


def test_polytope_flatness_threshold_is_AFFINE():
    """Points off a plane by less than AFFINE × diameter are flat; 100 × more is a solid."""
    square = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [1, 1, 0]], dtype=float)
    diameter = np.sqrt(2.0)
    for height, dim in [(0.01 * _tol.AFFINE * diameter, 2), (100 * _tol.AFFINE * diameter, 3)]:
        P = Polytope(np.vstack([square, [0.5, 0.5, height]]))
        assert P.affine_dim == dim


def test_tolerance_values_are_documented():
    """Every named tolerance has a reason next to it (a comment block or the class notes)."""
    source = open(_tol.__file__, encoding="utf-8").read()
    names = [n for n in _tol.__all__ if n.isupper() and n != "TOL"]
    assert {"AFFINE", "ANGLE", "CERTIFY", "COLLINEAR", "FEASIBLE_REL", "FEASIBLE_ABS", "SINGULAR"} <= set(
        names
    )
    for name in names:
        assert "#: " in source.split(f"\n{name} = ")[0].rsplit("\n\n", 1)[-1], name
    for field in ("zero", "parallel", "coplanar", "rank", "contains"):
        assert f"``{field} = " in Tolerances.__doc__, field


def test_oracle_names_are_case_insensitive_and_unknown_ones_are_project_errors():
    import zonotope
    from zonotope.mismatch import metamer_mismatch

    rng = np.random.default_rng(3)
    Phi, Psi = rng.random((12, 2)), rng.random((12, 3))
    c = np.full(12, 0.5) @ Phi
    a = metamer_mismatch(Phi, Psi, c, oracle="HiGHS")
    b = metamer_mismatch(Phi, Psi, c, oracle="fast")
    np.testing.assert_allclose(a.volume, b.volume, rtol=1e-7)
    with pytest.raises(zonotope.UnknownMethodError, match=r"oracle='cdd' is not a support oracle method"):
        metamer_mismatch(Phi, Psi, c, oracle="cdd")


@pytest.mark.parametrize(("bump", "n_vertices"), [(0.0, 4), (1e-17, 4), (1e-9, 5)])
def test_polygon_collinear_threshold_is_COLLINEAR(bump, n_vertices):
    """A point on a square's edge is dropped when it is off the edge by rounding only (COLLINEAR)."""
    pts = np.array([[0, 0], [1, 0], [1, 1], [0, 1], [0.5, -bump]], dtype=float)
    assert len(Polytope(pts).vertices) == n_vertices


def test_flat_halfspace_vertices_skip_singular_subsets():
    """A flat triangle as half-spaces (two opposite planes z ≤ 0, −z ≤ 0 plus 3 sides): the parallel
    pair's |det| is 0 ≤ SINGULAR, skipped; the vertices come from the well-conditioned subsets."""
    A = np.array([[0, 0, 1], [0, 0, -1], [-1, 0, 0], [0, -1, 0], [1, 1, 0]], dtype=float)
    b = np.array([0, 0, 0, 0, 1], dtype=float)
    P = Polytope.from_halfspaces(A, b)
    assert P.affine_dim == 2
    np.testing.assert_allclose(sorted(map(tuple, P.vertices)), [(0, 0, 0), (0, 1, 0), (1, 0, 0)], atol=1e-12)


# ---------------------------------------------------------------------------------------------
# No stray tolerance literals: every numerical threshold is a named value of a _tol module
# ---------------------------------------------------------------------------------------------

ROOT = Path(__file__).resolve().parents[2]

#: Keywords whose value is a tolerance wherever they are passed.
_TOLERANCE_KEYWORDS = {"atol", "rtol", "tol", "eps", "xtol", "ftol", "gtol", "xatol", "fatol"}

#: Calls whose literal arguments are floors or clip bounds (``max(x, 1e-300)`` against a division
#: by zero, ``np.clip(x, 1e-3, 1)``), not decisions.
_FLOOR_CALLS = {"max", "maximum", "clip", "fmax"}

#: Literals that stay, by ``(file, value)``, with the reason (splat's tolerances are in splat/_tol.py).
STRAY_ALLOWED: dict[tuple[str, float], str] = {
    ("splat/sim/geometry.py", 0.06): "scene design: the dark cell borders' width, a fraction of the cell",
    ("splat/sim/geometry.py", 0.025): "scene design: the ColorChecker's gap between patches (m)",
    ("splat/sim/capture.py", 0.9): "scene design: the white card's flat reflectance",
    ("splat/capture/spec.py", 1.5): "input range: the largest white reflectance accepted in capture.toml",
    ("splat/cli.py", 10.0): "UI: seconds between progress lines when stderr is not a terminal",
    ("splat/training.py", 1e-15): "optimiser hyper-parameter: Adam's ε (tiny, so rarely-seen Gaussians "
    "are not damped), not a decision",
}


def _stray_literals(path: Path) -> list[tuple[int, float]]:
    """``(line, value)`` of the tolerance-like float literals of a module.

    A literal is tolerance-like when it is small (``0 < |v| ≤ 1e-3``: an epsilon or threshold), is
    compared with (``x > 0.1 * y``; 0, ±0.5, ±1, ±2 excepted), or is passed as ``atol``/``rtol``/
    ``tol``/``eps``/... . Not counted: docstrings, default values of parameters and of dataclass
    fields and ``default=`` of CLI options (documented API defaults), and the arguments of
    ``max``/``np.maximum``/``clip`` (floors against a division by zero, clip bounds).
    """
    tree = ast.parse(path.read_text(encoding="utf-8"))
    skip: set[int] = set()

    def skip_all(node):
        skip.update(id(c) for c in ast.walk(node))

    for n in ast.walk(tree):
        if isinstance(n, ast.Module | ast.FunctionDef | ast.AsyncFunctionDef | ast.ClassDef):
            if n.body and isinstance(n.body[0], ast.Expr) and isinstance(n.body[0].value, ast.Constant):
                skip.add(id(n.body[0].value))
        if isinstance(n, ast.arguments):
            for d in [*n.defaults, *n.kw_defaults]:
                if d is not None:
                    skip_all(d)
        if isinstance(n, ast.ClassDef):
            for st in n.body:
                if isinstance(st, ast.AnnAssign) and st.value is not None:
                    skip_all(st.value)
        if isinstance(n, ast.keyword) and n.arg == "default":
            skip_all(n.value)
        if isinstance(n, ast.Call):
            f = n.func
            name = f.id if isinstance(f, ast.Name) else f.attr if isinstance(f, ast.Attribute) else ""
            if name in _FLOOR_CALLS:
                for a in [*n.args, *(k.value for k in n.keywords)]:
                    skip_all(a)

    def floats(node):
        return [c for c in ast.walk(node) if isinstance(c, ast.Constant) and type(c.value) is float]

    found = {}
    for n in ast.walk(tree):
        cands = []
        if isinstance(n, ast.Constant) and type(n.value) is float and 0 < abs(n.value) <= 1e-3:
            cands = [n]
        elif isinstance(n, ast.Compare):
            cands = [c for s in (n.left, *n.comparators) for c in floats(s)]
            cands = [c for c in cands if abs(c.value) not in (0.0, 0.5, 1.0, 2.0)]
        elif isinstance(n, ast.keyword) and n.arg in _TOLERANCE_KEYWORDS:
            cands = [c for c in floats(n.value) if c.value != 0]
        for c in cands:
            if id(c) not in skip:
                found[id(c)] = (c.lineno, c.value)
    return sorted(found.values())


def _package_modules():
    for package in ("zonotope", "isp", "splat"):
        for path in sorted((ROOT / package).rglob("*.py")):
            if path.name != "_tol.py":  # the homes of the named values
                yield path


def test_no_stray_tolerance_literals():
    """Every numerical threshold is a named, documented value of ``zonotope/_tol.py`` (or, for isp
    and splat, which may use only public zonotope names, ``isp/_tol.py`` / ``splat/_tol.py``); the
    allow-list says why a literal stays. Results do not depend on this: moving a literal to a name
    keeps its value."""
    stray, used = [], set()
    for path in _package_modules():
        rel = path.relative_to(ROOT).as_posix()
        for line, value in _stray_literals(path):
            if (rel, value) in STRAY_ALLOWED:
                used.add((rel, value))
            else:
                stray.append(f"{rel}:{line}: {value!r}")
    assert not stray, (
        "name these in _tol.py with the reason for the value (or allow-list them):\n" + "\n".join(stray)
    )
    stale = [k for k in STRAY_ALLOWED if k not in used]
    assert not stale, f"no longer in the code, remove from STRAY_ALLOWED: {stale}"


def test_stray_literal_finder_finds_and_skips_what_it_should(tmp_path):
    f = tmp_path / "m.py"
    f.write_text(
        '"""Doc 1e-9."""\n'
        "def f(x, atol=1e-9):\n"
        "    y = max(x, 1e-300)\n"
        "    if x < 1e-7 * y:\n"  # line 4: small
        "        return 0.1 < x\n"  # line 5: compared with
        "    return g(x, rtol=0.05, z=0.5 * x)\n"  # line 6: a tolerance keyword
    )
    assert _stray_literals(f) == [(4, 1e-7), (5, 0.1), (6, 0.05)]


@pytest.mark.parametrize(("module", "at_least"), [("isp._tol", 10), ("splat._tol", 9)])
def test_isp_and_splat_tolerances_are_documented(module, at_least):
    """isp's and splat's thresholds, like zonotope's, each have a reason next to them."""
    import importlib

    itol = importlib.import_module(module)
    source = Path(itol.__file__).read_text(encoding="utf-8")
    assert len(itol.__all__) >= at_least
    for name in itol.__all__:
        block = source.split(f"\n{name} = ")[0].rsplit("\n\n", 1)[-1]
        assert block.startswith("#: ") and len(block) > 120, name


def test_output_writers_go_through_the_atomic_writers():
    """Files are written only through ``zonotope``'s atomic, umask-respecting writers (``utilities.io``):
    no module of zonotope or isp makes its own temporary + rename (which gave 0600 files)."""
    allowed = {
        "zonotope/utilities/io.py": "the atomic writers themselves",
        "zonotope/parallel/files.py": "folder batches publish a finished temporary with os.link/os.replace "
        "(first attempt wins); the temporaries are created by open() and so already get umask modes",
    }
    bad = []
    for package in ("zonotope", "isp"):
        for path in sorted((ROOT / package).rglob("*.py")):
            rel = path.relative_to(ROOT).as_posix()
            code = "\n".join(
                line
                for line in path.read_text(encoding="utf-8").splitlines()
                if not line.strip().startswith("#")
            )
            for pattern in ("mkstemp(", "os.replace(", "NamedTemporaryFile("):
                if pattern in code and rel not in allowed:
                    bad.append(f"{rel}: {pattern}")
    assert not bad, f"write through zonotope.utilities.atomic_path / atomic_file / atomic_write_*: {bad}"
