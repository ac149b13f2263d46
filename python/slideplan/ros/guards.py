"""What the ROS nodes take from outside, checked where it arrives: joint states, the planning node's
parameters, how old its sensor data is, and who can reach the nodes (docs/ros2.md). A bad message is
ignored with its reason on /slideplan/status; a node never dies of one."""

from __future__ import annotations

import contextlib
import math
import re
import threading
import time
from typing import Callable, Iterator

import numpy as np

from ..errors import InputError

JOINT_BOUND = 1e3  # rad or rad/s: as a scene's lengths and angles, far beyond any arm, far below overflow
MAX_TIME_LIMIT_S = 600.0  # a plan request's limit: `slideplan ros call` waits 600 s by default
MAX_SENSOR_AGE_S = 3600.0
JOINT_LIMIT_SLACK = 0.02  # rad or m past a URDF limit that an encoder may still read (a joint at its stop)
POSE_BOUND = 1e3  # m or rad, as a scene's
REPORT_EVERY_S = 1.0  # a bad publisher's repeats of one reason: one status line a second, with their count
RANGES = ("LOCALHOST", "SUBNET", "SYSTEM_DEFAULT", "OFF")


def joint_state(message, robot_joints: list[str], limits: tuple[np.ndarray, np.ndarray] | None = None
                ) -> tuple[np.ndarray, np.ndarray] | None:
    """The positions and velocities (zero where the message has none) of ``robot_joints`` in a
    ``sensor_msgs/JointState``, or None for a message that does not name them all (another part of the
    robot, e.g. a gripper's own driver).

    Args:
        message: the JointState.
        robot_joints: the arm's joint names, in the order of the result.
        limits: the joints' (lower, upper) positions from the URDF: a position further outside than
            :data:`JOINT_LIMIT_SLACK` is refused (an arm cannot be there: a wrong URDF, or a driver's units).

    Raises:
        InputError: (``/joint_states``) not one position per name, velocities neither absent nor one per
            name, a position or velocity not a finite number within ``JOINT_BOUND``, or a position outside
            its joint's limits, named by its index and joint.
    """
    names = list(message.name)
    if not all(name in names for name in robot_joints):
        return None
    if len(message.position) != len(names):
        raise InputError(f"{len(message.position)} positions for {len(names)} names", field="/joint_states")
    if len(message.velocity) not in (0, len(names)):
        raise InputError(f"{len(message.velocity)} velocities for {len(names)} names (none, or one per name)",
                         field="/joint_states")
    order = [names.index(name) for name in robot_joints]
    positions = np.asarray(message.position, dtype=float)[order]
    velocities = np.asarray(message.velocity, dtype=float)[order] if len(message.velocity) else np.zeros(len(order))
    for what, values in (("position", positions), ("velocity", velocities)):
        outside = np.flatnonzero(~(np.abs(values) <= JOINT_BOUND))
        if len(outside):
            joint = outside[0]
            value = values[joint]
            problem = "not a finite number" if not math.isfinite(value) else f"beyond {JOINT_BOUND:g} in magnitude"
            raise InputError(f"{what}[{order[joint]}] ({robot_joints[joint]}) is {value:g}: {problem}", field="/joint_states")
    if limits is not None:
        lower, upper = (np.asarray(bound, dtype=float) for bound in limits)
        outside = np.flatnonzero((positions < lower - JOINT_LIMIT_SLACK) | (positions > upper + JOINT_LIMIT_SLACK))
        if len(outside):
            joint = outside[0]
            raise InputError(f"position[{order[joint]}] ({robot_joints[joint]}) is {positions[joint]:g} rad, outside its "
                             f"limits [{lower[joint]:g}, {upper[joint]:g}] in the URDF", field="/joint_states")
    return positions, velocities


