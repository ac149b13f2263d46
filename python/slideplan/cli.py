"""Command line: ``slideplan plan``, ``demo``, ``perceive``, ``experiment`` and ``plot`` (DESIGN.md 5).

Exit codes of ``plan``: 0 solved (and verified), 1 not solved within the time limit,
2 bad input (one line ``slideplan: error: ...`` on stderr), 3 solved but the plan fails
the independent verification (a planner bug; the violations go to stderr and the JSON
is written with status ``"invalid"``).

``experiment`` and ``plot`` need the ``experiments`` extra (pandas, pyarrow, dask);
``perceive`` the ``perception`` extra (scikit-learn, SciPy).
"""

from __future__ import annotations

import dataclasses
from pathlib import Path
from typing import Optional, Tuple

import numpy as np
import typer

from .errors import InputError
from .objects import CLOUD_SUFFIXES, ThinObject, load_object, load_outline, sample_pose_on_table
from .planning import PLANNERS, PlannerConfig, PlanResult
from .scenes import Scene, load_scene

EXIT_SOLVED, EXIT_NOT_SOLVED, EXIT_BAD_INPUT, EXIT_INVALID_PLAN = 0, 1, 2, 3
_SHOWN_VIOLATIONS = 20  # a broken plan can have thousands; the first ones tell the story

# Command-line option names of the PlannerConfig fields the CLI sets, for error messages.
_OPTION_OF_FIELD = {
    "seed": "--seed",
    "time_limit_s": "--time-limit",
    "reconfiguration_range": "--reconfiguration-range",
    "dz_max": "--reconfiguration-range",
    "planner": "--planner",
    "workers": "--workers",
    "scheduler": "--scheduler",
}

