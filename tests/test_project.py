"""Project-level checks: lint, the one direction of dependence between packages, and the layers
inside `screwcal` (each subpackage's `__init__` says what it may import)."""

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
# The face: the console script's commands (and `python -m screwcal`, its other door). It loads
# as the core does; a command that needs the service or the emulators imports them itself, when
# it runs or builds its options (never when the face loads).
FACE = (ROOT / "screwcal" / "commands", ROOT / "screwcal" / "__main__.py")
FACE_DISPATCHES_TO = {"service", "simulators"}


# Inside screwcal: what each layer may import of ours (its __init__ docstring says the same).
# The root modules (errors, tables, _lazy) are the ground floor; commands/ is the top and the
# only module of screwcal that may import service or simulators. rapid/ (the RAPID parser) is a
# floor of its own: it imports nothing of ours, so that the simulators' interpreter can use it;
# so is runtime/ (the process's settings, applied by the doors before anything else loads).
_BASE = {"screwcal", "screwcal.errors", "screwcal.tables", "screwcal._lazy", "screwcal.instrument"}
LAYERS = {
    "rapid": {"screwcal.rapid"},
    "programs": {"screwcal.programs"},
    "runtime": {"screwcal.runtime"},
    "kinematics": {*_BASE - {"screwcal.tables"}, "screwcal.kinematics"},
    "calibration": {*_BASE, "screwcal.kinematics", "screwcal.rapid", "screwcal.programs",
                    "screwcal.calibration"},
    "performance": {*_BASE, "screwcal.kinematics", "screwcal.performance"},
    "studies": {*_BASE, "screwcal.kinematics", "screwcal.rapid", "screwcal.calibration",
                "screwcal.performance", "screwcal.runtime", "screwcal.studies"},
}


def _import_names(node: ast.AST) -> set[str]:
    if isinstance(node, ast.Import):
        return {a.name for a in node.names}
    if isinstance(node, ast.ImportFrom) and node.module and node.level == 0:
        return {node.module}
    return set()


def _imports(path: Path, depth: int = 1) -> set[str]:
    """The modules `path` imports, anywhere in it, cut to their first `depth` dotted parts."""
    tree = ast.parse(path.read_text(encoding="utf-8"))
    names = set().union(*(_import_names(node) for node in ast.walk(tree)))
    return {".".join(n.split(".")[:depth]) for n in names}


def _imports_on_load(path: Path) -> set[str]:
    """The top-level packages `path` imports when it is loaded: outside functions, and not
    under `if TYPE_CHECKING:`."""
    names: set[str] = set()

    def visit(node: ast.AST) -> None:
        if isinstance(node, ast.FunctionDef | ast.AsyncFunctionDef | ast.Lambda):
            return
        if isinstance(node, ast.If) and "TYPE_CHECKING" in ast.unparse(node.test):
            return
        names.update(_import_names(node))
        for child in ast.iter_child_nodes(node):
            visit(child)

    visit(ast.parse(path.read_text(encoding="utf-8")))
    return {n.split(".")[0] for n in names}


def _in_face(path: Path) -> bool:
    return any(path == door or path.is_relative_to(door) for door in FACE)


@pytest.mark.parametrize("package", sorted(ALLOWED))
def test_packages_depend_in_one_direction(package):
    """Every module of every package, the face's too: what it loads keeps to its package's
    rule; the face's commands reach the service and the emulators only inside themselves."""
    ours = set(ALLOWED)
    for path in (ROOT / package).rglob("*.py"):
        where = path.relative_to(ROOT)
        crossing = (_imports_on_load(path) & ours) - ALLOWED[package]
        assert not crossing, f"{where} imports {sorted(crossing)} when it is loaded"
        inside = ALLOWED[package] | (FACE_DISPATCHES_TO if _in_face(path) else set())
        crossing = (_imports(path) & ours) - inside
        assert not crossing, f"{where} imports {sorted(crossing)}"


@pytest.mark.parametrize("package", sorted(ALLOWED))
def test_no_floor_imports_the_face(package):
    """What the floors share with the face (the options' vocabulary, the payload's options)
    lives on a floor both import (screwcal/arguments.py), never in the face."""
    for path in (ROOT / package).rglob("*.py"):
        if not _in_face(path):
            assert "screwcal.commands" not in _imports(path, 2), path.relative_to(ROOT)


