"""The closed loop (beyond the paper): watch the object while sliding, re-plan when it drifts, grasp it
where it is seen.

:func:`run` does a whole task in MuJoCo from a fixed depth camera's view:

1. render the scene and :func:`~slideplan.perception.perceive` the object (the table is the scene's);
   plan for the object as perceived;
2. execute the slide (:mod:`slideplan.execute`'s model and runner, the object as it really is); every
   ``replan_period`` of simulated time render a depth frame with the arm in view and track the object
   (:class:`~slideplan.tracking.Tracker`); when it is further than ``threshold`` from the pose Eq. 2
   predicts for the commanded configuration in two looks in a row, and the rest of the slide would not end
   graspable from where it is seen (:meth:`Segment.still_works`), plan again from that configuration (where
   the servos' reference is, so it does not jump) with the object where it was seen, and follow the new plan;
3. when a slide ends, track the object and plan from the final configuration with the object where it
   was seen: the plan is that configuration and its grasp when the object overhangs enough (else it
   slides on, up to ``end_replans`` times); then approach, close, lift 5 cm and hold 1 s. When the
   hand hides the object from the camera there, the finger rises ``CLEAR_LIFT_M`` straight up (and on
   ``CLEAR_ASIDE_M`` across where the arm still hides it: :meth:`SlideLoop.clear_way`), looks from
   there, and comes back to where it was before the plan from what it saw goes on.

The simulation waits while the loop tracks and plans; each re-plan's latency (track + plan with its
timing) is measured on the wall clock and reported: a real arm would go on moving along the old plan
meanwhile (at 5 cm/s, 1.3 mm in the median re-plan of docs/benchmarks/replan.md). MuJoCo's rendering of
the depth frames is the camera's work, not the loop's: it is reported apart (``sense_s``); the look at
the end of a slide may take several frames (up to ``END_LOOKS``), which a real camera delivers at its
frame rate.

A re-plan that is refused (the arm's state is not on the object as seen) or finds no plan within
``replan_time_limit`` is reported as such, and the loop goes on with the plan it has. After a slide,
a refused look (the object pushed from under the finger) asks for a whole new slide instead, reached
from where the finger is (lifted off first, every link checked: :mod:`slideplan.motions`).

Open loop (``closed=False``): the first plan is executed as planned, its own grasp included; the
camera only watches: after the slide it looks as the closed loop looks at the end of a slide
(:meth:`Watch.settled`), for the diagnostics.

Success, in both modes, is the world's verdict (:mod:`slideplan.verdict`): the object in the hand, at
least 3 cm above the table top, through the whole hold, in the simulator's true state. The seen and
true overhang after the slide are diagnostics. A closed loop's sliding is bounded (:mod:`slideplan.bounds`).
"""

from __future__ import annotations

import dataclasses
import math
import os
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Callable, Protocol

import numpy as np
import shapely

from . import _core, jsontext
from ._fields import as_numbers
from .camera import Camera, back_project
from .closed_loop_settings import (  # noqa: F401 - SETTINGS, RANDOM_RANGES, DEPTH_NOISE_AT_1M re-exported
    DEPTH_NOISE_AT_1M, RANDOM_RANGES, SETTINGS, Disturbance, camera_as_mounted, execution_settings, hard_push,
    push_candidates, setting_draws)
from .errors import InputError
from .execute.model import DEPTH_CAMERA, build_model
from .execute.runner import SETTLE_S, Runner, Unstable, timing_options
from .execute.settings import ExecutionSettings
from .bounds import MAX_REPLANS, MAX_SLIDE_S, Progress
from .execute.video import Recorder, plan_points
from .objects import ThinObject, load_object, load_outline, place_outline
from .plan.config import PlannerConfig
from .plan.robot import build_robot
from .plan.result import PlanResult
from .plan.planner import plan
from .rendering import camera_depth, depth_image, noisy_depth, place_objects, scene_mjcf
from .scenes import Scene, load_scene
from .timing import resolve_limits, time_path
from .tracking import NOT_UNDER_TIP, Tracker
from .verdict import Hold, judge
from .transforms import compose_planar, move_planar, pose_to_row, row_to_pose, wrap_angle
from .geometry import overhang
from .motions import Unreachable, collision_world, dense, reach_path, straight_line, straight_up, timed_way, timing_of
from .transforms import planar_motion

CLOSED_LOOP_SCHEMA = "slideplan.closed_loop/1"
DEPTH_DROPOUT = 0.05
CONFIRM = 2  # looks in a row off the predicted pose, agreeing with each other, that make a drift
AGREE = 3.0  # two looks agree within this many thresholds
END_LOOKS = 4  # frames at most at the end of a slide for two in a row that agree
ON_TABLE_SLACK_M = 0.003  # the perceived object may cross a table edge by this much (about a pixel)
CLEAR_LIFT_M = 0.1  # when the arm hides the object at the end of a slide, the finger rises this far to look
CLEAR_ASIDE_M = 0.15  # and where the arm still hides it from there (a camera behind the arm), this far across
SIGHT_LINES = 24  # lines of sight from the camera to the object's points that tell whether the arm hides it
SIGHT_RADIUS_M = 0.005  # each a capsule of this radius (CollisionWorld.hidden_lines)
HIDDEN_SHARE = 0.25  # a pose that hides at most this share of them shows the tracker enough of the object
BLIND_S = 1.0  # a slide no look has seen the object in for this long stops, and the finger rises clear to look
OBSTACLE_MARGIN = 0.01  # a search of the table keeps this far from an obstacle's footprint (its sides, depth noise)


@dataclass
class Replan:
    """One look at the object that asked for a new plan.

    Attributes:
        time_s: simulated time since the slide started (s).
        trigger: ``"drift"`` (off the predicted pose during a slide), ``"end"`` (a slide ended) or
            ``"clear"`` (the look after an end look that did not see the object, the finger lifted clear)
            or ``"blind"`` (the same when no look had seen the object for ``BLIND_S`` of a slide, which
            stopped there), or ``"search"`` (after a clear look that did not see the object: the whole
            table's frame searched for it), or ``"new_contact"`` (after a look that found the fingertip off the object:
            a whole new slide, reached from where the finger is).
        position_error_m, yaw_error_deg: how far the seen pose was from the predicted one.
        track_s, plan_s: wall time of tracking and of planning with timing (s).
        sense_s: wall time the frames took to arrive (s): in simulation MuJoCo's rendering of the depth
            camera, which a real camera does on its own; not part of the latency.
        outcome: ``"slide"`` (a new slide followed), ``"grasp"`` (grasped from there), ``"refused"``,
            ``"timeout"`` or ``"lost"`` (the frame did not show the object); the last three keep the
            plan there was; ``"kept"`` (a blind look: the rest of the stopped slide still works from
            the pose seen, or nothing was seen). After a blind look without a new plan the rest of the
            stopped slide goes on, from rest.
        detail: why refused or lost ("" otherwise).
        frames: the indices of the depth frames (0 the run's first look) the decision used: the looks in a
            row that confirmed a drift, or the end look's frames.
    """

    time_s: float
    trigger: str
    position_error_m: float
    yaw_error_deg: float
    track_s: float
    plan_s: float
    outcome: str
    detail: str = ""
    sense_s: float = 0.0
    frames: list[int] = dataclasses.field(default_factory=list)

    @property
    def latency_s(self) -> float:
        """Track + plan (s)."""
        return self.track_s + self.plan_s


