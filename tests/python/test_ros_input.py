"""What the planning node and the simulator take from outside: every bad message is ignored with a reason
on /slideplan/status and the node goes on, bad parameters and options are refused where they arrive,
old clouds and joint states are not planned on, and the discovery range is said at start (an
adversarial battery). The node's callbacks are called in this process, without DDS round trips."""

from __future__ import annotations

import json
import math
import subprocess
import sys
import time

import numpy as np
import pytest

rclpy = pytest.importorskip("rclpy", reason="the ros extra is not installed (pip install 'slideplan[ros]')")

from builtin_interfaces.msg import Time  # noqa: E402
from rclpy.parameter import Parameter  # noqa: E402
from rclpy.time import Time as RosTime  # noqa: E402
from sensor_msgs.msg import JointState  # noqa: E402
from std_msgs.msg import Header  # noqa: E402
from slideplan.ros.guards import discovery_notice  # noqa: E402
from slideplan.ros.messages import cloud_message  # noqa: E402
from slideplan.ros.serve import PlanningNode  # noqa: E402
from slideplan.ros.task import Refused  # noqa: E402
from slideplan.world.scenes import load_scene  # noqa: E402
from test_ros import _DOMAINS, _environment  # noqa: E402


class _Statuses:
    """Stands in for the node's /slideplan/status publisher: keeps each line, parsed."""

    def __init__(self) -> None:
        self.lines: list[dict] = []

    def publish(self, message) -> None:
        assert "\n" not in message.data
        self.lines.append(json.loads(message.data))


@pytest.fixture(scope="module")
def planning():
    """A planning node of the square scene on the simulator's clock (set by the tests), in a context and
    ROS domain of its own, never spun: the tests call its callbacks."""
    context = rclpy.Context()
    rclpy.init(context=context, domain_id=next(_DOMAINS))
    node = PlanningNode(load_scene("square"), {"use_sim_time": True}, context=context)
    node.status = _Statuses()
    yield node
    node.node.destroy_node()
    rclpy.shutdown(context=context)


def _at(planning: PlanningNode, seconds: float) -> None:
    """Set the node's (simulated) clock, as a /clock message would."""
    planning.node.get_clock().set_ros_time_override(RosTime(seconds=seconds, clock_type=planning.node.get_clock().clock_type))


def _joints(planning: PlanningNode, positions=None, **fields) -> JointState:
    """A JointState naming the arm's joints, ``positions`` (default all 0) and other ``fields``."""
    positions = [0.0] * len(planning.robot_joints) if positions is None else positions
    return JointState(name=planning.robot_joints, position=positions, **fields)


def _cloud(**layout):
    """A good 2 x 3 cloud, then its ``layout`` fields (row_step, point_step, ...) set as given."""
    message = cloud_message(np.ones((2, 3, 3)), Header(frame_id="slideplan_camera"))
    for name, value in layout.items():
        setattr(message, name, value)
    return message


def _last_ignored(planning: PlanningNode) -> dict:
    """The node's last status line, which must say a message was ignored."""
    line = planning.status.lines[-1]
    assert line["phase"] == "ignored", line
    return line


def test_a_malformed_message_is_ignored_with_a_reason_and_the_node_goes_on(planning):
    _at(planning, 1.0)
    planning._on_joints(_joints(planning))
    planning._on_cloud(_cloud())
    kept_joints, kept_cloud = planning.joints(), planning.latest_points()

    planning._on_joints(_joints(planning, [0.0]))  # every joint named, one position
    assert _last_ignored(planning)["topic"] == "/joint_states"
    assert "1 positions for 7 names" in _last_ignored(planning)["reason"]
    planning._on_joints(_joints(planning, velocity=[0.0, 1.0]))
    assert "2 velocities for 7 names" in _last_ignored(planning)["reason"]
    for layout, problem in (({"row_step": 12}, "row_step 12 is less than width 3 x point_step 12"),
                            ({"row_step": 0}, "row_step 0 is less than"),
                            ({"point_step": 0}, "does not fit in the point_step of 0 bytes"),
                            ({"height": 70000, "width": 70000, "row_step": 840000}, "bytes do not hold")):
        planning._on_cloud(_cloud(**layout))
        assert _last_ignored(planning)["topic"] == "/camera/points" and problem in _last_ignored(planning)["reason"], layout
    beyond = _cloud()
    beyond.fields[2].offset = 40  # z beyond the 12-byte point
    planning._on_cloud(beyond)
    assert "field z at offset 40 does not fit in the point_step of 12 bytes" in _last_ignored(planning)["reason"]
    assert planning.joints() is kept_joints and planning.latest_points() is kept_cloud

    planning._on_joints(_joints(planning, [0.1] * 7))  # and the next good messages are taken
    planning._on_cloud(_cloud())
    assert planning.joints()[0][0] == 0.1 and planning.latest_points() is not kept_cloud


