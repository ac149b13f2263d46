"""The closed-loop experiment: whole tasks in MuJoCo, open and closed loop.

Each task is one object pose of a task set (``--set dev``: the execution experiment's Fig. 10 set, 5
objects x 4 tables; ``--set eval``: the held-out letters, :func:`slideplan.experiments.tasks.closed_loop_eval_spec`);
its worker runs :func:`slideplan.sim.closed_loop.run` in every setting (nominal, stress, random, hard) and
mode (open, closed): perceive, plan, slide, grasp, lift, hold, judged by the world
(:mod:`slideplan.checks.verdict`). The random and hard settings' draws come from the task's seed alone, so open
and closed loop meet the same physics. One part file per task holds its eight runs side by side
(``<setting>_<mode>_<column>``); :func:`closed_loop_runs` turns them into one row per run::

    slideplan experiment closed-loop --set eval --out out/closed_loop_eval
    python -c "from slideplan.experiments.closed_loop import *; \\
        closed_loop_runs(load_closed_loop('out/closed_loop_eval')).to_parquet('docs/results/closed_loop_eval.parquet')"
    .venv/bin/python docs/results/make_tables.py   # docs/results/closed_loop.md from the rows
"""

from __future__ import annotations

import dataclasses
import itertools
import json
from typing import Any
from pathlib import Path

import numpy as np
import pandas as pd
import pyarrow as pa

from ..sim.closed_loop import run
from ..sim.conditions import SETTINGS
from ..provenance import PROVENANCE_COLUMNS, run_provenance
from .execution import TASK_COLUMNS
from .results import PROVENANCE_FIELDS, load_results
from .stats import wilson_interval
from .tasks import SET_SETTINGS, Task, cached_scene, task_set

MODES = ("open", "closed")
_RUN_COLUMNS = [
    ("success", pa.bool_()), ("failed_stage", pa.string()), ("failure", pa.string()), ("replans", pa.int64()),
    ("kept", pa.int64()), ("replan_latency_s", pa.float64()), ("max_latency_s", pa.float64()), ("looks", pa.int64()),
    ("lost_looks", pa.int64()), ("seen_status", pa.string()), ("seen_frames", pa.string()),
    ("seen_overhang_m", pa.float64()), ("seen_com_margin_m", pa.float64()),
    ("true_overhang_m", pa.float64()), ("true_com_margin_m", pa.float64()), ("lifted", pa.bool_()),
    ("slide_stop", pa.string()), ("slide_s", pa.float64()), ("decision_frames", pa.string()),
    ("draws", pa.string()), ("disturbance", pa.string()), ("camera_estimate", pa.string()), ("camera_error", pa.string()),
    ("sim_time_s", pa.float64()), ("wall_time_s", pa.float64()),
]
CLOSED_LOOP_ROW_SCHEMA = pa.schema(
    TASK_COLUMNS
    + [("task_set", pa.string()), ("solved", pa.bool_())]
    + [(f"{setting}_{mode}_{name}", kind) for setting, mode in itertools.product(SETTINGS, MODES) for name, kind in _RUN_COLUMNS]
    + [("error", pa.string())]
    + PROVENANCE_FIELDS
)
"""Columns of a task's part file: the task, its ``task_set`` (``dev`` or ``eval``), ``solved`` (every run of
it finished), then each run's outcome (:class:`slideplan.sim.closed_loop_run.ClosedLoopRun`; ``max_latency_s`` the
slowest re-plan; as JSON: ``draws`` the physics, ``disturbance`` the push, ``camera_estimate`` and
``camera_error`` where the run put the camera from the robot it saw and the error left, ``seen_frames`` the frames of the
look after the slide, ``decision_frames`` each deciding look's trigger, outcome and frames), then ``error``
(a run that raised), then the provenance columns of :data:`slideplan.experiments.results.ROW_SCHEMA`."""


def run_columns(report) -> dict[str, Any]:
    """A :class:`~slideplan.sim.closed_loop_run.ClosedLoopRun` as the values of :data:`_RUN_COLUMNS`."""
    outcome = dataclasses.asdict(report)
    for name in ("draws", "disturbance", "seen_frames", "camera_estimate", "camera_error"):
        outcome[name] = json.dumps(outcome[name], sort_keys=True)
    outcome["decision_frames"] = json.dumps([[event.trigger, event.outcome, event.frames] for event in report.events])
    latencies = [event.latency_s for event in report.events if event.outcome != "lost"]
    outcome["max_latency_s"] = max(latencies) if latencies else None
    return {name: outcome[name] for name, _ in _RUN_COLUMNS}


