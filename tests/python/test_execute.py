"""Execution in MuJoCo (slideplan.sim and ``slideplan execute``): physics against Eq. 2, grasps, bad input."""

from __future__ import annotations

import dataclasses
import json
import math

import numpy as np
import pytest
from typer.testing import CliRunner

from handmade_plan import DEPTH_M, build_grasp_plan
from slideplan import PlanResult
from slideplan.cli import app
from slideplan.sim import ExecutionSettings, execute


@pytest.fixture(scope="module")
def slide_plan(handmade_plan):
    return handmade_plan


def test_short_slide_ends_where_eq2_says(slide_plan):
    settings = ExecutionSettings()
    execution = execute(slide_plan, settings)
    assert execution.position_error_m <= 0.002
    assert abs(execution.yaw_error_deg) <= 1.0
    assert execution.failed_stage != "slide"
    # The planned 1 cm depth compresses the finger's spring: k * depth of normal force.
    expected_force = settings.spring_stiffness(slide_plan.params["dz_min"], slide_plan.params["dz_max"]) * DEPTH_M
    assert 0.6 * expected_force <= execution.normal_force_n["mean"] <= 1.4 * expected_force
    # The plate was slid 3.5 cm towards the edge, so it now overhangs.
    assert execution.overhang_m > 0.02
    assert execution.com_margin_m > 0


def test_a_box_in_the_slide_s_way_stops_an_open_loop_slide_that_ignores_it(slide_plan):
    import shapely
    from shapely.geometry import MultiPoint

    from slideplan.transforms import move_planar

    points = np.asarray(slide_plan.object["points"])[:, :2]
    start = MultiPoint([tuple(point) for point in points]).convex_hull
    motion = slide_plan.object_motion
    end = MultiPoint([tuple(point) for point in move_planar(points, (motion["x"], motion["y"], motion["yaw"]))]).convex_hull
    spot = end.difference(start.buffer(0.004)).representative_point()  # where the plate goes, clear of where it lies
    box = {"shape": "box", "center": [spot.x, spot.y, slide_plan.table["height"] + 0.025], "size": [0.01, 0.01, 0.05],
           "yaw": 0.0}
    blocked = execute(dataclasses.replace(slide_plan, obstacles=[box]), ExecutionSettings())
    assert not blocked.success and blocked.failed_stage == "slide", blocked.failure
    assert blocked.failure.startswith("the object touched obstacle 0 during the slide"), blocked.failure
    assert blocked.position_error_m > 0.005
    free = execute(slide_plan, ExecutionSettings())
    assert free.position_error_m <= 0.002  # the same slide, the box away


def test_finger_too_shallow_does_not_move_the_object(slide_plan):
    execution = execute(slide_plan, ExecutionSettings(contact_depth=0.0))
    assert not execution.success
    assert execution.failed_stage == "slide"
    assert "no normal force" in execution.failure
    assert execution.normal_force_n["mean"] < 0.1
    moved = math.hypot(execution.actual_motion["x"], execution.actual_motion["y"])
    assert moved < 0.001  # the plan moves it 3.5 cm
    assert execution.position_error_m > 0.03


def test_grasp_of_a_far_overhanging_plate_lifts_it():
    execution = execute(build_grasp_plan(), ExecutionSettings(cell_size=0.015))
    assert execution.lifted
    assert execution.success, execution.failure
    report = json.loads(execution.to_json())
    assert report["schema"] == "slideplan.execution/1" and report["lifted"] is True


@pytest.mark.physics
def test_the_demo_plan_slides_and_lifts_its_crescent(tmp_path):
    # The planner's T42 grasp lies grasp_standoff beyond the edge, so the lower finger passes the table.
    assert CliRunner().invoke(app, ["demo", "--out", str(tmp_path)]).exit_code == 0
    plan = PlanResult.load(tmp_path / "demo-plan.json")
    execution = execute(plan)
    assert execution.position_error_m <= 0.005 and abs(execution.yaw_error_deg) <= 3.0
    assert execution.lifted, execution.failure
    assert execution.success


def test_unstable_simulation_is_reported_without_nan(slide_plan):
    execution = execute(slide_plan, ExecutionSettings(timestep=0.03))
    assert execution.failed_stage == "simulation"
    assert "unstable (MuJoCo's BADQACC warning)" in execution.failure or "non-finite" in execution.failure
    assert execution.actual_motion is None and execution.position_error_m is None
    json.loads(execution.to_json())  # allow_nan=False: raises on any NaN


