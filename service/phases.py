"""The phases of a job, named in one place: the steps of each kind, the measured lists among
them, and the names people read for the performance lists."""

from __future__ import annotations

from dataclasses import dataclass
from enum import StrEnum
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
# What a person calls each phase of a job (the time-per-phase table of the report)
PHASE_WORDS: Final = {
    "setup": "set-up (links opened)", "warmup": "warm-up (test cycle, unmeasured)",
    "home_before": "home check before", "home_after": "home check after",
    "perf_before": "performance before (ISO 9283)", "perf_after": "performance after (ISO 9283)",
    "perf_after_2": "performance after round 2", "perf_verify": "verification poses",
    "cal": "calibration poses", "cal_2": "calibration poses, round 2",
    "estimation": "estimation", "estimation_2": "estimation, round 2",
    "correction": "correction", "correction_2": "correction, round 2",
    "evaluation": "evaluation",
}
# The estimation whose model drives a performance list's targets when the route compensates.
# A calibration list (the second round's) is sent as planned: its poses need reach no
# particular target, only be measured, and compensating them could push one out of the limits.
ESTIMATION_FOR: Final[dict[str, Round]] = {"perf_after": "", "perf_after_2": "_2"}
ROUND_SUFFIXES: Final[tuple[Round, Round]] = ("", "_2")  # the first and the second round


class Action(StrEnum):
    """What a step does."""

    SETUP = "setup"  # open the links
    WARMUP = "warmup"  # run the performance cycle unmeasured
    MEASURE = "measure"  # a measured list
    ESTIMATE = "estimate"  # the identification
    CORRECT = "correct"  # the correction route (ZERO, or compensation of the later lists)
    EVALUATE = "evaluate"  # ISO 9283's figures, the home check, the warnings


@dataclass(frozen=True)
class Step:
    """A step of a job: its name (as stored in the job's phases), what it does, its
    calibration round, and for a measured list, which planned list it runs."""

    name: str
    action: Action
    round: Round = ""
    list: ListKind | None = None


SETUP: Final = "setup"
STEP_OF: Final[dict[str, Step]] = {s.name: s for s in (
    Step(SETUP, Action.SETUP), Step(WARMUP, Action.WARMUP),
    *(Step(name, Action.MEASURE, list="perf") for name in (*HOME_PHASES, *PERF_PHASES[:2],
                                                            PERF_PHASES[3])),
    Step("perf_after_2", Action.MEASURE, "_2", "perf"),
    Step("cal", Action.MEASURE, "", "cal"), Step("cal_2", Action.MEASURE, "_2", "cal"),
    Step("estimation", Action.ESTIMATE), Step("estimation_2", Action.ESTIMATE, "_2"),
    Step("correction", Action.CORRECT), Step("correction_2", Action.CORRECT, "_2"),
    Step("evaluation", Action.EVALUATE))}


def calibration_list(round: Round) -> str:
    """The measured calibration list of a calibration round: "cal", "cal_2"."""
    return next(s.name for s in STEP_OF.values()
                if s.action is Action.MEASURE and s.list == "cal" and s.round == round)


def correction_step(round: Round) -> str:
    """The correction step of a calibration round: "correction", "correction_2"."""
    return next(s.name for s in STEP_OF.values()
                if s.action is Action.CORRECT and s.round == round)


def is_correction(phase: str) -> bool:
    """True for a correction step's name (a ZERO's go-ahead is confirmed in it)."""
    step = STEP_OF.get(phase)
    return step is not None and step.action is Action.CORRECT


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
    calibration list (cal, cal_2), "perf" for the others (performance and home lists, and the
    drift checks interleaved with them, service/drift.py, which are no step of their own)."""
    step = STEP_OF.get(phase)
    return step.list if step is not None and step.list is not None else "perf"
