"""One ``/slideplan/execute`` of the planning node (:class:`Execution`): reach, slide (watched and
re-planned with ``closed_loop``: the loop's decisions of :mod:`slideplan.loop.decisions` over the node's
controller and clouds, :class:`_Controlled`), approach, close, lift."""

from __future__ import annotations

import math
from typing import Callable

import numpy as np

from ..perception.camera import Camera
from ..loop.decisions import SLIP_FAILURE, SlideLoop, Stop
from ..plan.motions import reference, rest_to_rest
from ..plan.robot import base_pose_matrix
from ..plan.result import PlanResult
from ..loop.watch import Watch
from .task import Refused, Task, cloud_in_world, lift_path

# The closed loop, as slideplan run's defaults: a drift is 3 mm / 2 deg off the prediction; each re-plan has 1 s.
THRESHOLD = (0.003, math.radians(2.0))
REPLAN_TIME_LIMIT_S = 1.0
END_REPLANS = 3
CLOUD_WAIT_S = 10.0  # wall time: a simulator may run well below real time while the finger slides
MIN_CHECK_POINTS = 30  # cloud points over the object's footprint that can tell whether it is there
LOOKAHEAD_S = 0.15  # a re-plan starts where the arm will be this much later (grown to 1.5 x the slowest re-plan)


class Execution:
    """One ``/slideplan/execute``: reach, slide (watched and re-planned with ``closed_loop``), approach,
    close, lift; ``node`` is the :class:`slideplan.ros.serve.PlanningNode` that drives the robot."""

    def __init__(self, node, task: Task) -> None:
        self.node, self.task = node, task
        self.events: list = []  # the closed loop's looks that asked for a plan (slideplan.loop.watch.Replan)
        self.lookahead_s = LOOKAHEAD_S
        self.judge: Watch | None = None

    def run(self) -> dict:
        node, task = self.node, self.task
        result = task.result
        node.set_gripper(False)
        names = result.joint_names
        node.move(names, task.reach, rest_to_rest(result.robot_model(), task.reach, result.timing["limits"], "reach", capped=False), "reach")
        result, loop, expected = self.slide(result)
        if loop.abandoned:  # as slideplan.sim.closed_loop.run judges it: no grasp of an object the finger lost
            raise Refused("slide", f"{SLIP_FAILURE} (slide_stop {loop.stopped})")
        approach = np.asarray(result.grasp["approach"], dtype=float)
        if len(approach):
            node.move(names, approach, result.timing["approach"], "approach")
        self.look_before_closing(expected)
        node.publish_status("close")
        node.set_gripper(True)
        lift = lift_path(result)
        node.move(names, lift, rest_to_rest(result.robot_model(), lift, result.timing["limits"], "lift"), "lift")
        checked = self.check_lifted(expected)
        latencies = [event.latency_s for event in self.events if event.outcome in ("slide", "grasp", "refused", "timeout")]
        return {"status": "done", "closed_loop": bool(node.parameter("closed_loop")), "replans": loop.replans,
                "slide_stop": loop.stopped,
                "looks": 0 if self.judge is None else self.judge.looks, "kept": 0 if self.judge is None else self.judge.kept,
                "lift_checked": checked, "overhang_m": round(result.overhang_m, 4),
                "planning_time_s": round(task.result.planning_time_s, 4),
                "replan_latency_s": round(float(np.median(latencies)), 4) if latencies else None}

    def slide(self, result: PlanResult) -> tuple[PlanResult, SlideLoop, tuple]:
        """Follow the slide; with ``closed_loop``, watch the object in each new cloud and re-plan as
        :func:`slideplan.sim.closed_loop.run` does (:class:`~slideplan.loop.decisions.SlideLoop`, within its bounds).
        Return the plan whose grasp is made, the loop (its re-plans and the bound it met), and where the
        object is expected at the grasp (motion from its perceived pose: as last seen, or as Eq. 2 puts it)."""
        node, task = self.node, self.task
        watch = self.judge = self._watch() if bool(node.parameter("closed_loop")) else None
        robot = result.robot_model()
        loop = SlideLoop(watch, robot, task.scene.table.height + task.obj.thickness, END_REPLANS, _Controlled(self, result, robot))
        final, expected = loop.run(result)
        return final, loop, expected

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
        (:meth:`~slideplan.loop.watch.Watch.locate`, then a fit there). Seen on the table, the grasp
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
        return Watch(task.scene, task.obj, task.config, camera, THRESHOLD, REPLAN_TIME_LIMIT_S, table_plane=task.table_plane)


def _hold(config: np.ndarray) -> dict[str, np.ndarray]:
    """The timing of a one-point trajectory: be at ``config``, at rest."""
    return {"time_from_start": np.zeros(1), "velocities": np.zeros((1, len(config)))}


class _Controlled:
    """The :class:`~slideplan.loop.decisions.Arm` of an execution: trajectories on the controller's topic, a
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
        # The reach under the plan's own limits; the look from clear capped near the object only, as an approach.
        timing = rest_to_rest(result.robot_model(), path, result.timing["limits"], phase, capped=False,
                              top=None if phase == "reach" else result.object_top)
        self.node.move(self.names, path, timing, phase)

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
