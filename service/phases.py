"""The phases of a job, named in one place: the steps of each kind, the measured lists among
them, and the names people read for the performance lists."""

from __future__ import annotations

from typing import Final, Literal

Round = Literal["", "_2"]  # the suffix of the first and the second calibration round
ListKind = Literal["cal", "perf"]  # the job's two planned lists: calibration, performance

# A step is a measured list (home_*, perf_*, cal*), an estimation, a correction or the
# evaluation; "setup" (the links) comes before every job's steps.
STEPS: Final = {
    "performance": ("perf_before", "evaluation"),
    "calibration": ("cal", "estimation"),
    "procedure": ("home_before", "perf_before", "cal", "estimation", "correction", "home_after",
                  "perf_after", "evaluation"),
    # a short pose test with the robot's current model, no estimation (service/verify.py)
    "verify": ("perf_verify", "evaluation"),
}
# ISO 9283 (6.2): the robot warmed up before the test, by running the test cycle (unmeasured).
WARMUP: Final = "warmup"
# Table 14's check: the robot sent home (all joints 0) before and after, its flange measured.
HOME_PHASES: Final = ("home_before", "home_after")
# The thesis's "Calibracao 2" (4.7): acquire again, estimate, correct, evaluate.
SECOND_ROUND: Final = ("cal_2", "estimation_2", "correction_2", "perf_after_2")
# The ISO 9283 lists, in the order they are measured, and what a person calls each.
PERF_PHASES: Final = ("perf_before", "perf_after", "perf_after_2", "perf_verify")
PERF_PHASE_NAMES: Final = {"perf_before": "before", "perf_after": "after",
                           "perf_after_2": "round 2", "perf_verify": "verification"}
# The estimation whose model drives a performance list's targets when the route compensates.
# A calibration list (the second round's) is sent as planned: its poses need reach no
# particular target, only be measured, and compensating them could push one out of the limits.
ESTIMATION_FOR: Final[dict[str, Round]] = {"perf_after": "", "perf_after_2": "_2"}
ROUND_SUFFIXES: Final[tuple[Round, Round]] = ("", "_2")  # the first and the second round


def job_steps(kind: str, rounds: int = 1, warmup: bool = False) -> tuple[str, ...]:
    """The steps of a job of `kind`; a procedure of 2 rounds adds the second round before its
    evaluation; `warmup` puts ISO 9283's warm-up (the test cycle run unmeasured, "warmup")
    before the first performance list."""
    steps = STEPS[kind]
    if kind == "procedure" and rounds == 2:
        steps = (*steps[:-1], *SECOND_ROUND, steps[-1])
    if warmup:
        first = next((k for k, step in enumerate(steps) if step in PERF_PHASES), None)
        if first is not None:
            steps = (*steps[:first], WARMUP, *steps[first:])
    return steps


def compensated_list(suffix: Round) -> str:
    """The performance list that round `suffix`'s estimation compensates."""
    return next(phase for phase, s in ESTIMATION_FOR.items() if s == suffix)


def list_kind(phase: str) -> ListKind:
    """The planned list a measured phase runs, whose poses and payload it has: "cal" for a
    calibration list (cal, cal_2), "perf" for the others (performance and home lists)."""
    return "cal" if phase.startswith("cal") else "perf"


def round_suffix(step: str) -> Round:
    """'_2' for a step of the second calibration round, '' otherwise."""
    return "_2" if step.endswith("_2") else ""
