"""Command line: ``slideplan plan``, ``demo``, ``export``, ``view``, ``perceive``, ``execute``, ``run`` (the
closed loop), ``experiment``, ``plot`` (docs/design.md 5) and ``ros serve`` / ``ros sim`` (docs/ros2.md).

Exit codes of ``plan``: 0 solved (and verified), 1 not solved within the time limit,
2 bad input (one line ``slideplan: error: ...`` on stderr), 3 solved but the plan fails
verification (``slideplan.verify``: a planner bug; the violations go to stderr and the JSON
is written with status ``"invalid"``); every command exits 130 when stopped by Ctrl-C.

``experiment`` and ``plot`` need the ``experiments`` extra (pandas, pyarrow, dask); ``view`` the
``view`` extra (viser, yourdfpy); ``perceive`` the ``perception`` extra (scikit-learn, SciPy). Warnings (e.g. a URDF velocity limit replaced by a default) go to
stderr as one line ``slideplan: warning: ...`` each.
"""

from __future__ import annotations

import contextlib
import dataclasses
import difflib
import ipaddress
import math
import os
import socket
import sys
import time
import warnings
from pathlib import Path
from typing import Optional, Tuple

import numpy as np
import typer
from typer.core import TyperGroup

try:  # typer 0.28 carries its own copy of click; earlier releases use click itself
    from typer._click import exceptions as click_errors
except ImportError:
    from click import exceptions as click_errors

from ._fields import as_numbers
from . import grasp_cache
from .errors import InputError, SlideplanWarning
from .objects import CLOUD_SUFFIXES, ThinObject, load_object, load_outline, sample_pose_on_table
from .plan.config import PLANNERS, PlannerConfig
from .plan.robot import table_reach
from .plan.result import PlanResult
from .scenes import Scene, load_scene

EXIT_SOLVED, EXIT_NOT_SOLVED, EXIT_BAD_INPUT, EXIT_INVALID_PLAN = 0, 1, 2, 3
EXIT_INTERRUPTED = 130  # Ctrl-C
PICTURE_SUFFIXES = (".png", ".svg")
MIN_TABLE_REACH = 0.5  # perceive warns when the fingertip reaches less of the table than this (planning.table_reach)
VIDEO_SUFFIXES = (".mp4", ".gif", ".png")
_SHOWN_VIOLATIONS = 20  # a broken plan can have thousands; the first ones tell the story

# Command-line option names of the PlannerConfig fields the CLI sets, for error messages.
_OPTION_OF_FIELD = {
    "seed": "--seed",
    "time_limit_s": "--time-limit",
    "reconfiguration_range": "--reconfiguration-range",
    "dz_max": "--reconfiguration-range",
    "planner": "--planner",
    "preset": "--preset",
    "workers": "--workers",
    "scheduler": "--scheduler",
    "tip_speed": "--tip-speed",
    "setting": "--setting",
    "set": "--set",
}

class _OneLineErrors(TyperGroup):
    """Usage errors (an unknown or missing option, a value of the wrong type) as one line on stderr
    and exit 2, like every other bad input: not a box of rich text."""

    def main(self, args=None, prog_name=None, complete_var=None, standalone_mode=True, **extra):
        if not standalone_mode:
            return super().main(args, prog_name, complete_var, standalone_mode=False, **extra)
        try:
            code = super().main(args, prog_name, complete_var, standalone_mode=False, **extra)
        except click_errors.NoArgsIsHelpError as error:
            typer.echo(error.ctx.get_help())
            sys.exit(error.exit_code)
        except click_errors.NoSuchOption as error:
            known = sorted(name for param in error.ctx.command.params for name in param.opts if name.startswith("-")) if error.ctx else []
            close = difflib.get_close_matches(error.option_name, known, n=3, cutoff=0.75)  # click's 0.6 offers --pose for --bogus
            command = f"{error.ctx.command_path}: " if error.ctx else ""
            hint = f" (did you mean {' or '.join(close)}?)" if close else f" (see {error.ctx.command_path} --help)" if error.ctx else ""
            typer.echo(f"slideplan: error: {command}no such option {error.option_name}{hint}", err=True)
            sys.exit(EXIT_BAD_INPUT)
        except click_errors.ClickException as error:
            command = f"{error.ctx.command_path}: " if getattr(error, "ctx", None) else ""
            message = " ".join(error.format_message().split())
            typer.echo(f"slideplan: error: {command}{message}", err=True)
            sys.exit(EXIT_BAD_INPUT if isinstance(error, click_errors.UsageError) else error.exit_code)
        except typer.Abort:  # click's word for Ctrl-C: the shell's convention is 128 + SIGINT
            typer.echo("slideplan: aborted", err=True)
            sys.exit(EXIT_INTERRUPTED)
        sys.exit(code if isinstance(code, int) else 0)


app = typer.Typer(
    cls=_OneLineErrors,
    add_completion=False,
    no_args_is_help=True,
    pretty_exceptions_enable=False,
    help="Pre-grasp sliding planning of thin objects (Hang, Morgan, Dollar, RA-L 2019).",
)


def _fail(error: Exception) -> typer.Exit:
    """Print one error line on stderr and return the bad-input exit."""
    message = " ".join(str(error).split())  # one line, whatever the source's message looked like
    typer.echo(f"slideplan: error: {message}", err=True)
    return typer.Exit(EXIT_BAD_INPUT)


