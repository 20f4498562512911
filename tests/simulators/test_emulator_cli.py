"""The emulators as the commands a user runs: real processes, real ports, interrupted at the end."""

import asyncio
import os
import re
import signal
import subprocess
import sys

import numpy as np
import pytest

from protocol.arm import ArmReader
from protocol.client import ControllerClient

EXE = [sys.executable, "-m", "screwcal", "emulator"]


def start(args, **popen):
    proc = subprocess.Popen([*EXE, *args], stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                            text=True, **popen)
    line = proc.stdout.readline()
    assert line, proc.stderr.read()
    return proc, line


def stop(proc, sig=signal.SIGINT):
    """Interrupt as a user would (Ctrl-C, or `kill` with SIGTERM); a process that does not
    end is killed, never left running, and the failure shows what it printed."""
    proc.send_signal(sig)
    try:
        _, err = proc.communicate(timeout=30)  # also closes the pipes
    except subprocess.TimeoutExpired:
        proc.kill()
        _, err = proc.communicate()
        pytest.fail(f"{proc.args[3:5]} did not stop within 30 s of {sig.name}; stderr:\n{err}")
    assert proc.returncode == 0, err


@pytest.mark.slow
async def test_emulator_processes_serve_the_robot_and_the_arm(tmp_path):
    world = tmp_path / "world.json"
    irc5, line = start(["irc5", "--port", "0", "--time-scale", "0", "--world", str(world),
                        "--arm-port", "0"])
    arm_proc = None
    try:
        m = re.match(r"irc5 emulator on ([\d.]+):(\d+); measuring arm on (socket://\S+)", line)
        assert m, line
        arm_proc, arm_line = start(["arm", "--port", "0", "--world", str(world)])
        other = re.match(r"measuring arm on (socket://\S+)", arm_line).group(1)
        readers = [await asyncio.to_thread(ArmReader, url) for url in (m.group(3), other)]
        async with ControllerClient(m.group(1), int(m.group(2))) as robot:
            pose = await robot.movj([10, 20, -20, 30, 40, 50])
            assert pose.joints_deg == pytest.approx((10, 20, -20, 30, 40, 50), abs=1e-4)
        sets = [await asyncio.to_thread(r.read_holes, 5.0) for r in readers]
        np.testing.assert_allclose(sets[0].points_mm, sets[1].points_mm, atol=0.1)
        for r in readers:
            r.close()
    finally:
        try:
            stop(irc5)
        finally:
            if arm_proc is not None:
                stop(arm_proc)


def test_bad_errors_file_is_refused(tmp_path):
    bad = tmp_path / "errors.json"
    bad.write_text('{"J1rz": "two"}')
    out = subprocess.run([*EXE, "irc5", "--port", "0", "--errors", str(bad)],
                         capture_output=True, text=True, timeout=30,
                         env={**os.environ})
    assert out.returncode == 2 and "expected {\"J1rz\": 2.0" in out.stderr


@pytest.mark.slow
def test_the_commands_as_named_start_and_stop():
    for args in (["arm", "--port", "0"], ["irc5", "--host", "127.0.0.1", "--port", "0",
                                          "--seed", "3", "--time-scale", "0.5"]):
        proc, line = start(args)
        assert re.match(r"(measuring arm on socket://127\.0\.0\.1:\d+|"
                        r"irc5 emulator on 127\.0\.0\.1:\d+)$", line.strip()), line
        stop(proc)


def _as_a_background_job():
    """What a shell does to a command started with `&` without job control."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    signal.signal(signal.SIGQUIT, signal.SIG_IGN)


@pytest.mark.slow
@pytest.mark.parametrize("sig", [signal.SIGINT, signal.SIGTERM])
def test_started_in_the_background_the_emulators_still_stop(sig):
    """Found when an irc5 emulator outlived its test by half an hour: started from a
    background job, it had inherited SIGINT ignored and Ctrl-C never reached it. Both
    emulators now stop cleanly on SIGINT and on SIGTERM, whatever they inherited."""
    for args in (["arm", "--port", "0"], ["irc5", "--port", "0", "--arm-port", "0"]):
        proc, _ = start(args, preexec_fn=_as_a_background_job)
        stop(proc, sig)


def test_a_program_the_controller_would_refuse_is_named_with_its_line(tmp_path):
    bad = tmp_path / "Cell.mod"
    bad.write_text("MODULE Cell\nPROC main()\n  SetDO do1, 1;\nENDPROC\nENDMODULE\n")
    r = subprocess.run([*EXE, "irc5", "--port", "0", "--program", str(bad)],
                       capture_output=True, text=True, timeout=60)
    assert r.returncode == 2 and "Cell.mod:3: instruction SetDO is unknown" in r.stderr


def test_verbose_prints_the_controllers_event_log(tmp_path):
    proc, line = start(["irc5", "--port", "0", "--time-scale", "0", "--verbose"])
    host, port = re.search(r"on ([\d.]+):(\d+)", line).groups()

    async def talk() -> None:
        c = ControllerClient(host, int(port))
        await c.connect()
        await c.bye()
        await c.close()

    asyncio.run(talk())
    proc.send_signal(signal.SIGINT)
    out, _ = proc.communicate(timeout=30)
    assert proc.returncode == 0 and "event log: info: Program stopped" in out


def test_a_program_that_does_not_parse_is_named_by_its_file(tmp_path):
    """Issue 38: a syntax error was placed at `<module>:3:15`, not in the file given."""
    bad = tmp_path / "Cell.mod"
    bad.write_text("MODULE Cell\nPROC main()\n  MoveJ p1 v100;;; (\nENDPROC\nENDMODULE\n")
    r = subprocess.run([*EXE, "irc5", "--port", "0", "--program", str(bad)],
                       capture_output=True, text=True, timeout=60)
    assert r.returncode == 2 and f"{bad}:3:" in r.stderr and "<module>" not in r.stderr, r.stderr
    assert "Traceback" not in r.stderr
