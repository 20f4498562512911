"""The socket instructions (RobotWare option "Socket Messaging", part of "PC Interface") on
real OS sockets, with the controller's error numbers:

- SocketAccept/SocketReceive wait at most \\Time seconds (default 60; WAIT_MAX: forever; a
  fraction is accepted), then ERR_SOCK_TIMEOUT;
- a connection the peer closed or reset is ERR_SOCK_CLOSED (SocketReceive, SocketSend,
  SocketPeek);
- SocketBind on an address still in use (a socket bound or listening there) is
  ERR_SOCK_ADDR_INUSE; a port whose connection the controller closed first (TIME_WAIT) can be
  bound again at once, as the close-and-rebind pattern of public server modules needs (the OS
  sockets are opened with SO_REUSEADDR); `Network.time_wait_s` > 0 models a stack that holds
  such a port that long;
- a SocketSend the peer does not take within `Network.send_timeout_s` drops the connection
  (the stack gives up): ERR_SOCK_CLOSED.

Closing a socket with unread data resets the connection (the OS does it, as the controller's
stack does). `Network.faults` injects the emulator's faults into the frames the program sends.
"""

from __future__ import annotations

import contextlib
import errno
import fcntl
import select
import socket
import struct
import termios
import threading
import time
from typing import Any

from simulators.faults import FaultPlan
from simulators.rapid.builtins import builtin
from simulators.rapid.control import Stopped
from simulators.rapid.errors import RapidError
from simulators.rapid.library import wait
from simulators.rapid.values import MAX_STRING, RawBytes, SocketDev, is_integer, string

DEFAULT_TIME_S = 60.0
WAIT_MAX = 8388608.0
_SLICE_S = 0.05  # how often a blocked instruction looks for a stop request
SEND_BUFFER = 16384
RECEIVE_BUFFER = 65536  # a whole 200-pose LOAD (16 kB) arrives at once


class Network:
    """The controller's socket stack: what is in TIME_WAIT, the faults to inject, every socket
    it holds (closed when the controller shuts down)."""

    def __init__(self, settings: Any = None):
        self.settings = settings  # faults, send_timeout_s, time_wait_s (the emulator's)
        self.time_wait: dict[int, float] = {}  # local port -> until (monotonic)
        self.open: set[socket.socket] = set()
        self.listening: list[tuple[str, int]] = []
        self.accepted = 0
        self.refusals = 0  # "0 ERR 16 busy" frames sent
        self.host_port_in_use = False
        self._held: bytes = b""  # merge_frames: a j frame held for its p frame
        self._lock = threading.Lock()
        self.listen_event = threading.Event()

    @property
    def faults(self) -> FaultPlan:
        return getattr(self.settings, "faults", None) or FaultPlan()

    @property
    def send_timeout_s(self) -> float:
        return getattr(self.settings, "send_timeout_s", 10.0)

    @property
    def time_wait_s(self) -> float:
        return getattr(self.settings, "time_wait_s", 0.0)

    def shutdown(self) -> None:
        with self._lock:
            socks, self.open = list(self.open), set()
        for s in socks:
            with contextlib.suppress(OSError):
                s.close()
        self.listening.clear()
        self.time_wait.clear()  # a controller restart: a new network stack

    def track(self, s: socket.socket) -> None:
        with self._lock:
            self.open.add(s)

    def untrack(self, s: socket.socket) -> None:
        with self._lock:
            self.open.discard(s)


def _net(task: Any) -> Network:
    return task.services["network"]


def _closed(detail: str) -> RapidError:
    return RapidError("ERR_SOCK_CLOSED", detail)


def _wait_readable(task: Any, s: socket.socket, seconds: float, what: str) -> None:

    end = None if seconds >= WAIT_MAX else time.monotonic() + seconds
    while True:
        if task.stopping():
            raise Stopped("stopped by the controller")
        left = _SLICE_S if end is None else min(_SLICE_S, end - time.monotonic())
        if left <= 0:
            raise RapidError("ERR_SOCK_TIMEOUT", f"{what}: nothing within {seconds:g} s")
        ready, _, _ = select.select([s], [], [], left)
        if ready:
            return


