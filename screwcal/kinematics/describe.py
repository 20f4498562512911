"""Robot descriptions in and out (`screwcal robot import / export`): a model file in any
representation (the docs/robots.md templates: dh, mdh with Hayati's beta, screws) or a URDF in;
the same forms out, each reading back to the same forward kinematics."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Literal

from screwcal.errors import ModelError
from screwcal.kinematics.model import SerialModel

ImportFormat = Literal["json", "dh", "mdh", "screws", "urdf"]
ExportFormat = Literal["json", "screws", "dh", "mdh", "urdf"]


def read_description(path: str | Path, fmt: ImportFormat | None = None,
                     name: str | None = None) -> tuple[SerialModel, str]:
    """A robot from a description file, and the form it was read as. `fmt` None: a URDF when
    the file is XML, else a model file (any representation) or a calibration result."""
    from dataclasses import replace

    from screwcal.kinematics.modelfile import parse_model
    from screwcal.kinematics.urdf import model_from_urdf

    path = Path(path)
    try:
        text = path.read_text(encoding="utf-8")
    except FileNotFoundError:
        raise ModelError(f"{path}: robot description not found") from None
    except UnicodeDecodeError as err:
        raise ModelError(f"{path}: not a text file ({err})") from None
    if fmt == "urdf" or (fmt is None and text.lstrip().startswith("<")):
        model, _ = model_from_urdf(text, str(path), name)
        return model, "urdf"
    try:
        data = json.loads(text)
    except json.JSONDecodeError as err:
        raise ModelError(f"{path}: neither JSON (the templates of docs/robots.md) nor a URDF "
                         f"({err})") from None
    doc = data["model"] if isinstance(data, dict) and "model" in data and \
        "representation" not in data else data
    form = doc.get("representation") if isinstance(doc, dict) else None
    if fmt in ("dh", "mdh", "screws") and form != fmt:
        raise ModelError(f"{path}: --format {fmt} but the file's representation is "
                         f"{form!r}; see docs/robots.md for the {fmt} template")
    model = parse_model(data, str(path))
    return (replace(model, name=name) if name else model), str(form)


def description_text(model: SerialModel, fmt: ExportFormat) -> tuple[str, list[str]]:
    """The model written as `fmt`, and warnings about what the form cannot carry."""
    from screwcal.kinematics.modelfile import model_document

    warnings = []
    if fmt == "urdf":
        from screwcal.kinematics.urdf import urdf_from_model

        text = urdf_from_model(model)
        if model.has_compliance:
            warnings.append("URDF has no joint compliance: the calibrated compliance is not in "
                            "the file (the json / screws export keeps it)")
        if len({m.link for m in model.masses}) < len(model.masses):
            warnings.append("URDF has one inertial per link: masses on the same link merged")
    elif fmt in ("json", "screws", "dh", "mdh"):
        doc = model_document(model, "screws" if fmt == "json" else fmt)
        text = json.dumps(doc, indent=2) + "\n"
    else:
        raise ModelError(f"export format must be urdf, mdh, dh, screws or json, not {fmt!r}")
    return text, warnings
