"""What the closed loop makes of the camera's frames (:class:`Watch`), for the MuJoCo harness
(:func:`slideplan.sim.closed_loop.run`) and the ROS node alike: the object tracked in each frame from where
Eq. 2 predicts it (:class:`Segment`, the slide being followed) and from where it was last seen, a drift
confirmed over ``CONFIRM`` looks in a row, the settled look at the end of a slide, and a re-plan from the
arm's state with the object where it was seen (each look that asked for one: :class:`Replan`).

No physics here: the frames come from whatever camera the caller has; :mod:`slideplan.loop.decisions` decides
what the arm does with the looks.
"""

from __future__ import annotations

import dataclasses
import math
import time
from dataclasses import dataclass
from typing import Any

import numpy as np
import shapely

from ..perception.camera import Camera
from ..errors import InputError
from ..world.geometry import Ending, support_margin
from ..plan.motions import plan_times, rest_to_rest
from ..world.objects import ThinObject
from ..checks.pipeline import plan_checked
from ..checks.verify import start_contact
from ..plan.config import PlannerConfig
from ..plan.result import PlanResult
from ..world.scenes import Scene
from ..perception.tracking import NOT_UNDER_TIP, Tracker
from ..transforms import compose_planar, move_planar, planar_motion, pose_to_row, rotation_2d, row_to_pose, wrap_angle

CONFIRM = 2  # looks in a row off the predicted pose, agreeing with each other, that make a drift
AGREE = 3.0  # two looks agree within this many thresholds
END_LOOKS = 4  # frames at most at the end of a slide for two in a row that agree
OBSTACLE_MARGIN = 0.01  # a search of the table keeps this far from an obstacle's footprint (its sides, depth noise)
FINGER_SNAP_M = 0.01  # the pressing finger moves a seen pose at most this far onto itself (Watch.on_finger)
START_INSIDE_M = 0.001  # ... onto the object this far inside its hull (the planner's start test)
START_NEAR_SHARE = 0.9  # ... and this share of the verifier's tolerance from one of its points
SLIP_DEPTH_SHARE = 4  # after a slip, plans press in the deepest quarter of the finger's contact-depth band


