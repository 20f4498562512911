"""Issue 22's targets particular to service/: the runner a sequencer over acquisition and a pure
analysis, the phase names in one module. Sizes, import cycles, `type: ignore` and mypy for every
package: tests/test_house.py."""

import ast
import re
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2] / "service"
FILES = sorted(ROOT.rglob("*.py"))


def _module(path: Path) -> str:
    parts = path.relative_to(ROOT.parent).with_suffix("").parts
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


def _service_imports(path: Path) -> set[str]:
    """The service modules `path` imports, at any depth (function-level imports included)."""
    out = set()
    for node in ast.walk(ast.parse(path.read_text())):
        if isinstance(node, ast.ImportFrom) and node.module and node.module.startswith("service"):
            out.add(node.module)
            out |= {f"{node.module}.{a.name}" for a in node.names}
        elif isinstance(node, ast.Import):
            out |= {a.name for a in node.names if a.name.startswith("service")}
    return out & {_module(f) for f in FILES}


def test_the_analysis_does_no_io():
    """Correction planning, performance, home check and warnings are computed from what they are
    given: no store, no link, no event, no runner."""
    imports = _service_imports(ROOT / "analysis.py")
    assert not imports & {"service.store", "service.database", "service.acquisition",
                          "service.events", "service.runner", "service.manager"}
    text = (ROOT / "analysis.py").read_text()
    assert "import protocol" not in text and "from protocol" not in text


def test_the_runner_leaves_links_and_readings_to_the_acquisition():
    text = (ROOT / "runner.py").read_text()
    for name in ("ControllerClient", "ArmReader", "refusal", "MAX_LIST", "read_holes"):
        assert name not in text


@pytest.mark.parametrize("path", [f for f in FILES if f.name != "phases.py"],
                         ids=lambda p: str(p.relative_to(ROOT)))
def test_phase_names_live_in_phases_py(path):
    """The performance lists, the home checks and the second round are named in
    service/phases.py only: another module spelling two of them out keeps a second copy."""
    names = re.findall(r"[\"'](perf_before|perf_after|perf_after_2|home_before|home_after|cal_2|"
                       r"estimation_2|correction_2)[\"']", path.read_text())
    assert len(names) <= 1, names
