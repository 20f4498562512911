import numpy as np
import pytest

from screwcal.calibration.error_parameters import ErrorModel, candidate_params
from screwcal.kinematics.forward import forward_kinematics
from screwcal.kinematics.robots import irb1600
from screwcal.kinematics.se3 import exp_twist, twist_from_transform_difference
from tests.conftest import random_q


@pytest.mark.parametrize("kind", ["joints", "thesis", "full"])
def test_error_model_jacobian_is_exact_away_from_zero(rng, kind):
    """d(tool twist)/dx against central differences at a random, non-zero x."""
    model = irb1600().with_frames(exp_twist([0.3, -0.2, 1.0, 1500, -200, 300]),
                                  exp_twist([0.1, 0.2, 0.0, 20, -30, 100]))
    params = candidate_params(model, kind, base=True, tool_rotation=True, tool_position=True)
    errors = ErrorModel(model, tuple(params))
    x = rng.normal(0, 0.02, len(params)) * np.where([p.unit == "mm" for p in params], 100, 1)
    q = random_q(model, rng, 8)
    T, J = errors.jacobian(x, q)
    h = 1e-6
    for k, p in enumerate(params):
        step = np.zeros(len(params))
        step[k] = h
        fd = twist_from_transform_difference(
            forward_kinematics(
                errors.apply(x + step), q),
            forward_kinematics(
                errors.apply(x - step), q), T, h)
        np.testing.assert_allclose(J[:, :, k], fd, atol=2e-5 * max(1, np.abs(fd).max()),
                                   err_msg=p.name)


def test_full_model_candidate_count():
    params = candidate_params(irb1600(), "full", base=False, tool_rotation=False,
                              tool_position=False)
    assert len(params) == 6 * 5 + 6  # 2 dir + 2 location + zero per joint, home flange
