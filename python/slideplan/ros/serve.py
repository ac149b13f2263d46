"""``slideplan ros serve``: the planning node ``slideplan`` (docs/ros2.md).

``/slideplan/plan`` perceives the latest ``/camera/points`` cloud (:func:`slideplan.perception.perceive`,
the robot from the node's scene), plans the slide for the object ``target`` and a reach to its first
contact from the arm's current joint state, verifies the plan and publishes its markers.
``/slideplan/execute`` plans if there is no plan yet, then drives the robot: opens the hand, publishes
the reach, the slide and the approach on ``/<controller>/joint_trajectory`` (each when the last has
arrived), closes the hand through ``/gripper/set`` and lifts. With ``closed_loop`` it watches the object
in the clouds while sliding and re-plans as ``slideplan run`` does (:class:`slideplan.closed_loop.Watch`).

Every response's ``message`` is one line of JSON: ``status`` (``solved``, ``done`` or what failed) and
the numbers, or the ``reason`` it failed.
"""

from __future__ import annotations

import math
import os
import threading
import time
from dataclasses import dataclass, field
from typing import Callable

import numpy as np

from .. import jsontext
from ..closed_loop import SlideLoop, Stop, Watch
from ..errors import InputError
from ..execute.reach import Unreachable, reach_path
from ..execute.runner import reference, straight_up
from ..objects import ThinObject
from ..plan.config import PlannerConfig
from ..plan.robot import base_pose_matrix, robot_model
from ..plan.result import PlanResult
from ..rendering import Camera
from ..scenes import Scene
from ..timing import time_path
from .guards import Arrivals, Ignored, declare_checked, discovery_notice, joint_state, rcl_errors

# A trajectory has arrived when the arm is still (every joint slower than STILL_RAD_S) after its duration,
# every joint within GOAL_TOLERANCE_RAD of its last point: a servo pressing the finger on the object holds
# a hundredth of a radian or two off it (the simulator's servos have no integral action); more is a block.
STILL_RAD_S = 0.05
GOAL_TOLERANCE_RAD = 0.05
LIFT_M = 0.05
# The closed loop, as slideplan run's defaults: a drift is 3 mm / 2 deg off the prediction; each re-plan has 1 s.
THRESHOLD = (0.003, math.radians(2.0))
REPLAN_TIME_LIMIT_S = 1.0
END_REPLANS = 3
CLOCK_STALL_S = 5.0
CLOUD_WAIT_S = 10.0  # wall time: a simulator may run well below real time while the finger slides
MIN_CHECK_POINTS = 30  # cloud points over the object's footprint that can tell whether it is there
LOOKAHEAD_S = 0.15  # a re-plan starts where the arm will be this much later (grown to 1.5 x the slowest re-plan)
# The node's ROS parameters (docs/ros2.md). max_sensor_age: ten frames of the simulator's 5 Hz camera, so
# a few lost clouds do not refuse a plan, while a camera or arm driver that died is noticed within 2 s.
DEFAULTS = {"camera_pose": [0.0] * 6, "target": 0, "controller": "joint_trajectory_controller", "closed_loop": True,
            "time_limit": 5.0, "seed": 0, "max_sensor_age": 2.0}
SENSORS = {"/camera/points": "cloud", "/joint_states": "message"}  # what max_sensor_age applies to


class Refused(Exception):
    """A request that cannot be served: ``status`` names what failed, the message says why."""

    def __init__(self, status: str, reason: str) -> None:
        super().__init__(reason)
        self.status = status


def cloud_in_world(points: np.ndarray, camera_pose) -> np.ndarray:
    """The finite points of a cloud (any shape ending in 3) moved from the camera's frame into the world
    by ``camera_pose`` (x y z roll pitch yaw)."""
    pose = base_pose_matrix(camera_pose)
    flat = np.asarray(points, dtype=float).reshape(-1, 3)
    flat = flat[np.isfinite(flat).all(axis=1)]
    return flat @ pose[:3, :3].T + pose[:3, 3]


