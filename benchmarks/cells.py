"""The emulated cells of benchmarks/jobs.py, in a process of their own (as a plant's controllers
and arms are machines of their own, not threads of the service).

    .venv/bin/python benchmarks/cells.py

A cell is one true robot (the nominal IRB 1600 with the thesis's Table 11 errors), an IRC5
emulator running the shipped RAPID module (protocol/rapid/ScrewcalServer.mod, in the RAPID
interpreter: a thread of its own) at time scale 0, and a measuring-arm emulator following it.
Commands on stdin, one per line, each answered by one JSON line on stdout:

    start N   N new cells (the previous ones stopped): [[host, port, arm_url], ...]
    cpu       this process's CPU seconds so far (user and system, every thread)
    stop      the cells stopped: "stopped"

At the end of stdin the cells are stopped and the process exits 0.
"""

from __future__ import annotations

import asyncio
import json
import sys
import time
from typing import Any

from simulators.arm import ArmEmulator
from simulators.irc5 import EmulatorSettings, IRC5Emulator
from simulators.truth import make_world

Cell = tuple[str, int, str]  # the controller's host and port, the arm's URL


class Cells:
    """N cells in this process's event loop."""

    def __init__(self) -> None:
        self._parts: list[Any] = []

    async def start(self, n: int) -> list[Cell]:
        await self.stop()
        cells = []
        for _ in range(n):
            world = make_world(None, None)
            emu = IRC5Emulator(world, EmulatorSettings(time_scale=0.0))
            host, port = await emu.start("127.0.0.1", 0)
            arm = ArmEmulator(world, seed=1)
            ahost, aport = await arm.start("127.0.0.1", 0)
            self._parts += [emu, arm]
            cells.append((host, port, f"socket://{ahost}:{aport}"))
        return cells

    async def stop(self) -> None:
        parts, self._parts = self._parts, []
        for part in parts:
            await part.stop()


async def serve() -> None:
    cells = Cells()
    while line := await asyncio.to_thread(sys.stdin.readline):
        command, *args = line.split()
        answer: Any
        if command == "start" and len(args) == 1 and args[0].isdigit():
            answer = await cells.start(int(args[0]))
        elif command == "cpu" and not args:
            answer = time.process_time()
        elif command == "stop" and not args:
            await cells.stop()
            answer = "stopped"
        else:
            answer = {"error": f"unknown command {line.strip()!r}: start N, cpu or stop"}
        print(json.dumps(answer), flush=True)
    await cells.stop()


if __name__ == "__main__":
    asyncio.run(serve())
