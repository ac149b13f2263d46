"""Timed plans (slideplan.plan/2 timing block) and their export, checked by finite differences.

Nothing here asks toppra: the limits are re-checked from positions, times and velocities alone,
and fingertip speeds from forward kinematics of the waypoints.
"""

import csv
import dataclasses
import json
import math
import subprocess
import sys

import numpy as np
import pytest
from typer.testing import CliRunner

from slideplan import _core
from slideplan.cli import app
from slideplan.errors import InputError
from slideplan.plan.motions import rest_to_rest
from slideplan.world.objects import load_object
from slideplan.plan.config import PlannerConfig
from slideplan.plan.result import PlanResult
from slideplan.plan.planner import plan
from slideplan.world.scenes import load_scene
from slideplan.plan.timing import (
    DEFAULT_FINGERTIP_SPEED,
    DEFAULT_JOINT_ACCELERATION,
    DEFAULT_JOINT_VELOCITY,
    NEAR_TABLE_M,
    LimitWarning,
    TimingOptions,
    parameterize,
)

URDF_VELOCITY = 2.0  # every arm joint's <limit velocity> in data/robots/wam_t42.urdf
RELATIVE_SLACK = 1e-9  # floating-point slack on "<= limit"


@pytest.fixture(scope="module")
def handmade(handmade_plan):
    """A straight 3.5 cm slide and a 7 cm lift, timed with the defaults."""
    return dataclasses.replace(handmade_plan, timing=parameterize(handmade_plan))


def fingertip_positions(result, path):
    robot = _core.RobotModel(result.robot["urdf"], tip_link=result.robot["tip_link"], base_pose=result.robot["base_pose"])
    return np.array([np.asarray(robot.fk(q))[:3, 3] for q in path])


def check_segment(path, segment, vmax, amax, tips=None, capped=None, cap=None):
    """Every limit at every waypoint and between waypoints, by finite differences; returns the largest tip speed."""
    t, v, a = segment["time_from_start"], segment["velocities"], segment["accelerations"]
    assert len(t) == len(path) == len(v) == len(a)
    assert t[0] == 0.0 and np.all(np.diff(t) > 0)
    assert not np.any(v[0]) and not np.any(v[-1])
    dt = np.diff(t)[:, None]
    # reported values
    assert np.all(np.abs(v) <= vmax * (1 + RELATIVE_SLACK))
    assert np.all(np.abs(a) <= amax * (1 + RELATIVE_SLACK))
    # velocity between waypoints, from positions
    mean_velocity = np.diff(path, axis=0) / dt
    assert np.all(np.abs(mean_velocity) <= vmax * (1 + RELATIVE_SLACK))
    # acceleration from the reported velocities, and from second differences of positions (at rest at both ends)
    assert np.all(np.abs(np.diff(v, axis=0)) / dt <= amax * (1 + RELATIVE_SLACK))
    interior = np.diff(mean_velocity, axis=0) / ((dt[:-1] + dt[1:]) / 2)
    assert np.all(np.abs(interior) <= amax * (1 + RELATIVE_SLACK))
    for velocity, span in ((mean_velocity[0], dt[0]), (mean_velocity[-1], dt[-1])):
        assert np.all(2 * np.abs(velocity) / span <= amax * (1 + RELATIVE_SLACK))  # q1 - q0 = a dt^2 / 2 from rest
    # the reported velocities are the trajectory's: a central difference spans 2 intervals, over which
    # the velocity cannot change by more than amax * span
    central = (path[2:] - path[:-2]) / (t[2:] - t[:-2])[:, None]
    assert np.all(np.abs(central - v[1:-1]) <= amax * (t[2:] - t[:-2])[:, None])
    if tips is None:
        return 0.0
    speeds = np.linalg.norm(np.diff(tips, axis=0), axis=1) / dt[:, 0]
    limited = capped[:-1] | capped[1:]
    assert np.all(speeds[limited] <= cap * (1 + RELATIVE_SLACK))
    return float(np.max(speeds[limited], initial=0.0))