def parameter_problem(name: str, value, running: bool) -> str | None:
    """What is wrong with a value of one of the planning node's parameters (after the parameter's name
    in a message), or None.

    Args:
        name: the parameter (docs/ros2.md); others are left to rclpy.
        value: its new value, of the declared type (rclpy refuses other types).
        running: the node is serving (False while its parameters are declared): ``controller`` names
            a topic made at start, which a change later would not move.
    """
    if name == "camera_pose":
        pose = np.asarray(value, dtype=float)
        if pose.shape != (6,) or not np.all(np.abs(pose) <= POSE_BOUND):
            return f"must be 6 numbers within {POSE_BOUND:g} (x y z roll pitch yaw, m and rad), got {list(pose)}"
    elif name == "time_limit" and not 0.0 < value <= MAX_TIME_LIMIT_S:
        return f"must be a number of seconds in (0, {MAX_TIME_LIMIT_S:g}], got {value}"
    elif name in ("max_sensor_age", "max_plan_age") and not 0.0 < value <= MAX_SENSOR_AGE_S:
        return f"must be a number of seconds in (0, {MAX_SENSOR_AGE_S:g}], got {value}"
    elif name in ("seed", "target") and value < 0:
        return f"must be an integer >= 0, got {value}"
    elif name == "object" and value:
        from ..world.objects import load_outline

        try:
            load_outline(value)
        except InputError as error:
            return f"must be a built-in object or an outline TOML ({error})"
    elif name == "controller":
        if running:
            return "is read at start: restart the node to follow another controller"
        from rclpy.exceptions import InvalidTopicNameException
        from rclpy.validate_full_topic_name import validate_full_topic_name

        try:
            validate_full_topic_name(f"/{value}/joint_trajectory")
        except InvalidTopicNameException:
            return f"{value!r} does not name a topic (letters, digits, _ and / between names)"
    return None


@contextlib.contextmanager
def rcl_errors() -> Iterator[None]:
    """rcl's errors inside (``rclpy.init`` and making a node: ROS arguments it cannot parse, a security
    set-up it cannot meet) as an InputError: their words without where in rcl's C sources they arose."""
    from rclpy._rclpy_pybind11 import RCLError

    try:
        yield
    except RCLError as error:
        raise InputError(re.split(r"\. Error:|, at /", str(error))[0]) from None


def declare_checked(node, defaults: dict) -> None:
    """Declare a node's parameters (values given at start override ``defaults``) and have each value set
    later checked (:func:`parameter_problem`): the parameter service answers a bad one with
    ``successful=False`` and the reason.

    Args:
        node: the rclpy node.
        defaults: name: default value (its type is the parameter's).

    Raises:
        InputError: (``parameter NAME``) a value given at start of another type, or a bad one.
    """
    from rcl_interfaces.msg import SetParametersResult
    from rclpy.exceptions import ParameterException

    for name, value in defaults.items():
        try:
            problem = parameter_problem(name, node.declare_parameter(name, value).value, running=False)
        except ParameterException as error:  # a value of another type
            problem = error.args[0]
        if problem is not None:
            raise InputError(problem, field=f"parameter {name}")

    def checked(changed):
        problems = [f"{item.name} {problem}" for item in changed
                    if (problem := parameter_problem(item.name, item.value, running=True)) is not None]
        return SetParametersResult(successful=not problems, reason="; ".join(problems))

    node.add_on_set_parameters_callback(checked)


class Ignored:
    """Reports the messages a node ignores, through ``publish(phase, **content)``: the first of a reason
    at once, then, per topic, at most one line every ``REPORT_EVERY_S`` with how many were ignored since
    the last report (``count``), so a bad publisher at 100 Hz cannot flood the status.

    Args:
        publish: the node's status publisher (:meth:`slideplan.ros.serve.PlanningNode.publish_status`).
    """

    def __init__(self, publish: Callable[..., None]) -> None:
        self.publish = publish
        self._last: dict[str, tuple[str, float, int]] = {}  # topic: (reason, when reported, ignored since)
        self._lock = threading.Lock()

    @contextlib.contextmanager
    def guarding(self, topic: str) -> Iterator[None]:
        """Ignore whatever a message on ``topic`` raises inside, with its reason."""
        try:
            yield
        except Exception as error:  # any message, however malformed: the node goes on
            self.report(topic, str(error) if isinstance(error, InputError) else f"{type(error).__name__}: {error}")

    def report(self, topic: str, reason: str) -> None:
        """One message on ``topic`` ignored for ``reason``."""
        now = time.monotonic()
        with self._lock:
            last_reason, reported, count = self._last.get(topic, ("", -math.inf, 0))
            count += 1
            if reason == last_reason and now - reported < REPORT_EVERY_S:
                self._last[topic] = (last_reason, reported, count)
                return
            self._last[topic] = (reason, now, 0)
        self.publish("ignored", topic=topic, reason=" ".join(reason.split()), count=count)