def _largest_acceleration(path, times):
    """Largest joint acceleration between waypoints by finite differences, from and to rest."""
    dt = np.diff(times)
    mean_velocity = np.diff(path, axis=0) / dt[:, None]
    padded = np.vstack([np.zeros((1, path.shape[1])), mean_velocity, np.zeros((1, path.shape[1]))])
    # From rest, q1 - q0 = a dt^2 / 2: the mean velocity is reached in dt / 2.
    spans = np.concatenate([[dt[0] / 2], (dt[:-1] + dt[1:]) / 2, [dt[-1] / 2]])
    return float(np.max(np.abs(np.diff(padded, axis=0)) / spans[:, None]))


def test_untimed_plan_is_executed_under_the_limits_of_its_settings(slide_plan, monkeypatch):
    from slideplan.sim import runner as runner_module
    from slideplan.plan.robot import build_robot
    from slideplan.plan.timing import NEAR_TABLE_M

    followed = []
    follow = runner_module.Runner.follow

    def recording(runner, path, times, *args, **kwargs):
        followed.append((np.array(path), np.array(times)))
        return follow(runner, path, times, *args, **kwargs)

    monkeypatch.setattr(runner_module.Runner, "follow", recording)
    # Below the defaults (5 cm/s, 1 rad/s, 2 rad/s^2) and the URDF's 2 rad/s: defaults would break them.
    settings = ExecutionSettings(tip_speed=0.02, joint_velocity=0.06, joint_acceleration=0.1)
    execution = execute(slide_plan, settings)
    assert execution.position_error_m <= 0.002  # slower, still where Eq. 2 says

    moving = [(path, times) for path, times in followed if len(path) > 1]
    assert len(moving) == 3  # slide, approach, lift (closing holds one configuration)
    (slide, _), (approach, _), _ = moving
    assert np.array_equal(slide, slide_plan.trajectory) and np.array_equal(approach, slide_plan.grasp["approach"])
    robot = build_robot(slide_plan.robot)
    top = slide_plan.table["height"] + slide_plan.object["thickness"]
    tightest = []
    for path, times in moving:
        assert times[0] == 0 and np.all(np.diff(times) > 0)
        tips = np.array([np.asarray(robot.fk(q))[:3, 3] for q in path])
        capped = np.ones(len(path) - 1, dtype=bool)
        if path is approach:  # the approach is capped near the object only
            near = tips[:, 2] < top + NEAR_TABLE_M
            capped = near[:-1] | near[1:]
        ratios = (
            np.max(np.abs(np.diff(path, axis=0)) / np.diff(times)[:, None]) / settings.joint_velocity,
            np.max(np.linalg.norm(np.diff(tips, axis=0), axis=1)[capped] / np.diff(times)[capped]) / settings.tip_speed,
            _largest_acceleration(path, times) / settings.joint_acceleration,
        )
        assert max(ratios) <= 1 + 1e-6, ratios
        tightest.append(max(ratios))
    # Time-optimal: the slide and the lift each run at the tightest limit somewhere, not below it.
    assert tightest[0] >= 0.95 and tightest[2] >= 0.95, tightest


def _write(tmp_path, data, name="plan.json"):
    path = tmp_path / name
    path.write_text(json.dumps(data))
    return path


def _run(*args):
    result = CliRunner().invoke(app, ["execute", *map(str, args)])
    return result.exit_code, result.output


def _assert_one_error_line(code, output, *words):
    assert code == 2
    lines = output.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("slideplan: error: ")
    for word in words:
        assert word in lines[0]


def test_cli_rejects_another_schema(tmp_path, slide_plan):
    data = slide_plan.to_dict()
    data["schema"] = "slideplan.scene/1"
    _assert_one_error_line(*_run(_write(tmp_path, data)), "schema", "slideplan.scene/1")


def test_cli_rejects_an_unsolved_plan(tmp_path, slide_plan):
    data = dataclasses.replace(slide_plan, status="timeout").to_dict()
    _assert_one_error_line(*_run(_write(tmp_path, data)), "status", "timeout")


def test_cli_names_the_urdf_element_that_cannot_be_read(tmp_path, slide_plan):
    urdf = tmp_path / "robot.urdf"
    text = open(slide_plan.robot["urdf"]).read()
    urdf.write_text(text.replace('<box size="0.06 0.10 0.08"/>', '<box size="0.06 0.10"/>'))
    data = slide_plan.to_dict()
    data["robot"]["urdf"] = str(urdf)
    _assert_one_error_line(*_run(_write(tmp_path, data)), "malformed URDF", "[0.06 0.10]", "t42_palm", str(urdf))


def test_cli_names_a_missing_mesh(tmp_path, slide_plan):
    urdf = tmp_path / "robot.urdf"
    text = open(slide_plan.robot["urdf"]).read()
    urdf.write_text(text.replace('<box size="0.06 0.10 0.08"/>', '<mesh filename="meshes/palm.stl"/>'))
    data = slide_plan.to_dict()
    data["robot"]["urdf"] = str(urdf)
    _assert_one_error_line(*_run(_write(tmp_path, data)), "t42_palm", "meshes/palm.stl", "does not exist")