def test_nan_or_huge_joint_values_are_refused_on_arrival_naming_the_joint(planning):
    _at(planning, 1.0)
    planning._on_joints(_joints(planning))
    kept = planning.joints()
    for value in (math.nan, 1e308, -math.inf):
        positions = [0.0] * 7
        positions[2] = value
        planning._on_joints(_joints(planning, positions))
        reason = _last_ignored(planning)["reason"]
        assert f"position[2] ({planning.robot_joints[2]})" in reason, reason
    planning._on_joints(_joints(planning, velocity=[0.0, 0.0, 0.0, 0.0, math.nan, 0.0, 0.0]))
    assert f"velocity[4] ({planning.robot_joints[4]})" in _last_ignored(planning)["reason"]
    # Outside the URDF's limits (wam_j1: +-2.6 rad): no arm is there, so no plan starts there.
    planning._on_joints(_joints(planning, [6.0] + [0.0] * 6))
    reason = _last_ignored(planning)["reason"]
    assert f"position[0] ({planning.robot_joints[0]}) is 6 rad, outside its limits [" in reason, reason
    assert planning.joints() is kept


def test_a_burst_of_one_bad_message_is_reported_once_a_second_with_a_count(planning):
    count, started = len(planning.status.lines), time.monotonic()
    for _ in range(100):  # a bad 100 Hz joint state publisher
        planning._on_joints(_joints(planning, [math.nan] * 7))
    reports = planning.status.lines[count:]
    assert 1 <= len(reports) <= 1 + time.monotonic() - started, reports  # the first, then at most one a second
    assert sum(report["count"] for report in reports) <= 100


@pytest.mark.parametrize("name, value, problem", [
    ("time_limit", -1.0, "time_limit must be a number of seconds in (0, 600]"),
    ("time_limit", math.nan, "time_limit must be"),
    ("time_limit", 1e308, "time_limit must be"),
    ("seed", -1, "seed must be"),
    ("target", -1, "target must be"),
    ("camera_pose", [0.0, 1.0], "camera_pose must be 6 numbers"),
    ("camera_pose", [0.0, 0.0, math.nan, 0.0, 0.0, 0.0], "camera_pose must be 6 numbers"),
    ("max_sensor_age", 0.0, "max_sensor_age must be"),
    ("controller", "other_controller", "controller is read at start"),
])
def test_bad_parameters_are_refused_by_the_parameter_service(planning, name, value, problem):
    before = planning.parameter(name)
    result, = planning.node.set_parameters([Parameter(name, value=value)])
    assert not result.successful and problem in result.reason, result.reason
    assert planning.parameter(name) == before


def test_good_parameters_are_still_taken(planning):
    results = planning.node.set_parameters([Parameter("time_limit", value=2.5), Parameter("seed", value=7),
                                            Parameter("camera_pose", value=[0.1, 0.0, 0.6, 3.0, 0.0, 0.0])])
    assert all(result.successful for result in results), results
    assert planning.parameter("seed") == 7


def test_a_plan_on_an_old_cloud_or_joint_state_is_refused_with_its_age(planning):
    planning.node.set_parameters([Parameter("max_sensor_age", value=1.0)])
    _at(planning, 100.0)
    planning._on_cloud(cloud_message(np.full((2, 3, 3), np.nan), Header(stamp=Time(sec=100))))
    planning._on_joints(_joints(planning))
    _at(planning, 100.5)  # both fresh: on to perception, which finds no point in this cloud
    with pytest.raises(Refused, match="no finite points") as refused:
        planning._plan()
    _at(planning, 103.0)  # the camera died
    with pytest.raises(Refused, match=r"the latest cloud on /camera/points came 3.0 s ago \(max_sensor_age 1 s\)") as refused:
        planning._plan()
    assert refused.value.status == "stale"
    planning._on_cloud(cloud_message(np.full((2, 3, 3), np.nan), Header(stamp=Time(sec=103))))
    with pytest.raises(Refused, match=r"the latest message on /joint_states came 3.0 s ago") as refused:
        planning._plan()
    assert refused.value.status == "stale"