@pytest.mark.parametrize("which", ["planned", "handmade"])
def test_timed_plan_respects_every_limit(which, request):
    result = request.getfixturevalue(which)
    timing = result.timing
    dof = result.dof
    assert np.array_equal(timing["limits"]["joint_velocity"], np.full(dof, URDF_VELOCITY))
    assert np.array_equal(timing["limits"]["joint_acceleration"], np.full(dof, DEFAULT_JOINT_ACCELERATION))
    assert timing["limits"]["fingertip_speed"] == DEFAULT_FINGERTIP_SPEED == 0.05
    vmax, amax = URDF_VELOCITY, DEFAULT_JOINT_ACCELERATION
    slide_tips = fingertip_positions(result, result.trajectory)
    fastest = check_segment(result.trajectory, timing["trajectory"], vmax, amax,
                            slide_tips, np.ones(len(slide_tips), bool), DEFAULT_FINGERTIP_SPEED)
    assert fastest > 0.5 * DEFAULT_FINGERTIP_SPEED  # near time-optimal: the slide does reach the cap
    approach = result.grasp["approach"]
    approach_tips = fingertip_positions(result, approach)
    near_table = approach_tips[:, 2] < result.table["height"] + result.object["thickness"] + NEAR_TABLE_M
    assert near_table[0]  # the approach starts with the fingertip on the object
    check_segment(approach, timing["approach"], vmax, amax, approach_tips, near_table, DEFAULT_FINGERTIP_SPEED)


def test_rest_to_rest_times_a_path_the_plan_does_not_hold_as_the_plan_times_its_slide(handmade):
    robot = handmade.robot_model()
    path, limits = np.asarray(handmade.trajectory), handmade.timing["limits"]
    capped = rest_to_rest(robot, path, limits, "lift")
    for key in ("time_from_start", "velocities", "accelerations"):  # the slide is capped all along too
        assert np.allclose(capped[key], handmade.timing["trajectory"][key], rtol=1e-9, atol=1e-12), key
    tips = fingertip_positions(handmade, path)
    fastest = check_segment(path, capped, URDF_VELOCITY, DEFAULT_JOINT_ACCELERATION, tips, np.ones(len(path), bool),
                            DEFAULT_FINGERTIP_SPEED)
    free = rest_to_rest(robot, path, limits, "reach", capped=False)
    check_segment(path, free, URDF_VELOCITY, DEFAULT_JOINT_ACCELERATION)
    assert fastest > 0.9 * DEFAULT_FINGERTIP_SPEED  # the cap binds, so without it the move is quicker
    assert free["time_from_start"][-1] < 0.9 * capped["time_from_start"][-1]
    with pytest.raises(InputError) as error:
        rest_to_rest(robot, path, dict(limits, joint_velocity=-limits["joint_velocity"]), "lift")
    assert error.value.field.startswith("timing")


def test_a_look_from_clear_is_capped_only_near_the_object(handmade):
    # The closed loop's look from clear (up off the object and back) was capped all the way: 10 cm up,
    # 15 cm across and back took 10 s of a run at the slide's 5 cm/s.
    from slideplan.plan.motions import dense, straight_up

    robot, limits = handmade.robot_model(), handmade.timing["limits"]
    path = dense(list(straight_up(robot, np.asarray(handmade.trajectory[-1]), 0.12)))
    tips = fingertip_positions(handmade, path)
    near = tips[:, 2] < handmade.object_top + NEAR_TABLE_M
    assert near.any() and not near.all()
    look = rest_to_rest(robot, path, limits, "clear", top=handmade.object_top)
    check_segment(path, look, URDF_VELOCITY, DEFAULT_JOINT_ACCELERATION, tips, near, DEFAULT_FINGERTIP_SPEED)
    capped, free = (rest_to_rest(robot, path, limits, "clear", capped=flag)["time_from_start"][-1] for flag in (True, False))
    assert free <= look["time_from_start"][-1] < capped


def test_limits_can_be_overridden(handmade):
    slow = parameterize(handmade, TimingOptions(fingertip_speed=0.01, joint_acceleration=[0.5] * 7, joint_velocity=[1.5] * 7))
    assert slow["limits"]["fingertip_speed"] == 0.01
    assert np.array_equal(slow["limits"]["joint_velocity"], np.full(7, 1.5))
    tips = fingertip_positions(handmade, handmade.trajectory)
    check_segment(handmade.trajectory, slow["trajectory"], 1.5, 0.5, tips, np.ones(len(tips), bool), 0.01)
    # 3.5 cm at <= 1 cm/s takes at least 3.5 s; at the default 5 cm/s it took less
    slide_length = np.linalg.norm(tips[-1] - tips[0])
    assert slow["trajectory"]["time_from_start"][-1] >= slide_length / 0.01
    assert handmade.timing["trajectory"]["time_from_start"][-1] < slide_length / 0.01


