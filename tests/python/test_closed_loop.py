"""The closed loop (its decisions, slideplan.loop.decisions and slideplan.loop.watch; its MuJoCo harness,
slideplan.sim.closed_loop; and ``slideplan run``): tracking with the arm in view, recovery from a disturbance
that the open loop cannot recover from, determinism, bad input."""

import dataclasses
import math
import os

import numpy as np
import shapely
import pytest
from typer.testing import CliRunner

from slideplan import InputError, PlannerConfig, load_scene, plan
from slideplan.cli import app
from slideplan.sim.closed_loop import default_camera, run
from slideplan.sim.conditions import Disturbance
from slideplan.world.objects import load_object
from slideplan.sim.rendering import Box, depth_image, noisy_depth, place_objects, scene_spec
from slideplan.perception.tracking import Tracker
from slideplan.transforms import row_to_pose, wrap_angle
from slideplan.transforms import move_planar, planar_motion
from slideplan.loop.watch import Watch

DEMO = ("square", "crescent", (0.55, -0.08, 0.4))
PUSHED = Disturbance(0.0, -0.03, 0.17, 2.0)  # 3 cm and 10 degrees, 2 s into the slide


@pytest.fixture(scope="module")
def disturbed_closed():
    return run(*DEMO, seed=1, closed=True, disturbance=PUSHED)


@pytest.mark.physics
def test_the_closed_loop_recovers_from_a_push_the_open_loop_does_not(disturbed_closed):
    opened = run(*DEMO, seed=1, closed=False, disturbance=PUSHED)
    assert not opened.success and opened.replans == 0
    assert disturbed_closed.success, disturbed_closed.summary()
    assert disturbed_closed.replans >= 1 and disturbed_closed.lifted
    assert opened.failed_stage in ("release", "grasp", "hold"), opened.summary()  # what happened, not a camera reading
    assert disturbed_closed.seen_overhang_m >= PlannerConfig.for_scene(load_scene("square")).u_star
    # What it saw is where the object was.
    assert abs(disturbed_closed.true_overhang_m - disturbed_closed.seen_overhang_m) < 0.01
    assert all(event.latency_s > 0 for event in disturbed_closed.events)


@pytest.mark.physics
def test_the_same_seed_gives_the_same_run(disturbed_closed):
    again = run(*DEMO, seed=1, closed=True, disturbance=PUSHED)
    assert [(event.time_s, event.outcome) for event in again.events] == \
        [(event.time_s, event.outcome) for event in disturbed_closed.events]
    assert again.seen_motion == disturbed_closed.seen_motion and again.sim_time_s == disturbed_closed.sim_time_s


def test_tracking_with_the_arm_in_view_finds_the_object_along_a_plan():
    # Frames of the execution model (arm, hand, finger over the object) along a plan, the object where
    # Eq. 2 puts it: the tracker, guessing 5 mm and 3 degrees off, finds it closer than the push the loop
    # must see (3 cm, 10 degrees). (Measured on this task: a median 4 mm / 6 degrees, short of the 2 mm /
    # 1 degree the tracker reaches with a box over the object: docs/benchmarks/tracking.md.)
    os.environ.setdefault("MUJOCO_GL", "egl")  # before MuJoCo is first imported: offscreen rendering
    import mujoco

    from slideplan.sim import ExecutionSettings
    from slideplan.sim.model import DEPTH_CAMERA, build_model
    from slideplan.sim.rendering import camera_depth, noisy_depth
    from slideplan.perception.tracking import Tracker

    scene_name, name, pose = DEMO
    scene = load_scene(scene_name)
    obj = load_object(name, table_height=scene.table.height, pose=pose)
    result = plan(scene, obj, PlannerConfig.for_scene(scene, seed=1))
    camera = default_camera(scene)
    built = build_model(result, ExecutionSettings(), camera=camera)
    tracker = Tracker(obj, camera, table_height=scene.table.height)
    rng = np.random.default_rng(0)
    errors = []
    with mujoco.Renderer(built.model, camera.height, camera.width) as renderer:
        renderer.enable_depth_rendering()
        for k in np.linspace(0, len(result.trajectory) - 1, 8).round().astype(int):
            motion = planar_motion(row_to_pose(result.fingertip_poses[0]), row_to_pose(result.fingertip_poses[k]))
            built.data.qpos[built.arm_qpos] = result.trajectory[k]
            address = built.model.jnt_qposadr[built.model.body_jntadr[built.object_body]]
            com = obj.moved(motion).centroid_xy
            built.data.qpos[address:address + 2] = com
            built.data.qpos[address + 3:address + 7] = [math.cos(motion[2] / 2), 0, 0, math.sin(motion[2] / 2)]
            mujoco.mj_forward(built.model, built.data)
            depth = noisy_depth(camera_depth(renderer, built.model, built.data, DEPTH_CAMERA), 0.002, 0.05, rng)
            guess = (motion[0] + 0.005, motion[1], motion[2] + math.radians(3))
            seen = tracker.track(depth, guess)
            assert seen.ok, seen.reason
            errors.append((np.linalg.norm(obj.moved(seen.motion).centroid_xy - com), abs(wrap_angle(seen.motion[2] - motion[2]))))
    errors = np.array(errors)
    assert np.median(errors[:, 0]) < 0.01 and np.median(errors[:, 1]) < math.radians(10), errors


