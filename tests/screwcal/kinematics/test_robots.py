"""The robot library against its datasheets, and every library robot through every export and
back (issue 27)."""

from dataclasses import replace

import numpy as np
import pytest

from screwcal.errors import DegenerateTableError, ModelError
from screwcal.kinematics.describe import description_text, read_description
from screwcal.kinematics.dh import dh_forward_kinematics, dh_from_model
from screwcal.kinematics.forward import flange_kinematics, forward_kinematics
from screwcal.kinematics.robots import ENTRIES, LIBRARY, builtin_model, reach_mm
from screwcal.kinematics.se3 import exp_twist, rotation_from_rotvec
from screwcal.kinematics.urdf import model_from_urdf, urdf_from_model
from tests.conftest import random_q

NAMES = [e.name for e in ENTRIES]


def calibrated(model, rng):
    """The model as a calibration leaves it: axes tilted by ~0.01 deg, moved by ~0.2 mm, joint
    zeros, measuring frame and measured point (parallel axes stop being parallel)."""
    dirs = np.array([rotation_from_rotvec(rng.normal(0, 2e-4, 3)) @ d for d in model.axis_dirs])
    return replace(model, axis_dirs=dirs,
                   axis_points_mm=model.axis_points_mm + rng.normal(0, 0.2, (6, 3)),
                   joint_zero=rng.normal(0, 1e-3, 6),
                   base=exp_twist([0.1, 0.2, -0.3, 500, 100, -20]),
                   tool=exp_twist([0.0, 0.0, 0.1, 10, 20, 150]))


def test_the_library_has_the_arms_the_issue_lists():
    assert set(NAMES) >= {"irb120", "irb1200", "irb1600", "irb2600", "irb4600", "irb6700",
                          "kr6-r900", "kr10-r900", "kr16", "lrmate200id", "m20ia", "ur5e",
                          "ur10e"}


@pytest.mark.parametrize("name", NAMES)
def test_each_robot_reproduces_its_datasheet_figure(name):
    entry = LIBRARY[name]
    model = entry.model()
    check = entry.check
    if check.what == "reach_mm":
        assert reach_mm(model) == pytest.approx(check.value[0], abs=check.tol_mm)
    else:
        np.testing.assert_allclose(model.home_flange[:3, 3], check.value, atol=check.tol_mm)
    assert entry.source and entry.total_kg > 0
    assert model.masses and sum(m.kg for m in model.masses) < entry.total_kg
    assert np.all(model.limits[:, 0] < 0) and np.all(model.limits[:, 1] > 0)


def test_joint_directions_and_tool0_follow_each_maker():
    """FANUC's tool0 has x up (ROS-Industrial's joint_6-tool0 rpy (pi, -pi/2, 0)), ABB's and
    KUKA's x down; the LR Mate's J6 and the M-20iA's turn about -x."""
    for name, x_axis in (("m20ia", [0, 0, 1]), ("irb2600", [0, 0, -1]), ("kr16", [0, 0, -1])):
        flange = LIBRARY[name].model().home_flange
        np.testing.assert_allclose(flange[:3, 0], x_axis, atol=1e-12)
        np.testing.assert_allclose(flange[:3, 2], [1, 0, 0], atol=1e-12)
    assert LIBRARY["lrmate200id"].model().axis_dirs[5].tolist() == [-1, 0, 0]
    assert LIBRARY["m20ia"].model().axis_dirs[5].tolist() == [-1, 0, 0]


@pytest.mark.parametrize("name", [e.name for e in ENTRIES if e.check.what == "reach_mm"])
def test_a_robot_3_percent_too_small_fails_its_reach_check(name):
    """The check discriminates: the library's own arm with every length 3 % short (axis points
    and flange scaled about the base) misses its datasheet figure, by about 3 % of the reach."""
    entry = LIBRARY[name]
    model = entry.model()
    flange = model.home_flange.copy()
    flange[:3, 3] *= 0.97
    small = replace(model, axis_points_mm=0.97 * model.axis_points_mm, home_flange=flange)
    assert reach_mm(small) == pytest.approx(0.97 * reach_mm(model), rel=1e-3)
    assert abs(reach_mm(small) - entry.check.value[0]) > entry.check.tol_mm


