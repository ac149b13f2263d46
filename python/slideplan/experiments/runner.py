"""Running experiments: one planning task per worker call, one Parquet file per result.

Results go to ``OUT/results/part-<task_id>.parquet`` (:mod:`slideplan.experiments.results`), one
row each, written by the driver as results arrive. A killed run or a dead worker therefore loses
only unfinished tasks, and a rerun skips the task ids already present.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

from ..checks.pipeline import plan_checked
from ..provenance import run_provenance
from .executors import LocalPoolExecutor, TaskExecutor
from .results import ROW_SCHEMA, STAT_COLUMNS, finished_task_ids, results_dir, write_row
from .tasks import ExperimentSpec, Task, cached_scene

@dataclass(frozen=True)
class RunSummary:
    """What one :func:`run_experiment` call did.

    Attributes:
        total: tasks in the spec.
        skipped: tasks with a result from an earlier run (not run again).
        executed: tasks run now whose row was written (errors included).
        solved: of those, solved and verified.
        errors: of those, tasks that raised (row written with ``status="error"``).
        lost: tasks that produced no row (their worker died again when run alone); a rerun runs them.
        first_loss: the reason of the first lost task ("" if none).
    """

    total: int
    skipped: int
    executed: int
    solved: int
    errors: int
    lost: int
    first_loss: str = ""


def run_task(task: Task) -> dict:
    """Plan one task and return its results row (runs in the worker).

    Scenes, outlines and the robot model are cached per process. Solved plans are
    re-checked with :func:`slideplan.verify`. Any exception becomes an ``"error"`` row, so a
    failing task never stops the run. Every row records the worker's build, CPU and start time
    (:func:`slideplan.provenance.run_provenance`).

    Args:
        task: the task.

    Returns:
        A dict with the keys of :data:`ROW_SCHEMA`.
    """
    row = {**task.fields(), "solved": False, "status": "error", "planning_time_s": None,
           **dict.fromkeys(STAT_COLUMNS), "overhang_m": None, "verified": None, "error": None, **run_provenance()}
    try:
        scene = cached_scene(task.scene)
        obj = task.placed_object()
        checked = plan_checked(scene, obj, task.planner_config())
        result = checked.result
        verified = checked.verification.ok if checked.verification is not None else None
    except Exception as error:  # noqa: BLE001 - recorded in the row; one bad task must not end the run
        row["error"] = f"{type(error).__name__}: {error}"
        return row
    row.update(
        solved=bool(verified), status=result.status,
        planning_time_s=result.planning_time_s, overhang_m=result.overhang_m if result.solved else None,
        verified=verified, **{name: int(result.stats.get(name, 0)) for name in STAT_COLUMNS},
    )
    return row


def progress_bar(fields: str, enabled: bool = True):
    """A rich progress bar on stderr: done/total, ``fields`` (a rich template of the task's fields, e.g.
    ``"solved {task.fields[solved]}/{task.fields[ran]}"``), elapsed time and ETA."""
    from rich.console import Console
    from rich.progress import BarColumn, MofNCompleteColumn, Progress, TextColumn, TimeElapsedColumn, TimeRemainingColumn

    return Progress(
        TextColumn("{task.description}"), BarColumn(), MofNCompleteColumn(), TextColumn(fields),
        TimeElapsedColumn(), TextColumn("ETA"), TimeRemainingColumn(),
        console=Console(stderr=True), disable=not enabled,
    )


def run_experiment(
    spec: ExperimentSpec, out_dir: str | Path, executor: TaskExecutor | None = None, *, progress: bool = True
) -> RunSummary:
    """Run the tasks of ``spec`` that have no result in ``out_dir`` yet.

    Rows are written to ``OUT/results/part-<task_id>.parquet`` as they arrive. Tasks
    already there are skipped (resume), including rows of tasks that raised: delete a
    part file to run its task again. The ``execution`` experiment's tasks plan and then
    execute in MuJoCo (:func:`slideplan.experiments.execution.run_execution_task`); the
    ``closed-loop`` experiment's run whole tasks open and closed loop
    (:func:`slideplan.experiments.closed_loop.run_closed_loop_task`).

    Args:
        spec: the experiment (see :func:`slideplan.experiments.build_spec`).
        out_dir: the output directory (created if missing).
        executor: where tasks run; default :class:`LocalPoolExecutor` on all cores.
        progress: show a live progress bar on stderr.

    Returns:
        What was run, solved, failed and lost.

    Raises:
        InputError: the executor cannot start (e.g. an unreachable Dask scheduler).
        OSError: the output directory cannot be written.
    """
    results_dir(out_dir).mkdir(parents=True, exist_ok=True)
    done = finished_task_ids(out_dir)
    pending = [task for task in spec.tasks if task.task_id not in done]
    executor = executor or LocalPoolExecutor()
    run, schema = run_task, ROW_SCHEMA
    if spec.name == "execution":
        from .execution import EXECUTION_ROW_SCHEMA, run_execution_task

        run, schema = run_execution_task, EXECUTION_ROW_SCHEMA
    elif spec.name == "closed-loop":
        from .closed_loop import CLOSED_LOOP_ROW_SCHEMA, run_closed_loop_task

        run, schema = run_closed_loop_task, CLOSED_LOOP_ROW_SCHEMA
    executed = solved = errors = lost = 0
    first_loss = ""
    with progress_bar("solved {task.fields[solved]}/{task.fields[ran]}", progress) as bar:
        bar_task = bar.add_task(spec.name, total=len(spec.tasks), completed=len(spec.tasks) - len(pending),
                                solved=0, ran=0)
        for task, outcome in executor.imap_unordered(run, pending):
            if isinstance(outcome, BaseException):
                lost += 1
                first_loss = first_loss or f"task {task.task_id}: {type(outcome).__name__}: {outcome}"
            else:
                write_row(out_dir, outcome, schema)
                executed += 1
                solved += bool(outcome["solved"])
                errors += outcome["error"] is not None
            bar.update(bar_task, advance=1, solved=solved, ran=executed)
    return RunSummary(total=len(spec.tasks), skipped=len(spec.tasks) - len(pending), executed=executed,
                      solved=solved, errors=errors, lost=lost, first_loss=first_loss)