@pytest.mark.parametrize(
    "options, field",
    [
        (dict(fingertip_speed=0.0), "fingertip_speed"),
        (dict(joint_acceleration=-1.0), "joint_acceleration"),
        (dict(joint_acceleration=math.nan), "joint_acceleration"),
        (dict(joint_velocity=[]), "joint_velocity"),
        (dict(joint_velocity=[1.0, "x"]), "joint_velocity"),
    ],
)
def test_bad_timing_options_are_rejected(options, field):
    with pytest.raises(InputError, match=field):
        TimingOptions(**options)


def test_per_joint_option_of_the_wrong_length_is_rejected(handmade):
    with pytest.raises(InputError, match="joint_acceleration.*7"):
        parameterize(handmade, TimingOptions(joint_acceleration=[1.0, 2.0]))


def test_bad_urdf_velocity_limits_fall_back_to_the_default_with_a_warning(handmade, tmp_path):
    text = open(handmade.robot["urdf"]).read()
    text = text.replace('effort="60" velocity="2.0"', 'effort="60" velocity="0"', 1)  # wam_j1
    text = text.replace('effort="45" velocity="2.0"', 'effort="45" velocity="-1"', 1)  # wam_j3
    # wam_j7 continuous without <limit> (urdfdom requires the velocity of every <limit> it reads)
    text = text.replace('<joint name="wam_j7" type="revolute">', '<joint name="wam_j7" type="continuous">', 1)
    text = text.replace('<limit lower="-3.00196631343" upper="3.00196631343" effort="2" velocity="2.0"/>', "", 1)
    urdf = tmp_path / "robot.urdf"
    urdf.write_text(text)
    result = dataclasses.replace(handmade, robot={**handmade.robot, "urdf": str(urdf)})
    with pytest.warns(LimitWarning) as caught:
        timing = parameterize(result)
    message = str(caught[0].message)
    assert "wam_j1 (0 or missing)" in message and "wam_j3 (-1)" in message and "wam_j7 (0 or missing)" in message
    assert "wam_j2" not in message and str(urdf) in message
    expected = [DEFAULT_JOINT_VELOCITY, URDF_VELOCITY, DEFAULT_JOINT_VELOCITY] + [URDF_VELOCITY] * 3 + [DEFAULT_JOINT_VELOCITY]
    assert timing["limits"]["joint_velocity"].tolist() == expected


def test_unsolved_plan_is_not_timed(handmade):
    with pytest.raises(InputError, match="not solved"):
        parameterize(dataclasses.replace(handmade, status="timeout"))


def test_plan_json_round_trip_keeps_timing(planned):
    again = PlanResult.from_json(planned.to_json())
    for key in ("trajectory", "approach"):
        for name, array in planned.timing[key].items():
            assert np.array_equal(again.timing[key][name], array), (key, name)
    assert again.to_dict() == planned.to_dict()
    data = json.loads(planned.to_json())
    assert data["schema"] == "slideplan.plan/2"
    assert set(data["timing"]) == {"trajectory", "approach", "limits"}
    assert set(data["timing"]["limits"]) == {"joint_velocity", "joint_acceleration", "fingertip_speed"}
    assert set(data["timing"]["trajectory"]) == {"time_from_start", "velocities", "accelerations"}


def test_version_1_plans_are_read_without_timing(planned):
    data = planned.to_dict()
    data["schema"] = "slideplan.plan/1"
    del data["timing"]
    old = PlanResult.from_dict(data)
    assert old.timing is None and np.array_equal(old.trajectory, planned.trajectory)
    with pytest.raises(InputError, match="unknown fields.*timing"):
        PlanResult.from_dict({**data, "timing": None})
    with pytest.raises(InputError, match="missing fields.*timing"):
        PlanResult.from_dict({**data, "schema": "slideplan.plan/2"})


