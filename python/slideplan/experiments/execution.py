"""The execution experiment: plans of the Fig. 10 set executed in MuJoCo.

Each task plans as in Fig. 10 (full size) and, if solved, executes the plan with
:func:`slideplan.sim.execute` twice: in the **nominal** setting (:class:`ExecutionSettings`
defaults) and in a **stress** setting (torsional friction at the fingertip halved, and the finger
pressing at the band's shallowest depth ``dz_min`` at every waypoint instead of the planned
depth). One Parquet row per task holds the plan's features and both outcomes::

    slideplan experiment execution --poses 2 --out out/execution
    python -c "from slideplan.experiments.execution import *; plot_execution(load_execution('out/execution'), 'docs/figures')"
"""

from __future__ import annotations

import dataclasses
import math
from pathlib import Path

import numpy as np
import pandas as pd
import pyarrow as pa

from ..sim import ExecutionSettings, execute, path_features, stress_settings
from ..checks.pipeline import plan_checked
from ..provenance import run_provenance
from ..transforms import row_to_pose
from .results import PROVENANCE_FIELDS, ROW_SCHEMA, load_results
from .tasks import Task, cached_scene

SETTINGS = ("nominal", "stress")
_PLAN_COLUMNS = [
    ("solved", pa.bool_()), ("status", pa.string()), ("planning_time_s", pa.float64()), ("overhang_m", pa.float64()),
    ("tip_path_m", pa.float64()), ("straight_m", pa.float64()), ("yaw_travel_deg", pa.float64()),
    ("planned_com_margin_m", pa.float64()),
]
_OUTCOME_COLUMNS = [
    ("success", pa.bool_()), ("failed_stage", pa.string()), ("failure", pa.string()),
    ("position_error_m", pa.float64()), ("yaw_error_deg", pa.float64()), ("com_margin_m", pa.float64()),
    ("overhang_m", pa.float64()), ("lifted", pa.bool_()), ("normal_force_n", pa.float64()),
    ("wall_time_s", pa.float64()), ("sim_time_s", pa.float64()),
]
TASK_COLUMNS = [field for field in ROW_SCHEMA if field.name in {"task_id", "reconfiguration_range_m"}
                 or field.name in {item.name for item in dataclasses.fields(Task)}]
EXECUTION_ROW_SCHEMA = pa.schema(
    TASK_COLUMNS
    + _PLAN_COLUMNS
    + [(f"{setting}_{name}", kind) for setting in SETTINGS for name, kind in _OUTCOME_COLUMNS]
    + [("error", pa.string())]
    + PROVENANCE_FIELDS
)
"""Columns of an execution row: the task, the plan (``tip_path_m`` and ``straight_m``: fingertip
path length and the straight distance between its ends; ``yaw_travel_deg``: total turning of the
fingertip), then ``nominal_*`` and ``stress_*`` outcomes (:class:`slideplan.sim.Execution`;
``normal_force_n`` is the mean while sliding), then the provenance columns of
:data:`slideplan.experiments.results.ROW_SCHEMA`. Outcomes are null when the plan was not solved."""


def run_execution_task(task: Task) -> dict:
    """Plan one task, verify it, execute it in both settings and return its row (runs in the worker).

    Args:
        task: a task of :func:`slideplan.experiments.tasks.execution_spec`.

    Returns:
        A dict with the keys of :data:`EXECUTION_ROW_SCHEMA`; any exception becomes the ``error``
        column (the run goes on).
    """
    row = {field.name: None for field in EXECUTION_ROW_SCHEMA}
    row.update(task.fields(), solved=False, status="error", **run_provenance())
    try:
        scene = cached_scene(task.scene)
        obj = task.placed_object()
        result = plan_checked(scene, obj, task.planner_config()).result
        row.update(status=result.status, planning_time_s=result.planning_time_s)
        if not result.solved:
            return row
        tip_path, yaw_travel = path_features(result)
        ends = [row_to_pose(result.fingertip_poses[index])[:2, 3] for index in (0, -1)]
        row.update(
            solved=True, overhang_m=result.overhang_m, tip_path_m=tip_path, yaw_travel_deg=math.degrees(yaw_travel),
            straight_m=float(np.linalg.norm(ends[1] - ends[0])),
        )
        stress = stress_settings(float(result.params["dz_min"]))
        for name, settings in (("nominal", ExecutionSettings()), ("stress", stress)):
            execution = execute(result, settings)
            row["planned_com_margin_m"] = execution.planned_com_margin_m
            outcome = dataclasses.asdict(execution)
            outcome["normal_force_n"] = execution.normal_force_n["mean"]
            row.update({f"{name}_{column}": outcome[column] for column, _ in _OUTCOME_COLUMNS})
    except Exception as error:  # noqa: BLE001 - recorded in the row; one bad task must not end the run
        row["error"] = f"{type(error).__name__}: {error}"
    return row


