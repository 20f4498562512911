"""Robot descriptions in and out (`screwcal robot import / export`): a model file in any
representation (the docs/robots.md templates: dh, mdh with Hayati's beta, screws) or a URDF in;
the same forms out, each reading back to the same forward kinematics."""

from __future__ import annotations

import json
from pathlib import Path
from typing import TYPE_CHECKING, Literal

import numpy as np

from screwcal.errors import ModelError
from screwcal.kinematics.model import SerialModel
from screwcal.kinematics.readings import JointConvention

if TYPE_CHECKING:
    from screwcal.kinematics.robots import RobotEntry

ImportFormat = Literal["json", "dh", "mdh", "screws", "urdf"]
ExportFormat = Literal["json", "screws", "dh", "mdh", "urdf"]


def read_description(path: str | Path, fmt: ImportFormat | None = None,
                     name: str | None = None, base_link: str | None = None,
                     tip_link: str | None = None, notes: list[str] | None = None
                     ) -> tuple[SerialModel, str]:
    """A robot from a description file, and the form it was read as. `fmt` None: a URDF when
    the file is XML (a byte order mark and the declared encoding honoured), else a model file
    (any representation) or a calibration result. `base_link` / `tip_link` choose a URDF's
    chain; what the reader chose or assumed is appended to `notes`."""
    from dataclasses import replace

    from screwcal.kinematics.modelfile import parse_model
    from screwcal.kinematics.urdf import model_from_urdf
    from screwcal.kinematics.urdf_tree import MAX_BYTES

    path = Path(path)
    if path.exists() and not path.is_file():
        raise ModelError(f"{path}: not a regular file (a robot description is a file)")
    try:
        with path.open("rb") as handle:
            data = handle.read(MAX_BYTES + 1)
    except FileNotFoundError:
        raise ModelError(f"{path}: robot description not found") from None
    except OSError as err:
        raise ModelError(f"{path}: not readable ({err.strerror})") from None
    if len(data) > MAX_BYTES:
        raise ModelError(f"{path}: more than {MAX_BYTES // 2**20} MB, more than a robot "
                         "description holds: not read")
    head = data[:64].lstrip(b"\xef\xbb\xbf \t\r\n")
    if fmt == "urdf" or (fmt is None and (head.startswith(b"<") or data[:2] in (
            b"\xff\xfe", b"\xfe\xff"))):
        model, said = model_from_urdf(data, str(path), name, base_link, tip_link)
        if notes is not None:
            notes += said
        return model, "urdf"
    if base_link or tip_link:
        raise ModelError(f"{path}: --base-link and --tip-link choose a URDF's chain; this file "
                         "is not a URDF")
    try:
        text = data.decode("utf-8-sig")
        parsed = json.loads(text)
    except UnicodeDecodeError as err:
        raise ModelError(f"{path}: not a text file ({err})") from None
    except json.JSONDecodeError as err:
        raise ModelError(f"{path}: neither JSON (the templates of docs/robots.md) nor a URDF "
                         f"({err})") from None
    except RecursionError:
        raise ModelError(f"{path}: not a robot description (JSON nested deeper than Python "
                         "reads)") from None
    doc = parsed["model"] if isinstance(parsed, dict) and "model" in parsed and \
        "representation" not in parsed else parsed
    form = doc.get("representation") if isinstance(doc, dict) else None
    if fmt in ("dh", "mdh", "screws") and form != fmt:
        raise ModelError(f"{path}: --format {fmt} but the file's representation is "
                         f"{form!r}; see docs/robots.md for the {fmt} template")
    model = parse_model(parsed, str(path))
    return (replace(model, name=name) if name else model), str(form)


def _in_ros_frames(model: SerialModel, entry: RobotEntry
                   ) -> tuple[SerialModel, list[tuple[str, np.ndarray]]]:
    """The model re-expressed in the entry's base_link, and its other frames' poses there."""
    from screwcal.kinematics.pose import transform_from_pose
    from screwcal.kinematics.robots import in_frame

    poses = {name: transform_from_pose(pose) for name, pose in entry.frames}
    F = poses["base_link"]
    return in_frame(model, F), [(name, np.linalg.inv(F) @ T) for name, T in poses.items()
                                if name != "base_link"]


def description_text(model: SerialModel, fmt: ExportFormat,
                     convention: JointConvention = "serial", library: RobotEntry | None = None
                     ) -> tuple[str, list[str]]:
    """The model written as `fmt`, and what the user must know about it: "warning: ..." for
    what the form cannot carry, "note: ..." for how its joint values read. `convention`: how
    the robot's controller reports its joints; a FANUC arm's URDF carries the J2/J3 coupling
    (a mimic joint) so that its joint_3 takes the controller's J3. `library`: the library
    robot the model is (or was calibrated from): its URDF is written in ROS-Industrial's
    base_link with the entry's other frames as links (UR's `base`, FANUC's World)."""
    from screwcal.kinematics.modelfile import model_document

    said = []
    if fmt == "urdf":
        from screwcal.kinematics.urdf import urdf_from_model

        frames: list[tuple[str, np.ndarray]] = []
        if library is not None:
            model, frames = _in_ros_frames(model, library)
            from screwcal.kinematics.pose import pose_from_transform
            from screwcal.kinematics.robots import pose_words

            said.append("note: the root is ROS-Industrial's base_link" + "".join(
                f"; link '{name}' (the frame the controller reports in) at "
                f"{pose_words(pose_from_transform(T).tolist())}" for name, T in frames))
        text = urdf_from_model(model, j23_coupling=convention == "fanuc", more_links=frames)
        if convention == "fanuc":
            said.append("note: FANUC's J2/J3 coupling is in the URDF: joint_3_coupling turns "
                        "joint 3's axis with joint_2 (a mimic joint), so joint_1 .. joint_6 "
                        "take the controller's readings as they are; joint_3's limits are the "
                        "model's, on the serial angle J3 + J2")
        if model.has_compliance:
            said.append("warning: URDF has no joint compliance: the calibrated compliance is "
                        "not in the file (the json / screws export keeps it)")
        if len({m.link for m in model.masses}) < len(model.masses):
            said.append("warning: URDF has one inertial per link: masses on the same link "
                        "merged")
    elif fmt in ("json", "screws", "dh", "mdh"):
        doc = model_document(model, "screws" if fmt == "json" else fmt)
        text = json.dumps(doc, indent=2) + "\n"
        if convention == "fanuc":
            said.append("note: the table is serial (joint 3's angle is the controller's J3 + "
                        "J2): calibrate, predict and compensate read FANUC readings with "
                        "--joint-convention fanuc")
    else:
        raise ModelError(f"export format must be urdf, mdh, dh, screws or json, not {fmt!r}")
    return text, said