@contextlib.contextmanager
def _warnings_as_lines():
    """Print slideplan's own warnings raised inside (e.g. a URDF limit replaced by a default) as
    ``slideplan: warning: ...`` lines; the libraries' deprecation notices are not the user's concern."""
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        try:
            yield
        finally:
            for warning in caught:
                if issubclass(warning.category, SlideplanWarning):
                    typer.echo(f"slideplan: warning: {' '.join(str(warning.message).split())}", err=True)


def _parse_params(items: list[str]) -> dict:
    """``NAME=VALUE`` strings as PlannerConfig fields, each value typed like the field's default.

    Raises:
        InputError: naming ``--param NAME``: no ``=``, an unknown name, or a value of the wrong type.
    """
    fields = {item.name: item for item in dataclasses.fields(PlannerConfig)}
    defaults = PlannerConfig().resolved()  # every field with its built-in value, hence its type
    params = {}
    for item in items:
        name, equals, text = item.partition("=")
        name = name.strip()
        if not equals:
            raise InputError(f"expected NAME=VALUE, got {item!r}", field="--param")
        if name not in fields:
            raise InputError(f"unknown parameter (expected one of: {', '.join(sorted(fields))})", field=f"--param {name}")
        default = getattr(defaults, name)
        try:
            if isinstance(default, bool):
                if text.strip().lower() not in ("true", "false", "1", "0"):
                    raise ValueError(text)
                params[name] = text.strip().lower() in ("true", "1")
            elif isinstance(default, int):
                params[name] = int(text)
            elif isinstance(default, float):
                params[name] = float(text)
            else:
                params[name] = text
        except ValueError:
            raise InputError(f"expected a {type(default).__name__}, got {text!r}", field=f"--param {name}") from None
    return params


def _config_from_options(
    scene: Scene, seed: int, time_limit: float, reconfiguration_range: float | None, planner: str, params: list[str],
    preset: str = "default",
) -> PlannerConfig:
    """Build the planner config: built-in defaults, the hand's, the preset's, then the command line's,
    naming command-line options (not config fields) in errors."""
    overrides = _parse_params(params)
    overrides.pop("preset", None)  # --preset, not --param preset=, chooses it
    try:
        config = PlannerConfig.for_scene(scene, preset=preset,
                                         **{"seed": seed, "time_limit_s": time_limit, "planner": planner, **overrides})
        if reconfiguration_range is not None:
            config = config.with_reconfiguration_range(reconfiguration_range)
    except InputError as error:
        option = _OPTION_OF_FIELD.get(error.field) if error.field not in overrides else f"--param {error.field}"
        raise InputError(error.problem, field=option or error.field) from None
    return config


def _load_object(scene: Scene, object_spec: str, pose, seed: int) -> tuple[ThinObject, tuple | None]:
    """Load the object; place an outline object at ``pose`` or a seeded random pose on the scene's table
    (clear of its obstacles).

    Returns:
        (object, the random pose drawn or None).
    """
    sampled_pose = None
    if pose is None and Path(object_spec).suffix.lower() not in CLOUD_SUFFIXES:
        outline, thickness, _ = load_outline(object_spec)
        sampled_pose = sample_pose_on_table(outline, scene.table, rng=np.random.default_rng(seed),
                                            avoid=scene.footprints(scene.table.height + thickness))
        pose = sampled_pose
    obj = load_object(object_spec, table_height=scene.table.height, pose=pose)
    return obj, sampled_pose


def _write_scene_cloud(scene: Scene, object_name: str, pose, path: Path, seed: int) -> Path | None:
    """Render the table and the object at ``pose`` with the default depth camera into a PLY cloud; None
    (nothing written) without the execution and perception extras."""
    try:
        import plyfile

        from .rendering import place_objects, render_scene

        points = render_scene(scene.table, place_objects([(object_name, pose)]), seed=seed).points
    except ImportError:  # mujoco is imported when rendering
        return None
    vertices = np.array([tuple(point) for point in points], dtype=[("x", "f4"), ("y", "f4"), ("z", "f4")])
    path.parent.mkdir(parents=True, exist_ok=True)
    plyfile.PlyData([plyfile.PlyElement.describe(vertices, "vertex")]).write(str(path))
    return path


def _summary(result: PlanResult) -> str:
    """One line: status, time, overhang, roots and pairs; for a plan not found, why pairs were rejected
    most (a collision names its pair: what to move or retune)."""
    stats = result.stats
    counts = (
        f"roots {stats.get('start_roots', 0)} start / {stats.get('goal_roots', 0)} goal, "
        f"pairs {stats.get('pairs_checked', 0)} checked / {stats.get('pairs_rejected', 0)} rejected"
    )
    if not result.solved:
        ranked = sorted(stats.get("rejections", {}).items(), key=lambda item: (-item[1], item[0]))[:3]
        why = "; most rejected: " + ", ".join(f"{count} x {reason}" for reason, count in ranked) if ranked else ""
        # The limit bounds the search; setting up (the input's checks, the collision worlds) comes before it.
        setup = stats.get("setup_time", 0.0)
        split = f" ({setup:.2f} s of it setting up before the search)" if setup >= 0.1 * result.planning_time_s else ""
        return f"{result.status} after {result.planning_time_s:.2f} s{split} ({result.planner}; {counts}{why})"
    return (
        f"solved in {result.planning_time_s:.2f} s ({result.planner}): overhang {100 * result.overhang_m:.1f} cm, "
        f"{len(result.trajectory)} waypoints, {counts}"
    )


