"""A virtual ABB IRC5: the RAPID program users load (`protocol/rapid/ScrewcalServer.mod`, or a
cell's adapted copy) executed by the RAPID interpreter (`simulators/rapid`) against the emulated
world. There is no second implementation of the protocol: what the client, peer, hostile and
fault tests talk to is the module itself.

The program's task runs in its own thread with blocking OS sockets, as the controller's RAPID
task does; motion goes to the `World` (its arrivals are notified in the asyncio loop that
started the emulator). The cell's settings reach ScrewcalServer as the values of its data
(`overrides`): the bind address and port, the idle time, the poll interval. Any other program
(other people's server modules, a backup's task) keeps its own data: its bind address and port
are its own, unless `assignments` (`--set NAME=VALUE`) give them. The controller
keeps an event log (`log`, printed with `--verbose`) and a FlexPendant (`pendant`) whose
operator, by default, does what a ZERO prompt asks (enters the offsets, presses Done).
"""

from __future__ import annotations

import asyncio
import errno
import threading
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from protocol.rapid import MODULE_NAME, module_text
from simulators.faults import FaultPlan
from simulators.rapid.interpreter import Task, loaded_module
from simulators.rapid.motion import Motion
from simulators.rapid.operator import Event, EventLog, Pendant, Prompt
from simulators.rapid.program import RapidText, module_files
from simulators.rapid.sockets import Network
from simulators.world import World


@dataclass
class EmulatorSettings:
    speed_deg_s: float = 60.0
    time_scale: float = 1.0
    faults: FaultPlan = field(default_factory=FaultPlan)
    idle_timeout_s: float = 60.0  # the module's IDLE_S: the owner's silence while it waits
    send_timeout_s: float = 10.0  # the socket stack gives up on a peer that takes nothing
    # The module's POLL_S: how long it waits for a request's first byte before it looks for a
    # newcomer and at its idle time (a request is read the moment it arrives).
    poll_s: float = 0.1
    # A port whose connection the controller closed first can be bound again at once (the
    # close-and-rebind pattern of public server modules accepts the next client so); > 0: a
    # stack that holds such a port for this long (SocketBind is ERR_SOCK_ADDR_INUSE meanwhile).
    time_wait_s: float = 0.0
    # The task's modules: a cell's adapted copy of ScrewcalServer.mod, or any program (module
    # files, or folders such as a backup's TASK folder: `program.module_files`).
    program: Path | Sequence[Path] | None = None
    # `--set NAME=VALUE`: data of the program given these values (RAPID text) at load.
    assignments: dict[str, str] = field(default_factory=dict)
    operator: bool = True  # the pendant's operator answers ZERO prompts (enters the offsets)
    lan_ip: str | None = None  # GetSysInfo(\LanIp); None: the address it listens on


SERVER_MODULE = "screwcalserver"  # the module's name (lower case) in the shipped file


class ProgramStoppedError(RuntimeError):
    """The RAPID program stopped where a running controller was expected."""