@dataclass
class ClosedLoopRun:
    """What happened in one :func:`run`.

    Attributes:
        success: the world's verdict (:func:`slideplan.verdict.held`, the same for both modes): the object
            was in the hand, at least 3 cm above the table top, through the whole hold, in the simulator's
            true state. What the camera saw plays no part.
        mode: ``"closed"`` or ``"open"``.
        setting: one of :data:`SETTINGS`.
        failed_stage: None, ``"plan"`` (no first plan), ``"slide"`` (stopped for no progress, and no new plan
            followed: no grasp), ``"release"`` (the object fell off the table when the finger let go), ``"grasp"`` (not lifted), ``"hold"`` (lifted, then out of the hand or lower than
            3 cm in the hold) or ``"simulation"``.
        failure: one line saying what went wrong ("" on success).
        replans: re-plans whose new plan was followed (slides and grasps from a seen pose).
        replan_latency_s: median latency of the looks that planned (s), None if none did.
        kept: drifts (off the predicted pose in ``CONFIRM`` looks in a row) after which the rest of the
            slide still ended graspable from the pose seen, so the plan was kept; and blind stops whose
            look found the same, or nothing (events with outcome ``"kept"``).
        looks: depth frames tracked; lost_looks: of them, those that did not show the object.
        events: every look that asked for a plan, and each end-of-slide look (:class:`Replan`).
        seen_status: after the slide, ``"seen"`` or ``"lost"`` (the look did not find the object: the seen
            columns are then None, never the prediction); None without a slide. Diagnostic.
        seen_frames: the frames that look used (the closed loop's last deciding look; the open loop's end
            look, made by the same settled procedure, :meth:`Watch.settled`).
        seen_motion: the object's motion from its perceived pose to where it was seen then, ``{x, y, yaw}``.
        seen_overhang_m, seen_com_margin_m: at that pose.
        true_overhang_m, true_com_margin_m: at the object's true pose then.
        lifted: the runner's lift check (the object rose half the lift and stayed): diagnostic.
        slide_stop: ``""`` or the bounds (:mod:`slideplan.bounds`) the closed loop met, ``+``-joined:
            ``"no_progress"`` (a slide stopped: the finger travelled on, the object as seen did not),
            ``"replan_cap"`` or ``"time_cap"`` (no new plan after ``MAX_REPLANS`` re-plans or ``MAX_SLIDE_S``
            of sliding: the slide followed then ends as planned, and its own grasp follows).
        slide_s: simulated time from the first slide's start to the grasp's start (s).
        draws: the physical parameters of the run (the random and hard settings' draws).
        disturbance: the push applied (``--disturb``, or the hard setting's), or None.
        sim_time_s, wall_time_s: simulated and wall time of the run (s).
    """

    success: bool
    mode: str
    setting: str
    failed_stage: str | None
    failure: str
    replans: int
    replan_latency_s: float | None
    kept: int
    looks: int
    lost_looks: int
    events: list[Replan]
    seen_status: str | None
    seen_frames: list[int]
    seen_motion: dict[str, float] | None
    seen_overhang_m: float | None
    seen_com_margin_m: float | None
    true_overhang_m: float | None
    true_com_margin_m: float | None
    lifted: bool
    slide_stop: str
    slide_s: float
    draws: dict[str, float]
    disturbance: dict[str, float] | None
    sim_time_s: float
    wall_time_s: float

    def to_dict(self) -> dict[str, Any]:
        """The report as JSON-ready dicts, ``schema`` first, each event with its latency."""
        report = {"schema": CLOSED_LOOP_SCHEMA, **dataclasses.asdict(self)}
        for event, entry in zip(self.events, report["events"]):
            entry["latency_s"] = event.latency_s
        return report

    def to_json(self, indent: int | None = None) -> str:
        """The report as JSON text (no NaN).

        Args:
            indent: None for one line; a number for one line per key and per waypoint
                (:func:`slideplan.jsontext.dumps`).
        """
        return jsontext.dumps(self.to_dict(), indent=indent, allow_nan=False)

    def summary(self) -> str:
        """One line: the verdict and the numbers."""
        verdict = "ok" if self.success else f"failed at {self.failed_stage}: {self.failure}"
        seen = f"; seen {self.seen_status}" if self.seen_overhang_m is None else (
            f"; seen overhang {100 * self.seen_overhang_m:.1f} cm, CoM {1000 * self.seen_com_margin_m:.1f} mm inside")
        true = "" if self.true_overhang_m is None else (
            f"; true overhang {100 * self.true_overhang_m:.1f} cm, CoM {1000 * self.true_com_margin_m:.1f} mm inside")
        stop = f"; slide stopped: {self.slide_stop}" if self.slide_stop else ""
        latency = "" if self.replan_latency_s is None else f", median latency {1000 * self.replan_latency_s:.0f} ms"
        return (f"{verdict} ({self.mode} loop, {self.setting}){seen}{true}{stop}; {self.replans} re-plans{latency}; "
                f"lifted {'yes' if self.lifted else 'no'} ({self.sim_time_s:.1f} s simulated in {self.wall_time_s:.1f} s, "
                f"{self.sim_time_s / max(self.wall_time_s, 1e-9):.1f}x real time)")


def default_camera(scene: Scene) -> Camera:
    """The closed loop's camera: 0.6 m above the table, 0.45 m from its centroid towards (-x, -y) (the
    robot's side, to its right), looking at the centroid. Of 24 placements around the table (3 heights,
    8 directions) it saw the most of three objects' edges with the table along their slides: the arm
    hides less of the object from low and to the side than from above."""
    centre = scene.table.polygon.centroid
    offset = 0.45 / math.sqrt(2.0)
    return Camera((centre.x - offset, centre.y - offset, scene.table.height + 0.6), (centre.x, centre.y, scene.table.height))


def _perceived_object(scene: Scene, object_name, camera: Camera, pose, noise: float, seed: int,
                      mounted: Camera | None = None) -> ThinObject:
    """The object as the camera sees it before the slide: its known outline registered to the object
    :func:`~slideplan.perception.perceive` finds in a rendered frame (the table is the scene's). The frame
    is taken from where the camera is ``mounted`` (default: ``camera``) and read as if from ``camera``."""
    from .perception import perceive, register_outline

    placed = place_objects([(object_name, pose)])[0]
    mounted = mounted or camera
    depth = depth_image(scene_mjcf(scene.table, [placed], [], mounted), mounted)
    points = back_project(noisy_depth(depth, noise, DEPTH_DROPOUT, np.random.default_rng(seed)), camera)
    perception = perceive(points, seed=seed, source="the rendered scene")
    if not perception.objects:
        raise InputError("the camera does not see the object", field="--pose")
    outline, thickness, _ = load_outline(object_name)
    seen_pose, _ = register_outline(perception.objects[0].points, outline)
    return load_object(object_name, table_height=scene.table.height, pose=_on_table(scene.table.polygon, outline, seen_pose))


