"""``slideplan ros serve``: the planning node ``slideplan`` (docs/ros2.md).

``/slideplan/plan`` perceives the latest ``/camera/points`` cloud (:func:`slideplan.perception.tabletop.perceive`,
the robot from the node's scene), plans the slide for the object ``target`` and a reach to its first
contact from the arm's current joint state, verifies the plan and publishes its markers.
``/slideplan/execute`` plans if there is no plan yet, then drives the robot: opens the hand, publishes
the reach, the slide and the approach on ``/<controller>/joint_trajectory`` (each when the last has
arrived), closes the hand through ``/gripper/set`` and lifts. With ``closed_loop`` it watches the object
in the clouds while sliding and re-plans as ``slideplan run`` does (:class:`slideplan.loop.decisions.SlideLoop`,
:class:`slideplan.loop.watch.Watch`).

Every response's ``message`` is one line of JSON: ``status`` (``solved``, ``done`` or what failed) and
the numbers, or the ``reason`` it failed.
"""

from __future__ import annotations

import math
import os
import threading
import time

import numpy as np

from ..errors import InputError
from ..plan.robot import robot_model
from ..plan.result import PlanResult
from ..world.scenes import Scene
from .guards import Arrivals, Ignored, declare_checked, discovery_notice, joint_state, rcl_errors
from .execution import Execution
from .task import Refused, Task, one_line, plan_task

# A trajectory has arrived when the arm is still (every joint slower than STILL_RAD_S) after its duration,
# every joint within GOAL_TOLERANCE_RAD of its last point: a servo pressing the finger on the object holds
# a hundredth of a radian or two off it (the simulator's servos have no integral action); more is a block.
STILL_RAD_S = 0.05
GOAL_TOLERANCE_RAD = 0.05
# With use_sim_time, ROS time that stands still this long (wall s) during a motion ends it: no /clock, or a
# simulator stopped. 15 s, not less: a simulator sharing two loaded cores can pause for seconds (once, 5 s
# in CI, at a slide's start; not reproduced in nine runs, two of the cores kept busy besides).
CLOCK_STALL_S = 15.0
# The node's ROS parameters (docs/ros2.md). max_sensor_age: ten frames of the simulator's 5 Hz camera, so
# a few lost clouds do not refuse a plan, while a camera or arm driver that died is noticed within 2 s.
# max_plan_age: a plan served by /slideplan/plan longer ago than this is made again before it is executed
# (the object, the arm or the camera may have moved since); 10 s is a call to plan and one to execute.
DEFAULTS = {"camera_pose": [0.0] * 6, "target": 0, "controller": "joint_trajectory_controller", "closed_loop": True,
            "time_limit": 5.0, "seed": 0, "max_sensor_age": 2.0, "max_plan_age": 10.0, "object": ""}
SENSORS = {"/camera/points": "cloud", "/joint_states": "message"}  # what max_sensor_age applies to