def _plan_verify_write(scene: Scene, obj: ThinObject, config: PlannerConfig, json_path: Path | None,
                       png_path: Path | None) -> PlanResult:
    """Plan, verify a solved plan (:func:`slideplan.pipeline.plan_checked`: marked ``invalid`` if it fails,
    its violations printed) and write the outputs asked for."""
    from .pipeline import plan_checked

    with _warnings_as_lines():
        checked = plan_checked(scene, obj, config)
    if checked.verification is not None and not checked.verification.ok:
        violations = checked.verification.violations
        typer.echo(f"slideplan: plan fails verification ({len(violations)} violations):", err=True)
        for violation in violations[:_SHOWN_VIOLATIONS]:
            typer.echo(f"  {violation}", err=True)
        if len(violations) > _SHOWN_VIOLATIONS:
            typer.echo(f"  ... and {len(violations) - _SHOWN_VIOLATIONS} more", err=True)
    scene_name = Path(scene.source).stem if scene.source else "scene"
    _write_outputs(checked.result, json_path, png_path, f"{obj.name or 'object'} on {scene_name}")
    return checked.result


def _exit_for(result: PlanResult) -> typer.Exit:
    """The exit of ``plan``: 0 solved and verified, 1 not solved, 3 fails verification."""
    if result.status == "invalid":
        return typer.Exit(EXIT_INVALID_PLAN)
    return typer.Exit(EXIT_SOLVED if result.solved else EXIT_NOT_SOLVED)


def _output_file(path: Path | None, option: str, suffixes: tuple[str, ...] = ()) -> Path | None:
    """Check that an output file can be written before the work that fills it (its folder is made).

    Raises:
        InputError: naming the option and the path: a wrong suffix, a directory, or unwritable.
    """
    if path is None:
        return None
    if suffixes and path.suffix.lower() not in suffixes:
        raise InputError(f"expected a {' or '.join(suffixes)} file, got {str(path)!r}", field=option)
    if path.is_dir():
        raise InputError(f"{path} is a directory, not a file", field=option)
    existed = path.exists()
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        with open(path, "a"):
            pass
    except OSError as error:
        raise InputError(f"cannot write {path} ({error.strerror or error})", field=option) from None
    if not existed:
        path.unlink()
    return path


def _write_text(path: Path, text: str, option: str) -> None:
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_text(text)
    except OSError as error:
        raise InputError(f"cannot write {path} ({error.strerror or error})", field=option) from None


def _write_outputs(result: PlanResult, json_path: Path | None, png_path: Path | None, label: str = "") -> None:
    if json_path is not None:
        _write_text(json_path, result.to_json(indent=1), "--json")
    if png_path is not None:
        from .viz import draw_plan

        draw_plan(result, png_path, label)


@app.command("plan")
def plan_command(
    scene: str = typer.Option(
        ..., "--scene", help="Built-in scene (square, round, triangle, long, panda_square, ...) or a scene TOML file."
    ),
    object_spec: str = typer.Option(
        ..., "--object", help="Built-in object name, outline TOML, or point-cloud file (.ply/.npy/.csv/.pcd, used where it lies)."
    ),
    pose: Optional[Tuple[float, float, float]] = typer.Option(
        None, "--pose", help="X Y YAW of an outline object (m, m, rad); default: a seeded random pose on the table."
    ),
    seed: int = typer.Option(0, "--seed", help="Random seed (planner and random pose)."),
    time_limit: float = typer.Option(60.0, "--time-limit", help="Planning time budget (s)."),
    reconfiguration_range: Optional[float] = typer.Option(
        None, "--reconfiguration-range", help="dz_max - dz_min (m); default 0.02."
    ),
    planner: str = typer.Option("slideplan", "--planner", help=f"One of: {', '.join(PLANNERS)}."),
    preset: str = typer.Option(
        "default", "--preset", help="default (this project's departures from the paper on) or paper (Algorithm 1 and "
        "IsPairValid as published: docs/paper-to-code.md); recorded in the plan JSON as params.preset."
    ),
    param: list[str] = typer.Option(
        [], "--param", help="NAME=VALUE for any planner parameter (u_star, beta0, n_star, ...); repeatable; overrides "
        "the preset, the hand's [hand] params and the built-in defaults."
    ),
    json_out: Optional[Path] = typer.Option(None, "--json", help="Write the plan JSON (slideplan.plan/2) here."),
    png_out: Optional[Path] = typer.Option(None, "--png", help="Write a top-down picture here (.png or .svg)."),
    no_cache: bool = typer.Option(
        False, "--no-cache", help="Neither read nor write the stored grasp map (as SLIDEPLAN_NO_CACHE=1; "
        "SLIDEPLAN_CACHE_DIR moves it): every edge stretch the plan needs is probed anew."
    ),
) -> None:
    """Plan a pre-grasp sliding motion and verify it.

    Exit codes: 0 solved and verified, 1 not solved within the time limit, 2 bad input,
    3 solved but the plan fails verification.
    """
    if no_cache:
        os.environ[grasp_cache.NO_CACHE_ENV] = "1"
    try:
        json_out, png_out = _output_file(json_out, "--json"), _output_file(png_out, "--png", PICTURE_SUFFIXES)
        task_scene = load_scene(scene)
        config = _config_from_options(task_scene, seed, time_limit, reconfiguration_range, planner, param, preset)
        obj, sampled_pose = _load_object(task_scene, object_spec, pose, seed)
        result = _plan_verify_write(task_scene, obj, config, json_out, png_out)
    except (InputError, ValueError, OSError) as error:
        raise _fail(error) from None
    prefix = f"{obj.name} at random pose ({sampled_pose[0]:.3f}, {sampled_pose[1]:.3f}, {sampled_pose[2]:.3f}): " if sampled_pose else ""
    typer.echo(prefix + _summary(result) + (", verified" if result.solved else ""))
    raise _exit_for(result)


