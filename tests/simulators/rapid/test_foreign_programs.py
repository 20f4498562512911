"""The virtual IRC5 running other people's programs: a socket server in the form public PC-link
modules take (programs/CellLink.mod, written for these tests), tools and work objects in motion
and in the position functions, MoveC, configuration control, LONG_JMP_ALL_ERR, GOTO, several
modules in one task, `--set`, and close-and-rebind."""

from __future__ import annotations

import asyncio
import contextlib
import socket
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest

from screwcal.kinematics.forward import flange_kinematics
from screwcal.kinematics.pose import rotation_from_quaternion_wxyz
from simulators.faults import FaultPlan
from simulators.irc5 import EmulatorSettings, IRC5Emulator
from simulators.rapid.errors import ERRNUMS, LoadError, SettingError
from simulators.rapid.interpreter import Task
from simulators.rapid.motion import Motion
from simulators.rapid.program import module_files
from simulators.rapid.sockets import Network
from simulators.truth import make_world

PROGRAMS = Path(__file__).with_name("programs")
LINK = PROGRAMS / "CellLink.mod"
SETTINGS = dict(faults=FaultPlan(), send_timeout_s=0.5, time_wait_s=0.0, time_scale=0.0,
                speed_deg_s=60.0)


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def task(body: str, data: str = "", routines: str = "", world=None) -> Task:
    s = SimpleNamespace(**SETTINGS)
    world = world or make_world(None, None)
    return Task(f"MODULE T\n{data}\nPROC main()\n{body}\nENDPROC\n{routines}\nENDMODULE\n",
                "T.mod", services={"network": Network(s), "motion": Motion(world, None, s)})


def absj(*q: float) -> str:
    """A MoveAbsJ to these joints (deg), with tool0."""
    return (f"MoveAbsJ [[{', '.join(map(str, q))}], [9E9, 9E9, 9E9, 9E9, 9E9, 9E9]], v100, fine,"
            " tool0;")


def value(t: Task, name: str):
    return t.data[name.lower()].value


def xyz(rec) -> np.ndarray:
    return np.array([rec.f["trans"].f[k] for k in "xyz"])


def wxyz(rec) -> np.ndarray:
    return np.array([rec.f["rot"].f[k] for k in ("q1", "q2", "q3", "q4")])


def flange(world) -> np.ndarray:
    return flange_kinematics(world.nominal, np.radians(world.q_deg.astype(float))[None])[0]


# ------------------------------------------------------------------ a client of CellLink's form
class Link:
    """A PC client: "code p1 .. pn #" out, "code ok data" back."""

    def __init__(self, reader: asyncio.StreamReader, writer: asyncio.StreamWriter):
        self.reader, self.writer = reader, writer

    @classmethod
    async def open(cls, address: tuple[str, int]) -> Link:
        """Connected to the program listening again (a connection the old listening socket
        took before the program closed it is reset: tried again)."""
        for _ in range(100):
            with contextlib.suppress(ConnectionError):
                link = cls(*await asyncio.open_connection(*address))
                if await link.ask(0) == ["1", "?"]:  # an unknown code: the program answers
                    return link
            await asyncio.sleep(0.02)
        raise AssertionError("the program did not listen again")

    async def ask(self, code: int, *params: float) -> list[str]:
        text = f"{code:02d} " + "".join(f"{p:+08.5f} " for p in params) + "#"
        self.writer.write(text.encode())
        reply = (await asyncio.wait_for(self.reader.read(4096), 10)).decode().split()
        if not reply:
            raise ConnectionResetError("closed without a reply")
        assert reply[0] == str(code), reply
        return reply[1:]

    async def numbers(self, code: int, *params: float) -> list[float]:
        ok, *data = await self.ask(code, *params)
        assert ok == "1", data
        return [float(v) for v in data]

    async def close(self) -> None:
        self.writer.write(b"99 #")
        await self.writer.drain()
        self.writer.close()


@contextlib.asynccontextmanager
async def link_controller(**assignments: str):
    emu = IRC5Emulator(make_world(None, None), EmulatorSettings(
        time_scale=0.0, program=LINK, assignments=assignments))
    await emu.start("127.0.0.1", 0)
    try:
        yield emu
    finally:
        await emu.stop()