def test_unknown_robot_names_what_is_accepted():
    with pytest.raises(ModelError, match=r"irb6700.*ur10e.*robot import"):
        builtin_model("kuka-kr16")


@pytest.mark.parametrize("fmt", ["urdf", "mdh", "screws", "json"])
@pytest.mark.parametrize("name", NAMES)
def test_calibrated_robot_exports_and_reads_back_to_the_same_kinematics(tmp_path, rng, name, fmt):
    model = calibrated(LIBRARY[name].model(), rng)
    text, _ = description_text(model, fmt)
    path = tmp_path / f"robot.{fmt}"
    path.write_text(text)
    back, _ = read_description(path)
    q = random_q(model, rng, 2000)
    err = np.abs(forward_kinematics(back, q)[:, :3, 3] - forward_kinematics(model, q)[:, :3, 3])
    assert err.max() < 1e-6
    rot = np.abs(forward_kinematics(back, q)[:, :3, :3] - forward_kinematics(model, q)[:, :3, :3])
    assert rot.max() < 1e-9


@pytest.mark.parametrize("name", NAMES)
def test_nominal_robot_exports_as_standard_dh(tmp_path, rng, name):
    model = LIBRARY[name].model()
    path = tmp_path / "dh.json"
    path.write_text(description_text(model, "dh")[0])
    back, form = read_description(path, "dh")
    q = random_q(model, rng, 500)
    assert form == "dh"
    np.testing.assert_allclose(flange_kinematics(back, q), flange_kinematics(model, q), atol=1e-9)


def test_standard_dh_of_a_calibrated_robot_is_refused_with_the_form_to_use(rng):
    """Parallel axes 2-3 off by ~0.01 deg gave d = 3.2e7 mm (KUKA) silently; now refused."""
    model = calibrated(LIBRARY["kr16"].model(), rng)
    with pytest.raises(DegenerateTableError, match=r"axes 2 and 3 .*mdh"):
        dh_from_model(model, "dh")


def test_mdh_has_hayati_beta_and_no_huge_offsets_for_parallel_axes(rng):
    for name in NAMES:
        model = calibrated(LIBRARY[name].model(), rng)
        table = dh_from_model(model, "mdh")
        size = np.abs(model.axis_points_mm).max() + np.linalg.norm(model.home_flange[:3, 3])
        assert max(max(abs(r.a_mm), abs(r.d_mm)) for r in table.rows) < size
        assert any(abs(r.beta) > 0 for r in table.rows)  # axes 2-3 (and UR's 3-4) take beta
        q = random_q(model, rng, 500)
        np.testing.assert_allclose(dh_forward_kinematics(table, q, model.joint_zero),
                                   flange_kinematics(model, q), atol=1e-8)


def test_dh_file_with_beta_is_refused(tmp_path):
    import json

    doc = json.loads(description_text(LIBRARY["irb120"].model(), "dh")[0])
    doc["joints"][2]["beta_deg"] = 0.1
    path = tmp_path / "bad.json"
    path.write_text(json.dumps(doc))
    with pytest.raises(ModelError, match=r"beta.*mdh"):
        read_description(path)


def test_urdf_has_ros_industrial_links_and_the_measuring_links():
    import xml.etree.ElementTree as ET

    root = ET.fromstring(urdf_from_model(LIBRARY["irb2600"].model()))
    links = [e.get("name") for e in root.findall("link")]
    assert links[:7] == ["base_link", *(f"link_{i}" for i in range(1, 7))]
    assert {"flange", "tool0", "measuring_frame", "measured_point"} <= set(links)


def test_urdf_keeps_masses_and_limits():
    model = LIBRARY["irb4600"].model()
    back, _ = model_from_urdf(urdf_from_model(model))
    np.testing.assert_allclose(back.limits, model.limits, atol=1e-12)
    assert [m.kg for m in back.masses] == pytest.approx([m.kg for m in model.masses])
    np.testing.assert_allclose([m.home_mm for m in back.masses],
                               [m.home_mm for m in model.masses], atol=1e-9)


