"""Tables of docs/results/execution.md from the committed execution results, and the figure.

Every number in ``docs/results/execution.md`` comes from ``execution.parquet`` (the default planner)
and ``execution_paper.parquet`` (its physically aware options off: the paper's band and pair
conditions, goal roots drawn as Algorithm 1 draws them) next to this script. To commit the results of a run::

    PYTHONPATH=python python -c "from slideplan.experiments.execution import load_execution; \\
        load_execution('out/execution').to_parquet('docs/results/execution.parquet')"
    PYTHONPATH=python python docs/results/make_execution.py > /tmp/tables.md

It prints markdown tables (paste them into execution.md) and writes
``docs/results/figures/execution.png`` and ``.svg``. The grasp table re-plans each solved task
(planning is deterministic for a task) to read its grasp pose, which the rows do not hold, so run it
with the planner that made ``execution.parquet`` (execution.md names its commit); the tables of
``execution_paper.parquet`` need no re-planning.
"""

from __future__ import annotations

import dataclasses
import sys
from pathlib import Path

import numpy as np
import pandas as pd
import shapely

from slideplan.execute import cloud_footprint
from slideplan.experiments.execution import SETTINGS, load_execution, plot_execution, summarize_execution
from slideplan.experiments.tasks import Task, cached_scene
from slideplan.planning import plan

HERE = Path(__file__).resolve().parent


def markdown_table(frame: pd.DataFrame) -> str:
    """A GitHub markdown table of a DataFrame (index dropped)."""
    lines = ["| " + " | ".join(map(str, frame.columns)) + " |", "|" + "---|" * len(frame.columns)]
    lines += ["| " + " | ".join(map(str, row)) + " |" for row in frame.itertuples(index=False)]
    return "\n".join(lines)


def within(frame: pd.DataFrame, setting: str) -> pd.Series:
    """The slide ended within 5 mm / 3 degrees of Eq. 2."""
    return (frame[f"{setting}_position_error_m"] <= 0.005) & (frame[f"{setting}_yaw_error_deg"].abs() <= 3)


def binned(frame: pd.DataFrame, column: str, edges: list[float], label: str) -> pd.DataFrame:
    """Plans per bin of ``column`` and the fraction within 5 mm / 3 deg in each setting."""
    bins = pd.cut(frame[column], edges, right=False)
    rows = []
    for interval, group in frame.groupby(bins, observed=True):
        row = {label: f"[{interval.left:g}, {interval.right:g})", "plans": len(group)}
        for setting in SETTINGS:
            row[f"{setting} within 5 mm / 3 deg"] = f"{within(group, setting).sum()}/{len(group)}"
        rows.append(row)
    return pd.DataFrame(rows)


def replanned(row: pd.Series) -> dict[str, float]:
    """Features of a plan that its row does not hold, by re-planning its task (deterministic): how far
    outside the table edge the grasp frame lies, how far the first contact is from the object's centre
    of mass and from its outline, and the shallowest contact depth (mm)."""
    task = Task(**{field.name: row[field.name] for field in dataclasses.fields(Task)})
    scene = cached_scene(task.scene)
    obj = task.placed_object()
    result = plan(scene, obj, task.planner_config())
    tips = np.asarray(result.fingertip_poses)
    outline = cloud_footprint(np.asarray(result.object["points"])[:, :2])
    depths = scene.table.height + result.object["thickness"] - tips[:, 2]
    return {
        "grasp_outside_mm": -1000 * scene.table.edge_margin(np.asarray(result.grasp["pose"])[:2]),
        "contact_com_mm": 1000 * float(np.linalg.norm(tips[0, :2] - np.asarray(result.object["com_xy"]))),
        "contact_outline_mm": 1000 * outline.boundary.distance(shapely.Point(tips[0, :2])),
        "depth_min_mm": 1000 * float(depths.min()),
    }


def comparison(runs: dict[str, pd.DataFrame]) -> pd.DataFrame:
    """One row per planner and setting: success rates and the plans' median path features."""
    rows = []
    for name, results in runs.items():
        executed = results[results["solved"].fillna(False) & results["error"].isna()]
        for setting in SETTINGS:
            rows.append({
                "planner": name, "setting": setting, "plans": len(executed),
                "within 5 mm / 3 deg": f"{within(executed, setting).mean():.0%}",
                "lifted": f"{executed[f'{setting}_lifted'].fillna(False).mean():.0%}",
                "all good": f"{executed[f'{setting}_success'].fillna(False).mean():.0%}",
                "median / p90 yaw travel (deg)": "{:.0f} / {:.0f}".format(*executed["yaw_travel_deg"].quantile([0.5, 0.9])),
                "median path / straight": f"{(executed['tip_path_m'] / executed['straight_m']).median():.2f}",
            })
    return pd.DataFrame(rows)