def test_cli_rejects_a_bad_tip_speed(tmp_path, slide_plan):
    _assert_one_error_line(*_run(_write(tmp_path, slide_plan.to_dict()), "--tip-speed", "-0.01"), "--tip-speed", "> 0")


def test_cli_executes_and_writes_the_report(tmp_path, slide_plan):
    out = tmp_path / "execution.json"
    code, output = _run(_write(tmp_path, slide_plan.to_dict()), "--json", out)
    report = json.loads(out.read_text())
    # The hand-made plan's "grasp" is only a lift of the finger: nothing to lift, exit 1.
    assert code == 1 and report["failed_stage"] == "grasp"
    assert report["position_error_m"] <= 0.002
    assert "Eq. 2 error" in output


@pytest.mark.physics
def test_timed_plan_uses_its_timing_block(tmp_path, slide_plan):
    from slideplan.plan.timing import TimingOptions, parameterize

    slow = dataclasses.replace(slide_plan, timing=parameterize(slide_plan, TimingOptions(fingertip_speed=0.005)))
    result = PlanResult.load(_write(tmp_path, slow.to_dict()))
    assert result.timing is not None
    execution = execute(result)  # a loaded plan goes where plan()'s goes, its timing block with it
    # 3.5 cm at 5 mm/s (the own parameterization slides at 5 cm/s): the slide lasts seconds longer.
    assert execution.sim_time_s > execute(dataclasses.replace(result, timing=None)).sim_time_s + 3.0


def test_execution_experiment_uses_the_full_size_poses_of_fig10():
    from slideplan.experiments import build_spec

    execution = build_spec("execution", poses=2)
    fig10 = build_spec("fig10", poses=2)
    full_size = {(task.scene, task.object, task.pose_index): (task.x, task.y, task.yaw, task.seed)
                 for task in fig10.tasks if task.scale == 1.0}
    assert len(execution.tasks) == len(full_size) == 4 * 5 * 2
    for task in execution.tasks:
        assert full_size[(task.scene, task.object, task.pose_index)] == (task.x, task.y, task.yaw, task.seed)


def test_execution_summary_counts_each_setting():
    import pandas as pd

    from slideplan.experiments.execution import EXECUTION_ROW_SCHEMA, summarize_execution

    def row(position_mm, yaw_deg, stage):
        values = {field.name: None for field in EXECUTION_ROW_SCHEMA}
        values.update(solved=True)
        for setting in ("nominal", "stress"):
            values.update({
                f"{setting}_position_error_m": None if stage == "simulation" else position_mm / 1000,
                f"{setting}_yaw_error_deg": None if stage == "simulation" else yaw_deg,
                f"{setting}_failed_stage": stage, f"{setting}_lifted": stage is None,
                f"{setting}_success": stage is None, f"{setting}_normal_force_n": 2.0,
            })
        return values

    results = pd.DataFrame([row(1.0, 0.5, None), row(4.0, -4.0, "slide"), row(0.0, 0.0, "simulation"),
                            row(2.0, 1.0, "release")])
    summary = summarize_execution(results).set_index("setting")
    assert summary.loc["nominal", "plans"] == 4
    assert summary.loc["nominal", "within_5mm_3deg"] == 0.5  # 1 mm / 0.5 deg and 2 mm / 1 deg
    assert summary.loc["nominal", "lifted"] == 0.25
    assert summary.loc["nominal", "fell"] == 1 and summary.loc["nominal", "unstable"] == 1


def test_grasp_whose_fingers_reach_over_the_table_fails_and_says_why():
    execution = execute(build_grasp_plan(grasp_y=0.21), ExecutionSettings(cell_size=0.015))
    assert not execution.lifted
    assert execution.failed_stage == "grasp"
    assert "stopped by the table" in execution.failure


def test_a_non_convex_outline_is_a_union_of_convex_pieces_covering_it():
    from shapely.geometry import Polygon
    from shapely.ops import unary_union

    from slideplan.sim.mjscene import prism_pieces

    ell = Polygon([(0.3, -0.3), (0.9, -0.3), (0.9, 0.0), (0.6, 0.0), (0.6, 0.3), (0.3, 0.3)])
    pieces = [Polygon(piece) for piece in prism_pieces(ell)]
    assert len(pieces) > 1 and all(piece.convex_hull.area - piece.area < 1e-12 for piece in pieces)
    assert abs(unary_union(pieces).area - ell.area) < 1e-9 and unary_union(pieces).symmetric_difference(ell).area < 1e-9
    square = Polygon([(0.3, -0.2), (0.7, -0.2), (0.7, 0.2), (0.3, 0.2)])
    assert len(prism_pieces(square)) == 1


