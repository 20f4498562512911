"""The socket instructions on real OS sockets and the motion instructions on the emulated world,
as the RAPID task sees them."""

from __future__ import annotations

import socket
import threading
import time
from types import SimpleNamespace

import numpy as np
import pytest

from simulators.faults import FaultPlan
from simulators.rapid.errors import ERRNUMS
from simulators.rapid.interpreter import Task
from simulators.rapid.motion import Motion
from simulators.rapid.sockets import Network
from simulators.truth import make_world

SETTINGS = dict(faults=FaultPlan(), send_timeout_s=0.5, time_wait_s=0.5, time_scale=0.0,
                speed_deg_s=60.0)


def task(body: str, data: str = "", routines: str = "", world=None, **settings) -> Task:
    s = SimpleNamespace(**{**SETTINGS, **settings})
    world = world or make_world(None, None)
    return Task(f"MODULE T\n{data}\nPROC main()\n{body}\nENDPROC\n{routines}\nENDMODULE\n",
                "T.mod", services={"network": Network(s), "motion": Motion(world, None, s)})


def value(t: Task, name: str):
    return t.data[name.lower()].value


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


SERVER = ("VAR socketdev srv; VAR socketdev cli; VAR string got; VAR num err; VAR num port;"
          " VAR string ip;")


def test_accept_with_a_fractional_time_out_is_err_sock_timeout():
    t = task("SocketCreate srv; SocketBind srv, \"127.0.0.1\", 0; SocketListen srv; Acc;",
             SERVER, "PROC Acc()\n SocketAccept srv, cli \\Time:=0.05;\nERROR\n"
             " err := ERRNO; RETURN;\nENDPROC")
    start = time.monotonic()
    t.run()
    t.services["network"].shutdown()
    assert value(t, "err") == ERRNUMS["ERR_SOCK_TIMEOUT"]
    assert 0.04 < time.monotonic() - start < 1.0


def test_receive_of_a_closed_peer_is_err_sock_closed_and_exact_bytes_are_read():
    port = free_port()
    t = task(f"SocketCreate srv; SocketBind srv, \"127.0.0.1\", {port}; SocketListen srv;"
             " SocketAccept srv, cli \\ClientAddress:=ip \\Time:=5;"
             " SocketReceive cli \\Str:=got \\ReadNoOfBytes:=5 \\Time:=5; Rec;",
             SERVER, "PROC Rec()\n VAR string more;\n"
             " SocketReceive cli \\Str:=more \\Time:=5;\nERROR\n err := ERRNO; RETURN;\nENDPROC")
    thread = threading.Thread(target=t.run)
    thread.start()
    time.sleep(0.2)
    with socket.create_connection(("127.0.0.1", port)) as c:
        c.sendall(b"ab")
        time.sleep(0.05)
        c.sendall(b"cde")  # a split frame: ReadNoOfBytes waits for all five
    thread.join(5)
    t.services["network"].shutdown()
    assert value(t, "got") == "abcde" and value(t, "ip") == "127.0.0.1"
    assert value(t, "err") == ERRNUMS["ERR_SOCK_CLOSED"]


def test_rebinding_while_a_closed_connection_is_in_time_wait_is_addr_inuse():
    port = free_port()
    t = task(f"SocketCreate srv; SocketBind srv, \"127.0.0.1\", {port}; SocketListen srv;"
             " SocketAccept srv, cli \\Time:=5; SocketClose cli; SocketClose srv;"
             f" SocketCreate srv; Bind; WaitTime 0.6; SocketClose srv; SocketCreate srv;"
             f" SocketBind srv, \"127.0.0.1\", {port};",
             SERVER, f"PROC Bind()\n SocketBind srv, \"127.0.0.1\", {port};\nERROR\n"
             " err := ERRNO; RETURN;\nENDPROC")
    thread = threading.Thread(target=t.run)
    thread.start()
    time.sleep(0.2)
    with socket.create_connection(("127.0.0.1", port)):
        time.sleep(0.2)  # the controller closes first
    thread.join(5)
    t.services["network"].shutdown()
    assert value(t, "err") == ERRNUMS["ERR_SOCK_ADDR_INUSE"]
    assert t.stop_reason.startswith("program ended")  # after TIME_WAIT the bind succeeds


def test_moveabsj_moves_the_world_and_cjointt_reads_it():
    world = make_world(None, None)
    t = task("MoveAbsJ [[10, 20, -30, 40, 50, 60], [9E9, 9E9, 9E9, 9E9, 9E9, 9E9]], v100,"
             " fine, tool0; jt := CJointT(); rt := CRobT(\\Tool:=tool0 \\WObj:=wobj0);",
             "VAR jointtarget jt; VAR robtarget rt;", world=world)
    t.run()
    assert world.arrivals == 1
    np.testing.assert_allclose(world.q_deg, [10, 20, -30, 40, 50, 60])
    assert list(value(t, "jt").f["robax"].f.values()) == pytest.approx([10, 20, -30, 40, 50, 60])
    T = t.services["motion"].tool0(np.array([10, 20, -30, 40, 50, 60.0]))
    assert [value(t, "rt").f["trans"].f[k] for k in "xyz"] == pytest.approx(T[:3, 3], abs=1e-3)


def test_a_target_outside_the_controllers_limits_is_err_roblimit_and_nothing_moves():
    world = make_world(None, None)
    t = task("MoveAbsJ [[0, 0, 0, 0, 130, 0], [9E9, 9E9, 9E9, 9E9, 9E9, 9E9]], v100, fine,"
             " tool0;", world=world)
    t.run()
    assert "ERR_ROBLIMIT" in t.stop_reason and world.arrivals == 0


def test_calcjointt_inverts_calcrobt_on_the_configurations_branch():
    for q in ([30, 10, 20, 60, 45, 30], [30, 10, 20, 60, -45, 30], [-100, 40, -60, -150, 30,
                                                                       250]):
        t = task(f"jt := [[{', '.join(map(str, q))}], [9E9, 9E9, 9E9, 9E9, 9E9, 9E9]];"
                 " back := CalcJointT(CalcRobT(jt, tool0), tool0);",
                 "VAR jointtarget jt; VAR jointtarget back;")
        t.run()
        got = list(value(t, "back").f["robax"].f.values())
        np.testing.assert_allclose(got, q, atol=2e-3)


def test_without_inpos_the_encoders_are_read_before_the_servo_settles():
    world = make_world(None, None)
    body = ("MoveAbsJ [[10, 0, 0, 0, 0, 0], [9E9, 9E9, 9E9, 9E9, 9E9, 9E9]], v100, fine, tool0;"
            " a := CJointT(); MoveAbsJ [[20, 0, 0, 0, 0, 0], [9E9, 9E9, 9E9, 9E9, 9E9, 9E9]],"
            " v100, fine \\Inpos:=inpos50, tool0; b := CJointT();")
    t = task(body, "VAR jointtarget a; VAR jointtarget b;", world=world, time_scale=0.01,
             speed_deg_s=6000.0)
    t.run()
    assert value(t, "a").f["robax"].f["rax_1"] != pytest.approx(10, abs=1e-3)  # still settling
    assert value(t, "b").f["robax"].f["rax_1"] == pytest.approx(20, abs=1e-5)