@app.command("demo")
def demo_command(
    out: Path = typer.Option(Path("out"), "--out", help="Directory for demo-plan.json, demo-plan.png and demo-scene.ply."),
    seed: int = typer.Option(0, "--seed", help="Random seed (object pose and planner)."),
) -> None:
    """Slide the crescent on the square table from a seeded random pose; write the plan, a picture, and the
    scene as a depth camera sees it (demo-scene.ply, for ``slideplan perceive``)."""
    try:
        scene = load_scene("square")
        config = PlannerConfig.for_scene(scene, seed=seed)
        obj, pose = _load_object(scene, "crescent", None, seed)
        result = _plan_verify_write(scene, obj, config, out / "demo-plan.json", out / "demo-plan.png")
        cloud = _write_scene_cloud(scene, "crescent", pose, out / "demo-scene.ply", seed)
    except (InputError, ValueError, OSError) as error:
        raise _fail(error) from None
    if result.solved:
        typer.echo(f"solved in {result.planning_time_s:.2f} s, overhang {100 * result.overhang_m:.1f} cm, verified")
    elif result.status == "invalid":
        typer.echo(f"solved in {result.planning_time_s:.2f} s, but the plan fails verification (see above)")
    else:
        typer.echo(_summary(result))
    typer.echo(f"wrote {out / 'demo-plan.json'} (the plan) and {out / 'demo-plan.png'} (its picture)")
    typer.echo(f"wrote {cloud} (the scene as a depth camera sees it: try slideplan perceive {cloud})" if cloud else
               "no demo-scene.ply: rendering it needs the execution and perception extras (MuJoCo, plyfile)")
    if not result.solved:
        raise typer.Exit(EXIT_INVALID_PLAN if result.status == "invalid" else EXIT_NOT_SOLVED)


@app.command("perceive")
def perceive_command(
    cloud: Path = typer.Argument(..., help="Scene point cloud, world frame, z up (.ply, .npy, .csv or .pcd)."),
    out: Path = typer.Option(..., "--out", help="Directory for scene.toml and object_<i>.ply."),
    robot_scene: str = typer.Option(
        "square", "--robot-scene", help="Scene (name or TOML) whose robot scene.toml copies, its mount as high above the table top."
    ),
    robot_base_pose: Optional[Tuple[float, float, float, float, float, float]] = typer.Option(
        None, "--robot-base-pose", help="X Y Z ROLL PITCH YAW: the robot's mount in the cloud's frame instead (m, rad)."
    ),
    plan_target: Optional[int] = typer.Option(None, "--plan-target", help="Then plan for perceived object N (0 = largest)."),
    seed: int = typer.Option(0, "--seed", help="Random seed (RANSAC and planner)."),
    time_limit: float = typer.Option(60.0, "--time-limit", help="Planning time budget (s), with --plan-target."),
    json_out: Optional[Path] = typer.Option(None, "--json", help="With --plan-target: write the plan JSON here."),
    png_out: Optional[Path] = typer.Option(None, "--png", help="With --plan-target: write a top-down picture here."),
) -> None:
    """Find the table and the thin objects in a scene cloud; write a scene and object clouds (and plan).

    Exit codes: 0 perceived (and, with --plan-target, solved and verified), 1 not solved,
    2 bad input (including no table, a tilted table, no object), 3 plan fails verification.
    """
    from .objects import load_point_cloud
    from .perception import perceive, write_perception
    try:
        json_out, png_out = _output_file(json_out, "--json"), _output_file(png_out, "--png", PICTURE_SUFFIXES)
        if plan_target is not None and plan_target < 0:
            raise InputError(f"expected an object index >= 0, got {plan_target}", field="--plan-target")
        try:  # before perception runs and files are written
            load_scene(robot_scene)
        except InputError as error:
            raise InputError(error.problem, source=error.source, field="--robot-scene") from None
        if robot_base_pose is not None:
            as_numbers(list(robot_base_pose), 6, source="", field="--robot-base-pose")
        perception = perceive(load_point_cloud(cloud), seed=seed, source=str(cloud))
        if plan_target is not None and plan_target >= len(perception.objects):
            raise InputError(f"no object {plan_target}: the perceived objects are 0 to {len(perception.objects) - 1}",
                             field="--plan-target")
        scene_path, cloud_paths = write_perception(perception, out, robot_scene=robot_scene, base_pose=robot_base_pose)
    except (ImportError, InputError, OSError) as error:
        raise _fail(error) from None
    table = perception.table
    typer.echo(f"table: height {table.height:.4f} m, {len(table.vertices)} vertices, area {table.area:.3f} m^2 -> {scene_path}")
    for index, (perceived, path) in enumerate(zip(perception.objects, cloud_paths)):
        x, y = perceived.centroid_xy
        typer.echo(f"object {index}: centre ({x:.3f}, {y:.3f}), thickness {1000 * perceived.thickness:.1f} mm, "
                   f"area {100 * 100 * perceived.footprint.area:.0f} cm^2 -> {path}")
    try:
        scene = load_scene(str(scene_path))
        reach = table_reach(scene, max(perceived.thickness for perceived in perception.objects))
    except (InputError, ValueError, OSError) as error:
        raise _fail(error) from None
    warnings = list(perception.warnings)
    if reach < MIN_TABLE_REACH:  # a mount copied from a scene with its table elsewhere: every plan would time out
        warnings.append(f"the fingertip reaches the table top at beta0 = {PlannerConfig.for_scene(scene).beta0:g} over only "
                        f"{100 * reach:.0f}% of the table (a 5 x 5 grid): check the robot's mount (--robot-base-pose)")
    for warning in warnings:
        typer.echo(f"slideplan: warning: {warning}", err=True)
    if plan_target is None:
        return
    try:
        config = _config_from_options(scene, seed, time_limit, None, "slideplan", [])
        from .pipeline import for_perceived

        margin = perception.edge_uncertainty
        config = for_perceived(config, margin)
        typer.echo(f"planning with u* and grasp_standoff raised by the perception's edge uncertainty, {1000 * margin:.1f} mm")
        obj, _ = _load_object(scene, str(cloud_paths[plan_target]), None, seed)
        result = _plan_verify_write(scene, obj, config, json_out, png_out)
    except (InputError, ValueError, OSError) as error:
        raise _fail(error) from None
    typer.echo(_summary(result) + (", verified" if result.solved else ""))
    raise _exit_for(result)


