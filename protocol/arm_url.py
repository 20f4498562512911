"""Which measuring-arm addresses a cell may use, checked before pyserial ever sees them.

`serial.serial_for_url` is powerful: `spy://` writes a trace to any file named in its query,
`alt://` picks an implementation by name, and a plain path opens whatever file it names. An
address that comes from a client (the job service's robot records) must therefore be one a cell
uses and nothing else:

- a serial device: `/dev/ttyS0`, `/dev/ttyUSB0`, `/dev/ttyACM0`, `/dev/ttyAMA0`, `/dev/ttymxc0`,
  `/dev/serial/by-id/...`, `/dev/serial/by-path/...`, or `COM1`..`COM256` on Windows;
- `socket://HOST:PORT` (a serial server in raw mode), `rfc2217://HOST:PORT` (a serial server
  with port control, options `ign_set_control`, `poll_modem`, `timeout=N` allowed);
- `loop://` (the loop-back the tests use).

Everything else is refused with this list.
"""

from __future__ import annotations

import re
from urllib.parse import SplitResult, parse_qsl, urlsplit

ALLOWED = ("a serial device (/dev/ttyS*, /dev/ttyUSB*, /dev/ttyACM*, /dev/ttyAMA*, /dev/ttymxc*, "
           "/dev/serial/by-id/*, /dev/serial/by-path/*, COM1..COM256), socket://HOST:PORT, "
           "rfc2217://HOST:PORT or loop://")
_DEVICE = re.compile(r"/dev/(tty(S|USB|ACM|AMA|mxc)[0-9]{1,3}"
                     r"|serial/by-(id|path)/[A-Za-z0-9._:+-]{1,120})\Z")
_COM = re.compile(r"COM([1-9][0-9]{0,2})\Z", re.IGNORECASE)
# A host name or an IP address (an IPv6 one in a URL in brackets); the controller's host too.
HOSTNAME = re.compile(r"^(?=.{1,253}$)[A-Za-z0-9]([A-Za-z0-9.:-]*[A-Za-z0-9])?$")
_RFC2217_OPTIONS = {"ign_set_control", "poll_modem", "timeout"}


class ArmUrlError(ValueError):
    """An arm address outside what a cell uses (the message lists what is allowed)."""


def _host_port(url: str, scheme: str) -> SplitResult:
    """The URL's parts when it is SCHEME://HOST:PORT (an IPv6 host in brackets)."""
    needs = ArmUrlError(f"{url!r}: {scheme}:// needs HOST:PORT with a port 1-65535")
    try:
        parts = urlsplit(url)
        host, port = parts.hostname or "", parts.port
    except ValueError:  # a port out of range, a bracketed host that is no IPv6 address
        raise needs from None
    if parts.path not in ("", "/") or parts.fragment or parts.username or parts.password:
        raise ArmUrlError(f"{url!r}: {scheme}:// takes HOST:PORT only")
    bracketed = parts.netloc.startswith("[")  # urlsplit checked it is an IP address
    if not port or not (bracketed or HOSTNAME.match(host)) or (":" in host and not bracketed):
        raise needs
    return parts


def check_arm_url(url: str) -> str:
    """`url` itself when a cell may use it, else `ArmUrlError` naming the allowed forms."""
    try:
        return _checked(url)
    except ArmUrlError as err:
        if "allowed: " + ALLOWED in str(err):
            raise
        raise ArmUrlError(f"{err}; allowed: {ALLOWED}") from None


def _checked(url: str) -> str:
    if any(c.isspace() or not c.isprintable() for c in url):
        raise ArmUrlError(f"{url!r}: spaces or control characters; allowed: {ALLOWED}")
    if _DEVICE.match(url) and ".." not in url:
        return url
    com = _COM.match(url)
    if com and 1 <= int(com.group(1)) <= 256:
        return url
    scheme = url.split("://", 1)[0].lower() if "://" in url else ""
    if scheme == "loop":
        if url.lower() not in ("loop://", "loop:///"):
            raise ArmUrlError(f"{url!r}: loop:// takes no options")
        return url
    if scheme == "socket":
        if _host_port(url, scheme).query:
            raise ArmUrlError(f"{url!r}: socket:// takes no options")
        return url
    if scheme == "rfc2217":
        for key, value in parse_qsl(_host_port(url, scheme).query, keep_blank_values=True):
            bad_timeout = key == "timeout" and not value.replace(".", "", 1).isdigit()
            if key not in _RFC2217_OPTIONS or bad_timeout:
                raise ArmUrlError(f"{url!r}: rfc2217:// option {key!r} is not allowed "
                                  f"(allowed: {', '.join(sorted(_RFC2217_OPTIONS))})")
        return url
    what = f"the scheme {scheme}://" if scheme else "this path"
    raise ArmUrlError(f"{url!r}: {what} is not an arm address a cell uses; allowed: {ALLOWED}")
