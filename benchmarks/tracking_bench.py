"""Tracking benchmark (issue 24 item 1): pose error and time per frame of ``slideplan.tracking``.

Rendered 320 x 240 depth frames of the square table (MuJoCo, 2 mm depth noise at 1 m, 5 % dropouts,
the camera 0.75 m above the table) with a box 6 cm above the object standing in for the hand and
finger (it hides about a third of the object). Two regimes, each object at seeded random poses:

- ``step``: the object moved by up to 5 mm and 2 degrees since the tracker last saw it (a frame every
  0.1 s of a slide at the fingertip speed cap);
- ``disturbed``: up to 3 cm and 10 degrees (the closed loop's ``--disturb`` test).

Prints and writes (docs/benchmarks/tracking.md) the median and p95 of the centre-of-mass error, the
turn error and the time of ``Tracker.track`` (one core; the rendering is not timed), CPU named.
Not a test: ``make bench``.

    python benchmarks/tracking_bench.py [--poses 20]
"""

from __future__ import annotations

import argparse
import datetime
import math
import time
from pathlib import Path

import numpy as np

from plan_bench import cpu_name, write_report  # benchmarks/ is the script's directory, hence on sys.path
from slideplan import load_object, load_scene
from slideplan.rendering import Box, Camera, depth_image, noisy_depth, place_objects, scene_mjcf
from slideplan.tracking import Tracker
from slideplan.transforms import wrap_angle

OBJECTS = ("crescent", "L", "E", "triangle", "irregular")
REGIMES = {"step": (0.005, math.radians(2.0)), "disturbed": (0.03, math.radians(10.0))}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--poses", type=int, default=20, help="seeded poses per object and regime")
    parser.add_argument("--out", type=Path, default=Path("docs/benchmarks/tracking.md"))
    args = parser.parse_args()
    table = load_scene("square").table
    centre = table.polygon.centroid
    camera = Camera((centre.x - 0.15, centre.y, table.height + 0.75), (centre.x, centre.y, table.height))
    rows = []
    for regime, (reach, turn) in REGIMES.items():
        rng = np.random.default_rng(list(REGIMES).index(regime))
        errors, times, lost = [], [], 0
        for name in OBJECTS:
            for _ in range(args.poses):
                last = (rng.uniform(0.5, 0.6), rng.uniform(-0.1, 0.1), rng.uniform(-math.pi, math.pi))
                step = (*rng.uniform(-reach, reach, 2), rng.uniform(-turn, turn))
                now = tuple(a + b for a, b in zip(last, step))
                hand = [Box((now[0] + 0.02, now[1], table.height + 0.06), (0.05, 0.04, 0.03))]
                depth = noisy_depth(depth_image(scene_mjcf(table, place_objects([(name, now)]), hand, camera), camera),
                                    0.002, 0.05, rng)
                tracker = Tracker(load_object(name, table_height=table.height, pose=last), camera, table_height=table.height)
                tracker.track(depth)  # warm: the first call imports SciPy's modules
                started = time.perf_counter()
                estimate = tracker.track(depth)
                times.append(time.perf_counter() - started)
                if not estimate.ok:
                    lost += 1
                    continue
                truth = load_object(name, table_height=table.height, pose=now)
                moved = tracker.obj.moved(estimate.motion)
                errors.append((np.linalg.norm(moved.centroid_xy - truth.centroid_xy), abs(wrap_angle(estimate.motion[2] - step[2]))))
        errors, times = np.array(errors), np.array(times)
        rows.append(f"| {regime} | {len(times)} | {lost} | {1000 * np.median(errors[:, 0]):.2f} | {1000 * np.percentile(errors[:, 0], 95):.2f} "
                    f"| {np.degrees(np.median(errors[:, 1])):.2f} | {np.degrees(np.percentile(errors[:, 1], 95)):.2f} "
                    f"| {1000 * np.median(times):.1f} | {1000 * np.percentile(times, 95):.1f} |")
    lines = [
        "# Tracking the object in depth frames",
        "",
        f"`python benchmarks/tracking_bench.py --poses {args.poses}` on {cpu_name()}, {datetime.date.today()}: "
        f"{len(OBJECTS)} objects ({', '.join(OBJECTS)}) x {args.poses} seeded poses per regime, 320 x 240 frames, "
        "a box 6 cm above each object hiding about a third of it. Errors: the centre of mass (mm) and the turn "
        "(deg) against the truth; time: one `Tracker.track` call (rendering not included).",
        "",
        "| regime | frames | lost | CoM median | CoM p95 | turn median | turn p95 | ms median | ms p95 |",
        "|---|---|---|---|---|---|---|---|---|",
        *rows,
    ]
    write_report(lines, args.out)


if __name__ == "__main__":
    main()
