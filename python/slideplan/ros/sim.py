"""``slideplan ros sim``: the MuJoCo execution model (:mod:`slideplan.sim`) as a ROS 2 robot, node
``slideplan_sim``.

It runs in real time where the physics keeps up (slower where it cannot: everything is timed in
simulated time) and

- publishes ``/clock`` (simulated time: run the planning node with ``use_sim_time``), ``/joint_states`` (100 Hz, the arm's joints), ``/camera/points`` (an organized
  ``PointCloud2`` of a rendered depth camera with noise and dropouts, in its optical frame
  ``slideplan_camera``, 5 Hz by default) and ``/slideplan_sim/object_pose`` (the object's true pose, its
  centre of mass, for tests and demos);
- follows ``trajectory_msgs/JointTrajectory`` on ``/joint_trajectory_controller/joint_trajectory`` as
  ros2_control's JointTrajectoryController does: positions interpolated in ``time_from_start`` from
  the message's arrival, from where the arm is commanded then; a new message replaces the current one;
- serves ``/gripper/set`` (``std_srvs/SetBool``, true = close): it answers when the fingers have closed
  (or opened).

The open hand touches the world with its fingertip pad only (the slide's contact), the closed hand
with all its links: as in ``slideplan execute``, where the hand's links collide from the approach on.
"""

from __future__ import annotations

import dataclasses
import math
import os
import threading
import time
from pathlib import Path

import numpy as np

from ..perception.camera import Camera
from ..sim.closed_loop import default_camera
from ..sim.episode import DEPTH_DROPOUT, Episode
from ..sim.conditions import Disturbance, execution_settings, setting_draws
from ..errors import InputError
from ..sim.model import DEPTH_CAMERA, Rig, enable_hand_collisions, set_servo_gains
from ..sim.runner import instability
from ..plan.motions import reference
from ..world.objects import load_object
from ..plan.config import PlannerConfig
from ..plan.robot import build_robot, robot_description
from ..sim.rendering import camera_depth, noisy_depth
from ..world.scenes import Scene
from ..transforms import homogeneous

JOINT_STATE_HZ = 100.0
_CLOSE_HOLD_S = 0.8
# Fast DDS's default shared-memory segment (512 KB) drops nearly every best-effort cloud larger than it.
LARGE_SAMPLES_PROFILE = Path(__file__).with_name("fastdds_large_samples.xml")