@pytest.mark.parametrize("text, message", [
    ("<robot name='x'><link name='a'/></robot>", "no moving joint"),
    ("<robt/>", "not a URDF"),
    ("<robot", "XML error"),
    ("<robot name='x'><link name='base_link'/><link name='b'/><joint name='j' type='revolute'>"
     "<parent link='base_link'/><child link='b'/><axis xyz='0 0 z'/></joint></robot>", "axis"),
])
def test_bad_urdf_is_refused_with_the_reason(text, message):
    with pytest.raises(ModelError, match=message):
        model_from_urdf(text, "r.urdf")


@pytest.mark.parametrize("name", NAMES)
def test_exported_urdf_loads_in_a_urdf_library_with_our_kinematics(tmp_path, rng, name):
    """yourdfpy (as ROS tools read URDF) gives the calibrated robot's tool0 in base_link and the
    measured point in the measuring frame as our model does."""
    yourdfpy = pytest.importorskip("yourdfpy")
    model = calibrated(LIBRARY[name].model(), rng)
    path = tmp_path / "robot.urdf"
    path.write_text(urdf_from_model(model))
    urdf = yourdfpy.URDF.load(str(path), load_meshes=False, build_collision_scene_graph=False,
                              load_collision_meshes=False)
    assert urdf.actuated_joint_names == [f"joint_{i}" for i in range(1, 7)]
    q = random_q(model, rng, 20)
    tool0, measured = flange_kinematics(model, q), forward_kinematics(model, q)
    for k in range(len(q)):
        urdf.update_cfg(q[k])
        T = urdf.get_transform("tool0", "base_link")
        assert np.abs(T[:3, 3] * 1000.0 - tool0[k, :3, 3]).max() < 1e-6
        np.testing.assert_allclose(T[:3, :3], tool0[k, :3, :3], atol=1e-9)
        T = urdf.get_transform("measured_point", "measuring_frame")
        assert np.abs(T[:3, 3] * 1000.0 - measured[k, :3, 3]).max() < 1e-6


@pytest.mark.parametrize("name", NAMES)
def test_numerical_ik_of_every_library_robot(rng, name):
    """KUKA targets were refused as outside the limits on every branch: the seeds turned the
    reversed axes the wrong way; UR targets as out of reach: the ABB-type closed form seeded an
    arm without a spherical wrist (now seeded from sampled configurations)."""
    from screwcal.kinematics.ik import numerical_ik

    model = calibrated(LIBRARY[name].model(), rng).with_frames(np.eye(4), np.eye(4))
    q = rng.uniform(model.limits[:, 0] * 0.5, model.limits[:, 1] * 0.5, (40, 6))
    q[:, 4] = np.where(np.abs(q[:, 4]) < 0.2, 0.3, q[:, 4])  # away from the wrist singularity
    T = flange_kinematics(model, q)
    sols = numerical_ik(model, T)
    assert sols.reachable.any(axis=1).all()
    best = np.nanmin(sols.residual_mm, axis=1)
    assert best.max() < 1e-6


@pytest.mark.parametrize("full_pose", [True, False])
@pytest.mark.parametrize("name", NAMES)
def test_every_library_robot_calibrates_to_the_noise_floor(rng, name, full_pose):
    """Simulated data of a calibrated twin (axes tilted, moved, zeros, unknown frames): the
    full error model predicts unseen poses to the measuring noise (0.013 mm per coordinate)."""
    from screwcal.calibration.identify import NoiseModel, identify
    from screwcal.calibration.posesets import random_set
    from screwcal.studies.simulated_measurements import simulate_measurements

    nominal = LIBRARY[name].model()
    truth = calibrated(nominal, rng)
    data = simulate_measurements(truth, random_set(nominal, 60, seed=1), rng,
                                 joint_noise_deg=0.0, full_pose=full_pose)
    result = identify(nominal, data, kind="full", frames="unknown", noise=NoiseModel(joint_deg=0))
    assert result.converged and not result.degenerate
    q = random_set(nominal, 300, seed=2)
    d = forward_kinematics(truth, q)[:, :3, 3] - forward_kinematics(result.model, q)[:, :3, 3]
    assert np.sqrt(np.mean(np.sum(d**2, axis=1))) < 3 * np.sqrt(3) * 0.013


