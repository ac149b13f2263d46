"""``slideplan execute`` (open loop) and ``run`` (the closed loop), in MuJoCo."""

from __future__ import annotations

import contextlib
import sys
import time
from pathlib import Path
from typing import Optional, Tuple

import numpy as np
import typer

from .._fields import as_seed
from ..errors import InputError
from ..world.objects import load_outline, sample_pose_on_table
from ..plan.result import PlanResult
from ..world.scenes import load_scene
from .common import (
    EXIT_NOT_SOLVED,
    EXIT_SOLVED,
    VIDEO_SUFFIXES,
    _OPTION_OF_FIELD,
    _disturb_values,
    _fail,
    _output_file,
    _write_text,
    app,
)


@contextlib.contextmanager
def _progress_line(what: str, after_s: float = 2.0):
    """A callback showing the simulated time on stderr once a run has taken ``after_s`` of wall time: one
    line rewritten in place on a terminal, a line every 5 s in a log."""
    terminal = sys.stderr.isatty()
    started = time.perf_counter()
    last_shown = None  # wall time of the last line

    def progress(simulated_s: float) -> None:
        nonlocal last_shown
        wall = time.perf_counter() - started
        if wall < after_s or (last_shown is not None and wall - last_shown < (0.25 if terminal else 5.0)):
            return
        last_shown = wall
        line = f"{what}: {simulated_s:.1f} s simulated in {wall:.0f} s"
        typer.echo(f"\r{line}" if terminal else line, err=True, nl=not terminal)

    try:
        yield progress
    finally:
        if terminal and last_shown is not None:
            typer.echo("\r\033[K", err=True, nl=False)  # clear the line before the summary


@app.command("execute")
def execute_command(
    plan_file: Path = typer.Argument(..., help="A solved plan JSON (slideplan.plan/1, or /2 with a timing block)."),
    video: Optional[Path] = typer.Option(
        None, "--video", help="Render the execution offscreen to this .mp4 or .gif (or .png: a strip of 6 frames)."
    ),
    json_out: Optional[Path] = typer.Option(None, "--json", help="Write the execution report JSON here."),
    tip_speed: float = typer.Option(
        0.05, "--tip-speed", help="Fingertip speed cap (m/s) while lifting, and while sliding if the plan has no timing block."
    ),
) -> None:
    """Execute a plan in MuJoCo physics (arm, compliant finger, object, table), then grasp and lift.

    Exit codes: 0 the object ended within 5 mm / 3 degrees of Eq. 2 and was lifted, 1 the
    execution failed (the report says where), 2 bad input. Needs the ``execution`` extra.
    """
    try:
        from ..sim import ExecutionSettings, execute

        json_out, video = _output_file(json_out, "--json"), _output_file(video, "--video", VIDEO_SUFFIXES)
        result = PlanResult.load(plan_file)
        with _progress_line("executing" + (f", rendering {video.name}" if video is not None else "")) as progress:
            execution = execute(result, ExecutionSettings(tip_speed=tip_speed), video=video,
                                progress=progress)
        if json_out is not None:
            _write_text(json_out, execution.to_json(indent=1), "--json")
    except InputError as error:
        field = _OPTION_OF_FIELD.get(error.field, error.field)
        raise _fail(InputError(error.problem, source=error.source or str(plan_file), field=field)) from None
    except (ImportError, OSError, ValueError) as error:
        raise _fail(error) from None
    typer.echo(execution.summary())
    raise typer.Exit(EXIT_SOLVED if execution.success else EXIT_NOT_SOLVED)


