"""The closed loop's decisions over a slide, whatever drives the arm (:class:`SlideLoop`): the MuJoCo
harness (:func:`slideplan.sim.closed_loop.run`) and the ROS node (:mod:`slideplan.ros.execution`) each give
it an :class:`Arm`. A confirmed drift switches to a new plan (:class:`Stop`); a slide blind for
``BLIND_S`` stops to look from above; the end of a slide is looked at (from ``CLEAR_LIFT_M`` above when
the arm hides the object) and slid on, grasped, or slid anew from a new contact when the object was
pushed from under the finger. The looks are :mod:`slideplan.loop.watch`'s; no physics here.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass
from typing import Callable, Protocol

import numpy as np
import shapely

from .. import _core
from .bounds import MAX_REPLANS, MAX_SLIDE_S, Progress
from ..errors import InputError
from ..plan.motions import Unreachable, collision_world, dense, reach_path, straight_line, straight_up
from ..world.geometry import support_margin
from ..world.objects import ThinObject
from ..checks.pipeline import Checked, plan_checked
from ..plan.config import PlannerConfig
from ..plan.result import PlanResult
from ..world.scenes import Scene
from .watch import Replan, Segment, Watch, slide_segment

CLEAR_LIFT_M = 0.1  # when the arm hides the object at the end of a slide, the finger rises this far to look
CLEAR_ASIDE_M = 0.15  # and where the arm still hides it from there (a camera behind the arm), this far across
SIGHT_LINES = 24  # lines of sight from the camera to the object's points that tell whether the arm hides it
SIGHT_RADIUS_M = 0.005  # each a capsule of this radius (CollisionWorld.hidden_lines)
HIDDEN_SHARE = 0.25  # a pose that hides at most this share of them shows the tracker enough of the object
SET_DOWN_TRIES = 8  # points of an object over an edge tried for the finger's new contact, nearest its centre first
STAYS_SHARE = 0.5  # the finger rises to look only where the object's centre of mass is this share of support_margin inside what the table bears
BLIND_S = 1.0  # a slide no look has seen the object in for this long stops, and the finger rises clear to look
SLIP_ANSWERS = 2  # slides stopped for no progress answered (pressed deeper, then from another contact too) before a slip ends the run
SLIP_FAILURE = ("slip: the finger travelled on and the object did not, though pressed deeper and from another "
                "contact")  # a run's failure then (no grasp), in simulation and on the ROS node alike


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
            looks from above) or ``"no_progress"`` (:class:`~slideplan.loop.bounds.Progress`: the slide ends there,
            looked at as at its end).
    """

    plan: PlanResult | None
    motion: tuple | None
    config: np.ndarray
    at_s: float
    reason: str = "blind"


class Arm(Protocol):
    """What drives the arm for a :class:`SlideLoop`: the MuJoCo runner of :func:`slideplan.sim.closed_loop.run` or the
    ROS node's controller (:mod:`slideplan.ros.execution`)."""

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


