"""The HTTP server of the service: uvicorn on a socket bound beforehand, with the guard against
slow and many clients (service/http_guard.py), the store opened before anything is bound (a
database another service holds is refused at once), and a stop when the database is lost."""

from __future__ import annotations

import errno
import resource
import socket
from dataclasses import dataclass, field

from service.errors import ServiceError
from service.settings import ServiceSettings
from service.store import Store, open_store

DESCRIPTORS_WANTED = 8192  # slow clients must not exhaust the 1024 a shell gives by default


@dataclass
class Server:
    """A bound, not yet serving service: `run()` blocks until stopped."""

    settings: ServiceSettings
    store: Store
    sock: socket.socket
    fatal: list[str] = field(default_factory=list)

    def __post_init__(self) -> None:
        import uvicorn

        from service.app import create_app
        from service.http_guard import BodyTimeout, guarded_protocol

        s = self.settings
        app = create_app(s, self.store, on_fatal=self._stop)
        self.uvicorn = uvicorn.Server(uvicorn.Config(
            BodyTimeout(app, s.header_timeout_s), log_level="warning", lifespan="on",
            http=guarded_protocol(s.header_timeout_s, s.max_connections),
            timeout_keep_alive=5,
            ssl_certfile=str(s.tls_cert) if s.tls_cert is not None else None,
            ssl_keyfile=str(s.tls_key) if s.tls_key is not None else None))

    @property
    def address(self) -> tuple[str, int]:
        host, port = self.sock.getsockname()[:2]
        return host, port

    def _stop(self, reason: str) -> None:
        self.fatal.append(reason)
        self.uvicorn.should_exit = True

    async def serve(self) -> None:
        await self.uvicorn.serve(sockets=[self.sock])


def raise_descriptor_limit(wanted: int = DESCRIPTORS_WANTED) -> int:
    """Raise this process's open-file limit towards `wanted` (within the hard limit)."""
    soft, hard = resource.getrlimit(resource.RLIMIT_NOFILE)
    target = min(max(soft, wanted), hard) if hard != resource.RLIM_INFINITY else max(soft, wanted)
    if target > soft:
        resource.setrlimit(resource.RLIMIT_NOFILE, (target, hard))
    return target


LOOPBACK = ("127.0.0.1", "::1", "localhost")


def check_transport(settings: ServiceSettings) -> None:
    """TLS needs both files; beyond loopback the service speaks HTTPS unless told otherwise
    (IEC 62443-3-3 SR 3.1: tokens and passwords must not cross a cell network in clear)."""
    if (settings.tls_cert is None) != (settings.tls_key is None):
        raise ServiceError("TLS needs both --tls-cert and --tls-key")
    for path in (settings.tls_cert, settings.tls_key):
        if path is not None and not path.is_file():
            raise ServiceError(f"{path}: no such file (a PEM certificate or key)")
    if settings.host not in LOOPBACK and settings.tls_cert is None and not settings.insecure_http:
        raise ServiceError(f"listening on {settings.host} (beyond loopback) without TLS: give "
                           "--tls-cert and --tls-key, or --insecure-http to accept tokens and "
                           "passwords in clear on that network")


def bind(settings: ServiceSettings, port: int | None = None) -> Server:
    """Open the store (StoreBusyError when another service holds it), then bind the port
    (ServiceError saying so when it is taken)."""
    check_transport(settings)
    raise_descriptor_limit()
    store = open_store(settings)
    sock = socket.socket(socket.AF_INET, socket.SOCK_STREAM)
    sock.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
    want = settings.port if port is None else port
    try:
        sock.bind((settings.host, want))
    except OSError as err:
        sock.close()
        store.close()
        if err.errno == errno.EADDRINUSE:
            raise ServiceError(f"port {want} on {settings.host} is in use (another service or "
                               "program): choose another with --port, or 0 for a free one"
                               ) from None
        raise ServiceError(f"cannot bind {settings.host}:{want}: {err.strerror}") from None
    sock.listen(2048)  # connections wait in the backlog from the moment the address is announced
    return Server(settings, store, sock)