@pytest.mark.parametrize(
    "mutate, field",
    [
        (lambda timing: timing["trajectory"]["time_from_start"].__setitem__(1, 0.0), "timing.trajectory.time_from_start"),
        (lambda timing: timing["approach"]["velocities"][-1].__setitem__(0, 0.1), "timing.approach.velocities"),
        (lambda timing: timing["approach"]["time_from_start"].pop(), "timing.approach"),
        (lambda timing: timing.pop("limits"), "timing"),
    ],
)
def test_bad_timing_block_is_rejected(planned, mutate, field):
    data = planned.to_dict()
    mutate(data["timing"])
    with pytest.raises(InputError, match=field):
        PlanResult.from_dict(data)


def run(*args):
    return CliRunner().invoke(app, [str(arg) for arg in args])


def test_ros_json_export_round_trips(planned, tmp_path):
    source, out = tmp_path / "plan.json", tmp_path / "plan.ros.json"
    source.write_text(planned.to_json())
    result = run("export", source, "--format", "ros-json", "--out", out)
    assert result.exit_code == 0, result.output + result.stderr
    document = json.loads(out.read_text())
    names = [segment["name"] for segment in document["segments"]]
    assert names == ["slide", "approach"]
    for segment, path, timing in zip(document["segments"], (planned.trajectory, planned.grasp["approach"]),
                                     (planned.timing["trajectory"], planned.timing["approach"])):
        message = segment["joint_trajectory"]
        assert set(message) == {"header", "joint_names", "points"} and message["joint_names"] == planned.joint_names
        points = message["points"]
        assert all(set(point) == {"positions", "velocities", "accelerations", "effort", "time_from_start"} for point in points)
        assert np.array_equal([point["positions"] for point in points], path)  # passes through the plan's waypoints
        assert np.array_equal([point["velocities"] for point in points], timing["velocities"])
        assert np.array_equal([point["accelerations"] for point in points], timing["accelerations"])
        stamps = [point["time_from_start"] for point in points]
        assert all(isinstance(s["sec"], int) and isinstance(s["nanosec"], int) and 0 <= s["nanosec"] < 10**9 for s in stamps)
        seconds = np.array([s["sec"] + s["nanosec"] * 1e-9 for s in stamps])
        assert np.all(np.abs(seconds - timing["time_from_start"]) <= 1e-9) and np.all(np.diff(seconds) > 0)


def test_csv_export_round_trips_exactly(planned, tmp_path):
    source, out = tmp_path / "plan.json", tmp_path / "plan.csv"
    source.write_text(planned.to_json())
    assert run("export", source, "--format", "csv", "--out", out).exit_code == 0
    rows = list(csv.DictReader(out.open()))
    for name, path, timing in (("slide", planned.trajectory, planned.timing["trajectory"]),
                               ("approach", planned.grasp["approach"], planned.timing["approach"])):
        mine = [row for row in rows if row["segment"] == name]
        assert np.array_equal([float(row["time_from_start"]) for row in mine], timing["time_from_start"])
        for quantity, expected in (("position", path), ("velocity", timing["velocities"]),
                                   ("acceleration", timing["accelerations"])):
            table = [[float(row[f"{quantity}_{joint}"]) for joint in planned.joint_names] for row in mine]
            assert np.array_equal(table, expected), (name, quantity)
    assert len(rows) == len(planned.trajectory) + len(planned.grasp["approach"])


def test_version_1_plan_is_timed_on_export(planned, tmp_path):
    data = planned.to_dict()
    data["schema"] = "slideplan.plan/1"
    del data["timing"]
    source, out = tmp_path / "old.json", tmp_path / "old.csv"
    source.write_text(json.dumps(data))
    assert run("export", source, "--format", "csv", "--out", out).exit_code == 0
    times = [float(row["time_from_start"]) for row in csv.DictReader(out.open()) if row["segment"] == "slide"]
    assert np.array_equal(times, planned.timing["trajectory"]["time_from_start"])  # the same limits give the same timing


def assert_bad_input(result, *fragments):
    assert result.exit_code == 2, result.output
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("slideplan: error: "), result.stderr
    for fragment in fragments:
        assert fragment in lines[0], lines[0]


def test_export_refuses_an_unsolved_plan(planned, tmp_path):
    source = tmp_path / "timeout.json"
    unsolved = dataclasses.replace(planned, status="timeout", timing=None)
    source.write_text(unsolved.to_json())
    assert_bad_input(run("export", source, "--format", "csv", "--out", tmp_path / "x.csv"), str(source), "not solved")
    assert not (tmp_path / "x.csv").exists()