@pytest.mark.parametrize("kwargs, field", [
    (dict(setting="windy"), "setting"),
    (dict(pose=(2.0, 0.0, 0.0)), "--pose"),
    (dict(pose=(0.55, -0.08)), "--pose"),
    (dict(disturbance=Disturbance(0.0, 0.0, 0.0, -1.0)), "--disturb"),
    (dict(disturbance=Disturbance(0.0, 0.0, 0.0, 1000.0)), "--disturb"),
    (dict(replan_period=0.0), "replan_period"),
    (dict(threshold=("a", 0.1)), "threshold"),
    (dict(threshold=(0.003, -1.0)), "threshold"),
])
def test_bad_input_names_the_field(kwargs, field):
    args = dict(scene="square", object_name="crescent", pose=DEMO[2]) | kwargs
    with pytest.raises(InputError) as error:
        run(args.pop("scene"), args.pop("object_name"), args.pop("pose"), **args)
    assert error.value.field == field


def test_cli_bad_input_is_exit_2_with_one_line():
    result = CliRunner().invoke(app, ["run", "--pose", "2", "0", "0"])
    assert result.exit_code == 2
    assert "--pose" in result.output and "not wholly on the table" in result.output


@pytest.mark.parametrize("seed", ["-1", str(2**64)])
def test_cli_run_names_a_seed_out_of_range_before_drawing_a_pose_from_it(seed):
    # Without --pose the pose is drawn from the seed: numpy's own error ("expected non-negative integer")
    # named no option.
    result = CliRunner().invoke(app, ["run", "--seed", seed])
    assert result.exit_code == 2 and result.output.startswith("slideplan: error: --seed:"), result.output


@pytest.mark.parametrize("disturb, problem", [(["nan", "0", "0", "1"], "DX nan is not a finite number"),
                                               (["0", "5", "0", "1"], "DY 5 is beyond 1 m in magnitude")])
def test_cli_run_checks_the_disturbance_as_ros_sim_does(disturb, problem):
    result = CliRunner().invoke(app, ["run", "--disturb", *disturb])
    assert result.exit_code == 2 and "--disturb" in result.output and problem in result.output, result.output


def _demo_segment():
    """The demo task's scene, object, planner settings, plan, and that plan as a slide to follow."""
    from slideplan.loop.watch import slide_segment

    scene_name, name, pose = DEMO
    scene = load_scene(scene_name)
    obj = load_object(name, table_height=scene.table.height, pose=pose)
    config = PlannerConfig.for_scene(scene, seed=1)
    result = plan(scene, obj, config)
    return scene, obj, config, result, slide_segment(result, scene.table.height + obj.thickness, (0.0, 0.0, 0.0))


def test_a_slide_is_kept_while_it_still_ends_graspable_from_where_the_object_is_seen():
    scene, obj, config, result, segment = _demo_segment()
    middle = len(result.trajectory) // 2
    tip = row_to_pose(result.fingertip_poses[middle])
    where_planned = planar_motion(row_to_pose(result.fingertip_poses[0]), tip)
    assert segment.still_works(obj, scene.table, config, tip, where_planned)
    # Pushed 3 cm back from the edge it slides to (the demo's push): the rest of the plan ends short.
    pushed = (where_planned[0] + PUSHED.dx, where_planned[1] + PUSHED.dy, where_planned[2])
    assert not segment.still_works(obj, scene.table, config, tip, pushed)
    # Seen where the fingertip is not on it: the plan cannot go on pushing it.
    away = (where_planned[0] + 0.2, where_planned[1], where_planned[2])
    assert not segment.still_works(obj, scene.table, config, tip, away)