async def test_a_foreign_server_serves_sessions_with_tools_work_objects_and_circles():
    port = free_port()
    async with link_controller(linkPort=str(port)) as emu:
        assert emu.address == ("127.0.0.1", port)  # its own data, as --set gave it
        world = emu.world
        for _ in range(4):  # the first client and three reconnections
            link = await Link.open(emu.address)
            await link.numbers(7, 0, 0, 0, 1, 0, 0, 0)
            await link.numbers(8, 0, 0, 0, 1, 0, 0, 0)
            assert await link.numbers(2, 10, 20, 10, 0, 40, 10) == []
            assert await link.numbers(4) == pytest.approx([10, 20, 10, 0, 40, 10], abs=0.01)
            pose = await link.numbers(3)
            T = flange(world)
            assert pose[:3] == pytest.approx(T[:3, 3], abs=0.01)
            # a linear move to the pose read back (3 decimals: |q| up to 1e-3 from 1)
            target = [pose[0] + 40, pose[1], pose[2] - 30, *pose[3:]]
            await link.numbers(1, *target)
            assert flange(world)[:3, 3] == pytest.approx(target[:3], abs=0.01)
            # a circle through a via point to its end
            start = flange(world)[:3, 3]
            await link.numbers(5, start[0] + 30, start[1] + 30, start[2], *pose[3:])
            await link.numbers(6, start[0], start[1] + 60, start[2], *pose[3:])
            assert flange(world)[:3, 3] == pytest.approx(start + np.array([0, 60, 0]), abs=0.01)
            # a tool 100 mm along the flange's z: the TCP read back is there
            await link.numbers(7, 0, 0, 100, 1, 0, 0, 0)
            T = flange(world)
            tcp = await link.numbers(3)
            assert tcp[:3] == pytest.approx(T[:3, 3] + 100 * T[:3, 2], abs=0.01)
            # a work object 100 mm along x, turned 90 deg about z: poses in it
            c = np.sqrt(0.5)
            await link.numbers(8, 100, 0, 0, c, 0, 0, c)
            in_wobj = await link.numbers(3)
            expected = np.array([[0, 1, 0], [-1, 0, 0], [0, 0, 1]]) @ (
                T[:3, 3] + 100 * T[:3, 2] - [100, 0, 0])
            assert in_wobj[:3] == pytest.approx(expected, abs=0.01)
            # a move in the work object lands there, with the tool
            goal = [in_wobj[0] + 20, in_wobj[1], in_wobj[2], *in_wobj[3:]]
            await link.numbers(9, *goal)
            T = flange(world)
            tcp_base = T[:3, 3] + 100 * T[:3, 2]
            assert tcp_base == pytest.approx(np.array([100, 0, 0]) + np.array(
                [[0, -1, 0], [1, 0, 0], [0, 0, 1]]) @ goal[:3], abs=0.01)
            assert (await link.numbers(3))[:3] == pytest.approx(goal[:3], abs=0.01)
            # an unusable orient is the program's error (handled: the session goes on)
            ok, errno = await link.ask(1, 500, 0, 500, 1.3, 0, 0, 0)
            assert ok == "0" and int(errno) == ERRNUMS["ERR_ARGVALERR"]
            await link.close()
        link = await Link.open(emu.address)
        assert await link.numbers(4)  # a fifth session: the program still serves
        link.writer.close()  # a client that goes without a word: ERR_SOCK_CLOSED, RETRY
        link = await Link.open(emu.address)
        assert await link.numbers(4)
        await link.close()
        await asyncio.sleep(0.1)
        assert emu.running and value(emu.task, "sessions") >= 6  # (a reset one counts too)


async def test_a_foreign_module_keeps_its_own_port_and_screwcal_server_takes_the_emulators(
        tmp_path):
    own, asked = free_port(), free_port()
    module = tmp_path / "Other.mod"
    module.write_text(LINK.read_text().replace("MODULE CellLink", "MODULE Other").replace(
        "linkPort := 5000", f"linkPort := {own}"))
    emu = IRC5Emulator(make_world(None, None), EmulatorSettings(time_scale=0.0,
                                                                program=module))
    try:
        assert await emu.start("127.0.0.1", asked) == ("127.0.0.1", own)
        assert value(emu.task, "linkPort") == own
    finally:
        await emu.stop()
    emu = IRC5Emulator(make_world(None, None), EmulatorSettings(time_scale=0.0))
    try:
        assert await emu.start("127.0.0.1", asked) == ("127.0.0.1", asked)
    finally:
        await emu.stop()


def test_set_gives_data_their_value_in_rapid_and_refuses_what_does_not_fit():
    t = Task(LINK.read_text(), "CellLink.mod", overrides={})
    assert value(t, "linkPort") == 5000
    from simulators.rapid.program import RapidText, assignments

    given = assignments(["linkPort=6001", "linkAddress=0.0.0.0",
                         "linkTool=[TRUE,[[0,0,50],[1,0,0,0]],[1,[0,0,1],[1,0,0,0],0,0,0]]"])
    t = Task(LINK.read_text(), "CellLink.mod",
             overrides={k: RapidText(v) for k, v in given.items()})
    assert value(t, "linkPort") == 6001 and value(t, "linkAddress") == "0.0.0.0"
    assert xyz(value(t, "linkTool").f["tframe"]) == pytest.approx([0, 0, 50])
    # a command-line option has no line: the error names the option and the item as given
    with pytest.raises(SettingError, match=r"^--set 'linkPort=five': not a num value "
                                           r"\(no data named five\)$"):
        Task(LINK.read_text(), "CellLink.mod", overrides={"linkPort": RapidText("five")})
    with pytest.raises(SettingError, match=r"^--set 'linkPort=\[1,': not a num value \(expected "
                                           r"a value, found the end of the file at character 4\)$"):
        Task(LINK.read_text(), "CellLink.mod", overrides={"linkPort": RapidText("[1,")})
    with pytest.raises(SettingError, match=r"^--set 'nothere=1': no data named nothere to set "
                                           r"in CellLink\.mod$"):
        Task(LINK.read_text(), "CellLink.mod", overrides={"nothere": RapidText("1")})
    with pytest.raises(SettingError, match=r"^--set 'linkPort': expected NAME=VALUE"):
        assignments(["linkPort"])


# ------------------------------------------------------------------ tools and work objects
WOBJ = ("PERS wobjdata table := [FALSE, TRUE, \"\", [[200, -100, 50], [0.9238795, 0, 0, "
        "0.3826834]], [[100, 0, 0], [1, 0, 0, 0]]];"
        "PERS tooldata pen := [TRUE, [[10, 0, 120], [0.9659258, 0, 0.2588190, 0]], [1, [0, 0, "
        "50], [1, 0, 0, 0], 0, 0, 0]];"
        "VAR robtarget got; VAR robtarget base; VAR jointtarget jt; VAR robtarget back;")


