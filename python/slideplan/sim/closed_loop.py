"""The closed loop's MuJoCo harness (beyond the paper): a whole task, watched while sliding, re-planned
when the object drifts, grasped where it is seen, in simulation. The loop's decisions are
:mod:`slideplan.loop.decisions` (what the arm does) and :mod:`slideplan.loop.watch` (what the frames say), shared with
the ROS node; here the simulated arm (:class:`_Simulated`) and the camera's frames rendered; the report is :mod:`slideplan.sim.closed_loop_run`.

:func:`run` does a whole task in MuJoCo from a fixed depth camera's view:

1. render the scene and :func:`~slideplan.perception.tabletop.perceive` the object (the table is the scene's);
   plan for the object as perceived;
2. execute the slide (:mod:`slideplan.sim`'s model and runner, the object as it really is); every
   ``replan_period`` of simulated time render a depth frame with the arm in view and track the object
   (:class:`~slideplan.perception.tracking.Tracker`); when it is further than ``threshold`` from the pose Eq. 2
   predicts for the commanded configuration in two looks in a row, and the rest of the slide would not end
   graspable from where it is seen (:meth:`~slideplan.loop.watch.Segment.still_works`), plan again from that configuration (where
   the servos' reference is, so it does not jump) with the object where it was seen, and follow the new plan;
3. when a slide ends, track the object and plan from the final configuration with the object where it
   was seen: the plan is that configuration and its grasp when the object overhangs enough (else it
   slides on, up to ``end_replans`` times); then approach, close, lift 5 cm and hold 1 s. When the
   hand hides the object from the camera there, the finger rises ``CLEAR_LIFT_M`` straight up (and on
   ``CLEAR_ASIDE_M`` across where the arm still hides it: :meth:`~slideplan.loop.decisions.SlideLoop.clear_way`), looks from
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
from where the finger is (lifted off first, every link checked: :mod:`slideplan.plan.motions`).

Open loop (``closed=False``): the first plan is executed as planned, its own grasp included; the
camera only watches: after the slide it looks as the closed loop looks at the end of a slide
(:meth:`~slideplan.loop.watch.Watch.settled`), for the diagnostics.

Success, in both modes, is the world's verdict (:mod:`slideplan.checks.verdict`): the object in the hand, at
least 3 cm above the table top, through the whole hold, in the simulator's true state. The seen and
true overhang after the slide are diagnostics. A closed loop's sliding is bounded (:mod:`slideplan.loop.bounds`).
"""

from __future__ import annotations

import dataclasses
import math
import os
import time
from pathlib import Path
from typing import Any, Callable

import numpy as np
import shapely

from .._fields import as_number, as_numbers, as_seed
from ..perception.calibration import pose_offset
from .calibration import episode_fix, first_fix
from ..perception.camera import Camera, back_project
from .closed_loop_run import ClosedLoopRun, diagnose, new_report
from .conditions import Disturbance, camera_as_mounted, execution_settings, hard_push, push_candidates, setting_draws
from ..errors import InputError
from .episode import DEPTH_DROPOUT, Episode
from .runner import SETTLE_S, Runner, Unstable, timing_options
from .settings import ExecutionSettings
from .video import VIDEO_FPS
from ..loop.decisions import SLIP_FAILURE, SlideLoop, Stop
from ..plan.motions import plan_times, rest_to_rest
from ..world.objects import ThinObject, load_object, load_outline, place_outline
from ..plan.config import PlannerConfig
from ..plan.planner import plan
from ..plan.result import PlanResult
from .rendering import depth_image, noisy_depth, place_objects, scene_spec
from ..world.scenes import Scene, load_scene
from ..plan.timing import resolve_limits
from ..checks.verdict import Hold, judge
from ..loop.watch import Replan, Segment, Watch, slide_segment

ON_TABLE_SLACK_M = 0.003  # the perceived object may cross a table edge by this much (about a pixel)


