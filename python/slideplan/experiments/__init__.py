"""Experiments of the paper's section V (Figs. 10-12): tasks, runner, executors, statistics.

Needs the ``experiments`` extra (pandas, pyarrow, scipy, dask[distributed])::

    from slideplan.experiments import build_spec, run_experiment, load_results, LocalPoolExecutor

    spec = build_spec("fig11", quick=True)
    summary = run_experiment(spec, "out/fig11", LocalPoolExecutor(workers=2))
    results = load_results("out/fig11")       # one row per task (pandas DataFrame)

The command line does the same: ``slideplan experiment fig11 --quick --out out/fig11``.
"""

from .executors import DaskExecutor, LocalPoolExecutor, TaskExecutor
from .results import ROW_SCHEMA, finished_task_ids, load_results, part_path
from .runner import RunSummary, run_experiment, run_task
from .stats import (
    charged_planning_time,
    mean_and_standard_error,
    planning_runs,
    planning_time_summary,
    success_rate_curve,
    wilson_interval,
)
from .tasks import FIGURES, ExperimentSpec, Task, build_spec, initial_pose_and_seed

__all__ = [
    "FIGURES",
    "ROW_SCHEMA",
    "DaskExecutor",
    "ExperimentSpec",
    "LocalPoolExecutor",
    "RunSummary",
    "Task",
    "TaskExecutor",
    "build_spec",
    "charged_planning_time",
    "finished_task_ids",
    "initial_pose_and_seed",
    "load_results",
    "mean_and_standard_error",
    "part_path",
    "planning_runs",
    "planning_time_summary",
    "run_experiment",
    "run_task",
    "success_rate_curve",
    "wilson_interval",
]
