"""Benchmark: screwcal's kinematics beside the peers', in one interpreter (issues 14, 29).

    pip install -e '.[peers]'          # roboticstoolbox-python, pybotics, ikpy (optional extra)
    .venv/bin/python benchmarks/peers.py [--rounds 7] [--batch 10000] [--poses 100000]

The same IRB 1600 in every library (from screwcal's own DH / screw description), checked to give
the same flange pose first. The work of each side:
- FK: the flange pose (4 x 4) of one configuration per call, and of a batch (`--batch` and
  `--poses`; rtb's `ETS.eval` takes the batch in one call, pybotics and ikpy one pose per call,
  so they sit out the large batch).
- IK of one target per call. screwcal: the closed form, all eight branches, each checked by FK
  (its residual), readings inside the joint limits. The peers return one solution: rtb's C++
  `ik_LM` (Levenberg-Marquardt), pybotics's `ik` (scipy least_squares, trf), ikpy's
  `inverse_kinematics_frame` (scipy, position and orientation). Each peer twice: at its
  documented default start (rtb: random restarts; pybotics: its current joints, zero; ikpy:
  zero) and at its best setting, warm (started 0.05 rad from the answer on every joint).
Every IK case is checked before it is timed: the FK of what it returns must be on the target
(1e-3 mm, 1e-5 rad), on 5 calls; one that fails is reported and not timed.
Then interleaved rounds (every case of every library once per round, so a noisy host slows all
alike): medians with min and max per call; the two targets of issue 29 as ratios of the
screwcal and rtb times of the same round (median and min-max over the rounds). A peer that is
not installed is skipped and said so.
"""

from __future__ import annotations

import argparse
import statistics
import time
from collections.abc import Callable

import numpy as np

from screwcal.kinematics.dh import dh_from_model
from screwcal.kinematics.forward import forward_kinematics
from screwcal.kinematics.ik import closed_form_ik
from screwcal.kinematics.robots import irb1600

# library -> case -> (run once, the poses it returned or None: for the check)
Fn = Callable[[], object]
CHECK_MM, CHECK_RAD = 1e-3, 1e-5
BUDGET_S = 0.05  # each case's calls per round: about this long


def _on_target(T: np.ndarray, target: np.ndarray) -> tuple[float, float]:
    """Position (mm) and rotation (rad) error of a pose against the target."""
    cos = np.clip((np.trace(T[:3, :3].T @ target[:3, :3]) - 1) / 2, -1, 1)
    return float(np.linalg.norm(T[:3, 3] - target[:3, 3])), float(np.arccos(cos))