def _on_table(table, outline, pose) -> tuple[float, float, float]:
    """``pose`` moved onto the table when the outline there crosses an edge by up to ``ON_TABLE_SLACK_M``:
    the object lies on the table, and the camera's estimate of an object at an edge can put a millimetre
    of it over (the planner refuses an object off the table). Further over, ``pose`` as it is."""
    x, y, yaw = pose
    for _ in range(4):
        corners = np.asarray(place_outline(outline, (x, y, yaw)).exterior.coords)
        outside = [corner for corner in corners if not table.covers(shapely.Point(corner))]
        if not outside:
            break
        gaps = [(table.exterior.interpolate(table.exterior.project(shapely.Point(corner))), corner) for corner in outside]
        to, corner = max(gaps, key=lambda gap: gap[0].distance(shapely.Point(gap[1])))
        step = np.array([to.x, to.y]) - corner
        if np.linalg.norm(step) > ON_TABLE_SLACK_M:
            return tuple(pose)
        step *= 1.0 + 1e-6 / max(float(np.linalg.norm(step)), 1e-12)  # onto the edge, not a rounding error short
        x, y = x + float(step[0]), y + float(step[1])
    return (x, y, yaw)


class Unseen:
    """How long the looks during a slide have not seen the object: a slide the arm hides the object
    through is blind to a push, so it stops after ``BLIND_S`` and the finger rises clear to look."""

    def __init__(self) -> None:
        self.since: float | None = None

    def update(self, seen: bool, at: float) -> float:
        """After a look at time ``at`` (s, any clock) that saw the object or not: the time since the first
        look of those in a row that did not (0 after one that did)."""
        if seen:
            self.since = None
            return 0.0
        if self.since is None:
            self.since = at
        return at - self.since


def _times(result: PlanResult, key: str, length: int) -> np.ndarray:
    times = timing_of(result.timing, key, length)
    if times is None:
        raise InputError("the plan has no timing block", field="timing")
    return times


@dataclass
class Segment:
    """A slide being followed: the plan, its times and depths, and the object's seen motion (from its
    perceived pose) when the plan was made, which Eq. 2 moves along."""

    result: PlanResult
    times: np.ndarray
    depths: np.ndarray
    base: tuple[float, float, float]

    def predicted(self, tip: np.ndarray) -> tuple[float, float, float]:
        """Where Eq. 2 puts the object (motion from its perceived pose) with the fingertip at ``tip`` (4, 4)."""
        return compose_planar(self.base, planar_motion(row_to_pose(self.result.fingertip_poses[0]), tip))

    def rest(self, robot, stop_s: float, config: np.ndarray) -> PlanResult:
        """This slide stopped at ``stop_s`` with the arm at ``config``: from there, at rest, through the
        waypoints after it, timed from rest under the plan's limits (its grasp, at the same end, stays)."""
        after = self.times > stop_s
        configs = np.vstack([np.asarray(config, dtype=float)[None, :], np.asarray(self.result.trajectory, dtype=float)[after]])
        poses = [np.asarray(robot.fk(joints)) for joints in configs]
        timing = dict(self.result.timing)
        timing["trajectory"] = time_path(configs, np.array([pose[:3, 3] for pose in poses]), np.ones(len(configs), dtype=bool),
                                         timing["limits"], "trajectory")
        rows = np.vstack([pose_to_row(poses[0])[None, :], np.asarray(self.result.fingertip_poses)[after]])
        return dataclasses.replace(self.result, trajectory=configs, fingertip_poses=rows, start_config=configs[0], timing=timing)

    def still_works(self, perceived: ThinObject, table, config: PlannerConfig, tip: np.ndarray, seen, slack: float) -> bool:
        """Whether the rest of this slide still ends graspable from where the object is seen: carried
        from there by Eq. 2 to the plan's last contact, it overhangs by ``u*`` and keeps its centre of
        mass ``com_margin`` inside the table (a slide that ends short as seen then is slid on from its
        end), and the fingertip is on the object as seen, ``slack`` (the tracker's error) inside its hull."""
        now = perceived.moved(seen)
        if not shapely.MultiPoint(now.points[:, :2]).convex_hull.buffer(-slack).contains(shapely.Point(tip[:2, 3])):
            return False
        end = perceived.moved(compose_planar(seen, planar_motion(tip, row_to_pose(self.result.fingertip_poses[-1]))))
        return (overhang(table, end.points[:, :2])[0] >= config.u_star
                and table.edge_margin(end.centroid_xy) >= config.com_margin)


def slide_segment(result: PlanResult, top: float, base) -> Segment:
    """A plan to follow, from where the object was seen (``base``) when it was made."""
    return Segment(result, _times(result, "trajectory", len(result.trajectory)),
                    top - np.asarray(result.fingertip_poses)[:, 2], tuple(float(value) for value in base))


def _diagnose(report: dict[str, Any], table, perceived: ThinObject, truth: ThinObject, seen_motion, seen: bool,
              frames: list[int], runner: Runner) -> None:
    """After the slide, diagnostics only (the verdict is the world's, :func:`slideplan.verdict.held`): the
    overhang and centre-of-mass margin where the deciding look saw the object (None when it did not: a
    lost look is reported lost, never as the prediction) and where the object truly is."""
    report.update(seen_status="seen" if seen else "lost", seen_frames=list(frames))
    if seen:
        moved = perceived.moved(seen_motion)
        report["seen_motion"] = dict(zip(("x", "y", "yaw"), map(float, seen_motion)))
        report["seen_overhang_m"] = float(overhang(table, moved.points[:, :2])[0])
        report["seen_com_margin_m"] = float(table.edge_margin(moved.centroid_xy))
    com, yaw, _ = runner.object_pose()  # the object's body starts unturned, its origin at the centre of mass
    motion = (*(com - move_planar(np.asarray(truth.centroid_xy, dtype=float), (0.0, 0.0, yaw))), yaw)
    report["true_overhang_m"] = float(overhang(table, move_planar(truth.points[:, :2], motion))[0])
    report["true_com_margin_m"] = float(table.edge_margin(com))


def _pose_error(obj: ThinObject, first, second) -> tuple[float, float]:
    """Distance (m) between the object's centre of mass under two motions, and their yaw difference (rad)
    less the nearest turn that leaves the footprint as it was (a disc's yaw is no error)."""
    com = np.asarray(obj.centroid_xy, dtype=float)[None, :]
    turn = wrap_angle(float(first[2]) - float(second[2]))
    unseen = (turn - obj.symmetry_turns + math.pi) % (2 * math.pi) - math.pi
    return (float(np.linalg.norm(move_planar(com, first) - move_planar(com, second))),
            float(unseen[np.argmin(np.abs(unseen))]))