class Arrivals:
    """When the latest message of each topic arrived, on a node's clock (simulated time with
    ``use_sim_time``): the arrival, not the header's stamp, so a camera's clock skew does not count.

    Args:
        clock: the node's time now (s).
    """

    def __init__(self, clock: Callable[[], float]) -> None:
        self.clock = clock
        self._at: dict[str, float] = {}

    def mark(self, topic: str) -> None:
        """A message on ``topic`` arrived now."""
        self._at[topic] = self.clock()

    def too_old(self, limit_s: float, what: dict[str, str]) -> str | None:
        """Why the latest message of one of ``what``'s topics is too old to plan on (over ``limit_s``), or
        None (fresh, or none yet: the planner says so itself).

        Args:
            limit_s: the parameter ``max_sensor_age`` (s).
            what: topic: what its messages are, for the reason (``{"/camera/points": "cloud"}``).
        """
        now = self.clock()
        for topic, noun in what.items():
            age = now - self._at.get(topic, now)
            if age > limit_s:
                return (f"the latest {noun} on {topic} came {age:.1f} s ago (max_sensor_age {limit_s:g} s): "
                        f"is its publisher still running?")
        return None


def discovery_notice(environ, ros_args: list[str]) -> list[str]:
    """Lines a node prints at start: its DDS discovery range and, where other hosts can find it without
    SROS2 security, a warning (anyone there could call /slideplan/execute or set parameters).

    Args:
        environ: the environment (``ROS_AUTOMATIC_DISCOVERY_RANGE``, ``ROS_SECURITY_ENABLE``,
            ``ROS_SECURITY_STRATEGY``, ``ROS_SECURITY_ENCLAVE_OVERRIDE``).
        ros_args: the node's ``--ros-args ...`` (an ``--enclave``/``-e`` there).
    """
    value = environ.get("ROS_AUTOMATIC_DISCOVERY_RANGE", "")
    if not value:
        lines, reach = ["discovery range SUBNET (ROS_AUTOMATIC_DISCOVERY_RANGE unset: ROS 2's default)"], "SUBNET"
    elif value in RANGES:
        lines, reach = [f"discovery range {value}"], value
    else:
        lines, reach = [f"discovery range {value!r}: not one of {', '.join(RANGES)}"], value
    if reach in ("LOCALHOST", "OFF"):
        return lines
    enclave = environ.get("ROS_SECURITY_ENCLAVE_OVERRIDE", "")
    for flag, following in zip(ros_args, ros_args[1:]):
        if flag in ("--enclave", "-e"):
            enclave = following
    enabled = environ.get("ROS_SECURITY_ENABLE", "") == "true"
    if enabled and environ.get("ROS_SECURITY_STRATEGY", "") == "Enforce":
        return [*lines, f"SROS2 security enforced, enclave {enclave or '/'}"]
    if enabled:  # Permissive: a node without keys for its enclave runs unsecured
        unsecured = "ROS_SECURITY_STRATEGY is not Enforce"
    else:
        unsecured = "an enclave is set, but ROS_SECURITY_ENABLE is not true" if enclave else "no SROS2 security"
    return [*lines, f"warning: other hosts on the network can find this node and call its services ({unsecured}): "
                    "on one machine set ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST, across machines enable SROS2 "
                    "(docs/ros2.md, 'Who can reach the nodes')"]
