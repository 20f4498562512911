"""`screwcal calibrate --data EXPORT --joints JOINTS`: measurements from any instrument's software,
a point export (X, Y, Z, U95) in the forms tracker software writes, with a joints file."""

import json

import numpy as np
import pytest

from screwcal.calibration.point_export import read_point_export, read_points_and_joints
from screwcal.calibration.virtual_joints import THESIS_TABLE11, apply_virtual_joints
from screwcal.commands.main import main
from screwcal.errors import DataFileError
from screwcal.instrument import tracker_covariance_mm2
from screwcal.kinematics.forward import forward_kinematics
from screwcal.kinematics.robots import irb1600
from screwcal.studies.tracker_noise import tracker_models

SMR_POSES = 40


def _poses(rng):
    from screwcal.calibration.line_of_sight import visible_configurations
    from screwcal.instrument import TRACKER_STAND_MM

    return visible_configurations(irb1600(), SMR_POSES, np.array(TRACKER_STAND_MM), rng)


def _measured(rng):
    _, truth = tracker_models()
    q = _poses(rng)
    p = forward_kinematics(truth, q)[:, :3, 3]
    C = tracker_covariance_mm2(p)
    p = p + np.einsum("nij,nj->ni", np.linalg.cholesky(C), rng.normal(size=p.shape))
    u95 = 2.0 * np.sqrt(np.trace(C, axis1=1, axis2=2) / 3.0)
    return q, p, u95


def _write_sa_style(path, p, u95):
    """Semicolons and decimal commas, extra columns, base nests among the robot's points."""
    lines = ["Collection;Group;Point Name;X;Y;Z;U95;Time"]
    lines += [f"A;Base;NEST{k};{1000 + k},5;-200,25;0,0;0,011;10:00" for k in range(3)]
    lines += [f"A;Robot;P{k + 1};" + ";".join(f"{v:.5f}".replace(".", ",") for v in p[k])
              + f";{u95[k]:.5f}".replace(".", ",") + ";10:01" for k in range(len(p))]
    path.write_text("\n".join(lines) + "\n", encoding="utf-8")
    return path


def _write_joints(path, q, ids=True):
    head = ("id," if ids else "") + "q1,q2,q3,q4,q5,q6"
    rows = [(f"P{k + 1}," if ids else "") + ",".join(f"{v:.6f}" for v in np.degrees(q[k]))
            for k in range(len(q))]
    path.write_text("\n".join([head, *rows]) + "\n", encoding="utf-8")
    return path


def test_calibrate_reads_a_tracker_software_export(tmp_path, rng):
    q, p, u95 = _measured(rng)
    export = _write_sa_style(tmp_path / "points.csv", p, u95)
    joints = _write_joints(tmp_path / "joints.csv", q)
    out = tmp_path / "result.json"
    assert main(["calibrate", "--robot", "irb1600", "--data", str(export), "--joints",
                 str(joints), "--error-model", "thesis", "--out", str(out)]) == 0
    doc = json.loads(out.read_text())
    values = {p["name"]: p["value"] for p in doc["parameters"]}
    for name in ("J2ry", "J3rz", "J1px"):
        assert values[name] == pytest.approx(THESIS_TABLE11[name], abs=0.05)
    data = read_points_and_joints(export, joints, irb1600())
    assert data.ids[0] == "P1" and data.lines[0] == 5  # after the header and 3 base nests
    assert data.position_cov_mm2[0] == pytest.approx((u95[0] / 2) ** 2 * np.eye(3), rel=1e-3)


def test_a_plain_export_without_names_or_u95_pairs_by_order(tmp_path, rng):
    q, p, _ = _measured(rng)
    export = tmp_path / "polyworks.txt"
    export.write_text("X\tY\tZ\n" + "".join("\t".join(f"{v:.4f}" for v in row) + "\n"
                                             for row in p), encoding="utf-8")
    joints = _write_joints(tmp_path / "joints.csv", q, ids=False)
    data = read_points_and_joints(export, joints, irb1600())
    assert data.position_cov_mm2 is None and len(data) == SMR_POSES
    np.testing.assert_allclose(data.positions_mm, np.round(p, 4))
    short = _write_joints(tmp_path / "short.csv", q[:-1], ids=False)
    with pytest.raises(DataFileError, match="39 joint rows for 40 points"):
        read_points_and_joints(export, short, irb1600())


@pytest.mark.parametrize(("text", "what"), [
    ("", "empty"), ("Name,X,Y\nP1,1,2\n", "missing column"),
    ("Name,X,Y,Z,U95\nP1,1,2,3,0\n", "U95 0 is not positive"),
    ("Name,X,Y,Z\nP1,1,two,3\n", "'two' is not a number"),
    ("Name,X,Y,Z\nP1,1,2\n", "fields where the header has"),
])
def test_bad_exports_are_named(tmp_path, text, what):
    path = tmp_path / "bad.csv"
    path.write_text(text, encoding="utf-8")
    with pytest.raises(DataFileError, match=what):
        read_point_export(path)


def test_a_joint_row_without_its_point_is_refused(tmp_path, rng):
    q, p, u95 = _measured(rng)
    export = _write_sa_style(tmp_path / "points.csv", p[:-1], u95)
    joints = _write_joints(tmp_path / "joints.csv", q)
    with pytest.raises(DataFileError, match=r"1 joint row.* no point of that name.*'P40'"):
        read_points_and_joints(export, joints, apply_virtual_joints(irb1600(), {}))
