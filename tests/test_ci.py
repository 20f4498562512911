"""CI runs the README's test command, as written there, and fails when it runs no test."""

from __future__ import annotations

import re
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]


def _readme_test_command() -> str:
    text = (ROOT / "README.md").read_text(encoding="utf-8")
    block = re.search(r"\*\*Run the tests:\*\*\n.*?```sh\n(.+?)\n```", text, re.S)
    assert block, "README.md: no 'Run the tests:' shell block"
    return block.group(1).strip()


def test_ci_runs_the_readme_test_command_on_every_core():
    command = _readme_test_command()
    ci = [line.strip() for line in (ROOT / ".ci" / "run").read_text().splitlines()
          if "pytest" in line and not line.lstrip().startswith("#")]
    assert ci == [command]
    assert re.search(r"(^| )-n auto( |$)", command), command  # the suite is CPU-bound


@pytest.mark.slow
def test_a_parallel_run_that_collects_no_test_exits_5(tmp_path):
    """`set -e` in .ci/run fails on pytest's 5 for 'no tests ran': the workers keep it."""
    (tmp_path / "pytest.ini").write_text("[pytest]\n")
    done = subprocess.run([sys.executable, "-m", "pytest", "-n", "1", "-p", "no:cacheprovider",
                           str(tmp_path)], cwd=tmp_path, capture_output=True, text=True,
                          timeout=300)
    assert done.returncode == 5, done.stdout + done.stderr
    assert "set -euo pipefail" in (ROOT / ".ci" / "run").read_text()
