"""The pipeline/render package: no import cycle through any of its modules, one-line purposes."""

from __future__ import annotations

import ast
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
PACKAGE = "pipeline.render"
PROJECT = ("pipeline", "gnfr", "workflows", "benchmarks")


def module_name(path: Path) -> str:
    parts = list(path.relative_to(REPO).with_suffix("").parts)
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


def module_file(name: str) -> Path | None:
    base = REPO.joinpath(*name.split("."))
    for p in (base.with_suffix(".py"), base / "__init__.py"):
        if p.is_file():
            return p
    return None


def imports_of(name: str) -> set[str]:
    """Project modules ``name`` imports anywhere in its source (module level, inside
    functions, under TYPE_CHECKING); ``from package import submodule`` counts as the
    submodule, ``from package import name`` as the package."""
    path = module_file(name)
    is_pkg = path.name == "__init__.py"
    out = set()
    for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
        if isinstance(node, ast.Import):
            targets = [a.name for a in node.names]
        elif isinstance(node, ast.ImportFrom):
            if node.level:  # relative: resolve against this module's package
                base = name.split(".") if is_pkg else name.split(".")[:-1]
                base = base[:len(base) - node.level + 1]
                mod = ".".join(base + ([node.module] if node.module else []))
            else:
                mod = node.module
            targets = [f"{mod}.{a.name}" if module_file(f"{mod}.{a.name}") else mod
                       for a in node.names]
        else:
            continue
        out |= {t for t in targets if t.split(".")[0] in PROJECT and module_file(t)}
    return out


def import_graph(roots: list[str]) -> dict[str, set[str]]:
    """The import graph of the project modules reachable from ``roots``."""
    graph: dict[str, set[str]] = {}
    todo = list(roots)
    while todo:
        m = todo.pop()
        if m in graph:
            continue
        graph[m] = imports_of(m)
        todo += sorted(graph[m] - graph.keys())
    return graph


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


def render_modules() -> list[str]:
    return sorted(module_name(p) for p in (REPO / "pipeline" / "render").glob("*.py"))


def test_the_package_has_the_expected_modules():
    mods = render_modules()
    assert PACKAGE in mods and len(mods) > 5
    assert not (REPO / "pipeline" / "render.py").exists()
    assert not (REPO / "pipeline" / "render_full.py").exists()


def test_no_import_cycle_through_any_render_module():
    mods = render_modules()
    graph = import_graph(mods)
    for m in mods:  # reachable from m: no path leads back to m
        sub = import_graph([m])
        cycle = find_cycle(sub)
        assert cycle is None, f"import cycle from {m}: {' -> '.join(cycle)}"
    assert find_cycle(graph) is None


def test_no_submodule_imports_the_package_back():
    for m in render_modules():
        if m != PACKAGE:
            assert PACKAGE not in imports_of(m), f"{m} imports {PACKAGE} (its __init__)"


def test_the_cycle_finder_finds_cycles():
    assert find_cycle({"a": {"b"}, "b": {"c"}, "c": {"a"}}) == ["a", "b", "c", "a"]
    assert find_cycle({"a": {"b", "c"}, "b": {"c"}, "c": set()}) is None


def test_export_uses_only_public_render_names():
    tree = ast.parse((REPO / "pipeline" / "export.py").read_text(encoding="utf-8"))
    names = [a.name for n in ast.walk(tree) if isinstance(n, ast.ImportFrom)
             and (n.module or "").startswith(PACKAGE) for a in n.names]
    assert names and not [n for n in names if n.startswith("_")]


def test_every_module_starts_with_a_one_line_purpose():
    for m in render_modules():
        tree = ast.parse(module_file(m).read_text(encoding="utf-8"))
        doc = ast.get_docstring(tree)
        assert doc, f"{m} has no module docstring"
        first = doc.splitlines()[0]
        assert first.strip() and len(first) <= 100, f"{m}: {first!r}"
