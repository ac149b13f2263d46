"""Time-parameterization benchmark of issue 11: how long `slideplan.timing.parameterize` takes.

Plans the square table with 5 objects x N seeded poses, then times `parameterize` (slide and
approach, URDF limits, fingertip cap) on every solved plan, R repetitions each. Prints and writes
(docs/benchmarks/timing.md) the median / p90 / max per plan with the CPU named, the waypoint counts,
and the one-off cost of the first call in a process (importing toppra). Not a test: `make bench`.

    python benchmarks/timing_bench.py [--poses 10] [--repeat 5]
"""

from __future__ import annotations

import argparse
import datetime
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
from plan_bench import write_report
from plan_bench import OBJECTS, cpu_name  # same directory: python puts it on sys.path

from slideplan import PlannerConfig, load_object, load_scene, plan
from slideplan.objects import load_outline, sample_pose_on_table
from slideplan.timing import parameterize

GOAL_S = 0.050  # the budget for parameterizing one plan


def solved_plans(poses: int) -> list:
    """Seeded plans on the square table (unsolved ones left out)."""
    scene = load_scene("square")
    plans = []
    for object_name in OBJECTS:
        outline, _, _ = load_outline(object_name)
        for index in range(poses):
            pose = sample_pose_on_table(outline, scene.table, np.random.default_rng([index, OBJECTS.index(object_name)]))
            obj = load_object(object_name, table_height=scene.table.height, pose=pose)
            result = plan(scene, obj, PlannerConfig(seed=index, time_limit_s=10))
            if result.solved:
                plans.append(result)
    return plans


def first_call_seconds(result) -> float:
    """The first `parameterize` of a fresh Python process (imports included), in seconds."""
    with tempfile.TemporaryDirectory() as directory:
        path = Path(directory) / "plan.json"
        path.write_text(result.to_json())
        code = (
            "import sys, time; from slideplan.planning import PlanResult; "
            "r = PlanResult.from_json(open(sys.argv[1]).read()); s = time.perf_counter(); "
            "from slideplan.timing import parameterize; parameterize(r); print(time.perf_counter() - s)"
        )
        done = subprocess.run([sys.executable, "-c", code, str(path)], capture_output=True, text=True, check=True)
    return float(done.stdout.split()[-1])


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--poses", type=int, default=10, help="seeded poses per object")
    parser.add_argument("--repeat", type=int, default=5, help="timings per plan (the median is kept)")
    parser.add_argument("--out", type=Path, default=Path(__file__).resolve().parent.parent / "docs/benchmarks/timing.md")
    args = parser.parse_args()

    plans = solved_plans(args.poses)  # plan() already timed them once: toppra is imported, the URDF parsed
    per_plan, waypoints = [], []
    for result in plans:
        samples = []
        for _ in range(args.repeat):
            start = time.perf_counter()
            parameterize(result)
            samples.append(time.perf_counter() - start)
        per_plan.append(float(np.median(samples)))
        waypoints.append((len(result.trajectory), len(result.grasp["approach"])))
    per_plan = np.array(per_plan)
    slide, approach = np.array(waypoints).T

    first_call = first_call_seconds(plans[0])
    lines = [
        f"# Time-parameterization benchmark ({datetime.date.today().isoformat()})",
        "",
        f"CPU: {cpu_name()}, {os.cpu_count()} cores (1-minute load average {os.getloadavg()[0]:.1f} at the end: other "
        f"work on the machine slows the numbers); one thread. Square table, objects {', '.join(OBJECTS)}, "
        f"{args.poses} seeded poses each: {len(plans)} solved plans; each parameterized {args.repeat} times "
        "(its median kept). `parameterize` times the slide and the approach under the URDF velocity limits, "
        "the default accelerations and the 5 cm/s fingertip cap.",
        "",
        "| per plan | median | p90 | max |",
        "|---|---|---|---|",
        f"| parameterize | {1e3 * np.median(per_plan):.1f} ms | {1e3 * np.quantile(per_plan, 0.9):.1f} ms | "
        f"{1e3 * per_plan.max():.1f} ms |",
        "",
        f"Waypoints per plan: slide median {int(np.median(slide))} (max {slide.max()}), approach median "
        f"{int(np.median(approach))} (max {approach.max()}). Goal: under {1e3 * GOAL_S:.0f} ms per plan "
        f"({'met' if np.quantile(per_plan, 0.9) < GOAL_S else 'NOT met'} at p90).",
        "",
        f"Not included above: the first call in a fresh process also imports toppra (with matplotlib and scipy) "
        f"and parses the URDF: {first_call:.2f} s, once.",
    ]
    write_report(lines, args.out)


if __name__ == "__main__":
    main()