def frame(trans, q) -> np.ndarray:
    T = np.eye(4)
    T[:3, :3] = rotation_from_quaternion_wxyz(np.array(q))
    T[:3, 3] = trans
    return T


def test_a_move_in_a_work_object_with_a_tool_puts_the_tcp_where_the_frames_say():
    world = make_world(None, None)
    t = task("ConfL \\Off; MoveL [[150, 80, 300], [0, 0, 1, 0], [0, 0, 0, 0], [9E9, 9E9, 9E9,"
             " 9E9, 9E9, 9E9]], v100, fine, pen \\WObj:=table; got := CRobT();"
             " base := CRobT(\\Tool:=pen \\WObj:=wobj0); jt := CJointT();"
             " back := CalcRobT(jt, pen \\WObj:=table);", WOBJ, world=world)
    t.run()
    assert t.stop_reason.startswith("program ended"), t.stop_reason
    wobj = frame([200, -100, 50], [0.9238795, 0, 0, 0.3826834]) @ frame([100, 0, 0],
                                                                        [1, 0, 0, 0])
    target = frame([150, 80, 300], [0, 0, 1, 0])
    tcp = wobj @ target  # where the TCP must be, in the base frame
    T = flange(world) @ frame([10, 0, 120], [0.9659258, 0, 0.2588190, 0])
    np.testing.assert_allclose(T[:3, 3], tcp[:3, 3], atol=1e-3)
    np.testing.assert_allclose(T[:3, :3], tcp[:3, :3], atol=1e-5)
    for name in ("got", "back"):  # CRobT in the active tool and work object, CalcRobT alike
        assert xyz(value(t, name)) == pytest.approx([150, 80, 300], abs=1e-3)
        assert abs(wxyz(value(t, name)) @ [0, 0, 1, 0]) == pytest.approx(1, abs=1e-6)
    assert xyz(value(t, "base")) == pytest.approx(tcp[:3, 3], abs=1e-3)


def test_calcjointt_in_a_work_object_and_a_stationary_tool_with_a_held_work_object():
    world = make_world(None, None)
    held = ("PERS tooldata gun := [FALSE, [[900, 0, 400], [0, 0, 1, 0]], [1, [0, 0, 1], [1, 0, 0,"
            " 0], 0, 0, 0]]; PERS wobjdata part := [TRUE, TRUE, \"\", [[0, 0, 80], [1, 0, 0, 0]],"
            " [[0, 0, 0], [1, 0, 0, 0]]];")
    t = task("ConfL \\Off; MoveL [[150, 80, 300], [0, 0, 1, 0], [0, 0, 0, 0], [9E9, 9E9, 9E9,"
             " 9E9, 9E9, 9E9]], v100, fine, pen \\WObj:=table; base := CRobT(); ConfL \\On;"
             " MoveAbsJ [[0, 0, 0, 0, 30, 0], [9E9, 9E9, 9E9, 9E9, 9E9, 9E9]], v100, fine, tool0;"
             " jt := CalcJointT(base, pen \\WObj:=table); ConfJ \\Off;"
             " MoveJ [[0, 0, -20], [1, 0, 0, 0], [0, 0, 0, 0], [9E9, 9E9, 9E9, 9E9, 9E9, 9E9]],"
             " v100, fine, gun \\WObj:=part; got := CRobT(\\Tool:=gun \\WObj:=part);",
             WOBJ + held, world=world)
    t.run()
    assert t.stop_reason.startswith("program ended"), t.stop_reason
    # the part's frame (on the flange, 80 mm out) with the target 20 mm below it meets the gun
    T = flange(world) @ frame([0, 0, 80], [1, 0, 0, 0]) @ frame([0, 0, -20], [1, 0, 0, 0])
    gun = frame([900, 0, 400], [0, 0, 1, 0])
    np.testing.assert_allclose(T, gun, atol=1e-3)
    assert xyz(value(t, "got")) == pytest.approx([0, 0, -20], abs=1e-3)
    q = np.array(list(value(t, "jt").f["robax"].f.values()))
    T = flange_kinematics(world.nominal, np.radians(q)[None])[0] @ frame(
        [10, 0, 120], [0.9659258, 0, 0.2588190, 0])
    wobj = frame([200, -100, 50], [0.9238795, 0, 0, 0.3826834]) @ frame([100, 0, 0],
                                                                        [1, 0, 0, 0])
    np.testing.assert_allclose(T[:3, 3], (wobj @ frame([150, 80, 300], [0, 0, 1, 0]))[:3, 3],
                               atol=1e-3)


def test_a_held_tool_with_a_held_work_object_is_the_controllers_error():
    t = task("MoveL [[0, 0, 0], [1, 0, 0, 0], [0, 0, 0, 0], [9E9, 9E9, 9E9, 9E9, 9E9, 9E9]],"
             " v100, fine, tool0 \\WObj:=part;",
             "PERS wobjdata part := [TRUE, TRUE, \"\", [[0, 0, 0], [1, 0, 0, 0]],"
             " [[0, 0, 0], [1, 0, 0, 0]]];")
    t.run()
    assert "ERR_ARGVALERR" in t.stop_reason and "robhold" in t.stop_reason