def run_closed_loop_task(task: Task) -> dict:
    """Run one task in every setting of its set (all four but where SET_SETTINGS says), open and closed loop, and
    return its row (runs in the worker).

    Args:
        task: a task of :func:`slideplan.experiments.tasks.closed_loop_spec`.

    Returns:
        A dict with the keys of :data:`CLOSED_LOOP_ROW_SCHEMA`; an exception becomes the ``error`` column.
    """
    row = {field.name: None for field in CLOSED_LOOP_ROW_SCHEMA}
    row.update(task.fields(), task_set=task_set(task), solved=False, **run_provenance())
    try:
        scene, config = cached_scene(task.scene), task.planner_config()
        settings = SET_SETTINGS.get(task_set(task), SETTINGS)
        for setting, mode in itertools.product(settings, MODES):
            report = run(scene, task.object, (task.x, task.y, task.yaw), seed=task.seed, closed=mode == "closed",
                         setting=setting, config=config)
            row.update({f"{setting}_{mode}_{name}": value for name, value in run_columns(report).items()})
        row["solved"] = True
    except Exception as error:  # noqa: BLE001 - recorded in the row; one bad task must not end the run
        row["error"] = f"{type(error).__name__}: {error}"
    return row


def load_closed_loop(path: str | Path) -> pd.DataFrame:
    """Read closed-loop part files (an output directory or its ``results/``), one row per task.

    Raises:
        FileNotFoundError: ``path`` does not exist.
    """
    return load_results(path, CLOSED_LOOP_ROW_SCHEMA)


def closed_loop_runs(tasks: pd.DataFrame) -> pd.DataFrame:
    """One row per run: the task's columns and set, ``setting``, ``mode``, the run's outcome columns and the
    task's provenance columns.

    Args:
        tasks: :func:`load_closed_loop` rows. A task that raised keeps the runs it finished, and each run it
            did not finish is a failure (``failed_stage`` ``error``, ``failure`` the error): never left out,
            which would raise the success rate. Settings no finished task ran (rows from before a setting
            existed) are left out.
    """
    raised = tasks["error"].notna().to_numpy()
    task_columns = [field.name for field in TASK_COLUMNS] + ["task_set"]
    parts = []
    for setting, mode in itertools.product(SETTINGS, MODES):
        if (~raised).any() and tasks.loc[~raised, f"{setting}_{mode}_success"].isna().all():
            continue
        part = tasks[task_columns].copy()
        part.insert(len(task_columns), "setting", setting)
        part.insert(len(task_columns) + 1, "mode", mode)
        for name, _ in _RUN_COLUMNS:
            part[name] = tasks[f"{setting}_{mode}_{name}"].to_numpy()
        unfinished = raised & part["success"].isna().to_numpy()
        if unfinished.any():
            part["success"] = part["success"].astype(object)
            part.loc[unfinished, "success"] = False
            part.loc[unfinished, "failed_stage"] = "error"
            part.loc[unfinished, "failure"] = tasks["error"].to_numpy()[unfinished]
        for name in PROVENANCE_COLUMNS:
            part[name] = tasks[name].to_numpy()
        parts.append(part)
    columns = task_columns + ["setting", "mode"] + [name for name, _ in _RUN_COLUMNS] + list(PROVENANCE_COLUMNS)
    return pd.concat(parts, ignore_index=True) if parts else pd.DataFrame(columns=columns)


def summarize_closed_loop(runs: pd.DataFrame) -> pd.DataFrame:
    """Per setting and mode: runs, success rate with its 95% Wilson interval, re-plans per run and
    the median and 95th percentile of the runs' median re-plan latency.

    Args:
        runs: :func:`closed_loop_runs` rows.
    """
    rows = []
    for (setting, mode), group in runs.groupby(["setting", "mode"], sort=False):
        successes = int(group["success"].fillna(False).sum())
        low, high = wilson_interval(successes, len(group))
        latency = group["replan_latency_s"].dropna()
        rows.append({
            "setting": setting, "mode": mode, "runs": len(group), "success": successes / max(len(group), 1),
            "low": float(low), "high": float(high), "replans_mean": float(group["replans"].mean()),
            "replans_max": int(group["replans"].max()) if group["replans"].notna().any() else 0,  # none: all raised
            "latency_ms_median": float(1000 * latency.median()) if len(latency) else float("nan"),
            "latency_ms_p95": float(1000 * latency.quantile(0.95)) if len(latency) else float("nan"),
        })
    return pd.DataFrame(rows)


