"""Throughput of planning in threads and processes: plans per second with 1 and 2 threads of one
process and with 2 processes, on the same problems (square table, 5 objects x N seeded poses).

Plans release the GIL and share nothing mutable (docs/design.md 9), so threads should scale like
processes. Prints and writes docs/benchmarks/threads.md with the build, CPU and date named. Not a test: `make bench`.

    python benchmarks/thread_bench.py [--poses 10] [--repeats 3]
"""

from __future__ import annotations

import argparse
import time
from concurrent.futures import Executor, ProcessPoolExecutor, ThreadPoolExecutor
from pathlib import Path

import numpy as np
from plan_bench import OBJECTS, write_report

from slideplan import PlannerConfig, load_object, load_scene, plan
from slideplan.world.objects import load_outline, sample_pose_on_table

SETTINGS = (("1 thread", ThreadPoolExecutor, 1), ("2 threads", ThreadPoolExecutor, 2), ("2 processes", ProcessPoolExecutor, 2))


PROBLEMS: list = []  # (scene, object, config), built once before any pool starts (forked processes inherit them)


def build_problems(jobs: list[tuple[str, int]]) -> None:
    """The scene once, as a planning server holds it, and one placed object per job."""
    scene = load_scene("square")
    for object_name, pose_index in jobs:
        outline, _, _ = load_outline(object_name)
        pose = sample_pose_on_table(outline, scene.table, np.random.default_rng([pose_index, OBJECTS.index(object_name)]))
        obj = load_object(object_name, table_height=scene.table.height, pose=pose)
        PROBLEMS.append((scene, obj, PlannerConfig.for_scene(scene, seed=pose_index, time_limit_s=10.0)))


def run_one(index: int) -> bool:
    """Plan one problem (10 s budget); True if solved."""
    return plan(*PROBLEMS[index]).solved


def throughput(executor: Executor, workers: int) -> tuple[float, int]:
    """(plans per second, plans solved) of all problems on the executor, after one warm-up plan per worker."""
    list(executor.map(run_one, range(workers)))  # load the robot model (and start the processes)
    started = time.perf_counter()
    solved = sum(executor.map(run_one, range(len(PROBLEMS))))
    return len(PROBLEMS) / (time.perf_counter() - started), solved


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--poses", type=int, default=10, help="seeded initial poses per object")
    parser.add_argument("--repeats", type=int, default=3, help="runs of each setting (the median is reported)")
    parser.add_argument("--out", type=Path, default=Path("docs/benchmarks/threads.md"))
    args = parser.parse_args()

    jobs = [(name, pose) for name in OBJECTS for pose in range(args.poses)]
    build_problems(jobs)
    lines = [
        "# Planning throughput in threads and processes",
        "",
        f"Square table, objects {', '.join(OBJECTS)}, {args.poses} seeded "
        f"poses each ({len(jobs)} plans per run, 10 s budget), {args.repeats} runs per setting; plans per second "
        "of the whole batch (median and range over the runs). The scene and the placed objects are built once "
        "before timing, as a planning server holds its scene; each `plan()` (with its time parameterization) is timed.",
        "",
        "| setting | plans/s (median) | min | max | solved | speed-up over 1 thread |",
        "|---|---|---|---|---|---|",
    ]
    baseline = None
    for label, kind, workers in SETTINGS:
        rates, solved = [], 0
        with kind(max_workers=workers) as executor:
            for _ in range(args.repeats):
                rate, solved = throughput(executor, workers)
                rates.append(rate)
        median = float(np.median(rates))
        baseline = baseline or median
        lines.append(f"| {label} | {median:.1f} | {min(rates):.1f} | {max(rates):.1f} | {solved}/{len(jobs)} | "
                     f"{median / baseline:.2f}x |")
    write_report(lines, args.out)


if __name__ == "__main__":
    main()