def test_orients_are_normalised_within_the_controllers_limit():
    world = make_world(None, None)
    t = task(absj(10, 20, 10, 0, 40, 10) + " got := CRobT();"
             " got.rot := [Round(got.rot.q1 \\Dec:=3), Round(got.rot.q2 \\Dec:=3),"
             " Round(got.rot.q3 \\Dec:=3), Round(got.rot.q4 \\Dec:=3)];"
             " n := Sqrt(got.rot.q1 * got.rot.q1 + got.rot.q2 * got.rot.q2 + got.rot.q3 *"
             " got.rot.q3 + got.rot.q4 * got.rot.q4); ConfL \\Off;"
             " MoveL got, v100, fine, tool0; o := NOrient([0.5, 0.5, 0.5, 0.52]);"
             " got.rot := [1.2, 0, 0, 0]; MoveL got, v100, fine, tool0;",
             "VAR robtarget got; VAR num n; VAR orient o;", world=world)
    t.run()
    assert value(t, "n") != 1.0 and abs(value(t, "n") - 1) < 1e-3  # 3 decimals: not unit
    assert world.arrivals == 2  # the orient read back with 3 decimals was taken
    assert float(np.linalg.norm(wxyz(SimpleNamespace(f={"rot": value(t, "o")})))) == \
        pytest.approx(1, abs=1e-6)
    assert "ERR_ARGVALERR" in t.stop_reason and "unusable" in t.stop_reason


# ------------------------------------------------------------------ MoveC, ConfL, SingArea
def test_movec_ends_at_its_to_point_and_refuses_points_too_close_or_on_a_line():
    world = make_world(None, None)
    t = task(absj(0, 20, 10, 0, 60, 0) + " ConfL \\Off; SingArea \\Wrist; start := CRobT();"
             " via := Offs(start, 30, 30, 0); goal := Offs(start, 0, 60, 0);"
             " MoveC via, goal, v100, fine, tool0; got := CRobT();"
             " Circle Offs(goal, 0.05, 0, 0), start; Circle Offs(goal, 10, 0, 0), Offs(goal, 20,"
             " 0, 0);",
             "VAR robtarget start; VAR robtarget via; VAR robtarget goal; VAR robtarget got;"
             " VAR num err{2}; VAR num k;",
             "PROC Circle(robtarget a, robtarget b)\n Incr k;\n MoveC a, b, v100, fine, tool0;\n"
             "ERROR\n err{k} := ERRNO;\n RETURN;\nENDPROC", world=world)
    t.run()
    assert t.stop_reason.startswith("program ended"), t.stop_reason
    assert xyz(value(t, "got")) == pytest.approx(xyz(value(t, "start")) + np.array([0, 60, 0]),
                                               abs=1e-3)
    assert list(value(t, "err").items) == [ERRNUMS["ERR_ARGVALERR"]] * 2
    assert t.services["motion"].sing_area == "wrist"


def test_with_confl_off_a_move_keeps_the_arms_branch_and_with_it_on_takes_the_targets():
    start = np.array([0, 20, 10, 30, 60, -40])
    moved = []
    for cfx in range(8):
        world = make_world(None, None)
        t = task(absj(*start) + " p := Offs(CRobT(), 10, 0, 0);"
                 f" p.robconf.cfx := {cfx}; ConfL \\Off; MoveL p, v100, fine, tool0;"
                 " off := CJointT(); ConfL \\On; MoveL Offs(p, -10, 0, 0), v100, fine, tool0;"
                 " on := CJointT();\nERROR\n err := ERRNO;",
                 "VAR robtarget p; VAR jointtarget off; VAR jointtarget on; VAR num err;",
                 world=world)
        t.run()
        off = np.array(list(value(t, "off").f["robax"].f.values()))
        assert np.max(np.abs(off - start)) < 5  # whatever the confdata: near where it was
        if value(t, "err") == 0:
            on = np.array(list(value(t, "on").f["robax"].f.values()))
            moved.append(float(np.max(np.abs(on - start))))
        else:
            assert value(t, "err") in (ERRNUMS["ERR_OUTSIDE_REACH"], ERRNUMS["ERR_ROBLIMIT"])
    assert min(moved) < 5 and max(moved) > 30  # on: the confdata's branch, its own or another


# ------------------------------------------------------------------ errors, GOTO
def test_long_jmp_all_err_catches_a_callees_error_and_retry_calls_it_again():
    t = task("Deep; done := TRUE;\nERROR (LONG_JMP_ALL_ERR)\n seen := ERRNO; RETRY;",
             "VAR num tries; VAR num seen; VAR bool done;",
             "PROC Deep()\n Incr tries;\n IF tries < 3 Inner;\nENDPROC\n"
             "PROC Inner()\n VAR num x;\n x := 1 / 0;\nENDPROC")
    t.run()
    assert value(t, "done") is True and value(t, "tries") == 3
    assert value(t, "seen") == ERRNUMS["ERR_DIVZERO"]


def test_goto_jumps_back_and_forward_and_never_into_a_block():
    t = task("again:\n n := n + 1;\n IF n < 5 THEN\n WHILE TRUE DO\n GOTO again;\n ENDWHILE\n"
             " ENDIF\n IF n = 5 GOTO done;\n n := 100;\n done:", "VAR num n;")
    t.run()
    assert value(t, "n") == 5
    with pytest.raises(LoadError, match=r"T.mod:5: GOTO inside: no label inside"):
        task("n := 1;\n GOTO inside;\n IF n = 1 THEN\n inside:\n ENDIF", "VAR num n;")
    with pytest.raises(LoadError, match="label twice declared twice"):
        task("twice:\n twice:", "")


