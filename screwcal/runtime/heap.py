"""The C heap keeps the identification's freed temporaries for the next ones (glibc).

An identification allocates and frees arrays of one to a few megabytes at every step (the
Jacobians of 1000 poses by 30-40 parameters, their whitened copies, the frames' side-by-side
matrix): about 21 MB at its peak at 1000 full poses. glibc's malloc serves such blocks from
fresh mappings or hands the heap's free top back to the system once it exceeds its trim
threshold (by default twice the largest block freed so far, a few MB here), so the next step's
arrays page-fault their memory in again: 62,000 minor faults in six identifications of 1000
poses, against 19,000 with the heap kept, and a sixth of the identification's CPU time
(120 -> 100 ms each).

`keep_freed_memory()` raises the two thresholds once per process (blocks under `MMAP_THRESHOLD`
from the heap, its free top handed back beyond `TRIM_THRESHOLD`), called by the process's door
(the command line, the service, a worker: `screwcal.runtime.policy`; an identification leaves
the heap as it finds it). The process then keeps at most that much freed memory (its peak is
unchanged: the memory was in use a moment before). A threshold the user has set (glibc's
MALLOC_*_ environment variables) is left as it is, and other C libraries (musl, macOS) are not
touched.
"""

from __future__ import annotations

import os
import threading

__all__ = ["MMAP_THRESHOLD", "TRIM_THRESHOLD", "keep_freed_memory"]

MMAP_THRESHOLD = 16 * 2 ** 20  # blocks under this come from the heap (glibc's cap: 32 MB)
TRIM_THRESHOLD = 32 * 2 ** 20  # the heap's free top beyond this goes back to the system

# glibc's mallopt parameters (malloc.h) and their environment variables
_M_TRIM_THRESHOLD, _M_MMAP_THRESHOLD = -1, -3
_USER_SETTINGS = ("MALLOC_TRIM_THRESHOLD_", "MALLOC_MMAP_THRESHOLD_", "MALLOC_TOP_PAD_",
                  "MALLOC_MMAP_MAX_")

_lock = threading.Lock()
_done: dict[str, bool] = {}


def keep_freed_memory() -> bool:
    """Raise glibc's thresholds once for this process (see the module docstring); whether they
    are raised (False: not glibc, or the user has set one)."""
    with _lock:
        if "result" not in _done:
            _done["result"] = _raise_thresholds()
        return _done["result"]


def _raise_thresholds() -> bool:
    if not _on_glibc() or any(v in os.environ for v in _USER_SETTINGS):
        return False
    import ctypes  # (here: the command line applies this at its start, ctypes costs there)

    try:
        libc = ctypes.CDLL(None)
        mallopt = libc.mallopt
    except (OSError, AttributeError):
        return False
    mallopt.argtypes, mallopt.restype = (ctypes.c_int, ctypes.c_int), ctypes.c_int
    # (the mapping threshold first: setting either fixes both, glibc's own adjustment stops)
    return bool(mallopt(_M_MMAP_THRESHOLD, MMAP_THRESHOLD)
                and mallopt(_M_TRIM_THRESHOLD, TRIM_THRESHOLD))


def _on_glibc() -> bool:
    """Whether this process's C library is glibc (asked of the library, not by reading the
    interpreter's executable as `platform.libc_ver` does)."""
    try:
        return (os.confstr("CS_GNU_LIBC_VERSION") or "").startswith("glibc")
    except (AttributeError, ValueError, OSError):  # not a glibc system
        return False