def plan_anew(scene: Scene, seen: ThinObject, planner: PlannerConfig, robot, config: np.ndarray) -> Checked:
    """A verified plan (:class:`~slideplan.checks.pipeline.Checked`) for the object ``seen`` wherever it lies: a new
    slide when it is wholly on the table; else (partly over an edge, the finger off it: it slid on ahead of the
    finger) from the finger set down on it, turned and pressed as at ``config``, since the planner takes such
    an object only from a state: the grasp where the object already overhangs enough, or else the rest of the
    slide. The finger is set down at the object's point over the table nearest its centre from which it can
    rise as a reach comes down, else the next of SET_DOWN_TRIES points out to the median distance.

    Raises:
        Unreachable: no inverse kinematics puts the finger on the object where it can rise from.
        InputError: that configuration is not a valid contact (``start_config``: why), or the object is off the table.
    """
    if scene.table.polygon.contains(seen.outline):
        return plan_checked(scene, seen, planner)
    points = seen.points[:, :2]
    points = points[shapely.contains_xy(scene.table.polygon, points[:, 0], points[:, 1])]  # the finger on the table
    if not len(points):
        raise InputError("the object is off the table", field="object")
    order = np.argsort(np.linalg.norm(points - seen.centroid_xy, axis=1))
    nearest = points[order[np.linspace(0, len(order) // 2, SET_DOWN_TRIES).astype(int)]]  # out to the median
    target = np.asarray(robot.fk(config))
    for point in nearest:
        target[:2, 3] = point
        on = robot.ik(target, seed=config, rng_seed=0, options=_core.contact_ik_options(robot))
        # The reach to it comes down from approach_height above (motions.reach_path): a contact the finger
        # cannot rise straight up from (a joint at its limit) is no start, though the planner would take it.
        if on is not None and straight_up(robot, on, planner.approach_height) is not None:
            return plan_checked(scene, seen, planner, start_config=on)
    raise Unreachable(f"no inverse kinematics puts the finger on the object near ({nearest[0][0]:.3f}, "
                      f"{nearest[0][1]:.3f}) and lifts it straight up from there")


class SlideLoop:
    """The closed loop's decisions over a slide, whatever drives the arm (:func:`slideplan.sim.closed_loop.run`
    in MuJoCo, the ROS node): a confirmed drift switches to a new plan; a slide blind for ``BLIND_S`` stops
    to look from above; the end of a slide is looked at (from ``CLEAR_LIFT_M`` above when the arm hides the
    object) and slid on, grasped, or slid anew from a new contact when the object was pushed from under
    the finger.

    Args:
        watch: the judge of the frames; None: open loop (the slide as planned, no look).
        robot: the core robot model.
        top: the object's top surface height (m).
        end_replans: slides re-planned at most this many times after a slide ends (and blind stops at most
            this many).
        arm: what moves the arm (:class:`Arm`).

    Attributes:
        replans: new plans followed.
        stops: the bounds met (:mod:`slideplan.loop.bounds`), each once, in order: ``"no_progress"``,
            ``"replan_cap"``, ``"time_cap"``, and ``"slip"`` (no progress after :data:`SLIP_ANSWERS`
            answers, :meth:`answer_slip`: it replaces ``"no_progress"``); :attr:`stopped` joins them with
            ``+`` ("" for none).
        seen: whether the object's motion :meth:`run` returned was seen (else predicted), and
        seen_frames: the frames of the look it came from.
        abandoned: the run ended for a slip (``"slip"`` in :attr:`stops`): no grasp is made.
    """

    def __init__(self, watch: Watch | None, robot, top: float, end_replans: int, arm: Arm) -> None:
        self.watch, self.robot, self.top, self.end_replans, self.arm = watch, robot, top, end_replans, arm
        self.replans = self.ends = self.blinds = self.slips = 0
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
        self.anchor(result, (0.0, 0.0, 0.0))
        while True:
            self.segment = segment
            stop = arm.slide(segment, None if watch is None else self.look)
            # Graspable already where the looks during the slide saw it: ended short only once seen so from clear.
            early = stop is not None and stop.plan is not None and len(stop.plan.trajectory) == 1
            if stop is not None and stop.plan is not None and not early:
                self.replans += 1
                arm.replanned("drift", "slide", self.replans)
                arm.switch(stop)
                segment = slide_segment(stop.plan, self.top, stop.motion)
                continue
            blind = stop is not None and stop.plan is None and stop.reason == "blind"
            end_config, end_s = (stop.config, stop.at_s) if stop is not None else (np.asarray(segment.result.trajectory)[-1], float(segment.times[-1]))
            predicted = segment.predicted(np.asarray(robot.fk(end_config)))
            if watch is None or self.capped():
                if early:  # no more looks: the grasp the looks during the slide asked for
                    return self._early_grasp(stop)
                self.seen, self.seen_frames = None, []
                return segment.result, predicted
            if stop is not None:  # blind, or no progress: the slide ends where the arm stops
                self.blinds += blind
                arm.stop(stop)
            slipped, seen = stop is not None and stop.plan is None and stop.reason == "no_progress", None
            if not slipped:
                again, event, seen = self.look_at_end(segment, blind, end_config, predicted, clear=early)
                # Seen from clear, where the hand hid it through the slide: left behind by a pad that slipped.
                if seen.ok and self.progress.update(np.asarray(robot.fk(end_config))[:2, 3], seen.motion):
                    self._met("no_progress")
                    slipped = True
            if slipped:
                fresh, motion = self.answer_slip(end_config, predicted, None if seen is None else seen.motion)
                if fresh is None:  # nothing moved the object: no grasp; the slip says what no progress did
                    self.stops = [bound for bound in self.stops if bound != "no_progress"]
                    self._met("slip")
                    self.abandoned, self.seen, self.seen_frames = True, None, []
                    return segment.result, predicted
                self.replans += 1
                arm.replanned("slip", "grasp" if len(fresh.trajectory) == 1 else "slide", self.replans)
                self.seen = True
                if len(fresh.trajectory) == 1:
                    return fresh, motion
                segment = slide_segment(fresh, self.top, motion)
                continue
            outcome = event.outcome
            if again is None and outcome == "refused" and self.ends < self.end_replans:
                again, outcome = self.new_contact(seen.motion, end_config), "new_contact"  # pushed from under the finger
            replanned = again is not None
            if early and (outcome in ("lost", "refused", "timeout") or (replanned and len(again.trajectory) > 1
                                                                        and self.ends >= self.end_replans)):
                return self._early_grasp(stop)  # nothing better from clear
            if (blind or early) and not replanned:  # on track, not seen or no new plan: the rest of the slide, from rest
                again = segment.rest(robot, end_s, end_config)
            self.seen, self.seen_frames = bool(seen.ok), event.frames
            # Its own grasp, from where Eq. 2 put the object; a slide stopped short goes on (its rest is no re-plan).
            if again is None or (replanned and not early and self.ends >= self.end_replans):
                return segment.result, seen.motion
            if replanned:
                self.replans += 1
                arm.replanned("blind" if blind else "drift" if early else "end", outcome, self.replans)
            if len(again.trajectory) == 1:
                return again, seen.motion
            self.ends += replanned
            segment = slide_segment(again, self.top, seen.motion)

    def _early_grasp(self, stop: Stop) -> tuple[PlanResult, tuple]:
        """The grasp a drift look asked for (the object graspable where the looks during the slide saw it)."""
        self.replans += 1
        self.arm.replanned("drift", "grasp", self.replans)
        self.seen = True
        return stop.plan, stop.motion

    def look_at_end(self, segment: Segment, blind: bool, end_config: np.ndarray, predicted, clear: bool = False):
        """The look where a slide ended or stopped blind, the arm at rest at ``end_config``: from there, or
        from clear of the object where the arm hides it (and over the whole table when not found near
        ``predicted``), the finger back at ``end_config`` after. ``clear``: from clear at once (a slide
        stopped short because the looks during it saw the object graspable: the hand hides part of it
        then, and a fit a centimetre off along the slide ended one with 1.7 cm of overhang where the
        planned slide went on to 5). Returns :meth:`Watch.replan`'s triple."""
        robot, arm, watch = self.robot, self.arm, self.watch
        stays = self.stays(predicted)
        lifted = self.clear_way(segment.result, end_config, predicted) if (blind or clear) and stays else None
        trigger = "blind" if blind else "confirm" if clear else "clear"
        if lifted is None:
            again, event, seen = watch.replan("end", arm.clock(), arm.frames(), predicted, end_config,
                                              segment=segment, tip=np.asarray(robot.fk(end_config)))
            arm.record(event)
            lifted = self.clear_way(segment.result, end_config, predicted) if event.outcome == "lost" and stays else None
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
        return again, event, seen

    def stays(self, motion) -> bool:
        """Whether the object at ``motion`` stays where it is when the finger rises: its centre of mass well
        inside the part of it the table bears (:func:`~slideplan.world.geometry.support_margin`). An L slid past
        the edge with its centre of mass off its own material is held down by the finger alone; lifted to
        look, it tipped off the table (its centre of mass 2.3 mm inside), where the grasp's approach would have
        caught it; a crescent 6.9 mm inside stayed put, and the look from clear found it a better grasp than
        the planned one. The margin is ``STAYS_SHARE`` of the planner's ``support_margin`` (calibrated in
        physics for a grasp's release)."""
        watch = self.watch
        moved = watch.perceived.moved(motion)
        margin = support_margin(watch.scene.table, moved.points[:, :2], moved.centroid_xy)
        return margin >= STAYS_SHARE * watch.replan_config.support_margin

    def answer_slip(self, config: np.ndarray, predicted, motion=None) -> tuple[PlanResult | None, tuple]:
        """A slide stopped for no progress (the pad slipped over the object, or pushed it stuck fast), the
        arm at rest at ``config``: looked at (unless seen at ``motion``), then slid anew from a new contact
        pressed deeper (:meth:`~slideplan.loop.watch.Watch.press_deeper`), the second time from another
        contact too.
        Returns the new plan followed (None after SLIP_ANSWERS answers, or when there is none: the run
        ends for a slip) and the object's motion it was made from."""
        self.slips += 1
        watch = self.watch
        if self.slips > SLIP_ANSWERS:
            return None, predicted
        watch.press_deeper(another=self.slips > 1)  # already that deep: the same contact once more
        if motion is None:
            seen = watch.settled(self.arm.frames(), predicted)
            motion = seen.motion if seen.ok else predicted
        return self.new_contact(motion, config), motion

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

    def new_contact(self, motion, config: np.ndarray) -> PlanResult | None:
        """A whole new slide for the object seen at ``motion`` (verified) and the reach to its first contact
        from ``config`` (the finger lifted off first, every link checked), followed; None when there is none
        (the event says why)."""
        watch, started = self.watch, time.perf_counter()
        event = Replan(self.arm.clock(), "new_contact", 0.0, 0.0, 0.0, 0.0, "refused")
        seen = watch.perceived.moved(motion)
        checked = reach = None
        try:
            checked = plan_anew(watch.scene, seen, watch.replan_config, self.robot, config)
            if checked.verification is not None and not checked.ok:
                event.detail = f"the new plan fails verification: {checked.verification.violations[0]}"
            elif checked.ok:
                reach = reach_path(checked.result, seen, config, pressed=True)
        except (InputError, Unreachable) as error:  # e.g. pushed mostly off the table: no slide from there
            event.detail = error.problem if isinstance(error, InputError) else str(error)
        event.plan_s = time.perf_counter() - started
        fresh = None if checked is None else checked.result
        if checked is not None and checked.verification is None:
            event.outcome = "timeout"
        elif reach is not None:
            event.outcome = "grasp" if len(fresh.trajectory) == 1 else "slide"
        self.arm.record(event)
        if reach is None:
            return None
        self.arm.move(fresh, reach, "reach")
        self.anchor(fresh, motion)
        return fresh

    def anchor(self, result: PlanResult, motion) -> None:
        """Progress counted afresh from ``result``'s first contact on the object at ``motion``. It spans the
        slides from one contact: a pad slipping over the object is seen off the plan and re-planned every
        few looks, and a count reset by each re-plan never reached no progress; and anchored where the
        finger came down, a slide the hand hides to its end is judged by the look from clear."""
        self.progress.reset()
        self.progress.update(np.asarray(result.fingertip_poses[0], dtype=float)[:2], motion)
