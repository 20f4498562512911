"""`screwcal emulator irc5|arm`: the emulators as processes, until interrupted.

    screwcal emulator irc5 --host 127.0.0.1 --port 4012 [--errors FILE | --seed N]
                           [--time-scale X] [--world FILE] [--arm-port P]
                           [--realism ideal|typical|harsh | --realism-file FILE]
                           [--realism-seed N] [--payload-kg KG --payload-cog-mm X,Y,Z]
                           [--list-payload CAL=KG[:X,Y,Z] --list-payload PERF=KG[:X,Y,Z]]
                           [--program FILE.mod|DIR ...] [--set NAME=VALUE ...] [--verbose]
    screwcal emulator arm --port PORT [--world FILE] [--pty]
    (both: [--arm-faults duplicate=P,late=P,stale=P])
    screwcal emulator tracker --port PORT [--world FILE] [--stand-mm X Y Z]
    (irc5 --tracker-port P, and tracker: [--tracker-faults beam=K,beam_n=N,drop=K,uninit=K,warm=K])

The IRC5 executes the RAPID module users load on a real controller (ScrewcalServer.mod, or a
cell's adapted copy given by --program) in the RAPID interpreter; --verbose prints its event log
(what the FlexPendant shows) as it is written. --program also runs other people's programs:
several modules (repeat it) or a task folder; such a program keeps its own data (its address
and port) unless --set NAME=VALUE gives them; what the interpreter does not implement is
refused at load with its line. Each prints its bound address on one line
(`--port 0` picks a free port). The true robot is the nominal IRB 1600 with the thesis's Table
11 errors, or the virtual-joint errors of a JSON file ({"J1rz": 2.0, ...}), or a whole model
file (any full-model errors), or random errors from a seed. Beyond its geometry the true robot
has what real ones have (`--realism`, default ideal: nothing more): joint compliance under its
own masses and payload, backlash, read-back lag, thermal drift over its running time and
repeatability error (simulators/realism.py says each effect, its units and the published figures
the presets follow); a realism file is a JSON such as {"preset": "typical", "backlash_deg": [0,
0.01, 0, 0, 0, 0], "payload_kg": 10}. The arm runs in the IRC5 process (`--arm-port`) or in its
own, following the world file the IRC5 process writes: `--world FILE`, or by default a new
private folder per run, whose file the IRC5 process prints on its second line. Until a robot is
known the arm answers `$NM ... NO_ROBOT`. The laser tracker (emScon TPI, simulators/tracker.py)
runs the same two ways (`--tracker-port`, or `emulator tracker --world FILE`): it measures one
SMR on the flange from where it stands (--stand-mm, robot frame). Ctrl-C (SIGINT) or
`kill` (SIGTERM) closes the servers and exits 0, also when started in the background by a
script.
"""

from __future__ import annotations

import argparse
import sys
import tempfile
from pathlib import Path
from typing import TYPE_CHECKING

from screwcal.arguments import (
    bounded_int,
    finite_float,
    non_negative_float,
    positive_float,
)

if TYPE_CHECKING:
    import asyncio

    from simulators.realism import Realism


PORT = bounded_int(0, 65535)  # a TCP port; 0: a free one


async def _serve_irc5(args: argparse.Namespace) -> None:

    from simulators.arm import ArmEmulator, WorldFileWriter
    from simulators.irc5 import EmulatorSettings, IRC5Emulator
    from simulators.rapid.program import assignments
    from simulators.truth import make_world

    world = make_world(args.errors, args.seed, realism=realism_of(args),
                       realism_seed=args.realism_seed)
    # One world per run, in the run's private folder (mode 0700), unless --world names one.
    world_file = Path(args.world) if args.world else args.private_dir / "world.json"
    writer = WorldFileWriter(world_file)
    if args.list_payload:  # the operator mounts each list's payload: before anything reads
        from simulators.realism import ListPayloads

        world.observers.append(ListPayloads(lambda: getattr(emu, "list_name", ""),
                                            dict(args.list_payload)))
    world.observers.append(writer)
    writer(world)
    printer = (lambda event: print(f"event log: {event}", flush=True)) if args.verbose \
        else None
    emu = IRC5Emulator(world, EmulatorSettings(speed_deg_s=args.speed_deg_s,
                                               time_scale=args.time_scale,
                                               idle_timeout_s=args.idle_timeout_s,
                                               send_timeout_s=args.send_timeout_s,
                                               program=args.program,
                                               assignments=assignments(args.set)),
                       printer=printer)
    asked = 4012 if args.port is None else args.port
    host, port = await emu.start(args.host, asked)
    if args.port is not None and not emu.own_program:
        print(f"note: --port {args.port} is ScrewcalServer's; this program listens where its own "
              "data say (--set NAME=VALUE changes them)", file=sys.stderr, flush=True)
    line = f"irc5 emulator on {host}:{port}"
    arm = None
    if args.arm_port is not None:
        noise_seed = args.seed if args.noise_seed is None else args.noise_seed
        arm = ArmEmulator(world, seed=noise_seed, faults=args.arm_faults)
        arm_host, arm_port = await arm.start(args.host, args.arm_port)
        line += f"; measuring arm on socket://{arm_host}:{arm_port}"
    tracker = None
    if args.tracker_port is not None:
        from simulators.tracker import TrackerEmulator, WorldSource

        tracker = TrackerEmulator(WorldSource(world, smrs_of(args)), args.stand_mm,
                                  faults=args.tracker_faults, yaw_deg=args.stand_yaw_deg,
                                  seed=args.seed if args.noise_seed is None else args.noise_seed)
        tracker_host, tracker_port = await tracker.start(args.host, args.tracker_port)
        line += f"; laser tracker on emscon://{tracker_host}:{tracker_port}"
    stopped = stop_on_signals()
    print(line, flush=True)
    print(f"world file {world_file} (for `screwcal emulator arm --world`)", flush=True)
    try:
        await stopped.wait()
    finally:
        await emu.stop()
        if arm is not None:
            await arm.stop()
        if tracker is not None:
            await tracker.stop()


