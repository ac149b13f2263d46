"""The closed loop's camera calibration over the hard setting's draws: the mounting error drawn, the error
the calibration from the robot leaves (:mod:`slideplan.perception.calibration`), and the run's verdict.

Every task of the closed loop's ``dev`` and former ``eval`` sets (both worked on; never ``eval2``) runs once
closed loop in the hard setting (its own seed's draws: camera error, frictions, push); each row holds the
draws, the run report's ``camera_estimate`` and ``camera_error`` and the world's verdict, so that
docs/results/numbers_calibration.py writes the error before and after per axis into
docs/results/camera_calibration.md.

    python benchmarks/camera_calibration.py --workers 2     # writes docs/results/camera_calibration.parquet
"""

from __future__ import annotations

import argparse
import json
import multiprocessing
from pathlib import Path

import pandas as pd

OUT = Path(__file__).resolve().parent.parent / "docs" / "results" / "camera_calibration.parquet"


def tasks(poses: int | None):
    """``(set, task)`` for every task of dev and the former eval set."""
    from slideplan.experiments.tasks import build_spec

    return [(task_set, task) for task_set in ("dev", "eval")
            for task in build_spec("closed-loop", task_set=task_set, poses=poses).tasks]


def run_one(item) -> dict:
    """One hard closed-loop run: the task, its draws, the camera's estimate and the error left, the verdict."""
    from slideplan.experiments.tasks import cached_scene
    from slideplan.provenance import run_provenance
    from slideplan.sim.closed_loop import run

    task_set, task = item
    report = run(cached_scene(task.scene), task.object, (task.x, task.y, task.yaw), seed=task.seed, closed=True,
                 setting="hard", config=task.planner_config())
    return {**task.fields(), "task_set": task_set, **run_provenance(), "success": report.success,
            "failed_stage": report.failed_stage or "", "failure": report.failure, "draws": json.dumps(report.draws),
            "camera_estimate": json.dumps(report.camera_estimate), "camera_error": json.dumps(report.camera_error)}


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