def test_export_refuses_an_unknown_schema(planned, tmp_path):
    source = tmp_path / "future.json"
    source.write_text(json.dumps({**planned.to_dict(), "schema": "slideplan.plan/9"}))
    assert_bad_input(run("export", source, "--format", "ros-json", "--out", tmp_path / "x.json"), str(source), "schema", "plan/9")


def test_export_reports_a_missing_file_and_a_bad_format(planned, tmp_path):
    assert_bad_input(run("export", tmp_path / "nope.json", "--format", "csv", "--out", tmp_path / "x.csv"), "nope.json")
    source = tmp_path / "plan.json"
    source.write_text(planned.to_json())
    assert_bad_input(run("export", source, "--format", "yaml", "--out", tmp_path / "x"), "--format", "yaml")


RUN = "the plan cannot be run"


def _jump(data):
    """Joint 0 jumps 3 rad between two slide waypoints."""
    middle = len(data["trajectory"]) // 2
    for waypoint in data["trajectory"][middle:] + [data["goal_config"], data["grasp"]["config"], *data["grasp"]["approach"]]:
        waypoint[0] += 3.0


@pytest.mark.parametrize("mutate, fragments", [
    (_jump, [RUN, "trajectory", "a joint moves 3."]),
    (lambda data: data["timing"]["trajectory"]["velocities"][1].__setitem__(0, 1e6), [RUN, "timing.trajectory", "velocity limit"]),
    (lambda data: data["grasp"]["approach"][1].__setitem__(2, 1e3), [RUN, "grasp.approach", "outside its limits"]),
    (lambda data: data["grasp"]["approach"][1].__setitem__(2, 1e308), ["grasp.approach[1][2]", "beyond 1e+09"]),
    # A link or joint the robot does not have (view: a traceback from its URDF loader, export: exit 0).
    (lambda data: data["robot"].update(grasp_link="nosuch"), [RUN, "robot.grasp_link", "'nosuch' is not a link"]),
    (lambda data: data["robot"].update(contact_links=["nosuch"]), [RUN, "robot.contact_links", "'nosuch' is not a link"]),
    (lambda data: data["joint_names"].reverse(), [RUN, "joint_names", "are not the chain's joints"]),
])
@pytest.mark.parametrize("command", [["export", "--format", "ros-json", "--out", "out.json"], ["execute"],
                                     ["view", "--record", "out.html"]])
def test_a_plan_whose_motion_cannot_be_run_is_refused_by_every_command_that_runs_it(planned, tmp_path, mutate,
                                                                                   fragments, command):
    # Once exported with exit 0 (and executed: "Nan, Inf or huge value in CTRL").
    data = planned.to_dict()
    mutate(data)
    source = tmp_path / "plan.json"
    source.write_text(json.dumps(data))
    outputs = [tmp_path / name for name in command if name.startswith("out.")]
    command = [str(tmp_path / name) if name.startswith("out.") else name for name in command]
    assert_bad_input(run(command[0], source, *command[1:]), str(source), *fragments)
    assert not any(path.exists() for path in outputs)


def test_export_warns_on_one_line_about_defaulted_urdf_limits(planned, tmp_path):
    urdf = tmp_path / "robot.urdf"
    urdf.write_text(open(planned.robot["urdf"]).read().replace('effort="60" velocity="2.0"', 'effort="60" velocity="-2"', 1))
    data = {**planned.to_dict(), "schema": "slideplan.plan/1", "robot": {**planned.to_dict()["robot"], "urdf": str(urdf)}}
    del data["timing"]
    source, out = tmp_path / "old.json", tmp_path / "old.csv"
    source.write_text(json.dumps(data))
    result = run("export", source, "--format", "csv", "--out", out)
    assert result.exit_code == 0, result.stderr
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("slideplan: warning: ") and "wam_j1 (-2)" in lines[0], result.stderr
    assert f"{DEFAULT_JOINT_VELOCITY} rad/s" in lines[0]