def default_camera(scene: Scene) -> Camera:
    """The closed loop's camera: 0.6 m above the table, 0.45 m from its centroid towards (-x, -y) (the
    robot's side, to its right), looking at the centroid. Of 24 placements around the table (3 heights,
    8 directions) it saw the most of three objects' edges with the table along their slides: the arm
    hides less of the object from low and to the side than from above."""
    centre = scene.table.polygon.centroid
    offset = 0.45 / math.sqrt(2.0)
    return Camera((centre.x - offset, centre.y - offset, scene.table.height + 0.6), (centre.x, centre.y, scene.table.height))


TABLE_VIEW_MARGIN_M = 0.05  # the cloud perceived before the slide: the table and this much around it


def _perceived_object(scene: Scene, object_name, camera: Camera, pose, noise: float, seed: int,
                      mounted: Camera | None = None) -> tuple[ThinObject, tuple[float, float, float]]:
    """The object as the camera sees it before the slide: its known outline registered to the object
    :func:`~slideplan.perception.tabletop.perceive` finds in a rendered frame (the table is the scene's), and the
    table plane perceive fitted (what the tracker measures heights from). The frame is taken from where
    the camera is ``mounted`` (default: ``camera``) and read as if from ``camera``."""
    from ..perception.tabletop import perceive
    from ..perception.registration import seen_target

    placed = place_objects([(object_name, pose)])[0]
    mounted = mounted or camera
    clutter = [obstacle.to_dict() for obstacle in scene.obstacles]
    depth = depth_image(scene_spec(scene.table, [placed], [], mounted, obstacles=clutter), mounted)
    points = back_project(noisy_depth(depth, noise, DEPTH_DROPOUT, np.random.default_rng(seed)), camera)
    # The scene's table is known: the cloud is cut to it and a margin around it, and a plane half its size is
    # a table. Else a small arm's table (the SO-101's, 14 x 20 cm: 5% of the frame, under perceive's 0.04 m^2)
    # is lost to the floor around it, and the whole table is taken for clutter on the floor.
    table = scene.table.polygon
    points = points[shapely.contains_xy(table.buffer(TABLE_VIEW_MARGIN_M), points[:, 0], points[:, 1])]
    perception = perceive(points, seed=seed, source="the rendered scene", min_table_area=min(0.04, 0.5 * table.area))
    if not perception.objects:
        raise InputError("the camera does not see the object", field="--pose")
    outline, thickness, _ = load_outline(object_name)
    # The target is the thin object seen nearest where it lies: other thin objects of the scene are clutter.
    _, seen_pose = seen_target(perception.objects, near=pose[:2], outline=outline)
    obj = load_object(object_name, table_height=scene.table.height, pose=_on_table(scene.table.polygon, outline, seen_pose))
    return obj, perception.plane


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


class _Simulated:
    """The :class:`~slideplan.loop.decisions.Arm` of :func:`run`: MuJoCo's servos (:class:`~slideplan.sim.runner.Runner`), a look
    every ``period`` of simulated time, the frames rendered; ``on_step(clock)`` before each step (the
    disturbance); ``mark(text)`` says on the video what the loop did."""

    def __init__(self, runner: Runner, robot, settings: ExecutionSettings, frames, events: list, period: float,
                 on_step: Callable[[float], None], mark: Callable[[str], None]) -> None:
        self.runner, self.robot, self.settings, self._frames = runner, robot, settings, frames
        self.events, self.period, self.on_step, self.mark = events, period, on_step, mark
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
            timing = rest_to_rest(self.robot, path, result.timing["limits"], phase, capped=False)
        else:  # the look from clear: capped near the object only, as an approach
            limits = resolve_limits(result, timing_options(self.settings, self.robot.velocity_limits))
            timing = rest_to_rest(self.robot, path, limits, phase, top=result.object_top)
        self.runner.phase = phase
        self.runner.follow(path, timing["time_from_start"], SETTLE_S)

    def frames(self):
        return self._frames

    def record(self, event: Replan) -> None:
        self.events.append(event)

    def replanned(self, trigger: str, outcome: str, replans: int) -> None:
        """Marked on the video (the report has the loop's count and the events)."""
        self.mark(f"re-plan {replans} ({trigger}): {outcome}")