@app.command("check-scene")
def check_scene_command(
    scene_name: str = typer.Argument(..., help="Built-in scene name or scene TOML."),
    object_name: str = typer.Option("square", "--object", help="An object like the ones to slide (its thickness counts)."),
    param: list[str] = typer.Option([], "--param", help="NAME=VALUE for any planner parameter; repeatable."),
    png_out: Optional[Path] = typer.Option(
        None, "--png", help="Draw a map here (.png or .svg): where the fingertip reaches the table, which edge stretches admit a grasp."
    ),
) -> None:
    """Check a robot scene before planning: links that collide wherever the arm is, whether the fingertip
    reaches the table, which table edges admit a side grasp and a clear pre-grasp, and why not, naming
    links, obstacles and parameters.

    Exit codes: 0 the scene can plan, 1 it cannot (the first lines say why), 2 bad input.
    """
    from .check_scene import check_scene

    try:
        png_out = _output_file(png_out, "--png", PICTURE_SUFFIXES)
        scene = load_scene(scene_name)
        obj, _ = _load_object(scene, object_name, None, 0)
        result = check_scene(scene, obj, PlannerConfig.for_scene(scene, **_parse_params(param)))
        if png_out is not None:
            from .viz import draw_scene_check

            draw_scene_check(scene, result, png_out)
    except (InputError, ValueError, OSError) as error:
        raise _fail(error) from None
    for line in result.lines:
        typer.echo(line)
    raise typer.Exit(EXIT_SOLVED if result.ok else EXIT_NOT_SOLVED)


@app.command("export")
def export_command(
    plan_file: Path = typer.Argument(..., help="A solved plan JSON (slideplan.plan/2, or /1: it is timed on export)."),
    fmt: str = typer.Option(..., "--format", help="ros-json (trajectory_msgs/JointTrajectory per segment) or csv."),
    out: Path = typer.Option(..., "--out", help="Output file."),
) -> None:
    """Write a plan's timed slide and approach for a controller.

    Exit codes: 0 written, 2 bad input (unreadable or unknown plan, plan not solved, unknown format).
    """
    from .export import export_plan

    try:
        result = PlanResult.load(plan_file)
        with _warnings_as_lines():
            export_plan(result, fmt, out)
    except InputError as error:
        if not error.source and error.field != "--format":  # e.g. "status": a field of the plan file
            error = InputError(error.problem, source=str(plan_file), field=error.field)
        raise _fail(error) from None
    except OSError as error:
        raise _fail(error) from None
    typer.echo(str(out))


@app.command("view")
def view_command(
    plan_file: Path = typer.Argument(..., help="A plan JSON (slideplan.plan/1 or /2, solved or not)."),
    host: str = typer.Option("127.0.0.1", "--host", help="Interface to listen on (default: this machine only)."),
    port: int = typer.Option(8080, "--port", help="Port to try first; the next free one is used if it is taken."),
    record_out: Optional[Path] = typer.Option(
        None, "--record", help="Instead of serving, write the animated view to OUT.html (opens in any browser) or OUT.viser."
    ),
) -> None:
    """Show a plan in 3D in the browser: robot, table, object, fingertip path, grasp; a time slider plays the plan.

    Exit codes: 0 (after Ctrl-C, or once the recording is written), 2 bad input.
    """
    try:
        from . import view

        record_out = _output_file(record_out, "--record")
        result = PlanResult.load(plan_file)
        if not 0 <= port < 65536:
            raise InputError(f"must be in [0, 65536), got {port}", field="--port")
        with _warnings_as_lines():
            if record_out is not None:
                typer.echo(str(view.record(result, record_out)))
                return
            shown = view.open_view(result, host, port)
    except InputError as error:
        if not error.source and not error.field.startswith("--"):  # a field of the plan file
            error = InputError(error.problem, source=str(plan_file), field=error.field)
        raise _fail(error) from None
    except ImportError as error:
        raise _fail(error) from None
    except OSError as error:  # an unwritable --record
        raise _fail(InputError(str(error), field="--record")) from None
    if shown.server.get_port() != port:
        typer.echo(f"slideplan: port {port} is in use; using {shown.server.get_port()}", err=True)
    if not _is_loopback(host):
        where = "every network interface" if host in ("0.0.0.0", "::", "") else host
        typer.echo(f"slideplan: warning: serving on {where}: anyone who can reach this machine on port "
                   f"{shown.server.get_port()} can open the view (there is no password)", err=True)
    status = "" if result.solved else f" (not solved: {result.status}; showing the scene only)"
    typer.echo(f"view at {shown.url}{status}; Ctrl-C to stop")
    try:
        while True:
            time.sleep(1.0)
    except KeyboardInterrupt:
        pass
    finally:
        shown.server.stop()