class Sim(Episode):
    """The simulated robot without ROS: an :class:`~slideplan.sim.episode.Episode` built before any plan (the
    robot at ``home``), stepped to a time, the arm following timed joint paths, the gripper opened or closed,
    the camera rendered.

    Args:
        scene: the scene (robot, hand, table).
        object_name: the object's outline (a name in ``data/objects`` or a TOML path).
        pose: (x, y, yaw) where it lies (m, m, rad).
        setting: ``nominal``, ``stress`` (torsional friction halved) or ``random`` (frictions, mass and
            depth noise drawn from ``seed``), as ``slideplan run``.
        seed: the random setting's draws and the camera noise.
        camera: the depth camera (default: the closed loop's, :func:`slideplan.sim.closed_loop.default_camera`).
        home: the arm's first configuration (default: every joint at 0, clipped into its limits).
        disturbance: move the object ``after_s`` after the fingertip first touches it, or None.

    Raises:
        InputError: an unknown setting, an object off the table, a home of the wrong length or
            outside the limits, or a URDF MuJoCo cannot import.
    """

    def __init__(self, scene: Scene, object_name, pose, *, setting: str = "nominal", seed: int = 0,
                 camera: Camera | None = None, home=None, disturbance: Disturbance | None = None) -> None:
        os.environ.setdefault("MUJOCO_GL", "egl")  # before MuJoCo is first imported
        import mujoco

        if setting == "hard":  # its camera error and push are slideplan.sim.closed_loop.run's, not this simulator's
            raise InputError("the hard setting runs in `slideplan run` and the closed-loop experiment only", field="setting")
        self.draws = setting_draws(setting, seed)
        self.truth = load_object(object_name, table_height=scene.table.height, pose=pose)
        if not scene.table.polygon.contains(self.truth.outline):
            raise InputError(f"the object at {tuple(pose)} is not wholly on the table", field="--pose")
        config = PlannerConfig.for_scene(scene, seed=seed)
        self.robot = build_robot(robot_description(scene))
        self.joint_names = list(self.robot.joint_names)
        lower, upper = np.asarray(self.robot.lower_limits), np.asarray(self.robot.upper_limits)
        if home is None:
            home = np.clip(np.zeros(self.robot.dof), lower, upper)
        home = np.asarray(home, dtype=float)
        if home.shape != (self.robot.dof,) or not np.all(np.isfinite(home)):
            raise InputError(f"expected {self.robot.dof} joint values ({', '.join(self.joint_names)})", field="--home")
        if np.any(home < lower - 1e-9) or np.any(home > upper + 1e-9):
            raise InputError("outside the joint limits", field="--home")
        # The stress setting's spring override follows a plan's depths, which a robot does not know.
        self.settings = dataclasses.replace(execution_settings(setting, self.draws, config.dz_min), contact_depth=None)
        self.camera = camera or default_camera(scene)
        super().__init__(Rig.for_scene(scene, self.truth, config, self.joint_names, home), self.settings, self.truth,
                         self.camera)
        self.model, self.data = self.built.model, self.built.data
        self.data.qpos[self.built.arm_qpos] = home
        set_servo_gains(self.built, home, self.settings)
        self.data.ctrl[self.built.arm_actuators] = home
        mujoco.mj_forward(self.model, self.data)
        self._stiffness = float(self.model.jnt_stiffness[self.built.spring_joint])
        self._path, self._times, self._started = home[None, :], np.zeros(1), 0.0
        self._lead = 1.0 / (math.pi * self.settings.servo_bandwidth_hz)  # as the execution runner's servos
        self._gripper: tuple[bool, float, float] = (False, 0.0, 0.0)  # commanded closed, since (sim time), from (fraction closed)
        self._closed_fraction = 0.0  # of the gripper's servo targets, from open (0) to closed (1)
        self.gripper_done = threading.Event()
        self.gripper_done.set()
        self.disturbance, self._touched = disturbance, None
        self._noise = np.random.default_rng([seed, 1])
        self._renderer = None
        self.lock = threading.Lock()  # the ROS callbacks' commands against the stepping thread
        self._set_hand(False)

    # --------------------------------------------------------------- commands (any thread)

    def command(self, path: np.ndarray, times: np.ndarray) -> None:
        """Follow ``path`` (M, dof) at ``times`` (M,) s from now, starting from the reference held now
        (a trajectory whose first point is at t > 0 is approached from there)."""
        with self.lock:
            now = self.data.time
            current = self._reference(now)
            if times[0] > 0:
                path, times = np.vstack([current, path]), np.concatenate([[0.0], times])
            self._path, self._times, self._started = np.asarray(path, dtype=float), np.asarray(times, dtype=float), now

    def set_gripper(self, closed: bool) -> threading.Event:
        """Start closing (True) or opening the hand; the event is set when it has."""
        with self.lock:
            self.gripper_done.clear()
            self._gripper = (bool(closed), self.data.time, self._closed_fraction)
            self._set_hand(closed)
            return self.gripper_done

    # --------------------------------------------------------------- stepping (one thread)

    def step_to(self, until: float) -> None:
        """Step the physics up to simulated time ``until`` (s)."""
        import mujoco

        while self.data.time < until:
            with self.lock:
                self.data.ctrl[self.built.arm_actuators] = self._reference(self.data.time + self._lead)
                self._drive_gripper()
                self._maybe_disturb()
                mujoco.mj_step(self.model, self.data)
            cause = instability(self.data)
            if cause:  # MuJoCo would reset the arm and go on as if nothing happened
                raise RuntimeError(f"simulation unstable ({cause}) at t = {self.data.time:.3f} s")

    def joint_state(self) -> tuple[np.ndarray, np.ndarray]:
        """The arm's joint positions and velocities."""
        return self.data.qpos[self.built.arm_qpos].copy(), self.data.qvel[self.built.arm_dofs].copy()

    def object_pose(self) -> np.ndarray:
        """(4, 4) pose of the object's body (its origin at the centre of mass, unturned at the start)."""
        body = self.built.object_body
        return homogeneous(self.data.xmat[body].reshape(3, 3), self.data.xpos[body])

    def depth(self) -> np.ndarray:
        """A noisy depth frame of the camera now (NaN: no return). Call from the stepping thread: the
        renderer's GL context belongs to the thread that made it."""
        import mujoco

        if self._renderer is None:
            self._renderer = mujoco.Renderer(self.model, self.camera.height, self.camera.width)
            self._renderer.enable_depth_rendering()
        return noisy_depth(camera_depth(self._renderer, self.model, self.data, DEPTH_CAMERA),
                           self.draws["depth_noise_at_1m"], DEPTH_DROPOUT, self._noise)

    def optical_points(self, depth: np.ndarray) -> np.ndarray:
        """(height, width, 3) points of a depth frame in the camera's optical frame (x right, y down,
        z forward), NaN where there is no return."""
        camera = self.camera
        rows, cols = np.mgrid[0:camera.height, 0:camera.width]
        return np.stack([(cols + 0.5 - 0.5 * camera.width) / camera.focal_px * depth,
                         (rows + 0.5 - 0.5 * camera.height) / camera.focal_px * depth, depth], axis=-1)

    def close(self) -> None:
        if self._renderer is not None:
            self._renderer.close()
            self._renderer = None
        super().close()

    # --------------------------------------------------------------- internals

    def _reference(self, t: float) -> np.ndarray:
        return reference(self._path, self._times, t - self._started)

    def _set_hand(self, closed: bool) -> None:
        """Closed: every hand link touches the world, the finger's flexure stiffens and the closing torque
        is capped (as :meth:`slideplan.sim.runner.Runner.grasp`); open: the pad alone touches."""
        built, model = self.built, self.model
        enable_hand_collisions(built, closed)
        model.jnt_stiffness[built.spring_joint] = self._stiffness * (50.0 if closed else 1.0)
        built.gripper.grip(model, self.settings, closing=closed)

    def _drive_gripper(self) -> None:
        """The fingers close at the hand's speed and meet at the grasp plane together, then squeeze."""
        closed, since, start = self._gripper
        gripper = self.built.gripper
        if not len(gripper):
            self.gripper_done.set()
            return
        ramp_s = gripper.ramp_s(self.settings)
        moved = (self.data.time - since) / ramp_s  # from where the last command left the targets
        self._closed_fraction = min(start + moved, 1.0) if closed else max(start - moved, 0.0)
        self.data.ctrl[gripper.actuators] = gripper.target(self._closed_fraction)
        if self._closed_fraction == (1.0 if closed else 0.0) and (
                not closed or self.data.time - since >= (1.0 - start) * ramp_s + _CLOSE_HOLD_S):  # closed: then squeeze a while
            self.gripper_done.set()

    def _maybe_disturb(self) -> None:
        """Move the object by the disturbance ``after_s`` after the pad first touched it."""
        if self.disturbance is None:
            return
        if self._touched is None:
            for index in range(self.data.ncon):
                pair = (int(self.data.contact[index].geom1), int(self.data.contact[index].geom2))
                if self.built.pad_geom in pair and (pair[0] in self.built.object_geoms or pair[1] in self.built.object_geoms):
                    self._touched = self.data.time
                    break
            return
        if self.data.time - self._touched < self.disturbance.after_s:
            return
        move, self.disturbance = self.disturbance, None
        move.apply(self.built)