@dataclasses.dataclass
class Start:
    """How a run starts, before any physics: the setting's draws, the object as it really is and as the
    camera (where it is mounted) perceives it, and the first plan, made for the perceived object. The closed
    loop's :func:`run` and the environment of :mod:`slideplan.demos.env` start alike from this.

    Attributes:
        draws: the setting's draws (:func:`~slideplan.sim.conditions.setting_draws`).
        truth, perceived: the object as it is, and as perceived.
        table_plane: the table plane perception fitted.
        camera, mounted: where the camera is believed to be, and where it is.
        seen_through: where the camera was put by the arm seen before the plan
            (:func:`~slideplan.sim.calibration.first_fix`), the camera the object was perceived through
            (``camera`` itself where the arm was not seen well enough).
        config: the planner's parameters.
        first: the first plan (None if unsolved).
        unsolved: why there is no first plan (an object perceived over an edge, no plan found), or None.
    """

    draws: dict[str, float]
    truth: ThinObject
    perceived: ThinObject
    table_plane: tuple[float, float, float]
    camera: Camera
    mounted: Camera
    seen_through: Camera
    config: PlannerConfig
    first: PlanResult | None
    unsolved: str | None

    @classmethod
    def of(cls, scene: Scene, object_name, pose, *, seed: int, setting: str, config: PlannerConfig | None = None,
           camera: Camera | None = None) -> Start:
        """Perceive and plan for an object at ``pose`` (arguments as :func:`run`'s), through the camera where
        the arm, held over the object first seen, puts it (:func:`~slideplan.sim.calibration.first_fix`).

        Raises:
            InputError: the object is not wholly on the table, or cannot be read; an unknown setting; a seed
                that is not a whole number in [0, 2**64) (field ``seed``).
        """
        seed = as_seed(seed)
        draws = setting_draws(setting, seed)
        config = config or PlannerConfig.for_scene(scene, seed=seed)
        camera = camera or default_camera(scene)
        truth = load_object(object_name, table_height=scene.table.height, pose=pose)
        if not scene.table.polygon.contains(truth.outline):
            raise InputError(f"the object at {pose} is not wholly on the table", field="--pose")
        os.environ.setdefault("MUJOCO_GL", "egl")
        mounted = camera_as_mounted(camera, draws)
        noise = draws["depth_noise_at_1m"]
        perceived, table_plane = _perceived_object(scene, object_name, camera, pose, noise, seed, mounted)
        seen_through, resolved = camera, config.resolved(scene)
        fix = first_fix(scene, truth, resolved, execution_settings(setting, draws, resolved.dz_min), camera, mounted,
                        (camera.height, camera.width, noise), seed, perceived.centroid_xy)
        if fix is not None:
            seen_through = fix.corrected(camera)
            perceived, table_plane = _perceived_object(scene, object_name, seen_through, pose, noise, seed, mounted)
        first = None
        try:  # the object as perceived (a camera mounted off moves it) may lie over an edge: a failed run, not bad input
            first = plan(scene, perceived, config)
            unsolved = None if first.solved else f"no plan for the object as perceived ({first.status})"
        except InputError as error:
            unsolved = f"no plan for the object as perceived: {error.problem}"
        return cls(draws, truth, perceived, table_plane, camera, mounted, seen_through, config,
                   first if unsolved is None else None, unsolved)


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
    video_fps: int = VIDEO_FPS,
    progress=None,
    observe=None,
) -> ClosedLoopRun:
    """Perceive, plan, slide (re-planning when the object drifts, if ``closed``), grasp and lift in MuJoCo.

    Args:
        scene: a :class:`~slideplan.world.scenes.Scene`, a built-in scene name or a scene TOML.
        object_name: the object's outline (a name in ``data/objects`` or a TOML path).
        pose: (x, y, yaw) where the object really lies (m, m, rad).
        seed: seeds the camera's noise, perception, the planner and the random and hard settings' draws.
        closed: re-plan from what the camera sees (True) or execute the first plan blind (False).
        setting: ``"nominal"``, ``"stress"`` (torsional friction halved, the finger at ``dz_min``),
            ``"random"`` (frictions, mass and depth noise drawn per run: :data:`RANDOM_RANGES`) or ``"hard"``
            (fixed in advance: :mod:`slideplan.sim.conditions`).
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
        observe: called once the world is built, as ``observe(plan, built, runner, robot)`` (the first plan,
            the MuJoCo model, the servos, the core robot model); returns what to call after every simulated step
            (a demonstration's :class:`slideplan.demos.frames.Frames`), or None.

    Returns:
        The report, judged by the world (:mod:`slideplan.checks.verdict`). A run that cannot plan at first, or
        whose simulation goes unstable, is a report with that ``failed_stage``.

    Raises:
        InputError: an unknown setting, a pose that is not 3 numbers or puts the object off the table,
            a disturbance after a negative time, a non-positive period, threshold or limit, or a scene
            or object that cannot be read (each naming the field).
    """
    wall_start = time.perf_counter()
    pose, threshold = _checked_arguments(pose, replan_period, replan_time_limit, threshold, disturbance)
    scene = scene if isinstance(scene, Scene) else load_scene(scene)
    camera = camera or default_camera(scene)
    begun = Start.of(scene, object_name, pose, seed=seed, setting=setting, config=config, camera=camera)
    draws, truth, perceived, mounted, first = begun.draws, begun.truth, begun.perceived, begun.mounted, begun.first
    config, table_plane = begun.config, begun.table_plane
    report = new_report("closed" if closed else "open", setting, draws, disturbance)
    if begun.unsolved is not None:
        return ClosedLoopRun(**{**report, "failed_stage": "plan", "failure": begun.unsolved}, sim_time_s=0.0,
                             wall_time_s=time.perf_counter() - wall_start)

    top = scene.table.height + perceived.thickness
    segment = slide_segment(first, top, (0.0, 0.0, 0.0))
    slide_s = float(segment.times[-1])
    if disturbance is not None and disturbance.after_s > slide_s:
        raise InputError(f"{disturbance.after_s} s is after the planned slide ends ({slide_s:.2f} s)", field="--disturb")
    settings = execution_settings(setting, draws, float(first.params["dz_min"]))
    world = Episode(first, settings, truth, mounted, believed=begun.seen_through if closed else None,
                    depth=(camera.height, camera.width, draws["depth_noise_at_1m"]), seed=seed,
                    video=(video, video_fps, progress), observe=observe)
    push = _Push(disturbance, draws, slide_s, scene.table, world, report)

    world.runner.press(first.trajectory[0], segment.depths[0])
    seen_through = begun.seen_through
    if closed:  # where the camera is, from the robot in view: tracked and re-planned through from here on
        seen_through, table_plane = episode_fix(world, seen_through, scene.table.height, table_plane)
    report["camera_estimate"] = pose_offset(camera, seen_through)
    report["camera_error"] = pose_offset(seen_through, mounted)
    watch = Watch(scene, perceived, config, seen_through, threshold, replan_time_limit, table_plane=table_plane)
    loop = SlideLoop(watch if closed else None, world.robot, top, end_replans,
                     _Simulated(world.runner, world.robot, settings, world.frames, report["events"], replan_period, push,
                                world.recorder.mark))
    _episode(report, first, loop, watch, world, scene.table, perceived, truth, settings, top)
    world.recorder.write()
    return ClosedLoopRun(**report, sim_time_s=float(world.built.data.time), wall_time_s=time.perf_counter() - wall_start)


