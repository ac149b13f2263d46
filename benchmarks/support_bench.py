"""The centre of mass on the table along the slide (``com_supported``): what it costs and what it stops.

On the closed-loop experiment's 200 tasks (4 tables x 5 objects x 10 poses, the T42's parameters), with
``com_supported`` on and off in the same run, the order alternating per task so neither always pays for
the grasp map's first probes: the first plan (10 s limit), and a re-plan from 3/4 along the slide with
the object where Eq. 2 puts it (1 s limit, as in the closed loop). Reports solved, median / p90 / p99
planning time and how many plans take the centre of mass off the table before the end, with the build,
CPU and date named; writes docs/benchmarks/support.md. Not a test: ``make bench``.

    python benchmarks/support_bench.py [--poses 10]
"""

from __future__ import annotations

import argparse
import dataclasses
from pathlib import Path

import numpy as np
from plan_bench import write_report

from slideplan import plan
from slideplan.experiments.tasks import _placed_object, build_spec, cached_scene
from slideplan.transforms import move_planar, row_to_pose
from slideplan.transforms import planar_motion


def lowest_margin(table, result) -> float:
    """The smallest distance of the centre of mass inside the table edge over the plan's waypoints (m)."""
    first, com = row_to_pose(result.fingertip_poses[0]), np.asarray(result.object["com_xy"], dtype=float)
    return min(table.edge_margin(move_planar(com, planar_motion(first, row_to_pose(row)))) for row in result.fingertip_poses)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--poses", type=int, default=10, help="poses per table and object")
    parser.add_argument("--out", default="docs/benchmarks/support.md")
    args = parser.parse_args()
    runs = {(kind, on): [] for kind in ("first", "re-plan") for on in (True, False)}
    for index, task in enumerate(build_spec("closed-loop", poses=args.poses).tasks):
        scene = cached_scene(task.scene)
        obj = _placed_object(task.object, task.scale, scene.table.height, (task.x, task.y, task.yaw))
        base = dataclasses.replace(task.planner_config(), time_limit_s=10.0)
        order = (True, False) if index % 2 else (False, True)
        first = None
        for on in order:
            result = plan(scene, obj, dataclasses.replace(base, com_supported=on))
            runs["first", on].append((result.solved, result.planning_time_s,
                                      lowest_margin(scene.table, result) if result.solved else np.nan))
            first = result if result.solved and on else first
        if first is None or len(first.trajectory) < 4:
            continue
        k = 3 * len(first.trajectory) // 4
        seen = obj.moved(planar_motion(row_to_pose(first.fingertip_poses[0]), row_to_pose(first.fingertip_poses[k])))
        for on in order:
            result = plan(scene, seen, dataclasses.replace(base, com_supported=on, time_limit_s=1.0),
                          start_config=first.trajectory[k])
            runs["re-plan", on].append((result.solved, result.planning_time_s,
                                        lowest_margin(scene.table, result) if result.solved else np.nan))

    lines = ["# Centre of mass on the table along the slide (`com_supported`)", "",
             "One process. `python benchmarks/support_bench.py "
             f"--poses {args.poses}`: the closed-loop experiment's tasks, on and off in the same run.", "",
             "| plans | com_supported | solved | median | p90 | p99 | centre of mass off the table before the end | lowest margin |",
             "|---|---|---|---|---|---|---|---|"]
    for (kind, on), rows in runs.items():
        data = np.array(rows, dtype=float)
        solved = data[:, 0] > 0
        ms = 1000 * data[solved, 1]
        lines.append(f"| {kind} | {'on' if on else 'off'} | {solved.sum()}/{len(data)} | {np.median(ms):.1f} ms | "
                     f"{np.percentile(ms, 90):.1f} ms | {np.percentile(ms, 99):.1f} ms | {int((data[solved, 2] < 0).sum())} | "
                     f"{1000 * np.nanmin(data[solved, 2]):.1f} mm |")
    write_report(lines, Path(args.out))


if __name__ == "__main__":
    main()
