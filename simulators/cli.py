"""`screwcal emulator irc5|arm`: the emulators as processes, until interrupted.

    screwcal emulator irc5 --host 127.0.0.1 --port 4012 [--errors FILE | --seed N]
                           [--time-scale X] [--world FILE] [--arm-port P]
    screwcal emulator arm --port PORT [--world FILE] [--pty]

Each prints its bound address on one line (`--port 0` picks a free port). The true robot is the
nominal IRB 1600 with the thesis's Table 11 errors, or the virtual-joint errors of a JSON file
({"J1rz": 2.0, ...}), or a whole model file (any full-model errors), or random errors from a
seed. The arm runs in the IRC5 process (`--arm-port`) or in its own, following the world file
the IRC5 process writes (`--world FILE`, by default screwcal-world.json in the temp folder); until
a robot is known it answers `$NM ... NO_ROBOT`.
"""

from __future__ import annotations

import argparse
import asyncio
import json
import tempfile
from dataclasses import replace
from pathlib import Path

import numpy as np

from screwcal.calibration.virtual_joints import THESIS_TABLE11, apply_virtual_joints
from screwcal.errors import ModelError
from screwcal.kinematics.model import SerialModel
from screwcal.kinematics.modelfile import parse_model
from screwcal.kinematics.robots import irb1600
from screwcal.kinematics.se3 import exp_twist
from simulators.arm import ArmEmulator, WorldFileSource, WorldFileWriter
from simulators.irc5 import EmulatorSettings, IRC5Emulator
from simulators.world import World

# Where the measuring arm stands by default: (500, 0, 600) mm in the robot frame.
DEFAULT_ARM_POSITION_MM = (500.0, 0.0, 600.0)
# Where an irc5 emulator process publishes its world for an arm process, unless --world says.
DEFAULT_WORLD_FILE = Path(tempfile.gettempdir()) / "screwcal-world.json"


def arm_base(arm_position_mm: tuple[float, float, float]) -> np.ndarray:
    """The arm frame <- robot base transform for an arm standing at this robot-frame point."""
    T = np.eye(4)
    T[:3, 3] = -np.asarray(arm_position_mm, dtype=float)
    return T


def random_errors(nominal: SerialModel, seed: int) -> SerialModel:
    """Thesis-like errors drawn from a seed: joint offsets within +-3 deg, link offsets within
    +-0.5 mm, axes tilted by ~0.05 deg and shifted by ~0.2 mm."""
    rng = np.random.default_rng(seed)
    names = ["J1rz", "J2ry", "J3rz", "J4rx", "J5ry", "J6rx"]
    errors = {n: float(rng.uniform(-3, 3)) for n in names}
    errors |= {n: float(rng.uniform(-0.5, 0.5)) for n in ("J1pz", "J1px", "J2pz", "J4px")}
    model = apply_virtual_joints(nominal, errors)
    dirs = model.axis_dirs + rng.normal(0, np.radians(0.05), (6, 3))
    dirs /= np.linalg.norm(dirs, axis=1, keepdims=True)
    return replace(model, axis_dirs=dirs,
                   axis_points_mm=model.axis_points_mm + rng.normal(0, 0.2, (6, 3)),
                   home_flange=exp_twist(np.r_[rng.normal(0, 1e-3, 3), rng.normal(0, 0.2, 3)])
                   @ model.home_flange)


def true_robot(errors_file: str | None, seed: int | None) -> SerialModel:
    nominal = irb1600()
    if errors_file is None:
        return random_errors(nominal, seed) if seed is not None else \
            apply_virtual_joints(nominal, THESIS_TABLE11)
    try:
        doc = json.loads(Path(errors_file).read_text(encoding="utf-8"))
    except (OSError, json.JSONDecodeError) as err:
        raise ModelError(f"{errors_file}: cannot read the errors file ({err})") from None
    if isinstance(doc, dict) and ("representation" in doc or "model" in doc):
        return parse_model(doc, errors_file)  # a whole true model
    if not isinstance(doc, dict) or not all(isinstance(v, int | float) for v in doc.values()):
        raise ModelError(f"{errors_file}: expected {{\"J1rz\": 2.0, ...}} or a model file")
    return apply_virtual_joints(nominal, doc)


