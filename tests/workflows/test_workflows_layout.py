"""workflows/ and benchmarks/: the product apart from the research tools, a purpose line atop
every module, and only benchmark scripts that a page cites."""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

from workflows.cli import COMMAND_MODULES, RESEARCH_COMMANDS

REPO = Path(__file__).resolve().parents[2]
MODULES = sorted([*(REPO / "workflows").rglob("*.py"), *(REPO / "benchmarks").glob("*.py")])


def _imports(path: Path) -> set[str]:
    """Every module ``path`` imports, at any depth of its code."""
    out = set()
    for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
        if isinstance(node, ast.Import):
            out |= {alias.name for alias in node.names}
        elif isinstance(node, ast.ImportFrom) and node.module:
            out.add(node.module)
            out |= {f"{node.module}.{alias.name}" for alias in node.names}
    return out


@pytest.mark.parametrize("path", MODULES, ids=[str(p.relative_to(REPO)) for p in MODULES])
def test_every_module_opens_with_a_one_line_purpose(path):
    doc = ast.get_docstring(ast.parse(path.read_text(encoding="utf-8")))
    assert doc, f"{path} has no docstring"
    first = doc.splitlines()[0]
    assert first.rstrip().endswith((".", "?")) and len(first) > 20, first


def test_the_product_never_imports_research():
    research_modules = {f"workflows.commands.{name}" for name in RESEARCH_COMMANDS}
    product = [p for p in (REPO / "workflows").rglob("*.py")
               if "research" not in p.parts and p.stem not in RESEARCH_COMMANDS]
    assert set(RESEARCH_COMMANDS) < set(COMMAND_MODULES)
    for path in product:
        bad = {m for m in _imports(path) if m.startswith("workflows.research")}
        bad |= _imports(path) & research_modules
        assert not bad, (path, bad)
    for path in [*(REPO / "pipeline").rglob("*.py"), *(REPO / "gnfr").rglob("*.py")]:
        assert not {m for m in _imports(path) if m.startswith("workflows")}, path


def test_every_benchmark_script_is_cited_by_a_page():
    pages = [REPO / "README.md", *(REPO / "docs").rglob("*.md"),
             *(REPO / "gnfr" / "weights").glob("*.md")]
    text = "\n".join(p.read_text(encoding="utf-8") for p in pages)
    for script in (REPO / "benchmarks").glob("*.py"):
        assert f"benchmarks/{script.name}" in text, f"no page cites {script.name}"