def report(results: pd.DataFrame, name: str, grasps: bool) -> None:
    """Print the tables of one run (``grasps``: also where the grasp frames lie, by re-planning)."""
    executed = results[results["solved"].fillna(False) & results["error"].isna()].copy()
    print(f"### {name}: {len(results)} tasks, {int(results['solved'].fillna(False).sum())} solved, "
          f"{int(results['error'].notna().sum())} raised\n")
    print(markdown_table(summarize_execution(results).round(3)) + "\n")
    executed["yaw_per_cm"] = executed["yaw_travel_deg"] / (100 * executed["tip_path_m"])
    executed["path_ratio"] = executed["tip_path_m"] / executed["straight_m"]
    print(markdown_table(binned(executed, "yaw_travel_deg", [0, 100, 150, 1e4], "yaw travel (deg)")) + "\n")
    print(markdown_table(binned(executed, "yaw_per_cm", [0, 2, 4, 1e4], "yaw per cm of path (deg/cm)")) + "\n")
    print(markdown_table(binned(executed, "path_ratio", [1, 1.3, 2, 1e4], "path / straight distance")) + "\n")
    margin = pd.cut(1000 * executed["planned_com_margin_m"], [-1e4, 3, 10, 1e4], right=False)
    rows = []
    for interval, group in executed.groupby(margin, observed=True):
        row = {"planned CoM margin (mm)": f"[{interval.left:g}, {interval.right:g})", "plans": len(group)}
        for setting in SETTINGS:
            row[f"{setting} fell"] = int((group[f"{setting}_failed_stage"] == "release").sum())
        rows.append(row)
    print(markdown_table(pd.DataFrame(rows)) + "\n")
    failures = executed["nominal_failure"].fillna("").str.replace(r"[-\d.]+", "N", regex=True)
    print(markdown_table(failures[failures != ""].value_counts().rename_axis("nominal failure").reset_index()) + "\n")
    if grasps:
        executed = executed.join(pd.DataFrame([replanned(row) for _, row in executed.iterrows()], index=executed.index))
        grasp = pd.cut(executed["grasp_outside_mm"], [-1e4, 15, 25, 1e4], right=False)
        rows = []
        for interval, group in executed.groupby(grasp, observed=True):
            kept = group[group["nominal_failed_stage"].isna() | (group["nominal_failed_stage"] == "grasp")]
            rows.append({
                "grasp frame outside the edge (mm)": f"[{interval.left:g}, {interval.right:g})",
                "plans (slide ok or grasp failed, nominal)": len(kept),
                "lifted": int(kept["nominal_lifted"].fillna(False).sum()),
            })
        print(markdown_table(pd.DataFrame(rows)) + "\n")
        for column, edges, label in (("contact_com_mm", [0, 30, 45, 1e4], "first contact from the CoM (mm)"),
                                     ("contact_outline_mm", [0, 2, 6, 1e4], "first contact inside the outline (mm)"),
                                     ("depth_min_mm", [0, 9.9, 12, 20, 1e4], "shallowest contact depth (mm)")):
            print(markdown_table(binned(executed, column, edges, label)) + "\n")
    print("median: path {:.2f} m, wall time per execution {:.1f} s (nominal)\n".format(
        executed["tip_path_m"].median(), executed["nominal_wall_time_s"].median()))


def main() -> None:
    default, paper = load_execution(HERE / "execution.parquet"), load_execution(HERE / "execution_paper.parquet")
    same_tasks = default[default["pose_index"].isin(paper["pose_index"].unique())]
    print(markdown_table(comparison({
        f"default, all {len(default)} tasks": default,
        f"default, the {len(same_tasks)} tasks below": same_tasks,
        "physically aware options off": paper,
    })) + "\n")
    report(default, "default planner", grasps=True)
    report(paper, "physically aware options off", grasps=False)
    for path in plot_execution(default, HERE / "figures"):
        print(path, file=sys.stderr)


if __name__ == "__main__":
    main()
