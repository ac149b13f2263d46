"""The verifier accepts a genuinely valid hand-made plan and reports each deliberate corruption."""

import copy

import numpy as np
import pytest
from handmade_plan import DEPTH_M, PITCH, THICKNESS, build_grasp_plan, contact_target

from slideplan.plan.robot import robot_model
from slideplan.world.scenes import load_scene
from slideplan.transforms import pose_to_row
from slideplan.world.geometry import overhang
from slideplan.transforms import planar_motion
from slideplan.checks.verify import verify
from slideplan.world.geometry import SupportSurface
from slideplan.outputs.pictures import draw_plan


@pytest.fixture(scope="module")
def valid_plan(handmade_plan):
    """The slide of build_plan without a grasp: its corruptions name their own checks."""
    return handmade_plan


@pytest.fixture(scope="module")
def grasp_plan():
    return build_grasp_plan()


@pytest.fixture
def plan(valid_plan):
    return copy.deepcopy(valid_plan)


@pytest.fixture(scope="module")
def robot():
    return robot_model(load_scene("square"))


def replace_waypoint(plan, robot, index, target):
    """Move waypoint ``index`` to the IK solution of ``target``, keeping the recorded pose consistent."""
    config = robot.ik(target, seed=plan.trajectory[index], rng_seed=1)
    assert config is not None
    plan.trajectory[index] = config
    plan.fingertip_poses[index] = pose_to_row(robot.fk(config))


def assert_reported(plan, *fragments):
    violations = verify(plan).violations
    for fragment in fragments:
        assert any(fragment in violation for violation in violations), (fragment, violations)


def test_valid_handmade_plan_passes(grasp_plan):
    verification = verify(grasp_plan)
    assert verification.ok, str(verification)
    assert grasp_plan.overhang_m > grasp_plan.params["u_star"]


def test_a_grasp_the_pads_cannot_hold_up_is_reported(grasp_plan):
    """grasp_model: the hand-made plate hangs 8 cm from its grasp. A plan that claims the model with a grip of
    1 mN is refused; with 100 N the pads hold it; with the model off nothing is asked."""
    claimed = copy.deepcopy(grasp_plan)
    claimed.params.update(grasp_model=True, grip_force=0.001)
    assert_reported(claimed, "the closed hand would not hold the object up (grasp_model)")
    claimed.params["grip_force"] = 100.0
    assert verify(claimed).ok
    assert not grasp_plan.params["grasp_model"] and verify(grasp_plan).ok


def test_a_lifted_fingertip_is_not_a_grasp(valid_plan):
    # build_plan calls the end of its lift (the fingertip 6 cm above the table) its grasp.
    violations = verify(valid_plan).violations
    assert any("grasp.pose:" in violation and "from H_g" in violation for violation in violations), violations
    assert all(violation.startswith(("grasp.pose:", "timing.")) for violation in violations), violations


