"""``slideplan plan``, ``demo``, ``perceive`` and ``check-scene``."""

from __future__ import annotations

import os
from pathlib import Path
from typing import Optional, Tuple

import typer

from .._fields import as_numbers
from .._limits import MAX_SCENE_MAGNITUDE
from .. import grasp_cache
from ..errors import InputError
from ..plan.config import PLANNERS, PlannerConfig
from ..plan.robot import table_reach
from ..world.scenes import load_scene
from .common import (
    _OPTION_OF_FIELD,
    EXIT_INVALID_PLAN,
    EXIT_NOT_SOLVED,
    EXIT_SOLVED,
    MIN_TABLE_REACH,
    PICTURE_SUFFIXES,
    _config_from_options,
    _exit_for,
    _fail,
    _load_object,
    _output_file,
    _parse_params,
    _plan_verify_write,
    _summary,
    _write_scene_cloud,
    app,
)


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
    from ..world.objects import load_point_cloud
    from ..perception.tabletop import perceive
    from ..perception.files import write_perception
    try:
        json_out, png_out = _output_file(json_out, "--json"), _output_file(png_out, "--png", PICTURE_SUFFIXES)
        if plan_target is not None and plan_target < 0:
            raise InputError(f"expected an object index >= 0, got {plan_target}", field="--plan-target")
        try:  # before perception runs and files are written
            load_scene(robot_scene)
        except InputError as error:
            raise InputError(error.problem, source=error.source, field="--robot-scene") from None
        if robot_base_pose is not None:
            as_numbers(list(robot_base_pose), 6, source="", field="--robot-base-pose", bound=MAX_SCENE_MAGNITUDE)
        try:  # the planner's options, named before any file is written
            PlannerConfig(seed=seed, time_limit_s=time_limit).resolved()
        except InputError as error:
            raise InputError(error.problem, field=_OPTION_OF_FIELD.get(error.field, error.field)) from None
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
        from ..checks.pipeline import for_perceived

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
    from ..checks.scene import check_scene

    try:
        png_out = _output_file(png_out, "--png", PICTURE_SUFFIXES)
        scene = load_scene(scene_name)
        obj, _ = _load_object(scene, object_name, None, 0)
        result = check_scene(scene, obj, PlannerConfig.for_scene(scene, **_parse_params(param)))
        if png_out is not None:
            from ..outputs.pictures import draw_scene_check

            draw_scene_check(scene, result, png_out)
    except (InputError, ValueError, OSError) as error:
        raise _fail(error) from None
    for line in result.lines:
        typer.echo(line)
    raise typer.Exit(EXIT_SOLVED if result.ok else EXIT_NOT_SOLVED)
