"""The arm's port is closed for good even when the arm hung up first (pyserial's socket:// close
skips closing a socket whose shutdown fails: a descriptor leaked per aborted job)."""

import socket
import struct
import threading
import time

from protocol.arm import ArmReader


def _server_that_resets(opened: threading.Event) -> tuple[socket.socket, threading.Thread]:
    """A server that resets its first client once the client says its port is `opened` (a
    reset during the client's own connect is the open's error, not the close's case)."""
    server = socket.socket()
    server.bind(("127.0.0.1", 0))
    server.listen(1)

    def reset_the_first_client() -> None:
        conn, _ = server.accept()
        opened.wait(5)
        conn.setsockopt(socket.SOL_SOCKET, socket.SO_LINGER, struct.pack("ii", 1, 0))
        conn.close()  # a reset, not a FIN: the client's socket is no longer connected

    thread = threading.Thread(target=reset_the_first_client)
    thread.start()
    return server, thread


def test_close_after_the_arm_reset_the_connection_closes_the_socket():
    opened = threading.Event()
    server, thread = _server_that_resets(opened)
    try:
        reader = ArmReader(f"socket://127.0.0.1:{server.getsockname()[1]}")
        opened.set()
        thread.join(5)
        sock = reader.port._socket
        time.sleep(0.05)  # the reset arrives
        try:
            sock.shutdown(socket.SHUT_RDWR)  # what pyserial's close() tries first
            reset_seen = False
        except OSError:
            reset_seen = True
        reader.close()
        assert reset_seen, "the connection was not reset: the test shows nothing"
        assert sock.fileno() == -1, "the socket was left open"
    finally:
        server.close()


def test_an_open_that_fails_after_connecting_closes_the_socket(monkeypatch):
    """pyserial's socket:// open connects, then clears the input: a reset arriving then fails
    the open, and the port object's own close on collection skips closing a socket whose
    shutdown fails (ENOTCONN), so the socket was left to the garbage collector (a
    ResourceWarning in a later test of the service: a job aborted while its arm port opened).
    Here the server resets the connection before the clearing reads it (a delay before the
    real clearing): the open is refused and nothing is left unclosed."""
    import gc
    import warnings

    import pytest
    from serial.urlhandler import protocol_socket

    from protocol.errors import ArmLineError

    clear = protocol_socket.Serial.reset_input_buffer

    def clear_after_the_reset(self):
        time.sleep(0.2)
        return clear(self)

    monkeypatch.setattr(protocol_socket.Serial, "reset_input_buffer", clear_after_the_reset)
    opened = threading.Event()
    opened.set()  # reset at once
    server, thread = _server_that_resets(opened)
    try:
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            with pytest.raises(ArmLineError, match="reset by peer"):
                ArmReader(f"socket://127.0.0.1:{server.getsockname()[1]}")
            gc.collect()
        thread.join(5)
        assert not [w for w in caught if issubclass(w.category, ResourceWarning)]
    finally:
        server.close()
