"""Issue 38: every shell block of README.md and docs/*.md runs as written, from the repository's
root of a fresh clone.

A block fenced ```sh is a run of commands: it runs here with bash (-e, pipefail) in a copy of
the repository's `docs/` folder beside a link to the repository's `.venv`, so that the paths it
names resolve as they do at the root, and what it writes stays out of the checkout. The venv's
`bin` is on PATH, as after `. .venv/bin/activate`. Synopsis lines (`[--option]`, `a|b`, DIR) are
fenced ```text, data ```json, shown output plain ```. A shell block that cannot run here says
so, and why, on the line before its fence: `<!-- docs-test: not run: REASON -->`.
"""

from __future__ import annotations

import os
import re
import shutil
import socket
import subprocess
import sys
from dataclasses import dataclass
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
DOCUMENTS = [ROOT / "README.md", *sorted((ROOT / "docs").glob("*.md"))]
NOT_RUN = re.compile(r"<!-- docs-test: not run: (.+?) -->")
# [--opt], a|b, a placeholder to fill in
SYNOPSIS = re.compile(r"\[--|[\w+-]\|[\w+-]|\b(?:DIR|FILE|NAME|ID)\b")


@dataclass(frozen=True)
class Block:
    path: Path
    line: int  # of the opening fence
    language: str
    text: str
    not_run: str | None  # the reason given, when it is not run

    @property
    def name(self) -> str:
        return f"{self.path.relative_to(ROOT)}:{self.line}"


def blocks(path: Path) -> list[Block]:
    found, lines = [], path.read_text(encoding="utf-8").splitlines()
    k = 0
    while k < len(lines):
        fence = re.match(r"^```(\w*)\s*$", lines[k])
        if not fence:
            k += 1
            continue
        end = next(j for j in range(k + 1, len(lines)) if lines[j].startswith("```"))
        reason = NOT_RUN.search(lines[k - 1]) if k else None
        found.append(Block(path, k + 1, fence.group(1), "\n".join(lines[k + 1:end]) + "\n",
                           reason.group(1) if reason else None))
        k = end + 1
    return found


SHELL = [b for doc in DOCUMENTS for b in blocks(doc) if b.language == "sh"]


def test_the_documents_have_shell_blocks_and_each_not_run_says_why():
    assert len(SHELL) >= 6
    assert all(b.not_run is None or len(b.not_run) > 10 for b in SHELL)


@pytest.mark.parametrize("block", SHELL, ids=lambda b: b.name)
def test_a_shell_block_holds_commands_not_synopses(block):
    """Optional parts and alternatives are a synopsis: the shell would run `[--before` or pipe
    into `zero`."""
    for n, line in enumerate(block.text.splitlines(), block.line + 1):
        command = line.split(" #")[0]
        assert not SYNOPSIS.search(command), f"{block.path.name}:{n}: a synopsis in a sh block"


# What a block may not name, so that it runs beside anything else: a fixed folder outside its
# own (mktemp -d makes one) and a fixed port (a variable with a default the test sets free)
FIXED_PLACE = re.compile(r"(?<![\w.$])/tmp\b|--(?:arm-)?port \d|\b127\.0\.0\.1:\d|"
                         r"socket://[\w.]+:\d")
PORT_VARIABLES = ("CELL_PORT", "ARM_PORT", "SCREWCAL_PORT")  # README's service block


@pytest.mark.parametrize("block", [b for b in SHELL if b.not_run is None], ids=lambda b: b.name)
def test_a_shell_block_names_no_fixed_folder_or_port(block):
    """A block wrote to /tmp/screwcal-examples and listened on 4012, 4013 and 8080: a second
    run, or anything else on the host, got in its way."""
    for n, line in enumerate(block.text.splitlines(), block.line + 1):
        found = FIXED_PLACE.search(line.split(" #")[0])
        assert not found, f"{block.path.name}:{n}: {found.group(0)!r} is fixed"


def _free_ports(n: int) -> list[int]:
    sockets = [socket.socket() for _ in range(n)]
    try:
        for s in sockets:
            s.bind(("127.0.0.1", 0))
        return [s.getsockname()[1] for s in sockets]
    finally:
        for s in sockets:
            s.close()


@pytest.mark.slow
@pytest.mark.parametrize("block", [b for b in SHELL if b.not_run is None], ids=lambda b: b.name)
def test_a_shell_block_runs_as_written(block, tmp_path):
    shutil.copytree(ROOT / "docs", tmp_path / "docs")
    venv = Path(sys.prefix)
    (tmp_path / ".venv").symlink_to(venv, target_is_directory=True)
    env = {**os.environ, "PATH": f"{venv / 'bin'}{os.pathsep}{os.environ.get('PATH', '')}",
           **dict(zip(PORT_VARIABLES, map(str, _free_ports(len(PORT_VARIABLES))), strict=True)),
           "TMPDIR": str(tmp_path)}  # what mktemp makes is removed with the test's folder
    env.pop("SCREWCAL_TOKEN", None)
    env.pop("SCREWCAL_SERVICE", None)
    done = subprocess.run(["bash", "-e", "-o", "pipefail", "-c", block.text], cwd=tmp_path,
                          env=env, capture_output=True, text=True, timeout=900,
                          start_new_session=True)
    assert done.returncode == 0, f"{block.name}: exit {done.returncode}\n{done.stderr[-3000:]}"
    assert "Traceback" not in done.stderr, done.stderr