READY_DEG = {"KUKA": [0, -90, 90, 0, 0, 0], "Universal Robots": [0, -90, 90, -90, -90, 0]}


def _reachable_near(truth, T, ref, bound_deg=10.0, starts=24, seed=0):
    """Whether Levenberg-Marquardt from any of `starts` random joint sets within +-bound_deg of
    the reference puts the calibrated arm on the target (the singular tolerances) within the
    bound: an independent check that a refused target has no plausible solution."""
    from screwcal.calibration.singular_fit import fit_poses, meets, turned_toward

    rng = np.random.default_rng(seed)
    seeds = ref + np.radians(rng.uniform(-bound_deg, bound_deg, (starts, 6)))
    seeds[0] = ref
    q = turned_toward(fit_poses(truth, np.repeat(T[None], starts, axis=0), seeds)[0], ref)
    ok = meets(np.repeat(T[None], starts, axis=0), truth, q) & \
        (np.degrees(np.abs(q - ref)).max(axis=1) <= bound_deg)
    return bool(ok.any())


@pytest.mark.parametrize("around", ["ready", "zero", "at zero"])
@pytest.mark.parametrize("name", NAMES)
def test_compensation_puts_every_library_robot_on_its_targets(rng, name, around):
    """tool0 targets in the base frame (what a program commands), compensated for the calibrated
    twin: the twin at the compensated joints is within 0.02 mm of every target. Around a ready
    pose, around the zero pose (joints within a tenth of their ranges: KUKA's and UR's zero is
    the arm stretched, where Gauss-Newton stalls and the targets were refused), and at the
    zero pose itself. A target refused (next to a singularity) says why, and has no solution
    within the plausible bound of the nominal one (checked from 24 other starts)."""
    from screwcal.calibration.correction import compensate_each, nearest_home_solution
    from screwcal.calibration.posesets import random_set

    nominal = LIBRARY[name].model()
    truth = calibrated(nominal, rng).with_frames(np.eye(4), np.eye(4))
    ready = np.radians(READY_DEG.get(LIBRARY[name].maker, [0, 0, 0, 0, 0, 0]))
    scale = {"ready": 0.4, "zero": 0.1, "at zero": 0.0}[around]
    q = random_set(nominal, 30, seed=3) * scale + (ready if around == "ready" else 0.0)
    T = flange_kinematics(nominal, q)
    comp = compensate_each(truth, nominal, T, frame="base")
    assert comp.ok.sum() >= 27, comp.refused
    reached = flange_kinematics(truth, comp.q_rad[comp.ok])
    assert np.abs(reached[:, :3, 3] - T[comp.ok, :3, 3]).max() < 0.02
    assert (truth.within_limits(comp.q_rad[comp.ok])).all()
    for k, why in comp.refused:
        assert why, k
        ref = nearest_home_solution(nominal.with_frames(np.eye(4), np.eye(4)), T[k:k + 1])[0]
        assert not _reachable_near(truth, T[k], ref), (k, why)


@pytest.mark.parametrize("name", NAMES)
def test_measuring_targets_next_to_the_zero_pose_are_compensated(rng, name):
    """compensate --measuring-targets (the measured point in the measuring frame, solved on
    the calibrated robot from home): around the zero pose too. The UR arms' stretched zero
    refused one of 30 as out of reach on every branch before."""
    from screwcal.calibration.correction import compensate_each
    from screwcal.calibration.posesets import random_set

    nominal = LIBRARY[name].model()
    truth = calibrated(nominal, rng)
    for scale in (0.1, 0.02):
        T = forward_kinematics(truth, random_set(nominal, 30, seed=3) * scale)
        comp = compensate_each(truth, nominal, T, frame="measuring")
        assert comp.ok.all(), comp.refused
        reached = forward_kinematics(truth, comp.q_rad)
        assert np.abs(reached[:, :3, 3] - T[:, :3, 3]).max() < 0.02
