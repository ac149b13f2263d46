"""Generated blocks of docs/results/grasp_model.md from ``grasp_model.parquet`` (benchmarks/grasp_model.py's rows:
open-loop nominal runs of the dev grasps, planned with the grasp's physics rules off).

Each run's grasp is judged by the rules (``support_hull`` and ``grasp_model``, the registry's values) on the
object as it truly lay when the slide ended, and set against the world's verdict: the confusion matrix,
the acceptance precision, and ``support_margin`` and ``grip_force`` chosen by the rule the page states
(:func:`calibrated`). The registry's values must be those: rows that disagree stop the page's
regeneration."""

from __future__ import annotations

import dataclasses
import json
import math
from functools import cache

import numpy as np
import pandas as pd
from numbers_common import HERE, build_of, percent

ROWS = "grasp_model.parquet"
STEP_N = 0.05  # grip_force's grid (N)
SUPPORT_STEP_M = 0.0025  # support_margin's grid (m)
PRECISION = 0.99


@cache
def judged() -> pd.DataFrame:
    """The runs that made a grasp, with ``support_margin_m``, the grasp model's terms and ``required_force_n``
    (gravity's moment over the patch's length: the grip at which the model starts to hold)."""
    from slideplan import _core
    from slideplan.experiments.tasks import Task, cached_scene
    from slideplan.transforms import move_planar, row_to_pose
    from slideplan.world.geometry import overhang, support_margin

    runs = pd.read_parquet(HERE / ROWS)
    runs = runs[runs["grasp_pose"] != "null"].reset_index(drop=True)
    names = [field.name for field in dataclasses.fields(Task)]
    extra = []
    for row in runs.itertuples():
        task = Task(**{name: getattr(row, name) for name in names})
        table = cached_scene(task.scene).table
        config = dataclasses.replace(task.planner_config(), grasp_model=True, support_hull=True)
        truth = task.placed_object()
        motion = (row.true_x, row.true_y, row.true_yaw)
        points = move_planar(truth.points[:, :2], motion)
        com = move_planar(np.asarray(truth.centroid_xy, dtype=float), motion)
        support = support_margin(table, points, com)
        pose = row_to_pose(json.loads(row.grasp_pose))
        outward = -pose[:2, 2] / np.linalg.norm(pose[:2, 2])
        _, outside, edge = overhang(table, points)
        beyond = float((pose[:2, 3] - edge[0]) @ edge[1]) if edge is not None else 0.0
        params = config.to_params()
        hold = _core.estimate_hold(np.ascontiguousarray(points), com, truth.thickness, pose[:2, 3], beyond, outward, params)
        extra.append({"support_margin_m": support, "support_margin": config.support_margin, "patch_area_m2": hold["patch_area"],
                      "mass_kg": hold["mass"], "lever_m": hold["lever"], "patch_length_m": hold["patch_length"],
                      "required_force_n": hold["demand"] / hold["patch_length"] if hold["patch_length"] > 0 else np.inf,
                      "grip_force_n": params.grip_force})
    return pd.concat([runs, pd.DataFrame(extra)], axis=1)


def accepted(runs: pd.DataFrame, support: float, grip_force: float) -> pd.Series:
    """Whether both rules accept each run's grasp at ``support_margin`` = ``support`` and ``grip_force``."""
    return (runs["support_margin_m"] >= support - 1e-12) & (runs["required_force_n"] <= grip_force + 1e-12)


def calibrated(runs: pd.DataFrame) -> tuple[float, float]:
    """``(support_margin, grip_force)`` on the grids :data:`SUPPORT_STEP_M` and :data:`STEP_N`: of the pairs
    whose accepted grasps lift in at least :data:`PRECISION` of the runs, the one that accepts the most lifted
    grasps (the smaller margin and the larger grip among equals)."""
    lifted = runs["success"].astype(bool)
    finite = runs["required_force_n"][np.isfinite(runs["required_force_n"])]
    best, chosen = -1, (math.nan, math.nan)
    for support in np.arange(0.0, 0.02 + 1e-9, SUPPORT_STEP_M):
        for force in np.arange(STEP_N, float(finite.max()) + STEP_N, STEP_N):
            taken = accepted(runs, support, force)
            kept = int((taken & lifted).sum())
            if taken.any() and kept / int(taken.sum()) >= PRECISION and kept >= best:
                if kept > best or support < chosen[0] - 1e-12 or force > chosen[1]:
                    best, chosen = kept, (round(float(support), 4), round(float(force), 2))
    return chosen