def _is_loopback(host: str) -> bool:
    """Whether ``host`` is this machine only (an address or a name resolved here)."""
    try:
        return ipaddress.ip_address(socket.gethostbyname(host) if ":" not in host else host).is_loopback
    except (OSError, ValueError, UnicodeError):
        return False


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
        from .execute import ExecutionSettings, execute

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
        from .closed_loop import Disturbance, run

        json_out, video = _output_file(json_out, "--json"), _output_file(video, "--video", VIDEO_SUFFIXES)
        scene = load_scene(scene_name)
        if pose is None:
            outline, _, _ = load_outline(object_name)
            pose = sample_pose_on_table(outline, scene.table, rng=np.random.default_rng(seed))
        disturbance = None if disturb is None else Disturbance(*disturb)
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
    from .closed_loop import default_camera
    from .rendering import Camera

    if camera is None:
        return default_camera(scene)
    position, target = np.asarray(camera[:3], dtype=float), np.asarray(camera[3:], dtype=float)
    if not (np.all(np.isfinite(camera)) and np.all(np.abs(camera) <= 1e3)) or np.linalg.norm(position - target) < 0.05:
        raise InputError(f"expected a position and a distinct target (m, within 1e3), got {camera}", field="--camera")
    return Camera(tuple(position), tuple(target))


def _experiment_executor(workers: int | None, scheduler: str | None, threads: bool = False):
    """The executor the options ask for: a Dask scheduler, or local processes or threads (default: all cores).

    Raises:
        InputError: both options given, or a worker count < 1.
    """
    from .experiments import DaskExecutor, LocalPoolExecutor

    if workers is not None and scheduler is not None:
        raise InputError("give at most one of --workers and --scheduler", field="--workers")
    if threads and scheduler is not None:
        raise InputError("--threads is for local workers; give the Dask workers their threads", field="--threads")
    return DaskExecutor(scheduler) if scheduler is not None else LocalPoolExecutor(workers, threads=threads)


@app.command("experiment")
def experiment_command(
    figure: str = typer.Argument(
        ..., help="Which experiment: fig10, fig11 or fig12 (paper section V), execution (Fig. 10's plans executed in MuJoCo) "
        "or closed-loop (a task set run whole in MuJoCo, open and closed loop, in every setting: --set)."
    ),
    task_set: str = typer.Option(
        "dev", "--set", help="closed-loop's task set: dev (Fig. 10's objects, to fix failures on) or eval (held out: "
        "the letters Y, A, L, E, 5 poses per table, its own seed; run once, on one build)."
    ),
    out: Path = typer.Option(..., "--out", help="Output directory; results go to OUT/results/ (one Parquet file per task)."),
    quick: bool = typer.Option(False, "--quick", help="A small subset: 2 objects x 2 poses per cell, 5 s limit."),
    poses: Optional[int] = typer.Option(
        None, "--poses", help="Initial poses per cell instead of the paper's (fewer poses, same budget)."
    ),
    time_limit: Optional[float] = typer.Option(
        None, "--time-limit", help="Planning time budget per task (s); default 60 (the paper's), 5 with --quick."
    ),
    seed: int = typer.Option(0, "--seed", help="Experiment seed: initial poses and planner seeds derive from it."),
    workers: Optional[int] = typer.Option(None, "--workers", help="Local workers (default: all cores)."),
    threads: bool = typer.Option(False, "--threads", help="Local workers are threads of this process, not processes."),
    scheduler: Optional[str] = typer.Option(
        None, "--scheduler", help="Run on a Dask cluster at this scheduler address instead (e.g. tcp://host:8786)."
    ),
    param: list[str] = typer.Option(
        [], "--param", help="NAME=VALUE for any planner parameter, applied to every task after the figure's; repeatable."
    ),
    preset: str = typer.Option(
        "default", "--preset", help="default or paper (every departure from the paper off) for the slideplan tasks; "
        "the baselines always run as published."
    ),
    planner: list[str] = typer.Option(
        [], "--planner", help="Run only this planner's tasks of the figure (slideplan, cbirrt, cbirrt2); repeatable; "
        "default: all. Fig. 11's baselines are the same tasks in both presets."
    ),
) -> None:
    """Run the planning tasks of one figure, resuming: tasks with a result in OUT/results/ are skipped.

    Exit codes: 0 every task has a result, 1 some tasks raised or were lost (see the
    summary; rerun the same command to run lost tasks), 2 bad input.
    """
    try:
        from .experiments import build_spec, run_experiment

        spec = build_spec(figure, quick=quick, time_limit_s=time_limit, seed=seed, poses=poses, params=_parse_params(param),
                          preset=preset, planners=tuple(planner) or None, task_set=task_set)
        executor = _experiment_executor(workers, scheduler, threads)
        typer.echo(f"{figure}: {len(spec.tasks)} tasks on {executor.description}, results in {out / 'results'}")
        summary = run_experiment(spec, out, executor)
    except InputError as error:
        raise _fail(InputError(error.problem, source=error.source, field=_OPTION_OF_FIELD.get(error.field, error.field))) from None
    except (ImportError, OSError) as error:
        raise _fail(error) from None
    typer.echo(
        f"{summary.executed} run ({summary.solved} solved, {summary.errors} raised), "
        f"{summary.skipped} already done, {summary.lost} lost"
    )
    if figure == "execution":
        from .experiments.execution import load_execution, plot_execution, summarize_execution

        results = load_execution(out)
        typer.echo(summarize_execution(results).to_string(index=False))
        for path in plot_execution(results, out):
            typer.echo(str(path))
    if figure == "closed-loop":
        from .experiments.closed_loop import closed_loop_runs, load_closed_loop, plot_closed_loop, summarize_closed_loop

        runs = closed_loop_runs(load_closed_loop(out))
        typer.echo(summarize_closed_loop(runs).to_string(index=False))
        for path in plot_closed_loop(runs, out):
            typer.echo(str(path))
    if summary.lost:
        typer.echo(f"slideplan: {summary.lost} tasks lost, first: {summary.first_loss}; rerun to resume", err=True)
    if summary.errors or summary.lost:
        raise typer.Exit(EXIT_NOT_SOLVED)


