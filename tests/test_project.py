"""Project-level checks: lint, and the one direction of dependence between packages."""

import ast
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
# Who may import whom (ARCHITECTURE.md); the CLI face is the only place allowed to cross.
ALLOWED = {
    "screwcal": {"screwcal"},
    "protocol": {"protocol"},
    "simulators": {"simulators", "screwcal", "protocol"},
    "service": {"service", "screwcal", "protocol"},
}


def _imports(path: Path) -> set[str]:
    tree = ast.parse(path.read_text(encoding="utf-8"))
    out = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            out |= {a.name.split(".")[0] for a in node.names}
        elif isinstance(node, ast.ImportFrom) and node.module and node.level == 0:
            out.add(node.module.split(".")[0])
    return out


@pytest.mark.parametrize("package", sorted(ALLOWED))
def test_packages_depend_in_one_direction(package):
    ours = set(ALLOWED)
    for path in (ROOT / package).rglob("*.py"):
        if path.name == "cli.py" and package == "screwcal":
            continue  # the console-script face dispatches to every package
        crossing = (_imports(path) & ours) - ALLOWED[package]
        assert not crossing, f"{path.relative_to(ROOT)} imports {sorted(crossing)}"


def test_ruff_is_clean():
    ruff = shutil.which("ruff") or str(Path(sys.executable).with_name("ruff"))
    result = subprocess.run([ruff, "check", str(ROOT)], capture_output=True, text=True)
    assert result.returncode == 0, result.stdout + result.stderr
