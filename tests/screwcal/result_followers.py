"""Every calibration result the tests produce is fed to the commands that read one (issue 39):
`predict`, `compensate --targets`, `robot show` and `robot export` in each form. A result one
of them refuses (a compliance below zero once was: "greater than or equal to 0") fails the test
that produced it, with the command and its message.

`follow_result` runs them in the test's process (through `main`, as a user's shell would);
tests/screwcal/conftest.py wraps `screwcal calibrate` so that each result it writes is
followed."""

from __future__ import annotations

import contextlib
import io
import json
from pathlib import Path

import numpy as np

# compensate: 0 all compensated, 3 some refused (listed); 2 only for a position-only model
_COMPENSATE_OK = (0, 3)


def _run(argv: list[str]) -> tuple[int, str]:
    from screwcal.commands.main import main

    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        code = main(argv)
    return code, out.getvalue() + err.getvalue()


def follow_result(result: Path) -> list[str]:
    """The commands that refused the result (command line and message); empty when none did."""
    from screwcal.errors import ScrewcalError
    from screwcal.kinematics.forward import flange_kinematics
    from screwcal.kinematics.modelfile import parse_model
    from screwcal.kinematics.pose import pose_from_transform
    from screwcal.kinematics.readings import readings_from_serial

    doc = json.loads(result.read_text())
    try:
        model = parse_model(doc, str(result))
        nominal = parse_model(doc["nominal_model"], f"{result} nominal_model")
    except ScrewcalError as err:
        return [f"its model is refused: {err}"]
    convention = (doc.get("settings") or {}).get("joint_convention") or "serial"
    rng = np.random.default_rng(0)
    q = 0.3 * rng.uniform(model.limits[:, 0], model.limits[:, 1], (5, model.n_joints))
    q_deg = readings_from_serial(model.joints_to_deg(q), convention)
    folder = result.parent / f".follow-{result.stem}"
    folder.mkdir(exist_ok=True)
    joints, targets = folder / "joints.csv", folder / "targets.csv"
    columns = [f"q{i + 1}" for i in range(model.n_joints)]
    joints.write_text(",".join(columns) + "\n" + "\n".join(
        ",".join(f"{v:.9f}" for v in row) for row in q_deg) + "\n")
    poses = pose_from_transform(flange_kinematics(nominal, q))
    targets.write_text("id,x,y,z,rx,ry,rz\n" + "\n".join(
        f"t{k}," + ",".join(f"{v:.9f}" for v in row) for k, row in enumerate(poses)) + "\n")
    runs = [(["predict", "--result", str(result), "--joints", str(joints), "--out",
              str(folder / "p.csv")], (0,)),
            (["compensate", "--result", str(result), "--targets", str(targets), "--out",
              str(folder / "c.csv")], _COMPENSATE_OK),
            (["robot", "show", str(result)], (0,))]
    runs += [(["robot", "export", str(result), "--format", fmt, "--out",
               str(folder / f"e.{fmt}")], (0,)) for fmt in ("urdf", "mdh", "screws", "json")]
    refused = []
    for argv, ok in runs:
        code, said = _run(argv)
        position_only = argv[0] == "compensate" and code == 2 and "position-only" in said
        if code not in ok and not position_only:
            refused.append(f"screwcal {' '.join(argv[:2])} exit {code}: {said.strip()[-400:]}")
    return refused
