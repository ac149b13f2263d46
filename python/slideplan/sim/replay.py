"""Open-loop execution: the plan replayed as planned, then the grasp (:func:`execute`)."""

from __future__ import annotations

import dataclasses
import math
import os
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Callable

import numpy as np

from ..errors import InputError, require_type
from ..world.geometry import Ending, SupportSurface
from ..plan.robot import build_robot
from ..plan.result import PlanResult
from ..plan.timing import parameterize, resolve_limits
from ..transforms import move_planar, rotation_2d, wrap_angle
from ..plan.motions import timing_of
from ..checks.verify import require_motion
from .model import build_model
from .report import Execution, path_features
from .runner import SETTLE_S, Runner, Unstable, timing_options
from .settings import ExecutionSettings
from .video import VIDEO_FPS, Recorder, plan_points

_NO_FORCE_N = 0.1  # below this mean normal force the finger does not press at all

def execute(
    result: PlanResult,
    settings: ExecutionSettings | None = None,
    *,
    timing: dict[str, Any] | None = None,
    video: str | Path | None = None,
    video_fps: int = VIDEO_FPS,
    video_size: tuple[int, int] = (480, 640),
    progress: Callable[[float], None] | None = None,
) -> Execution:
    """Execute a plan in MuJoCo: slide, let go, approach, grasp, lift and hold (module docstring).

    Args:
        result: a solved plan.
        settings: physical parameters (default :class:`ExecutionSettings`).
        timing: a ``slideplan.plan/2`` ``timing`` block; its ``trajectory`` and ``approach``
            ``time_from_start`` are followed (default: the plan's own ``timing`` attribute). A
            segment it lacks is timed by :func:`slideplan.plan.timing.parameterize` under the limits
            of ``settings`` (:class:`ExecutionSettings`).
        video: write a rendering here: ``.mp4`` or ``.gif``, or ``.png`` for a strip of 6 frames.
        video_fps: frames per simulated second of the video.
        video_size: (height, width) of a frame in pixels.
        progress: called with the simulated time (s) every simulated tenth of a second, e.g. to show
            a progress line (the CLI's ``execute`` does, on runs longer than two seconds).

    Returns:
        The report. An unstable simulation is a report with ``failed_stage == "simulation"``.

    Raises:
        InputError: the plan is not solved or its motion cannot be run
            (:func:`slideplan.checks.verify.require_motion`), or its robot cannot be imported (naming the element),
            or a mesh is missing, or the timing block does not fit the plan, or TOPP-RA finds no
            timing of a segment this function times itself.
    """
    require_type(result, PlanResult, "result", "a PlanResult (from plan or PlanResult.load)")
    if result.status != "solved":
        raise InputError(f"plan status is {result.status!r}: only solved plans can be executed", field="status")
    require_motion(result)
    settings = settings or ExecutionSettings()
    timing = timing if timing is not None else getattr(result, "timing", None)
    if video is not None and Path(video).suffix.lower() not in (".mp4", ".gif", ".png"):
        raise InputError(f"expected a .mp4, .gif or .png file, got {str(video)!r}", field="--video")
    os.environ.setdefault("MUJOCO_GL", "egl")  # offscreen rendering without a display

    wall_start = time.perf_counter()
    built = build_model(result, settings)
    core_robot = build_robot(result.robot)
    options = timing_options(settings, core_robot.velocity_limits)
    slide_times, approach_times = _segment_times(result, timing, options)
    planned = _Planned.of(result)
    recorder = Recorder(built.model, built.data, video, video_fps, video_size, plan_points(result, core_robot),
                        progress=progress)
    runner = Runner(built, settings, recorder.after_step if recorder.active else None)
    report = _new_report(result, settings, planned)

    runner.press(planned.trajectory[0], planned.depths[0])
    try:
        runner.slide(planned.trajectory, slide_times, planned.depths, SETTLE_S)
        if runner.clutter_contact is not None:
            _fail(report, *runner.clutter_contact)
        _judge_slide(report, runner, result, planned, settings)
        failure = runner.grasp(np.asarray(result.grasp["approach"], dtype=float), approach_times,
                               np.asarray(result.grasp["config"], dtype=float), core_robot,
                               resolve_limits(result, options), planned.top,
                               float(result.table["height"]) + float(result.object["thickness"]) / 2)
        report["lifted"] = runner.lifted
        if runner.clutter_contact is not None:
            _fail(report, *runner.clutter_contact)
        if failure is not None:
            stage, message = failure
            _fail(report, stage,
                  message + (f" (CoM {1000 * report['com_margin_m']:.1f} mm inside the edge)" if stage == "release" else ""))
    except Unstable as error:
        report.update(actual_motion=None, position_error_m=None, yaw_error_deg=None, overhang_m=None,
                      com_margin_m=None, lifted=False, failed_stage="simulation", failure=str(error))
    finally:
        recorder.close()
    report["success"] = report["failed_stage"] is None
    execution = Execution(sim_time_s=float(built.data.time), wall_time_s=time.perf_counter() - wall_start, **report)
    recorder.write()
    return execution