def _time(opt: dict) -> float:
    t = opt.get("time", DEFAULT_TIME_S)
    if t <= 0:
        raise RapidError("ERR_ARGVALERR", f"\\Time must be positive, got {t:g}")
    return t


@builtin("SocketCreate", "proc", opts=("UDP",))
def _create(task: Any, pos: list, opt: dict) -> None:
    dev: SocketDev = pos[0]
    if dev.state not in ("none", "closed"):
        raise RapidError("ERR_SOCK_UNSPEC", "socket already created")
    s = socket.socket(socket.AF_INET, socket.SOCK_DGRAM if opt.get("udp") else socket.SOCK_STREAM)
    s.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
    # An embedded stack's small buffers (accepted connections inherit them): a peer that
    # floods or does not read meets back-pressure in kilobytes, not in the host's megabytes.
    s.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, RECEIVE_BUFFER)
    s.setsockopt(socket.SOL_SOCKET, socket.SO_SNDBUF, SEND_BUFFER)
    _net(task).track(s)
    dev.sock, dev.state, dev.peer_closed, dev.local = s, "created", False, None


@builtin("SocketBind", "proc")
def _bind(task: Any, pos: list, opt: dict) -> None:
    dev, address, port = pos
    net = _net(task)
    if dev.state != "created":
        raise RapidError("ERR_SOCK_IS_BOUND" if dev.state != "closed" else "ERR_SOCK_CLOSED",
                         "SocketBind on a socket that is not newly created")
    until = net.time_wait.get(int(port))
    if until is not None and time.monotonic() < until:
        raise RapidError("ERR_SOCK_ADDR_INUSE",
                         f"port {int(port)}: a connection closed here is in TIME_WAIT")
    try:
        dev.sock.bind((address, int(port)))
    except OSError as err:
        if err.errno == errno.EADDRINUSE:
            net.host_port_in_use = True  # another program of the host holds it
            raise RapidError("ERR_SOCK_ADDR_INUSE", f"{address}:{int(port)} in use") from None
        raise RapidError("ERR_SOCK_ADDR_INVALID", f"{address}:{int(port)}: {err}") from None
    dev.local = dev.sock.getsockname()[:2]
    dev.state = "bound"


@builtin("SocketListen", "proc")
def _listen(task: Any, pos: list, opt: dict) -> None:
    dev = pos[0]
    if dev.state != "bound":
        raise RapidError("ERR_SOCK_NOT_BOUND", "SocketListen on a socket not bound")
    dev.sock.listen(8)
    dev.state = "listening"
    net = _net(task)
    net.listening.append(dev.local)
    net.listen_event.set()


@builtin("SocketAccept", "proc", optrefs=("ClientAddress",), opts=("ClientAddress", "Time"))
def _accept(task: Any, pos: list, opt: dict) -> None:
    dev, client = pos
    if dev.state != "listening":
        raise _closed("SocketAccept on a socket that does not listen")
    if client.state not in ("none", "closed"):
        raise RapidError("ERR_SOCK_IS_CONN", "SocketAccept into a socket still in use")
    _wait_readable(task, dev.sock, _time(opt), "SocketAccept")
    try:
        conn, addr = dev.sock.accept()
    except OSError as err:
        raise _closed(f"accept: {err}") from None
    # Each SocketSend leaves at once (no Nagle delay: a pose's p frame would otherwise wait
    # for the peer's delayed ACK of its j frame, 40 ms on Linux).
    conn.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
    net = _net(task)
    net.track(conn)
    net.accepted += 1
    client.sock, client.state, client.peer_closed = conn, "connected", False
    client.local = conn.getsockname()[:2]
    if "clientaddress" in opt:
        opt["clientaddress"].value = string(addr[0])


def _connected(dev: SocketDev, what: str) -> socket.socket:
    if dev.state != "connected" or dev.sock is None:
        raise _closed(f"{what} on a socket that is not connected")
    return dev.sock


