"""The house's proportions (issue 22's targets), held for good: no module over 450 lines, no
function over 80 (unless its docstring argues why), no import cycle between our modules, at most
five `type: ignore` each with its reason, and the type checker clean (strict on the kinematics
the RAPID parser and the link)."""

import ast
import os
import re
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
PACKAGES = ("screwcal", "protocol", "service", "simulators")
MAX_MODULE_LINES = 450
MAX_FUNCTION_LINES = 80
ARGUED = "long because"  # a function's docstring that argues its length says so in these words
MAX_TYPE_IGNORES = 5


def _sources() -> list[Path]:
    return sorted(p for package in PACKAGES for p in (ROOT / package).rglob("*.py"))


def _module_name(path: Path) -> str:
    parts = path.relative_to(ROOT).with_suffix("").parts
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


def test_no_module_is_over_450_lines():
    long = {str(p.relative_to(ROOT)): n for p in _sources()
            if (n := len(p.read_text(encoding="utf-8").splitlines())) > MAX_MODULE_LINES}
    assert not long, f"modules over {MAX_MODULE_LINES} lines: {long}"


def test_no_function_is_over_80_lines_unless_argued():
    long = []
    for path in _sources():
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            if not isinstance(node, ast.FunctionDef | ast.AsyncFunctionDef):
                continue
            lines = node.end_lineno - node.lineno + 1
            argued = ARGUED in (ast.get_docstring(node) or "").lower()
            if lines > MAX_FUNCTION_LINES and not argued:
                long.append(f"{path.relative_to(ROOT)}:{node.lineno} {node.name} ({lines})")
    assert not long, f"functions over {MAX_FUNCTION_LINES} lines: {long}"


def _imports_of(path: Path, module: str) -> set[str]:
    """Every module `module` imports, at any depth (a function's own imports too: a cycle broken
    by importing late is still a cycle of concerns), except under `if TYPE_CHECKING:`."""
    package = module if path.name == "__init__.py" else module.rpartition(".")[0]
    tree = ast.parse(path.read_text(encoding="utf-8"))
    skipped = {id(n) for node in ast.walk(tree) if isinstance(node, ast.If)
               and "TYPE_CHECKING" in ast.unparse(node.test) for n in ast.walk(node)}
    found: set[str] = set()
    for node in ast.walk(tree):
        if id(node) in skipped:
            continue
        if isinstance(node, ast.Import):
            found.update(a.name for a in node.names)
        elif isinstance(node, ast.ImportFrom):
            base = node.module or ""
            if node.level:
                parts = package.split(".")
                base = ".".join([*parts[: len(parts) - node.level + 1], *([base] if base else [])])
            found.add(base)
            found.update(f"{base}.{a.name}" for a in node.names)  # a submodule, perhaps
    return found


def _cycles(graph: dict[str, set[str]]) -> list[list[str]]:
    """Strongly connected components of more than one module (Tarjan)."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on_stack: set[str] = set()
    out: list[list[str]] = []
    sys.setrecursionlimit(max(10000, sys.getrecursionlimit()))

    def strong(v: str) -> None:
        index[v] = low[v] = len(index)
        stack.append(v)
        on_stack.add(v)
        for w in graph[v]:
            if w not in index:
                strong(w)
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
                out.append(sorted(component))

    for v in graph:
        if v not in index:
            strong(v)
    return out


def test_no_import_cycle():
    modules = {_module_name(p): p for p in _sources()}
    graph: dict[str, set[str]] = {}
    for name, path in modules.items():
        imported = _imports_of(path, name) & set(modules)
        # a package's own __init__ runs before its modules: not an edge of a cycle by itself
        graph[name] = {m for m in imported if m != name and not name.startswith(m + ".")}
    assert not _cycles(graph)


def test_the_cycle_finder_finds_a_cycle():
    assert _cycles({"a": {"b"}, "b": {"c"}, "c": {"a"}, "d": {"a"}}) == [["a", "b", "c"]]


def test_type_ignores_are_few_and_explained():
    marks = []
    for path in _sources():
        for k, line in enumerate(path.read_text(encoding="utf-8").splitlines(), 1):
            if "type: ignore" in line:
                marks.append((f"{path.relative_to(ROOT)}:{k}", line))
    assert len(marks) <= MAX_TYPE_IGNORES, [where for where, _ in marks]
    bare = [where for where, line in marks
            if not re.search(r"type: ignore\[[a-z-, ]+\]\s*#\s*\S", line)]
    assert not bare, f"a type: ignore names its code and says why after it: {bare}"


def _mypy() -> list[str]:
    found = shutil.which("mypy") or str(Path(sys.executable).with_name("mypy"))
    if not Path(found).exists():
        pytest.fail("mypy is not installed: pip install -e '.[test]'")
    return [found, "--cache-dir", str(ROOT / ".mypy_cache"), "--no-error-summary"]


@pytest.mark.slow
@pytest.mark.xdist_group("mypy cache")  # the two runs share .mypy_cache: one after the other
@pytest.mark.parametrize("strict,targets", [
    (True, ["screwcal/kinematics", "screwcal/rapid", "protocol"]),
    (False, list(PACKAGES)),
], ids=["strict-ground-floors", "all-packages"])
def test_mypy_is_clean(strict, targets):
    command = [*_mypy(), *(["--strict"] if strict else []), *targets]
    result = subprocess.run(command, cwd=ROOT, capture_output=True, text=True,
                            env={**os.environ, "MYPY_FORCE_COLOR": "0"})
    assert result.returncode == 0, result.stdout[-6000:] + result.stderr[-2000:]