class PlanningNode:
    """The node ``slideplan`` (module docstring); build it after ``rclpy.init()``.

    Args:
        scene: the robot's scene (URDF, mount, hand); the table and objects come from the clouds.
        parameters: initial values of the ROS parameters (``DEFAULTS``'s names and ``use_sim_time``).
        context: the rclpy context to make the node in (default: the global one).

    Raises:
        InputError: (``parameter NAME``) a parameter of the wrong type or a bad value
            (:func:`slideplan.ros.guards.parameter_problem`).
    """

    def __init__(self, scene: Scene, parameters: dict | None = None, context=None) -> None:
        from rclpy.callback_groups import MutuallyExclusiveCallbackGroup, ReentrantCallbackGroup
        from rclpy.node import Node
        from rclpy.parameter import Parameter
        from rclpy.qos import qos_profile_sensor_data
        from sensor_msgs.msg import JointState, PointCloud2
        from std_msgs.msg import String
        from std_srvs.srv import SetBool, Trigger
        from trajectory_msgs.msg import JointTrajectory
        from visualization_msgs.msg import MarkerArray

        # What the first request needs, loaded now (a cold import of scikit-learn alone takes seconds).
        import scipy.ndimage  # noqa: F401
        import sklearn.linear_model  # noqa: F401

        self.scene = scene
        robot = robot_model(scene)
        self.robot_joints = list(robot.joint_names)
        self.joint_limits = (np.asarray(robot.lower_limits), np.asarray(robot.upper_limits))
        overrides = [Parameter(name, value=value) for name, value in (parameters or {}).items()]
        self.node = node = Node("slideplan", context=context, parameter_overrides=overrides)
        try:
            declare_checked(node, DEFAULTS)
        except InputError:
            node.destroy_node()
            raise
        self.ignored = Ignored(self.publish_status)
        self.arrivals = Arrivals(self.now)
        self._lock = threading.Lock()
        self._cloud = None  # (stamp s, (h, w, 3) camera-frame points)
        self._joints = None  # (positions in robot_joints order, velocities)
        self._joints_stamped = -math.inf  # the newest joint state's header stamp (s): says who stopped when ROS time stops
        self._cloud_arrived = threading.Condition()
        self.task: Task | None = None
        self._plane = None  # (camera_pose, the table plane seen from there): the table does not move
        sensors = ReentrantCallbackGroup()
        self._services = MutuallyExclusiveCallbackGroup()  # one request at a time
        node.create_subscription(PointCloud2, "/camera/points", self._on_cloud, qos_profile_sensor_data, callback_group=sensors)
        node.create_subscription(JointState, "/joint_states", self._on_joints, 10, callback_group=sensors)
        self.markers = node.create_publisher(MarkerArray, "/slideplan/markers", 1)
        self.status = node.create_publisher(String, "/slideplan/status", 10)
        self.trajectory = node.create_publisher(JointTrajectory, f"/{self.parameter('controller')}/joint_trajectory", 10)
        self.gripper = node.create_client(SetBool, "/gripper/set", callback_group=sensors)
        node.create_service(Trigger, "/slideplan/plan", self._plan_service, callback_group=self._services)
        node.create_service(Trigger, "/slideplan/execute", self._execute_service, callback_group=self._services)

    def now(self) -> float:
        """ROS time (s): the simulator's /clock with use_sim_time, else the system clock."""
        return self.node.get_clock().now().nanoseconds * 1e-9

    def parameter(self, name: str):
        return self.node.get_parameter(name).value

    # --------------------------------------------------------------- sensors

    def _on_cloud(self, message) -> None:
        from .messages import cloud_points

        with self.ignored.guarding("/camera/points"):
            points = cloud_points(message)
            with self._cloud_arrived:
                # Its arrival on the node's clock, not its header stamp: a camera whose clock is off by seconds
                # would otherwise never bring a "next" cloud, or have every look skipped (docs/ros2.md).
                self._cloud = (self.now(), points)
                self.arrivals.mark("/camera/points")
                self._cloud_arrived.notify_all()

    def _on_joints(self, message) -> None:
        with self.ignored.guarding("/joint_states"):
            state = joint_state(message, self.robot_joints, self.joint_limits)
            if state is not None:
                with self._lock:
                    self._joints = state
                    self._joints_stamped = message.header.stamp.sec + 1e-9 * message.header.stamp.nanosec
                    self.arrivals.mark("/joint_states")

    def joints(self) -> tuple[np.ndarray, np.ndarray] | None:
        with self._lock:
            return self._joints

    def newest_cloud(self) -> float:
        """When the latest cloud arrived (the node's ROS time, s), -inf before any."""
        cloud = self._cloud
        return -math.inf if cloud is None else cloud[0]

    def latest_points(self) -> np.ndarray:
        return self._cloud[1]

    def next_cloud(self, after: float, timeout: float = 2.0) -> tuple[float, np.ndarray] | None:
        """The first cloud that arrived after ``after`` (the node's ROS time, s) as (arrival, points), waiting up
        to ``timeout`` wall s; None if none came."""
        with self._cloud_arrived:
            self._cloud_arrived.wait_for(lambda: self._cloud is not None and self._cloud[0] > after, timeout)
            return self._cloud if self._cloud is not None and self._cloud[0] > after else None

    # --------------------------------------------------------------- services

    def publish_status(self, phase: str, **content) -> None:
        from std_msgs.msg import String

        line = one_line({"phase": phase, **content})
        self.status.publish(String(data=line))
        self.node.get_logger().info(line)

    def _plan(self) -> Task:
        cloud = self._cloud
        if cloud is None:
            raise Refused("no_cloud", "no cloud received on /camera/points yet")
        joints = self.joints()
        self.publish_status("plan")
        stale = self.arrivals.too_old(float(self.parameter("max_sensor_age")), SENSORS)
        if stale is not None:
            raise Refused("stale", stale)
        camera_pose = list(self.parameter("camera_pose"))
        known = self._plane[1] if self._plane is not None and self._plane[0] == camera_pose else None
        task = plan_task(self.scene, cloud[1], None if joints is None else joints[0], camera_pose=camera_pose,
                         target=int(self.parameter("target")), seed=int(self.parameter("seed")),
                         time_limit=float(self.parameter("time_limit")), table_plane=known,
                         object_name=str(self.parameter("object")))
        self._plane = (camera_pose, task.table_plane)
        task.planned_at = self.now()
        self._publish_markers(task.result)
        self.publish_status("planned", **task.summary)
        return task

    def _fresh(self, task: Task) -> bool:
        """Whether a served plan may still be executed: made at most ``max_plan_age`` ago (ROS time); an
        older one is said on /slideplan/status and made again from the latest cloud."""
        age = self.now() - task.planned_at
        if age <= float(self.parameter("max_plan_age")):
            return True
        self.publish_status("replan", trigger="old_plan", age_s=round(age, 3))
        return False

    def _publish_markers(self, result: PlanResult) -> None:
        from std_msgs.msg import Header

        from .messages import WORLD_FRAME, plan_markers

        self.markers.publish(plan_markers(result, Header(stamp=self.node.get_clock().now().to_msg(), frame_id=WORLD_FRAME)))

    def _plan_service(self, request, response):
        try:
            self.task = self._plan()
            response.success, response.message = True, one_line(self.task.summary)
        except Refused as error:
            self.task = None
            response.success, response.message = False, one_line({"status": error.status, "reason": str(error)})
            self.publish_status("failed", status=error.status, reason=str(error))
        except Exception as error:  # the node keeps serving whatever one request did
            self.task = None
            response.success, response.message = False, one_line({"status": "error", "reason": f"{type(error).__name__}: {error}"})
            self.node.get_logger().error(f"/slideplan/plan: {type(error).__name__}: {error}")
        return response

    def _execute_service(self, request, response):
        try:
            task = self.task if self.task is not None and self._fresh(self.task) else self._plan()
            self.task = None  # a plan is executed once: the object has moved
            summary = Execution(self, task).run()
            response.success, response.message = True, one_line(summary)
            self.publish_status("done", **summary)
        except Refused as error:
            response.success, response.message = False, one_line({"status": error.status, "reason": str(error)})
            self.publish_status("failed", status=error.status, reason=str(error))
        except Exception as error:
            response.success, response.message = False, one_line({"status": "error", "reason": f"{type(error).__name__}: {error}"})
            self.node.get_logger().error(f"/slideplan/execute: {type(error).__name__}: {error}")
        return response

    # --------------------------------------------------------------- driving the robot

    def send(self, joint_names: list[str], path: np.ndarray, timing: dict, phase: str, delay: float = 0.0) -> float:
        """Publish a timed path (``timing``: ``time_from_start`` and ``velocities``, as a plan's timing
        block), its first point ``delay`` s after arrival; return its start (ROS time, s)."""
        from std_msgs.msg import Header

        from .messages import trajectory_message

        times = np.asarray(timing["time_from_start"], dtype=float)
        times = times - times[0] + delay
        message = trajectory_message(joint_names, path, times, Header(), timing.get("velocities"))  # stamp 0: start on arrival
        self.publish_status(phase, duration_s=round(float(times[-1]), 3), points=len(path))
        self.trajectory.publish(message)
        return self.now()

    def move(self, joint_names: list[str], path: np.ndarray, timing: dict, phase: str, delay: float = 0.0) -> None:
        """:meth:`send`, then :meth:`wait_arrived`."""
        duration = float(timing["time_from_start"][-1] - timing["time_from_start"][0]) + delay
        self.wait_arrived(path[-1], self.send(joint_names, path, timing, phase, delay), duration, phase)

    def wait_arrived(self, final: np.ndarray, started: float, duration_s: float, phase: str, during=None) -> None:
        """Wait until the arm is at ``final`` and still (``during(elapsed)`` called every 10 ms meanwhile;
        it may return True to stop waiting).

        Raises:
            Refused: (``phase``) not there within twice the duration plus 10 s, or ROS time stopped for
            CLOCK_STALL_S (a simulator's /clock, with use_sim_time).
        """
        deadline = started + 2.0 * duration_s + 10.0
        ticked, ticked_at = self.now(), time.monotonic()
        while self.now() < deadline:
            if self.now() != ticked:
                ticked, ticked_at = self.now(), time.monotonic()
            elif time.monotonic() - ticked_at > CLOCK_STALL_S:
                raise Refused(phase, f"ROS time stood still for {CLOCK_STALL_S:.0f} s during the {phase} (use_sim_time "
                                     f"is set: is the simulator publishing /clock?); {self._joint_stamps_since(ticked)}")
            elapsed = self.now() - started
            if during is not None and during(elapsed):
                return
            joints = self.joints()
            if joints is not None and elapsed >= duration_s and np.abs(joints[1]).max() < STILL_RAD_S:
                error = float(np.abs(joints[0] - final).max())
                if error > GOAL_TOLERANCE_RAD:
                    raise Refused(phase, f"the arm stopped {error:.3f} rad from the end of the {phase} "
                                         f"(tolerance {GOAL_TOLERANCE_RAD} rad): blocked?")
                return
            time.sleep(0.01)
        error = "no joint state" if self.joints() is None else f"{np.abs(self.joints()[0] - final).max():.3f} rad off"
        raise Refused(phase, f"the arm did not come to rest at the end of the {phase} within {deadline - started:.0f} s ({error})")

    def _joint_stamps_since(self, ticked: float) -> str:
        """Whether the joint states went on meanwhile: if so, the clock messages stopped reaching this
        node; if not, the simulator stopped publishing altogether."""
        ahead = self._joints_stamped - ticked
        return (f"/joint_states went on {ahead:.2f} s of simulated time past it" if ahead > 0
                else "no newer /joint_states either")

    def set_gripper(self, closed: bool) -> None:
        from std_srvs.srv import SetBool

        what = "close" if closed else "open"
        if not self.gripper.wait_for_service(timeout_sec=2.0):
            raise Refused("gripper", f"no /gripper/set service to {what} the hand")
        done = threading.Event()
        future = self.gripper.call_async(SetBool.Request(data=closed))
        future.add_done_callback(lambda _: done.set())
        if not done.wait(15.0) or not future.result().success:
            reason = "no answer" if not done.is_set() else future.result().message
            raise Refused("gripper", f"/gripper/set could not {what} the hand ({reason})")