# ------------------------------------------------------------------ several modules
def write(folder: Path, name: str, text: str) -> Path:
    folder.mkdir(parents=True, exist_ok=True)
    (folder / name).write_text(text)
    return folder / name


def test_a_task_folder_loads_its_modules_together(tmp_path):
    progmod, sysmod = tmp_path / "TASK1" / "PROGMOD", tmp_path / "TASK1" / "SYSMOD"
    write(progmod, "Main.mod", "MODULE Main\nPERS num shared;\nPROC main()\n"
          " total := Twice(shared) + offset;\nENDPROC\nENDMODULE\n")
    write(progmod, "Helpers.mod", "MODULE Helpers\nVAR num total;\nPERS num shared := 21;\n"
          "FUNC num Twice(num x)\n RETURN 2 * x;\nENDFUNC\nENDMODULE\n")
    write(sysmod, "user.sys", "MODULE user(SYSMODULE)\nCONST num offset := base + 1;\n"
          "CONST num base := 1;\nENDMODULE\n")
    files = module_files([tmp_path / "TASK1"])
    assert [f.name for f in files] == ["Helpers.mod", "Main.mod", "user.sys"]
    (text, path), *more = [(f.read_text(), str(f)) for f in files]
    t = Task(text, path, modules=more)
    t.run()
    assert t.stop_reason.startswith("program ended"), t.stop_reason
    assert value(t, "total") == 44 and t.path.endswith("Main.mod")


def test_a_name_declared_twice_is_refused_and_a_backup_of_several_tasks_named(tmp_path):
    write(tmp_path, "A.mod", "MODULE A\nPROC main()\n Helper;\nENDPROC\nENDMODULE\n")
    write(tmp_path, "B.mod", "MODULE B\nPROC Helper()\nENDPROC\nENDMODULE\n")
    write(tmp_path, "Unused.mod", "MODULE Unused\nPROC Helper()\nENDPROC\nENDMODULE\n")
    with pytest.raises(LoadError, match=r"Unused.mod:2: Helper is declared again \(first in "
                       r".*B.mod\)"):
        Task((tmp_path / "A.mod").read_text(), "A.mod", modules=[
            ((tmp_path / n).read_text(), str(tmp_path / n)) for n in ("B.mod", "Unused.mod")])
    for task_name in ("T_ROB1", "T_ROB2"):
        write(tmp_path / "backup" / "RAPID" / task_name / "PROGMOD", "M.mod",
              "MODULE M\nENDMODULE\n")
    with pytest.raises(LoadError, match="2 tasks in this folder \\(T_ROB1, T_ROB2\\)"):
        module_files([tmp_path / "backup"])
    assert [f.name for f in module_files([tmp_path / "backup" / "RAPID" / "T_ROB2"])] == \
        ["M.mod"]
    (tmp_path / "empty").mkdir()
    with pytest.raises(LoadError, match="no RAPID module in this folder"):
        module_files([tmp_path / "empty"])


async def test_the_emulator_takes_several_modules_and_names_their_errors_with_their_file(
        tmp_path):
    write(tmp_path, "Main.mod", "MODULE Main\nPROC main()\n Fail;\nENDPROC\nENDMODULE\n")
    write(tmp_path, "Lib.mod", "MODULE Lib\nPROC Fail()\n VAR num x;\n x := 1 / 0;\n"
          "ENDPROC\nENDMODULE\n")
    emu = IRC5Emulator(make_world(None, None), EmulatorSettings(
        time_scale=0.0, program=[tmp_path / "Main.mod", tmp_path / "Lib.mod"]))
    with pytest.raises(Exception, match=r"ERR_DIVZERO at .*Lib.mod:4"):
        await emu.start("127.0.0.1", 0)


# ------------------------------------------------------------------ open_abb, when fetched
OPEN_ABB = Path("/tmp/open_abb")
PYTHON2 = Path("/root/.pyenv/versions/2.7.18/bin/python")


@pytest.mark.slow
@pytest.mark.skipif(not (OPEN_ABB / "RAPID" / "SERVER.mod").is_file() or not PYTHON2.is_file(),
                    reason="robotics/open_abb not fetched into /tmp/open_abb, or no Python 2.7")