def _segment_times(result: PlanResult, timing: dict[str, Any] | None, options) -> tuple[np.ndarray, np.ndarray]:
    """The slide's and the approach's time_from_start: the timing block's, else timed here under ``options``."""
    slide_times = timing_of(timing, "trajectory", len(result.trajectory))
    approach_times = timing_of(timing, "approach", len(result.grasp["approach"]))
    if slide_times is None or approach_times is None:
        own = parameterize(result, options)
        slide_times = own["trajectory"]["time_from_start"] if slide_times is None else slide_times
        approach_times = own["approach"]["time_from_start"] if approach_times is None else approach_times
    return slide_times, approach_times


@dataclass
class _Planned:
    """What the plan commands and predicts: the slide's configurations and the finger's depths below the
    object's top, the table, the object's centre of mass before the slide and its motion and centre of
    mass after it (Eq. 2)."""

    trajectory: np.ndarray
    depths: np.ndarray
    top: float
    table: SupportSurface
    com0: np.ndarray
    predicted: tuple[float, float, float]
    planned_com: np.ndarray

    @classmethod
    def of(cls, result: PlanResult) -> _Planned:
        tips = np.asarray(result.fingertip_poses)[:, :3]
        top = result.object_top
        table = SupportSurface.from_vertices(result.table["polygon"], float(result.table["height"]), field="table.polygon")
        motion = result.object_motion
        predicted = (float(motion["x"]), float(motion["y"]), float(motion["yaw"]))
        com0 = np.asarray(result.object["com_xy"], dtype=float)
        return cls(np.asarray(result.trajectory, dtype=float), top - tips[:, 2], top, table, com0, predicted,
                   move_planar(com0, predicted))


def _new_report(result: PlanResult, settings: ExecutionSettings, planned: _Planned) -> dict[str, Any]:
    """An :class:`Execution`'s fields before the run (all but the times): the plan's, nothing measured or failed yet."""
    tip_path, yaw_travel = path_features(result)
    return dict(
        success=False, failed_stage=None, failure="", predicted_motion=dict(zip(("x", "y", "yaw"), planned.predicted)),
        actual_motion=None, position_error_m=None, yaw_error_deg=None, overhang_m=None, com_margin_m=None,
        planned_com_margin_m=planned.table.edge_margin(planned.planned_com),
        normal_force_n={"mean": 0.0, "min": 0.0, "max": 0.0},
        lifted=False, tip_path_m=tip_path, yaw_travel_deg=math.degrees(yaw_travel),
        settings=dataclasses.asdict(settings),
    )


def _fail(report: dict[str, Any], stage: str, message: str) -> None:
    """Record a failure; the first one found is the report's."""
    if report["failed_stage"] is None:
        report["failed_stage"], report["failure"] = stage, message


def _judge_slide(report: dict[str, Any], runner: Runner, result: PlanResult, planned: _Planned,
                 settings: ExecutionSettings) -> None:
    """After the slide: the fingertip's force, where the object is against Eq. 2's pose and how it ends on the
    table, into the report; a slide with no force or off the pose beyond the tolerances is a failure."""
    forces = runner.forces
    if forces:
        report["normal_force_n"] = {"mean": float(np.mean(forces)), "min": float(np.min(forces)), "max": float(np.max(forces))}
    com1, yaw1, _ = runner.object_pose()
    actual = (*(com1 - rotation_2d(yaw1) @ planned.com0), yaw1)
    report["actual_motion"] = dict(zip(("x", "y", "yaw"), map(float, actual)))
    report["position_error_m"] = float(np.linalg.norm(com1 - planned.planned_com))
    report["yaw_error_deg"] = math.degrees(wrap_angle(yaw1 - planned.predicted[2]))
    moved = move_planar(np.asarray(result.object["points"])[:, :2], actual)
    report["overhang_m"], report["com_margin_m"] = Ending.at(planned.table, moved, com1)
    if report["normal_force_n"]["mean"] < _NO_FORCE_N:
        _fail(report, "slide", f"no normal force at the fingertip (mean {report['normal_force_n']['mean']:.2f} N): "
                               "the finger does not press, the object does not follow")
    elif report["position_error_m"] > settings.position_tolerance or abs(report["yaw_error_deg"]) > math.degrees(settings.yaw_tolerance):
        _fail(report, "slide", f"the object ends {1000 * report['position_error_m']:.1f} mm / {report['yaw_error_deg']:.1f} deg "
                               "from Eq. 2's pose")