def _refused(*arguments: str, lines: int = 1) -> str:
    """The last line on stderr of a `slideplan ros` command that must refuse its input, exit 2, with
    ``lines`` lines in all (a subprocess with a time-out: a command that accepted it would serve until
    stopped)."""
    done = subprocess.run([sys.executable, "-m", "slideplan.cli", "ros", *arguments], env=_environment(next(_DOMAINS)),
                          capture_output=True, text=True, timeout=120)
    assert done.returncode == 2 and done.stderr.count("\n") == lines, done.stderr
    return done.stderr.splitlines()[-1]


@pytest.mark.parametrize("parameter, problem", [
    ("controller:=a b", "parameter controller: 'a b' does not name a topic"),
    ("camera_pose:=foo", "parameter camera_pose: Trying to set parameter 'camera_pose' to 'foo' of type 'STRING'"),
    ("time_limit:=-1.0", "parameter time_limit: must be a number of seconds in (0, 600], got -1.0"),
])
def test_a_bad_parameter_at_start_is_one_line_naming_it(parameter, problem):
    assert problem in _refused("serve", "--ros-args", "-p", parameter)


def test_ros_arguments_rcl_cannot_parse_are_named_without_a_traceback():
    # rcl logs its own line before ours: it writes to stderr from C, during rclpy.init.
    assert _refused("serve", "--ros-args", "-p", "foo", lines=2) == (
        "slideplan: error: failed to initialize rcl: Couldn't parse parameter override rule: '-p foo'")


@pytest.mark.parametrize("options, problem", [
    (["--disturb", "nan", "0", "0", "1"], "--disturb: DX nan is not a finite number"),
    (["--disturb", "0", "0", "0", "-5"], "--disturb: T must be in [0, 600] s, got -5"),
    (["--disturb", "1e300", "0", "0", "0.1"], "--disturb: DX 1e+300 is beyond 1 m"),
    (["--disturb", "0", "0", "7", "0.1"], "--disturb: DYAW 7 is beyond"),
    (["--home", "a,b"], "--home: expected comma-separated numbers (rad), got 'a,b'"),
])
def test_bad_simulator_options_are_one_line_naming_the_option(options, problem):
    assert problem in _refused("sim", "--pose", "0.55", "-0.08", "0.4", *options)


def test_the_discovery_range_is_said_and_an_open_unsecured_one_warned_of():
    open_lines = discovery_notice({}, [])
    assert open_lines[0] == "discovery range SUBNET (ROS_AUTOMATIC_DISCOVERY_RANGE unset: ROS 2's default)"
    assert open_lines[1].startswith("warning: other hosts on the network can find this node") and "docs/ros2.md" in open_lines[1]
    assert discovery_notice({"ROS_AUTOMATIC_DISCOVERY_RANGE": "LOCALHOST"}, []) == ["discovery range LOCALHOST"]
    assert discovery_notice({"ROS_AUTOMATIC_DISCOVERY_RANGE": "OFF"}, []) == ["discovery range OFF"]
    secured = {"ROS_AUTOMATIC_DISCOVERY_RANGE": "SUBNET", "ROS_SECURITY_ENABLE": "true", "ROS_SECURITY_STRATEGY": "Enforce"}
    assert discovery_notice(secured, ["--ros-args", "--enclave", "/slideplan/serve"]) == [
        "discovery range SUBNET", "SROS2 security enforced, enclave /slideplan/serve"]
    permissive = discovery_notice({**secured, "ROS_SECURITY_STRATEGY": "Permissive"}, [])
    assert "ROS_SECURITY_STRATEGY is not Enforce" in permissive[1]
    enclave_only = discovery_notice({"ROS_SECURITY_ENCLAVE_OVERRIDE": "/slideplan"}, [])
    assert "ROS_SECURITY_ENABLE is not true" in enclave_only[1]