def load_execution(path: str | Path) -> pd.DataFrame:
    """Read execution results (an output directory, its ``results/`` or a compacted Parquet file).

    Raises:
        FileNotFoundError: ``path`` does not exist.
    """
    return load_results(path, EXECUTION_ROW_SCHEMA)


def summarize_execution(results: pd.DataFrame) -> pd.DataFrame:
    """Per setting: executed plans, success rates and error quantiles.

    Args:
        results: :func:`load_execution` rows.

    Returns:
        One row per setting: ``plans`` (solved and executed), ``within_5mm_3deg``, ``lifted``,
        ``success`` (fractions), ``fell``, ``unstable`` (counts), median and 90th percentile of
        position error (mm) and absolute yaw error (deg), and the mean normal force (N).
    """
    rows = []
    executed = results[results["solved"].fillna(False) & results["error"].isna()]
    for setting in SETTINGS:
        stable = executed[executed[f"{setting}_failed_stage"] != "simulation"]
        position_mm = 1000 * stable[f"{setting}_position_error_m"]
        yaw_deg = stable[f"{setting}_yaw_error_deg"].abs()
        within = (position_mm <= 5) & (yaw_deg <= 3)
        rows.append({
            "setting": setting,
            "plans": len(executed),
            "within_5mm_3deg": float(within.sum() / max(len(executed), 1)),
            "lifted": float(executed[f"{setting}_lifted"].fillna(False).sum() / max(len(executed), 1)),
            "success": float(executed[f"{setting}_success"].fillna(False).sum() / max(len(executed), 1)),
            "fell": int((executed[f"{setting}_failed_stage"] == "release").sum()),
            "unstable": int((executed[f"{setting}_failed_stage"] == "simulation").sum()),
            "position_mm_median": float(position_mm.median()),
            "position_mm_p90": float(position_mm.quantile(0.9)),
            "yaw_deg_median": float(yaw_deg.median()),
            "yaw_deg_p90": float(yaw_deg.quantile(0.9)),
            "normal_force_n_mean": float(stable[f"{setting}_normal_force_n"].mean()),
        })
    return pd.DataFrame(rows)


def plot_execution(results: pd.DataFrame, out_dir: str | Path, name: str = "execution") -> list[Path]:
    """Error distributions per setting, and the yaw error against the plan's yaw travel.

    Args:
        results: :func:`load_execution` rows.
        out_dir: where ``<name>.png`` and ``<name>.svg`` go.
        name: file name stem.

    Returns:
        The files written.
    """
    from matplotlib.figure import Figure

    from .plots import save_figures

    executed = results[results["solved"].fillna(False) & results["error"].isna()]
    figure = Figure(figsize=(13, 3.8))
    position_axes, yaw_axes, travel_axes = figure.subplots(1, 3)
    for setting, colour in zip(SETTINGS, ("tab:blue", "tab:red")):
        stable = executed[executed[f"{setting}_failed_stage"] != "simulation"]
        for axes, values, limit in (
            (position_axes, np.sort(1000 * stable[f"{setting}_position_error_m"].to_numpy()), 5),
            (yaw_axes, np.sort(stable[f"{setting}_yaw_error_deg"].abs().to_numpy()), 3),
        ):
            axes.step(values, np.arange(1, len(values) + 1) / max(len(executed), 1), where="post", color=colour,
                      label=f"{setting} ({len(executed)} plans)")
            axes.axvline(limit, color="grey", linestyle=":")
        travel_axes.scatter(stable["yaw_travel_deg"], stable[f"{setting}_yaw_error_deg"].abs(), s=14, color=colour,
                            label=setting, alpha=0.7)
    position_axes.set(xscale="log", xlabel="position error vs Eq. 2 (mm)", ylabel="fraction of executed plans")
    yaw_axes.set(xscale="log", xlabel="|yaw error| vs Eq. 2 (deg)")
    travel_axes.set(yscale="log", xlabel="plan's total fingertip yaw travel (deg)", ylabel="|yaw error| (deg)")
    travel_axes.axhline(3, color="grey", linestyle=":")
    for axes in (position_axes, yaw_axes, travel_axes):
        axes.legend(fontsize=8)
        axes.grid(alpha=0.3)
    figure.tight_layout()
    return save_figures(figure, out_dir, name)
