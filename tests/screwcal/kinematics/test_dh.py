import numpy as np
import pytest

from screwcal.kinematics.dh import (
    DHRow,
    DHTable,
    dh_forward_kinematics,
    dh_from_model,
    model_from_dh,
)
from screwcal.kinematics.forward import flange_kinematics
from screwcal.kinematics.robots import irb120, irb1600
from tests.conftest import random_model, random_q


@pytest.mark.parametrize("convention", ["dh", "mdh"])
@pytest.mark.parametrize("make", [irb1600, irb120])
def test_builtin_models_as_dh_give_the_same_flange_poses(rng, convention, make):
    model = make()
    table = dh_from_model(model, convention)
    q = random_q(model, rng, 500)
    np.testing.assert_allclose(dh_forward_kinematics(table, q, model.joint_zero),
                               flange_kinematics(model, q), atol=1e-9)


@pytest.mark.parametrize("convention", ["dh", "mdh"])
@pytest.mark.parametrize("types", ["RRRRRR", "RPRRPR", "PRP"])
def test_random_models_round_trip_through_dh(rng, convention, types):
    for _ in range(20):
        model = random_model(rng, types, frames=False)
        table = dh_from_model(model, convention)
        back = model_from_dh(table, "back", model.limits, model.joint_zero)
        q = random_q(model, rng, 200)
        expected = flange_kinematics(model, q)
        np.testing.assert_allclose(dh_forward_kinematics(table, q, model.joint_zero), expected,
                                   atol=1e-8)
        np.testing.assert_allclose(flange_kinematics(back, q), expected, atol=1e-8)


def test_irb1600_standard_dh_table_reads_as_expected():
    """The familiar table: d1 = 486.5, a1 = 150, alpha1 = -90, a2 = 475, d4 = 600, d6 = 65."""
    table = dh_from_model(irb1600(), "dh")
    a = [r.a_mm for r in table.rows]
    d = [r.d_mm for r in table.rows]
    alpha = np.degrees([r.alpha for r in table.rows])
    np.testing.assert_allclose(a, [150, 475, 0, 0, 0, 0], atol=1e-9)
    np.testing.assert_allclose(d, [486.5, 0, 0, 600, 0, 65], atol=1e-9)
    np.testing.assert_allclose(np.abs(alpha), [90, 0, 90, 90, 90, 0], atol=1e-9)
    np.testing.assert_allclose(table.dh_base, np.eye(4), atol=1e-12)


def test_dh_table_to_screws_matches_independent_dh_fk(rng):
    """A hand-written DH table (a PUMA-like arm) gives the same poses through the screw model."""
    rows = (DHRow(0, -np.pi / 2, 400, 0), DHRow(300, 0, 0, -np.pi / 2),
            DHRow(50, -np.pi / 2, 0, 0), DHRow(0, np.pi / 2, 350, 0),
            DHRow(0, -np.pi / 2, 0, 0), DHRow(0, 0, 80, 0))
    table = DHTable("dh", rows, np.eye(4), np.eye(4))
    limits = np.tile([-np.pi, np.pi], (6, 1))
    model = model_from_dh(table, "puma-like", limits)
    q = random_q(model, rng, 300)
    np.testing.assert_allclose(flange_kinematics(model, q), dh_forward_kinematics(table, q),
                               atol=1e-9)
