"""Running experiments: one planning task per worker call, one Parquet file per result.

Results go to ``OUT/results/part-<task_id>.parquet``, one row each, written by the
driver as results arrive (temp file + rename, so a file is either whole or absent). A
killed run or a dead worker therefore loses only unfinished tasks, and a rerun skips the
task ids already present. The directory is a Parquet dataset: :func:`load_results`, pandas
and pyarrow read it whole.
"""

from __future__ import annotations

import dataclasses
import functools
import os
from dataclasses import dataclass
from pathlib import Path

import pandas as pd
import pyarrow as pa
import pyarrow.dataset
import pyarrow.parquet as pq

from ..objects import ThinObject
from ..planning import plan
from ..verify import verify
from .executors import LocalPoolExecutor, TaskExecutor
from .tasks import ExperimentSpec, Task, cached_scene, scaled_outline

RESULTS_SUBDIR = "results"
PART_PREFIX, PART_SUFFIX = "part-", ".parquet"
_STAT_COLUMNS = ("iterations", "start_roots", "goal_roots", "pairs_checked", "pairs_rejected", "nodes")
_ARROW_TYPES = {"str": pa.string(), "int": pa.int64(), "float": pa.float64()}

# One schema for every part file, so the dataset reads as one table even when a part
# holds nulls only (an error row has no iterations, a timeout no verdict).
ROW_SCHEMA = pa.schema(
    [("task_id", pa.string())]
    + [(item.name, _ARROW_TYPES[item.type]) for item in dataclasses.fields(Task)]
    + [("reconfiguration_range_m", pa.float64()), ("solved", pa.bool_()), ("status", pa.string()),
       ("planning_time_s", pa.float64())]
    + [(name, pa.int64()) for name in _STAT_COLUMNS]
    + [("overhang_m", pa.float64()), ("verified", pa.bool_()), ("error", pa.string())]
)
"""Columns of a results row: the task (:meth:`Task.fields`) then the outcome.

``status`` is ``"solved"``, ``"timeout"``, ``"invalid"`` (the planner returned a plan that
:func:`slideplan.verify` rejects) or ``"error"`` (the task raised; ``error`` has the text).
``solved`` is True only for verified plans; ``verified`` is null when there was no plan.
"""


@dataclass(frozen=True)
class RunSummary:
    """What one :func:`run_experiment` call did.

    Attributes:
        total: tasks in the spec.
        skipped: tasks with a result from an earlier run (not run again).
        executed: tasks run now whose row was written (errors included).
        solved: of those, solved and verified.
        errors: of those, tasks that raised (row written with ``status="error"``).
        lost: tasks that produced no row (a worker died); a rerun runs them.
        first_loss: the reason of the first lost task ("" if none).
    """

    total: int
    skipped: int
    executed: int
    solved: int
    errors: int
    lost: int
    first_loss: str = ""


@functools.lru_cache(maxsize=4)
def _object_at(object_name: str, scale: float, table_height: float, pose: tuple[float, float, float]) -> ThinObject:
    """The task's object placed on the table (cached: the settings of one pose share it)."""
    outline, thickness = scaled_outline(object_name, scale)
    return ThinObject.from_outline(outline, thickness=thickness, table_height=table_height, pose=pose, name=object_name)


def run_task(task: Task) -> dict:
    """Plan one task and return its results row (runs in the worker).

    Scenes, outlines and the robot model are cached per process. Solved plans are
    re-checked with :func:`slideplan.verify`. Any exception becomes an ``"error"`` row, so a
    failing task never stops the run.

    Args:
        task: the task.

    Returns:
        A dict with the keys of :data:`ROW_SCHEMA`.
    """
    row = {**task.fields(), "solved": False, "status": "error", "planning_time_s": None,
           **dict.fromkeys(_STAT_COLUMNS), "overhang_m": None, "verified": None, "error": None}
    try:
        scene = cached_scene(task.scene)
        obj = _object_at(task.object, task.scale, scene.table.height, (task.x, task.y, task.yaw))
        result = plan(scene, obj, task.planner_config())
        verified = verify(result).ok if result.solved else None
    except Exception as error:  # noqa: BLE001 - recorded in the row; one bad task must not end the run
        row["error"] = f"{type(error).__name__}: {error}"
        return row
    row.update(
        solved=bool(verified), status="invalid" if verified is False else result.status,
        planning_time_s=result.planning_time_s, overhang_m=result.overhang_m if result.solved else None,
        verified=verified, **{name: int(result.stats.get(name, 0)) for name in _STAT_COLUMNS},
    )
    return row