async def _serve_arm(args: argparse.Namespace) -> None:
    import errno

    from simulators.arm import ArmEmulator, WorldFileSource

    if not args.world:
        print("warning: no --world: this arm knows no robot and answers NO_ROBOT; pass the "
              "world file the irc5 emulator printed", file=sys.stderr)
    world = Path(args.world) if args.world else args.private_dir / "none.json"
    if world.is_dir():  # named with what --world expects by the CLI's boundary
        raise IsADirectoryError(errno.EISDIR, "is a folder", str(world))
    if not world.parent.is_dir():  # no irc5 emulator can write it there
        raise FileNotFoundError(errno.ENOENT, "no such folder", str(world))
    arm = ArmEmulator(WorldFileSource(world), seed=args.seed, faults=args.arm_faults)
    host, port = await arm.start(args.host, args.port, pty=args.pty)
    line = f"measuring arm on socket://{host}:{port}"
    if arm.pty_path:
        line += f" and {arm.pty_path}"
    stopped = stop_on_signals()
    print(line, flush=True)
    try:
        await stopped.wait()
    finally:
        await arm.stop()


async def _serve_tracker(args: argparse.Namespace) -> None:

    from simulators.tracker import TrackerEmulator, WorldFileSource

    if not args.world:
        print("warning: no --world: this tracker knows no robot and finds no reflector; pass "
              "the world file the irc5 emulator printed", file=sys.stderr)
    world = args.world or str(args.private_dir / "none.json")
    tracker = TrackerEmulator(WorldFileSource(world, smrs_of(args)), args.stand_mm,
                              seed=args.seed, yaw_deg=args.stand_yaw_deg,
                              faults=args.tracker_faults)
    host, port = await tracker.start(args.host, args.port)
    stopped = stop_on_signals()
    print(f"laser tracker on emscon://{host}:{port}", flush=True)
    try:
        await stopped.wait()
    finally:
        await tracker.stop()


def realism_of(args: argparse.Namespace) -> Realism:
    """The realism the options name: a preset or a file, the payload options over either."""
    from dataclasses import replace

    from simulators.realism import PRESETS, read_realism

    realism = read_realism(args.realism_file) if args.realism_file else PRESETS[args.realism]
    if args.payload_kg is not None:
        realism = replace(realism, payload_kg=args.payload_kg,
                          payload_cog_mm=tuple(args.payload_cog_mm))
    return realism


def stop_on_signals() -> asyncio.Event:
    """An event set by SIGINT (Ctrl-C) or SIGTERM (`kill`): the server awaits it, then closes.
    Installed before the address line is printed (a peer may signal as soon as it reads it).

    Installed here rather than left to Python's default: a process started in the background
    by a shell script (`screwcal emulator irc5 &`) inherits SIGINT ignored, and Python then
    installs no handler of its own, so Ctrl-C never reached it; SIGTERM ended it without
    closing anything. The loop removes the handlers when it closes."""
    import asyncio
    import signal

    loop = asyncio.get_running_loop()
    stop = asyncio.Event()
    for sig in (signal.SIGINT, signal.SIGTERM):
        loop.add_signal_handler(sig, stop.set)
    return stop


def _interrupted(signum: int, frame: object) -> None:
    raise KeyboardInterrupt