def _checked_arguments(pose, replan_period: float, replan_time_limit: float, threshold,
                       disturbance: Disturbance | None) -> tuple[tuple[float, float, float], np.ndarray]:
    """The pose and threshold as numbers, the other arguments of :func:`run` checked (InputError naming the field)."""
    pose = tuple(float(value) for value in as_numbers(pose, 3, source="", field="--pose"))
    for name, value in (("replan_period", replan_period), ("replan_time_limit", replan_time_limit)):
        as_number(value, source="", field=name, positive=True)
    threshold = as_numbers(threshold, 2, source="", field="threshold", positive=True)
    if disturbance is not None:
        as_numbers([disturbance.dx, disturbance.dy, disturbance.dyaw, disturbance.after_s], 4, source="", field="--disturb")
        if disturbance.after_s < 0:
            raise InputError(f"the time must be >= 0 s after the slide starts, got {disturbance.after_s}", field="--disturb")
    return pose, threshold


class _Push:
    """The run's push, applied at its time (the ``on_step`` of :class:`_Simulated`): ``--disturb``'s, or the
    hard setting's, drawn when it is due and written into the report."""

    def __init__(self, disturbance: Disturbance | None, draws: dict[str, float], slide_s: float, table,
                 world: Episode, report: dict[str, Any]) -> None:
        self.pending: Disturbance | list[Disturbance] | None = disturbance
        if disturbance is None and draws.get("push"):
            self.pending = push_candidates(int(draws["push_seed"]), draws["push_fraction"] * slide_s)
        self.table, self.world, self.report = table, world, report

    def __call__(self, now: float) -> None:
        if self.pending is None:
            return
        after_s = self.pending[0].after_s if isinstance(self.pending, list) else self.pending.after_s
        if now >= after_s:
            push = self.pending
            if isinstance(push, list):  # the hard setting's: redrawn while it would leave the CoM near an edge
                push = hard_push(push, self.table, self.world.runner.object_pose()[0])
                self.report["disturbance"] = None if push is None else dataclasses.asdict(push)
            if push is not None:
                push.apply(self.world.built)
                self.world.recorder.mark(f"pushed {100 * math.hypot(push.dx, push.dy):.1f} cm, "
                                         f"{math.degrees(push.dyaw):+.0f} deg")
            self.pending = None