class IRC5Emulator:
    def __init__(self, world: World, settings: EmulatorSettings | None = None,
                 printer: Callable[[Event], None] | None = None):
        self.world = world
        self.settings = settings or EmulatorSettings()
        self.log = EventLog(printer)
        self.pendant = Pendant()
        self.pendant.auto = self._operator
        self.network = Network(self.settings)
        self.task: Task | None = None
        self.address: tuple[str, int] | None = None
        self._own_program = True
        self._thread: threading.Thread | None = None

    # -- the program --------------------------------------------------------------------------
    def _program(self) -> list[tuple[str, str]]:
        """The task's modules (text, path)."""
        p = self.settings.program
        if p is None:
            return [(module_text(), MODULE_NAME)]
        paths = [Path(p)] if isinstance(p, str | Path) else [Path(x) for x in p]
        return [(f.read_text(encoding="latin-1"), str(f)) for f in module_files(paths)]

    def _own(self, modules: list[tuple[str, str]]) -> bool:
        """Whether the task runs ScrewcalServer (the shipped module or a cell's copy): only
        then do the emulator's address and times set its data."""
        return any(loaded_module(t, p).name.lower() == SERVER_MODULE for t, p in modules)

    def _overrides(self, modules: list[tuple[str, str]], host: str,
                   port: int) -> dict[str, Any]:
        settings = self.settings
        out: dict[str, Any] = {}
        if self._own(modules):
            wanted = {"BIND_ADDRESS": host, "PORT": float(port),
                      "IDLE_S": lambda: float(settings.idle_timeout_s),
                      "POLL_S": lambda: float(settings.poll_s)}
            declared = {d.key for t, p in modules for d in loaded_module(t, p).data}
            out = {k: v for k, v in wanted.items() if k.lower() in declared}
        out.update({k.lower(): RapidText(v) for k, v in settings.assignments.items()})
        return out

    async def start(self, host: str = "127.0.0.1", port: int = 0) -> tuple[str, int]:
        """Load the program (once), run main; returns where it listens."""
        loop = asyncio.get_running_loop()
        if self.task is None:
            modules = self._program()
            (text, path), *more = modules
            self._own_program = self._own(modules)
            self.task = Task(text, path, log=self.log, pendant=self.pendant,
                             overrides=self._overrides(modules, host, port), modules=more)
        elif self._own_program:  # a restart: the same program and data, where it is told to
            for name, value in (("bind_address", host), ("port", float(port))):  # listen now
                if name in self.task.data and name not in self.settings.assignments:
                    self.task.data[name].value = value
        self.task.services.update(
            network=self.network, motion=Motion(self.world, loop, self.settings),
            sysinfo={"lanip": self.settings.lan_ip or host, "systemname": "screwcal-virtual-irc5",
                     "robottype": "IRB 1600", "serialno": "virtual-1",
                     "swversion": "screwcal virtual IRC5 (RobotWare 6 RAPID subset)"})
        self.network.listen_event.clear()
        self.network.host_port_in_use = False
        self._thread = threading.Thread(target=self.task.run, name="rapid-task", daemon=True)
        self._thread.start()
        while not self.network.listen_event.is_set():
            if not self._thread.is_alive():
                raise ProgramStoppedError(f"the RAPID program stopped before listening: "
                                          f"{self.task.stop_reason}")
            if self.network.host_port_in_use:  # another program holds it: not the module's wait
                await self.stop()
                where = f"{host}:{port}" if self._own_program else "the address the program binds"
                raise OSError(errno.EADDRINUSE, f"{where} is in use on this host")
            await asyncio.sleep(0.002)
        self.address = self.network.listening[-1]
        return self.address

    async def stop(self) -> None:
        """The controller shuts down: the program is stopped, PP to Main runs its UNDO
        handlers, every socket is closed."""
        if self.task is None or self._thread is None:
            return
        self.task.request_stop()
        await asyncio.to_thread(self._thread.join, 10.0)
        self.task.pp_to_main()
        self.network.shutdown()
        self._thread = None

    async def pp_to_main(self) -> tuple[str, int]:
        """The operator stops the program, moves PP to Main (its UNDO handlers run) and starts
        it again; what the program left open stays open (no controller restart)."""
        assert self.task is not None and self._thread is not None and self.address is not None
        self.task.request_stop()
        await asyncio.to_thread(self._thread.join, 10.0)
        self.task.pp_to_main()
        return await self.start(*self.address)

    @property
    def own_program(self) -> bool:
        """Whether the task runs ScrewcalServer (the emulator's --host/--port set its data)."""
        return self._own_program

    @property
    def running(self) -> bool:
        return self._thread is not None and self._thread.is_alive()

    # -- what tests read ------------------------------------------------------------------------
    @property
    def sessions(self) -> int:
        """Connections the program accepted as its client (not turned away busy)."""
        return self.network.accepted - self.refused

    @property
    def refused(self) -> int:
        return self.network.refusals

    @property
    def list_name(self) -> str:
        """The list the program runs or last ran (CAL, PERF, NONE)."""
        if self.task is None or "cur_list" not in self.task.data:
            return ""
        return self.task.data["cur_list"].value

    def data(self, name: str) -> Any:
        """A datum of the running module, by name."""
        assert self.task is not None
        return self.task.data[name.lower()].value

    # -- the operator at the FlexPendant --------------------------------------------------------
    def _operator(self, prompt: Prompt) -> int | None:
        """The emulated operator (`settings.operator`): does what a ZERO prompt asks."""
        if not self.settings.operator:
            return None
        return self.enter_offsets(prompt)

    def enter_offsets(self, prompt: Prompt) -> int | None:
        """What a person does at ZERO's prompt: enters the offsets shown on the FlexPendant
        (the world's joint zero moves there) and returns the Done key to press."""
        at = _offsets_on_screen(prompt.screen)
        if at is None or "Done" not in prompt.keys:
            return None
        self.world.set_zero(at)
        return prompt.keys.index("Done") + 1


def _offsets_on_screen(lines: tuple[str, ...]) -> np.ndarray | None:
    """The six joint values a ZERO prompt shows (the line after 'ZERO ...')."""
    for line in lines:
        if line.startswith("j1..j6 "):
            try:
                return np.array([float(v) for v in line.split()[1:7]])
            except ValueError:
                return None
    return None