def run(args: argparse.Namespace) -> int:
    import asyncio  # here, not at the top: `screwcal --help` builds this parser too
    import errno
    import signal

    from screwcal.rapid import RapidSyntaxError
    from simulators.irc5 import ProgramStoppedError
    from simulators.rapid.errors import LoadError, SettingError

    # A signal before the servers' own handlers are in place ends the run as Ctrl-C does, so
    # that the private folder is removed whenever the run ends (stop_on_signals after)
    signal.signal(signal.SIGTERM, _interrupted)
    try:
        serve = {"irc5": _serve_irc5, "arm": _serve_arm, "tracker": _serve_tracker}
        with tempfile.TemporaryDirectory(prefix="screwcal-world-") as private:
            args.private_dir = Path(private)  # the world file when no --world names one
            asyncio.run(serve[args.which](args))
    except KeyboardInterrupt:
        pass
    except SettingError as err:  # known at load only (the datum's type): as argparse says it
        print(f"screwcal emulator {args.which}: error: argument --set: {err.item!r}: "
              f"{err.reason}", file=sys.stderr)
        return 2
    except (LoadError, RapidSyntaxError, ProgramStoppedError) as err:
        print(f"screwcal emulator {args.which}: the RAPID program: {err}", file=sys.stderr)
        return 2
    except OSError as err:
        if err.errno != errno.EADDRINUSE:
            raise
        print(f"screwcal emulator {args.which}: a port asked for is in use (another emulator or "
              "program): choose others with --port/--arm-port (a program's own port with --set "
              "NAME=VALUE), or 0 for free ones",
              file=sys.stderr)
        return 2
    return 0