@app.command("run")
def run_command(
    scene_name: str = typer.Option("square", "--scene", help="Built-in scene name or scene TOML."),
    object_name: str = typer.Option("crescent", "--object", help="Object outline: a name in data/objects or a TOML."),
    pose: Optional[Tuple[float, float, float]] = typer.Option(
        None, "--pose", help="X Y YAW where the object really lies (m, m, rad); default: drawn on the table from --seed."
    ),
    seed: int = typer.Option(1, "--seed", help="Seeds the camera noise, perception, the planner and the random setting."),
    closed: bool = typer.Option(True, "--closed-loop/--open-loop", help="Re-plan from what the camera sees, or not."),
    setting: str = typer.Option("nominal", "--setting", help="nominal, stress, random or hard (physics drawn per --seed)."),
    disturb: Optional[Tuple[float, float, float, float]] = typer.Option(
        None, "--disturb", help="DX DY DYAW T: move the object by (DX, DY) m and turn it by DYAW rad, T s into the slide."
    ),
    video: Optional[Path] = typer.Option(None, "--video", help="Render the run to this .mp4 or .gif (or .png: a strip of 6 frames)."),
    json_out: Optional[Path] = typer.Option(None, "--json", help="Write the run's report JSON here."),
    camera: Optional[Tuple[float, float, float, float, float, float]] = typer.Option(
        None, "--camera", help="X Y Z TX TY TZ: the depth camera at (X, Y, Z) looking at (TX, TY, TZ) (m); default: "
        "0.6 m above the table, 0.45 m from its centroid towards (-x, -y), looking at the centroid."
    ),
) -> None:
    """The whole task in MuJoCo from a depth camera's view: perceive, plan, slide (re-planning when the
    object drifts off the plan, with --closed-loop), grasp where the object is seen, lift and hold.

    Exit codes: 0 the object was in the hand, at least 3 cm above the table, through the whole hold
    (the simulator's true state, whatever the camera saw); 1 it was not (the report says where it
    failed); 2 bad input. Needs the ``execution`` and
    ``perception`` extras.
    """
    try:
        from ..sim.closed_loop import run
        from ..sim.conditions import Disturbance

        json_out, video = _output_file(json_out, "--json"), _output_file(video, "--video", VIDEO_SUFFIXES)
        scene, seed = load_scene(scene_name), as_seed(seed)  # the seed checked before the pose is drawn from it
        if pose is None:
            outline, _, _ = load_outline(object_name)
            pose = sample_pose_on_table(outline, scene.table, rng=np.random.default_rng(seed))
        disturbance = None if disturb is None else Disturbance(*_disturb_values(disturb))
        view = _run_camera(scene, camera)
        with _progress_line(f"running ({'closed' if closed else 'open'} loop)") as progress:
            report = run(scene, object_name, pose, seed=seed, closed=closed, setting=setting, disturbance=disturbance,
                         video=video, progress=progress, camera=view)
        if json_out is not None:
            _write_text(json_out, report.to_json(indent=1), "--json")
    except InputError as error:
        raise _fail(InputError(error.problem, source=error.source, field=_OPTION_OF_FIELD.get(error.field, error.field))) from None
    except (ImportError, OSError, ValueError) as error:
        raise _fail(error) from None
    typer.echo(report.summary())
    if report.looks and report.lost_looks > LOST_LOOKS_SHARE * report.looks:
        where = " ".join(f"{value:.2f}" for value in (*view.position, *view.target))
        typer.echo(f"slideplan: the camera did not see the object in {report.lost_looks} of {report.looks} looks: the "
                   "arm or hand hides it from there, so the loop slid blind and stopped to look from clear, which "
                   f"is slow; try a camera that sees past the arm (now --camera {where})", err=True)
    raise typer.Exit(EXIT_SOLVED if report.success else EXIT_NOT_SOLVED)


LOST_LOOKS_SHARE = 0.5  # beyond this share of looks without the object, the camera is the problem


def _run_camera(scene, camera: tuple | None):
    """``run``'s depth camera: the closed loop's default for the scene, or (X, Y, Z, TX, TY, TZ) as given."""
    from ..sim.closed_loop import default_camera
    from ..perception.camera import Camera

    if camera is None:
        return default_camera(scene)
    position, target = np.asarray(camera[:3], dtype=float), np.asarray(camera[3:], dtype=float)
    if not (np.all(np.isfinite(camera)) and np.all(np.abs(camera) <= 1e3)) or np.linalg.norm(position - target) < 0.05:
        raise InputError(f"expected a position and a distinct target (m, within 1e3), got {camera}", field="--camera")
    return Camera(tuple(position), tuple(target))
