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
import threading
import time
from dataclasses import dataclass, field

import numpy as np

from .. import jsontext
from ..errors import InputError
from ..objects import ThinObject
from ..planning import PlannerConfig, PlanResult, base_pose_matrix, plan, robot_model
from ..scenes import Scene
from ..timing import time_path

HOVER_M = 0.03  # the reach comes down onto the first contact from this far above it
REACH_STEP_RAD = 0.02  # the reach is checked for collisions this densely (joint space)
ARRIVED_RAD = 0.01  # a trajectory has arrived when every joint is this close to its last point
STILL_RAD_S = 0.05  # and moves slower than this
LIFT_M = 0.05
DEFAULTS = {"camera_pose": [0.0] * 6, "target": 0, "controller": "joint_trajectory_controller", "closed_loop": True,
            "time_limit": 5.0, "seed": 0}  # the node's ROS parameters (docs/ros2.md)


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
                   table_plane=None) -> tuple[Scene, ThinObject, int, tuple]:
    """The perceived scene (its table and clutter, the robot from ``scene``), the object ``target``, how
    many objects were seen, and the table plane (``table_plane``: the plane of an earlier cloud of the
    same camera, :func:`slideplan.perception.perceive`'s).

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
    return perception.scene(scene), obj, len(perception.objects), perception.plane


def _collision_world(result: PlanResult, obj: ThinObject):
    """The plan's robot, table, clutter and object (a prism over its cloud's hull) for collision checks."""
    import shapely

    from .. import _core
    from ..planning import core_obstacles

    world = _core.CollisionWorld(result.robot_model(),
                                 _core.SupportSurface(np.asarray(result.table["polygon"], dtype=float), float(result.table["height"])),
                                 core_obstacles(result.obstacles), list(result.robot["contact_links"]))
    hull = np.asarray(shapely.MultiPoint(obj.points[:, :2]).convex_hull.exterior.coords)[:-1]
    world.set_object(hull, float(result.table["height"]) + obj.thickness)
    return world


def _dense(configs: list[np.ndarray]) -> np.ndarray:
    """Joint-linear segments between ``configs``, no step longer than REACH_STEP_RAD."""
    path = [configs[0]]
    for start, end in zip(configs, configs[1:]):
        count = max(1, int(math.ceil(np.abs(end - start).max() / REACH_STEP_RAD)))
        path.extend(start + (end - start) * fraction for fraction in np.linspace(0.0, 1.0, count + 1)[1:])
    return np.array(path)


def reach_path(result: PlanResult, obj: ThinObject, current) -> np.ndarray:
    """From the arm's configuration ``current`` to the slide's first contact: joint-linear to a
    configuration HOVER_M above it (every link clear of table, clutter and object), then down onto it
    (the finger may touch the object, as while sliding).

    Raises:
        Refused: (``reach``) no IK above the contact, or a collision on the way, naming the links.
    """
    from .. import _core

    robot = result.robot_model()
    start = np.asarray(result.start_config, dtype=float)
    above = np.asarray(robot.fk(start))
    above[2, 3] += HOVER_M
    hover = robot.ik(above, seed=start, rng_seed=0)
    if hover is None:
        raise Refused("reach", f"no inverse kinematics {100 * HOVER_M:.0f} cm above the first contact")
    world = _collision_world(result, obj)
    current = np.asarray(current, dtype=float)
    down = _dense([np.asarray(hover), start])
    for config in _dense([current, np.asarray(hover)]):
        if not world.is_valid(config, _core.ContactMode.FREE):
            pairs = ", ".join(f"{first}-{second}" for first, second in world.collisions(config, _core.ContactMode.FREE)[:3])
            raise Refused("reach", f"the joint-space move from the current configuration to above the first contact "
                                   f"collides ({pairs}): move the arm clear first")
    for config in down:
        if not world.is_valid(config, _core.ContactMode.SLIDING):
            raise Refused("reach", "the move down onto the first contact collides")
    return np.vstack([_dense([current, np.asarray(hover)]), down[1:]])


def lift_path(result: PlanResult) -> np.ndarray:
    """From the grasp straight up LIFT_M (20 waypoints).

    Raises:
        Refused: (``lift``) no IK for the lifted grasp.
    """
    robot = result.robot_model()
    grasp = np.asarray(result.grasp["config"], dtype=float)
    target = np.asarray(robot.fk(grasp))
    target[2, 3] += LIFT_M
    lifted = robot.ik(target, seed=grasp, rng_seed=0)
    if lifted is None:
        raise Refused("lift", f"no inverse kinematics for the {100 * LIFT_M:.0f} cm lift")
    return np.linspace(grasp, np.asarray(lifted), 20)


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
    from ..verify import verify

    if joints is None:
        raise Refused("no_joint_state", "no message on /joint_states yet: the arm's configuration is unknown")
    started = time.perf_counter()
    perceived_scene, obj, seen, plane = perceived_task(scene, cloud_in_world(points, camera_pose), target, seed, table_plane)
    perceived = time.perf_counter()
    config = PlannerConfig.for_scene(perceived_scene, seed=seed, time_limit_s=time_limit)
    try:
        result = plan(perceived_scene, obj, config)
    except InputError as error:
        raise Refused("plan", error.problem) from None
    if not result.solved:
        raise Refused(result.status, f"no plan within {time_limit:g} s ({result.status})")
    verification = verify(result)
    if not verification.ok:
        raise Refused("invalid", f"the plan fails verification: {verification.violations[0]}")
    reach = reach_path(result, obj, joints)
    summary = {"status": "solved", "planning_time_s": round(result.planning_time_s, 4),
               "perceive_s": round(perceived - started, 4), "total_s": round(time.perf_counter() - started, 4),
               "overhang_m": round(result.overhang_m, 4), "objects_seen": seen, "replans": 0}
    return Task(result, obj, perceived_scene, reach, summary, plane)


def one_line(content: dict) -> str:
    """A response message: one line of JSON, no NaN."""
    return jsontext.dumps(content, indent=None, allow_nan=False)


class PlanningNode:
    """The node ``slideplan`` (module docstring); build it after ``rclpy.init()``.

    Args:
        scene: the robot's scene (URDF, mount, hand); the table and objects come from the clouds.
        parameters: initial values of the ROS parameters (``camera_pose``, ``target``, ``controller``,
            ``closed_loop``, ``time_limit``, ``seed``).
    """

    def __init__(self, scene: Scene, parameters: dict | None = None) -> None:
        from rclpy.callback_groups import MutuallyExclusiveCallbackGroup, ReentrantCallbackGroup
        from rclpy.node import Node
        from rclpy.parameter import Parameter
        from rclpy.qos import qos_profile_sensor_data
        from sensor_msgs.msg import JointState, PointCloud2
        from std_msgs.msg import String
        from std_srvs.srv import SetBool, Trigger
        from trajectory_msgs.msg import JointTrajectory
        from visualization_msgs.msg import MarkerArray

        self.scene = scene
        self.robot_joints = list(robot_model(scene).joint_names)
        overrides = [Parameter(name, value=value) for name, value in (parameters or {}).items()]
        self.node = node = Node("slideplan", parameter_overrides=overrides)
        for name, value in DEFAULTS.items():
            node.declare_parameter(name, value)
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

    def parameter(self, name: str):
        return self.node.get_parameter(name).value

    # --------------------------------------------------------------- sensors

    def _on_cloud(self, message) -> None:
        from .messages import cloud_points

        try:
            points = cloud_points(message)
        except InputError as error:
            self.node.get_logger().error(f"cloud ignored: {error.problem}")
            return
        with self._cloud_arrived:
            self._cloud = (time.monotonic(), points)
            self._cloud_arrived.notify_all()

    def _on_joints(self, message) -> None:
        names = list(message.name)
        if not all(name in names for name in self.robot_joints):
            return  # another part of the robot (e.g. the gripper's own driver)
        order = [names.index(name) for name in self.robot_joints]
        positions = np.asarray(message.position, dtype=float)[order]
        velocities = np.asarray(message.velocity, dtype=float)[order] if len(message.velocity) == len(names) else np.zeros(len(order))
        with self._lock:
            self._joints = (positions, velocities)

    def joints(self) -> tuple[np.ndarray, np.ndarray] | None:
        with self._lock:
            return self._joints

    def next_cloud(self, after: float, timeout: float = 2.0) -> np.ndarray | None:
        """The first cloud that arrived after monotonic time ``after``, waiting up to ``timeout`` s."""
        with self._cloud_arrived:
            self._cloud_arrived.wait_for(lambda: self._cloud is not None and self._cloud[0] > after, timeout)
            return self._cloud[1] if self._cloud is not None and self._cloud[0] > after else None

    # --------------------------------------------------------------- services

    def publish_status(self, phase: str, **content) -> None:
        from std_msgs.msg import String

        self.status.publish(String(data=one_line({"phase": phase, **content})))

    def _plan(self) -> Task:
        cloud = self._cloud
        if cloud is None:
            raise Refused("no_cloud", "no cloud received on /camera/points yet")
        joints = self.joints()
        self.publish_status("plan")
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

    def send(self, result: PlanResult, path: np.ndarray, times: np.ndarray, phase: str) -> float:
        """Publish a trajectory; return its monotonic start time."""
        from std_msgs.msg import Header

        from .messages import trajectory_message

        message = trajectory_message(result.joint_names, path, times, Header(stamp=self.node.get_clock().now().to_msg()))
        self.publish_status(phase, duration_s=round(float(times[-1]), 3), points=len(path))
        self.trajectory.publish(message)
        return time.monotonic()

    def wait_arrived(self, final: np.ndarray, started: float, duration_s: float, phase: str, during=None) -> None:
        """Wait until the arm is at ``final`` and still (``during(elapsed)`` called every 10 ms meanwhile;
        it may return True to stop waiting).

        Raises:
            Refused: (``phase``) not there within three times the duration plus 10 s (a simulated robot
            may run slower than real time).
        """
        deadline = started + 3.0 * duration_s + 10.0
        while time.monotonic() < deadline:
            elapsed = time.monotonic() - started
            if during is not None and during(elapsed):
                return
            joints = self.joints()
            if joints is not None and elapsed >= duration_s and np.abs(joints[0] - final).max() < ARRIVED_RAD \
                    and np.abs(joints[1]).max() < STILL_RAD_S:
                return
            time.sleep(0.01)
        error = "no joint state" if self.joints() is None else f"{np.abs(self.joints()[0] - final).max():.3f} rad off"
        raise Refused(phase, f"the arm did not reach the end of the {phase} within {deadline - started:.0f} s ({error})")

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

    def run(self) -> dict:
        node, task = self.node, self.task
        result = task.result
        node.set_gripper(False)
        reach = timed(result, task.reach, "reach", capped=False)
        node.wait_arrived(task.reach[-1], node.send(result, task.reach, reach["time_from_start"], "reach"),
                          float(reach["time_from_start"][-1]), "reach")
        result, replans = self.slide(result)
        approach = np.asarray(result.grasp["approach"], dtype=float)
        if len(approach):
            times = np.asarray(result.timing["approach"]["time_from_start"], dtype=float)
            node.wait_arrived(approach[-1], node.send(result, approach, times - times[0], "approach"),
                              float(times[-1] - times[0]), "approach")
        node.publish_status("close")
        node.set_gripper(True)
        lift = lift_path(result)
        lift_times = timed(result, lift, "lift", capped=True)["time_from_start"]
        node.wait_arrived(lift[-1], node.send(result, lift, lift_times, "lift"), float(lift_times[-1]), "lift")
        return {"status": "done", "replans": replans, "overhang_m": round(result.overhang_m, 4),
                "planning_time_s": round(task.result.planning_time_s, 4)}

    def slide(self, result: PlanResult) -> tuple[PlanResult, int]:
        """Follow the slide open loop; return the plan whose grasp is made and the re-plans."""
        path = np.asarray(result.trajectory, dtype=float)
        times = np.asarray(result.timing["trajectory"]["time_from_start"], dtype=float)
        self.node.wait_arrived(path[-1], self.node.send(result, path, times - times[0], "slide"),
                               float(times[-1] - times[0]), "slide")
        return result, 0


def serve(scene: Scene, parameters: dict | None = None, *, ros_args: list[str] = (), log=print) -> None:
    """Run the node ``slideplan`` until interrupted (``ros_args``: ``--ros-args ...`` remappings and
    parameters, as any ROS 2 node takes)."""
    import rclpy
    from rclpy.executors import ExternalShutdownException, MultiThreadedExecutor

    rclpy.init(args=["slideplan", *ros_args])
    planning = PlanningNode(scene, parameters)
    executor = MultiThreadedExecutor(num_threads=4)
    executor.add_node(planning.node)
    log(f"slideplan: serving /slideplan/plan and /slideplan/execute for {scene.name} "
        f"({len(planning.robot_joints)} joints)")
    try:
        executor.spin()
    except (KeyboardInterrupt, ExternalShutdownException):
        pass
    finally:
        executor.shutdown()
        planning.node.destroy_node()
        if rclpy.ok():
            rclpy.shutdown()