def plot_closed_loop(runs: pd.DataFrame, out_dir: str | Path, name: str = "closed_loop") -> list[Path]:
    """Success per setting and mode (95% Wilson interval), re-plans per closed-loop run, the
    distribution of the runs' median re-plan latency, and of the error of the verdict (the overhang
    as seen after the slide less the true one).

    Args:
        runs: :func:`closed_loop_runs` rows.
        out_dir: where ``<name>.png`` and ``<name>.svg`` go.
        name: file name stem.

    Returns:
        The files written.
    """
    from matplotlib.figure import Figure
    from matplotlib.ticker import NullFormatter

    from .plots import save_figures

    summary = summarize_closed_loop(runs)
    figure = Figure(figsize=(17, 3.8))
    success_axes, replan_axes, latency_axes, error_axes = figure.subplots(1, 4)
    width = 0.38
    for offset, (mode, colour) in zip((-width / 2, width / 2), zip(MODES, ("tab:grey", "tab:blue"))):
        rows = summary[summary["mode"] == mode].set_index("setting").reindex(list(SETTINGS))
        positions = np.arange(len(SETTINGS)) + offset
        success_axes.bar(positions, 100 * rows["success"], width, color=colour, label=f"{mode} loop")
        # Clipped at 0: at 100% success the interval's top can round a hair below it.
        success_axes.errorbar(positions, 100 * rows["success"], yerr=np.clip([100 * (rows["success"] - rows["low"]),
                              100 * (rows["high"] - rows["success"])], 0.0, None), fmt="none", color="black", capsize=3)
    success_axes.set(xticks=np.arange(len(SETTINGS)), xticklabels=list(SETTINGS), ylabel="success (%)", ylim=(0, 105))
    success_axes.axhline(95, color="grey", linestyle=":")
    closed = runs[runs["mode"] == "closed"]
    for index, setting in enumerate(SETTINGS):
        colour = f"C{index}"
        replans = closed[closed["setting"] == setting]["replans"].to_numpy()
        replan_axes.step(np.sort(replans), np.arange(1, len(replans) + 1) / max(len(replans), 1), where="post",
                         color=colour, label=setting)
        latency = np.sort(1000 * closed[closed["setting"] == setting]["replan_latency_s"].dropna().to_numpy())
        latency_axes.step(latency, np.arange(1, len(latency) + 1) / max(len(latency), 1), where="post", color=colour,
                          label=setting)
        for mode, style in zip(MODES, (":", "-")):
            ran = runs[(runs["setting"] == setting) & (runs["mode"] == mode)]
            error = np.sort(1000 * (ran["seen_overhang_m"] - ran["true_overhang_m"]).dropna().to_numpy())
            error_axes.step(error, np.arange(1, len(error) + 1) / max(len(error), 1), where="post", color=colour,
                            linestyle=style, label=f"{setting}, {mode}")
    replan_axes.set(xlabel="re-plans per closed-loop run", ylabel="fraction of runs")
    latency_axes.set(xlabel="median re-plan latency of a run (ms): track + plan", ylabel="fraction of runs")
    latency_axes.axvline(50, color="grey", linestyle=":")
    # Log and symmetric-log axes: a run whose object fell off the table is metres off, and a slow re-plan
    # hundreds of milliseconds; linear axes squeezed every other run into one line.
    latency_axes.set_xscale("log")
    latency_axes.set_xticks([10, 20, 50], ["10", "20", "50"])
    latency_axes.xaxis.set_minor_formatter(NullFormatter())
    error_axes.set_xscale("symlog", linthresh=10.0, linscale=4.0)
    error_axes.set_xticks([-1000, -10, -5, 0, 5, 10, 100], ["-1000", "-10", "-5", "0", "5", "10", "100"])
    error_axes.set(xlabel="seen - true overhang after the slide (mm)", ylabel="fraction of runs")
    for axes in (success_axes, replan_axes, latency_axes, error_axes):
        axes.legend(fontsize=8)
        axes.grid(alpha=0.3)
    figure.tight_layout()
    return save_figures(figure, out_dir, name)
