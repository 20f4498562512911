"""Issue 22's target particular to the core and the controller protocol: module constants defined
before the code that uses them. Sizes, import cycles, `type: ignore` and mypy for every package:
tests/test_house.py."""

import ast
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
AREAS = [ROOT / "screwcal", ROOT / "protocol"]
FILES = sorted(f for a in AREAS for f in ([a] if a.is_file() else a.rglob("*.py")))


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