def test_object_boxes_cover_a_non_convex_outline_and_not_its_hollow():
    from shapely.geometry import Point, box
    from shapely.ops import unary_union

    from slideplan.sim import object_boxes
    from slideplan.world.objects import load_object

    crescent = load_object("crescent", table_height=0.0, pose=(0.5, 0.0, 0.3))
    boxes = object_boxes(crescent.points, 0.0125)
    covered = unary_union([box(x - hx, y - hy, x + hx, y + hy) for x, y, hx, hy in boxes])
    outline = crescent.outline
    assert all(covered.buffer(0.001).contains(Point(point[:2])) for point in crescent.points)
    assert covered.difference(outline).area < 0.2 * outline.area  # overfill only along the edges
    hollow = outline.convex_hull.difference(outline.buffer(0.01))
    assert hollow.area > 0 and covered.intersection(hollow).area < 0.05 * hollow.area


def test_progress_reports_the_simulated_time_as_it_goes(slide_plan):
    seen = []
    execution = execute(slide_plan, progress=seen.append)
    assert len(seen) >= 10 and np.all(np.diff(seen) >= 0.1 - 1e-9)
    assert 0.0 < seen[-1] <= execution.sim_time_s and execution.sim_time_s - seen[-1] < 0.2


def test_cli_progress_line_is_one_line_per_interval_in_a_log(capsys):
    from slideplan.cli.physics import _progress_line

    with _progress_line("executing", after_s=0.0) as progress:
        progress(1.0)
        progress(1.1)  # within 5 s of wall time of the first: not shown
    err = capsys.readouterr().err
    assert err.splitlines() == ["executing: 1.0 s simulated in 0 s"]


@pytest.mark.physics
def test_the_video_keeps_the_table_and_the_hand_in_view_through_the_transfer(tmp_path, monkeypatch):
    # The Panda's approach rises far above the table: a camera fixed on the object lost its hand.
    from slideplan import PlannerConfig, load_object, load_scene, plan
    from slideplan.sim import video

    scene = load_scene("panda_square")
    result = plan(scene, load_object("crescent", table_height=scene.table.height, pose=(0.55, -0.08, 0.4)), PlannerConfig(seed=1))
    assert result.solved
    corners = np.column_stack([result.table["polygon"], np.full(len(result.table["polygon"]), scene.table.height)])
    hand_per_frame, recorders = [], []
    record = video.Recorder.after_step

    def after_step(recorder):
        before = recorder.count
        record(recorder)
        if recorder.count > before:  # a frame of this state was sent: where the hand is in it
            import mujoco  # after execute() chose the offscreen GL

            hand = [mujoco.mj_name2id(recorder.data.model, mujoco.mjtObj.mjOBJ_BODY, result.robot[key]) for key in ("grasp_link", "tip_link")]
            hand_per_frame.append(np.array(recorder.data.xpos[hand]))
            recorders[:] = [recorder]

    monkeypatch.setattr(video.Recorder, "after_step", after_step)
    execute(result, video=tmp_path / "strip.png")
    assert len(hand_per_frame) > 100
    # MuJoCo's own camera of the video's view: its pose and frustum at the near plane.
    import mujoco

    recorder = recorders[0]
    renderer = mujoco.Renderer(recorder.data.model, *recorder.size)
    renderer.update_scene(recorder.data, recorder.camera)
    camera = renderer.scene.camera[0]
    renderer.close()
    forward, up = np.asarray(camera.forward), np.asarray(camera.up)
    half_height = (camera.frustum_top - camera.frustum_bottom) / 2
    half_width = half_height * recorder.size[1] / recorder.size[0]
    outside_per_frame = []
    for hand in hand_per_frame:
        offsets = np.vstack([hand, corners]) - np.asarray(camera.pos)
        depth = offsets @ forward
        across = offsets @ np.cross(forward, up) * camera.frustum_near / depth
        along = offsets @ up * camera.frustum_near / depth - (camera.frustum_top + camera.frustum_bottom) / 2
        outside_per_frame.append(int(((depth <= 0) | (np.abs(across) > half_width) | (np.abs(along) > half_height)).sum()))
    assert sum(outside_per_frame) == 0
    assert (tmp_path / "strip.png").exists()