def results_dir(out_dir: str | Path) -> Path:
    """Return ``OUT/results``, the Parquet dataset directory of an experiment output directory."""
    return Path(out_dir) / RESULTS_SUBDIR


def part_path(out_dir: str | Path, task_id: str) -> Path:
    """Return the result file of one task, ``OUT/results/part-<task_id>.parquet``."""
    return results_dir(out_dir) / f"{PART_PREFIX}{task_id}{PART_SUFFIX}"


def finished_task_ids(out_dir: str | Path) -> set[str]:
    """Return the task ids with a result file in ``OUT/results`` (empty if there is none).

    Only names are read: a part file exists only once it is complete (atomic rename).
    """
    return {
        path.name[len(PART_PREFIX):-len(PART_SUFFIX)]
        for path in results_dir(out_dir).glob(f"{PART_PREFIX}*{PART_SUFFIX}")
    }


def write_row(out_dir: str | Path, row: dict, schema: pa.Schema = ROW_SCHEMA) -> Path:
    """Write one results row to its part file atomically (temp file, then rename).

    The temp name starts with ``.``, which Parquet dataset readers skip, so a write cut
    short leaves nothing that looks like a result.

    Args:
        out_dir: the experiment output directory.
        row: a dict with the keys of ``schema``.
        schema: the row schema (:data:`ROW_SCHEMA` for planning experiments).

    Returns:
        The part file.
    """
    final = part_path(out_dir, row["task_id"])
    temporary = final.with_name(f".{final.name}.{os.getpid()}.tmp")
    pq.write_table(pa.Table.from_pylist([row], schema=schema), temporary)
    os.replace(temporary, final)
    return final


def load_results(path: str | Path, schema: pa.Schema = ROW_SCHEMA) -> pd.DataFrame:
    """Read results into a DataFrame, one row per finished task.

    Args:
        path: an experiment output directory (holding ``results/``), a results directory
            of part files, or a single Parquet file (e.g. a committed, compacted one:
            ``load_results(out).to_parquet(file)``).
        schema: the row schema (the execution experiment has its own,
            :data:`slideplan.experiments.execution.EXECUTION_ROW_SCHEMA`).

    Returns:
        The rows, with the columns of ``schema`` (empty if there are none).

    Raises:
        FileNotFoundError: ``path`` does not exist.
    """
    path = Path(path)
    if not path.exists():
        raise FileNotFoundError(f"{path}: no such file or directory")
    if path.is_dir() and results_dir(path).is_dir():
        path = results_dir(path)
    files = sorted(path.glob("*.parquet")) if path.is_dir() else [path]  # not temp files, not figures
    table = pyarrow.dataset.dataset(files, format="parquet", schema=schema).to_table()
    return table.to_pandas()


def _progress_bar(enabled: bool):
    """A rich progress bar on stderr: done/total, solved so far, elapsed time and ETA."""
    from rich.console import Console
    from rich.progress import BarColumn, MofNCompleteColumn, Progress, TextColumn, TimeElapsedColumn, TimeRemainingColumn

    return Progress(
        TextColumn("{task.description}"), BarColumn(), MofNCompleteColumn(),
        TextColumn("solved {task.fields[solved]}/{task.fields[ran]}"),
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
    execute in MuJoCo (:func:`slideplan.experiments.execution.run_execution_task`).

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
    executed = solved = errors = lost = 0
    first_loss = ""
    with _progress_bar(progress) as bar:
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
