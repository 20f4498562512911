from dataclasses import replace

import numpy as np
import pytest

from screwcal.calibration.virtual_joints import THESIS_TABLE11, apply_virtual_joints
from screwcal.errors import ModelError, UnreachableError
from screwcal.kinematics.forward import forward_kinematics
from screwcal.kinematics.ik import BRANCHES, closed_form_ik, numerical_ik
from screwcal.kinematics.ik_solutions import controller_readings
from screwcal.kinematics.robots import irb120, irb1600
from screwcal.kinematics.se3 import exp_twist
from tests.conftest import random_q


def _assert_branches_reach(model, sol, T):
    """Every valid branch's FK equals its target (position and orientation)."""
    ok = sol.valid
    k, b = np.nonzero(ok)
    T_b = forward_kinematics(model, sol.q[k, b])
    np.testing.assert_allclose(T_b[:, :3, 3], T[k, :3, 3], atol=1e-7)
    np.testing.assert_allclose(T_b[:, :3, :3], T[k, :3, :3], atol=1e-10)


def _contains(sol, q):
    d = np.abs((sol.q - q[:, None, :] + np.pi) % (2 * np.pi) - np.pi).max(axis=2)
    return np.nanmin(d, axis=1) < 1e-7


@pytest.mark.parametrize("make", [irb1600, irb120])
def test_closed_form_round_trip_every_branch(rng, make):
    model = make()
    q = random_q(model, rng, 5000)
    T = forward_kinematics(model, q)
    sol = closed_form_ik(model, T)
    assert sol.q.shape == (5000, 8, 6) and len(sol.branches) == 8
    assert _contains(sol, q).all()  # the configuration that made the pose is one of the branches
    _assert_branches_reach(model, sol, T)
    # Every branch is exercised, and its flags are honest.
    assert sol.valid.any(axis=0).all(), "a branch never produced a valid solution"
    assert (model.within_limits(sol.q[sol.valid])).all()
    outside = sol.reachable & ~sol.within_limits
    assert outside.any() and not model.within_limits(sol.q[outside]).any()


def test_branch_labels_are_distinct_configurations(rng):
    model = irb1600()
    q = np.radians([[10, 20, -30, 40, 50, 60]])
    sol = closed_form_ik(model, forward_kinematics(model, q))
    assert set(BRANCHES) == {(s, e, w) for s in ("front", "back") for e in ("up", "down")
                             for w in ("noflip", "flip")}
    found = sol.q[0][sol.reachable[0]]
    assert len(np.unique(np.round(found, 9), axis=0)) == len(found)


def test_nearest_returns_the_seed_configuration(rng):
    model = irb1600()
    q = random_q(model, rng, 200)
    sol = closed_form_ik(model, forward_kinematics(model, q))
    np.testing.assert_allclose(sol.nearest(q), q, atol=1e-7)


def test_unreachable_target_raises_naming_it():
    model = irb1600()
    T = forward_kinematics(model, np.zeros((3, 6)))
    T[1, :3, 3] = [3000.0, 0, 500]
    with pytest.raises(UnreachableError, match="target 1 is out of the arm's reach"):
        closed_form_ik(model, T)


def test_all_branches_outside_limits_raise_on_nearest():
    model = irb1600()
    narrow = replace(model, limits=np.radians([[-1, 1]] * 6))
    sol = closed_form_ik(narrow, forward_kinematics(model, np.radians([[90, 0, 0, 0, 30, 0]])))
    assert not sol.within_limits.any()
    with pytest.raises(UnreachableError, match="outside the joint limits"):
        sol.nearest(np.zeros(6))


def test_closed_form_refuses_a_calibrated_model():
    with pytest.raises(ModelError, match="numerical_ik"):
        closed_form_ik(replace(irb1600(), axis_dirs=_tilted(irb1600().axis_dirs)),
                       np.eye(4)[None])


def test_closed_form_names_the_joints_that_are_not_ideal():
    m = irb1600()
    dirs = m.axis_dirs.copy()
    dirs[2] = [0.0, np.cos(1e-4), np.sin(1e-4)]  # joint 3 tilted
    points = m.axis_points_mm.copy()
    points[4, 1] = 0.01  # joint 5 off the arm plane
    with pytest.raises(ModelError, match=r"joints \[3, 5\] differ"):
        closed_form_ik(replace(m, axis_dirs=dirs, axis_points_mm=points), np.eye(4)[None])
    dirs[2] = [0.0, 1.0, 5e-10]  # within the tolerance: accepted
    closed_form_ik(replace(m, axis_dirs=dirs / np.linalg.norm(dirs, axis=1, keepdims=True)),
                   forward_kinematics(m, np.zeros((1, 6))))


def _tilted(dirs):
    d = dirs + np.array([[0, 1e-3, 0]] + [[0, 0, 0]] * 5)
    return d / np.linalg.norm(d, axis=1, keepdims=True)