@builtin("SocketPeek", "func")
def _peek(task: Any, pos: list, opt: dict) -> float:
    """The bytes waiting to be read; a connection the peer closed with nothing left to read
    is ERR_SOCK_CLOSED."""
    s = _connected(pos[0], "SocketPeek")
    n = struct.unpack("i", fcntl.ioctl(s.fileno(), termios.FIONREAD, b"\0\0\0\0"))[0]
    if n == 0:
        ready, _, _ = select.select([s], [], [], 0)
        if ready:
            try:
                data = s.recv(1, socket.MSG_PEEK)
            except OSError as err:
                raise _closed(f"SocketPeek: {err}") from None
            if not data:
                pos[0].peer_closed = True
                raise _closed("the peer closed the connection")
            return float(len(data))
    return float(n)


@builtin("SocketReceive", "proc", optrefs=("Str", "RawData", "Data", "NoRecBytes"),
         opts=("Str", "RawData", "Data", "ReadNoOfBytes", "NoRecBytes", "Time"))
def _receive(task: Any, pos: list, opt: dict) -> None:
    """Into \\Str (at most 80 bytes), \\RawData (1024) or \\Data (a byte array's length):
    what has arrived, or exactly \\ReadNoOfBytes of it."""
    dev = pos[0]
    s = _connected(dev, "SocketReceive")
    into = [k for k in ("str", "rawdata", "data") if k in opt]
    if len(into) != 1:
        raise RapidError("ERR_ARGVALERR", "SocketReceive takes one of \\Str, \\RawData, "
                         "\\Data")
    room = {"str": MAX_STRING, "rawdata": RawBytes.MAX}.get(into[0]) or \
        len(opt["data"].value.items)
    want = int(opt.get("readnoofbytes", room))
    if not 1 <= want <= room:
        raise RapidError("ERR_ARGVALERR", f"\\{into[0]} receives 1..{room} bytes")
    seconds = _time(opt)
    end = time.monotonic() + seconds
    data = b""
    while True:
        _wait_readable(task, s, max(1e-3, end - time.monotonic()), "SocketReceive")
        try:
            chunk = s.recv(want - len(data))
        except OSError as err:
            raise _closed(f"SocketReceive: {err}") from None
        if not chunk:
            dev.peer_closed = True
            raise _closed("the peer closed the connection")
        data += chunk
        if "readnoofbytes" not in opt or len(data) >= want:
            break
    if into[0] == "str":
        opt["str"].value = data.decode("latin-1")
    elif into[0] == "rawdata":
        opt["rawdata"].value = RawBytes(data)
    else:
        items = opt["data"].value.items
        items[:len(data)] = [float(b) for b in data]
    if "norecbytes" in opt:
        opt["norecbytes"].value = float(len(data))


def _outgoing(opt: dict) -> bytes:
    """What SocketSend sends: \\Str, \\RawData or \\Data (bytes 0..255), the first
    \\NoOfBytes of it when given."""
    given = [k for k in ("str", "rawdata", "data") if k in opt]
    if len(given) != 1:
        raise RapidError("ERR_ARGVALERR", "SocketSend takes one of \\Str, \\RawData, \\Data")
    if given[0] == "str":
        data = opt["str"].encode("latin-1")
    elif given[0] == "rawdata":
        data = opt["rawdata"].data
    else:
        values = opt["data"].items
        if any(not (is_integer(v) and 0 <= v <= 255) for v in values):
            raise RapidError("ERR_ARGVALERR", "\\Data holds a value that is no byte (0..255)")
        data = bytes(int(v) for v in values)
    if "noofbytes" in opt:
        n = int(opt["noofbytes"])
        if not 1 <= n <= len(data):
            raise RapidError("ERR_ARGVALERR", f"\\NoOfBytes {n}: 1..{len(data)}")
        data = data[:n]
    return data


@builtin("SocketSend", "proc", opts=("Str", "RawData", "Data", "NoOfBytes"))
def _send(task: Any, pos: list, opt: dict) -> None:
    dev = pos[0]
    s = _connected(dev, "SocketSend")
    data = _outgoing(opt)
    net = _net(task)
    if data.startswith(b"0 ERR 16 "):
        net.refusals += 1
    for piece, pause in _faulted(net, data, task):
        if piece == b"__DROP__":
            _cut(dev, net)
            raise _closed("connection dropped (injected fault)")
        _send_all(task, dev, s, piece, net)
        if pause:
            time.sleep(0.001)


