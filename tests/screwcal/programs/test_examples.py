"""docs/examples (the worked examples of docs/formats.md) are what docs/examples/make.py
writes: the committed files are not stale."""

import runpy
import shutil
from pathlib import Path

ROOT = Path(__file__).resolve().parents[3]


def test_the_worked_examples_are_what_make_writes(tmp_path):
    copy = tmp_path / "examples"
    shutil.copytree(ROOT / "docs" / "examples", copy)
    runpy.run_path(str(copy / "make.py"), run_name="__main__")
    for committed in (ROOT / "docs" / "examples").rglob("*"):
        if committed.is_file() and committed.suffix != ".py":
            written = copy / committed.relative_to(ROOT / "docs" / "examples")
            assert written.read_text() == committed.read_text(), committed