@app.command("plot")
def plot_command(
    results: Path = typer.Argument(..., help="An experiment output directory, its results/ directory, or a Parquet file."),
    out: Path = typer.Option(..., "--out", help="Directory for the figures (PNG and SVG)."),
) -> None:
    """Draw Figs. 10-12 from experiment results, each figure whose experiment is present.

    Exit codes: 0 figures written, 2 bad input (no such path, or no results of fig10-12 in it).
    """
    try:
        from .plots import plot_results

        paths = plot_results(results, out)
    except (ImportError, OSError, ValueError) as error:  # pyarrow's unreadable-file errors are ValueErrors
        raise _fail(error) from None
    if not paths:
        raise _fail(InputError("no planning results of fig10, fig11 or fig12 (`plot` draws those; "
                               "`slideplan experiment execution|closed-loop --out DIR` draws its own figures in DIR)", source=str(results)))
    for path in paths:
        typer.echo(str(path))


ros_app = typer.Typer(cls=_OneLineErrors, no_args_is_help=True, help="slideplan on a ROS 2 robot (docs/ros2.md; the ros extra).")
app.add_typer(ros_app, name="ros")
_ROS_ARGS = {"allow_extra_args": True, "ignore_unknown_options": True}


def _ros_args(context: typer.Context) -> list[str]:
    """What follows ``--ros-args`` (remappings ``-r FROM:=TO``, parameters ``-p NAME:=VALUE``); nothing
    else may be left over."""
    extra = list(context.args)
    if extra and extra[0] != "--ros-args":
        raise _fail(InputError(f"unexpected argument {extra[0]!r} (ROS arguments go after --ros-args)"))
    return extra


def _ros_import(module: str):
    try:
        return __import__(f"slideplan.ros.{module}", fromlist=[module])
    except ImportError as error:
        raise _fail(InputError(f"the ros extra is not installed ({error}): pip install 'slideplan[ros]'")) from None


@ros_app.command("serve", context_settings=_ROS_ARGS)
def ros_serve_command(
    context: typer.Context,
    scene_name: str = typer.Option("square", "--scene", help="The robot's scene (URDF, mount, hand): built-in name or TOML."),
    camera_pose: Optional[Tuple[float, float, float, float, float, float]] = typer.Option(
        None, "--camera-pose", help="X Y Z ROLL PITCH YAW of the cloud's frame in the world (parameter camera_pose)."),
    target: int = typer.Option(0, "--target", help="Which object to slide, largest first (parameter target)."),
    closed: bool = typer.Option(True, "--closed-loop/--open-loop", help="Watch and re-plan while sliding (parameter closed_loop)."),
    sim_time: bool = typer.Option(False, "--sim-time", help="Run on the simulator's /clock (parameter use_sim_time)."),
) -> None:
    """The planning node ``slideplan``: services /slideplan/plan and /slideplan/execute (docs/ros2.md).
    ROS arguments (remappings, parameters) go after --ros-args. Exit codes: 0 on Ctrl-C, 2 bad input."""
    ros_args = _ros_args(context)
    serve = _ros_import("serve")
    try:
        scene = load_scene(scene_name)
    except (InputError, OSError, ValueError) as error:
        raise _fail(error) from None
    parameters = {"target": target, "closed_loop": closed, "use_sim_time": sim_time}
    if camera_pose is not None:
        parameters["camera_pose"] = [float(value) for value in camera_pose]
    try:
        serve.serve(scene, parameters, ros_args=ros_args, log=typer.echo)
    except InputError as error:
        raise _fail(error) from None


