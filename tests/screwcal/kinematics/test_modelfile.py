import json

import numpy as np
import pytest

from screwcal.errors import ModelError
from screwcal.kinematics.forward import forward_kinematics
from screwcal.kinematics.modelfile import (
    load_model,
    model_document,
    resolve_model,
    save_model,
)
from screwcal.kinematics.robots import irb1600
from tests.conftest import random_model, random_q


@pytest.mark.parametrize("representation", ["screws", "dh", "mdh"])
def test_save_and_load_round_trip(tmp_path, rng, representation):
    model = random_model(rng, "RRPRRR")
    path = tmp_path / "m.json"
    save_model(model, path, representation)
    back = load_model(path)
    q = random_q(model, rng, 100)
    np.testing.assert_allclose(forward_kinematics(back, q), forward_kinematics(model, q),
                               atol=1e-8)
    np.testing.assert_allclose(back.limits, model.limits, atol=1e-12)
    assert back.joint_types == model.joint_types
    assert json.loads(path.read_text())["representation"] == representation


def _irb1600_doc() -> dict:
    return model_document(irb1600())


@pytest.mark.parametrize(("edit", "message"), [
    (lambda d: d["joints"][1].update(direction=[0, 2, 0]), r"joints\.1.*unit vector"),
    (lambda d: d["joints"][2].update(limits_deg=[65, -245]), r"joints\.2.*min < max"),
    (lambda d: d["joints"][0].update(point_mm=[0, "nan", 0]), r"joints\.0.*point_mm"),
    (lambda d: d["joints"][0].pop("direction"), r"joints"),
    (lambda d: d.pop("home_flange"), r"home_flange"),
    (lambda d: d["base"].update(rz=float("inf")), r"base\.rz"),
    (lambda d: d.update(colour="red"), r"colour"),
])
def test_invalid_model_files_are_refused_with_the_field(tmp_path, edit, message):
    doc = _irb1600_doc()
    edit(doc)
    path = tmp_path / "bad.json"
    path.write_text(json.dumps(doc))
    with pytest.raises(ModelError, match=message):
        load_model(path)


def test_not_json_and_missing_files(tmp_path):
    bad = tmp_path / "x.json"
    bad.write_text("{not json")
    with pytest.raises(ModelError, match="not a JSON model file"):
        load_model(bad)
    with pytest.raises(ModelError, match="neither a library robot"):
        resolve_model(str(tmp_path / "absent.json"))


def test_builtin_limits_follow_the_spec():
    np.testing.assert_allclose(irb1600().limits_deg, [[-180, 180], [-90, 150], [-245, 65],
                                                      [-200, 200], [-115, 115], [-400, 400]])


@pytest.mark.parametrize("representation", ["screws", "dh", "mdh"])
def test_the_written_document_is_what_the_schema_reads_and_writes(rng, representation):
    """Documents are written without pydantic (`model_document`) and read through the schema
    (`modelschema`): the schema, dumping what it read, must give back the very document, gravity
    section and all, so that the writer can never drift from the reader."""
    from dataclasses import replace

    from screwcal.kinematics.compliance import Payload
    from screwcal.kinematics.modelschema import ADAPTER
    from screwcal.kinematics.robots import irb120

    soft = replace(irb120(), compliance_by_mass=rng.uniform(0, 1e-4, (6, 3)),
                   payload=Payload(0.7, (1.0, -2.0, 30.0)))
    for model in (random_model(rng, "RRPRRR"), irb1600(), soft):
        doc = model_document(model, representation)
        assert all(type(v) in (float, int, str, type(None)) for v in _leaves(doc)), doc
        assert ADAPTER.validate_python(doc).model_dump(mode="json") == doc
    assert model_document(soft)["gravity"]["compliance_by_mass_deg_per_knm"] is not None
    with pytest.raises(ModelError, match="representation"):
        model_document(irb1600(), "euler")  # type: ignore[arg-type]


def _leaves(x):
    """Every value of a decoded-JSON-like document (dicts and lists walked)."""
    if isinstance(x, dict):
        for v in x.values():
            yield from _leaves(v)
    elif isinstance(x, list | tuple):
        for v in x:
            yield from _leaves(v)
    else:
        yield x


def test_the_schema_names_the_format_modelfile_writes():
    """The schema spells the format out (a Literal needs the text; importing modelfile there
    was an import cycle): the two stay one fact."""
    from typing import get_args

    from screwcal.kinematics.modelfile import FORMAT
    from screwcal.kinematics.modelschema import _FileCommon

    field = _FileCommon.model_fields["format"]
    assert get_args(field.annotation) == (FORMAT,) and field.default == FORMAT