class Watch:
    """What the closed loop makes of the camera's frames, for :func:`run` and the ROS node alike:
    tracking from the predicted and from the last seen pose, a drift confirmed over ``CONFIRM`` looks,
    the settled look at the end of a slide, and a re-plan from the arm's state with the object where
    it was seen.

    Args:
        scene: the scene planned in.
        perceived: the object as perceived before the slide (every motion is from its pose).
        config: planner parameters; re-plans use ``replan_time_limit``.
        camera: the fixed depth camera the frames come from.
        threshold: (m, rad) a seen pose further than this from the predicted one is off it.
        replan_time_limit: planning time limit of each re-plan (s).

    Attributes:
        looks, lost_looks: frames tracked, and of them those that did not show the object.
        kept: confirmed drifts after which the rest of the slide still ended graspable.
    """

    def __init__(self, scene: Scene, perceived: ThinObject, config: PlannerConfig, camera: Camera,
                 threshold, replan_time_limit: float) -> None:
        self.scene, self.perceived, self.threshold = scene, perceived, threshold
        self.replan_config = dataclasses.replace(config, time_limit_s=replan_time_limit)
        self.tracker = Tracker(perceived, camera, table_height=scene.table.height)
        # The sides of an obstacle rise through the object's height: a search of the table leaves them out.
        obstacles = scene.footprints(scene.table.height + perceived.thickness + self.tracker.hand_clearance)
        self.free_table = scene.table.polygon if obstacles is None else scene.table.polygon.difference(
            obstacles.buffer(OBSTACLE_MARGIN))
        perceived.symmetry_turns  # computed once, before the first look's latency
        self.looks = self.lost_looks = self.kept = 0
        self._last: tuple | None = None  # (motion seen, fingertip pose then) of the last look that found the object
        self._beyond: list = []  # (pose seen, fingertip pose, frame) of the looks in a row off the predicted pose

    def error(self, first, second) -> tuple[float, float]:
        """Distance (m) between the object's centre of mass under two motions, and their yaw difference (rad)."""
        return _pose_error(self.perceived, first, second)

    def agree(self, first, second, factor: float = AGREE) -> bool:
        """Two poses within ``factor`` thresholds of each other (two seen poses agree within AGREE: the
        tracker's own scatter under the arm is about a threshold; its wrong fits are centimetres or tens
        of degrees off)."""
        error_m, error_yaw = self.error(first, second)
        return error_m <= factor * self.threshold[0] and abs(error_yaw) <= factor * self.threshold[1]

    @staticmethod
    def carried(motion, since: np.ndarray, tip: np.ndarray):
        """A pose seen with the fingertip at ``since``, carried by the fingertip's motion to ``tip`` (Eq. 2)."""
        return compose_planar(motion, planar_motion(since, tip))

    def carried_last(self, tip: np.ndarray):
        """The pose last seen, carried by the fingertip's motion since (Eq. 2), or None."""
        return None if self._last is None else self.carried(*self._last, tip)

    def look(self, frame: np.ndarray, tip: np.ndarray, predicted, *, under_tip: bool = True) -> Any:
        """Track the object in ``frame`` (a depth image) with the fingertip measured at ``tip`` (4, 4), from
        where Eq. 2 puts it and from where it was last seen carried along by the fingertip since (the
        better fit wins): after a disturbance the prediction is centimetres off, and after a wrong fit
        the last pose is. ``under_tip``: only a fit with the object under the fingertip counts."""
        guesses = [predicted]
        carried = self.carried_last(tip)
        if carried is not None and not self.agree(carried, predicted):
            guesses.append(carried)
        # The finger presses on the object until the grasp: its measured position is on the object.
        contact = tip[:2, 3] if under_tip else None
        seen = max((self.tracker.track(frame, guess, contact=contact) for guess in guesses),
                   key=lambda fit: (fit.ok, fit.edge_points, -fit.rmse_m if fit.ok else 0.0))
        self.looks += 1
        if seen.ok:
            self._last = (seen.motion, tip)
        else:
            self.lost_looks += 1
        return seen

    def locate(self, frames, predicted):
        """Where to look for an object not seen near ``predicted``: over the whole table but the obstacles
        in the next frame (:meth:`slideplan.tracking.Tracker.locate`), or None."""
        return self.tracker.locate(frames()[0], predicted, self.free_table)

    def settled(self, frames, predicted, *, pressed: bool = True) -> Any:
        """At the end of a slide, the arm at rest: frames (``frames()`` gives the next ``(depth, tip)``)
        until two in a row agree (a single frame's fit can be a wrong one, and the grasp is made where
        the object is seen). The pose last seen during the slide, carried to the end, counts as the
        first of the two. When no fit puts the object under the fingertip (a push took it from under the
        finger), as many frames again without that test; ``pressed=False`` (the finger lifted clear):
        only those."""
        frame, tip = frames()
        carried = self.carried_last(tip)
        seen = self.look(frame, tip, predicted, under_tip=pressed)
        if seen.ok and carried is not None and self.agree(carried, seen.motion):
            return seen
        for under_tip in (True, False)[0 if pressed else 1:]:
            for _ in range(END_LOOKS - 1 if under_tip else END_LOOKS):
                again = self.look(*frames(), predicted, under_tip=under_tip)
                if seen.ok and again.ok and self.agree(seen.motion, again.motion):
                    return again
                seen = again
            if seen.reason != NOT_UNDER_TIP:
                break
        return dataclasses.replace(seen, ok=False, reason=f"no two of {END_LOOKS} frames agree") if seen.ok else seen

    def drifted(self, seen, predicted, segment: Segment, tip: np.ndarray) -> bool:
        """Whether a look during a slide asks for a new plan: off the prediction in CONFIRM looks in a row
        that agree with each other, the earlier carried by the fingertip's motion since (one look's
        error alone is mostly the tracker's, with the arm hiding much of the object), and the rest of the slide would not end graspable from there (re-planning
        on the tracker's own error restarts the slide from rest again and again)."""
        if self.agree(seen.motion, predicted, 1.0):
            self._beyond.clear()
        else:
            # The finger carries the object between looks (a centimetre in 0.2 s): compare the last look
            # carried to this one's fingertip.
            if self._beyond and not self.agree(self.carried(*self._beyond[-1][:2], tip), seen.motion):
                self._beyond.clear()
            self._beyond.append((seen.motion, tip, self.looks - 1))
        if len(self._beyond) < CONFIRM:
            return False
        if segment.still_works(self.perceived, self.scene.table, self.replan_config, tip, seen.motion, self.threshold[0]):
            self.kept += 1
            return False
        return True

    def replan(self, trigger: str, elapsed: float, frames, predicted, start_config: np.ndarray, *,
               segment: Segment | None = None, tip: np.ndarray | None = None,
               start_tip: np.ndarray | None = None) -> tuple[PlanResult | None, Replan | None, Any]:
        """One look that may lead to a new plan.

        Args:
            trigger: ``"drift"`` (a look during the slide ``segment``, the fingertip commanded at ``tip``),
                ``"end"`` (the settled look after a slide), ``"clear"`` (the same with the finger lifted
                clear of the object, after an end look that did not see it) or ``"blind"`` (lifted clear
                where the slide ``segment``, not seen for ``BLIND_S``, stopped with the fingertip at
                ``tip``: where its rest still works from the pose seen, or nothing is seen, no new plan and
                the event's outcome ``"kept"``) or ``"search"`` (as ``"clear"``, ``predicted`` where the whole
                table's frame shows the object, after a clear look that lost it).
            elapsed: time into the slide, for the event (s).
            frames: gives the next ``(depth, measured fingertip pose)``.
            predicted: where Eq. 2 puts the object now (motion from its perceived pose).
            start_config: the arm's configuration to plan from.
            start_tip: its fingertip pose when it is later than the look's (``tip``): a moving arm goes
                on while the loop plans, and the object as seen is carried there by Eq. 2; None: the same.

        Returns:
            (the new plan or None, the event or None (a drift look that asks for nothing), the look).
        """
        sensed = [0.0]  # the time spent getting frames, kept out of the tracking time

        def timed_frames():
            begun = time.perf_counter()
            try:
                return frames()
            finally:
                sensed[0] += time.perf_counter() - begun

        started, first_frame = time.perf_counter(), self.looks
        if trigger in ("end", "clear", "blind", "search"):
            seen = self.settled(timed_frames, predicted, pressed=trigger == "end")
        else:
            seen = self.look(*timed_frames(), predicted)
        tracked = time.perf_counter()
        error_m, error_yaw = self.error(seen.motion, predicted)
        event = Replan(elapsed, trigger, error_m, math.degrees(error_yaw), tracked - started - sensed[0], 0.0, "lost",
                       seen.reason, sensed[0], list(range(first_frame, self.looks)))
        if trigger == "blind" and (not seen.ok or segment.still_works(self.perceived, self.scene.table, self.replan_config, tip,
                                                                      seen.motion, self.threshold[0])):
            # On track, or not seen even from above: the rest of the slide goes on as it would have.
            self.kept += 1
            event.outcome, event.detail = "kept", ("" if seen.ok else f"not seen ({seen.reason})")
            return None, event, (seen if seen.ok else dataclasses.replace(seen, motion=tuple(predicted)))
        if not seen.ok:
            return None, (event if trigger != "drift" else None), seen
        if trigger == "drift" and not self.drifted(seen, predicted, segment, tip):
            return None, None, seen
        if trigger == "drift":
            event.frames = [frame for _, _, frame in self._beyond]
        self._beyond.clear()
        motion = seen.motion if start_tip is None else compose_planar(seen.motion, planar_motion(tip, start_tip))
        try:
            again = plan(self.scene, self.perceived.moved(motion), self.replan_config, start_config=start_config)
        except InputError as error:
            event.plan_s, event.outcome, event.detail = time.perf_counter() - tracked, "refused", error.problem
            return None, event, seen
        event.plan_s = time.perf_counter() - tracked
        if not again.solved:
            event.outcome = "timeout"
            return None, event, seen
        event.outcome, event.detail = ("grasp" if len(again.trajectory) == 1 else "slide"), ""
        return again, event, dataclasses.replace(seen, motion=motion)


