"""Benchmark: screwcal's kinematics beside the peers', in one interpreter (issue 14).

    pip install -e '.[peers]'          # roboticstoolbox-python, pybotics, ikpy (optional extra)
    .venv/bin/python benchmarks/peers.py [--rounds 7]

The same IRB 1600 in every library (from screwcal's own DH / screw description), checked to give
the same flange pose first; then interleaved rounds (every library once per round, so a noisy
host slows all alike), medians: FK of one pose per call, FK of 10,000 poses, and IK of one pose
per call (screwcal: closed form, all eight branches; rtb: its C++ `ik_LM`, warm start near the
answer; pybotics: its numerical `ik`; ikpy: its scipy-based `inverse_kinematics`). A peer that is
not installed is skipped and said so. Ratios are what to quote: the host is shared.
"""

from __future__ import annotations

# isort: off
# isort: on
import argparse
import statistics
import time
from collections.abc import Callable

import numpy as np

from screwcal.kinematics.dh import dh_from_model
from screwcal.kinematics.forward import forward_kinematics
from screwcal.kinematics.ik import closed_form_ik
from screwcal.kinematics.robots import irb1600

Case = dict[str, Callable[[], object]]


def _per_call(fn: Callable[[], object], calls: int) -> float:
    start = time.perf_counter()
    for _ in range(calls):
        fn()
    return (time.perf_counter() - start) / calls


def build_cases() -> tuple[dict[str, Case], list[str]]:
    model = irb1600()
    rng = np.random.default_rng(0)
    lo = np.maximum(0.8 * model.limits[:, 0], -2.8)  # inside every library's default limits
    hi = np.minimum(0.8 * model.limits[:, 1], 2.8)
    q_batch = rng.uniform(lo, hi, (10_000, 6))
    q1 = q_batch[:1]
    T1 = forward_kinematics(model, q1)[0]
    ours_T = forward_kinematics(model, q_batch[:20])
    cases: dict[str, Case] = {"screwcal": {
        "FK one pose": lambda: forward_kinematics(model, q1),
        "FK 10,000 poses": lambda: forward_kinematics(model, q_batch),
        "IK one pose": lambda: closed_form_ik(model, T1[None]),
    }}
    skipped = []
    dh, mdh = dh_from_model(model, "dh"), dh_from_model(model, "mdh")

    def check(name: str, poses: np.ndarray) -> None:
        err = np.abs(poses[:, :3, 3] - ours_T[:, :3, 3]).max()
        if err > 1e-6:
            raise SystemExit(f"{name} disagrees with screwcal by {err:.3g} mm: not the same robot")

    try:
        import roboticstoolbox as rtb

        robot = rtb.DHRobot([rtb.RevoluteDH(d=r.d_mm, a=r.a_mm, alpha=r.alpha, offset=r.theta)
                             for r in dh.rows])
        ets = robot.ets()
        check("rtb", np.array([ets.eval(q) @ dh.dh_flange for q in q_batch[:20]]))
        T1_dh = T1 @ np.linalg.inv(dh.dh_flange)
        q_near = q1[0] + 0.05
        cases["roboticstoolbox"] = {
            "FK one pose": lambda: ets.eval(q1[0]),
            "FK 10,000 poses": lambda: ets.eval(q_batch),
            "IK one pose": lambda: ets.ik_LM(T1_dh, q0=q_near),
        }
    except ImportError:
        skipped.append("roboticstoolbox-python")
    try:
        from pybotics.kinematic_chain import MDHKinematicChain
        from pybotics.robot import Robot

        table = np.array([[r.alpha, r.a_mm, r.theta, r.d_mm] for r in mdh.rows])
        probot = Robot(MDHKinematicChain(table))
        check("pybotics", np.array([probot.fk(q) @ mdh.dh_flange for q in q_batch[:20]]))
        T1_mdh = T1 @ np.linalg.inv(mdh.dh_flange)
        cases["pybotics"] = {
            "FK one pose": lambda: probot.fk(q1[0]),
            "FK 10,000 poses": lambda: [probot.fk(q) for q in q_batch],
            "IK one pose": lambda: probot.ik(T1_mdh, q=q1[0] + 0.05),
        }
    except ImportError:
        skipped.append("pybotics")
    try:
        from ikpy.chain import Chain
        from ikpy.link import OriginLink, URDFLink

        links = [OriginLink()]
        previous = np.zeros(3)
        for i in range(6):
            point = model.axis_points_mm[i]
            links.append(URDFLink(name=f"j{i + 1}", origin_translation=point - previous,
                                  origin_orientation=np.zeros(3), rotation=model.axis_dirs[i]))
            previous = point
        links.append(URDFLink(name="flange", origin_translation=model.home_flange[:3, 3] - previous,
                              origin_orientation=np.array([0.0, np.pi / 2, 0.0]),
                              joint_type="fixed"))
        chain = Chain(links, active_links_mask=[False] + [True] * 6 + [False])

        def full(q: np.ndarray) -> np.ndarray:
            return np.r_[0.0, q, 0.0]

        check("ikpy", np.array([chain.forward_kinematics(full(q)) for q in q_batch[:20]]))
        cases["ikpy"] = {
            "FK one pose": lambda: chain.forward_kinematics(full(q1[0])),
            "FK 10,000 poses": lambda: [chain.forward_kinematics(full(q)) for q in q_batch],
            "IK one pose": lambda: chain.inverse_kinematics_frame(
                T1, initial_position=full(q1[0] + 0.05), orientation_mode="all"),
        }
    except ImportError:
        skipped.append("ikpy")
    return cases, skipped


CALLS = {"FK one pose": 2000, "FK 10,000 poses": 1, "IK one pose": 100}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--rounds", type=int, default=7)
    args = parser.parse_args()
    cases, skipped = build_cases()
    times: dict[tuple[str, str], list[float]] = {}
    for _ in range(args.rounds):  # interleaved: every library once per round
        for lib, fns in cases.items():
            for what, fn in fns.items():
                calls = CALLS[what] if not (lib != "screwcal" and what == "FK 10,000 poses"
                                            and lib in ("pybotics", "ikpy")) else 1
                times.setdefault((lib, what), []).append(_per_call(fn, calls))
    print(f"{'':<22}" + "".join(f"{lib:>18}" for lib in cases))
    for what in CALLS:
        cells = []
        ours = statistics.median(times[("screwcal", what)])
        for lib in cases:
            t = statistics.median(times[(lib, what)])
            rate = (f"{10_000 / t / 1e6:.2f} M/s" if what.startswith("FK 10,000")
                    else f"{t * 1e6:.1f} us")
            cells.append(f"{rate} ({t / ours:.2g}x)" if lib != "screwcal" else rate)
        print(f"{what:<22}" + "".join(f"{c:>18}" for c in cells))
    print("(x: the peer's time over screwcal's; medians of "
          f"{args.rounds} interleaved rounds)")
    if skipped:
        print("not installed, skipped: " + ", ".join(skipped) + " (pip install -e '.[peers]')")


if __name__ == "__main__":
    main()