async def test_open_abbs_server_and_its_python_client_when_fetched(tmp_path):
    import json
    import subprocess

    port = free_port()
    emu = IRC5Emulator(make_world(None, None), EmulatorSettings(
        time_scale=0.0, program=OPEN_ABB / "RAPID" / "SERVER.mod",
        assignments={"serverPort": str(port)}))
    await emu.start("127.0.0.1", 0)
    client = OPEN_ABB / "abb_node" / "packages" / "abb_communications"
    script = (
        "import sys, time, json\n"
        f"sys.path.insert(0, {str(client)!r})\n"
        "import abb\n"
        "for s in range(4):\n"
        f"    r = abb.Robot(ip='127.0.0.1', port_motion={port})\n"
        "    r.set_joints([10, 20, 10, 0, 40, 10]); j = r.get_joints()\n"
        "    p = r.get_cartesian()\n"
        "    r.set_cartesian([[p[0][0] + 50, p[0][1], p[0][2] - 20], p[1]])\n"
        "    q = r.get_cartesian()\n"
        "    r.move_circular([[q[0][0] + 30, q[0][1] + 30, q[0][2]], q[1]],"
        " [[q[0][0], q[0][1] + 60, q[0][2]], q[1]])\n"
        "    c = r.get_cartesian()\n"
        "    r.set_tool([[0, 0, 100], [1, 0, 0, 0]]); t = r.get_cartesian()\n"
        "    r.set_workobject([[100, 0, 0], [1, 0, 0, 0]]); w = r.get_cartesian()\n"
        "    print(json.dumps([j, p, q, c, t, w]))\n"
        "    r.close(); time.sleep(0.2)\n")
    try:
        done = await asyncio.to_thread(subprocess.run, [str(PYTHON2), "-c", script],
                                       capture_output=True, text=True, timeout=120)
        assert done.returncode == 0, done.stderr
        sessions = [json.loads(line) for line in done.stdout.splitlines()]
        assert len(sessions) == 4 and emu.running, (done.stdout, emu.task.stop_reason)
        for j, p, q, c, t, w in sessions:
            assert j == pytest.approx([10, 20, 10, 0, 40, 10], abs=0.01)
            assert q[0] == pytest.approx([p[0][0] + 50, p[0][1], p[0][2] - 20], abs=0.1)
            assert c[0] == pytest.approx([q[0][0], q[0][1] + 60, q[0][2]], abs=0.1)
            assert float(np.linalg.norm(np.subtract(t[0], c[0]))) == pytest.approx(100, abs=0.1)
            assert w[0] == pytest.approx([t[0][0] - 100, t[0][1], t[0][2]], abs=0.01)
    finally:
        await emu.stop()


# ------------------------------------------------------------------ rawbytes, \Data, dates, zones
def test_raw_bytes_and_byte_arrays_go_over_the_socket_packed_as_the_program_says():
    port = free_port()
    t = task(f"SocketCreate srv; SocketBind srv, \"127.0.0.1\", {port}; SocketListen srv;"
             " SocketAccept srv, cli \\Time:=5;"
             " SocketReceive cli \\RawData:=raw \\ReadNoOfBytes:=11 \\Time:=5;"
             " UnpackRawBytes raw \\Network, 1, n \\IntX:=UINT;"
             " UnpackRawBytes raw, 3, f \\Float4; UnpackRawBytes raw, 7, s \\ASCII:=3;"
             " UnpackRawBytes raw, 10, h \\Hex1; UnpackRawBytes raw, 11, i \\IntX:=SINT;"
             " ClearRawBytes out; PackRawBytes n + 1, out \\Network, 1, \\IntX:=UDINT;"
             " PackRawBytes f * 2, out, RawBytesLen(out) + 1, \\Float4;"
             " PackRawBytes \"ok\", out, RawBytesLen(out) + 1, \\ASCII;"
             " CopyRawBytes raw, 10, out, RawBytesLen(out) + 1 \\NoOfBytes:=2;"
             " PackRawBytes StrToByte(\"A\" \\Char), out, RawBytesLen(out) + 1 \\Hex1;"
             " a := ByteToStr(StrToByte(\"1F\" \\Hex) \\Bin) + ByteToStr(10 \\Hex);"
             " SocketSend cli \\RawData:=out; len := RawBytesLen(out);"
             " SocketReceive cli \\Data:=bytes \\ReadNoOfBytes:=3 \\Time:=5;"
             " bytes{4} := 255; SocketSend cli \\Data:=bytes \\NoOfBytes:=4;",
             "VAR socketdev srv; VAR socketdev cli; VAR rawbytes raw; VAR rawbytes out;"
             " VAR num n; VAR num f; VAR string s; VAR byte h; VAR num i; VAR num len;"
             " VAR string a; VAR byte bytes{6};")
    import struct
    import threading

    thread = threading.Thread(target=t.run)
    thread.start()
    try:
        assert t.services["network"].listen_event.wait(5)
        with socket.create_connection(("127.0.0.1", port), timeout=5) as c:
            c.sendall(struct.pack(">H", 513) + struct.pack("<f", 1.5) + b"abc" + b"\x7f\xfe")
            got = b""
            while len(got) < 13:
                got += c.recv(64)
            c.sendall(bytes([1, 2, 3]))
            back = c.recv(64)
    finally:
        thread.join(10)
        t.services["network"].shutdown()
    assert t.stop_reason.startswith("program ended"), t.stop_reason
    assert (value(t, "n"), value(t, "f"), value(t, "s"), value(t, "h"), value(t, "i")) == \
        (513, 1.5, "abc", 0x7F, -2)
    assert got == struct.pack(">I", 514) + struct.pack("<f", 3.0) + b"ok" + b"\x7f\xfeA"
    assert value(t, "len") == 13 and back == bytes([1, 2, 3, 255])
    assert value(t, "a") == "000111110A"


def test_dates_clocks_and_world_zones():
    t = task("d := CDate(); c := CTime(); h := GetTime(\\Hour); ClkStart k; WaitTime 0.05;"
             " e := ClkRead(k \\HighRes); WZBoxDef \\Inside, box, [0, 0, 0], [100, 100, 100];"
             " WZLimSup \\Temp, zone, box; WZBoxDef \\Inside, box, [0, 0, 0], [10, 10, 10];",
             "VAR string d; VAR string c; VAR num h; VAR clock k; VAR num e;"
             " VAR shapedata box; VAR wztemporary zone;")
    assert t.log.count(containing="World Zones") == 1  # the declarations, once
    t.run()
    import re

    assert re.fullmatch(r"\d{4}-\d\d-\d\d", value(t, "d"))
    assert re.fullmatch(r"\d\d:\d\d:\d\d", value(t, "c")) and 0 <= value(t, "h") < 24
    assert 0.04 < value(t, "e") < 1
    assert t.log.count(containing="World Zones") == 1  # and not again when they run