def test_a_hand_with_nothing_to_close_executes_the_slide_and_says_why_it_cannot_grasp():
    # The bundled UR5 carries a rigid finger on its flange and no gripper: this was numpy's
    # "zero-size array to reduction operation maximum which has no identity".
    from slideplan import PlannerConfig, load_object, load_scene, plan

    scene = load_scene("ur5_square")
    result = plan(scene, load_object("crescent", table_height=scene.table.height, pose=(0.55, -0.08, 0.4)), PlannerConfig(seed=2))  # a slide within tolerance
    assert result.solved
    execution = execute(result)
    assert execution.failed_stage == "grasp" and not execution.success and not execution.lifted
    assert "no fingers to close" in execution.failure and "[hand] gripper_joints" in execution.failure
    assert execution.position_error_m is not None  # the slide itself ran and was measured


def _rig(name: str):
    from slideplan import PlannerConfig, load_object, load_scene
    from slideplan.sim.model import Rig
    from slideplan.plan.robot import robot_model

    scene = load_scene(name)
    obj = load_object("square", table_height=scene.table.height, pose=(0.55, 0.0, 0.0))
    robot = robot_model(scene)
    return Rig.for_scene(scene, obj, PlannerConfig.for_scene(scene).resolved(scene), list(robot.joint_names),
                         np.zeros(len(robot.joint_names)))


def test_the_panda_closes_its_own_prismatic_fingers_and_the_mimic_follows():
    """[hand] gripper_joints names the URDF's panda_finger_joint1; panda_finger_joint2 mimics it in the
    URDF. Held open while sliding, closed to 0 (the fingers meet) with nothing between them."""
    import mujoco

    from slideplan.sim.model import build_model

    settings = ExecutionSettings()
    built = build_model(_rig("panda_square"), settings)
    model, data, gripper = built.model, built.data, built.gripper
    joints = [model.joint(name) for name in ("panda_finger_joint1", "panda_finger_joint2")]
    assert [model.actuator_trnid[actuator, 0] for actuator in gripper.actuators] == [joints[0].id]
    assert gripper.prismatic.tolist() == [True]
    assert gripper.ramp_s(settings) == pytest.approx(0.02 / settings.close_speed_linear)

    def opening() -> list[float]:
        return [float(data.qpos[model.jnt_qposadr[joint.id]]) for joint in joints]

    for _ in range(300):  # held open
        mujoco.mj_step(model, data)
    assert opening() == pytest.approx([0.02, 0.02], abs=1e-3)
    gripper.grip(model, settings, closing=True)
    data.ctrl[gripper.actuators] = gripper.target(1.0)
    for _ in range(1000):
        mujoco.mj_step(model, data)
    assert opening() == pytest.approx([0.0, 0.0], abs=1e-3)  # closed: the mimic finger came along


def test_the_t42_tendon_closes_both_fingers_to_the_grasp_plane_together():
    """t42_finger2_base closes the hand; t42_finger1_base mimics it, scaled so that the middles of both
    distal links reach the grasp plane (y = 0 of the grasp frame) at the same moment of the ramp."""
    import mujoco

    from slideplan.sim.model import build_model

    settings = ExecutionSettings()
    rig = _rig("square")
    built = build_model(rig, settings)
    model, data, gripper = built.model, built.data, built.gripper
    ramp_s = gripper.ramp_s(settings)
    grasp = model.body(rig.robot["grasp_link"]).id
    distal = [model.body(name).id for name in ("t42_finger1_distal", "t42_finger2_distal")]

    def sides() -> np.ndarray:  # of the middle of each distal link (where it pinches) from the grasp plane
        mujoco.mj_kinematics(model, data)
        tips = [data.xpos[body] + 0.0225 * data.xmat[body].reshape(3, 3)[:, 2] for body in distal]
        return np.array([(tip - data.xpos[grasp]) @ data.xmat[grasp].reshape(3, 3)[:, 1] for tip in tips])

    start, reached = np.sign(sides()), [None, None]
    assert start[0] == -start[1]  # open: one finger on each side
    gripper.grip(model, settings, closing=True)
    while data.time < ramp_s + 0.3:
        data.ctrl[gripper.actuators] = gripper.target(data.time / ramp_s)
        mujoco.mj_step(model, data)
        for index, side in enumerate(sides()):
            if reached[index] is None and np.sign(side) != start[index]:
                reached[index] = data.time
    assert None not in reached, reached
    assert abs(reached[0] - reached[1]) < 0.1 * ramp_s, (reached, ramp_s)