def test_numerical_ik_of_a_calibrated_model(rng):
    truth = apply_virtual_joints(irb1600(), THESIS_TABLE11)
    truth = replace(truth, axis_dirs=_tilted(truth.axis_dirs),
                    base=exp_twist([0.01, -0.02, 0.03, 100, -50, 20]),
                    tool=exp_twist([0.0, 0.0, 0.1, 0, 10, 120]))
    q = random_q(truth, rng, 300)
    T = forward_kinematics(truth, q)
    sol = numerical_ik(truth, T)
    assert _contains(sol, q).all()
    _assert_branches_reach(truth, sol, T)


def test_ik_rejects_bad_target_shapes():
    with pytest.raises(ValueError, match=r"\(N, 4, 4\)"):
        closed_form_ik(irb1600(), np.eye(4))


@pytest.mark.parametrize("make", [irb1600, irb120])
def test_ik_batch_equals_one_by_one(rng, make):
    # frames, joint zeros and limits that make some branches turn (J3 of the IRB 1600) or fall
    # outside; far targets, which some arms cannot reach
    nominal = make()
    model = replace(nominal, joint_zero=rng.normal(0, 0.05, 6),
                    limits=nominal.limits * rng.uniform(0.6, 1.0, (6, 1))).with_frames(
        exp_twist([0.1, -0.2, 0.3, 1500, -300, 200]), exp_twist([0, 0, 0, 30, -20, 80]))
    q = random_q(nominal, rng, 60)
    q[50:, 1:3] = np.radians([70.0, -80.0])  # leaning forward, nearly stretched
    T = forward_kinematics(model, q)
    T[-1, :3, 3] *= 3.0  # out of reach of every arm
    batch = closed_form_ik(model, T, require_all=False)
    for k in range(len(T)):
        single = closed_form_ik(model, T[k:k + 1], require_all=False)  # the scalar path
        np.testing.assert_allclose(single.q[0], batch.q[k], rtol=0, atol=1e-12)
        for name in ("reachable", "within_limits"):
            np.testing.assert_array_equal(getattr(single, name)[0], getattr(batch, name)[k])
        np.testing.assert_allclose(single.residual_mm[0], batch.residual_mm[k], atol=1e-9)
    assert (~batch.within_limits & batch.reachable).any() and batch.within_limits.any()
    assert (~batch.reachable).any()
    assert batch.residual_mm[batch.reachable].max() < 1e-8


def test_readings_wrap_into_the_limits_by_whole_turns(rng):
    """The rule the closed form's readings follow, from its definition: joint zero removed,
    wrapped to [-pi, pi), a whole turn added or taken where that brings a reading outside the
    limits inside them."""
    model = irb1600()
    for _ in range(20):
        lo = rng.uniform(-2 * np.pi, 0.5, 6)
        limits = np.stack([lo, lo + rng.uniform(0.2, 3 * np.pi, 6)], axis=1)
        m = replace(model, limits=limits, joint_zero=rng.normal(0, 0.1, 6))
        theta = rng.uniform(-10, 10, (50, 8, 6))
        got, within = controller_readings(m, theta)
        x = (theta - m.joint_zero + np.pi) % (2 * np.pi) - np.pi
        lo, hi = limits[:, 0], limits[:, 1]
        want = np.where((x < lo) & (x + 2 * np.pi <= hi), x + 2 * np.pi,
                        np.where((x > hi) & (x - 2 * np.pi >= lo), x - 2 * np.pi, x))
        np.testing.assert_allclose(got, want, rtol=0, atol=1e-12)
        np.testing.assert_array_equal(within, ((want >= lo) & (want <= hi)).all(axis=-1))


def test_remainder_of_turns_is_numpys_remainder_bit_for_bit(rng):
    from screwcal.kinematics.ik_solutions import _remainder_of_turns

    tau = 2 * np.pi
    x = np.concatenate([rng.uniform(-30, 30, 100_000), rng.normal(0, 1e-18, 100),
                        np.arange(-10, 11) * tau,
                        [np.nan, 0.0, -0.0, 1e300, -1e300, -1e-300, np.nextafter(tau, 0),
                         -np.nextafter(tau, 0), np.nextafter(-0.0, -1.0)]])
    got, want = _remainder_of_turns(x.copy()), x % tau
    np.testing.assert_array_equal(got, want)
    np.testing.assert_array_equal(np.signbit(got), np.signbit(want))  # -0.0 as numpy's


