"""A job's states and the one table of the moves between them (every other module asks here).

    queued ──> running <──> paused
      │          │            │
      └──────────┴────────────┴──> done | failed | aborted   (finished: no way out)

`running -> running` and `paused -> paused` are a resumed runner's (after a restart, a job is
stored as it was left) and a second pause (the disk still full). A runner changes a job's state
only along `TRANSITIONS`; the store checks each change in the transaction that makes it, so a
stale runner (another ended the job) changes nothing.
"""

from __future__ import annotations

from enum import StrEnum

from service.errors import ConflictError


class JobState(StrEnum):
    QUEUED = "queued"
    RUNNING = "running"
    PAUSED = "paused"
    DONE = "done"
    FAILED = "failed"
    ABORTED = "aborted"

    @property
    def finished(self) -> bool:
        return self in FINISHED


FINISHED = frozenset({JobState.DONE, JobState.FAILED, JobState.ABORTED})
UNFINISHED = frozenset(JobState) - FINISHED

TRANSITIONS: dict[JobState, frozenset[JobState]] = {
    JobState.QUEUED: frozenset({JobState.RUNNING, JobState.PAUSED, *FINISHED}),
    JobState.RUNNING: frozenset({JobState.RUNNING, JobState.PAUSED, *FINISHED}),
    JobState.PAUSED: frozenset({JobState.RUNNING, JobState.PAUSED, *FINISHED}),
    JobState.DONE: frozenset(),
    JobState.FAILED: frozenset(),
    JobState.ABORTED: frozenset(),
}


def state_said(state: JobState | str, reason: str | None) -> str:
    """A job's state and why, as a person reads it: 'failed: the arm stopped answering',
    'done'; a reason that says its state itself ('aborted by the operator') alone."""
    reason = (reason or "").strip()
    if reason.startswith(str(state)):
        return reason
    return f"{state}: {reason}" if reason else str(state)


class JobStateError(ConflictError):
    """A change of state the table does not allow (a stale runner's, most often)."""


def check_transition(job_id: int, old: JobState | str, new: JobState | str) -> JobState:
    """`new` when a job may go from `old` to it; JobStateError naming both otherwise."""
    old, new = JobState(old), JobState(new)
    if new not in TRANSITIONS[old]:
        why = ("it is no longer unfinished: this runner is stale and changes nothing"
               if old.finished else "not a move of a job")
        raise JobStateError(f"job {job_id} cannot go from {old} to {new}: {why}")
    return new


def sql_list(states: frozenset[JobState]) -> str:
    """The states as a SQL list, e.g. ('paused', 'queued', 'running') (sorted: stable SQL)."""
    return "(" + ", ".join(f"'{s.value}'" for s in sorted(states)) + ")"
