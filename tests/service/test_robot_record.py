"""Robot records as models, their instrument a discriminated union (arm, tracker, external), and
the records of an older release, which name their arm by `arm_url` only, read as arms: on SQLite
and on a real PostgreSQL server."""

from __future__ import annotations

import pytest
from pydantic import ValidationError

from service.database import open_database
from service.migrations import MIGRATIONS
from service.robot_record import ArmSetup, ExternalSetup, RobotRecord, TrackerSetup
from service.schemas import RobotCreate
from service.store import Store

HOLES = [[0, 0, 0], [10, 0, 0], [0, 10, 0]]


def test_a_robot_of_the_previous_schema_reads_as_an_arm_and_its_jobs_measure_on(db_target):
    """Version 7 (the release before instruments): a robot stored with its arm_url only."""
    db = open_database(db_target)
    db.migrate(MIGRATIONS, 7)
    with db.tx() as tx:
        tx.execute("INSERT INTO robots (name, controller_host, controller_port, arm_url, model, "
                   "holes_mm, created) VALUES ('old cell', '127.0.0.1', 4012, "
                   "'socket://127.0.0.1:7001', '{\"name\": \"x\"}', "
                   "'[[0, 0, 0], [10, 0, 0], [0, 10, 0]]', 1.0)")
    db.close()
    store = Store(db_target)
    robot = store.robot_named("old cell")
    assert robot.instrument == ArmSetup(url="socket://127.0.0.1:7001")
    assert robot.arm_url == "socket://127.0.0.1:7001" and robot.targets_mm() == HOLES
    assert robot.model_dump()["arm_url"] == "socket://127.0.0.1:7001"  # older clients read it
    job = store.add_job(robot.id, "calibration", "AUTO", {})
    store.add_measurement(job.id, "cal", 0, [0.0] * 6, [0.0] * 7, HOLES, [0.0] * 6)
    row = store.measurements(job.id)[0]  # the arm states no weather: none stored
    assert row["conditions"] is None and row["measured_at"] is None
    store.close()


def test_each_instrument_round_trips_through_the_store(db_target):
    store = Store(db_target)
    tracker = TrackerSetup(host="10.0.0.5", smrs_mm=[[0, -30, 40], [40, 0, 40], [0, 30, 40]],
                           yaw_deg=12.0)
    external = ExternalSetup(targets_mm=[[30, 20, 40]], name="AT960 via SpatialAnalyzer")
    for name, setup in (("a", "loop://"), ("t", tracker), ("e", external)):
        store.add_robot(name, "127.0.0.1", 4012, setup, {"name": "x"}, HOLES)
    a, t, e = store.robots()
    assert isinstance(a, RobotRecord) and a.instrument == ArmSetup(url="loop://")
    assert t.instrument == tracker and t.arm_url == "" and t.instrument.url == \
        "emscon://10.0.0.5:700"
    assert t.targets_mm() == tracker.smrs_mm and e.targets_mm() == [[30, 20, 40]]
    assert "SpatialAnalyzer" in e.instrument_text()
    store.close()


def test_a_new_record_names_one_instrument_checked():
    base = {"name": "c", "controller_host": "127.0.0.1"}
    assert RobotCreate(**base, arm_url="loop://").setup == ArmSetup(url="loop://")
    both = RobotCreate(**base, arm_url="loop://", instrument={"kind": "arm", "url": "loop://"})
    assert both.setup == ArmSetup(url="loop://")
    for bad, words in (
            ({}, "name the robot's instrument"),
            ({"arm_url": "loop://", "instrument": {"kind": "tracker", "host": "t"}},
             "two instruments"),
            ({"instrument": {"kind": "arm", "url": "/etc/passwd"}}, "the arm's url"),
            ({"instrument": {"kind": "tracker", "host": "a b"}}, "the tracker's host"),
            ({"instrument": {"kind": "tracker", "host": "t", "smrs_mm": [[0, 0, 0]] * 2}},
             "one point .positions. or three"),
            ({"instrument": {"kind": "external", "targets_mm": [[0, 0, 0], [1, 0, 0],
                                                                [2, 0, 0]]}},
             "cannot define the flange frame"),
            ({"instrument": {"kind": "tracker", "host": "t", "port": 70000}}, "port"),
            ({"instrument": {"kind": "laser", "host": "t"}}, "arm', 'tracker', 'external"),
            ({"instrument": {"kind": "tracker", "host": "t", "stand_mm": [1, "nan", 2]}},
             "stand_mm")):
        with pytest.raises(ValidationError, match=words):
            RobotCreate(**base, **bad)