def serve(scene: Scene, parameters: dict | None = None, *, ros_args: list[str] = (), log=print) -> None:
    """Run the node ``slideplan`` until interrupted (``ros_args``: ``--ros-args ...`` remappings and
    parameters, as any ROS 2 node takes); say its discovery range first (a warning where other hosts can
    reach it unsecured: :func:`slideplan.ros.guards.discovery_notice`).

    Args:
        scene: the robot's scene (:class:`PlanningNode`).
        parameters: initial values of the ROS parameters (:class:`PlanningNode`).
        ros_args: ``--ros-args ...`` as the command line gave them.
        log: prints a line.

    Raises:
        InputError: a bad parameter (:class:`PlanningNode`), ROS arguments rcl cannot parse, or a
            security set-up it cannot meet.
    """
    import rclpy
    from rclpy.executors import ExternalShutdownException, MultiThreadedExecutor

    with rcl_errors():
        rclpy.init(args=["slideplan", *ros_args])
    try:
        with rcl_errors():
            planning = PlanningNode(scene, parameters)
    except InputError:
        rclpy.shutdown()
        raise
    executor = MultiThreadedExecutor(num_threads=4)
    executor.add_node(planning.node)
    for line in discovery_notice(os.environ, list(ros_args)):
        log(f"slideplan: {line}")
    log(f"slideplan: serving /slideplan/plan and /slideplan/execute for {scene.name} "
        f"({len(planning.robot_joints)} joints)")
    try:
        while rclpy.ok():
            executor.spin_once(timeout_sec=0.1)
    except (KeyboardInterrupt, ExternalShutdownException):
        pass
    except Exception:
        if rclpy.ok():  # Ctrl-C shuts the context down under the spinning executor: no error then
            raise
    finally:
        executor.shutdown()
        planning.node.destroy_node()
        if rclpy.ok():
            rclpy.shutdown()
