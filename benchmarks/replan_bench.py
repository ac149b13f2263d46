"""Re-planning latency: track the object in a depth frame, then plan from the arm's state.

For each object at seeded poses on the square table: plan; a third of the way along the slide the
object is where Eq. 2 puts it, moved further by a drift (turned up to 2 degrees about the fingertip,
shifted up to 1 mm, seeded); a 320 x 240 depth frame shows it with a box over the fingertip standing
in for the hand; the tracker (guess: Eq. 2's pose) finds it, and ``plan(..., start_config=q)`` plans from that waypoint with the
object where it was seen (timing included, the grasp map warm as in a running loop). Every solved
re-plan is verified.

Prints and writes (docs/benchmarks/replan.md) the median / p95 of the tracking time, the re-planning
time and their sum, with the build, CPU and date named. Not a test: ``make bench``.

    python benchmarks/replan_bench.py [--poses 10]
"""

from __future__ import annotations

import argparse
import math
import os
import time
from pathlib import Path

import numpy as np

from plan_bench import write_report  # benchmarks/ is the script's directory, hence on sys.path
from slideplan import InputError, PlannerConfig, load_object, load_scene, plan, verify
from slideplan.world.objects import load_outline, sample_pose_on_table
from slideplan.perception.camera import Camera
from slideplan.sim.rendering import Box, PlacedObject, depth_image, noisy_depth, scene_spec
from slideplan.perception.tracking import Tracker
from slideplan.transforms import rotation_2d, row_to_pose
from slideplan.transforms import planar_motion

OBJECTS = ("crescent", "L", "E", "triangle", "irregular")


def main() -> None:
    os.environ["SLIDEPLAN_NO_CACHE"] = "1"  # the map warms up in this process, as in a running loop
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--poses", type=int, default=10, help="seeded poses per object")
    parser.add_argument("--out", type=Path, default=Path("docs/benchmarks/replan.md"))
    args = parser.parse_args()
    scene = load_scene("square")
    table = scene.table
    centre = table.polygon.centroid
    camera = Camera((centre.x - 0.15, centre.y, table.height + 0.75), (centre.x, centre.y, table.height))
    rng = np.random.default_rng(0)
    tracking, planning, total, outcomes = [], [], [], {"solved and verified": 0, "solved, not verified": 0,
                                                       "timeout": 0, "start refused": 0,
                                                       "observed pose refused": 0, "lost": 0}
    for name in OBJECTS:
        outline, _, _ = load_outline(name)
        for index in range(args.poses):
            pose = sample_pose_on_table(outline, table, np.random.default_rng([index, OBJECTS.index(name)]))
            obj = load_object(name, table_height=table.height, pose=pose)
            config = PlannerConfig.for_scene(scene, seed=index, time_limit_s=10.0)
            first = plan(scene, obj, config)
            if not first.solved:
                continue
            k = len(first.trajectory) // 3
            predicted = planar_motion(row_to_pose(first.fingertip_poses[0]), row_to_pose(first.fingertip_poses[k]))
            # The drift: the object turned about the fingertip (torsional slip)
            # and shifted by up to 1 mm.
            tip = row_to_pose(first.fingertip_poses[k])[:3, 3]
            turn, shift = rng.uniform(-math.radians(2), math.radians(2)), rng.uniform(-0.001, 0.001, 2)
            about = (*(tip[:2] - rotation_2d(turn) @ tip[:2] + shift), turn)
            truth = obj.moved(predicted).moved(about)
            hand = [Box((tip[0], tip[1], table.height + 0.06), (0.05, 0.04, 0.03))]
            depth = noisy_depth(depth_image(scene_spec(table, [PlacedObject(name, pose, obj.thickness, truth.outline)], hand, camera),
                                            camera), 0.002, 0.05, rng)
            tracker = Tracker(obj, camera, table_height=table.height)
            tracker.track(depth, predicted)  # warm: SciPy's imports
            started = time.perf_counter()
            seen = tracker.track(depth, predicted)
            tracked = time.perf_counter() - started
            if not seen.ok:
                outcomes["lost"] += 1
                continue
            started = time.perf_counter()
            try:
                again = plan(scene, obj.moved(seen.motion), PlannerConfig.for_scene(scene, seed=index, time_limit_s=10.0),
                             start_config=first.trajectory[k])
            except InputError as error:
                print(f"{name} pose {index}: {error}")
                outcomes["start refused" if error.field == "start_config" else "observed pose refused"] += 1
                continue
            planned = time.perf_counter() - started
            tracking.append(tracked)
            planning.append(planned)
            total.append(tracked + planned)
            if not again.solved:
                outcomes["timeout"] += 1
            else:
                outcomes["solved and verified" if verify(again).ok else "solved, not verified"] += 1

    def row(label: str, values: list[float]) -> str:
        return f"| {label} | {1000 * np.median(values):.1f} | {1000 * np.percentile(values, 95):.1f} | {1000 * max(values):.1f} |"

    lines = [
        "# Re-planning during a slide: track, then plan from the arm's state",
        "",
        f"`python benchmarks/replan_bench.py --poses {args.poses}`: square table, {len(OBJECTS)} objects x "
        f"{args.poses} seeded poses, a third of the way along each plan, "
        "the object drifted from Eq. 2's pose (turned up to 2 degrees about the fingertip, shifted up to 1 mm); "
        "one process, one thread. A start is refused when the fingertip is off the object as seen; an observed "
        "pose when the object would overhang the table there.",
        "",
        "| step | median ms | p95 ms | max ms |",
        "|---|---|---|---|",
        row("track (320 x 240 frame)", tracking),
        row("plan from the state (timing included)", planning),
        row("track + plan", total),
        "",
        "Outcomes: " + ", ".join(f"{count} {label}" for label, count in outcomes.items()) + ".",
    ]
    write_report(lines, args.out)


if __name__ == "__main__":
    main()
