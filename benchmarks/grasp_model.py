"""The grasp's physics rules (``support_hull`` and ``grasp_model``) against MuJoCo, on the dev set's grasps.

Every task of the closed loop's ``dev`` and former ``eval`` sets (both worked on; never ``eval2``) is planned
with both rules off, at two values of ``u_star`` (the hand's 2 cm and a shallower 1 cm, so that marginal
grasps are among them), and run open loop in nominal physics. Each row holds the world's verdict
(:mod:`slideplan.checks.verdict`), the object's true pose when the slide ended and the grasp the hand made, so
that the rules are judged on the object as it truly lay (its catalogue outline there) by
docs/results/numbers_grasp_model.py, which writes the confusion matrix at the registry's values into
docs/results/grasp_model.md. Every value of ``grip_force`` is scored by the same rows (the rules only judge,
the physics ran without them).

    python benchmarks/grasp_model.py --workers 2        # writes docs/results/grasp_model.parquet
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import multiprocessing
from pathlib import Path

import pandas as pd

OUT = Path(__file__).resolve().parent.parent / "docs" / "results" / "grasp_model.parquet"
U_STARS = (0.02, 0.01)
RULES_OFF = {"grasp_model": False, "support_hull": False}


def tasks(poses: int | None):
    """``(set, task)`` for every task of dev and the former eval set, once per value of :data:`U_STARS`."""
    from slideplan.experiments.tasks import build_spec

    chosen = []
    for task_set in ("dev", "eval"):
        for task in build_spec("closed-loop", task_set=task_set, poses=poses).tasks:
            chosen += [(task_set, dataclasses.replace(task, params=json.dumps({**RULES_OFF, "u_star": u})))
                       for u in U_STARS]
    return chosen


def run_one(item) -> dict:
    """One open-loop nominal run: the task, the verdict, the true end pose and the grasp."""
    from slideplan.experiments.tasks import cached_scene
    from slideplan.provenance import run_provenance
    from slideplan.sim.closed_loop import run

    task_set, task = item
    config = task.planner_config()
    report = run(cached_scene(task.scene), task.object, (task.x, task.y, task.yaw), seed=task.seed, closed=False,
                 setting="nominal", config=config)
    true = report.true_motion or {}
    return {**task.fields(), "task_set": task_set, "u_star": config.u_star, **run_provenance(),
            "success": report.success, "failed_stage": report.failed_stage or "", "failure": report.failure,
            "lifted": report.lifted, "true_overhang_m": report.true_overhang_m,
            "true_x": true.get("x"), "true_y": true.get("y"), "true_yaw": true.get("yaw"),
            "grasp_pose": json.dumps(report.grasp_pose)}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--workers", type=int, default=2)
    parser.add_argument("--poses", type=int, default=None, help="poses per cell (default: each set's)")
    parser.add_argument("--out", type=Path, default=OUT)
    args = parser.parse_args()
    items = tasks(args.poses)
    rows = []
    with multiprocessing.get_context("spawn").Pool(args.workers) as pool:
        for index, row in enumerate(pool.imap_unordered(run_one, items), 1):
            rows.append(row)
            if index % 20 == 0 or index == len(items):
                print(f"{index}/{len(items)}", flush=True)
                pd.DataFrame(rows).sort_values(["task_id"]).to_parquet(args.out, index=False)


if __name__ == "__main__":
    main()