@dataclass
class Stop:
    """Where a look during a slide leaves it (:meth:`SlideLoop.look`).

    Attributes:
        plan: the new plan a confirmed drift asks for, followed from ``config``; None: the arm stops at
            ``config``, for ``reason``.
        motion: where the object was seen (motion from its perceived pose); None when blind.
        config: the configuration the new plan starts from, or the arm stops at.
        at_s: its time into the slide (s).
        reason: why a stop without a plan: ``"blind"`` (no look has seen the object for ``BLIND_S``: it
            looks from above) or ``"no_progress"`` (:class:`~slideplan.bounds.Progress`: the slide ends there,
            looked at as at its end).
    """

    plan: PlanResult | None
    motion: tuple | None
    config: np.ndarray
    at_s: float
    reason: str = "blind"


class Arm(Protocol):
    """What drives the arm for a :class:`SlideLoop`: the MuJoCo runner of :func:`run` or the ROS node's
    controller (:mod:`slideplan.ros.serve`)."""

    def slide(self, segment: Segment, look: Callable[..., Stop | None] | None) -> Stop | None:
        """Follow ``segment`` to its end; with a ``look`` (:meth:`SlideLoop.look`), call it at each new
        frame, and leave the slide at the first :class:`Stop` it returns (returned)."""

    def stop(self, stop: Stop) -> None:
        """Bring the arm to rest at ``stop.config`` (a blind stop)."""

    def switch(self, stop: Stop) -> None:
        """Go on with ``stop.plan`` from ``stop.config`` (a one-configuration plan: rest there)."""

    def move(self, result: PlanResult, path: np.ndarray, phase: str) -> None:
        """Move along ``path`` from rest to rest under ``result``'s limits: ``"clear"`` (to look from clear
        of the object and back, the fingertip's speed capped) or ``"reach"`` (to a new slide's first contact)."""

    def frames(self) -> Callable[[], tuple[np.ndarray, np.ndarray]]:
        """What gives the next (depth image, measured fingertip pose) with the arm at rest."""

    def clock(self) -> float:
        """Time since the slide started (s)."""

    def record(self, event: Replan) -> None:
        """A look that asked for a plan, its outcome known."""

    def replanned(self, trigger: str, outcome: str, replans: int) -> None:
        """A new plan is followed (``replans`` so far)."""