def perceived_task(scene: Scene, world_points: np.ndarray, target: int, seed: int,
                   table_plane=None) -> tuple[Scene, ThinObject, int, tuple, float]:
    """The perceived scene (its table and clutter, the robot from ``scene``), the object ``target``, how
    many objects were seen, the table plane (``table_plane``: the plane of an earlier cloud of the
    same camera, :func:`slideplan.perception.perceive`'s) and how far the perceived edges may be off (m).

    Raises:
        Refused: an empty cloud (``no_cloud``), nothing perceived (``perception``), or a target that is
            not one of the objects seen (``target``).
    """
    from ..perception import perceive

    if len(world_points) == 0:
        raise Refused("no_cloud", "the latest cloud on /camera/points has no finite points")
    try:
        perception = perceive(world_points, seed=seed, table_plane=table_plane, source="/camera/points")
    except InputError as error:
        raise Refused("perception", error.problem) from None
    if not perception.objects:
        raise Refused("perception", "no thin object on the table in the latest cloud")
    if not 0 <= target < len(perception.objects):
        raise Refused("target", f"target {target} is not one of the {len(perception.objects)} objects seen (0 to "
                                f"{len(perception.objects) - 1}, largest first)")
    seen = perception.objects[target]
    obj = ThinObject.from_points(seen.points, table_height=perception.table.height, name=f"object {target}")
    return perception.scene(scene), obj, len(perception.objects), perception.plane, perception.edge_uncertainty


def lift_path(result: PlanResult) -> np.ndarray:
    """From the grasp straight up LIFT_M, a centimetre at a time (:func:`slideplan.execute.runner.straight_up`).

    Raises:
        Refused: (``lift``) no IK for the lifted grasp.
    """
    lifted = straight_up(result.robot_model(), np.asarray(result.grasp["config"], dtype=float), LIFT_M)
    if lifted is None:
        raise Refused("lift", f"no inverse kinematics for the {100 * LIFT_M:.0f} cm lift")
    return lifted


def timed(result: PlanResult, path: np.ndarray, name: str, capped: bool) -> dict[str, np.ndarray]:
    """Rest-to-rest timing of ``path`` under the plan's limits (the fingertip capped all along if ``capped``)."""
    robot = result.robot_model()
    tips = np.array([np.asarray(robot.fk(config))[:3, 3] for config in path])
    return time_path(path, tips, np.full(len(path), capped), result.timing["limits"], name)


@dataclass
class Task:
    """A plan being served: the plan, the object as perceived, the reach, and what the request said."""

    result: PlanResult
    obj: ThinObject
    scene: Scene
    reach: np.ndarray
    config: PlannerConfig
    summary: dict = field(default_factory=dict)
    table_plane: tuple | None = None


def plan_task(scene: Scene, points: np.ndarray, joints: np.ndarray | None, *, camera_pose, target: int, seed: int,
              time_limit: float, table_plane=None) -> Task:
    """Perceive a cloud (camera frame; ``table_plane`` as :func:`perceived_task`), plan for object
    ``target`` and the reach from ``joints``.

    Raises:
        Refused: no joint state yet (``no_joint_state``), a failed perception, an unsolved plan
            (``timeout`` or the planner's status), a plan that fails the verifier (``invalid``) or no reach.
    """
    from ..pipeline import for_perceived, plan_checked

    started = time.perf_counter()
    perceived_scene, obj, seen, plane, margin = perceived_task(scene, cloud_in_world(points, camera_pose), target, seed,
                                                               table_plane)
    perceived = time.perf_counter()
    if joints is None:
        raise Refused("no_joint_state", "no message on /joint_states yet: the arm's configuration is unknown")
    config = for_perceived(PlannerConfig.for_scene(perceived_scene, seed=seed, time_limit_s=time_limit), margin)
    try:
        checked = plan_checked(perceived_scene, obj, config)
    except InputError as error:
        raise Refused("plan", error.problem) from None
    result = checked.result
    if checked.verification is None:
        raise Refused(result.status, f"no plan within {time_limit:g} s ({result.status})")
    if not checked.ok:
        raise Refused("invalid", f"the plan fails verification: {checked.verification.violations[0]}")
    try:
        reach = reach_path(result, obj, joints)
    except Unreachable as error:
        raise Refused("reach", str(error)) from None
    summary = {"status": "solved", "planning_time_s": round(result.planning_time_s, 4),
               "perceive_s": round(perceived - started, 4), "total_s": round(time.perf_counter() - started, 4),
               "overhang_m": round(result.overhang_m, 4), "objects_seen": seen, "replans": 0}
    return Task(result, obj, perceived_scene, reach, config, summary, plane)