@pytest.mark.parametrize("name", ["irb1600", "kr16", "lrmate200id", "ur5e"])
def test_one_branch_is_that_branch_of_all_eight(rng, name):
    """`branch=` solves one branch alone (testcube's screening of thousands of candidate
    cubes): the same joints, masks and residuals as that column of all eight."""
    from screwcal.kinematics.ik_branches import all_branches
    from screwcal.kinematics.robots import builtin_model

    model = builtin_model(name)
    q = random_q(model, rng, 300)
    q[:20, 4] = 0.0  # the wrist singularity
    T = forward_kinematics(model.with_frames(np.eye(4), np.eye(4)), q)
    T[-10:, :3, 3] *= 3.0  # out of reach
    full = all_branches(model, T)
    solvers = [lambda b: all_branches(model, T, branch=b)]
    if name.startswith("irb"):
        solvers.append(lambda b: closed_form_ik(model, T, require_all=False, branch=b))
        full_cf = closed_form_ik(model, T, require_all=False)
    for b in range(8):
        for k, solve in enumerate(solvers):
            one = solve(b)
            ref = full if k == 0 else full_cf
            assert one.q.shape == (len(T), 1, 6) and one.branches == (BRANCHES[b],)
            np.testing.assert_array_equal(one.q[:, 0], ref.q[:, b])
            for mask in ("reachable", "within_limits"):
                np.testing.assert_array_equal(getattr(one, mask)[:, 0], getattr(ref, mask)[:, b])
            np.testing.assert_allclose(one.residual_mm[:, 0], ref.residual_mm[:, b], atol=1e-9)
    assert (~full.reachable).any() and full.reachable.any()


def test_nearest_chain_takes_each_valid_solution_nearest_the_one_before(rng):
    """The controller's rule for targets without flags, written out target by target: the
    flagged ones carried on, one with no valid solution skipped (the next measured from the
    one before it)."""
    from screwcal.kinematics.ik_branches import all_branches
    from screwcal.kinematics.maker_configs import _candidates, nearest_chain
    from screwcal.kinematics.robots import builtin_model

    model = builtin_model("ur5e")
    q = random_q(model, rng, 200)
    T = forward_kinematics(model.with_frames(np.eye(4), np.eye(4)), q)
    T[::17, :3, 3] *= 5.0  # out of reach
    sol = all_branches(model, T)
    fixed = np.where(rng.random((200, 1)) < 0.3, q, np.nan)
    start = np.radians([10.0, -100.0, 90.0, -80.0, -90.0, 20.0])
    got, found = nearest_chain(sol, start, fixed)
    cand = _candidates(sol).reshape(200, -1, 6)
    prev = start
    for k in range(200):
        if np.isfinite(fixed[k]).all():
            want = fixed[k]
        else:
            dist = np.linalg.norm(cand[k] - prev, axis=-1)
            if np.isnan(dist).all():
                assert not found[k] and np.isnan(got[k]).all()
                continue
            want = cand[k, np.nanargmin(dist)]
        assert found[k]
        np.testing.assert_array_equal(got[k], want)
        prev = want
    assert (~found).any() and np.isfinite(fixed).all(axis=1).any()


@pytest.mark.parametrize("name", ["irb1600", "kr16", "lrmate200id", "ur5e"])
def test_branch_of_is_branch_index_of_all_eight(rng, name):
    """`branch_of` (the compensated program's flags) solves a target's hinted branch and its
    elbow partner only: the branch `branch_index` finds among all eight, wherever the hint is
    right, wrong or missing, on the stretched arm (elbow up and down coincide: the first wins),
    at the wrist singularity, a whole turn off, and for joints on no branch."""
    from screwcal.kinematics.ik_branches import all_branches, branch_of
    from screwcal.kinematics.maker_configs import branch_index
    from screwcal.kinematics.robots import builtin_model

    model = builtin_model(name)
    flange = model.with_frames(np.eye(4), np.eye(4))
    q = random_q(model, rng, 400)
    sol = all_branches(model, forward_kinematics(flange, q))
    k = int(np.flatnonzero(sol.reachable[:, 0] & sol.reachable[:, 2])[0])
    up, down = sol.q[k, 0, 2], sol.q[k, 2, 2]
    q[:100, 2] = up + (np.mod(down - up + np.pi, 2 * np.pi) - np.pi) / 2  # arm stretched
    q[100:120, 4] = 0.0  # the wrist singularity
    T = forward_kinematics(flange, q)
    full = all_branches(model, T)
    b = np.array([rng.choice(np.flatnonzero(r)) if r.any() else 0 for r in full.reachable])
    joints = np.nan_to_num(full.q[np.arange(len(q)), b])
    joints[::7, 5] += 2 * np.pi  # a whole turn off
    joints[::11, 1] += 1e-3  # on no branch
    hint = b.copy()
    hint[::5] = rng.integers(0, 8, hint[::5].size)  # a wrong hint
    hint[::13] = -1
    want = branch_index(full, joints)
    np.testing.assert_array_equal(branch_of(model, T, joints, hint), want)
    if not name.startswith("ur"):  # the stretched arm's elbow-down joints are the up branch's
        assert ((b[:100] % 4 >= 2) & (want[:100] >= 0) & (want[:100] % 4 < 2)).any()
    assert (want == -1).any() and (want >= 0).any()