@pytest.mark.physics
@pytest.mark.parametrize("scene_name", ["panda_square", "ur5_gripper_square"])
def test_a_parallel_gripper_lifts_the_object_with_its_own_prismatic_jaws(scene_name):
    """The Panda's own hand; the UR5 with the gripper fragment data/robots/ur5_gripper.urdf attached. The
    hand's own geometry touches the object only once the pad is off it: the Panda's finger, enabled while
    still pressed in, dragged this object off the table (the check read the tip link's origin, 5 cm up
    the finger)."""
    from slideplan import PlannerConfig, load_object, load_scene, plan
    from slideplan.world.objects import load_outline, sample_pose_on_table

    scene = load_scene(scene_name)
    pose = sample_pose_on_table(load_outline("square")[0], scene.table, rng=np.random.default_rng(0))
    result = plan(scene, load_object("square", table_height=scene.table.height, pose=pose), PlannerConfig.for_scene(scene, seed=0))
    assert result.solved
    execution = execute(result)
    assert execution.failed_stage != "release" and execution.lifted, execution.failure


@pytest.mark.physics  # CoACD decomposes both jaw meshes anew: 20-25 s
def test_the_z1_jaw_meshes_become_convex_parts_that_leave_the_gap_between_the_jaws_open(grasp_map_store):
    """MuJoCo collides a mesh as its hull; the hull of the Z1's gripperStator (housing and fixed jaw)
    fills the gap where the grasp frame lies. Its convex parts (CoACD) leave the grasp frame free."""
    import mujoco
    from scipy.spatial import ConvexHull

    from slideplan.sim.model import build_model

    rig = _rig("z1_square")
    model, data = (built := build_model(rig, ExecutionSettings())).model, built.data
    mujoco.mj_kinematics(model, data)
    link = model.body("gripperStator").id
    grasp = np.eye(4)
    grasp[:3, :3], grasp[:3, 3] = data.xmat[link].reshape(3, 3), data.xpos[link]
    point = (grasp @ rig.robot["grasp_offset"])[:3, 3]

    def world_vertices(geom: int) -> np.ndarray:
        mesh = model.geom_dataid[geom]
        local = model.mesh_vert[model.mesh_vertadr[mesh]:model.mesh_vertadr[mesh] + model.mesh_vertnum[mesh]]
        return local @ data.geom_xmat[geom].reshape(3, 3).T + data.geom_xpos[geom]

    def inside(vertices: np.ndarray) -> bool:
        equations = ConvexHull(vertices).equations
        return bool(np.all(equations[:, :3] @ point + equations[:, 3] <= 0.0))

    parts = [geom for geom in range(model.ngeom) if model.geom_bodyid[geom] == link and model.geom_type[geom] == mujoco.mjtGeom.mjGEOM_MESH]
    assert len(parts) > 1
    assert inside(np.vstack([world_vertices(geom) for geom in parts]))  # the whole mesh's hull holds the grasp frame
    assert not any(inside(world_vertices(geom)) for geom in parts)  # no part does
    assert len(list((grasp_map_store / "convex-parts").glob("*.npz"))) == 2  # both jaw meshes' parts, stored


@pytest.mark.physics  # decomposes first unless the test above did
def test_convex_parts_are_read_back_from_the_cache_without_decomposing_again(monkeypatch):
    import coacd

    from slideplan.sim.model import build_model

    first = build_model(_rig("z1_square"), ExecutionSettings()).model  # decomposes, or reads an earlier test's parts
    monkeypatch.setattr(coacd, "run_coacd", lambda *args, **kwargs: pytest.fail("decomposed again"))
    again = build_model(_rig("z1_square"), ExecutionSettings()).model
    assert again.ngeom == first.ngeom
    np.testing.assert_array_equal(again.mesh_vert, first.mesh_vert)


def _plan_and_execute(scene_name: str, object_name: str, pose: tuple[float, float, float], seed: int):
    """Plan one object on a bundled robot scene (its meshes' warnings silenced) and execute the plan."""
    import warnings

    from slideplan import PlannerConfig, load_object, load_scene, plan
    from slideplan.errors import MeshWarning

    scene = load_scene(scene_name)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", MeshWarning)
        result = plan(scene, load_object(object_name, table_height=scene.table.height, pose=pose), PlannerConfig(seed=seed))
        assert result.solved
        return execute(result)


@pytest.mark.physics
def test_the_z1_closes_its_jaw_on_the_overhang_and_lifts_the_object():
    execution = _plan_and_execute("z1_square", "circle", (0.52, 0.0, 0.4), 2)
    assert execution.lifted, execution.failure
    # The slide too: with each joint's motor inertia the wrist's servo holds the fingertip's yaw (without
    # it the Z1's last joint was soft, and its slides ended 3-10 deg off Eq. 2).
    assert execution.success, execution.failure


@pytest.mark.physics
def test_the_five_joint_so101_slides_grasps_and_lifts():
    execution = _plan_and_execute("so101_square", "square", (0.37, 0.0, 0.5), 1)
    assert execution.success, execution.failure