def one_line(content: dict) -> str:
    """A response message: one line of JSON, no NaN."""
    return jsontext.dumps(content, indent=None, allow_nan=False)


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
        self.robot_joints = list(robot_model(scene).joint_names)
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
            stamp = message.header.stamp.sec + 1e-9 * message.header.stamp.nanosec
            with self._cloud_arrived:
                self._cloud = (stamp if stamp > 0 else self.now(), points)
                self.arrivals.mark("/camera/points")
                self._cloud_arrived.notify_all()

    def _on_joints(self, message) -> None:
        with self.ignored.guarding("/joint_states"):
            state = joint_state(message, self.robot_joints)
            if state is not None:
                with self._lock:
                    self._joints = state
                    self.arrivals.mark("/joint_states")

    def joints(self) -> tuple[np.ndarray, np.ndarray] | None:
        with self._lock:
            return self._joints

    def newest_cloud(self) -> float:
        """The latest cloud's stamp (ROS time, s), -inf before any."""
        cloud = self._cloud
        return -math.inf if cloud is None else cloud[0]

    def latest_points(self) -> np.ndarray:
        return self._cloud[1]

    def next_cloud(self, after: float, timeout: float = 2.0) -> tuple[float, np.ndarray] | None:
        """The first cloud stamped after ``after`` (ROS time, s) as (stamp, points), waiting up to
        ``timeout`` wall s; None if none came."""
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
                         time_limit=float(self.parameter("time_limit")), table_plane=known)
        self._plane = (camera_pose, task.table_plane)
        self._publish_markers(task.result)
        self.publish_status("planned", **task.summary)
        return task

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
            task = self.task or self._plan()
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
                                     "is set: is the simulator publishing /clock?)")
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


