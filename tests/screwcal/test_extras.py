"""The optional parts come as extras (pyproject: `[cluster]` for Dask, `[postgres]` for the
PostgreSQL store, both in `[test]`); asked for without them, the message names the extra."""

from __future__ import annotations

import sys
import tomllib
from pathlib import Path

import pytest

from screwcal.commands.main import main
from screwcal.errors import ExtraMissingError

ROOT = Path(__file__).resolve().parents[2]


def test_dask_and_psycopg_are_extras_both_in_test():
    project = tomllib.loads((ROOT / "pyproject.toml").read_text())["project"]
    hard = " ".join(project["dependencies"])
    assert "distributed" not in hard and "psycopg" not in hard
    extras = project["optional-dependencies"]
    assert any(d.startswith("distributed") for d in extras["cluster"])
    assert any(d.startswith("psycopg") for d in extras["postgres"])
    assert "screwcal[cluster,postgres]" in extras["test"]


def test_a_study_on_a_cluster_without_dask_names_the_extra(monkeypatch):
    from screwcal.studies.study import STUDIES, run_samples

    monkeypatch.setitem(sys.modules, "distributed", None)  # as if not installed
    with pytest.raises(ExtraMissingError, match=r"pip install 'screwcal\[cluster\]'"):
        run_samples(next(iter(STUDIES)), 1, 1, 1, scheduler="tcp://127.0.0.1:1")


def test_a_postgresql_store_without_psycopg_names_the_extra(monkeypatch, capsys, tmp_path):
    monkeypatch.setitem(sys.modules, "psycopg", None)
    code = main(["serve", "--db", f"postgresql://screwcal@/jobs?host={tmp_path}", "--port", "0"])
    err = capsys.readouterr().err
    assert code == 2 and "pip install 'screwcal[postgres]'" in err, err
    assert "Traceback" not in err and "PostgreSQL job store" in err