def add_parser(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("emulator", help="run the IRC5 or measuring-arm emulator",
                       description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    which = p.add_subparsers(dest="which", metavar="DEVICE", required=True)
    irc5 = which.add_parser("irc5", help="the robot controller (wire protocol v1)",
                            description=__doc__,
                            formatter_class=argparse.RawDescriptionHelpFormatter)
    irc5.add_argument("--host", default="127.0.0.1", help="bind address (default 127.0.0.1)")
    irc5.add_argument("--port", type=PORT, default=None,
                      help="TCP port of the wire protocol (default 4012; 0: a free one)")
    errors = irc5.add_mutually_exclusive_group()
    errors.add_argument("--errors", help="JSON of virtual-joint errors, or a true model file")
    errors.add_argument("--seed", type=int, default=None, help="random true errors")
    irc5.add_argument("--time-scale", type=non_negative_float, default=1.0,
                      help="motion time factor (0: instant)")
    irc5.add_argument("--speed-deg-s", type=positive_float, default=60.0,
                      help="joint speed (default 60)")
    irc5.add_argument("--program", type=Path, action="append", default=None,
                      metavar="FILE.mod|DIR",
                      help="a RAPID module of the task, or a folder of them (a backup's TASK "
                      "folder, a .pgf program); repeat for several (default: the shipped "
                      "ScrewcalServer.mod)")
    irc5.add_argument("--set", action="append", default=[], metavar="NAME=VALUE",
                      type=_assignment,
                      help="give a datum of the program this RAPID value at load, e.g. "
                      "--set serverPort=5000 (a program other than ScrewcalServer keeps its "
                      "own address and port otherwise: --host/--port set ScrewcalServer's)")
    irc5.add_argument("--verbose", action="store_true",
                      help="print the controller's event log as it is written")
    irc5.add_argument("--idle-timeout-s", type=positive_float, default=60.0,
                      help="drop an owner that sends nothing (STAT counts) for this long")
    irc5.add_argument("--send-timeout-s", type=positive_float, default=10.0,
                      help="drop an owner that reads nothing of what is sent for this long")
    irc5.add_argument("--noise-seed", type=int, default=None,
                      help="seed of the in-process arm's noise (default: --seed; none: random)")
    irc5.add_argument("--world", help="keep this world file up to date for an arm process "
                      "(default: a new private folder per run, printed on start)")
    irc5.add_argument("--arm-port", type=PORT, default=None,
                      help="also serve the measuring arm on this TCP port")
    _add_arm_faults(irc5)
    irc5.add_argument("--tracker-port", type=PORT, default=None,
                      help="also serve a laser tracker (emScon TPI) on this TCP port")
    _add_tracker(irc5)
    _add_realism(irc5)
    irc5.set_defaults(func=run)
    arm = which.add_parser("arm", help="the measuring arm ($PT lines)", description=__doc__,
                           formatter_class=argparse.RawDescriptionHelpFormatter)
    arm.add_argument("--host", default="127.0.0.1", help="bind address (default 127.0.0.1)")
    arm.add_argument("--port", type=PORT, required=True, help="TCP port of the $PT lines")
    arm.add_argument("--world", help="the world file a running irc5 emulator printed")
    arm.add_argument("--pty", action="store_true", help="also serve a pty (a serial device)")
    arm.add_argument("--seed", type=int, default=None, help="noise seed")
    _add_arm_faults(arm)
    arm.set_defaults(func=run)
    tracker = which.add_parser("tracker", help="a laser tracker (Leica emScon TPI)",
                               description=__doc__,
                               formatter_class=argparse.RawDescriptionHelpFormatter)
    tracker.add_argument("--host", default="127.0.0.1", help="bind address (default 127.0.0.1)")
    tracker.add_argument("--port", type=PORT, required=True,
                         help="TCP port of the TPI (a real tracker's is 700; 0: a free one)")
    tracker.add_argument("--world", help="the world file a running irc5 emulator printed")
    tracker.add_argument("--seed", type=int, default=None, help="noise seed")
    _add_tracker(tracker)
    tracker.set_defaults(func=run)


def smrs_of(args: argparse.Namespace) -> tuple[tuple[float, float, float], ...]:
    """The SMRs on the flange, in tool0: one (positions) or three over the holes (full pose)."""
    from screwcal.calibration.line_of_sight import DEFAULT_SMR_MM, THREE_SMRS_MM

    return THREE_SMRS_MM if args.smrs == 3 else (DEFAULT_SMR_MM,)


def _add_tracker(p: argparse.ArgumentParser) -> None:
    from screwcal.arguments import add_vector
    from screwcal.instrument import TRACKER_STAND_MM

    add_vector(p, "--stand-mm", default=TRACKER_STAND_MM,
               help="where the tracker stands, mm in the robot's base frame (default "
               f"{' '.join(f'{v:g}' for v in TRACKER_STAND_MM)})")
    p.add_argument("--stand-yaw-deg", type=finite_float, default=0.0,
                   help="the tracker's frame turned about the vertical from the robot's (default "
                   "0: its axes the robot base's)")
    p.add_argument("--smrs", type=int, choices=[1, 3], default=1,
                   help="SMRs on the flange: 1 (positions; default) or 3 over the measuring "
                   "flange's holes (full pose; GoPosition points at each)")
    p.add_argument("--tracker-faults", type=_tracker_faults, default=None, metavar="NAME=K,...",
                   help="faults at a measurement attempt K (from 0): beam (broken for beam_n "
                   "attempts, default 3), drop (the connection), uninit (initialisation lost), "
                   "warm (laser warming up), e.g. beam=5,drop=9")


def _tracker_faults(text: str) -> object:
    from simulators.tracker import TrackerFaults

    try:
        return TrackerFaults.parse(text)
    except ValueError as err:
        raise argparse.ArgumentTypeError(str(err)) from None


def _assignment(text: str) -> str:
    from simulators.rapid.errors import SettingError
    from simulators.rapid.program import assignments

    try:
        assignments([text])
    except SettingError as err:
        raise argparse.ArgumentTypeError(f"{err.item!r}: {err.reason}") from None
    return text


def _arm_faults(text: str) -> object:
    from simulators.arm import ArmFaults

    try:
        return ArmFaults.parse(text)
    except ValueError as err:
        raise argparse.ArgumentTypeError(str(err)) from None


def _add_arm_faults(p: argparse.ArgumentParser) -> None:
    p.add_argument("--arm-faults", type=_arm_faults, default=None, metavar="NAME=P,...",
                   help="a careless arm line: probabilities per arrival of a triple sent twice "
                        "(duplicate), late, or a stale re-probe sent later (stale), e.g. "
                        "duplicate=0.3,late=0.2,stale=0.2 (seeded with the noise seed)")


def _add_realism(p: argparse.ArgumentParser) -> None:
    from screwcal.arguments import add_payload_arguments

    realism = p.add_mutually_exclusive_group()
    realism.add_argument("--realism", choices=["ideal", "typical", "harsh"], default="ideal",
                         help="what the true robot has beyond its geometry: ideal (nothing, "
                         "the default), typical (a geometric-only calibration leaves 0.2-0.4 mm, "
                         "as published for the IRB 1600) or harsh (twice typical's effects)")
    realism.add_argument("--realism-file", metavar="FILE",
                         help="JSON: a preset with fields changed, e.g. {\"preset\": "
                         "\"typical\", \"lag\": [0.001, 0.001, 0.001, 0, 0, 0]}")
    p.add_argument("--realism-seed", type=int, default=None,
                   help="seed of the robot's own masses and of its stops (default: --seed)")
    add_payload_arguments(p)
    p.add_argument("--list-payload", type=_list_payload, action="append", default=[],
                   metavar="LIST=KG[:X,Y,Z]",
                   help="the payload mounted while the controller runs list CAL or PERF (the "
                   "operator of a job that calibrates and evaluates under different loads), "
                   "e.g. --list-payload CAL=10:0,0,100 --list-payload PERF=0")


def _list_payload(text: str) -> object:
    from simulators.realism import parse_list_payload

    try:
        return parse_list_payload(text)
    except ValueError as err:
        raise argparse.ArgumentTypeError(str(err)) from None
