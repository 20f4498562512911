"""Issue 22's targets for the core (every package of screwcal and its root modules) and the
controller protocol: modules of at most 450 lines, functions of at most 80, no `type: ignore`."""

import ast
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
AREAS = [ROOT / "screwcal", ROOT / "protocol"]
FILES = sorted(f for a in AREAS for f in ([a] if a.is_file() else a.rglob("*.py")))
MAX_MODULE, MAX_FUNCTION = 450, 80


@pytest.mark.parametrize("path", FILES, ids=lambda p: str(p.relative_to(ROOT)))
def test_small_modules_and_functions(path):
    text = path.read_text()
    assert len(text.splitlines()) <= MAX_MODULE
    long = [f"{node.name}: {node.end_lineno - node.lineno + 1} lines"
            for node in ast.walk(ast.parse(text))
            if isinstance(node, ast.FunctionDef | ast.AsyncFunctionDef)
            and node.end_lineno - node.lineno + 1 > MAX_FUNCTION]
    assert not long


@pytest.mark.parametrize("path", FILES, ids=lambda p: str(p.relative_to(ROOT)))
def test_no_type_ignore(path):
    assert "type: ignore" not in path.read_text()


@pytest.mark.parametrize("path", FILES, ids=lambda p: str(p.relative_to(ROOT)))
def test_constants_defined_before_their_use(path):
    tree = ast.parse(path.read_text())
    defined: dict[str, int] = {}
    for node in tree.body:
        targets = node.targets if isinstance(node, ast.Assign) else \
            [node.target] if isinstance(node, ast.AnnAssign) else []
        for t in targets:
            if isinstance(t, ast.Name) and t.id.lstrip("_").isupper():
                defined.setdefault(t.id, node.lineno)
    late = sorted({f"{n.id} (line {defined[n.id]}) used at line {n.lineno}"
                   for node in tree.body
                   if isinstance(node, ast.FunctionDef | ast.AsyncFunctionDef | ast.ClassDef)
                   for n in ast.walk(node)
                   if isinstance(n, ast.Name) and defined.get(n.id, 0) > node.lineno})
    assert not late