class Execution:
    """One ``/slideplan/execute``: reach, slide (watched and re-planned with ``closed_loop``), approach,
    close, lift."""

    def __init__(self, node: PlanningNode, task: Task) -> None:
        self.node, self.task = node, task
        self.events: list = []  # the closed loop's looks that asked for a plan (slideplan.closed_loop.Replan)
        self.lookahead_s = LOOKAHEAD_S
        self.judge: Watch | None = None

    def run(self) -> dict:
        node, task = self.node, self.task
        result = task.result
        node.set_gripper(False)
        names = result.joint_names
        node.move(names, task.reach, timed(result, task.reach, "reach", capped=False), "reach")
        result, replans, expected = self.slide(result)
        approach = np.asarray(result.grasp["approach"], dtype=float)
        if len(approach):
            node.move(names, approach, result.timing["approach"], "approach")
        self.look_before_closing(expected)
        node.publish_status("close")
        node.set_gripper(True)
        lift = lift_path(result)
        node.move(names, lift, timed(result, lift, "lift", capped=True), "lift")
        checked = self.check_lifted(expected)
        latencies = [event.latency_s for event in self.events if event.outcome in ("slide", "grasp", "refused", "timeout")]
        return {"status": "done", "closed_loop": bool(node.parameter("closed_loop")), "replans": replans,
                "looks": 0 if self.judge is None else self.judge.looks, "kept": 0 if self.judge is None else self.judge.kept,
                "lift_checked": checked, "overhang_m": round(result.overhang_m, 4),
                "planning_time_s": round(task.result.planning_time_s, 4),
                "replan_latency_s": round(float(np.median(latencies)), 4) if latencies else None}

    def slide(self, result: PlanResult) -> tuple[PlanResult, int, tuple]:
        """Follow the slide; with ``closed_loop``, watch the object in each new cloud and re-plan as
        :func:`slideplan.closed_loop.run` does (:class:`~slideplan.closed_loop.SlideLoop`). Return the plan
        whose grasp is made, the re-plans followed, and where the object is expected at the grasp (motion
        from its perceived pose: as last seen, or as Eq. 2 puts it)."""
        node, task = self.node, self.task
        watch = self.judge = self._watch() if bool(node.parameter("closed_loop")) else None
        robot = result.robot_model()
        loop = SlideLoop(watch, robot, task.scene.table.height + task.obj.thickness, END_REPLANS, _Controlled(self, result, robot))
        final, expected = loop.run(result)
        return final, loop.replans, expected

    def next_points(self, phase: str) -> np.ndarray:
        """The points of the next cloud, in the camera's optical frame as they came.

        Raises:
            Refused: (``phase``) no cloud within ``CLOUD_WAIT_S``.
        """
        node = self.node
        cloud = node.next_cloud(node.now(), timeout=CLOUD_WAIT_S)
        if cloud is None:
            raise Refused(phase, f"no cloud on /camera/points for {CLOUD_WAIT_S:.0f} s to check the {phase}")
        return cloud[1]

    def object_share(self, expected, points: np.ndarray) -> float | None:
        """Of a cloud's points over the object's footprint where it is expected (a motion from its
        perceived pose; within 4 mm of its cloud), the share at the object's top rather than at the
        table's; None where too few are in view to tell."""
        from scipy.spatial import cKDTree

        task = self.task
        world = cloud_in_world(points, self.node.parameter("camera_pose"))
        footprint = cKDTree(task.obj.moved(expected).points[:, :2])
        over = np.isfinite(footprint.query(world[:, :2], distance_upper_bound=0.004)[0])
        height = world[over, 2] - task.scene.table.height
        thickness = task.obj.thickness
        on_object = int(np.sum((height > 0.5 * thickness) & (height < thickness + 0.005)))
        on_table = int(np.sum(np.abs(height) < 0.5 * thickness))
        return None if on_object + on_table < MIN_CHECK_POINTS else on_object / (on_object + on_table)

    def look_before_closing(self, expected) -> None:
        """With the hand around the object: it must be on the table where the grasp expects it.

        Raises:
            Refused: (``release``) the table is seen there instead (it fell when the finger let go, or
                the slide left it elsewhere).
        """
        share = self.object_share(expected, self.next_points("release"))
        if share is not None and share < 0.5:
            raise Refused("release", f"the object is not where the grasp expects it (the table is seen over "
                                     f"{100 * (1 - share):.0f}% of its footprint there): it fell or slid elsewhere")

    def check_lifted(self, expected) -> bool:
        """After the lift, look for the object on the table: where it was grasped, then (from an organized
        cloud) anywhere on the table, as the closed loop searches for a lost object
        (:meth:`~slideplan.closed_loop.Watch.locate`, then a fit there). Seen on the table, the grasp
        missed it, let it go or knocked it away. Return False when too little of the place where it was
        grasped is in view to tell.

        Raises:
            Refused: (``grasp``) the object is still on the table.
        """
        points = self.next_points("grasp")
        share = self.object_share(expected, points)
        if share is not None and share >= 0.5:
            raise Refused("grasp", f"the object is still on the table after the lift (its top seen over "
                                   f"{100 * share:.0f}% of its footprint): the grasp missed it or let it go")
        off_m = self.found_on_table(expected, points)
        if off_m is not None:
            raise Refused("grasp", f"the object is on the table {100 * off_m:.0f} cm from where it was grasped after "
                                   f"the lift: the grasp missed it or knocked it away")
        return share is not None

    def found_on_table(self, expected, points: np.ndarray) -> float | None:
        """How far from ``expected`` (m) a search of the table finds the object in an organized cloud (a
        fit there, with its top seen over at least half its footprint), or None (not found, or the cloud
        is unorganized)."""
        try:
            watch = self.judge or self._watch()
        except Refused:  # an unorganized cloud: no depth image to search
            return None
        depth = _depth(points)
        guess = watch.locate(lambda: (depth, None), expected)
        seen = None if guess is None else watch.tracker.track(depth, guess)
        if seen is None or not seen.ok:
            return None
        share = self.object_share(seen.motion, points)
        return watch.error(seen.motion, expected)[0] if share is not None and share >= 0.5 else None

    def record(self, event) -> None:
        """Keep a look that asked for a plan, and say what came of it on /slideplan/status."""
        self.events.append(event)
        self.node.publish_status("look", trigger=event.trigger, outcome=event.outcome, detail=event.detail,
                                 off_m=round(event.position_error_m, 4), off_deg=round(event.yaw_error_deg, 2),
                                 latency_s=round(event.latency_s, 4))

    def _watch(self) -> Watch:
        """The closed loop's judge for this task, its camera from the latest cloud.

        Raises:
            Refused: (``closed_loop``) the cloud is not an organized depth camera's.
        """
        node, task = self.node, self.task
        camera = tracking_camera(node.latest_points(), node.parameter("camera_pose"))
        return Watch(task.scene, task.obj, task.config, camera, THRESHOLD, REPLAN_TIME_LIMIT_S)