def make_world(errors_file: str | None, seed: int | None,
               arm_position_mm: tuple[float, float, float] = DEFAULT_ARM_POSITION_MM) -> World:
    truth = true_robot(errors_file, seed).with_frames(base=arm_base(arm_position_mm))
    return World(nominal=irb1600(), truth=truth)


async def _serve_irc5(args: argparse.Namespace) -> None:
    world = make_world(args.errors, args.seed)
    writer = WorldFileWriter(args.world or DEFAULT_WORLD_FILE)
    world.observers.append(writer)
    writer(world)
    emu = IRC5Emulator(world, EmulatorSettings(speed_deg_s=args.speed_deg_s,
                                               time_scale=args.time_scale,
                                               zero_wait=args.zero_wait))
    host, port = await emu.start(args.host, args.port)
    line = f"irc5 emulator on {host}:{port}"
    arm = None
    if args.arm_port is not None:
        noise_seed = args.seed if args.noise_seed is None else args.noise_seed
        arm = ArmEmulator(world, seed=noise_seed)
        arm_host, arm_port = await arm.start(args.host, args.arm_port)
        line += f"; measuring arm on socket://{arm_host}:{arm_port}"
    print(line, flush=True)
    try:
        await asyncio.Event().wait()
    finally:
        await emu.stop()
        if arm is not None:
            await arm.stop()


async def _serve_arm(args: argparse.Namespace) -> None:
    arm = ArmEmulator(WorldFileSource(args.world or DEFAULT_WORLD_FILE), seed=args.seed)
    host, port = await arm.start(args.host, args.port, pty=args.pty)
    line = f"measuring arm on socket://{host}:{port}"
    if arm.pty_path:
        line += f" and {arm.pty_path}"
    print(line, flush=True)
    try:
        await asyncio.Event().wait()
    finally:
        await arm.stop()


def run(args: argparse.Namespace) -> int:
    try:
        asyncio.run(_serve_irc5(args) if args.which == "irc5" else _serve_arm(args))
    except KeyboardInterrupt:
        pass
    return 0


def add_parser(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("emulator", help="run the IRC5 or measuring-arm emulator",
                       description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    which = p.add_subparsers(dest="which", metavar="DEVICE", required=True)
    irc5 = which.add_parser("irc5", help="the robot controller (wire protocol v1)",
                            description=__doc__,
                            formatter_class=argparse.RawDescriptionHelpFormatter)
    irc5.add_argument("--host", default="127.0.0.1")
    irc5.add_argument("--port", type=int, default=4012)
    errors = irc5.add_mutually_exclusive_group()
    errors.add_argument("--errors", help="JSON of virtual-joint errors, or a true model file")
    errors.add_argument("--seed", type=int, default=None, help="random true errors")
    irc5.add_argument("--time-scale", type=float, default=1.0,
                      help="motion time factor (0: instant)")
    irc5.add_argument("--speed-deg-s", type=float, default=60.0, help="joint speed")
    irc5.add_argument("--zero-wait", action="store_true",
                      help="stop after ZERO for the operator (WAIT 0), as a real IRC5 does")
    irc5.add_argument("--noise-seed", type=int, default=None,
                      help="seed of the in-process arm's noise (default: --seed; none: random)")
    irc5.add_argument("--world", help="keep this world file up to date for an arm process "
                      f"(default {DEFAULT_WORLD_FILE})")
    irc5.add_argument("--arm-port", type=int, default=None,
                      help="also serve the measuring arm on this TCP port")
    irc5.set_defaults(func=run)
    arm = which.add_parser("arm", help="the measuring arm ($PT lines)", description=__doc__,
                           formatter_class=argparse.RawDescriptionHelpFormatter)
    arm.add_argument("--host", default="127.0.0.1")
    arm.add_argument("--port", type=int, required=True)
    arm.add_argument("--world", help="the world file of a running irc5 emulator "
                     f"(default {DEFAULT_WORLD_FILE})")
    arm.add_argument("--pty", action="store_true", help="also serve a pty (a serial device)")
    arm.add_argument("--seed", type=int, default=None, help="noise seed")
    arm.set_defaults(func=run)