@pytest.mark.parametrize("layer", sorted(LAYERS))
def test_screwcal_layers_import_only_below(layer):
    for path in (ROOT / "screwcal" / layer).rglob("*.py"):
        ours = {n for n in _imports(path, 2) if n.split(".")[0] in ALLOWED}
        crossing = ours - LAYERS[layer]
        assert not crossing, f"{path.relative_to(ROOT)} imports {sorted(crossing)}"


def test_screwcal_ground_floor_imports_only_kinematics_basics():
    for name in ("errors.py", "tables.py", "_lazy.py", "__init__.py", "instrument.py"):
        ours = {n for n in _imports(ROOT / "screwcal" / name, 3) if n.startswith("screwcal")}
        assert ours <= {"screwcal.errors", "screwcal.kinematics.se3", "screwcal._lazy"}, name


def test_subpackage_public_names_resolve():
    """Every name a layer's __init__ exports is importable from the layer."""
    import importlib

    for layer in LAYERS:
        module = importlib.import_module(f"screwcal.{layer}")
        for name in module.__all__:
            assert getattr(module, name) is not None, f"screwcal.{layer}.{name}"


def test_subpackage_public_names_are_what_users_call():
    """A layer exports its functions and types, each documented; tuning constants and helpers
    stay in their modules (few enough to read: at most 40 names a layer)."""
    import importlib
    import inspect

    for layer in LAYERS:
        module = importlib.import_module(f"screwcal.{layer}")
        assert len(module.__all__) <= 40, f"screwcal.{layer}: {len(module.__all__)} names"
        for name in module.__all__:
            value = getattr(module, name)
            assert not name.startswith("_"), f"screwcal.{layer}.{name}"
            if inspect.isfunction(value) or inspect.isclass(value):
                assert (value.__doc__ or "").strip(), f"screwcal.{layer}.{name} has no docstring"


def test_study_names_for_help_match_the_studies():
    from screwcal.commands.study import STUDY_NAMES
    from screwcal.studies.study import STUDIES

    assert STUDY_NAMES == tuple(STUDIES)


def test_ruff_is_clean():
    ruff = shutil.which("ruff") or str(Path(sys.executable).with_name("ruff"))
    result = subprocess.run([ruff, "check", str(ROOT)], capture_output=True, text=True)
    assert result.returncode == 0, result.stdout + result.stderr


def test_the_package_stands_on_its_own():
    """Users get the repository alone: nothing in the package, its README or docs points to the
    development workspace's shared folder."""
    places = [ROOT / "README.md", *(ROOT / "docs").rglob("*.md")]
    for package in ALLOWED:
        places += list((ROOT / package).rglob("*.py"))
    offenders = [str(p.relative_to(ROOT)) for p in places
                 if "../shared" in p.read_text(encoding="utf-8")]
    assert not offenders, offenders


_IMPORT_COMPUTES_NOTHING = """
import importlib, pkgutil
import numpy as np
import screwcal.calibration.posesets as posesets
import screwcal.kinematics.robots as robots

def refuse(*args, **kwargs):
    raise AssertionError("computed at import")

posesets.random_set = posesets.cube_set = refuse
robots.irb1600 = robots.irb120 = refuse
np.random.default_rng = refuse
import screwcal.studies as studies
for info in pkgutil.iter_modules(studies.__path__):
    module = importlib.import_module("screwcal.studies." + info.name)
    arrays = [n for n, v in vars(module).items() if isinstance(v, np.ndarray)]
    assert not arrays, f"screwcal.studies.{info.name} builds {arrays} at import"
"""


def test_studies_compute_nothing_at_import():
    """Importing a study module draws no configurations and builds no robot (study.py drew its
    200 held-out configurations at import, in every worker and every `screwcal --help`): the
    held-out sets are drawn on first use."""
    result = subprocess.run([sys.executable, "-c", _IMPORT_COMPUTES_NOTHING],
                            capture_output=True, text=True, cwd=ROOT)
    assert result.returncode == 0, result.stderr[-2000:]
