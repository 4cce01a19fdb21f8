"""The pipeline/render package: no import cycle through its modules, none imports it back.

The import graph and the cycle finder are tests/test_layers.py's (every project module,
read from source); one-line module purposes are checked there for all of pipeline/.
"""

from __future__ import annotations

import ast

from tests.test_layers import REPO, find_cycle, import_graph, project_modules

PACKAGE = "pipeline.render"


def render_modules() -> list[str]:
    return sorted(m for m in project_modules() if m == PACKAGE or m.startswith(PACKAGE + "."))


def reachable(graph: dict[str, set[str]], root: str) -> dict[str, set[str]]:
    """The part of ``graph`` reachable from ``root``."""
    out: dict[str, set[str]] = {}
    todo = [root]
    while todo:
        m = todo.pop()
        if m not in out:
            out[m] = graph.get(m, set())
            todo += sorted(out[m] - out.keys())
    return out


def test_the_package_has_the_expected_modules():
    mods = render_modules()
    assert PACKAGE in mods and len(mods) > 5
    assert not (REPO / "pipeline" / "render.py").exists()
    assert not (REPO / "pipeline" / "render_full.py").exists()


def test_no_import_cycle_through_any_render_module():
    graph = import_graph(project_modules())
    for m in render_modules():  # reachable from m: no path leads back to m
        cycle = find_cycle(reachable(graph, m))
        assert cycle is None, f"import cycle from {m}: {' -> '.join(cycle)}"


def test_no_submodule_imports_the_package_back():
    graph = import_graph(project_modules())
    for m in render_modules():
        if m != PACKAGE:
            assert PACKAGE not in graph[m], f"{m} imports {PACKAGE} (its __init__)"


def test_export_uses_only_public_render_names():
    tree = ast.parse((REPO / "pipeline" / "export.py").read_text(encoding="utf-8"))
    names = [a.name for n in ast.walk(tree) if isinstance(n, ast.ImportFrom)
             and (n.module or "").startswith(PACKAGE) for a in n.names]
    assert names and not [n for n in names if n.startswith("_")]