class _SimNode:
    """The node ``slideplan_sim`` around a :class:`Sim`: its publishers, the trajectory subscription, the
    gripper service, and the physics loop that steps and publishes (run in a thread of its own)."""

    def __init__(self, sim: Sim, cloud_hz: float, ros_args: list[str]) -> None:
        import rclpy
        from rclpy.callback_groups import ReentrantCallbackGroup
        from rclpy.node import Node
        from rclpy.qos import qos_profile_sensor_data
        from builtin_interfaces.msg import Time
        from geometry_msgs.msg import PoseStamped
        from rosgraph_msgs.msg import Clock
        from sensor_msgs.msg import JointState, PointCloud2
        from std_msgs.msg import Header
        from std_srvs.srv import SetBool
        from trajectory_msgs.msg import JointTrajectory

        from .guards import rcl_errors

        self.sim, self.cloud_hz, self.stop = sim, cloud_hz, threading.Event()
        self._Time, self._Header, self._Clock, self._JointState = Time, Header, Clock, JointState  # rclpy is imported here only
        with rcl_errors():
            rclpy.init(args=["slideplan_sim", *ros_args])
            self.node = Node("slideplan_sim")
        node, group = self.node, ReentrantCallbackGroup()
        self.joint_pub = node.create_publisher(JointState, "/joint_states", 10)
        self.cloud_pub = node.create_publisher(PointCloud2, "/camera/points", qos_profile_sensor_data)
        self.pose_pub = node.create_publisher(PoseStamped, "/slideplan_sim/object_pose", 10)
        self.clock_pub = node.create_publisher(Clock, "/clock", 10)
        node.create_subscription(JointTrajectory, "/joint_trajectory_controller/joint_trajectory",
                                 self._on_trajectory, 10, callback_group=group)
        node.create_service(SetBool, "/gripper/set", self._on_gripper, callback_group=group)

    def _on_trajectory(self, message) -> None:
        from .messages import trajectory_arrays

        try:
            path, times = trajectory_arrays(message, self.sim.joint_names)
        except InputError as error:
            self.node.get_logger().error(f"trajectory ignored: {error.problem}")
            return
        self.sim.command(path, times)

    def _on_gripper(self, request, response):
        done = self.sim.set_gripper(request.data)
        response.success = done.wait(timeout=10.0)
        response.message = ("closed" if request.data else "opened") if response.success else "the hand did not finish"
        return response

    def _stamp(self):
        """Simulated time: what the planning node runs on with use_sim_time."""
        nanoseconds = int(round(self.sim.data.time * 1e9))
        return self._Time(sec=nanoseconds // 1_000_000_000, nanosec=nanoseconds % 1_000_000_000)

    def _header(self, frame: str):
        return self._Header(stamp=self._stamp(), frame_id=frame)

    def physics(self) -> None:
        """Step 10 ms of simulated time at a time, no faster than the wall clock (slower where the
        physics cannot keep up: the arm follows its trajectories in simulated time); publish the joint
        states after each, a cloud and the object's pose every 1 / cloud_hz."""
        import rclpy

        from .messages import WORLD_FRAME, cloud_message, pose_message

        sim, stop = self.sim, self.stop
        start, next_cloud, period = time.perf_counter(), 0.0, 1.0 / JOINT_STATE_HZ
        try:
            while not stop.is_set():
                sim.step_to(sim.data.time + period)
                self.clock_pub.publish(self._Clock(clock=self._stamp()))
                positions, velocities = sim.joint_state()
                self.joint_pub.publish(self._JointState(
                    header=self._header(""), name=sim.joint_names, position=positions.tolist(),
                    velocity=velocities.tolist()))
                if sim.data.time >= next_cloud:
                    next_cloud += 1.0 / self.cloud_hz
                    self.cloud_pub.publish(cloud_message(sim.optical_points(sim.depth()), self._header("slideplan_camera")))
                    self.pose_pub.publish(pose_message(sim.object_pose(), self._header(WORLD_FRAME)))
                stop.wait(max(0.0, sim.data.time - (time.perf_counter() - start)))
        except Exception as error:  # the node must say why it stopped stepping (unless it is shutting down)
            if rclpy.ok() and not stop.is_set():
                self.node.get_logger().error(f"simulation stopped: {error}")
            stop.set()
        finally:
            sim.close()


def serve(sim: Sim, *, cloud_hz: float = 5.0, ros_args: list[str] = (), log=print) -> None:
    """Run ``sim`` as the node ``slideplan_sim`` until interrupted; say its discovery range first (a
    warning where other hosts can reach it unsecured: :func:`slideplan.ros.guards.discovery_notice`).

    Args:
        sim: the simulated robot.
        cloud_hz: clouds per second of simulated time on /camera/points.
        ros_args: ``--ros-args ...`` remappings, as the command line gave them.
        log: prints a line.

    Raises:
        InputError: ROS arguments rcl cannot parse, or a security set-up it cannot meet.
    """
    import rclpy
    from rclpy.executors import ExternalShutdownException, MultiThreadedExecutor

    from .guards import discovery_notice

    if not any(name in os.environ for name in ("FASTDDS_DEFAULT_PROFILES_FILE", "FASTRTPS_DEFAULT_PROFILES_FILE")):
        os.environ["FASTDDS_DEFAULT_PROFILES_FILE"] = str(LARGE_SAMPLES_PROFILE)  # read at the first participant
    sim_node = _SimNode(sim, cloud_hz, list(ros_args))
    thread = threading.Thread(target=sim_node.physics, name="slideplan_sim physics", daemon=True)
    thread.start()
    for line in discovery_notice(os.environ, list(ros_args)):
        log(f"slideplan_sim: {line}")
    log(f"slideplan_sim: {len(sim.joint_names)} joints ({', '.join(sim.joint_names)}); camera_pose "
        + " ".join(f"{value:.6g}" for value in camera_pose_of(sim.camera)))
    executor = MultiThreadedExecutor(num_threads=2)
    executor.add_node(sim_node.node)
    try:
        while rclpy.ok() and not sim_node.stop.is_set():
            executor.spin_once(timeout_sec=0.1)
    except (KeyboardInterrupt, ExternalShutdownException):
        pass
    except Exception:
        if rclpy.ok():  # Ctrl-C shuts the context down under the spinning executor: no error then
            raise
    finally:
        sim_node.stop.set()
        thread.join(timeout=5.0)
        executor.shutdown()
        sim_node.node.destroy_node()
        if rclpy.ok():
            rclpy.shutdown()


def camera_pose_of(camera: Camera) -> list[float]:
    """The camera's optical frame as ``x y z roll pitch yaw`` (URDF rpy), the planning node's
    ``camera_pose`` parameter."""
    from scipy.spatial.transform import Rotation

    pose = camera.optical_pose()
    return [*pose[:3, 3].tolist(), *Rotation.from_matrix(pose[:3, :3]).as_euler("xyz").tolist()]