def test_a_fingertip_inside_the_objects_edge_is_on_it_as_the_planner_takes_a_start(monkeypatch):
    # With the tracker's error (3 mm) as a margin inside the hull, a finger near the object's edge asked for a
    # re-plan, which the planner started from that same contact: 20 re-plans on one nominal slide.
    from slideplan.loop import watch

    scene, obj, config, result, segment = _demo_segment()
    monkeypatch.setattr(watch.Ending, "graspable", lambda *_: True)  # the ending aside: only where the tip is
    tip = row_to_pose(result.fingertip_poses[len(result.trajectory) // 2])
    where_planned = planar_motion(row_to_pose(result.fingertip_poses[0]), tip)
    hull = obj.moved(where_planned).outline.convex_hull
    edge = np.asarray(shapely.shortest_line(hull.exterior, shapely.Point(tip[:2, 3])).coords[0])
    inward = (tip[:2, 3] - edge) / np.linalg.norm(tip[:2, 3] - edge)
    for inside, on in ((0.001, True), (-0.001, False)):  # the object moved so that the tip is this far inside its edge
        shift = (np.linalg.norm(tip[:2, 3] - edge) - inside) * inward
        seen = (where_planned[0] + shift[0], where_planned[1] + shift[1], where_planned[2])
        assert segment.still_works(obj, scene.table, config, tip, seen) is on, inside


def test_a_push_is_confirmed_by_two_looks_while_the_finger_carries_the_object_on_between_them():
    # Looks 0.2 s apart (a ROS camera at 5 Hz): the object, pushed 3 cm and turned 10 deg, is carried on
    # by the finger a centimetre or more between them; they are one drift, seen twice.
    from types import SimpleNamespace

    from slideplan.transforms import compose_planar

    scene, obj, config, result, segment = _demo_segment()
    watch = Watch(scene, obj, config, default_camera(scene), (0.003, math.radians(2.0)), 1.0)
    tips = [row_to_pose(row) for row in result.fingertip_poses]
    first = len(tips) // 3
    second = next(index for index in range(first + 1, len(tips)) if np.linalg.norm(tips[index][:2, 3] - tips[first][:2, 3]) > 0.015)
    pushed = compose_planar(segment.predicted(tips[first]), (PUSHED.dx, PUSHED.dy, 0.0))
    turned = (pushed[0], pushed[1], pushed[2] + PUSHED.dyaw)
    seen_then = SimpleNamespace(motion=turned)
    seen_now = SimpleNamespace(motion=compose_planar(turned, planar_motion(tips[first], tips[second])))  # Eq. 2
    assert not watch.agree(seen_then.motion, seen_now.motion)  # as poses, the looks are far apart
    assert not watch.drifted(seen_then, segment.predicted(tips[first]), segment, tips[first])
    assert watch.drifted(seen_now, segment.predicted(tips[second]), segment, tips[second])
    # A second look that does not follow from the first (the tracker's wrong fit) confirms nothing.
    watch = Watch(scene, obj, config, default_camera(scene), (0.003, math.radians(2.0)), 1.0)
    watch.drifted(seen_then, segment.predicted(tips[first]), segment, tips[first])
    assert not watch.drifted(seen_then, segment.predicted(tips[second]), segment, tips[second])


def test_a_turn_that_leaves_the_footprint_as_it_was_is_no_pose_error():
    scene = load_scene("square")
    for name, turn, seen_turn in (("circle", 0.4, 0.0), ("square", math.pi / 2 + 0.01, 0.01), ("crescent", 0.4, 0.4)):
        obj = load_object(name, table_height=scene.table.height, pose=(0.5, 0.0, 0.0))
        watch = Watch(scene, obj, PlannerConfig.for_scene(scene), default_camera(scene), (0.003, 0.035), 1.0)
        # Turned about its centre of mass: no distance, and only the turn a camera can see.
        centre = np.asarray(obj.centroid_xy)
        turned = (*(centre - np.array([[math.cos(turn), -math.sin(turn)], [math.sin(turn), math.cos(turn)]]) @ centre), turn)
        distance, yaw = watch.error(turned, (0.0, 0.0, 0.0))
        assert distance < 1e-9 and yaw == pytest.approx(seen_turn, abs=math.radians(0.5))


def test_a_perceived_object_a_millimetre_over_an_edge_is_moved_onto_the_table():
    # The camera's estimate of an object lying at an edge can put a millimetre of it over (the planner
    # refuses an object off the table); a centimetre over is not the camera's error and stays.
    from slideplan.sim.closed_loop import ON_TABLE_SLACK_M, _on_table
    from slideplan.world.objects import load_outline, place_outline

    table = load_scene("square").table.polygon
    outline = load_outline("square")[0]
    edge_y = table.bounds[3]
    for over, moved in ((0.001, True), (ON_TABLE_SLACK_M - 1e-4, True), (0.01, False)):
        pose = (0.5, edge_y - 0.05 + over, 0.0)
        placed = _on_table(table, outline, pose)
        assert table.covers(place_outline(outline, placed)) == moved
        if moved:
            assert placed[0] == pose[0] and placed[2] == pose[2] and pose[1] - placed[1] == pytest.approx(over, abs=1e-5)
        else:
            assert placed == pose



def test_an_object_perceived_over_an_edge_is_a_run_failed_at_planning_not_an_error(monkeypatch):
    # The dev sweep (a380440): in 9 of 200 tasks a camera mounted off moved the perceived object a centimetre
    # over an edge, the planner refused it as input, and the task raised, losing all eight of its runs.
    from slideplan.sim import closed_loop

    scene = load_scene("square")
    edge_y = scene.table.polygon.bounds[3]
    over = load_object("square", table_height=scene.table.height, pose=(0.5, edge_y - 0.04, 0.0))  # 1 cm over
    monkeypatch.setattr(closed_loop, "_perceived_object", lambda *args, **kwargs: (over, None))
    result = run(scene, "square", (0.5, 0.0, 0.0), seed=1)
    assert not result.success and result.failed_stage == "plan", result
    assert "no plan for the object as perceived" in result.failure and "not on the table" in result.failure
@pytest.mark.physics
def test_when_the_arm_hides_the_object_at_the_end_the_finger_rises_clear_to_look(monkeypatch):
    # A camera beside the slide's end: at the end of the slide the hand hides the object from it. The
    # finger rises clear, the look from there finds the object, and the loop goes on from what it saw.
    # (No blind stops, so that the end look alone is tested.)
    from slideplan.loop import decisions as loop
    from slideplan.perception.camera import Camera

    monkeypatch.setattr(loop, "BLIND_S", math.inf)
    height = load_scene("square").table.height
    report = run(*DEMO, seed=1, closed=True, camera=Camera((0.5, -0.35, height + 0.7), (0.55, -0.15, height)))
    hidden = [index for index, event in enumerate(report.events) if event.trigger == "end" and event.outcome == "lost"]
    assert hidden, [(event.trigger, event.outcome) for event in report.events]
    assert all(report.events[index + 1].trigger == "clear" for index in hidden)
    assert any(event.trigger == "clear" and event.outcome in ("slide", "grasp") for event in report.events)
    assert report.success, report.summary()


@pytest.mark.physics
def test_with_a_camera_behind_the_arm_the_finger_moves_aside_to_look(monkeypatch):
    # Behind the arm and above its shoulder, the camera sees the object past the hand, but at the slide's
    # end the forearm hides it, also from 10 cm higher: only a move across clears its lines of sight.
    from slideplan.loop import decisions as loop
    from slideplan.perception.camera import Camera

    monkeypatch.setattr(loop, "BLIND_S", math.inf)
    height = load_scene("square").table.height
    report = run(*DEMO, seed=1, closed=True, camera=Camera((-0.1, 0.05, height + 0.6), (0.4, -0.15, height)))
    triggers = [(event.trigger, event.outcome) for event in report.events]
    assert ("end", "lost") in triggers, triggers
    assert any(trigger == "clear" and outcome in ("slide", "grasp") for trigger, outcome in triggers), triggers
    assert report.success, report.summary()


@pytest.mark.physics
def test_a_slide_hidden_from_the_camera_stops_to_look_from_above_and_recovers_from_a_push(monkeypatch):
    # The hand hides the object from every look with the finger on it (a camera behind the arm): the
    # push goes unseen until the slide stops, the finger rises clear and looks from there.
    import dataclasses

    from slideplan.loop.decisions import BLIND_S
    from slideplan.perception.tracking import Tracker

    real_track = Tracker.track

    def hidden(self, depth, guess=(0.0, 0.0, 0.0), contact=None):
        seen = real_track(self, depth, guess, contact)
        return seen if contact is None else dataclasses.replace(seen, ok=False, reason="hidden by the hand (test)")

    monkeypatch.setattr(Tracker, "track", hidden)
    report = run(*DEMO, seed=1, closed=True, disturbance=PUSHED)
    triggers = [(event.trigger, event.outcome) for event in report.events]
    blind = [event for event in report.events if event.trigger == "blind"]
    assert any(event.outcome in ("slide", "grasp") for event in blind), triggers
    assert blind[0].time_s >= BLIND_S and "drift" not in [trigger for trigger, _ in triggers], triggers
    assert report.success, report.summary()


@pytest.mark.physics
def test_under_the_stress_setting_the_loop_does_not_chase_the_trackers_error():
    # Torsional friction halved and the finger at its shallowest: the tracker's scatter under the arm is
    # about the 3 mm / 2 degree threshold, so looks off the prediction come often. Before the re-plan was
    # kept for drifts that matter (and to looks that agree), this run re-planned 517 times in 192 s.
    report = run(*DEMO, seed=1, closed=True, setting="stress")
    assert report.success, report.summary()
    assert report.replans <= 10 and report.sim_time_s < 60.0, report.summary()
    assert report.kept >= 1  # drifts were seen and the plan kept


@pytest.mark.physics
def test_the_closed_loop_experiment_records_each_run_of_a_task(monkeypatch, tmp_path):
    # One task of `slideplan experiment closed-loop`, the nominal setting only (each run is a whole MuJoCo task).
    import json

    import pandas as pd

    from slideplan.experiments import build_spec
    from slideplan.experiments import closed_loop as experiment

    monkeypatch.setattr(experiment, "SETTINGS", ("nominal",))
    task = build_spec("closed-loop", quick=True).tasks[0]
    row = experiment.run_closed_loop_task(task)
    assert row["error"] is None and row["solved"]
    runs = experiment.closed_loop_runs(pd.DataFrame([row]))
    assert list(runs["mode"]) == ["open", "closed"] and set(runs["setting"]) == {"nominal"}
    assert (runs["task_id"] == task.task_id).all()
    # The row is the run: the open loop again, alone, gives what the row holds.
    alone = run(task.scene, task.object, (task.x, task.y, task.yaw), seed=task.seed, closed=False, config=task.planner_config())
    opened = runs[runs["mode"] == "open"].iloc[0]
    assert bool(opened["success"]) == alone.success and opened["sim_time_s"] == alone.sim_time_s
    assert json.loads(opened["draws"]) == alone.draws
    summary = experiment.summarize_closed_loop(runs)
    assert list(summary["runs"]) == [1, 1]
    assert [path.suffix for path in experiment.plot_closed_loop(runs, tmp_path)] == [".png", ".svg"]


@pytest.mark.physics
def test_a_stopped_blind_slide_not_seen_from_above_either_goes_on_with_the_rest_of_its_plan(monkeypatch):
    # No look finds the object at all: after each blind stop the rest of the slide goes on from rest, as
    # it would have without the stop, rather than grasping where the slide stopped (short of the edge).
    import dataclasses

    from slideplan.perception.tracking import Tracker

    real_track = Tracker.track

    def never(self, depth, guess=(0.0, 0.0, 0.0), contact=None):
        return dataclasses.replace(real_track(self, depth, guess, contact), ok=False, reason="hidden (test)")

    monkeypatch.setattr(Tracker, "track", never)
    report = run(*DEMO, seed=1, closed=True)
    blind = [event for event in report.events if event.trigger == "blind"]
    assert blind and all(event.outcome == "kept" and event.detail.startswith("not seen") for event in blind), report.events
    assert report.replans == 0 and report.true_overhang_m >= 0.02, report.summary()


@pytest.mark.physics
def test_an_object_thrown_off_the_table_mid_slide_is_not_blamed_on_the_release():
    report = run(*DEMO, seed=1, closed=False, disturbance=Disturbance(1.2, 0.0, 0.0, 2.0))
    assert not report.success and report.failed_stage == "slide", report.summary()
    assert "left the table before the finger let go" in report.failure


@pytest.mark.physics
def test_a_push_from_under_the_finger_is_followed_by_a_new_slide_from_a_new_contact():
    # Pushed 4 cm sideways 2 s into the slide: the finger is no longer on the object as seen, so no slide
    # can go on from where the arm is; a whole new slide is planned, reached from above, and followed.
    report = run(*DEMO, seed=1, closed=True, disturbance=Disturbance(0.0, 0.04, 0.0, 2.0))
    triggers = [(event.trigger, event.outcome) for event in report.events]
    contact = [index for index, (trigger, _) in enumerate(triggers) if trigger == "new_contact"]
    assert contact and triggers[contact[0]][1] == "slide" and triggers[contact[0] - 1][1] == "refused", triggers
    assert report.success, report.summary()


def test_a_search_of_the_table_leaves_out_the_obstacles_whose_sides_rise_through_the_object_s_height():
    """clutter_boxed's 8 cm walls: over the whole table the largest patch at the object's height is a
    wall's side, so the search for a lost object (Watch.locate) leaves the obstacles out, and finds the
    object itself among them."""
    scene = load_scene("clutter_boxed")
    camera = default_camera(scene)
    walls = [Box(tuple(o.center), tuple(o.size), o.yaw) for o in scene.obstacles]
    pose = (0.5, -0.05, 0.3)
    obj = load_object("crescent", table_height=scene.table.height, pose=(0.5, -0.05, 0.0))
    watch = Watch(scene, obj, PlannerConfig.for_scene(scene), camera, (0.003, math.radians(2.0)), 0.05)

    def frame(objects):
        spec = scene_spec(scene.table, place_objects(objects), walls, camera)
        return noisy_depth(depth_image(spec, camera), 0.002, 0.05, np.random.default_rng(3))

    empty = frame([])
    tracker = Tracker(obj, camera, table_height=scene.table.height)
    assert tracker.locate(empty, (0.0, 0.0, 0.0), scene.table.polygon) is not None  # a wall, taken for it
    assert watch.locate(lambda: (empty, None), (0.0, 0.0, 0.0)) is None
    found = watch.locate(lambda: (frame([("crescent", pose)]), None), (0.0, 0.0, 0.0))
    truth = load_object("crescent", table_height=scene.table.height, pose=pose)
    assert found is not None
    assert np.linalg.norm(obj.moved(found).centroid_xy - truth.centroid_xy) < 0.02  # a start for tracking


@pytest.mark.parametrize("verifier_rejects", [False, True])
def test_an_object_seen_over_the_edge_with_the_finger_off_it_is_grasped_from_a_touch_where_it_is(verifier_rejects, monkeypatch):
    """The object slid on ahead of the finger to where it already overhangs (a heavy object on a slippery
    table): the planner takes an object over an edge only from a state, so a new contact puts the finger
    down on it where it is seen, and plans from there, rather than grasping where Eq. 2 put the object.
    A plan the verifier rejects is not run (the loop plans through slideplan.checks.pipeline)."""
    from slideplan.checks import pipeline
    from slideplan.loop.decisions import SlideLoop
    from slideplan.plan.robot import build_robot
    from slideplan.checks.verify import verify

    scene = load_scene(DEMO[0])
    config = PlannerConfig.for_scene(scene, seed=1)
    obj = load_object(DEMO[1], table_height=scene.table.height, pose=DEMO[2])
    first = plan(scene, obj, config)
    motion = tuple(first.object_motion[key] for key in ("x", "y", "yaw"))
    seen = obj.moved(motion)
    assert not scene.table.polygon.contains(seen.outline)  # over the edge: no plan from scratch takes it

    class Arm:
        events, moves = [], []

        def clock(self):
            return 0.0

        def record(self, event):
            self.events.append(event)

        def move(self, result, path, phase):
            self.moves.append(phase)

    robot = build_robot(first.robot)
    watch = Watch(scene, obj, config, default_camera(scene), (0.003, math.radians(2.0)), 1.0)
    off = np.asarray(first.trajectory[0])  # the finger where the slide began, 10 cm behind the object now
    assert not seen.outline.buffer(0.005).contains(shapely.Point(np.asarray(robot.fk(off))[:2, 3]))
    loop = SlideLoop(watch, robot, scene.table.height + obj.thickness, 3, Arm())
    if verifier_rejects:
        monkeypatch.setattr(pipeline, "verify", lambda result, **_: pipeline.Verification(["trajectory[2]: planted"]))
        assert loop.new_contact(motion, off) is None and Arm.moves == []
        assert (Arm.events[-1].outcome, Arm.events[-1].detail) == ("refused", "the new plan fails verification: trajectory[2]: planted")
        return
    fresh = loop.new_contact(motion, off)
    assert fresh is not None, Arm.events[-1]
    assert Arm.events[-1].outcome in ("grasp", "slide") and Arm.moves == ["reach"]
    assert seen.outline.contains(shapely.Point(np.asarray(robot.fk(fresh.trajectory[0]))[:2, 3]))
    assert verify(fresh).ok


@pytest.mark.physics
def test_a_run_seen_over_the_edge_whose_object_was_not_held_fails_whatever_the_runner_says(monkeypatch):
    # The disturbed demo, its closed loop seen over u* after the slide; the grasp skipped and reported fine:
    # no object was held, so the world says no.
    from slideplan.sim.runner import Runner

    monkeypatch.setattr(Runner, "grasp", lambda self, *args: None)
    report = run(*DEMO, seed=1, closed=True, disturbance=PUSHED)
    assert report.seen_status == "seen" and report.seen_overhang_m >= PlannerConfig.for_scene(load_scene("square")).u_star
    assert not report.success and report.failed_stage == "hold", report.summary()


@pytest.mark.physics
def test_a_run_seen_short_whose_object_was_held_succeeds_and_a_lost_look_is_reported_lost(monkeypatch):
    # The open loop, undisturbed: its look after the slide made to say the object never moved (seen short of
    # u*, wholly on the table); the world's verdict holds. Then the same look lost: no seen numbers at all.
    import dataclasses

    real = Watch.settled

    def unmoved(self, *args, **kwargs):
        return dataclasses.replace(real(self, *args, **kwargs), ok=True, motion=(0.0, 0.0, 0.0))

    monkeypatch.setattr(Watch, "settled", unmoved)
    report = run(*DEMO, seed=1, closed=False)
    assert report.seen_overhang_m < PlannerConfig.for_scene(load_scene("square")).u_star
    assert report.success and report.failed_stage is None, report.summary()
    assert report.seen_frames and report.true_overhang_m > report.seen_overhang_m

    def lost(self, *args, **kwargs):
        return dataclasses.replace(real(self, *args, **kwargs), ok=False, reason="lost (test)")

    monkeypatch.setattr(Watch, "settled", lost)
    again = run(*DEMO, seed=1, closed=False)
    assert again.seen_status == "lost" and again.seen_overhang_m is None and again.seen_motion is None
    assert again.success == report.success and again.true_overhang_m == report.true_overhang_m


@pytest.mark.physics
def test_a_capped_closed_loop_re_plans_no_more_and_says_so(monkeypatch):
    # The disturbed demo with the re-plan cap at 0: the push is not chased, the slide runs to its end and the
    # row says why the loop stopped deciding.
    import slideplan.loop.decisions as loop

    monkeypatch.setattr(loop, "MAX_REPLANS", 0)
    report = run(*DEMO, seed=1, closed=True, disturbance=PUSHED)
    assert report.replans == 0 and report.slide_stop == "replan_cap", report.summary()
    assert report.seen_frames and report.slide_s > 0


def test_a_task_that_raised_counts_its_unfinished_runs_as_failures():
    import pandas as pd

    from slideplan.experiments import closed_loop as experiment

    def row(task_id, error=None, finished=None):
        out = {field.name: None for field in experiment.CLOSED_LOOP_ROW_SCHEMA} | {"task_id": task_id, "error": error}
        for setting in experiment.SETTINGS:
            for mode in experiment.MODES:
                if finished is None or (setting, mode) in finished:
                    out[f"{setting}_{mode}_success"], out[f"{setting}_{mode}_replans"] = True, 1
        return out

    tasks = pd.DataFrame([row("ok"), row("broke", "RuntimeError: mesh", finished={("nominal", "open")})])
    runs = experiment.closed_loop_runs(tasks)
    assert len(runs) == 2 * len(experiment.SETTINGS) * len(experiment.MODES)  # none left out
    broke = runs[runs["task_id"] == "broke"]
    finished = broke[(broke["setting"] == "nominal") & (broke["mode"] == "open")]
    assert bool(finished["success"].iloc[0]) and finished["failed_stage"].isna().all()  # the run it finished is kept
    unfinished = broke.drop(finished.index)
    assert (~unfinished["success"].astype(bool)).all() and (unfinished["failed_stage"] == "error").all()
    assert (unfinished["failure"] == "RuntimeError: mesh").all()
    summary = experiment.summarize_closed_loop(runs)
    assert summary.set_index(["setting", "mode"]).loc[("hard", "closed"), "success"] == 0.5


def test_the_camera_finds_the_object_on_a_small_arms_table():
    # The SO-101's table (14 x 20 cm) is 5% of the camera's frame: on the whole cloud, perceive took the floor
    # for the table and the table for clutter, and no run on it could start.
    from scipy.spatial import cKDTree

    from slideplan.sim.closed_loop import _perceived_object

    scene = load_scene("so101_square")
    pose = (0.37, 0.0, 0.4)
    seen, plane = _perceived_object(scene, "irregular", default_camera(scene), pose, 0.002, 1)
    truth = load_object("irregular", table_height=scene.table.height, pose=pose)
    distances = cKDTree(truth.points[:, :2]).query(seen.points[:, :2])[0]
    assert np.percentile(distances, 95) < 0.003, np.percentile(distances, 95)
    assert abs(plane[2] - scene.table.height) < 0.005  # the table top's plane, not the floor's


def test_the_ros_node_perceives_the_object_as_the_simulated_loop_does():
    # The same frame (rendered, back-projected to the world) through the node's path and through the loop's.
    from slideplan.perception.camera import back_project
    from slideplan.ros.task import perceived_task
    from slideplan.sim.closed_loop import DEPTH_DROPOUT, _perceived_object

    scene, pose = load_scene("square"), (0.55, -0.08, 0.4)
    camera = default_camera(scene)
    loop_object, _ = _perceived_object(scene, "crescent", camera, pose, 0.002, 1)
    depth = depth_image(scene_spec(scene.table, place_objects([("crescent", pose)]), [], camera), camera)
    cloud = back_project(noisy_depth(depth, 0.002, DEPTH_DROPOUT, np.random.default_rng(1)), camera)
    _, node_object, seen, _, _ = perceived_task(scene, cloud, 0, 1, object_name="crescent")
    def hull(thin_object):
        return shapely.MultiPoint(np.asarray(thin_object.points)[:, :2]).convex_hull

    assert seen == 1 and node_object.name == loop_object.name == "crescent"
    assert hull(node_object).hausdorff_distance(hull(loop_object)) < 0.002  # one registration, one object
    _, raw_object, _, _, _ = perceived_task(scene, cloud, 0, 1)  # no outline named: the points themselves
    assert raw_object.name == "object 0" and hull(raw_object).hausdorff_distance(hull(loop_object)) < 0.015  # its blur


@pytest.mark.physics
def test_the_ls_grasp_lifts_once_its_centre_of_mass_stays_on_what_the_table_bears():
    """support_hull: on the triangle table the plan without the grasp's physics rules leaves the L's centre of
    mass inside the table and off the L's part on it; when the finger lets go the L tips over the edge and the
    hand closes on nothing. With the rules (opt-in) the same task is lifted."""
    scene = load_scene("triangle")
    pose, seed = (0.5191195067123792, -0.048628356003934226, -0.3383366871271103), 86967003
    rules_off = PlannerConfig.for_scene(scene, seed=seed, support_hull=False, grasp_model=False)
    tipped = run(scene, "L", pose, seed=seed, closed=False, config=rules_off)
    assert not tipped.success and tipped.failed_stage == "grasp", tipped.summary()
    rules_on = PlannerConfig.for_scene(scene, seed=seed, support_hull=True, grasp_model=True)
    held = run(scene, "L", pose, seed=seed, closed=False, config=rules_on)
    assert held.success, held.summary()


def test_a_pose_seen_a_few_millimetres_off_the_pressing_finger_is_moved_under_it():
    # The tracker takes a fit with the fingertip up to INLIER_M outside the object's outline, and the camera's
    # mounting error moves every fit; a re-plan from such a pose was refused as not starting on the
    # object. The finger presses on it: the pose is moved onto the finger, by the least shift; a finger
    # further off than FINGER_SNAP_M is not on the object (pushed from under it) and the pose stays.
    from slideplan.checks.verify import start_contact
    from slideplan.loop.watch import FINGER_SNAP_M
    from slideplan.perception.tracking import INLIER_M

    scene = load_scene("square")
    for name in ("square", "crescent"):
        obj = load_object(name, table_height=scene.table.height, pose=(0.5, 0.0, 0.3))
        watch = Watch(scene, obj, PlannerConfig.for_scene(scene), default_camera(scene), (0.003, 0.035), 1.0)
        hull = shapely.MultiPoint(obj.points[:, :2]).convex_hull
        centre = np.asarray(hull.centroid.coords[0])
        edge = obj.points[np.argmax(np.linalg.norm(obj.points[:, :2] - centre, axis=1)), :2]  # a hull vertex
        outward = (edge - centre) / np.linalg.norm(edge - centre)  # beyond it: off the hull, this far off the object
        seen = (0.004, -0.002, 0.05)  # the fit: a few millimetres and degrees off the perceived pose
        moved = obj.moved(seen)
        seen_edge = move_planar(edge, seen)
        seen_outward = outward @ np.array([[math.cos(0.05), math.sin(0.05)], [-math.sin(0.05), math.cos(0.05)]])
        for outside, snapped in ((0.5 * INLIER_M, True), (2 * INLIER_M, True), (FINGER_SNAP_M + 0.002, False)):
            tip = np.eye(4)
            tip[:2, 3] = seen_edge + outside * seen_outward
            assert not shapely.MultiPoint(moved.points[:, :2]).convex_hull.contains(shapely.Point(tip[:2, 3]))
            now = watch.on_finger(seen, tip)
            if not snapped:  # pushed from under the finger: left for a new contact
                assert now == seen
                continue
            assert now[2] == seen[2] and 0 < np.hypot(now[0] - seen[0], now[1] - seen[1]) <= FINGER_SNAP_M
            under = obj.moved(now).points[:, :2]
            assert shapely.MultiPoint(under).convex_hull.contains(shapely.Point(tip[:2, 3]))  # the planner's test
            gap, tolerance = start_contact(under, tip[:2, 3])  # the verifier's
            assert gap <= tolerance
        deepest = obj.points[np.argmax(shapely.distance(hull.exterior, shapely.points(obj.points[:, :2]))), :2]
        inside = np.eye(4)
        inside[:2, 3] = move_planar(deepest, seen)  # on one of its points, deep inside its hull
        assert watch.on_finger(seen, inside) == seen  # already on it: unchanged


def test_after_a_slip_plans_press_in_the_deepest_quarter_of_the_band_then_from_another_contact():
    scene = load_scene("square")
    obj = load_object("square", table_height=scene.table.height, pose=(0.5, 0.0, 0.0))
    config = PlannerConfig.for_scene(scene).resolved(scene)
    watch = Watch(scene, obj, config, default_camera(scene), (0.003, 0.035), 1.0)
    low, high, seed = watch.replan_config.dz_min, watch.replan_config.dz_max, watch.replan_config.seed
    assert low < high
    assert watch.press_deeper()
    assert watch.replan_config.dz_min == pytest.approx(high - (high - low) / 4) and watch.replan_config.dz_max == high
    assert watch.replan_config.seed == seed
    assert not watch.press_deeper()  # as deep as it goes, and no other contact asked for
    assert watch.press_deeper(another=True) and watch.replan_config.seed == seed + 1
    assert watch.replan_config.dz_min == pytest.approx(high - (high - low) / 4)


@pytest.mark.physics
def test_a_pad_that_slips_over_the_object_ends_the_run_for_a_slip_after_pressing_deeper_and_another_contact():
    # A dev task (the crescent on the triangle, pose 4) whose hard draw gives the pad less friction (0.43)
    # than the table (0.63), and no push. No normal force makes such a pad carry the object: the loop sees
    # the finger travel on and the object stay, slides anew from new contacts pressed deeper, and ends the
    # run for a slip, without a grasp.
    from slideplan.loop.decisions import SLIP_FAILURE

    report = run("triangle", "crescent", (0.408927987466508, -0.10810048999667199, 0.9026371459183293), seed=1632981460,
                 closed=True, setting="hard")
    assert report.draws["pad_friction"] < report.draws["table_friction"] and not report.draws["push"]
    assert not report.success and report.failed_stage == "slide" and report.failure == SLIP_FAILURE, report.summary()
    assert report.slide_stop == "slip"  # the contract's value; it says what no progress would
    assert report.grasp_pose is None and not report.lifted
    assert sum(event.trigger == "new_contact" for event in report.events) >= 2


def _seen(motion):
    from slideplan.perception.tracking import TrackedPose

    return TrackedPose(True, tuple(float(value) for value in motion), 200, 0.001)


def test_a_slide_the_looks_find_graspable_early_ends_short_only_once_seen_so_from_clear(monkeypatch):
    # A fit under the hand a centimetre ahead of the object made a nominal slide stop at 1.7 cm of overhang
    # and grasp there, where the planned slide went on to 5 cm: the look from clear decides.
    from slideplan.loop.decisions import SlideLoop, Stop
    from slideplan.loop.watch import Replan
    from slideplan.plan.robot import build_robot

    scene, obj, config, result, segment = _demo_segment()
    middle = len(result.trajectory) // 2
    config_then = np.asarray(result.trajectory)[middle]
    early_grasp = dataclasses.replace(result, trajectory=config_then[None, :])

    class Arm:
        def __init__(self):
            self.slides, self.stops = [], []

        def slide(self, segment, look):
            self.slides.append(segment)
            if len(self.slides) == 1:  # a drift look asks for a grasp halfway
                return Stop(early_grasp, (0.01, 0.0, 0.0), config_then, float(segment.times[middle]))
            return None

        def stop(self, stop):
            self.stops.append(stop)

        def switch(self, stop):
            raise AssertionError("the early grasp is not switched to before the look from clear")

        def clock(self):
            return 0.0

        def record(self, event):
            pass

        def replanned(self, *_):
            pass

    robot = build_robot(result.robot)
    # (its outcome, slides re-planned after their end before it: at the cap too, the rest of a slide stopped short goes on)
    for (outcome, ends), last in ((("kept", 0), "planned"), (("kept", 3), "planned"), (("lost", 0), "early")):
        arm = Arm()
        watch = Watch(scene, obj, config, default_camera(scene), (0.003, math.radians(2.0)), 1.0)
        loop = SlideLoop(watch, robot, scene.table.height + obj.thickness, 3, arm)
        loop.ends = ends
        asked = []

        def look_at_end(segment, blind, end_config, predicted, clear=False, outcome=outcome):
            asked.append(clear)
            return None, Replan(0.0, "clear", 0.0, 0.0, 0.0, 0.0, outcome), _seen(predicted)

        monkeypatch.setattr(loop, "look_at_end", look_at_end)
        plan_made, _ = loop.run(result)
        assert asked[0] is True and len(arm.stops) == 1  # stopped, and looked at from clear
        if last == "planned":  # seen on track from clear: the rest of the slide, from rest, and its own grasp
            assert len(arm.slides) == 2 and np.allclose(arm.slides[1].result.trajectory[0], config_then)
            assert plan_made.grasp is result.grasp and len(plan_made.trajectory) > 1
        else:  # not seen from clear: the grasp the looks asked for
            assert plan_made is early_grasp and len(arm.slides) == 1


def test_an_object_the_finger_alone_holds_on_the_table_is_not_let_go_to_look_from_clear(monkeypatch):
    # An L slid past the edge, its centre of mass just inside what the table bears, tipped off the table
    # when the finger rose to look; the open loop's grasp caught it where it was.
    from slideplan.loop.decisions import STAYS_SHARE, SlideLoop
    from slideplan.loop.watch import Replan, slide_segment
    from slideplan.plan.robot import build_robot
    from slideplan.world.geometry import support_margin

    scene, _, config, result, segment = _demo_segment()
    obj = load_object("L", table_height=scene.table.height, pose=(0.5, 0.0, 0.0))
    watch = Watch(scene, obj, config, default_camera(scene), (0.003, math.radians(2.0)), 1.0)
    moved = lambda dx: obj.moved((dx, 0.0, 0.0))
    margins = {dx: support_margin(scene.table, moved(dx).points[:, :2], moved(dx).centroid_xy) for dx in np.arange(0.0, 0.4, 0.001)}
    share = STAYS_SHARE * config.support_margin
    near = min((dx for dx, margin in margins.items() if 0.0 < margin < share), key=lambda dx: margins[dx])
    safe = min((dx for dx, margin in margins.items() if share <= margin < config.support_margin), key=lambda dx: margins[dx])

    class Arm:
        moves = []

        def clock(self):
            return 0.0

        def frames(self):
            return None

        def record(self, event):
            pass

        def move(self, result, path, phase):
            self.moves.append(phase)

    loop = SlideLoop(watch, build_robot(result.robot), scene.table.height + obj.thickness, 3, Arm())
    monkeypatch.setattr(loop, "clear_way", lambda *_: np.zeros((2, len(result.trajectory[0]))))
    lost = Replan(0.0, "end", 0.0, 0.0, 0.0, 0.0, "lost")
    monkeypatch.setattr(watch, "replan", lambda *_, **__: (None, lost, _seen((0.0, 0.0, 0.0))))
    monkeypatch.setattr(watch, "locate", lambda *_: None)  # not found on the whole table either
    end = np.asarray(result.trajectory)[-1]
    for dx, lifted in ((0.0, True), (safe, True), (near, False)):
        Arm.moves.clear()
        assert loop.stays((dx, 0.0, 0.0)) is lifted
        loop.look_at_end(segment, False, end, (dx, 0.0, 0.0))
        assert (Arm.moves == ["clear", "clear"]) is lifted and (Arm.moves == []) is not lifted, (dx, Arm.moves)