def test_the_command_runs_a_foreign_program_where_its_data_say(tmp_path):
    import signal

    from tests.simulators.test_emulator_cli import start

    port = free_port()
    proc, line = start(["irc5", "--time-scale", "0", "--port", "0", "--program", str(LINK),
                        "--set", f"linkPort={port}", "--verbose"])
    try:
        assert line.strip() == f"irc5 emulator on 127.0.0.1:{port}", line
        with socket.create_connection(("127.0.0.1", port), timeout=5) as c:
            c.sendall(b"04 #")
            assert c.recv(64).decode().split()[:2] == ["4", "1"]
    finally:
        proc.send_signal(signal.SIGINT)
        _, err = proc.communicate(timeout=30)
    assert proc.returncode == 0, err
    assert "note: --port 0 is ScrewcalServer's" in err
    bad = subprocess_run(["irc5", "--port", "0", "--program", str(LINK), "--set", "linkPort"])
    assert bad.returncode == 2 and "expected NAME=VALUE" in bad.stderr


def test_the_command_names_the_option_and_the_value_a_program_cannot_take():
    """A value is checked against its datum's type at load, after the arguments: its error
    reads as the arguments' own (the option and the item), not as a file's line."""
    for item, why in (("linkPort=five", "not a num value (no data named five)"),
                      ("nothere=1", f"no data named nothere to set in {LINK}")):
        bad = subprocess_run(["irc5", "--port", "0", "--time-scale", "0",
                              "--program", str(LINK), "--set", item])
        assert bad.returncode == 2, bad.stderr
        assert bad.stderr.strip() == \
            f"screwcal emulator irc5: error: argument --set: {item!r}: {why}", bad.stderr


def subprocess_run(args: list[str]):
    import subprocess

    from tests.simulators.test_emulator_cli import EXE

    return subprocess.run([*EXE, *args], capture_output=True, text=True, timeout=60)


# ------------------------------------------------------------------ records, Present, WaitUntil
def test_a_tasks_records_and_aliases_are_data_types_of_its_values():
    t = Task("MODULE Types\nRECORD waypoint\n robtarget p;\n num speed;\n wobjdata where;\n"
             "ENDRECORD\nALIAS waypoint stop;\nALIAS num counter;\n"
             "PERS stop route{2} := [[[[1, 2, 3], [1, 0, 0, 0], [0, 0, 0, 0], [9E9, 9E9, 9E9,"
             " 9E9, 9E9, 9E9]], 100, [FALSE, TRUE, \"\", [[0, 0, 0], [1, 0, 0, 0]], [[0, 0, 0],"
             " [1, 0, 0, 0]]]], [[[4, 5, 6], [1, 0, 0, 0], [0, 0, 0, 0], [9E9, 9E9, 9E9, 9E9,"
             " 9E9, 9E9]], 200, [FALSE, TRUE, \"\", [[0, 0, 0], [1, 0, 0, 0]], [[0, 0, 0],"
             " [1, 0, 0, 0]]]]];\nVAR counter n;\nVAR waypoint copy;\n"
             "PROC main()\n copy := route{2};\n copy.p.trans.x := 40;\n"
             " n := route{1}.speed + copy.speed + copy.p.trans.x;\nENDPROC\nENDMODULE\n", "T.mod")
    t.run()
    assert t.stop_reason.startswith("program ended"), t.stop_reason
    assert value(t, "n") == 340 and xyz(value(t, "route").items[1].f["p"]) == \
        pytest.approx([4, 5, 6])  # a record is a value: the copy changed, not the array
    with pytest.raises(LoadError, match=r"T\.mod:2: data type pose is declared again"):
        Task("MODULE T\nRECORD pose\n num x;\nENDRECORD\nENDMODULE\n", "T.mod")
    with pytest.raises(LoadError, match=r"T\.mod:3: unknown data type nothing"):
        Task("MODULE T\nRECORD r\n nothing x;\nENDRECORD\nENDMODULE\n", "T.mod")


def test_present_and_waituntil():
    t = task("Opt; Opt \\limit:=3; WaitUntil k >= 0 \\MaxTime:=0.2 \\TimeFlag:=late;"
             " ClkStart c; WaitUntil ClkRead(c) > 0.15 \\PollRate:=0.05 \\MaxTime:=2;"
             " e := ClkRead(c); WaitUntil FALSE \\MaxTime:=0.1 \\TimeFlag:=never; WaitUntil FALSE"
             " \\MaxTime:=0.1;",
             "VAR num k; VAR bool late := TRUE; VAR bool never; VAR clock c; VAR num e;"
             " VAR num given{2};",
             "PROC Opt(\\num limit)\n Incr k;\n IF Present(limit) THEN\n given{k} := limit;\n"
             " ELSE\n given{k} := -1;\n ENDIF\nENDPROC")
    t.run()
    assert list(value(t, "given").items) == [-1, 3]
    assert value(t, "late") is False and value(t, "never") is True
    assert 0.15 < value(t, "e") < 1.0
    assert "ERR_WAIT_MAXTIME" in t.stop_reason