def _faulted(net: Network, data: bytes, task: Any) -> list[tuple[bytes, bool]]:
    """The emulator's faults, applied to an outgoing 80-byte frame."""
    f = net.faults
    parts = data.split(b" ", 3)
    idx = int(parts[3].split(b" ", 1)[0]) if len(parts) > 3 and parts[1] == b"j" \
        and parts[3][:1].isdigit() else None
    if idx is not None and parts[1] == b"j":
        if f.take("stall_at_pose", idx):
            wait(task, f.stall_s)
        if f.take("drop_at_pose", idx):
            return [(b"__DROP__", False)]
        if f.take("garble_at_pose", idx):
            data = data.replace(b"#", b" ")
    if f.merge_frames:
        is_j = len(parts) > 1 and parts[1] == b"j"
        if is_j:
            net._held = data
            return []
        data, net._held = net._held + data, b""
    if f.split_frames:
        return [(data[:33], True), (data[33:], False)]
    return [(data, False)]


def _send_all(task: Any, dev: SocketDev, s: socket.socket, data: bytes, net: Network) -> None:

    end = time.monotonic() + net.send_timeout_s
    view = memoryview(data)
    while view:
        if task.stopping():
            raise Stopped("stopped by the controller")
        left = end - time.monotonic()
        if left <= 0:
            _abort(dev, net)
            raise _closed(f"the peer took nothing for {net.send_timeout_s:g} s")
        _, writable, _ = select.select([], [s], [], min(left, _SLICE_S))
        if not writable:
            continue
        try:
            n = s.send(view, socket.MSG_NOSIGNAL)
        except OSError as err:
            raise _closed(f"SocketSend: {err}") from None
        view = view[n:]


def _cut(dev: SocketDev, net: Network) -> None:
    """The link goes (the injected drop): what was sent still arrives, then the close."""
    s = dev.sock
    if s is not None:
        with contextlib.suppress(OSError):
            s.setblocking(False)
            while s.recv(65536):
                pass
        with contextlib.suppress(OSError):
            s.shutdown(socket.SHUT_WR)
            s.close()
        net.untrack(s)
    dev.sock, dev.state = None, "closed"


def _abort(dev: SocketDev, net: Network) -> None:
    """Reset the connection (RST), as a stack that gives up does."""
    if dev.sock is not None:
        with contextlib.suppress(OSError):
            dev.sock.setsockopt(socket.SOL_SOCKET, socket.SO_LINGER, struct.pack("ii", 1, 0))
            dev.sock.close()
        net.untrack(dev.sock)
    dev.sock, dev.state = None, "closed"


@builtin("SocketClose", "proc")
def _close(task: Any, pos: list, opt: dict) -> None:
    """Close; a connection this side closes first leaves its port in TIME_WAIT."""
    dev = pos[0]
    net = _net(task)
    if dev.sock is None:
        dev.state = "closed"
        return
    if dev.state == "connected" and not dev.peer_closed:
        peer_gone = False
        with contextlib.suppress(OSError):
            ready, _, _ = select.select([dev.sock], [], [], 0)
            peer_gone = bool(ready) and dev.sock.recv(1, socket.MSG_PEEK) == b""
        if not peer_gone and dev.local is not None:
            net.time_wait[int(dev.local[1])] = time.monotonic() + net.time_wait_s
    if dev.state == "listening" and dev.local in net.listening:
        net.listening.remove(dev.local)
    with contextlib.suppress(OSError):
        dev.sock.close()
    net.untrack(dev.sock)
    dev.sock, dev.state = None, "closed"


@builtin("SocketGetStatus", "func")
def _status(task: Any, pos: list, opt: dict) -> float:
    return {"none": 0.0, "created": 1.0, "connected": 2.0, "bound": 3.0, "listening": 4.0,
            "closed": 5.0}[pos[0].state]