def build_cases(n_batch: int, n_big: int
                ) -> tuple[dict[str, dict[str, Fn]], dict[str, str], list[str]]:
    """Per library its timed cases; the IK cases that failed their check (why); the skipped."""
    model = irb1600()
    rng = np.random.default_rng(0)
    lo = np.maximum(0.8 * model.limits[:, 0], -2.8)  # inside every library's default limits
    hi = np.minimum(0.8 * model.limits[:, 1], 2.8)
    q_big = rng.uniform(lo, hi, (max(n_big, n_batch, 20), 6))
    q_batch, q_big = q_big[:n_batch], q_big[:n_big]
    q1 = q_batch[:1]
    T1 = forward_kinematics(model, q1)[0]
    q_warm = q1[0] + 0.05
    ours_T = forward_kinematics(model, q_big[:20])
    batch, big = f"FK {n_batch:,} poses", f"FK {n_big:,} poses"
    cases: dict[str, dict[str, Fn]] = {"screwcal": {
        "FK one pose": lambda: forward_kinematics(model, q1),
        batch: lambda: forward_kinematics(model, q_batch),
        big: lambda: forward_kinematics(model, q_big),
        "IK one target, default": lambda: closed_form_ik(model, T1[None]),
        "IK one target, warm": lambda: closed_form_ik(model, T1[None]),
    }}
    wrong: dict[str, str] = {}
    sol = closed_form_ik(model, T1[None])
    turn = np.abs((sol.q[0] - q1 + np.pi) % (2 * np.pi) - np.pi).max(axis=1)
    if np.nanmax(sol.residual_mm) > CHECK_MM or not (turn < 1e-9).any():
        raise SystemExit("screwcal's closed form missed the target: fix that first")
    skipped = []
    dh, mdh = dh_from_model(model, "dh"), dh_from_model(model, "mdh")

    def same_robot(name: str, poses: np.ndarray) -> None:
        err = np.abs(poses[:, :3, 3] - ours_T[:, :3, 3]).max()
        if err > 1e-6:
            raise SystemExit(f"{name} disagrees with screwcal by {err:.3g} mm: not the same robot")

    def check_ik(lib: str, case: str, solve: Callable[[], np.ndarray | None],
                 fk: Callable[[np.ndarray], np.ndarray]) -> None:
        """Five calls, each on the target, or the case is not timed."""
        for _ in range(5):
            q = solve()
            if q is None:
                wrong[f"{lib}: {case}"] = "no solution returned"
                break
            mm, rad = _on_target(fk(q), T1)
            if mm > CHECK_MM or rad > CHECK_RAD:
                wrong[f"{lib}: {case}"] = f"off the target by {mm:.3g} mm, {rad:.3g} rad"
                break
        if f"{lib}: {case}" in wrong:
            del cases[lib][case]

    try:
        import roboticstoolbox as rtb

        robot = rtb.DHRobot([rtb.RevoluteDH(d=r.d_mm, a=r.a_mm, alpha=r.alpha, offset=r.theta)
                             for r in dh.rows])
        ets = robot.ets()

        def rtb_fk(q: np.ndarray) -> np.ndarray:
            return ets.eval(q) @ dh.dh_flange

        same_robot("rtb", np.array([rtb_fk(q) for q in q_big[:20]]))
        T1_dh = T1 @ np.linalg.inv(dh.dh_flange)

        def rtb_q(result: object) -> np.ndarray | None:
            return result.q if result.success else None  # type: ignore[attr-defined]

        cases["roboticstoolbox"] = {
            "FK one pose": lambda: ets.eval(q1[0]),
            batch: lambda: ets.eval(q_batch),
            big: lambda: ets.eval(q_big),
            "IK one target, default": lambda: ets.ik_LM(T1_dh),
            "IK one target, warm": lambda: ets.ik_LM(T1_dh, q0=q_warm),
        }
        for case in ("IK one target, default", "IK one target, warm"):
            fn = cases["roboticstoolbox"][case]
            check_ik("roboticstoolbox", case, lambda fn=fn: rtb_q(fn()), rtb_fk)
    except ImportError:
        skipped.append("roboticstoolbox-python")
    try:
        from pybotics.kinematic_chain import MDHKinematicChain
        from pybotics.robot import Robot

        table = np.array([[r.alpha, r.a_mm, r.theta, r.d_mm] for r in mdh.rows])
        probot = Robot(MDHKinematicChain(table))

        def pyb_fk(q: np.ndarray) -> np.ndarray:
            return probot.fk(q) @ mdh.dh_flange

        same_robot("pybotics", np.array([pyb_fk(q) for q in q_big[:20]]))
        T1_mdh = T1 @ np.linalg.inv(mdh.dh_flange)
        cases["pybotics"] = {
            "FK one pose": lambda: probot.fk(q1[0]),
            batch: lambda: [probot.fk(q) for q in q_batch],
            "IK one target, default": lambda: probot.ik(T1_mdh),
            "IK one target, warm": lambda: probot.ik(T1_mdh, q=q_warm),
        }
        for case in ("IK one target, default", "IK one target, warm"):
            check_ik("pybotics", case, cases["pybotics"][case], pyb_fk)  # type: ignore[arg-type]
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

        def ikpy_fk(q: np.ndarray) -> np.ndarray:
            return np.asarray(chain.forward_kinematics(q))

        same_robot("ikpy", np.array([ikpy_fk(full(q)) for q in q_big[:20]]))
        cases["ikpy"] = {
            "FK one pose": lambda: chain.forward_kinematics(full(q1[0])),
            batch: lambda: [chain.forward_kinematics(full(q)) for q in q_batch],
            "IK one target, default": lambda: chain.inverse_kinematics_frame(
                T1, orientation_mode="all"),
            "IK one target, warm": lambda: chain.inverse_kinematics_frame(
                T1, initial_position=full(q_warm), orientation_mode="all"),
        }
        for case in ("IK one target, default", "IK one target, warm"):
            check_ik("ikpy", case, cases["ikpy"][case], ikpy_fk)  # type: ignore[arg-type]
    except ImportError:
        skipped.append("ikpy")
    return cases, wrong, skipped