@ros_app.command("call", context_settings=_ROS_ARGS)
def ros_call_command(
    context: typer.Context,
    service: str = typer.Argument(..., help="plan, execute, or a Trigger service's full name (/slideplan/plan)."),
    timeout: float = typer.Option(600.0, "--timeout", help="Seconds to wait for the answer once called (execute runs a whole task)."),
    wait: float = typer.Option(30.0, "--wait", help="Seconds to wait for the service to appear."),
) -> None:
    """Call the planning node's /slideplan/plan or /slideplan/execute (std_srvs/Trigger) and print its answer:
    what ROS 2's `ros2 service call` would do, without ROS 2's command line tools. Exit codes: 0 the service
    answered success, 1 it answered failure, 2 bad input or no answer."""
    ros_args = _ros_args(context)
    call = _ros_import("call")
    name = f"/slideplan/{service}" if service in ("plan", "execute") else service
    try:
        for value, option in ((timeout, "--timeout"), (wait, "--wait")):
            if not (math.isfinite(value) and value > 0):
                raise InputError(f"must be a finite number > 0, got {value}", field=option)
        success, message = call.call_trigger(name, wait_s=wait, answer_s=timeout, ros_args=ros_args[1:])
    except InputError as error:
        raise _fail(InputError(error.problem, field={"timeout": "--timeout", "service": "SERVICE"}.get(error.field, error.field))) from None
    typer.echo(f"{name}: {'success' if success else 'failure'}: {message}")
    if not success:
        raise typer.Exit(EXIT_NOT_SOLVED)


def _numbers(text: str, option: str, unit: str) -> list[float]:
    """The comma-separated numbers of ``option`` (in ``unit``, for the message).

    Raises:
        InputError: one is not a number (field ``option``).
    """
    try:
        return [float(value) for value in text.split(",")]
    except ValueError:
        raise InputError(f"expected comma-separated numbers ({unit}), got {text!r}", field=option) from None


def _disturb_values(disturb: tuple[float, float, float, float]) -> tuple[float, float, float, float]:
    """``--disturb DX DY DYAW T`` checked: a push within a metre and a turn, T in [0, 600] s (MuJoCo resets
    an object moved beyond any table, and a NaN poisons the simulation).

    Raises:
        InputError: (``--disturb``) naming the value.
    """
    for name, value, bound, unit in zip(("DX", "DY", "DYAW"), disturb, (1.0, 1.0, 2 * math.pi), ("m", "m", "rad")):
        if not math.isfinite(value):
            raise InputError(f"{name} {value} is not a finite number", field="--disturb")
        if abs(value) > bound:
            raise InputError(f"{name} {value:g} is beyond {bound:g} {unit} in magnitude", field="--disturb")
    if not 0.0 <= disturb[3] <= 600.0:
        raise InputError(f"T must be in [0, 600] s, got {disturb[3]:g}", field="--disturb")
    return disturb


@ros_app.command("sim", context_settings=_ROS_ARGS)
def ros_sim_command(
    context: typer.Context,
    scene_name: str = typer.Option("square", "--scene", help="Built-in scene name or scene TOML."),
    object_name: str = typer.Option("crescent", "--object", help="Object outline: a name in data/objects or a TOML."),
    pose: Optional[Tuple[float, float, float]] = typer.Option(
        None, "--pose", help="X Y YAW where the object lies (m, m, rad); default: drawn on the table from --seed."),
    seed: int = typer.Option(1, "--seed", help="Seeds the pose, the camera noise and the random setting."),
    setting: str = typer.Option("nominal", "--setting", help="nominal, stress or random (physics drawn per --seed)."),
    disturb: Optional[Tuple[float, float, float, float]] = typer.Option(
        None, "--disturb", help="DX DY DYAW T: move the object by (DX, DY) m and turn it by DYAW rad T s after the finger first touches it."),
    home: Optional[str] = typer.Option(None, "--home", help="The arm's first configuration, comma-separated (rad); default all 0."),
    cloud_hz: float = typer.Option(5.0, "--cloud-rate", help="Depth clouds per second on /camera/points."),
) -> None:
    """The MuJoCo robot ``slideplan_sim``: /joint_states, /camera/points, /slideplan_sim/object_pose; follows
    /joint_trajectory_controller/joint_trajectory; serves /gripper/set (docs/ros2.md). Exit codes: 0 on
    Ctrl-C, 2 bad input."""
    ros_args = _ros_args(context)
    sim = _ros_import("sim")
    try:
        from .closed_loop import Disturbance

        scene = load_scene(scene_name)
        if pose is None:
            outline, _, _ = load_outline(object_name)
            pose = sample_pose_on_table(outline, scene.table, rng=np.random.default_rng(seed))
        if not (np.isfinite(cloud_hz) and 0 < cloud_hz <= 60):
            raise InputError(f"expected a rate in (0, 60] Hz, got {cloud_hz}", field="--cloud-rate")
        configuration = None if home is None else _numbers(home, "--home", "rad")
        disturbance = None if disturb is None else Disturbance(*_disturb_values(disturb))
        robot = sim.Sim(scene, object_name, pose, setting=setting, seed=seed, home=configuration, disturbance=disturbance)
    except InputError as error:
        raise _fail(InputError(error.problem, source=error.source, field=_OPTION_OF_FIELD.get(error.field, error.field))) from None
    except (OSError, ValueError) as error:
        raise _fail(error) from None
    try:
        sim.serve(robot, cloud_hz=cloud_hz, ros_args=ros_args, log=typer.echo)
    except InputError as error:
        raise _fail(error) from None


if __name__ == "__main__":
    app(prog_name="slideplan")
