"""Execution benchmark: the demo plan (crescent on the square table, seed 0) executed in MuJoCo.

Plans the demo once, then executes it ``--runs`` times in this process (one core) and prints and
writes (docs/benchmarks/execution.md) the wall time per execution (median, min), the simulated
time and the real-time factor, with the build, CPU and date named. Not a test: ``make bench``.

    python benchmarks/execute_bench.py [--runs 3] [--out docs/benchmarks/execution.md]
"""

from __future__ import annotations

import argparse
import statistics
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from slideplan import PlannerConfig, load_scene, plan
from slideplan.execute import execute
from slideplan.objects import load_object, load_outline, sample_pose_on_table

sys.path.insert(0, str(Path(__file__).resolve().parent))
from plan_bench import write_report  # noqa: E402 - the benchmarks' common ending


def demo_plan():
    """The plan ``slideplan demo`` makes (crescent, square table, seed 0)."""
    scene = load_scene("square")
    outline, _, _ = load_outline("crescent")
    pose = sample_pose_on_table(outline, scene.table, rng=np.random.default_rng(0))
    obj = load_object("crescent", table_height=scene.table.height, pose=pose)
    return plan(scene, obj, PlannerConfig.for_scene(scene, seed=0))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--runs", type=int, default=3, help="executions to time")
    parser.add_argument("--out", type=Path, default=Path(__file__).resolve().parents[1] / "docs/benchmarks/execution.md")
    args = parser.parse_args()
    result = demo_plan()
    assert result.solved, "the demo plan did not solve"
    executions = [execute(result) for _ in range(args.runs)]
    walls = [execution.wall_time_s for execution in executions]
    with tempfile.TemporaryDirectory() as folder:  # the same run rendered, as `execute --video` does
        started = time.perf_counter()
        execute(result, video=Path(folder) / "run.mp4")
        video_wall = time.perf_counter() - started
    simulated = executions[0].sim_time_s
    median = statistics.median(walls)
    lines = [
        "# Execution benchmark",
        "",
        f"`benchmarks/execute_bench.py --runs {args.runs}`, one process (one core): the demo plan (crescent on the "
        "square table, seed 0, "
        f"{len(result.trajectory)} sliding waypoints, {len(result.grasp['approach'])} approach waypoints) executed "
        "in MuJoCo: slide, approach, close, 5 cm lift, 1 s hold (docs/execution.md).",
        "",
        "| executions | simulated time | wall time, median | wall time, min | real-time factor (median) |",
        "|---|---|---|---|---|",
        f"| {args.runs} | {simulated:.1f} s | {median:.1f} s | {min(walls):.1f} s | {simulated / median:.1f}x |",
        "",
        f"Outcome (the same every run): {executions[0].summary()}",
        "",
        f"With `--video run.mp4` (640x480, 20 frames per simulated second, software EGL): {video_wall:.1f} s wall, "
        f"{video_wall / median:.2f}x the median without video.",
    ]
    write_report(lines, args.out)


if __name__ == "__main__":
    main()