def test_plan_takes_timing_options():
    scene = load_scene("square")
    obj = load_object("L", table_height=scene.table.height, pose=(0.6, 0.0, 0.5))
    result = plan(scene, obj, PlannerConfig(seed=1, time_limit_s=20), timing=TimingOptions(fingertip_speed=0.02))
    assert result.solved and result.timing["limits"]["fingertip_speed"] == 0.02
    tips = fingertip_positions(result, result.trajectory)
    check_segment(result.trajectory, result.timing["trajectory"], URDF_VELOCITY, DEFAULT_JOINT_ACCELERATION,
                  tips, np.ones(len(tips), bool), 0.02)


@pytest.fixture(scope="module")
def table_plans():
    """One solved plan per table of Fig. 10 (full scale), with the hand's parameters."""
    from slideplan.experiments.tasks import build_spec

    plans = {}
    for task in build_spec("fig10", poses=2).tasks:
        if task.scale == 1.0 and task.scene not in plans:
            result = plan(load_scene(task.scene), task.placed_object(), task.planner_config())
            if result.solved:
                plans[task.scene] = result
    assert set(plans) == {"square", "round", "long", "triangle"}
    return list(plans.values())


def test_the_cxx_profile_matches_toppra_within_two_percent(table_plans):
    # The C++ TOPP-RA against the Python toppra it replaced (toppra_reference.py): same limits, same grid, durations
    # within 2% (they agree to about 1e-4 on the Fig. 10 plans: benchmarks/timing_bench.py).
    import toppra_reference  # tests/python; toppra is in the test extra
    from slideplan.plan.timing import resolve_limits

    for result in table_plans:
        limits = resolve_limits(result)
        approach = np.asarray(result.grasp["approach"])
        tips = fingertip_positions(result, approach)
        object_top = result.table["height"] + result.object["thickness"]
        reference = {
            "trajectory": toppra_reference.time_path(np.asarray(result.trajectory), np.asarray(result.fingertip_poses)[:, :3],
                                                     np.ones(len(result.trajectory), bool), limits, "trajectory"),
            "approach": toppra_reference.time_path(approach, tips, tips[:, 2] < object_top + NEAR_TABLE_M, limits, "approach"),
        }
        for segment in ("trajectory", "approach"):
            ours, theirs = result.timing[segment]["time_from_start"][-1], reference[segment]["time_from_start"][-1]
            assert ours == pytest.approx(theirs, rel=0.02), (result.table, segment)


def test_plan_times_in_the_planner_call_as_parameterize_does(table_plans):
    # plan() times a solved plan inside the C++ call; parameterize() re-times a plan: the same profile.
    for result in table_plans:
        again = parameterize(result)
        for segment in ("trajectory", "approach"):
            for key in ("time_from_start", "velocities", "accelerations"):
                np.testing.assert_array_equal(result.timing[segment][key], again[segment][key])


def test_timed_plans_of_every_table_respect_every_limit(table_plans):
    for result in table_plans:
        limits = result.timing["limits"]
        tips = fingertip_positions(result, result.trajectory)
        check_segment(result.trajectory, result.timing["trajectory"], limits["joint_velocity"], limits["joint_acceleration"],
                      tips, np.ones(len(tips), bool), limits["fingertip_speed"])
        approach = np.asarray(result.grasp["approach"])
        approach_tips = fingertip_positions(result, approach)
        capped = approach_tips[:, 2] < result.table["height"] + result.object["thickness"] + NEAR_TABLE_M
        check_segment(approach, result.timing["approach"], limits["joint_velocity"], limits["joint_acceleration"],
                      approach_tips, capped, limits["fingertip_speed"])


def test_slideplan_plan_loads_no_plotting_physics_scipy_or_toppra(tmp_path):
    # The CLI and a ROS node pay every import on every start: planning, verifying and writing a plan need
    # none of these (scipy.spatial alone cost 0.4 s a call; pydantic comes with typer 0.29).
    code = ("import sys; from slideplan.cli import app; "
            "app(['plan', '--scene', 'square', '--object', 'crescent', '--pose', '0.55', '-0.08', '0.4', "
            f"'--json', {str(tmp_path / 'p.json')!r}], standalone_mode=False); "
            "print(sorted({m.split('.')[0] for m in sys.modules} & "
            "{'toppra', 'matplotlib', 'mujoco', 'pandas', 'viser', 'scipy', 'pydantic'}))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout
    assert json.loads((tmp_path / "p.json").read_text())["status"] == "solved"
    assert out.strip().splitlines()[-1] == "[]"
