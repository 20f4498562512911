"""A misbehaving controller for the client's tests: answers each request frame with whatever a
script returns, and records what the client sent and whether it closed; on real TCP on port 0
(`start`), or in memory (`opener`, protocol/memory.py) where a socket adds nothing."""

from __future__ import annotations

import asyncio
from collections.abc import Callable

from protocol.codec import FRAME_LEN, frame
from protocol.memory import Opener, memory_link

Reply = str | bytes  # a payload to frame, or raw bytes sent as they are
Script = Callable[[int, str, list[str]], list[Reply]]


def well_behaved(seq: int, verb: str, args: list[str]) -> list[Reply]:
    """What a correct controller answers to the requests these tests do not script."""
    if verb == "HELO":
        return [f"{seq} ACK HELO 1"]
    if verb == "STAT":
        return [f"{seq} STAT IDLE AUTO NONE 0 0 0"]
    if verb == "LOAD":
        return []  # the ACK comes after the last packet
    if verb in ("j", "p") and args[0] == "2":
        return [f"{seq} ACK LOAD"]
    if verb in ("j", "p", "GO"):
        return []
    return [f"{seq} ACK {verb}"]


def answering(verb: str, replies: Callable[[int], list[Reply]]) -> Script:
    """A script that answers `verb` with `replies(seq)` and every other request well."""
    def script(seq: int, v: str, args: list[str]) -> list[Reply]:
        return replies(seq) if v == verb else well_behaved(seq, v, args)
    return script


def packets(seq: int, flag: int, idx: int) -> list[str]:
    return [f"{seq} j {flag} {idx} 1.0 2.0 3.0 4.0 5.0 6.0",
            f"{seq} p {flag} {idx} 800.0 0.0 900.0 0.0 90.0 0.0"]


class FakeController:
    def __init__(self, script: Script):
        self.script = script
        self.received: list[str] = []
        self.connections = 0
        self.client_closed = asyncio.Event()
        self._server: asyncio.base_events.Server | None = None

    async def start(self) -> tuple[str, int]:
        self._server = await asyncio.start_server(self._serve, "127.0.0.1", 0)
        return self._server.sockets[0].getsockname()[:2]

    @property
    def opener(self) -> Opener:
        """Links to this controller in memory, for `ControllerClient(connect=...)`."""
        return memory_link(self._serve)

    async def stop(self) -> None:
        if self._server is not None:
            self._server.close()

    async def _serve(self, reader: asyncio.StreamReader, writer: asyncio.StreamWriter) -> None:
        self.connections += 1
        try:
            while True:
                data = await reader.readexactly(FRAME_LEN)
                payload = data.decode().split("#")[0]
                self.received.append(payload)
                seq, verb, *args = payload.split(" ")
                for reply in self.script(int(seq), verb, args):
                    writer.write(reply if isinstance(reply, bytes) else frame(reply))
                await writer.drain()
        except (asyncio.IncompleteReadError, ConnectionError):
            self.client_closed.set()
        finally:
            writer.close()

    def sent_verbs(self) -> list[str]:
        return [p.split(" ")[1] for p in self.received]