@dataclass
class Replan:
    """One look at the object that asked for a new plan.

    Attributes:
        time_s: simulated time since the slide started (s).
        trigger: ``"drift"`` (off the predicted pose during a slide), ``"end"`` (a slide ended) or
            ``"clear"`` (the look after an end look that did not see the object, the finger lifted clear)
            or ``"blind"`` (the same when no look had seen the object for :data:`~slideplan.loop.decisions.BLIND_S` of a slide, which
            stopped there), or ``"confirm"`` (the same where a drift had found the object graspable during
            the slide, which stopped there), or ``"search"`` (after a clear look that did not see the object: the whole
            table's frame searched for it), or ``"new_contact"`` (after a look that found the fingertip off the object:
            a whole new slide, reached from where the finger is).
        position_error_m, yaw_error_deg: how far the seen pose was from the predicted one.
        track_s, plan_s: wall time of tracking and of planning with timing (s).
        sense_s: wall time the frames took to arrive (s): in simulation MuJoCo's rendering of the depth
            camera, which a real camera does on its own; not part of the latency.
        outcome: ``"slide"`` (a new slide followed), ``"grasp"`` (grasped from there), ``"refused"``,
            ``"timeout"`` or ``"lost"`` (the frame did not show the object); the last three keep the
            plan there was; ``"kept"`` (a blind or confirm look: the rest of the stopped slide still works
            from the pose seen, or, blind, nothing was seen). After such a look without a new plan the
            rest of the stopped slide goes on, from rest.
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
        timing = dict(self.result.timing)
        timing["trajectory"] = rest_to_rest(robot, configs, timing["limits"], "trajectory")
        rows = np.vstack([pose_to_row(np.asarray(robot.fk(configs[0])))[None, :], np.asarray(self.result.fingertip_poses)[after]])
        return dataclasses.replace(self.result, trajectory=configs, fingertip_poses=rows, start_config=configs[0], timing=timing)

    def still_works(self, perceived: ThinObject, table, config: PlannerConfig, tip: np.ndarray, seen) -> bool:
        """Whether the rest of this slide still ends graspable from where the object is seen: carried
        from there by Eq. 2 to the plan's last contact, it overhangs by ``u*`` and keeps its centre of
        mass ``com_margin`` inside the table (a slide that ends short as seen then is slid on from its
        end), and the fingertip is on the object as seen. On it as the planner takes a start (inside the
        hull): with the tracker's error as a margin inside it, a finger near the object's edge asked for a
        re-plan that started from the same contact, again and again (20 re-plans on one nominal slide)."""
        now = perceived.moved(seen)
        if not shapely.MultiPoint(now.points[:, :2]).convex_hull.contains(shapely.Point(tip[:2, 3])):
            return False
        end = perceived.moved(compose_planar(seen, planar_motion(tip, row_to_pose(self.result.fingertip_poses[-1]))))
        if not Ending.at(table, end.points[:, :2], end.centroid_xy).graspable(config.u_star, config.com_margin):
            return False
        return not config.support_hull or support_margin(table, end.points[:, :2], end.centroid_xy) >= config.support_margin


def slide_segment(result: PlanResult, top: float, base) -> Segment:
    """A plan to follow, from where the object was seen (``base``) when it was made."""
    return Segment(result, plan_times(result, "trajectory", len(result.trajectory)),
                    top - np.asarray(result.fingertip_poses)[:, 2], tuple(float(value) for value in base))


def pose_error(obj: ThinObject, first, second) -> tuple[float, float]:
    """Distance (m) between the object's centre of mass under two motions, and their yaw difference (rad)
    less the nearest turn that leaves the footprint as it was (a disc's yaw is no error)."""
    com = np.asarray(obj.centroid_xy, dtype=float)[None, :]
    turn = wrap_angle(float(first[2]) - float(second[2]))
    unseen = (turn - obj.symmetry_turns + math.pi) % (2 * math.pi) - math.pi
    return (float(np.linalg.norm(move_planar(com, first) - move_planar(com, second))),
            float(unseen[np.argmin(np.abs(unseen))]))


class Watch:
    """What the closed loop makes of the camera's frames, for :func:`slideplan.sim.closed_loop.run` and the
    ROS node alike: tracking from the predicted and from the last seen pose, a drift confirmed over
    ``CONFIRM`` looks, the settled look at the end of a slide, and a re-plan from the arm's state with the
    object where it was seen.

    Args:
        scene: the scene planned in.
        perceived: the object as perceived before the slide (every motion is from its pose).
        config: planner parameters; re-plans use ``replan_time_limit``.
        camera: the fixed depth camera the frames come from.
        threshold: (m, rad) a seen pose further than this from the predicted one is off it.
        replan_time_limit: planning time limit of each re-plan (s).
        table_plane: the table top as the camera sees it (``z = a x + b y + c``, from the perception before
            the slide), or None for the scene's level table (:class:`slideplan.perception.tracking.Tracker`).

    Attributes:
        looks, lost_looks: frames tracked, and of them those that did not show the object.
        kept: confirmed drifts after which the rest of the slide still ended graspable.
    """

    def __init__(self, scene: Scene, perceived: ThinObject, config: PlannerConfig, camera: Camera,
                 threshold, replan_time_limit: float, table_plane=None) -> None:
        self.scene, self.perceived, self.threshold = scene, perceived, threshold
        self.replan_config = dataclasses.replace(config, time_limit_s=replan_time_limit)
        self._band = (config.dz_min, config.dz_max)  # the finger's contact-depth band (m), before any slip
        self.tracker = Tracker(perceived, camera, table_height=scene.table.height, table_plane=table_plane)
        # The sides of an obstacle rise through the object's height: a search of the table leaves them out.
        obstacles = scene.footprints(scene.table.height + perceived.thickness + self.tracker.hand_clearance)
        self.free_table = scene.table.polygon if obstacles is None else scene.table.polygon.difference(
            obstacles.buffer(OBSTACLE_MARGIN))
        perceived.symmetry_turns  # computed once, before the first look's latency
        # Where a re-plan may start, in the perceived frame: inside the hull of the points (the planner's test)
        # and near one of them (the verifier's), each with a margin.
        points = np.asarray(perceived.points, dtype=float)[:, :2]
        tolerance = start_contact(points, points[0])[1]
        self._start_region = shapely.MultiPoint(points).convex_hull.buffer(-START_INSIDE_M).intersection(
            shapely.MultiPoint(points).buffer(START_NEAR_SHARE * tolerance))
        shapely.prepare(self._start_region)
        self.looks = self.lost_looks = self.kept = 0
        self._last: tuple | None = None  # (motion seen, fingertip pose then) of the last look that found the object
        self._beyond: list = []  # (pose seen, fingertip pose, frame) of the looks in a row off the predicted pose

    def error(self, first, second) -> tuple[float, float]:
        """Distance (m) between the object's centre of mass under two motions, and their yaw difference (rad)."""
        return pose_error(self.perceived, first, second)

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

    def press_deeper(self, another: bool = False) -> bool:
        """After a slide the pad slipped through (the finger travelled on, the object did not): every plan
        from now on presses in the deepest ``1 / SLIP_DEPTH_SHARE`` of the finger's band (more normal force
        for the pad's friction against the table's), and ``another``: from another contact (a new seed for
        the planner's start). False when the band is already that deep and no other contact is asked for."""
        config, (low, high) = self.replan_config, self._band
        if low is None or high is None:
            return False
        deeper = max(config.dz_min, high - (high - low) / SLIP_DEPTH_SHARE)
        if deeper == config.dz_min and not another:
            return False
        seed = (config.seed + 1) % 2**64 if another else config.seed
        self.replan_config = dataclasses.replace(config, dz_min=deeper, seed=seed)
        return True

    def on_finger(self, motion, tip: np.ndarray):
        """The seen pose ``motion`` with the object under the pressing fingertip at ``tip`` (4, 4) as a
        re-plan's start needs it: inside the hull of its points (the planner's test) and near one of them
        (the verifier's, :func:`~slideplan.checks.verify.start_contact`). The finger presses on the object
        where the tracker's fit has it a few millimetres off (its scatter, the camera's mounting error),
        and every re-plan from there was refused as not starting on the object. Moved by the least shift
        that meets both tests with a margin (``START_INSIDE_M``, ``START_NEAR_SHARE``); unchanged when the
        tip already is on it, or when the shift would exceed ``FINGER_SNAP_M`` (the object pushed from
        under the finger: a new contact)."""
        x, y, yaw = (float(value) for value in motion)
        local = (np.asarray(tip, dtype=float)[:2, 3] - (x, y)) @ rotation_2d(yaw)  # R^T (tip - t)
        point = shapely.Point(local)
        if self._start_region.is_empty or self._start_region.contains(point):
            return motion
        nearest = np.asarray(shapely.shortest_line(point, self._start_region).coords[1])
        if np.linalg.norm(local - nearest) > FINGER_SNAP_M:
            return motion
        shift = (local - nearest) @ rotation_2d(yaw).T  # R (local - q): the world shift
        return (x + float(shift[0]), y + float(shift[1]), yaw)

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
        in the next frame (:meth:`slideplan.perception.tracking.Tracker.locate`), or None."""
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
        if segment.still_works(self.perceived, self.scene.table, self.replan_config, tip, seen.motion):
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
                where the slide ``segment``, not seen for :data:`~slideplan.loop.decisions.BLIND_S`, stopped with the fingertip at
                ``tip``: where its rest still works from the pose seen, or nothing is seen, no new plan and
                the event's outcome ``"kept"``), ``"confirm"`` (as ``"blind"`` where a drift stopped the slide
                to grasp early: ``"kept"`` only when seen) or ``"search"`` (as ``"clear"``, ``predicted`` where the whole
                table's frame shows the object, after a clear look that lost it).
            elapsed: time into the slide, for the event (s).
            frames: gives the next ``(depth, measured fingertip pose)``.
            predicted: where Eq. 2 puts the object now (motion from its perceived pose).
            start_config: the arm's configuration to plan from.
            tip: where the fingertip presses on the object (4, 4) during the slide, or where it stopped
                and comes back to after a look from clear: the pose seen is moved under it
                (:meth:`on_finger`) but after a ``"search"``; None: not moved.
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
        if trigger in ("end", "clear", "blind", "confirm", "search"):
            seen = self.settled(timed_frames, predicted, pressed=trigger == "end")
        else:
            seen = self.look(*timed_frames(), predicted)
        tracked = time.perf_counter()
        error_m, error_yaw = self.error(seen.motion, predicted)
        event = Replan(elapsed, trigger, error_m, math.degrees(error_yaw), tracked - started - sensed[0], 0.0, "lost",
                       seen.reason, sensed[0], list(range(first_frame, self.looks)))
        if seen.ok and tip is not None and trigger != "search":  # the finger presses there, or comes back to
            seen = dataclasses.replace(seen, motion=self.on_finger(seen.motion, tip))
        if (trigger == "blind" and not seen.ok) or (trigger in ("blind", "confirm") and seen.ok and segment.still_works(
                self.perceived, self.scene.table, self.replan_config, tip, seen.motion)):
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
        try:  # verified, as every plan the arm runs (slideplan.checks.pipeline)
            checked = plan_checked(self.scene, self.perceived.moved(motion), self.replan_config, start_config=start_config)
        except InputError as error:
            event.plan_s, event.outcome, event.detail = time.perf_counter() - tracked, "refused", error.problem
            return None, event, seen
        event.plan_s = time.perf_counter() - tracked
        again = checked.result
        if checked.verification is None:
            event.outcome = "timeout"
            return None, event, seen
        if not checked.ok:
            event.outcome, event.detail = "refused", f"the new plan fails verification: {checked.verification.violations[0]}"
            return None, event, seen
        event.outcome, event.detail = ("grasp" if len(again.trajectory) == 1 else "slide"), ""
        return again, event, dataclasses.replace(seen, motion=motion)