class SlideLoop:
    """The closed loop's decisions over a slide, whatever drives the arm (:func:`run` in MuJoCo, the ROS
    node): a confirmed drift switches to a new plan; a slide blind for ``BLIND_S`` stops to look from
    above; the end of a slide is looked at (from ``CLEAR_LIFT_M`` above when the arm hides the object) and
    slid on, grasped, or slid anew from a new contact when the object was pushed from under the finger.

    Args:
        watch: the judge of the frames; None: open loop (the slide as planned, no look).
        robot: the core robot model.
        top: the object's top surface height (m).
        end_replans: slides re-planned at most this many times after a slide ends (and blind stops at most
            this many).
        arm: what moves the arm (:class:`Arm`).

    Attributes:
        replans: new plans followed.
        stops: the bounds met (:mod:`slideplan.bounds`), each once, in order: ``"no_progress"``,
            ``"replan_cap"``, ``"time_cap"``; :attr:`stopped` joins them with ``+`` ("" for none).
        seen: whether the object's motion :meth:`run` returned was seen (else predicted), and
        seen_frames: the frames of the look it came from.
        abandoned: the slide stopped for no progress and no new plan followed: no grasp is made.
    """

    def __init__(self, watch: Watch | None, robot, top: float, end_replans: int, arm: Arm) -> None:
        self.watch, self.robot, self.top, self.end_replans, self.arm = watch, robot, top, end_replans, arm
        self.replans = self.ends = self.blinds = 0
        self.unseen = Unseen()
        self.progress = Progress()
        self.segment: Segment | None = None
        self.stops: list[str] = []
        self.seen, self.seen_frames, self.abandoned = False, [], False

    @property
    def stopped(self) -> str:
        return "+".join(self.stops)

    def _met(self, bound: str) -> None:
        if bound not in self.stops:
            self.stops.append(bound)

    def capped(self) -> bool:
        """Whether a cap ends the re-planning now (recorded in :attr:`stops`)."""
        for bound, met in (("replan_cap", self.replans >= MAX_REPLANS), ("time_cap", self.arm.clock() >= MAX_SLIDE_S)):
            if met:
                self._met(bound)
                return True
        return False

    def look(self, frames, stamp: float, tip: np.ndarray, config: np.ndarray, at_s: float,
             start_tip: np.ndarray | None = None) -> Stop | None:
        """A look during the slide, the frame taken at ``stamp`` (s, :meth:`Arm.clock`) with the fingertip
        commanded at ``tip`` (4, 4); a new plan would start from ``config``, ``at_s`` into the slide (its
        fingertip ``start_tip`` when later than the look's). Returns where to leave the slide, or None."""
        segment = self.segment
        if self.capped():  # no new plan: the slide goes on to its end, then its own grasp
            return None
        again, event, seen = self.watch.replan("drift", stamp, frames, segment.predicted(tip), config, segment=segment,
                                               tip=tip, start_tip=start_tip)
        if event is not None:
            self.arm.record(event)
        if again is None and self.progress.update(np.asarray(tip)[:2, 3], seen.motion if seen.ok else None):
            self._met("no_progress")
            return Stop(None, seen.motion, config, at_s, "no_progress")
        if again is None:
            if (self.unseen.update(seen.ok, stamp) < BLIND_S or segment.times[-1] - at_s < BLIND_S
                    or max(self.ends, self.blinds) >= self.end_replans):
                return None
            return Stop(None, None, config, at_s)
        self.unseen.update(True, stamp)
        self.seen_frames = event.frames
        return Stop(again, seen.motion, config, at_s)

    def run(self, result: PlanResult) -> tuple[PlanResult, tuple]:
        """Slide along ``result`` and whatever the looks ask for. Returns the plan whose grasp is made, and
        the object's motion from its perceived pose then: where the last deciding look saw it (:attr:`seen`
        True, its frames :attr:`seen_frames`), or its best guess when that look did not see it (the
        prediction or the last pose seen carried on: :attr:`seen` False), or where Eq. 2 puts it when no
        look decided (open loop, or a bound reached: :attr:`seen` None)."""
        robot, arm, watch = self.robot, self.arm, self.watch
        segment = slide_segment(result, self.top, (0.0, 0.0, 0.0))
        self.seen, self.seen_frames = None, []
        while True:
            self.segment = segment
            self.progress.reset()
            stop = arm.slide(segment, None if watch is None else self.look)
            if stop is not None and stop.plan is not None:
                self.replans += 1
                arm.replanned("drift", "grasp" if len(stop.plan.trajectory) == 1 else "slide", self.replans)
                arm.switch(stop)
                if len(stop.plan.trajectory) == 1:  # already graspable where it was seen: the slide ends here
                    self.seen = True
                    return stop.plan, stop.motion
                segment = slide_segment(stop.plan, self.top, stop.motion)
                continue
            blind = stop is not None and stop.reason == "blind"
            end_config, end_s = (stop.config, stop.at_s) if stop is not None else (np.asarray(segment.result.trajectory)[-1], float(segment.times[-1]))
            predicted = segment.predicted(np.asarray(robot.fk(end_config)))
            if watch is None or self.capped():
                self.seen, self.seen_frames = None, []
                return segment.result, predicted
            if stop is not None:  # blind, or no progress: the slide ends where the arm stops
                self.blinds += blind
                arm.stop(stop)
            lifted, trigger = (self.clear_way(segment.result, end_config, predicted), "blind") if blind else (None, "clear")
            if lifted is None:
                again, event, seen = watch.replan("end", arm.clock(), arm.frames(), predicted, end_config)
                arm.record(event)
                lifted = self.clear_way(segment.result, end_config, predicted) if event.outcome == "lost" else None
            if lifted is not None:  # the arm hides the object: the finger moves clear, looks and comes back
                arm.move(segment.result, lifted, "clear")
                again, event, seen = watch.replan(trigger, arm.clock(), arm.frames(), predicted, end_config,
                                                  segment=segment, tip=np.asarray(robot.fk(end_config)))
                arm.record(event)
                if event.outcome == "lost" and (found := watch.locate(arm.frames(), predicted)) is not None:
                    # Not near where it was expected even from clear (pushed away, or left behind by a pad
                    # that slipped over it): the whole table is searched, and a new contact slides it on.
                    searched = watch.replan("search", arm.clock(), arm.frames(), found, end_config)
                    arm.record(searched[1])
                    if searched[1].outcome != "lost":  # else the pose Eq. 2 predicts stays the best guess
                        again, event, seen = searched
                arm.move(segment.result, lifted[::-1], "clear")
            self.unseen.update(True, arm.clock())
            outcome = event.outcome
            if again is None and outcome == "refused" and self.ends < self.end_replans:
                again, outcome = self.new_contact(seen.motion, end_config), "new_contact"  # pushed from under the finger
            replanned = again is not None
            if blind and not replanned:  # on track, not seen or no new plan: the rest of the slide, from rest
                again = segment.rest(robot, end_s, end_config)
            self.seen, self.seen_frames = bool(seen.ok), event.frames
            if again is None or self.ends >= self.end_replans:
                # Its own grasp, from where Eq. 2 put the object; none after no progress (the arm is mid-slide).
                self.abandoned = stop is not None and stop.reason == "no_progress"
                return segment.result, seen.motion
            if replanned:
                self.replans += 1
                arm.replanned("blind" if blind else "end", outcome, self.replans)
            if len(again.trajectory) == 1:
                return again, seen.motion
            self.ends += replanned
            segment = slide_segment(again, self.top, seen.motion)

    def clear_way(self, result: PlanResult, config: np.ndarray, motion) -> np.ndarray | None:
        """Where the finger goes from ``config`` to look when the hand hides the object (at ``motion``) from
        the camera: ``CLEAR_LIFT_M`` straight up; where the arm still hides more than ``HIDDEN_SHARE`` of the
        object from there (a camera behind the arm sees past the hand but not the forearm), on
        ``CLEAR_ASIDE_M`` across in whichever of 8 directions hides least, clear of the table, clutter and
        object. None without inverse kinematics straight up."""
        up = straight_up(self.robot, config, CLEAR_LIFT_M)
        if up is None:
            return None
        obj = self.watch.perceived.moved(motion)
        world = collision_world(result, obj)
        eye, points = np.asarray(self.watch.tracker.camera.position, dtype=float), obj.points[
            np.linspace(0, len(obj.points) - 1, SIGHT_LINES).round().astype(int)]

        def hidden(joints: np.ndarray) -> int:
            return int(np.sum(world.hidden_lines(joints, eye, points, SIGHT_RADIUS_M)))

        best, most = up, hidden(up[-1])
        if most <= HIDDEN_SHARE * SIGHT_LINES:
            return up
        for angle in np.arange(8) * (math.pi / 4):
            aside = straight_line(self.robot, up[-1], CLEAR_ASIDE_M * np.array([math.cos(angle), math.sin(angle), 0.0]))
            if aside is None or (count := hidden(aside[-1])) >= most:
                continue
            if all(world.is_valid(joints, _core.ContactMode.FREE) for joints in dense(list(aside))):
                best, most = np.vstack([up, aside[1:]]), count
        return best

    def touch(self, seen: ThinObject, config: np.ndarray) -> PlanResult:
        """A plan for the object ``seen`` partly over an edge, the finger off it (it slid on ahead of the
        finger): the planner takes such an object only from a state, so the state is the finger set down on
        it, turned and pressed as at ``config``, at the object's point nearest its centre; from there the
        plan is the grasp where the object already overhangs enough, or else the rest of the slide.

        Raises:
            Unreachable: no inverse kinematics puts the finger there.
            InputError: that configuration is not a valid contact (``start_config``: why).
        """
        points = seen.points[:, :2]
        point = points[np.argmin(np.linalg.norm(points - seen.centroid_xy, axis=1))]
        target = np.asarray(self.robot.fk(config))
        target[:2, 3] = point
        on = self.robot.ik(target, seed=config, rng_seed=0, options=_core.contact_ik_options(self.robot))
        if on is None:
            raise Unreachable(f"no inverse kinematics puts the finger on the object at ({point[0]:.3f}, {point[1]:.3f})")
        return plan(self.watch.scene, seen, self.watch.replan_config, start_config=on)

    def new_contact(self, motion, config: np.ndarray) -> PlanResult | None:
        """A whole new slide for the object seen at ``motion`` (verified) and the reach to its first contact
        from ``config`` (the finger lifted off first, every link checked), followed; None when there is none
        (the event says why)."""
        from .verify import verify

        watch, started = self.watch, time.perf_counter()
        event = Replan(self.arm.clock(), "new_contact", 0.0, 0.0, 0.0, 0.0, "refused")
        seen = watch.perceived.moved(motion)
        fresh = reach = None
        try:
            fresh = (plan(watch.scene, seen, watch.replan_config) if watch.scene.table.polygon.contains(seen.outline)
                     else self.touch(seen, config))
            checked = verify(fresh) if fresh.solved else None
            if checked is not None and not checked.ok:
                event.detail = f"the new plan fails verification: {checked.violations[0]}"
            elif checked is not None:
                reach = reach_path(fresh, seen, config, pressed=True)
        except (InputError, Unreachable) as error:  # e.g. pushed mostly off the table: no slide from there
            event.detail = error.problem if isinstance(error, InputError) else str(error)
        event.plan_s = time.perf_counter() - started
        if fresh is not None and not fresh.solved:
            event.outcome = "timeout"
        elif reach is not None:
            event.outcome = "grasp" if len(fresh.trajectory) == 1 else "slide"
        self.arm.record(event)
        if reach is None:
            return None
        self.arm.move(fresh, reach, "reach")
        return fresh