def _calls(fn: Fn) -> int:
    """Calls per round for about BUDGET_S (after one warm-up call)."""
    fn()
    start = time.perf_counter()
    fn()
    return max(1, int(BUDGET_S / max(time.perf_counter() - start, 1e-9)))


def _fmt(seconds: float) -> str:
    return f"{seconds * 1e3:.1f} ms" if seconds >= 1e-3 else f"{seconds * 1e6:.1f} us"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--rounds", type=int, default=7)
    parser.add_argument("--batch", type=int, default=10_000, help="the FK batch every peer runs")
    parser.add_argument("--poses", type=int, default=100_000, help="the large FK batch")
    args = parser.parse_args()
    if args.rounds < 5:
        parser.error("--rounds: at least 5 interleaved rounds per side")
    if min(args.batch, args.poses) < 1:
        parser.error("--batch and --poses must be at least 1")
    cases, wrong, skipped = build_cases(args.batch, args.poses)
    calls = {(lib, what): _calls(fn) for lib, fns in cases.items() for what, fn in fns.items()}
    times: dict[tuple[str, str], list[float]] = {key: [] for key in calls}
    for _ in range(args.rounds):  # interleaved: every case of every library once per round
        for (lib, what), n in calls.items():
            fn = cases[lib][what]
            start = time.perf_counter()
            for _ in range(n):
                fn()
            times[(lib, what)].append((time.perf_counter() - start) / n)
    print(f"{'per call':<26}{'library':<18}{'median (min-max)':>30}{'vs screwcal':>13}")
    for what in cases["screwcal"]:
        ours = statistics.median(times[("screwcal", what)])
        for lib in cases:
            t = times.get((lib, what))
            if t is None:
                continue
            med = statistics.median(t)
            cell = f"{_fmt(med)} ({_fmt(min(t))}-{_fmt(max(t))})"
            ratio = "" if lib == "screwcal" else f"{med / ours:.2f}x"
            print(f"{what:<26}{lib:<18}{cell:>30}{ratio:>13}")
    for case, why in wrong.items():
        print(f"{case}: WRONG, not timed ({why})")
    print(f"(medians of {args.rounds} interleaved rounds; every IK result checked first)")
    if "roboticstoolbox" in cases:
        big = f"FK {args.poses:,} poses"
        for label, what, target in (("one-target IK (8 branches) / rtb ik_LM warm",
                                     "IK one target, warm", 1.0),
                                    (f"{big} / rtb ETS.eval", big, 0.8)):
            if what not in cases["roboticstoolbox"]:
                continue
            r = [a / b for a, b in zip(times[("screwcal", what)],
                                       times[("roboticstoolbox", what)], strict=True)]
            med = statistics.median(r)
            print(f"screwcal's time, {label}: {med:.2f} ({min(r):.2f}-{max(r):.2f} over the "
                  f"rounds), target <= {target:g} " + ("ok" if med <= target else "MISSED"))
    if skipped:
        print("not installed, skipped: " + ", ".join(skipped) + " (pip install -e '.[peers]')")


if __name__ == "__main__":
    main()