def _hold(config: np.ndarray) -> dict[str, np.ndarray]:
    """The timing of a one-point trajectory: be at ``config``, at rest."""
    return {"time_from_start": np.zeros(1), "velocities": np.zeros((1, len(config)))}


class _Controlled:
    """The :class:`~slideplan.closed_loop.Arm` of an execution: trajectories on the controller's topic, a
    look at each new cloud; a new plan starts where the arm will be ``lookahead_s`` after the frame (it
    goes on moving while the loop plans)."""

    def __init__(self, execution: Execution, result: PlanResult, robot) -> None:
        self.execution, self.node, self.names, self.robot = execution, execution.node, result.joint_names, robot
        self.began = self.node.now()
        self.delay = 0.0  # the first point of the next slide is where the old one would be by then
        self.sent = (self.began, 0.0)  # the last slide's start (ROS time) and delay

    def clock(self) -> float:
        return self.node.now() - self.began

    def _frames_after(self, stamp_box: list) -> Callable[[], tuple[np.ndarray, np.ndarray]]:
        """The next cloud after the last one used (``stamp_box[0]``, updated), as (depth, measured fingertip pose)."""
        def frames():
            cloud = self.node.next_cloud(stamp_box[0], timeout=CLOUD_WAIT_S)
            if cloud is None:
                raise Refused("slide", f"no new cloud on /camera/points for {CLOUD_WAIT_S:.0f} s while watching the slide")
            stamp_box[0] = cloud[0]
            return _depth(cloud[1]), np.asarray(self.robot.fk(self.node.joints()[0]))
        return frames

    def frames(self) -> Callable[[], tuple[np.ndarray, np.ndarray]]:
        return self._frames_after([self.node.now()])

    def slide(self, segment, look) -> Stop | None:
        node, robot = self.node, self.robot
        path, times = np.asarray(segment.result.trajectory, dtype=float), segment.times
        started = node.send(self.names, path, segment.result.timing["trajectory"], "slide", self.delay)
        self.sent, delay, self.delay = (started, self.delay), self.delay, 0.0
        stops: list[Stop] = []
        seen_at = [started]

        def during(elapsed: float) -> bool:
            newest = node.newest_cloud()
            if look is None or newest <= seen_at[0]:
                return False
            at = newest - started - delay  # when the frame arrived, into this slide
            ahead = at + self.execution.lookahead_s
            if at <= 0.0 or ahead >= times[-1]:
                return False
            config = reference(path, times, ahead)
            stop = look(self._frames_after(seen_at), newest - self.began, np.asarray(robot.fk(reference(path, times, at))), config,
                        ahead, start_tip=np.asarray(robot.fk(config)))
            if stop is not None:
                stops.append(stop)
            return stop is not None

        node.wait_arrived(path[-1], started, float(times[-1] + delay), "slide", during)
        return stops[0] if stops else None

    def _arrival(self, stop: Stop) -> float:
        """How long from now until the last slide sent is at ``stop`` (s, >= 0)."""
        started, delay = self.sent
        return max(0.0, started + delay + stop.at_s - self.node.now())

    def stop(self, stop: Stop) -> None:
        self.node.move(self.names, stop.config[None, :], _hold(stop.config), "slide", self._arrival(stop))

    def switch(self, stop: Stop) -> None:
        self.delay = self._arrival(stop)
        if len(stop.plan.trajectory) == 1:  # graspable where it was seen: stop there
            self.node.move(self.names, stop.config[None, :], _hold(stop.config), "slide", self.delay)

    def move(self, result: PlanResult, path: np.ndarray, phase: str) -> None:
        self.node.move(self.names, path, timed(result, path, phase, capped=phase != "reach"), phase)

    def record(self, event) -> None:
        self.execution.record(event)
        if event.trigger == "drift" and event.outcome in ("slide", "grasp"):  # the arm went on this long meanwhile
            self.execution.lookahead_s = max(self.execution.lookahead_s, 1.5 * event.latency_s)

    def replanned(self, trigger: str, outcome: str, replans: int) -> None:
        self.node.publish_status("replan", trigger=trigger, replans=replans, outcome=outcome)