def test_the_planners_grasp_lifts_straight_up_where_its_wrist_sits_at_a_limit():
    # The sweep's long/square pose at (0.475, 0.225): the grasp IK found the WAM's last joint at its +3.0 rad
    # limit; one IK 5 cm higher "lifted" by turning that joint a full turn, so the planner's lift check
    # passed and the execution found no straight lift (2-3 runs per setting of the closed-loop sweep).
    from slideplan import load_object, load_scene, plan
    from slideplan.plan.motions import straight_up
    from slideplan.experiments.tasks import build_spec

    scene = load_scene("long")
    task = next(task for task in build_spec("closed-loop", poses=10).tasks
                if task.scene == "long" and task.object == "square" and abs(task.x - 0.4751) < 1e-3)
    result = plan(scene, load_object(task.object, table_height=scene.table.height, pose=(task.x, task.y, task.yaw)),
                  task.planner_config())
    assert result.solved
    assert straight_up(result.robot_model(), np.asarray(result.grasp["config"]), result.params["grasp_lift"]) is not None


def test_the_planners_first_contact_can_be_come_down_onto_straight():
    # The crescent of the ROS tests, seed 11: any IK of Eq. 3 (lift_check off) put the WAM's first and sixth
    # joints at their limits, where the fingertip cannot rise approach_height straight up, so the reach had
    # no way down onto the contact (CI's ROS test refused the plan: "no inverse kinematics straight up").
    from slideplan import PlannerConfig, load_object, load_scene, plan
    from slideplan.plan.motions import reach_path, straight_up

    scene = load_scene("square")
    obj = load_object("crescent", table_height=scene.table.height, pose=(0.55, -0.08, 0.4))
    home = np.zeros(7)

    def rises(result) -> bool:
        robot, start = result.robot_model(), np.asarray(result.start_config)
        z, top = float(np.asarray(robot.fk(start))[2, 3]), scene.table.height + obj.thickness
        return straight_up(robot, start, max(z, top) + result.params["approach_height"] - z) is not None

    paper_rule = plan(scene, obj, PlannerConfig.for_scene(scene, seed=11, lift_check=False))
    assert paper_rule.solved and not rises(paper_rule)  # what the check is for
    for seed in range(16):
        result = plan(scene, obj, PlannerConfig.for_scene(scene, seed=seed))
        assert result.solved and rises(result), seed
        assert len(reach_path(result, obj, home)) > 1

def test_a_move_straight_up_stays_on_the_vertical_and_on_the_arms_branch():
    # The sweep's square/irregular pose 0: one IK call for 10 cm above the slide's end lands on another
    # branch (a joint turned by 3.4 rad), and the joint-linear move there swept the hand 25 cm down
    # through the table and dragged the object. Solved a centimetre at a time, the way rises straight.
    from slideplan import load_object, load_scene, plan
    from slideplan import _core
    from slideplan.plan.motions import straight_up
    from slideplan.experiments.tasks import build_spec

    scene = load_scene("square")
    task = next(task for task in build_spec("closed-loop", poses=10).tasks
                if (task.scene, task.object, task.pose_index) == ("square", "irregular", 0))
    result = plan(scene, load_object(task.object, table_height=scene.table.height, pose=(task.x, task.y, task.yaw)),
                  task.planner_config())
    assert result.solved
    robot = result.robot_model()
    for config in (np.asarray(result.trajectory[-1]), np.asarray(result.grasp["config"])):
        way = straight_up(robot, config, 0.1)
        assert way is not None
        tips = np.array([np.asarray(robot.fk(q))[:3, 3] for q in way])
        # Checked between the waypoints too: the runner interpolates joints linearly.
        between = np.array([np.asarray(robot.fk(q))[:3, 3] for q in 0.5 * (way[1:] + way[:-1])])
        for points in (tips, between):
            assert np.linalg.norm(points[:, :2] - tips[0, :2], axis=1).max() < 0.001
        assert np.all(np.diff(tips[:, 2]) > 0) and tips[-1, 2] - tips[0, 2] == pytest.approx(0.1, abs=1e-4)
        assert np.abs(np.diff(way, axis=0)).max() <= _core.LIFT_JOINT_STEP_RAD


def test_a_state_mujoco_resets_silently_is_named_as_the_cause():
    # MuJoCo answers a huge or NaN position with its BADQPOS warning and a reset, then steps on: every
    # stepping loop (execute, run, ros sim) must end there, naming it (once a 1e300 trajectory reset the arm).
    import mujoco

    from slideplan.sim.runner import instability

    model = mujoco.MjModel.from_xml_string("<mujoco><worldbody><body><freejoint/><geom size='0.1'/></body></worldbody></mujoco>")
    data = mujoco.MjData(model)
    mujoco.mj_step(model, data)
    assert instability(data) == ""
    data.qpos[0] = 1e300
    mujoco.mj_step(model, data)
    assert instability(data) == "MuJoCo's BADQPOS warning"