def test_a_grasp_cut_from_the_approach_is_rejected(grasp_plan, robot):
    # The approach cut at a third, its last configuration declared the grasp (consistent FK).
    plan = copy.deepcopy(grasp_plan)
    approach = plan.grasp["approach"][: len(plan.grasp["approach"]) // 3]
    plan.grasp = {"pose": pose_to_row(robot.link_pose(approach[-1], "t42_grasp")), "config": approach[-1].copy(),
                  "approach": approach}
    plan.timing = None
    assert_reported(plan, "grasp.pose:", "from H_g")


def test_a_grasp_a_centimetre_off_h_g_is_rejected(grasp_plan, robot):
    plan = copy.deepcopy(grasp_plan)
    target = robot.link_pose(plan.grasp["config"], "t42_grasp")
    target[0, 3] += 0.01  # along the edge
    config = robot.ik(target, seed=plan.grasp["config"], rng_seed=1, link="t42_grasp")
    assert config is not None
    plan.grasp = {**plan.grasp, "pose": pose_to_row(robot.link_pose(config, "t42_grasp")), "config": config}
    plan.grasp["approach"] = np.vstack([plan.grasp["approach"], config])
    assert_reported(plan, "grasp.pose: 0.0100 m from H_g")


def test_turning_and_contact_bounds_are_checked(grasp_plan):
    plan = copy.deepcopy(grasp_plan)
    plan.params["max_object_yaw"] = 1e-9
    plan.object_motion["yaw"] = 0.01  # also breaks Eq. 2, reported separately
    plan.params["contact_radius"] = 1e-3  # the slide starts 8 cm from the centre of mass
    assert_reported(plan, "> max_object_yaw", "beyond the closest point")
    # A re-plan from where the finger is (plan(..., start_config=q)) did not draw its first contact from Eq. 3's
    # region: the closed loop's re-plans mid-slide were refused for a contact 3.3 cm from the centre of mass.
    assert not any("closest point" in problem for problem in verify(plan, given_start=True).violations)


def test_timing_beyond_its_limits_is_reported(grasp_plan):
    from slideplan.plan.timing import parameterize

    plan = copy.deepcopy(grasp_plan)
    plan.timing = parameterize(plan)
    assert verify(plan).ok, verify(plan)
    plan.timing["trajectory"]["time_from_start"] = np.asarray(plan.timing["trajectory"]["time_from_start"]) / 2
    assert_reported(plan, "timing.trajectory: the fingertip moves at")


def test_a_wrong_centre_of_mass_is_reported(grasp_plan):
    plan = copy.deepcopy(grasp_plan)
    plan.object["com_xy"] = plan.object["points"][:, :2].mean(axis=0) + (0.003, 0.0)
    assert_reported(plan, "object.com_xy:")


def test_waypoint_out_of_depth_band_is_reported(plan, robot):
    x, y = plan.fingertip_poses[5][:2]
    replace_waypoint(plan, robot, 5, contact_target(x, y, THICKNESS - 0.04))
    assert_reported(plan, "trajectory[5]: contact depth 0.04")


def test_pitch_off_is_reported(plan, robot):
    x, y = plan.fingertip_poses[5][:2]
    replace_waypoint(plan, robot, 5, contact_target(x, y, THICKNESS - DEPTH_M, pitch=PITCH + 0.3))
    assert_reported(plan, "trajectory[5]: pitch 1.3")


def test_skipped_waypoints_break_density(plan):
    # Dropping four waypoints leaves a 12.5 mm fingertip jump, over the 1 cm bound.
    plan.trajectory = np.delete(plan.trajectory, [6, 7, 8, 9], axis=0)
    plan.fingertip_poses = np.delete(plan.fingertip_poses, [6, 7, 8, 9], axis=0)
    assert_reported(plan, "trajectory[5]->[6]: fingertip moves 0.0125")


def test_fingertip_jump_breaks_tip_density(plan):
    plan.params["max_tip_step"] = 0.002  # the hand-made path moves 2.5 mm per waypoint
    assert_reported(plan, "trajectory[0]->[1]: fingertip moves 0.0025")


def test_wrong_object_motion_is_reported(plan):
    plan.object_motion["x"] += 0.01
    assert_reported(plan, "object_motion:", "overhang_m: recorded")


def test_joint_beyond_limit_is_reported(plan, robot):
    plan.trajectory[3][0] = robot.upper_limits[0] + 0.1
    plan.fingertip_poses[3] = pose_to_row(robot.fk(plan.trajectory[3]))
    assert_reported(plan, "trajectory[3]: joint 0 =")


def test_fingertip_outside_table_is_reported(plan):
    # Move the table's right edge to x = 0.62: the fingertip (0.61 -> 0.645) crosses it.
    polygon = plan.table["polygon"].copy()
    polygon[polygon[:, 0] > 0.65, 0] = 0.62
    plan.table["polygon"] = polygon
    assert_reported(plan, "trajectory[5]: fingertip (0.6225", "trajectory[14]: fingertip (0.6450")
    assert not any(violation.startswith("trajectory[3]:") for violation in verify(plan).violations)


def test_wrong_recorded_pose_is_reported(plan):
    plan.fingertip_poses[2][2] += 0.001
    assert_reported(plan, "trajectory[2]: forward kinematics differs from fingertip_poses[2] by 0.001 m")


def test_too_small_overhang_is_reported(plan):
    plan.params["u_star"] = 0.03
    assert_reported(plan, "final object pose: overhang held by the hand 0.025")


def test_a_grasp_nearer_the_edge_than_the_standoff_is_reported(plan):
    plan.params["grasp_standoff"] = 0.2  # beyond where the hand-made plan grasps
    assert_reported(plan, "less than grasp_standoff 0.2")


def test_the_overhang_within_the_standoff_is_not_held(plan):
    table = SupportSurface.from_vertices(plan.table["polygon"], plan.table["height"])
    _, _, (start, normal) = overhang(table, plan.moved_object_xy())
    grasp = np.asarray(plan.grasp["pose"][:2], dtype=float)
    plan.grasp["pose"][:2] = grasp + (0.04 - (grasp - start) @ normal) * normal  # 4 cm beyond the edge
    plan.params["grasp_standoff"] = 0.001  # so 3.9 cm of the 2.5 cm overhang lie within the hand's free length
    violations = verify(plan).violations
    assert any("overhang held by the hand" in violation for violation in violations), violations
    assert not any("grasp_standoff" in violation for violation in violations), violations


def test_approach_must_start_at_goal_and_reach_grasp(plan):
    plan.grasp["approach"] = plan.grasp["approach"][1:]
    plan.grasp["config"] = plan.grasp["config"] + 0.01
    assert_reported(plan, "approach[0]: differs from goal_config", "differs from grasp.config", "grasp.pose:")


def test_timeout_plan_is_not_ok(plan):
    plan.status = "timeout"
    assert not verify(plan).ok


def test_planar_motion_and_overhang_on_known_numbers():
    first, last = np.eye(4), np.eye(4)
    first[:3, 3] = (1.0, 0.0, 0.0)
    last[:2, :2] = [[0.0, -1.0], [1.0, 0.0]]  # yaw +90 degrees
    last[:3, 3] = (0.0, 2.0, 0.0)
    x, y, yaw = planar_motion(first, last)
    assert (x, y, yaw) == pytest.approx((0.0, 1.0, np.pi / 2))
    table = SupportSurface.from_vertices([[0, 0], [1, 0], [1, 1], [0, 1]])
    u, outside, _ = overhang(table, np.array([[0.5, 0.5], [1.02, 0.5], [1.05, 0.4]]))
    assert u == pytest.approx(0.05)
    assert outside.tolist() == [False, True, True]


def test_draw_plan_writes_png_and_svg(valid_plan, tmp_path):
    assert draw_plan(valid_plan, tmp_path / "plan.png").stat().st_size > 1000
    assert draw_plan(valid_plan, tmp_path / "plan.svg").read_text().lstrip().startswith("<?xml")


def test_a_slide_that_does_not_start_on_the_object_is_reported(plan):
    plan.object["points"] = plan.object["points"] + np.array([0.0, 0.15, 0.0])  # the object lies 15 cm aside
    assert_reported(plan, "trajectory[0]: the fingertip is", "the slide does not start on the object")


def test_a_centre_of_mass_closer_to_the_edge_than_com_margin_is_reported(plan):
    plan.params["com_margin"] = 0.5  # more than the table's half-width: no final pose can satisfy it
    assert_reported(plan, "less than com_margin 0.5")


def test_the_picture_draws_the_object_along_the_slide_under_the_fingertip():
    import shapely

    from slideplan import PlannerConfig, load_object
    from slideplan import plan as make_plan
    from slideplan.transforms import move_planar, row_to_pose
    from slideplan.outputs.pictures import SLIDE_SPACING_M, slide_motions

    scene = load_scene("square")
    valid_plan = make_plan(scene, load_object("crescent", table_height=0.0, pose=(0.55, -0.08, 0.4)),
                           PlannerConfig(seed=1, time_limit_s=30.0))
    assert valid_plan.solved
    tips = np.asarray(valid_plan.fingertip_poses)
    travel = np.linalg.norm(np.diff(tips[:, :3], axis=0), axis=1).sum()
    motions = slide_motions(valid_plan)
    assert len(motions) == int(np.ceil(travel / SLIDE_SPACING_M - 0.5)) - 1 >= 3  # one per spacing, ends excluded
    start = np.asarray(valid_plan.object["points"])[:, :2]
    for index, motion in motions:
        # The finger presses on the object's top: at each drawn pose the object lies under the fingertip.
        footprint = shapely.MultiPoint(move_planar(start, motion)).convex_hull.buffer(1e-4)
        assert footprint.contains(shapely.Point(row_to_pose(tips[index])[:2, 3])), index


def test_a_dense_clouds_point_spacing_comes_from_a_sample_and_still_bounds_the_start_contact():
    # 40,000 points 2 mm apart: every point's nearest neighbour took seconds; a stride sample gives the
    # same spacing, so a fingertip 1 cm off the plate is still refused and one on it is not.
    from slideplan.checks.verify import SPACING_SAMPLE, _start_contact_violations

    axis = np.arange(200) * 0.002
    cloud = np.column_stack([axis.repeat(200), np.tile(axis, 200)]) + [0.4, -0.2]
    assert len(cloud) > 10 * SPACING_SAMPLE
    assert _start_contact_violations(cloud, np.array([0.5, -0.1])) == []
    (violation,) = _start_contact_violations(cloud, np.array([0.4 + 0.398 + 0.01, -0.1]))
    assert "the fingertip is 0.0100 m from the nearest point of the object (point spacing 0.0020 m)" in violation


def test_a_crescent_overhanging_with_both_horns_is_grasped_on_a_horn_not_between_them():
    """grasp_hold: the paper's H_g (the centroid of P_out) lies between the horns, on nothing; the planner
    slides it along the edge onto the object and the verifier recomputes the same grasp, or reports the
    paper's."""
    from shapely.geometry import Polygon, box
    from shapely.affinity import rotate, translate

    from slideplan.world.objects import load_object
    from slideplan.plan.config import PlannerConfig
    from slideplan.plan.planner import plan
    from slideplan.transforms import row_to_pose

    scene = load_scene("round")
    crescent = load_object("crescent", table_height=scene.table.height, pose=(0.5041, -0.1354, -2.3101))
    result = plan(scene, crescent, PlannerConfig.for_scene(scene, seed=2707478050))
    assert result.solved and verify(result).ok, verify(result).violations
    motion, hold = result.object_motion, result.params["grasp_hold"]
    reach = max(result.params["grasp_standoff"], hold)
    moved = translate(rotate(Polygon(crescent.outline.exterior.coords), motion["yaw"], origin=(0, 0), use_radians=True),
                      motion["x"], motion["y"])

    def strip(xy):
        """The fingers' strip at the grasp: grasp_hold wide, from H_g to its reach line towards the table."""
        pose = row_to_pose(result.grasp["pose"])
        approach = pose[:2, 2] / np.linalg.norm(pose[:2, 2])
        angle = float(np.arctan2(approach[1], approach[0]))
        local = box(-2.0, -hold / 2, reach, hold / 2)  # beyond H_g, outward, is inside the hand too
        return translate(rotate(local, angle, origin=(0, 0), use_radians=True), *xy)

    grasp_xy = np.asarray(result.grasp["pose"][:2])
    assert strip(grasp_xy).intersection(moved).area >= 0.5 * hold * hold
    _, outside, (start, normal) = overhang(SupportSurface.from_vertices(result.table["polygon"], result.table["height"]), result.moved_object_xy())
    centroid = result.moved_object_xy()[outside].mean(axis=0)
    paper_xy = centroid + max(0.0, result.params["grasp_standoff"] - float((centroid - start) @ normal)) * normal
    assert strip(paper_xy).intersection(moved).area == 0.0  # the paper's H_g holds nothing here
    paper = copy.deepcopy(result)
    paper.params["grasp_hold"] = 0.0
    assert_reported(paper, "grasp.pose:", "the centroid of the overhanging points (IV-C.1)")