def _depth(points: np.ndarray) -> np.ndarray:
    """The depth image of an organized cloud in its optical frame (z forward), NaN where no return."""
    depth = np.array(points[..., 2], dtype=float)
    depth[~(depth > 0)] = np.nan
    return depth


def tracking_camera(points: np.ndarray, camera_pose) -> Camera:
    """The pinhole camera that took an organized cloud given in its optical frame (x right, y down, z
    forward) at ``camera_pose`` in the world: the focal length fitted to the points themselves
    (column offset from the centre = f x / z).

    Raises:
        Refused: (``closed_loop``) an unorganized cloud, or too few points to fit.
    """
    rows, cols = points.shape[:2]
    if rows < 2:
        raise Refused("closed_loop", "closed_loop tracks the object in an organized depth cloud (height > 1) in the "
                                     "camera's optical frame; this cloud is unorganized: set closed_loop to false")
    with np.errstate(invalid="ignore", divide="ignore"):
        ratio = points[..., 0] / points[..., 2]
    offset = np.broadcast_to(np.arange(cols) + 0.5 - 0.5 * cols, (rows, cols))
    valid = np.isfinite(ratio) & (points[..., 2] > 0) & (np.abs(offset) > 1)
    if valid.sum() < 100:
        raise Refused("closed_loop", f"{int(valid.sum())} points with depth in the cloud: too few to fit the camera's focal length")
    ratio, offset = ratio[valid], offset[valid]
    focal = float(offset @ offset / (offset @ ratio))
    return Camera.from_optical_pose(base_pose_matrix(camera_pose), width=cols, height=rows,
                                    fovy_deg=math.degrees(2.0 * math.atan(0.5 * rows / focal)))


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

