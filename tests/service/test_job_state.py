"""One state machine for jobs (service/job_state.py): the table, and the store keeping to it."""

from __future__ import annotations

import re

import pytest

from service.job_state import FINISHED, TRANSITIONS, UNFINISHED, JobState, JobStateError
from service.migrations import MIGRATIONS
from service.store import Store
from tests.service.test_store import robot_and_job


def test_a_finished_job_has_no_way_out_and_an_unfinished_one_may_end_every_way():
    for state in FINISHED:
        assert TRANSITIONS[state] == frozenset() and state.finished
    for state in UNFINISHED:
        assert FINISHED <= TRANSITIONS[state] and not state.finished


def test_no_job_goes_back_to_queued():
    assert all(JobState.QUEUED not in after for after in TRANSITIONS.values())


def test_the_databases_one_unfinished_job_per_robot_index_names_the_unfinished_states():
    index = re.search(r"jobs_one_unfinished_per_robot ON jobs\(robot_id\)\s+WHERE state IN "
                      r"\(([^)]*)\)", MIGRATIONS[2])
    assert index is not None
    assert {s.strip(" '") for s in index.group(1).split(",")} == {s.value for s in UNFINISHED}


def test_the_store_moves_a_job_along_the_table_and_refuses_to_revive_a_finished_one(tmp_path):
    store = Store(tmp_path / "jobs.db")
    _, job_id = robot_and_job(store)
    assert store.job(job_id).state is JobState.QUEUED
    for state in (JobState.RUNNING, JobState.PAUSED, JobState.RUNNING, JobState.DONE):
        assert store.set_state(job_id, state, "").state is state
    with pytest.raises(JobStateError, match=f"job {job_id} cannot go from done to running"):
        store.set_state(job_id, JobState.RUNNING, "")
    with pytest.raises(JobStateError, match="stale"):
        store.fail(job_id, "cannot run")
    assert store.job(job_id).state is JobState.DONE
    store.close()


def test_a_state_the_table_does_not_know_is_refused_with_the_states(tmp_path):
    store = Store(tmp_path / "jobs.db")
    _, job_id = robot_and_job(store)
    with pytest.raises(ValueError, match="'finished' is not a valid JobState"):
        store.set_state(job_id, "finished", "")  # a typo of a caller
    store.close()