def confusion(runs: pd.DataFrame, support: float, grip_force: float) -> str:
    taken = accepted(runs, support, grip_force)
    lifted = runs["success"].astype(bool)
    lines = ["| | lifted and held | not |", "|---|---|---|",
             f"| accepted | {int((taken & lifted).sum())} | {int((taken & ~lifted).sum())} |",
             f"| rejected | {int((~taken & lifted).sum())} | {int((~taken & ~lifted).sum())} |"]
    return "\n".join(lines)


def by_rule(runs: pd.DataFrame, support_m: float, grip_force: float) -> str:
    """What each rule rejects, and how many of those runs lifted anyway."""
    support = runs["support_margin_m"] >= support_m - 1e-12
    hold = runs["required_force_n"] <= grip_force + 1e-12
    lines = ["| rejected by | runs | of them lifted and held |", "|---|---|---|"]
    for label, mask in (("support_hull only", ~support & hold), ("grasp_model only", support & ~hold),
                        ("both", ~support & ~hold)):
        lines.append(f"| {label} | {int(mask.sum())} | {int(runs['success'][mask].sum())} |")
    return "\n".join(lines)


def sweep(runs: pd.DataFrame, support: float) -> str:
    """Precision and recall of the rules over a range of grip forces, at ``support``."""
    lifted = runs["success"].astype(bool)
    lines = ["| grip_force | accepted | precision | lifted grasps accepted |", "|---|---|---|---|"]
    for force in (0.1, 0.2, 0.3, 0.5, 0.75, 1.0, 1.5, 2.0, 3.0, 5.0):
        taken = accepted(runs, support, force)
        precision = percent(int((taken & lifted).sum()), int(taken.sum())) if taken.any() else "-"
        lines.append(f"| {force:g} N | {int(taken.sum())} | {precision} | "
                     f"{percent(int((taken & lifted).sum()), int(lifted.sum()))} |")
    return "\n".join(lines)


def missed(runs: pd.DataFrame, support: float, grip_force: float) -> str:
    """The accepted grasps that did not lift, one line each."""
    taken = runs[accepted(runs, support, grip_force) & ~runs["success"].astype(bool)]
    lines = [f"- {row.object} on {row.scene}, pose {row.pose_index}, u* {100 * row.u_star:g} cm: {row.failure} "
             f"(support margin {1000 * row.support_margin_m:.1f} mm, {row.required_force_n:.2f} N needed)"
             for row in taken.itertuples()]
    return "\n".join(lines) if lines else "(none)"


def values() -> dict[str, str]:
    runs = judged()
    registry = (float(runs["support_margin"].iloc[0]), float(runs["grip_force_n"].iloc[0]))
    chosen = calibrated(runs)
    if any(abs(a - b) > 1e-9 for a, b in zip(registry, chosen)):
        raise ValueError(f"the registry's (support_margin, grip_force) is {registry}; {ROWS} calibrates them to {chosen} "
                         "(cpp/src/params.cpp)")
    support, grip = registry
    taken = accepted(runs, support, grip)
    lifted = runs["success"].astype(bool)
    return {
        "grasp-model-confusion": confusion(runs, support, grip), "grasp-model-rules": by_rule(runs, support, grip),
        "grasp-model-sweep": sweep(runs, support), "grasp-model-missed": missed(runs, support, grip),
        "grasp-model-grip": f"{grip:g} N", "grasp-model-support": f"{1000 * support:g} mm",
        "grasp-model-runs": str(len(runs)),
        "grasp-model-precision": percent(int((taken & lifted).sum()), int(taken.sum())),
        "grasp-model-recall": percent(int((taken & lifted).sum()), int(lifted.sum())),
        "grasp-model-base": percent(int(lifted.sum()), len(runs)),
        "build-grasp-model": build_of(ROWS),
        "grasp-model-machine": ", ".join(sorted(set(runs["cpu"].astype(str)))),
        "grasp-model-date": ", ".join(sorted(set(runs["date"].astype(str).str[:10]))),
    }
