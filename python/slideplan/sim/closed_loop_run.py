"""What a closed-loop run reports (:class:`ClosedLoopRun`): the world's verdict, the loop's events, and the
diagnostics of where the object was seen and truly was after the slide."""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from typing import Any

import numpy as np

from .. import jsontext
from .conditions import Disturbance
from ..world.geometry import Ending
from ..world.objects import ThinObject
from ..transforms import move_planar
from ..loop.watch import Replan

CLOSED_LOOP_SCHEMA = "slideplan.sim.closed_loop/1"


@dataclass
class ClosedLoopRun(jsontext.Document):
    """What happened in one :func:`run`.

    Attributes:
        success: the world's verdict (:func:`slideplan.checks.verdict.held`, the same for both modes): the object
            was in the hand, at least 3 cm above the table top, through the whole hold, in the simulator's
            true state. What the camera saw plays no part.
        mode: ``"closed"`` or ``"open"``.
        setting: one of :data:`slideplan.sim.conditions.SETTINGS`.
        failed_stage: None, ``"plan"`` (no first plan), ``"slide"`` (a slip: slides stopped for no progress,
            answered and still none, :data:`~slideplan.loop.decisions.SLIP_FAILURE`: no grasp), ``"release"`` (the object fell off the table when the finger let go), ``"grasp"`` (not lifted), ``"hold"`` (lifted, then out of the hand or lower than
            3 cm in the hold) or ``"simulation"``.
        failure: one line saying what went wrong ("" on success).
        replans: re-plans whose new plan was followed (slides and grasps from a seen pose).
        replan_latency_s: median latency of the looks that planned (s), None if none did.
        kept: drifts (off the predicted pose in ``CONFIRM`` looks in a row) after which the rest of the
            slide still ended graspable from the pose seen, so the plan was kept; and blind stops whose
            look found the same, or nothing (events with outcome ``"kept"``).
        looks: depth frames tracked; lost_looks: of them, those that did not show the object.
        events: every look that asked for a plan, and each end-of-slide look (:class:`~slideplan.loop.watch.Replan`).
        seen_status: after the slide, ``"seen"`` or ``"lost"`` (the look did not find the object: the seen
            columns are then None, never the prediction); None without a slide. Diagnostic.
        seen_frames: the frames that look used (the closed loop's last deciding look; the open loop's end
            look, made by the same settled procedure, :meth:`~slideplan.loop.watch.Watch.settled`).
        seen_motion: the object's motion from its perceived pose to where it was seen then, ``{x, y, yaw}``.
        seen_overhang_m, seen_com_margin_m: at that pose.
        true_overhang_m, true_com_margin_m: at the object's true pose then.
        true_motion: the object's true motion from where it lay to its pose then, ``{x, y, yaw}``.
        grasp_pose: the grasp the hand made, ``[x, y, z, qx, qy, qz, qw]`` (the plan's ``grasp.pose``), or None
            without a grasp.
        lifted: the runner's lift check (the object rose half the lift and stayed): diagnostic.
        slide_stop: ``""`` or the bounds (:mod:`slideplan.loop.bounds`) the closed loop met, ``+``-joined:
            ``"no_progress"`` (a slide stopped: the finger travelled on, the object as seen did not),
            ``"replan_cap"`` or ``"time_cap"`` (no new plan after ``MAX_REPLANS`` re-plans or ``MAX_SLIDE_S``
            of sliding: the slide followed then ends as planned, and its own grasp follows), ``"slip"``
            (no progress after the loop pressed deeper and slid from another contact, in place of
            ``"no_progress"``: the run ends without a grasp, a failure the report counts apart).
        slide_s: simulated time from the first slide's start to the grasp's start (s).
        draws: the physical parameters of the run (the random and hard settings' draws).
        camera_estimate: where the run put the depth camera from where it was believed to be, found from the
            robot it sees (:mod:`slideplan.sim.calibration`: the arm held over the object before the plan, and
            for the closed loop the episode's first frame too), as the hard setting draws a mounting error
            (``dx_m, dy_m, dz_m, rx_deg, ry_deg, rz_deg``; zero where the robot was not seen well enough);
            camera_error: where the camera truly is from there (the same keys): the error left. The run
            perceives, plans, tracks and re-plans through the camera it put there.
        disturbance: the push applied (``--disturb``, or the hard setting's), or None.
        sim_time_s, wall_time_s: simulated and wall time of the run (s).
    """

    JSON_ALLOWS_NAN = False

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
    true_motion: dict[str, float] | None
    grasp_pose: list[float] | None
    lifted: bool
    slide_stop: str
    slide_s: float
    draws: dict[str, float]
    disturbance: dict[str, float] | None
    camera_estimate: dict[str, float] | None
    camera_error: dict[str, float] | None
    sim_time_s: float
    wall_time_s: float

    def to_dict(self) -> dict[str, Any]:
        """The report as JSON-ready dicts, ``schema`` first, each event with its latency."""
        report = {"schema": CLOSED_LOOP_SCHEMA, **dataclasses.asdict(self)}
        for event, entry in zip(self.events, report["events"]):
            entry["latency_s"] = event.latency_s
        return report

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


def new_report(mode: str, setting: str, draws: dict[str, float], disturbance: Disturbance | None) -> dict[str, Any]:
    """A :class:`ClosedLoopRun`'s fields before the run (all but the times): nothing seen, nothing failed yet."""
    return dict(
        success=False, mode=mode, setting=setting, failed_stage=None, failure="", replans=0, replan_latency_s=None,
        kept=0, looks=0, lost_looks=0, events=[], seen_status=None, seen_frames=[], seen_motion=None, seen_overhang_m=None,
        seen_com_margin_m=None, true_overhang_m=None, true_com_margin_m=None, true_motion=None, grasp_pose=None, lifted=False, slide_stop="", slide_s=0.0,
        camera_estimate=None, camera_error=None,
        draws=draws, disturbance=None if disturbance is None else dataclasses.asdict(disturbance),
    )


def diagnose(report: dict[str, Any], table, perceived: ThinObject, truth: ThinObject, seen_motion, seen: bool,
              frames: list[int], runner) -> None:
    """After the slide, diagnostics only (the verdict is the world's, :func:`slideplan.checks.verdict.held`): the
    overhang and centre-of-mass margin where the deciding look saw the object (None when it did not: a
    lost look is reported lost, never as the prediction) and where the object truly is (``runner``: the
    :class:`slideplan.sim.runner.Runner` of the run)."""
    report.update(seen_status="seen" if seen else "lost", seen_frames=list(frames))
    if seen:
        moved = perceived.moved(seen_motion)
        report["seen_motion"] = dict(zip(("x", "y", "yaw"), map(float, seen_motion)))
        seen_end = Ending.at(table, moved.points[:, :2], moved.centroid_xy)
        report["seen_overhang_m"], report["seen_com_margin_m"] = map(float, seen_end)
    com, yaw, _ = runner.object_pose()  # the object's body starts unturned, its origin at the centre of mass
    motion = (*(com - move_planar(np.asarray(truth.centroid_xy, dtype=float), (0.0, 0.0, yaw))), yaw)
    true_end = Ending.at(table, move_planar(truth.points[:, :2], motion), com)
    report["true_overhang_m"], report["true_com_margin_m"] = map(float, true_end)
    report["true_motion"] = dict(zip(("x", "y", "yaw"), map(float, motion)))