class _Simulated:
    """The :class:`Arm` of :func:`run`: MuJoCo's servos (:class:`~slideplan.execute.runner.Runner`), a look
    every ``period`` of simulated time, the frames rendered; ``on_step(clock)`` before each step (the
    disturbance)."""

    def __init__(self, runner: Runner, robot, settings: ExecutionSettings, frames, events: list, period: float,
                 on_step: Callable[[float], None]) -> None:
        self.runner, self.robot, self.settings, self._frames = runner, robot, settings, frames
        self.events, self.period, self.on_step = events, period, on_step
        self.started = float(runner.built.data.time)

    def clock(self) -> float:
        return float(self.runner.built.data.time) - self.started

    def slide(self, segment: Segment, look) -> Stop | None:
        runner, path = self.runner, np.asarray(segment.result.trajectory)
        stops: list[Stop] = []
        next_look = [self.clock() + self.period]

        def during(elapsed: float, step: int) -> bool:
            now = self.clock()
            self.on_step(now)
            if look is None or now < next_look[0] or elapsed >= segment.times[-1]:
                return False
            next_look[0] += self.period
            config = runner.commanded(path, segment.times, elapsed)  # where the servos' reference is: no jump
            stop = look(self._frames, now, np.asarray(self.robot.fk(config)), config, elapsed)
            if stop is not None:
                stops.append(stop)
            return stop is not None

        runner.slide(path, segment.times, segment.depths, SETTLE_S, during)
        return stops[0] if stops else None

    def stop(self, stop: Stop) -> None:
        self.runner.follow(stop.config[None, :], np.zeros(1), SETTLE_S)

    def switch(self, stop: Stop) -> None:
        """Nothing to do: the new plan starts at the servos' reference."""

    def move(self, result: PlanResult, path: np.ndarray, phase: str) -> None:
        if phase == "reach":  # under the new plan's own limits, as a reach to a first contact
            way = timed_way(self.robot, path, result.timing["limits"], phase, capped=False)
        else:
            way = timed_way(self.robot, path, resolve_limits(result, timing_options(self.settings, self.robot.velocity_limits)), phase)
        self.runner.follow(*way, SETTLE_S)

    def frames(self):
        return self._frames

    def record(self, event: Replan) -> None:
        self.events.append(event)

    def replanned(self, trigger: str, outcome: str, replans: int) -> None:
        """Nothing to say: the report has the loop's count and the events."""


