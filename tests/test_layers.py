"""Layers (docs/design.md): the project's import graph, read from source, has no cycle and
only goes workflows -> pipeline -> gnfr; rawpy and pycolmap stay behind decode and pose.

The graph is built with ``ast`` from every module found by walking the package folders (no
fixed module list: packages are reorganised), counting every import wherever it is (module
level, inside functions, under TYPE_CHECKING). The checks are also run on a small tree with
deliberate violations, so they are known to fail when they should.
"""

from __future__ import annotations

import ast
from dataclasses import dataclass
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
PACKAGES = ("gnfr", "pipeline", "workflows", "benchmarks")
"""Folders walked for modules: every .py file under them (benchmarks has no __init__)."""
LAYER = {"gnfr": 0, "pipeline": 1, "workflows": 2, "benchmarks": 3}
"""A module may import modules of its own layer or of a lower one, never of a higher one."""
PRODUCT = ("gnfr", "pipeline", "workflows")
"""The installed packages: they must run where rawpy and pycolmap are not installed."""
HEAVY = {"rawpy": {"pipeline.decode"},
         "pycolmap": {"pipeline.pose", "pipeline.colmap_io"}}
"""Optional libraries and the only product modules that import them (inside functions):
decode reads camera raw, pose runs SfM with colmap_io as its COLMAP I/O."""


@dataclass(frozen=True)
class Import:
    """One imported module as written in a module's source."""

    target: str
    """Dotted name: a project module, or a third-party module."""
    line: int
    deferred: bool
    """Inside a function or under ``if TYPE_CHECKING:``, so not run at import time."""


# --------------------------------------------------------------------------- the graph
def project_modules(root: Path = REPO) -> dict[str, Path]:
    """{dotted name: file} of every module under the ``PACKAGES`` folders of ``root``."""
    out = {}
    for pkg in PACKAGES:
        for path in sorted((root / pkg).rglob("*.py")):
            rel = path.relative_to(root)
            if any(p.startswith(".") or p == "__pycache__" for p in rel.parts):
                continue
            parts = list(rel.with_suffix("").parts)
            out[".".join(parts[:-1] if parts[-1] == "__init__" else parts)] = path
    return out


def _is_type_checking(test: ast.expr) -> bool:
    return (isinstance(test, ast.Name) and test.id == "TYPE_CHECKING") or (
        isinstance(test, ast.Attribute) and test.attr == "TYPE_CHECKING")


def imports_of(name: str, modules: dict[str, Path]) -> list[Import]:
    """Every import in module ``name``'s source. ``from package import submodule`` counts as
    the submodule, ``from package import name`` as the package; relative imports are
    resolved against the module's package."""
    path = modules[name]
    is_pkg = path.name == "__init__.py"
    found: list[Import] = []

    def resolve(node: ast.ImportFrom) -> str:
        if not node.level:
            return node.module or ""
        base = name.split(".") if is_pkg else name.split(".")[:-1]
        base = base[:len(base) - node.level + 1]
        return ".".join(base + ([node.module] if node.module else []))

    def visit(node: ast.AST, deferred: bool) -> None:
        if isinstance(node, ast.Import):
            found.extend(Import(a.name, node.lineno, deferred) for a in node.names)
        elif isinstance(node, ast.ImportFrom):
            mod = resolve(node)
            for a in node.names:
                sub = f"{mod}.{a.name}"
                found.append(Import(sub if sub in modules else mod, node.lineno, deferred))
        inner = deferred or isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef,
                                              ast.Lambda))
        if isinstance(node, ast.If) and _is_type_checking(node.test):
            for child in node.body:
                visit(child, True)
            for child in node.orelse:
                visit(child, inner)
            return
        for child in ast.iter_child_nodes(node):
            visit(child, inner)

    visit(ast.parse(path.read_text(encoding="utf-8")), False)
    return found


def import_graph(modules: dict[str, Path]) -> dict[str, set[str]]:
    """{module: the project modules it imports}."""
    return {m: {i.target for i in imports_of(m, modules) if i.target in modules}
            for m in modules}


def find_cycle(graph: dict[str, set[str]]) -> list[str] | None:
    """One import cycle of ``graph`` as [a, b, ..., a], or None when it is acyclic."""
    state: dict[str, int] = {}  # 1: on the current path, 2: done
    path: list[str] = []

    def visit(m: str) -> list[str] | None:
        state[m] = 1
        path.append(m)
        for n in sorted(graph.get(m, ())):
            if state.get(n) == 1:
                return path[path.index(n):] + [n]
            if n not in state and (cycle := visit(n)):
                return cycle
        path.pop()
        state[m] = 2
        return None

    for m in sorted(graph):
        if m not in state and (cycle := visit(m)):
            return cycle
    return None


# --------------------------------------------------------------------------- the rules
def layer_violations(modules: dict[str, Path]) -> list[str]:
    """'a imports b' for every import of a higher layer's module."""
    out = []
    for a, targets in sorted(import_graph(modules).items()):
        for b in sorted(targets):
            if LAYER[b.split(".")[0]] > LAYER[a.split(".")[0]]:
                out.append(f"{a} imports {b}")
    return out