def test_following_a_path_ends_on_a_state_mujoco_reset_within_a_few_steps():
    # The runner reads MuJoCo's warnings every few steps, not every step: the counters only grow, so the
    # run still ends on the reset, a few steps later, and not at the end of the path.
    from types import SimpleNamespace

    import mujoco

    from slideplan.sim import ExecutionSettings
    from slideplan.sim.runner import _CHECK_EVERY, Runner, Unstable

    model = mujoco.MjModel.from_xml_string(
        "<mujoco><worldbody><body><joint name='j' type='slide'/><geom size='0.1'/></body></worldbody>"
        "<actuator><position joint='j' kp='10'/></actuator></mujoco>")
    data = mujoco.MjData(model)
    built = SimpleNamespace(model=model, data=data, arm_actuators=np.array([0]))
    runner = Runner(built, ExecutionSettings(), None)

    def poison(elapsed, step):
        if step == 3:
            data.qpos[0] = 1e300
        return False

    with pytest.raises(Unstable, match="BADQPOS"):
        runner.follow(np.zeros((2, 1)), np.array([0.0, 1.0]), on_step=poison)
    assert data.warning[int(mujoco.mjtWarning.mjWARN_BADQPOS)].number >= 1
    # Reset to time 0 at the fourth step, then stepped on until the next check.
    assert data.time <= (_CHECK_EVERY + 1) * model.opt.timestep


def test_a_mark_is_written_on_the_frames_that_follow_it_and_the_depth_cameras_quality_is_kept(tmp_path):
    import os

    os.environ.setdefault("MUJOCO_GL", "egl")  # before MuJoCo is first imported: offscreen rendering
    import imageio.v2 as imageio
    import mujoco
    from slideplan.sim.video import MARK_S, Recorder

    model = mujoco.MjModel.from_xml_string(  # a sphere moving across the view: no two frames alike (a GIF merges those)
        "<mujoco><option gravity='0 0 0'/><worldbody><light pos='0 0 2'/><body><joint type='slide' axis='1 0 0'/>"
        "<geom type='sphere' size='.05' rgba='1 1 1 1'/></body></worldbody></mujoco>")
    data = mujoco.MjData(model)
    data.qvel[0] = 0.1
    quality = [model.vis.quality.offsamples, model.vis.quality.numslices]
    recorder = Recorder(model, data, tmp_path / "run.gif", 10, (48, 64), np.array([[-0.1, -0.1, 0.0], [0.3, 0.1, 0.1]]))
    while data.time < 1.95:  # frames at 0, 0.1, ..., 1.9 s
        if 0.25 <= data.time < 0.25 + model.opt.timestep:  # once, between the frames of 0.2 and 0.3 s
            recorder.mark("re-plan 1 (drift): slide")
        mujoco.mj_step(model, data)
        recorder.after_step()
    recorder.close()
    recorder.write()  # the render process's frames, written as the GIF
    assert [model.vis.quality.offsamples, model.vis.quality.numslices] == quality  # what a depth renderer made later reads
    frames = imageio.mimread(tmp_path / "run.gif")
    assert len(frames) == 20
    band = np.array([np.asarray(frame)[:4, :, :3].reshape(-1, 3).astype(int) for frame in frames])  # each frame's top rows
    marked = [bool((np.abs(rows - 20) <= 4).all(axis=1).any()) for rows in band]  # the band's grey (20, 20, 20)
    # Frames every 0.1 s: marked from the one after the mark until MARK_S later (0.25 + 1.5 = 1.75 s).
    assert MARK_S == 1.5 and marked == [3 <= index <= 17 for index in range(20)], marked


def test_a_render_process_that_fails_is_reported_with_its_reason(tmp_path):
    import os

    os.environ.setdefault("MUJOCO_GL", "egl")
    import mujoco
    from slideplan.sim.video import Recorder

    model = mujoco.MjModel.from_xml_string("<mujoco><worldbody><geom type='sphere' size='.1'/></worldbody></mujoco>")
    data = mujoco.MjData(model)
    (tmp_path / "a_file").write_text("")
    recorder = Recorder(model, data, tmp_path / "a_file" / "run.gif", 10, (48, 64), np.zeros((2, 3)))
    for _ in range(50):
        mujoco.mj_step(model, data)
        recorder.after_step()
    recorder.close()
    with pytest.raises(OSError, match=r"a_file/run\.gif: the video's render process failed .*(Not a directory|File exists)"):
        recorder.write()