def _episode(report: dict[str, Any], first: PlanResult, loop: SlideLoop, watch: Watch, world: Episode, table,
             perceived: ThinObject, truth: ThinObject, settings: ExecutionSettings, top: float) -> None:
    """The slides from ``first``, the look after them, the grasp and the verdict, into the report; the world
    closed after it."""
    runner, robot = world.runner, world.robot
    try:
        grasp_plan, seen_motion = loop.run(first)
        report["slide_s"] = loop.arm.clock()
        seen, seen_frames = loop.seen, loop.seen_frames
        if seen is None:  # no look decided (open loop, or a bound): one look for the diagnostics, as the closed loop's end look
            first_frame = watch.looks
            look = watch.settled(world.frames, seen_motion)
            seen, seen_frames, seen_motion = look.ok, list(range(first_frame, watch.looks)), look.motion
        diagnose(report, table, perceived, truth, seen_motion, seen, seen_frames, runner)
        if loop.abandoned:
            failure = ("slide", SLIP_FAILURE)
        else:
            report["grasp_pose"] = [float(value) for value in grasp_plan.grasp["pose"]]
            failure = runner.grasp(np.asarray(grasp_plan.grasp["approach"], dtype=float),
                                   plan_times(grasp_plan, "approach", len(grasp_plan.grasp["approach"])),
                                   np.asarray(grasp_plan.grasp["config"], dtype=float), robot,
                                   resolve_limits(grasp_plan, timing_options(settings, robot.velocity_limits)), top,
                                   table.height + truth.thickness / 2)
        report["lifted"] = runner.lifted
        hold = Hold.from_samples(runner.hold, settings.hold_s) if runner.hold else None
        _, report["failed_stage"], report["failure"] = judge(hold, table.height, failure, runner.clutter_contact)
    except Unstable as error:
        report.update(failed_stage="simulation", failure=str(error), lifted=False)
    finally:
        report.update(replans=loop.replans, looks=watch.looks, lost_looks=watch.lost_looks, kept=watch.kept,
                      slide_stop=loop.stopped)
        world.close()
    planned = [event.latency_s for event in report["events"] if event.outcome in ("slide", "grasp", "refused", "timeout")]
    report["replan_latency_s"] = float(np.median(planned)) if planned else None
    report["success"] = report["failed_stage"] is None

