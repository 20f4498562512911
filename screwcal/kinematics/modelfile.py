"""The model file: JSON in the interface units (mm, degrees), validated by pydantic when read.

One format, three representations of the same serial model (chosen with `representation`):

- "screws": per joint a unit direction and a point on the axis at home, plus the home flange pose;
- "dh" / "mdh": a standard or modified Denavit-Hartenberg table, with `dh_base` (robot base <-
  DH frame 0) and `dh_flange` (DH frame n <- flange); "mdh" rows carry Hayati's `beta_deg` for
  nearly parallel axes (0 elsewhere, and always 0 in "dh", which refuses a calibrated model
  whose parallel axes would need huge offsets: `dh.DegenerateTableError`).

Every representation also carries per-joint `zero_deg` and `limits_deg`, and the `base` (world
<- robot base) and `tool` (flange <- measured point) poses; a model with joint compliance carries
`gravity`: per-joint compliance in deg per kN m, the lumped masses that load the joints (joint
numbers from 1, kg, centre at home in mm) and the payload (kg, centre of gravity in the flange
frame, mm). Poses are {x, y, z} in mm and
{rx, ry, rz} in degrees with R = Rz(rz) Ry(ry) Rx(rx). For prismatic joints, `zero_deg`,
`limits_deg` and `theta_deg`/`d_mm` values along the joint are in mm.

Writing builds the document as plain JSON (`model_document`); reading validates it field by
field against the schema in `modelschema`, imported only then (pydantic costs a process that
only writes, such as `screwcal calibrate`, ~90 ms and ~10 MB).
"""

from __future__ import annotations

import json
import math
from pathlib import Path
from typing import Literal

import numpy as np

from screwcal.errors import ModelError
from screwcal.kinematics.dh import dh_from_model
from screwcal.kinematics.model import SerialModel
from screwcal.kinematics.pose import pose_from_transform

FORMAT = "screwcal-model"
Representation = Literal["screws", "dh", "mdh"]


def pose_document(T: np.ndarray) -> dict[str, float]:
    """A pose as the files write it: {x, y, z} mm and {rx, ry, rz} deg (EulerZYX)."""
    return dict(zip(("x", "y", "z", "rx", "ry", "rz"), pose_from_transform(T).tolist(),
                    strict=True))


def gravity_document(model: SerialModel) -> dict[str, object] | None:
    """The `gravity` section: compliance (deg per kN m), masses, payload; None without any
    (a robot's masses alone are kept: an imported robot calibrates its compliance with them)."""
    if not model.has_compliance and model.payload.kg == 0.0 and not model.masses:
        return None
    by_mass = model.compliance_by_mass
    return {"compliance_deg_per_knm": (np.degrees(model.compliance) * 1000.0).tolist(),
            "compliance_by_mass_deg_per_knm": None if by_mass is None else
            (np.degrees(by_mass) * 1000.0).tolist(),
            "masses": [{"joint": m.link + 1, "kg": float(m.kg),
                        "home_mm": np.asarray(m.home_mm, float).tolist()} for m in model.masses],
            "payload": {"kg": float(model.payload.kg),
                        "cog_mm": np.asarray(model.payload.cog_mm, float).tolist()}}


def _rating_document(model: SerialModel, i: int) -> dict[str, object]:
    """A joint's name, effort (N m; N for P) and speed (deg/s; mm/s for P) when the model
    keeps them from its description; nothing otherwise (the files stay as they were)."""
    if not model.ratings:
        return {}
    r = model.ratings[i]
    speed = None if r.velocity is None else \
        (math.degrees(r.velocity) if model.joint_types[i] == "R" else r.velocity)
    return {k: v for k, v in (("name", r.name or None), ("effort_nm", r.effort),
                              ("velocity_deg_s", speed)) if v is not None}


def model_document(model: SerialModel, representation: Representation = "screws"
                   ) -> dict[str, object]:
    """The file document of a model, in the chosen representation (JSON-ready)."""
    limits = model.limits_deg
    zero = model.joints_to_deg(model.joint_zero).tolist()
    common = [{"type": t, "zero_deg": zero[i], "limits_deg": limits[i].tolist()}
              | _rating_document(model, i) for i, t in enumerate(model.joint_types)]
    doc = {"format": FORMAT, "version": 1, "name": model.name,
           "base": pose_document(model.base), "tool": pose_document(model.tool),
           "gravity": gravity_document(model), "representation": representation}
    if representation == "screws":
        doc["joints"] = [c | {"direction": d, "point_mm": p} for c, d, p in
                         zip(common, model.axis_dirs.tolist(), model.axis_points_mm.tolist(),
                             strict=True)]
        doc["home_flange"] = pose_document(model.home_flange)
        return doc
    if representation not in ("dh", "mdh"):
        raise ModelError(f"representation must be screws, dh or mdh, not {representation!r}")
    table = dh_from_model(model, representation)
    doc["joints"] = [c | {"a_mm": float(r.a_mm), "alpha_deg": math.degrees(r.alpha),
                          "d_mm": float(r.d_mm), "theta_deg": math.degrees(r.theta),
                          "beta_deg": math.degrees(r.beta)}
                     for r, c in zip(table.rows, common, strict=True)]
    doc |= {"dh_base": pose_document(table.dh_base), "dh_flange": pose_document(table.dh_flange)}
    return doc


def parse_model(data: object, source: str = "model") -> SerialModel:
    """A serial model from a decoded JSON object, validated field by field (`modelschema`). A
    calibration result (with a `model` member) is accepted as well."""
    from pydantic import ValidationError

    from screwcal.kinematics.modelschema import ADAPTER, describe

    if isinstance(data, dict) and "model" in data and "representation" not in data:
        data = data["model"]
    try:
        return ADAPTER.validate_python(data).to_model()
    except ValidationError as err:
        raise ModelError(f"{source}: invalid model file: {describe(err)}") from None


def load_model(path: str | Path) -> SerialModel:
    """Read a model file (any representation)."""
    return parse_model(read_model_document(path), str(path))


def read_model_document(path: str | Path) -> object:
    """The decoded JSON of a robot, model or result file (what `parse_model` reads; a command
    that needs the result's other members too reads it once)."""
    path = Path(path)
    if path.exists() and not path.is_file():
        raise ModelError(f"{path}: not a regular file (a model file is a JSON file)")
    try:
        data: object = json.loads(path.read_text(encoding="utf-8-sig"))
    except FileNotFoundError:
        raise ModelError(f"{path}: model file not found") from None
    except (json.JSONDecodeError, UnicodeDecodeError) as err:
        raise ModelError(f"{path}: not a JSON model file ({err})") from None
    except RecursionError:
        raise ModelError(f"{path}: not a model file (JSON nested deeper than Python reads)"
                         ) from None
    return data


def save_model(model: SerialModel, path: str | Path,
               representation: Representation = "screws") -> None:
    """Write a model file in the chosen representation."""
    doc = model_document(model, representation)
    Path(path).write_text(json.dumps(doc, indent=2) + "\n", encoding="utf-8")


def resolve_model(name_or_path: str) -> SerialModel:
    """A library robot's name (`screwcal robot list`) or the path of a robot, model or result
    file."""
    from screwcal.kinematics.robots import BUILTIN_MODELS, accepted_robots, builtin_model

    if name_or_path in BUILTIN_MODELS:
        return builtin_model(name_or_path)
    if not Path(name_or_path).exists():
        raise ModelError(f"'{name_or_path}' is neither a library robot nor an existing file; "
                         f"give {accepted_robots()}")
    return load_model(name_or_path)