def test_the_issues_work_object_case_a_move_to_500_0_500_in_oframe_x_plus_100():
    """Issue 37: with oframe x+100, CRobT read [600, 0, 500] for [500, 0, 500] and a MoveL to
    [500, 0, 500] went to base [500, 0, 500] (the work object ignored)."""
    world = make_world(None, None)
    t = task("MoveL [[500, 0, 500], [0, 0, 1, 0], [0, 0, 0, 0], [9E9, 9E9, 9E9, 9E9, 9E9, 9E9]],"
             " v100, fine, tool0 \\WObj:=shifted; inside := CRobT(\\Tool:=tool0 \\WObj:=shifted);"
             " base := CRobT(\\Tool:=tool0 \\WObj:=wobj0);",
             "PERS wobjdata shifted := [FALSE, TRUE, \"\", [[0, 0, 0], [1, 0, 0, 0]], [[100, 0,"
             " 0], [1, 0, 0, 0]]]; VAR robtarget inside; VAR robtarget base;", world=world)
    t.run()
    assert t.stop_reason.startswith("program ended"), t.stop_reason
    assert flange(world)[:3, 3] == pytest.approx([600, 0, 500], abs=1e-3)
    assert xyz(value(t, "inside")) == pytest.approx([500, 0, 500], abs=1e-3)
    assert xyz(value(t, "base")) == pytest.approx([600, 0, 500], abs=1e-3)


def test_a_conditional_argument_is_passed_only_when_the_callers_own_is_present():
    t = task("Outer; Outer \\limit:=4 \\fast;",
             "VAR num seen{4}; VAR num k;",
             "PROC Outer(\\num limit \\switch fast)\n Inner \\limit?limit \\fast?fast;\n"
             " Inner \\limit?limit;\nENDPROC\n"
             "PROC Inner(\\num limit \\switch fast)\n Incr k;\n seen{k} := -1;\n"
             " IF Present(limit) seen{k} := limit;\n IF Present(fast) seen{k} := seen{k} + 100;\n"
             "ENDPROC")
    t.run()
    assert t.stop_reason.startswith("program ended"), t.stop_reason
    assert list(value(t, "seen").items) == [-1, -1, 104, 4]


def test_an_optional_argument_the_interpreter_does_not_implement_is_refused_at_load():
    with pytest.raises(LoadError, match=r"T\.mod:5: MoveL \\Corr is not implemented"):
        task("MoveL [[500, 0, 500], [0, 0, 1, 0], [0, 0, 0, 0], [9E9, 9E9, 9E9, 9E9, 9E9, 9E9]],"
             " v100, z10, tool0\n \\Corr;")
    with pytest.raises(LoadError, match=r"T\.mod:5: TPWrite \\Bool is not implemented"):
        task("x := 1;\n TPWrite \"on\" \\Bool:=TRUE;", "VAR num x;")
    with pytest.raises(LoadError, match=r"CRobT \\TaskName is not implemented"):
        task("p := CRobT(\\TaskName:=\"T_ROB1\");", "VAR robtarget p;")
    t = task("MoveL [[500, 0, 500], [0, 0, 1, 0], [0, 0, 0, 0], [9E9, 9E9, 9E9, 9E9, 9E9, 9E9]],"
             " v100 \\V:=300, z10 \\Z:=5, tool0 \\WObj:=wobj0;")  # timing and path: accepted
    t.run()
    assert t.stop_reason.startswith("program ended"), t.stop_reason


def test_local_data_and_routines_are_their_modules_own():
    main = ("MODULE Main\nVAR num posTemp := 1;\nVAR num got{4};\nPROC main()\n"
            " got{1} := posTemp;\n got{2} := Other();\n Helper;\n got{4} := Twice(2);\nENDPROC\n"
            "LOCAL FUNC num Twice(num x)\n RETURN 2 * x;\nENDFUNC\nENDMODULE\n")
    other = ("MODULE Dummy\nLOCAL VAR num posTemp := 10;\nLOCAL CONST num stride := posTemp + 5;\n"
             "FUNC num Other()\n RETURN posTemp + stride;\nENDFUNC\n"
             "PROC Helper()\n VAR num posTemp := 100;\n got{3} := posTemp + Twice(1);\nENDPROC\n"
             "LOCAL FUNC num Twice(num x)\n RETURN 3 * x;\nENDFUNC\nENDMODULE\n")
    t = Task(main, "Main.mod", modules=[(other, "Dummy.mod")])
    t.run()
    assert t.stop_reason.startswith("program ended"), t.stop_reason
    # the global posTemp; Dummy's own (10 + 15); Helper's own with Dummy's Twice; Main's Twice
    assert list(value(t, "got").items) == [1, 25, 103, 4]
    for twice in ("LOCAL VAR num x;\nLOCAL VAR num x;", "VAR num x;\nLOCAL VAR num x;",
                  "LOCAL VAR num x;\nLOCAL PROC x()\nENDPROC"):
        with pytest.raises(LoadError, match=r"Dummy\.mod:3: x is declared again"):
            Task(main, "Main.mod", modules=[(f"MODULE Dummy\n{twice}\nENDMODULE\n",
                                             "Dummy.mod")])


def test_trigonometry_in_degrees_and_pow():
    t = task("a{1} := Sin(30); a{2} := Cos(60); a{3} := Tan(45); a{4} := ASin(0.5);"
             " a{5} := ACos(0.5); a{6} := ATan(1); a{7} := Exp(0); a{8} := Pow(2, 10);"
             " a{9} := ASin(2);", "VAR num a{9};")
    t.run()
    assert list(value(t, "a").items)[:8] == pytest.approx([0.5, 0.5, 1, 30, 60, 45, 1, 1024])
    assert "ERR_ARGVALERR" in t.stop_reason and "ASin(2)" in t.stop_reason