def heavy_violations(modules: dict[str, Path]) -> list[str]:
    """Product modules importing rawpy / pycolmap other than those ``HEAVY`` allows, and
    allowed ones importing them at import time (outside functions)."""
    out = []
    for m in sorted(modules):
        if m.split(".")[0] not in PRODUCT:
            continue
        for imp in imports_of(m, modules):
            lib = imp.target.split(".")[0]
            if lib not in HEAVY:
                continue
            if m not in HEAVY[lib]:
                out.append(f"{m}:{imp.line} imports {lib}")
            elif not imp.deferred:
                out.append(f"{m}:{imp.line} imports {lib} at import time")
    return out


def colmap_io_users(modules: dict[str, Path]) -> set[str]:
    """Product modules that import pipeline.colmap_io (pycolmap's other way in)."""
    return {m for m, t in import_graph(modules).items()
            if "pipeline.colmap_io" in t and m.split(".")[0] in PRODUCT}


# --------------------------------------------------------------------------- tests
def test_the_walk_finds_every_package():
    mods = project_modules()
    for pkg in PRODUCT:
        assert pkg in mods, pkg
    assert {"pipeline.workspace", "pipeline.render.engine", "gnfr.fit"} <= mods.keys()
    assert any(m.startswith("workflows.") for m in mods)
    assert any(m.startswith("benchmarks.") for m in mods)


def test_no_import_cycle_anywhere():
    cycle = find_cycle(import_graph(project_modules()))
    assert cycle is None, "import cycle: " + " -> ".join(cycle)


def test_imports_go_down_the_layers_only():
    """gnfr imports nothing of pipeline or workflows, pipeline nothing of workflows, and no
    package imports benchmarks."""
    assert layer_violations(project_modules()) == []


def test_rawpy_and_pycolmap_only_in_decode_and_pose():
    mods = project_modules()
    assert heavy_violations(mods) == []
    assert colmap_io_users(mods) <= {"pipeline.pose"}


def test_every_pipeline_and_gnfr_module_starts_with_a_one_line_purpose():
    for m, path in project_modules().items():
        if m.split(".")[0] not in ("pipeline", "gnfr"):
            continue
        doc = ast.get_docstring(ast.parse(path.read_text(encoding="utf-8")))
        assert doc, f"{m} has no module docstring"
        lines = doc.splitlines()
        first = lines[0].strip()
        assert first.endswith(".") and len(lines[0]) <= 100, f"{m}: {lines[0]!r}"
        assert len(lines) == 1 or not lines[1].strip(), f"{m}: the purpose runs on: {lines[1]!r}"


def _tree(root: Path, files: dict[str, str]) -> dict[str, Path]:
    for rel, text in files.items():
        p = root / rel
        p.parent.mkdir(parents=True, exist_ok=True)
        p.write_text(text)
    return project_modules(root)


def test_the_checks_catch_deliberate_violations(tmp_path):
    mods = _tree(tmp_path, {
        "gnfr/__init__.py": "",
        "gnfr/a.py": "def f():\n    from pipeline.b import g\n",          # upward, lazily
        "pipeline/__init__.py": "",
        "pipeline/b.py": "from gnfr import a\nfrom . import c\n",          # cycle via gnfr.a
        "pipeline/c.py": "from typing import TYPE_CHECKING\nif TYPE_CHECKING:\n"
                         "    import pycolmap\nimport workflows.d\n",
        "pipeline/decode.py": "import rawpy\n",                              # at import time
        "pipeline/pose.py": "def f():\n    import pycolmap\n",              # allowed
        "workflows/__init__.py": "",
        "workflows/d.py": "from pipeline import colmap_io\n",
        "pipeline/colmap_io.py": "def f():\n    import pycolmap.x\n",      # allowed
        "benchmarks/e.py": "import pycolmap\nfrom pipeline import b\n",     # benchmarks: free
    })
    assert find_cycle(import_graph(mods)) == ["pipeline.b", "gnfr.a", "pipeline.b"]
    assert layer_violations(mods) == ["gnfr.a imports pipeline.b",
                                      "pipeline.c imports workflows.d"]
    assert heavy_violations(mods) == ["pipeline.c:3 imports pycolmap",
                                      "pipeline.decode:1 imports rawpy at import time"]
    assert colmap_io_users(mods) == {"workflows.d"}
    clean = _tree(tmp_path / "clean", {"gnfr/__init__.py": "", "pipeline/__init__.py": "",
                                       "pipeline/x.py": "import gnfr\n"})
    assert find_cycle(import_graph(clean)) is None and layer_violations(clean) == []


def test_tests_mirror_the_packages():
    """tests/<package>/ for each package's tests, tests/benchmarks/ for the scripts of
    benchmarks/ (a folder of scripts, not a package), tests/docs/ for the numbers the docs
    quote; only project-wide checks at the top."""
    tests = REPO / "tests"
    folders = {p.name for p in tests.iterdir() if p.is_dir() and (p / "__init__.py").exists()}
    assert folders == {"gnfr", "pipeline", "workflows", "benchmarks", "docs"}
    assert all((REPO / name / "__init__.py").exists()
               for name in folders - {"docs", "benchmarks"})
    assert any((REPO / "benchmarks").glob("*.py"))
    assert (REPO / "docs" / "results").is_dir()
    top = {p.name for p in tests.glob("test_*.py")}
    assert top == {"test_layers.py"}, top