app = typer.Typer(
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


def _config_from_options(seed: int, time_limit: float, reconfiguration_range: float | None, planner: str) -> PlannerConfig:
    """Build the planner config, naming command-line options (not config fields) in errors."""
    try:
        config = PlannerConfig(seed=seed, time_limit_s=time_limit, planner=planner)
        if reconfiguration_range is not None:
            config = config.with_reconfiguration_range(reconfiguration_range)
    except InputError as error:
        raise InputError(error.problem, field=_OPTION_OF_FIELD.get(error.field, error.field)) from None
    return config


def _load_task(scene_spec: str, object_spec: str, pose, seed: int) -> tuple[Scene, ThinObject, tuple | None]:
    """Load the scene and the object; place an outline object at ``pose`` or a seeded random pose.

    Returns:
        (scene, object, the random pose drawn or None).
    """
    scene = load_scene(scene_spec)
    sampled_pose = None
    if pose is None and Path(object_spec).suffix.lower() not in CLOUD_SUFFIXES:
        outline, _, _ = load_outline(object_spec)
        sampled_pose = sample_pose_on_table(outline, scene.table, rng=np.random.default_rng(seed))
        pose = sampled_pose
    obj = load_object(object_spec, table_height=scene.table.height, pose=pose)
    return scene, obj, sampled_pose


def _summary(result: PlanResult) -> str:
    """One line: status, time, overhang, roots and pairs."""
    stats = result.stats
    counts = (
        f"roots {stats.get('start_roots', 0)} start / {stats.get('goal_roots', 0)} goal, "
        f"pairs {stats.get('pairs_checked', 0)} checked / {stats.get('pairs_rejected', 0)} rejected"
    )
    if not result.solved:
        return f"{result.status} after {result.planning_time_s:.2f} s ({result.planner}; {counts})"
    return (
        f"solved in {result.planning_time_s:.2f} s ({result.planner}): overhang {100 * result.overhang_m:.1f} cm, "
        f"{len(result.trajectory)} waypoints, {counts}"
    )


def _verify_and_mark(result: PlanResult) -> PlanResult:
    """Verify a solved plan; print its violations and return it marked ``invalid`` if it fails."""
    from .verify import verify

    verification = verify(result)
    if verification.ok:
        return result
    typer.echo(f"slideplan: plan fails verification ({len(verification.violations)} violations):", err=True)
    for violation in verification.violations[:_SHOWN_VIOLATIONS]:
        typer.echo(f"  {violation}", err=True)
    if len(verification.violations) > _SHOWN_VIOLATIONS:
        typer.echo(f"  ... and {len(verification.violations) - _SHOWN_VIOLATIONS} more", err=True)
    return dataclasses.replace(result, status="invalid")


def _write_outputs(result: PlanResult, json_path: Path | None, png_path: Path | None) -> None:
    if json_path is not None:
        json_path.parent.mkdir(parents=True, exist_ok=True)
        json_path.write_text(result.to_json(indent=1))
    if png_path is not None:
        from .viz import draw_plan

        draw_plan(result, png_path)


@app.command("plan")
def plan_command(
    scene: str = typer.Option(..., "--scene", help="Built-in scene (square, round, triangle, long) or a scene TOML file."),
    object_spec: str = typer.Option(
        ..., "--object", help="Built-in object name, outline TOML, or point-cloud file (.ply/.npy/.csv, used where it lies)."
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
    json_out: Optional[Path] = typer.Option(None, "--json", help="Write the plan JSON (slideplan.plan/1) here."),
    png_out: Optional[Path] = typer.Option(None, "--png", help="Write a top-down picture here (.png or .svg)."),
) -> None:
    """Plan a pre-grasp sliding motion and verify it.

    Exit codes: 0 solved and verified, 1 not solved within the time limit, 2 bad input,
    3 solved but the plan fails verification.
    """
    from .planning import plan

    try:
        config = _config_from_options(seed, time_limit, reconfiguration_range, planner)
        task_scene, obj, sampled_pose = _load_task(scene, object_spec, pose, seed)
        result = plan(task_scene, obj, config)
        if result.solved:
            result = _verify_and_mark(result)
        _write_outputs(result, json_out, png_out)
    except (InputError, ValueError, OSError) as error:
        raise _fail(error) from None
    prefix = f"{obj.name} at random pose ({sampled_pose[0]:.3f}, {sampled_pose[1]:.3f}, {sampled_pose[2]:.3f}): " if sampled_pose else ""
    typer.echo(prefix + _summary(result) + (", verified" if result.solved else ""))
    if result.status == "invalid":
        raise typer.Exit(EXIT_INVALID_PLAN)
    raise typer.Exit(EXIT_SOLVED if result.solved else EXIT_NOT_SOLVED)


@app.command("demo")
def demo_command(
    out: Path = typer.Option(Path("out"), "--out", help="Directory for demo-plan.json and demo-plan.png."),
    seed: int = typer.Option(0, "--seed", help="Random seed (object pose and planner)."),
) -> None:
    """Slide the crescent on the square table from a seeded random pose; write the plan and a picture."""
    from .planning import plan

    try:
        scene, obj, _ = _load_task("square", "crescent", None, seed)
        result = plan(scene, obj, PlannerConfig(seed=seed))
        if result.solved:
            result = _verify_and_mark(result)
        _write_outputs(result, out / "demo-plan.json", out / "demo-plan.png")
    except (InputError, ValueError, OSError) as error:
        raise _fail(error) from None
    if result.solved:
        typer.echo(f"solved in {result.planning_time_s:.2f} s, overhang {100 * result.overhang_m:.1f} cm, verified")
    elif result.status == "invalid":
        typer.echo(f"solved in {result.planning_time_s:.2f} s, but the plan fails verification (see above)")
        raise typer.Exit(EXIT_INVALID_PLAN)
    else:
        typer.echo(_summary(result))
        raise typer.Exit(EXIT_NOT_SOLVED)


@app.command("perceive")
def perceive_command(
    cloud: Path = typer.Argument(..., help="Scene point cloud, world frame, z up (.ply, .npy, .csv or .pcd)."),
    out: Path = typer.Option(..., "--out", help="Directory for scene.toml and object_<i>.ply."),
    robot_scene: str = typer.Option("square", "--robot-scene", help="Scene (name or TOML) whose robot mount scene.toml copies."),
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
    from .planning import plan

    try:
        perception = perceive(load_point_cloud(cloud), seed=seed, source=str(cloud))
        scene_path, cloud_paths = write_perception(perception, out, robot_scene=robot_scene)
        if plan_target is not None and not 0 <= plan_target < len(cloud_paths):
            raise InputError(f"no object {plan_target}: the perceived objects are 0 to {len(cloud_paths) - 1}", field="--plan-target")
    except (ImportError, InputError, OSError) as error:
        raise _fail(error) from None
    table = perception.table
    typer.echo(f"table: height {table.height:.4f} m, {len(table.vertices)} vertices, area {table.area:.3f} m^2 -> {scene_path}")
    for index, (perceived, path) in enumerate(zip(perception.objects, cloud_paths)):
        x, y = perceived.centroid_xy
        typer.echo(f"object {index}: centre ({x:.3f}, {y:.3f}), thickness {1000 * perceived.thickness:.1f} mm, "
                   f"area {100 * 100 * perceived.footprint.area:.0f} cm^2 -> {path}")
    for warning in perception.warnings:
        typer.echo(f"slideplan: warning: {warning}", err=True)
    if plan_target is None:
        return
    try:
        scene, obj, _ = _load_task(str(scene_path), str(cloud_paths[plan_target]), None, seed)
        result = plan(scene, obj, _config_from_options(seed, time_limit, None, "slideplan"))
        if result.solved:
            result = _verify_and_mark(result)
        _write_outputs(result, json_out, png_out)
    except (InputError, ValueError, OSError) as error:
        raise _fail(error) from None
    typer.echo(_summary(result) + (", verified" if result.solved else ""))
    if result.status == "invalid":
        raise typer.Exit(EXIT_INVALID_PLAN)
    raise typer.Exit(EXIT_SOLVED if result.solved else EXIT_NOT_SOLVED)


def _experiment_executor(workers: int | None, scheduler: str | None):
    """The executor the options ask for: a Dask scheduler, or local processes (default: all cores).

    Raises:
        InputError: both options given, or a worker count < 1.
    """
    from .experiments import DaskExecutor, LocalPoolExecutor

    if workers is not None and scheduler is not None:
        raise InputError("give at most one of --workers and --scheduler", field="--workers")
    return DaskExecutor(scheduler) if scheduler is not None else LocalPoolExecutor(workers)


@app.command("experiment")
def experiment_command(
    figure: str = typer.Argument(..., help="Which experiment: fig10, fig11 or fig12 (paper section V)."),
    out: Path = typer.Option(..., "--out", help="Output directory; results go to OUT/results/ (one Parquet file per task)."),
    quick: bool = typer.Option(False, "--quick", help="A small subset: 2 objects x 2 poses per cell, 5 s limit."),
    poses: Optional[int] = typer.Option(
        None, "--poses", help="Initial poses per cell instead of the paper's (fewer poses, same budget)."
    ),
    time_limit: Optional[float] = typer.Option(
        None, "--time-limit", help="Planning time budget per task (s); default 60 (the paper's), 5 with --quick."
    ),
    seed: int = typer.Option(0, "--seed", help="Experiment seed: initial poses and planner seeds derive from it."),
    workers: Optional[int] = typer.Option(None, "--workers", help="Local worker processes (default: all cores)."),
    scheduler: Optional[str] = typer.Option(
        None, "--scheduler", help="Run on a Dask cluster at this scheduler address instead (e.g. tcp://host:8786)."
    ),
) -> None:
    """Run the planning tasks of one figure, resuming: tasks with a result in OUT/results/ are skipped.

    Exit codes: 0 every task has a result, 1 some tasks raised or were lost (see the
    summary; rerun the same command to run lost tasks), 2 bad input.
    """
    try:
        from .experiments import build_spec, run_experiment

        spec = build_spec(figure, quick=quick, time_limit_s=time_limit, seed=seed, poses=poses)
        executor = _experiment_executor(workers, scheduler)
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
        raise _fail(InputError("no planning results of fig10, fig11 or fig12", source=str(results)))
    for path in paths:
        typer.echo(str(path))


if __name__ == "__main__":
    app(prog_name="slideplan")
