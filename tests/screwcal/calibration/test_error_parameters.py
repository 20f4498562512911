import numpy as np
import pytest

from screwcal.calibration.error_parameters import ErrorModel, candidate_params
from screwcal.kinematics.forward import forward_kinematics, point_jacobian, spatial_jacobian
from screwcal.kinematics.robots import irb1600
from screwcal.kinematics.se3 import exp_twist
from tests.conftest import point_rates, random_model, random_q


def assert_central_differences(errors: ErrorModel, x: np.ndarray, q: np.ndarray,
                               J: np.ndarray) -> None:
    """Each parameter's column of J (N, 6, P) against central differences of the tool point
    and of its rotation."""
    h = 1e-6
    for k, p in enumerate(errors.params):
        step = np.zeros(len(errors.params))
        step[k] = h
        fd = point_rates(forward_kinematics(errors.apply(x + step), q),
                         forward_kinematics(errors.apply(x - step), q), 2 * h)
        np.testing.assert_allclose(J[:, :, k], fd, atol=2e-5 * max(1, np.abs(fd).max()),
                                   err_msg=p.name)


@pytest.mark.parametrize("kind", ["joints", "thesis", "full"])
def test_error_model_linearisation_is_exact_away_from_zero(rng, kind):
    """The tool point's and rotation's rates w.r.t. x against central differences at a
    random, non-zero x."""
    model = irb1600().with_frames(exp_twist([0.3, -0.2, 1.0, 1500, -200, 300]),
                                  exp_twist([0.1, 0.2, 0.0, 20, -30, 100]))
    params = candidate_params(model, kind, base=True, tool_rotation=True, tool_position=True)
    errors = ErrorModel(model, tuple(params))
    x = rng.normal(0, 0.02, len(params)) * np.where([p.unit == "mm" for p in params], 100, 1)
    q = random_q(model, rng, 8)
    _, J, _ = errors.linearisation(x, q)
    assert_central_differences(errors, x, q, J)


@pytest.mark.parametrize("types", ["RRRRRR", "RPRRPR", "PPP"])
def test_full_model_linearisation_is_exact_for_any_joint_types(rng, types):
    """Random arms with prismatic joints too (a prismatic axis has its direction and its zero;
    its location is no parameter), every frame identified, at a random x."""
    model = random_model(rng, types)
    params = candidate_params(model, "full", base=True, tool_rotation=True, tool_position=True)
    errors = ErrorModel(model, tuple(params))
    x = rng.normal(0, 0.01, len(params)) * np.where([p.unit == "mm" for p in params], 50, 1)
    q = random_q(model, rng, 10)
    _, J, Jq = errors.linearisation(x, q)
    assert_central_differences(errors, x, q, J)
    T = forward_kinematics(errors.apply(x), q)
    np.testing.assert_allclose(Jq, point_jacobian(spatial_jacobian(errors.apply(x), q), T),
                               atol=1e-9 * np.abs(Jq).max())


@pytest.mark.parametrize("types", ["RRRRRR", "RPRRPR", "RRRRRRR"])
def test_linearisation_of_a_batch_equals_one_pose_at_a_time(rng, types):
    model = random_model(rng, types)
    params = candidate_params(model, "full", base=True, tool_rotation=True, tool_position=True)
    errors = ErrorModel(model, tuple(params))
    x = rng.normal(0, 0.01, len(params))
    q = random_q(model, rng, 30)
    T, J, Jq = errors.linearisation(x, q)
    one = [errors.linearisation(x, q[k:k + 1]) for k in range(len(q))]
    for whole, each in ((T, 0), (J, 1), (Jq, 2)):
        alone = np.concatenate([o[each] for o in one])
        np.testing.assert_allclose(whole, alone, rtol=0, atol=1e-12 * np.abs(whole).max())