def run(
    scene: Scene | str | Path,
    object_name: str | Path,
    pose,
    *,
    seed: int = 1,
    closed: bool = True,
    setting: str = "nominal",
    disturbance: Disturbance | None = None,
    config: PlannerConfig | None = None,
    camera: Camera | None = None,
    replan_period: float = 0.1,
    threshold: tuple[float, float] = (0.003, math.radians(2.0)),
    replan_time_limit: float = 1.0,
    end_replans: int = 3,
    video: str | Path | None = None,
    video_fps: int = 20,
    progress=None,
) -> ClosedLoopRun:
    """Perceive, plan, slide (re-planning when the object drifts, if ``closed``), grasp and lift in MuJoCo.

    Args:
        scene: a :class:`~slideplan.scenes.Scene`, a built-in scene name or a scene TOML.
        object_name: the object's outline (a name in ``data/objects`` or a TOML path).
        pose: (x, y, yaw) where the object really lies (m, m, rad).
        seed: seeds the camera's noise, perception, the planner and the random and hard settings' draws.
        closed: re-plan from what the camera sees (True) or execute the first plan blind (False).
        setting: ``"nominal"``, ``"stress"`` (torsional friction halved, the finger at ``dz_min``),
            ``"random"`` (frictions, mass and depth noise drawn per run: :data:`RANDOM_RANGES`) or ``"hard"``
            (issue 53's: :mod:`slideplan.closed_loop_settings`).
        disturbance: move the object during the slide (a test hook and a demo; in the hard setting, in
            place of its own push), or None.
        config: planner parameters (default: the scene's hand, ``seed``).
        camera: the fixed depth camera (default :func:`default_camera`): where the planner and the tracker
            believe it is (the hard setting mounts it off there: :func:`camera_as_mounted`).
        replan_period: simulated time between looks (s).
        threshold: (m, rad) a seen pose further than this from the predicted one asks for a re-plan.
        replan_time_limit: planning time limit of each re-plan (s).
        end_replans: slides re-planned at most this many times after the first slide ends.
        video: write a rendering of the run here (``.mp4``, ``.gif``, or ``.png``: a strip of 6 frames).
        video_fps: frames per simulated second.
        progress: called with the simulated time (s) every simulated tenth of a second, or None.

    Returns:
        The report, judged by the world (:mod:`slideplan.verdict`). A run that cannot plan at first, or
        whose simulation goes unstable, is a report with that ``failed_stage``.

    Raises:
        InputError: an unknown setting, a pose that is not 3 numbers or puts the object off the table,
            a disturbance after a negative time, a non-positive period, threshold or limit, or a scene
            or object that cannot be read (each naming the field).
    """
    wall_start = time.perf_counter()
    draws = setting_draws(setting, seed)
    pose = tuple(float(value) for value in as_numbers(pose, 3, source="", field="--pose"))
    for name, value in (("replan_period", replan_period), ("replan_time_limit", replan_time_limit)):
        if not (isinstance(value, (int, float)) and math.isfinite(value) and value > 0):
            raise InputError(f"must be a positive number of seconds, got {value!r}", field=name)
    threshold = as_numbers(threshold, 2, source="", field="threshold")
    if not np.all(threshold > 0):
        raise InputError(f"expected (m, rad), both > 0, got {tuple(threshold)}", field="threshold")
    if disturbance is not None:
        as_numbers([disturbance.dx, disturbance.dy, disturbance.dyaw, disturbance.after_s], 4, source="", field="--disturb")
        if disturbance.after_s < 0:
            raise InputError(f"the time must be >= 0 s after the slide starts, got {disturbance.after_s}", field="--disturb")
    scene = scene if isinstance(scene, Scene) else load_scene(scene)
    config = config or PlannerConfig.for_scene(scene, seed=seed)
    camera = camera or default_camera(scene)
    truth = load_object(object_name, table_height=scene.table.height, pose=pose)
    if not scene.table.polygon.contains(truth.outline):
        raise InputError(f"the object at {pose} is not wholly on the table", field="--pose")
    os.environ.setdefault("MUJOCO_GL", "egl")
    mounted = camera_as_mounted(camera, draws)
    perceived = _perceived_object(scene, object_name, camera, pose, draws["depth_noise_at_1m"], seed, mounted)

    mode = "closed" if closed else "open"
    report: dict[str, Any] = dict(
        success=False, mode=mode, setting=setting, failed_stage=None, failure="", replans=0, replan_latency_s=None,
        kept=0, looks=0, lost_looks=0, events=[], seen_status=None, seen_frames=[], seen_motion=None, seen_overhang_m=None,
        seen_com_margin_m=None, true_overhang_m=None, true_com_margin_m=None, lifted=False, slide_stop="", slide_s=0.0,
        draws=draws, disturbance=None if disturbance is None else dataclasses.asdict(disturbance),
    )
    first = plan(scene, perceived, config)
    if not first.solved:
        return ClosedLoopRun(**{**report, "failed_stage": "plan", "failure": f"no plan for the object as perceived "
                                f"({first.status})"}, sim_time_s=0.0, wall_time_s=time.perf_counter() - wall_start)

    top = scene.table.height + perceived.thickness
    segment = slide_segment(first, top, (0.0, 0.0, 0.0))
    slide_s = float(segment.times[-1])
    if disturbance is not None and disturbance.after_s > slide_s:
        raise InputError(f"{disturbance.after_s} s is after the planned slide ends ({slide_s:.2f} s)", field="--disturb")
    import mujoco

    settings = execution_settings(setting, draws, float(first.params["dz_min"]))
    built = build_model(first, settings, world_object=truth, camera=mounted)
    model, data = built.model, built.data
    depth_renderer = mujoco.Renderer(model, camera.height, camera.width)
    depth_renderer.enable_depth_rendering()
    noise_rng = np.random.default_rng([seed, 1])
    robot = build_robot(first.robot)
    recorder = Recorder(model, data, video, video_fps, (480, 640), plan_points(first, robot), progress=progress)
    runner = Runner(built, settings, recorder.after_step if recorder.active else None)

    watch = Watch(scene, perceived, config, camera, threshold, replan_time_limit)

    def frames() -> tuple[np.ndarray, np.ndarray]:
        """A new depth frame and the fingertip's measured pose."""
        frame = noisy_depth(camera_depth(depth_renderer, model, data, DEPTH_CAMERA), draws["depth_noise_at_1m"],
                            DEPTH_DROPOUT, noise_rng)
        return frame, np.asarray(robot.fk(data.qpos[built.arm_qpos]))

    pending = [disturbance]
    if disturbance is None and draws.get("push"):
        pending = [push_candidates(int(draws["push_seed"]), draws["push_fraction"] * slide_s)]

    def on_step(now: float) -> None:
        if pending[0] is None:
            return
        after_s = pending[0][0].after_s if isinstance(pending[0], list) else pending[0].after_s
        if now >= after_s:
            push = pending[0]
            if isinstance(push, list):  # the hard setting's: redrawn while it would leave the CoM near an edge
                push = hard_push(push, scene.table, runner.object_pose()[0])
                report["disturbance"] = None if push is None else dataclasses.asdict(push)
            if push is not None:
                push.apply(built)
            pending[0] = None

    runner.press(first.trajectory[0], segment.depths[0])
    loop = SlideLoop(watch if closed else None, robot, top, end_replans,
                     _Simulated(runner, robot, settings, frames, report["events"], replan_period, on_step))
    try:
        grasp_plan, seen_motion = loop.run(first)
        report["slide_s"] = loop.arm.clock()
        seen, seen_frames = loop.seen, loop.seen_frames
        if seen is None:  # no look decided (open loop, or a bound): one look for the diagnostics, as the closed loop's end look
            first_frame = watch.looks
            look = watch.settled(frames, seen_motion)
            seen, seen_frames, seen_motion = look.ok, list(range(first_frame, watch.looks)), look.motion
        _diagnose(report, scene.table, perceived, truth, seen_motion, seen, seen_frames, runner)
        if loop.abandoned:
            failure = ("slide", "no progress: the finger travelled on and the object did not, and no new plan followed")
        else:
            failure = runner.grasp(np.asarray(grasp_plan.grasp["approach"], dtype=float),
                                   _times(grasp_plan, "approach", len(grasp_plan.grasp["approach"])),
                                   np.asarray(grasp_plan.grasp["config"], dtype=float), robot,
                                   resolve_limits(grasp_plan, timing_options(settings, robot.velocity_limits)), top,
                                   scene.table.height + truth.thickness / 2)
        report["lifted"] = runner.lifted
        hold = Hold.from_samples(runner.hold, settings.hold_s) if runner.hold else None
        _, report["failed_stage"], report["failure"] = judge(hold, scene.table.height, failure)
    except Unstable as error:
        report.update(failed_stage="simulation", failure=str(error), lifted=False)
    finally:
        report.update(replans=loop.replans, looks=watch.looks, lost_looks=watch.lost_looks, kept=watch.kept,
                      slide_stop=loop.stopped)
        recorder.close()
        depth_renderer.close()
    planned = [event.latency_s for event in report["events"] if event.outcome in ("slide", "grasp", "refused", "timeout")]
    report["replan_latency_s"] = float(np.median(planned)) if planned else None
    report["success"] = report["failed_stage"] is None
    recorder.write()
    return ClosedLoopRun(**report, sim_time_s=float(data.time), wall_time_s=time.perf_counter() - wall_start)
