"""Time-parameterization benchmark: the C++ TOPP-RA (`slideplan.plan.timing.parameterize`) against the Python
toppra it replaced (tests/python/toppra_reference.py), on the plans of Fig. 10.

Plans the Fig. 10 tasks (4 tables x 5 objects x 2 scales x N poses, the hand's parameters), then times
both parameterizations of every solved plan (slide and approach, URDF limits, fingertip cap), R
repetitions each, and compares their durations. Prints and writes (docs/benchmarks/timing.md) the
median / p90 / max per plan with the build, CPU and date named, the largest duration difference, the cost of the
first call in a fresh process, and the wall time of a warm `plan()` (timing included) per table. Not a
test: `make bench`.

    python benchmarks/timing_bench.py [--poses 3] [--repeat 5]
"""

from __future__ import annotations

import argparse
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
from plan_bench import write_report  # same directory: python puts it on sys.path

from slideplan import InputError, load_scene, plan
from slideplan.experiments.tasks import build_spec
from slideplan.plan.timing import NEAR_TABLE_M, parameterize, resolve_limits

sys.path.insert(0, str(Path(__file__).resolve().parent.parent / "tests/python"))
import toppra_reference  # noqa: E402  (needs toppra: the test extra)

GOAL_S = 0.050  # the budget for parameterizing one plan
PLAN_GOAL_S = 0.010  # and for a warm plan() with its timing (median per table)


def solved_plans(poses: int) -> tuple[list, dict[str, list[float]]]:
    """The solved plans of the first ``poses`` poses of every Fig. 10 cell, and per table the wall
    seconds of planning each of them again: warm (robot and grasp map loaded), timing included."""
    plans, walls = [], {}
    for task in build_spec("fig10", poses=poses).tasks:
        scene, placed, config = load_scene(task.scene), task.placed_object(), task.planner_config()
        try:
            result = plan(scene, placed, config)
        except InputError:  # an object too small for u* at half scale
            continue
        if result.solved:
            plans.append(result)
            start = time.perf_counter()
            plan(scene, placed, config)
            walls.setdefault(task.scene, []).append(time.perf_counter() - start)
    return plans, walls


def toppra_timing(result) -> dict:
    """Both segments timed by the toppra reference, as parameterize times them."""
    limits = resolve_limits(result)
    robot = result.robot_model()
    approach = np.asarray(result.grasp["approach"], dtype=float)
    tips = np.array([np.asarray(robot.fk(config))[:3, 3] for config in approach])
    top = result.table["height"] + result.object["thickness"]
    return {
        "trajectory": toppra_reference.time_path(np.asarray(result.trajectory), np.asarray(result.fingertip_poses)[:, :3],
                                                 np.ones(len(result.trajectory), bool), limits, "trajectory"),
        "approach": toppra_reference.time_path(approach, tips, tips[:, 2] < top + NEAR_TABLE_M, limits, "approach"),
    }


def median_seconds(function, repeat: int) -> float:
    samples = []
    for _ in range(repeat):
        start = time.perf_counter()
        function()
        samples.append(time.perf_counter() - start)
    return float(np.median(samples))


def first_call_seconds(result) -> float:
    """The first `parameterize` of a fresh Python process (imports included), in seconds."""
    with tempfile.TemporaryDirectory() as directory:
        path = Path(directory) / "plan.json"
        path.write_text(result.to_json())
        code = (
            "import sys, time; from slideplan.plan.result import PlanResult; "
            "r = PlanResult.from_json(open(sys.argv[1]).read()); s = time.perf_counter(); "
            "from slideplan.plan.timing import parameterize; parameterize(r); print(time.perf_counter() - s)"
        )
        done = subprocess.run([sys.executable, "-c", code, str(path)], capture_output=True, text=True, check=True)
    return float(done.stdout.split()[-1])


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--poses", type=int, default=3, help="poses per Fig. 10 cell")
    parser.add_argument("--repeat", type=int, default=5, help="timings per plan (the median is kept)")
    parser.add_argument("--out", type=Path, default=Path(__file__).resolve().parent.parent / "docs/benchmarks/timing.md")
    args = parser.parse_args()

    plans, walls = solved_plans(args.poses)
    toppra_timing(plans[0])  # import toppra before timing it
    ours, theirs, differences, waypoints = [], [], [], []
    for result in plans:
        ours.append(median_seconds(lambda: parameterize(result), args.repeat))
        theirs.append(median_seconds(lambda: toppra_timing(result), args.repeat))
        reference = toppra_timing(result)
        for segment in ("trajectory", "approach"):
            duration = result.timing[segment]["time_from_start"][-1]
            expected = reference[segment]["time_from_start"][-1]
            differences.append(abs(duration - expected) / expected)
        waypoints.append((len(result.trajectory), len(result.grasp["approach"])))
    ours, theirs, differences = np.array(ours), np.array(theirs), np.array(differences)
    slide, approach = np.array(waypoints).T

    def row(name, values):
        return f"| {name} | {1e3 * np.median(values):.2f} ms | {1e3 * np.quantile(values, 0.9):.2f} ms | {1e3 * values.max():.2f} ms |"

    first_call = first_call_seconds(plans[0])
    lines = [
        "# Time-parameterization benchmark",
        "",
        f"1-minute load average {os.getloadavg()[0]:.1f} at the end (other work on the machine slows the numbers); "
        "one thread. The Fig. 10 tasks, {args.poses} poses per table, object "
        f"and scale: {len(plans)} solved plans; each timed {args.repeat} times by each implementation (its median kept), "
        "slide and approach under the URDF velocity limits, the default accelerations and the 5 cm/s fingertip cap.",
        "",
        "| per plan | median | p90 | max |",
        "|---|---|---|---|",
        row("C++ TOPP-RA (`parameterize`)", ours),
        row("toppra, Python (before)", theirs),
        "",
        f"Durations: the largest difference between the two over {len(differences)} segments is "
        f"{100 * differences.max():.4f}% (median {100 * np.median(differences):.5f}%). Waypoints per plan: slide median "
        f"{int(np.median(slide))} (max {slide.max()}), approach median {int(np.median(approach))} (max {approach.max()}). "
        f"Goal: under {1e3 * GOAL_S:.0f} ms per plan ({'met' if np.quantile(ours, 0.9) < GOAL_S else 'NOT met'} at p90).",
        "",
        f"The first `parameterize` in a fresh process (its imports and the URDF parse included): {1e3 * first_call:.1f} ms. "
        "`plan()` times a solved plan inside its C++ call, without the GIL.",
        "",
        "## `plan()` warm, timing included",
        "",
        "Each solved task above planned once more in the same process (the robot and the grasp map loaded, as in a "
        f"planning server or a closed loop), wall time of the call. Goal: median under {1e3 * PLAN_GOAL_S:.0f} ms per table.",
        "",
        "| table | plans | median | p90 | max |",
        "|---|---|---|---|---|",
        *(row(f"{table} | {len(seconds)}", np.array(seconds)) for table, seconds in walls.items()),
        "",
        "Goal " + ("met" if all(np.median(s) < PLAN_GOAL_S for s in walls.values()) else "NOT met") + " on every table.",
    ]
    write_report(lines, args.out)


if __name__ == "__main__":
    main()