def test_a_plan_older_than_max_plan_age_is_made_again_before_it_is_executed(planning, monkeypatch):
    from types import SimpleNamespace

    from std_srvs.srv import Trigger

    from slideplan.ros import serve

    executed, made = [], []

    class Executed:  # stands in for the robot's motions: records which plan was run
        def __init__(self, node, task) -> None:
            executed.append(task.name)

        def run(self) -> dict:
            return {"status": "done"}

    def plan_again():
        made.append(planning.now())
        return SimpleNamespace(name="fresh", planned_at=planning.now())

    monkeypatch.setattr(serve, "Execution", Executed)
    monkeypatch.setattr(planning, "_plan", plan_again)
    planning.node.set_parameters([Parameter("max_plan_age", value=5.0)])
    _at(planning, 200.0)
    planning.task = SimpleNamespace(name="served", planned_at=196.0)  # 4 s old: run as served
    assert planning._execute_service(Trigger.Request(), Trigger.Response()).success
    assert executed == ["served"] and made == []
    _at(planning, 300.0)
    planning.task = SimpleNamespace(name="served", planned_at=294.0)  # 6 s old: the object may have moved
    assert planning._execute_service(Trigger.Request(), Trigger.Response()).success
    assert executed == ["served", "fresh"] and made == [300.0]
    assert {"phase": "replan", "trigger": "old_plan", "age_s": 6.0} in planning.status.lines
    result, = planning.node.set_parameters([Parameter("max_plan_age", value=0.0)])
    assert not result.successful and "must be a number of seconds in (0, 3600]" in result.reason
    assert planning.parameter("max_plan_age") == 5.0


def test_ros_time_standing_still_is_refused_saying_whether_the_joint_states_went_on(planning, monkeypatch):
    """A simulator that stops publishing /clock is noticed within CLOCK_STALL_S of wall time (shortened
    here), and the reason says who stopped: the clock messages alone, or the simulator."""
    from slideplan.ros import serve

    monkeypatch.setattr(serve, "CLOCK_STALL_S", 0.2)
    _at(planning, 7.0)
    planning._on_joints(_joints(planning, header=Header(stamp=Time(sec=9, nanosec=500_000_000))))
    final = np.ones(7)  # far from where the arm is: only the stall can end the wait
    with pytest.raises(Refused, match=r"stood still .* /joint_states went on 2.50 s of simulated time past it") as refused:
        planning.wait_arrived(final, 7.0, 30.0, "slide")
    assert refused.value.status == "slide"
    planning._on_joints(_joints(planning, header=Header(stamp=Time(sec=6))))
    with pytest.raises(Refused, match="stood still .* no newer /joint_states either"):
        planning.wait_arrived(final, 7.0, 30.0, "slide")


@pytest.mark.parametrize("skew_s", [-10.0, 1000.0])
def test_a_camera_whose_clock_is_off_still_brings_the_next_cloud(planning, skew_s):
    # Once: clouds stamped 10 s behind never counted as "next" (the slide failed for no cloud), 1000 s ahead
    # made every later look count as seen already. A cloud's time is its arrival on the node's clock.
    _at(planning, 50.0)
    planning._on_cloud(cloud_message(np.ones((2, 3, 3)), Header(stamp=Time(sec=int(50 + skew_s)))))
    assert planning.newest_cloud() == pytest.approx(50.0)
    _at(planning, 50.2)
    planning._on_cloud(cloud_message(np.ones((2, 3, 3)), Header(stamp=Time(sec=int(50.2 + skew_s)))))
    arrived = planning.next_cloud(after=50.1, timeout=0.0)
    assert arrived is not None and arrived[0] == pytest.approx(50.2)


def test_options_not_given_leave_the_node_s_parameters_to_ros_args(monkeypatch):
    # Once: `ros serve --ros-args -p target:=1` served target 0, the command's own default overriding it.
    from typer.testing import CliRunner

    import slideplan.ros.serve
    from slideplan.cli import app

    given = []
    monkeypatch.setattr(slideplan.ros.serve, "serve", lambda scene, parameters, ros_args, log: given.append((parameters, ros_args)))
    ros_args = ["--ros-args", "-p", "target:=1", "-p", "closed_loop:=false", "-p", "use_sim_time:=true"]
    assert CliRunner().invoke(app, ["ros", "serve", *ros_args]).exit_code == 0
    assert given[-1] == ({}, ros_args)
    assert CliRunner().invoke(app, ["ros", "serve", "--target", "2", "--open-loop", "--sim-time"]).exit_code == 0
    assert given[-1][0] == {"target": 2, "closed_loop": False, "use_sim_time": True}