def test_a_revolute_axis_has_four_independent_parameters(rng):
    """Two turns about the axis' normals and two shifts along them: independent columns (a turn
    or a shift along the axis itself would change nothing)."""
    model = random_model(rng)
    params = candidate_params(model, "full", base=False, tool_rotation=False,
                              tool_position=False)
    errors = ErrorModel(model, tuple(params))
    _, J, _ = errors.linearisation(np.zeros(len(params)), random_q(model, rng, 30))
    axis = [k for k, p in enumerate(params) if p.joint == 2 and p.kind in ("dir", "point")]
    assert [params[k].name for k in axis] == ["J3.dir.u", "J3.dir.v", "J3.pos.u", "J3.pos.v"]
    columns = J[:, :, axis].reshape(-1, 4)
    assert np.linalg.matrix_rank(columns, tol=1e-8 * np.abs(columns).max()) == 4


def test_full_model_candidate_count():
    params = candidate_params(irb1600(), "full", base=False, tool_rotation=False,
                              tool_position=False)
    assert len(params) == 6 * 5 + 6  # 2 dir + 2 location + zero per joint, home flange


@pytest.mark.parametrize("compliance", ["none", "j23", "j23-free"])
def test_linearisation_is_exact_for_parameters_and_joints(rng, compliance):
    """The point rates of every parameter and every joint, built as two matrix products over
    all poses, against central differences of the tool point and its rotation, at a random
    x (compliance at zero: its columns are the torques', exact there; the bent model's own are
    test_compliance's), with a payload; a bent model's joint rates are spatial_jacobian's."""
    from dataclasses import replace

    from screwcal.kinematics.compliance import Payload

    model = replace(irb1600(), payload=Payload(5.0, (0.0, 30.0, 80.0))).with_frames(
        exp_twist([0.3, -0.2, 1.0, 1500, -200, 300]), exp_twist([0.1, 0.2, 0.0, 20, -30, 100]))
    params = candidate_params(model, "full", base=True, tool_rotation=True, tool_position=True,
                              compliance=compliance)
    params += candidate_params(model, "thesis", base=False, tool_rotation=False,
                               tool_position=False)[6:]  # the link offsets
    errors = ErrorModel(model, tuple(params))
    x = rng.normal(0, 0.02, len(params)) * np.where([p.unit == "mm" for p in params], 100, 1)
    bending = [k for k, p in enumerate(params) if p.kind.startswith("compliance")]
    x[bending] = 0.0
    q = random_q(model, rng, 7)
    T, J, Jq = errors.linearisation(x, q)
    assert_central_differences(errors, x, q, J)
    h = 1e-6
    straight = errors.apply(x)
    for j in range(model.n_joints):
        step = np.zeros(model.n_joints)
        step[j] = h
        fd = point_rates(forward_kinematics(straight, q + step),
                         forward_kinematics(straight, q - step), 2 * h)
        np.testing.assert_allclose(Jq[:, :, j], fd, atol=2e-5 * max(1, np.abs(fd).max()),
                                   err_msg=f"joint {j + 1}")
    x[bending] = np.radians(5.0)  # deg per kN m
    T, _, Jq = errors.linearisation(x, q)
    np.testing.assert_allclose(Jq, point_jacobian(spatial_jacobian(errors.apply(x), q), T),
                               atol=1e-9)


def test_every_parameter_kind_has_its_carrier_and_names_its_frame():
    """Parameter kinds are one enum (error_parameters.ParamKind): each says which frame
    carries its twist; the frames' kinds name their frame; a kind is still its string."""
    import json

    from screwcal.calibration.error_parameters import Carrier, Param, ParamKind

    assert {k.carrier for k in ParamKind} == set(Carrier)
    assert [k.frame for k in ParamKind if k.frame] == ["home", "home", "base", "base", "tool",
                                                       "tool"]
    assert {k for k in ParamKind if k.is_compliance} == {ParamKind.COMPLIANCE,
                                                        ParamKind.COMPLIANCE_MASS}
    p = Param("J1", "deg", "zero", joint=0)  # type: ignore[arg-type]  # (a string is taken)
    assert p.kind is ParamKind.ZERO and p.kind == "zero" and json.dumps(p.kind) == '"zero"'
    assert Param("base.x", "mm", ParamKind.BASE_POS, axis=0).group == "base"
    assert Param("home.x", "mm", ParamKind.HOME_POS, axis=0).group == "robot"
    with pytest.raises(ValueError):
        Param("J1", "deg", "zeros", joint=0)  # type: ignore[arg-type]
