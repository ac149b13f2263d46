"""``slideplan experiment`` and ``plot`` (the ``experiments`` extra)."""

from __future__ import annotations

import contextlib
from pathlib import Path
from typing import Optional

import typer

from ..errors import InputError
from .common import EXIT_NOT_SOLVED, _OPTION_OF_FIELD, _fail, _parse_params, app


@contextlib.contextmanager
def _tally_bar(description: str, fields: str):
    """A progress bar (:func:`slideplan.experiments.runner.progress_bar`) and the callback that moves it from a
    tally ``{"total", "done", ...}`` (the other keys feed ``fields``)."""
    from ..experiments.runner import progress_bar

    with progress_bar(fields) as bar:
        shown = []

        def show(tally: dict) -> None:
            extra = {name: value for name, value in tally.items() if name not in ("total", "done")}
            if not shown:
                shown.append(bar.add_task(description, total=tally["total"], **extra))
            bar.update(shown[0], completed=tally["done"], **extra)

        yield bar, show


def _experiment_executor(workers: int | None, scheduler: str | None, threads: bool = False):
    """The executor the options ask for: a Dask scheduler, or local processes or threads (default: all cores).

    Raises:
        InputError: both options given, or a worker count < 1.
    """
    from ..experiments import DaskExecutor, LocalPoolExecutor

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
        "dev", "--set", help="closed-loop's task set: dev (Fig. 10's objects, to fix failures on), eval (the letters Y, "
        "A, L, E: once held out, now worked on as dev), eval2 (held out: 8 objects on 5 tables, 5 poses each, its own "
        "seed; run once, on one build) or clutter (the paper's objects among the bundled scenes' clutter, nominal physics)."
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
    scene: list[str] = typer.Option(
        [], "--scene", help="Run only the tasks on this table (a scene of the figure); repeatable; default: all. "
        "A long figure can run one table at a time into the same --out."
    ),
) -> None:
    """Run the planning tasks of one figure, resuming: tasks with a result in OUT/results/ are skipped.

    Exit codes: 0 every task has a result, 1 some tasks raised or were lost (see the
    summary; rerun the same command to run lost tasks), 2 bad input.
    """
    try:
        from ..experiments import build_spec, run_experiment

        spec = build_spec(figure, quick=quick, time_limit_s=time_limit, seed=seed, poses=poses, params=_parse_params(param),
                          preset=preset, planners=tuple(planner) or None, task_set=task_set,
                          scenes=tuple(scene) or None)
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
        from ..experiments.execution import load_execution, plot_execution, summarize_execution

        results = load_execution(out)
        typer.echo(summarize_execution(results).to_string(index=False))
        for path in plot_execution(results, out):
            typer.echo(str(path))
    if figure == "closed-loop":
        from ..experiments.closed_loop import (
            closed_loop_runs,
            load_closed_loop,
            plot_closed_loop,
            summarize_closed_loop,
        )

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
        from ..experiments.plots import plot_results

        paths = plot_results(results, out)
    except (ImportError, OSError, ValueError) as error:  # pyarrow's unreadable-file errors are ValueErrors
        raise _fail(error) from None
    if not paths:
        raise _fail(InputError("no planning results of fig10, fig11 or fig12 (`plot` draws those; "
                               "`slideplan experiment execution|closed-loop --out DIR` draws its own figures in DIR)", source=str(results)))
    for path in paths:
        typer.echo(str(path))


@app.command("demos")
def demos_command(
    scene: str = typer.Option(..., "--scene", help="Built-in scene name or scene TOML."),
    episodes: int = typer.Option(..., "--episodes", help="Episodes to attempt (1..1e6)."),
    out: Path = typer.Option(..., "--out", help="The dataset's folder (new or empty; or this generation's, to resume it)."),
    objects: list[str] = typer.Option(
        [], "--objects", help="Objects to draw from (built-in names or outline TOMLs); repeatable; default: "
        "crescent, square, triangle, circle, irregular."
    ),
    setting: str = typer.Option("nominal", "--setting", help="Physics: nominal, stress, random or hard (pushes mid-slide)."),
    closed: bool = typer.Option(True, "--closed-loop/--open-loop", help="Re-plan from the camera (default) or execute blind."),
    cameras: list[str] = typer.Option(
        [], "--cameras", help="NAME:WxH, an RGB video per camera: front (across the table) or scene (the loop's "
        "depth camera's view); NAME:WxH:depth adds its depth video (NAME_depth); repeatable; default: none (state only)."
    ),
    fps: int = typer.Option(10, "--fps", help="Frames per simulated second."),
    keep: str = typer.Option("success", "--keep", help="success (drop failed episodes) or all."),
    seed: int = typer.Option(0, "--seed", help="Episodes' draws and seeds derive from it."),
    workers: Optional[int] = typer.Option(None, "--workers", help="Local worker processes (default: all cores)."),
    scheduler: Optional[str] = typer.Option(
        None, "--scheduler", help="Run on a Dask cluster at this scheduler address instead (e.g. tcp://host:8786)."
    ),
) -> None:
    """Record closed-loop episodes in MuJoCo as a LeRobotDataset v3.0 (needs the lerobot extra; docs/demos.md).

    Exit codes: 0 every episode attempted and the kept ones merged, 1 some episodes lost (an episode
    whose worker died again when run alone: run the same command again to redo them), 2 bad input.
    """
    try:
        from ..demos.generate import Request, generate

        request = Request(scene=scene, episodes=episodes, setting=setting, closed=closed, cameras=tuple(cameras), fps=fps,
                          keep=keep, seed=seed, **({"objects": tuple(objects)} if objects else {})).checked()
        executor = _experiment_executor(workers, scheduler)
        typer.echo(f"demos: {episodes} episodes on {executor.description}, dataset in {out}")
        with _tally_bar("demos", "kept {task.fields[kept]}, lost {task.fields[lost]}") as (bar, show):
            summary = generate(request, out, executor, progress=show)
    except InputError as error:
        raise _fail(InputError(error.problem, source=error.source, field=_OPTION_OF_FIELD.get(error.field, error.field))) from None
    except (ImportError, OSError) as error:
        raise _fail(error) from None
    share = summary["kept"] / summary["episodes"] if summary["episodes"] else 0.0
    typer.echo(f"{summary['episodes']} episodes attempted: {summary['successes']} succeeded (the world's verdict), "
               f"{summary['kept']} kept ({100 * share:.0f}%), {summary['lost']} lost")
    if summary["lost"]:
        typer.echo(f"slideplan: {summary['lost']} episodes lost; rerun the same command to redo them", err=True)
        raise typer.Exit(EXIT_NOT_SOLVED)
