"""Benchmark: memory under a flooding peer, both sides of the controller link.

    .venv/bin/python benchmarks/link_memory.py [--frames 1000000]

1. Server: an IRC5 emulator process; a peer sends `--frames` STAT requests and reads none of the
   replies. Reported: how many frames the peer got in before it was dropped, and the emulator's
   peak resident memory above its start.
2. Client: a controller process answers HELO, then sends `--frames` frames that answer no
   request (the client must drop it), and again with every frame on the pending request's SEQ
   (it must not queue them without bound). Reported: this process's peak memory above its start.

Target (issue 12): within 10 MB of the start in every case.
"""

from __future__ import annotations

# isort: off
# isort: on
import argparse
import asyncio
import os
import re
import socket
import subprocess
import sys
import textwrap
import time
from pathlib import Path

from protocol.client import ControllerClient, Timeouts
from protocol.codec import FRAME_LEN, frame
from protocol.errors import ProtocolError

ROOT = Path(__file__).resolve().parents[1]
TARGET_MB = 10.0


def _status_kb(pid: int | str, field: str) -> int:
    text = Path(f"/proc/{pid}/status").read_text()
    return int(re.search(rf"{field}:\s+(\d+) kB", text).group(1))  # type: ignore[union-attr]


def server_case(frames: int) -> tuple[int, float]:
    emu = subprocess.Popen([sys.executable, "-m", "screwcal", "emulator", "irc5", "--port", "0",
                            "--time-scale", "0", "--send-timeout-s", "2"], cwd=ROOT,
                           stdout=subprocess.PIPE, text=True)
    try:
        line = emu.stdout.readline()  # type: ignore[union-attr]
        port = int(re.search(r":(\d+)", line).group(1))  # type: ignore[union-attr]
        time.sleep(0.3)
        start_kb = _status_kb(emu.pid, "VmRSS")
        sock = socket.create_connection(("127.0.0.1", port))
        sock.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, 4096)  # and never read
        batch = b"".join(frame(f"{k} STAT") for k in range(1, 1001))
        sent = 0
        try:
            while sent < frames:
                sock.sendall(batch)
                sent += 1000
        except OSError:
            pass  # dropped by the emulator
        sock.close()
        peak_kb = _status_kb(emu.pid, "VmHWM")
        return sent, (peak_kb - start_kb) / 1024
    finally:
        emu.terminate()
        emu.wait(5)


FLOODER = textwrap.dedent("""
    import socket, sys
    frames, same_seq = int(sys.argv[1]), sys.argv[2] == "1"
    def frame(p): return (p + "#").ljust(80).encode()
    srv = socket.create_server(("127.0.0.1", 0))
    print(srv.getsockname()[1], flush=True)
    conn, _ = srv.accept()
    seq = conn.recv(80).decode().split(" ")[0]
    conn.sendall(frame(seq + " ACK HELO 1"))
    if same_seq:  # wait for the run request, then flood its SEQ
        conn.recv(80); run = str(int(seq) + 1)
        payload = frame(run + " ACK RUN") + frame(run + " WAIT 0")
        conn.sendall(payload)
        one = frame(run + " DONE MOVJ")
    else:
        one = frame("999999 ACK STAT")
    batch = one * 1000
    try:
        for _ in range(frames // 1000):
            conn.sendall(batch)
    except OSError:
        pass
""")


async def client_case(frames: int, same_seq: bool) -> tuple[str, float]:
    flooder = subprocess.Popen([sys.executable, "-c", FLOODER, str(frames),
                                "1" if same_seq else "0"], stdout=subprocess.PIPE, text=True)
    try:
        port = int(flooder.stdout.readline())  # type: ignore[union-attr]
        start_kb = _status_kb("self", "VmRSS")
        client = ControllerClient("127.0.0.1", port, Timeouts(reply_s=5, pose_s=5))
        outcome = "not dropped"
        try:
            await client.connect()
            if same_seq:
                client._loaded["CAL"] = 1  # the flooder takes any list

                async def operator(idx: int) -> None:
                    await asyncio.sleep(2.0)  # a slow operator: frames pile up meanwhile

                async for _ in client.run("CAL", "STEP", on_wait=operator):
                    pass
            else:
                await asyncio.sleep(0.2)
                await client.stat()
                await asyncio.sleep(2.0)
        except ProtocolError as err:
            outcome = f"dropped ({str(err)[:60].rstrip('; ')})"
        await client.close()
        return outcome, (_status_kb("self", "VmHWM") - start_kb) / 1024
    finally:
        flooder.kill()
        flooder.wait(5)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--frames", type=int, default=1_000_000)
    args = parser.parse_args()
    os.chdir(ROOT)
    sent, grown = server_case(args.frames)
    verdict = "ok" if grown <= TARGET_MB else "MISSED"
    print(f"server, {args.frames} unread requests: peer got {sent} frames "
          f"({sent * FRAME_LEN / 1e6:.1f} MB) in before the drop; emulator peak "
          f"{grown:+.1f} MB   target {TARGET_MB:g} MB {verdict}")
    for same_seq, what in ((False, "unsolicited frames"), (True, "frames on a pending SEQ")):
        outcome, grown = asyncio.run(client_case(args.frames, same_seq))
        verdict = "ok" if grown <= TARGET_MB else "MISSED"
        print(f"client, {args.frames} {what}: {outcome}; client peak {grown:+.1f} MB   "
              f"target {TARGET_MB:g} MB {verdict}")


if __name__ == "__main__":
    main()
