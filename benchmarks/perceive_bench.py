"""Perception benchmark: time of ``slideplan.perceive`` on ~300k-point rendered scene clouds.

Renders scenes with MuJoCo (640 x 512 depth images, 5 % dropouts: about 311k points each;
the four bundled tables, three objects each, a box of clutter), perceives each several times
and prints and writes (docs/benchmarks/perception.md) the median / p90 time with the build, CPU
and date named. The first call of a process also pays for importing scikit-learn and SciPy; it is
reported separately. Not a test: ``make bench``.

    python benchmarks/perceive_bench.py [--repeats 5]
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

import numpy as np

from plan_bench import write_report  # benchmarks/ is the script's directory, hence on sys.path
from slideplan import load_scene
from slideplan.perception.camera import Camera
from slideplan.sim.rendering import Box, place_objects, render_scene

SCENES = {  # table -> objects (name, (x, y, yaw)) and a clutter box on the table
    "square": ([("L", (0.42, -0.08, 0.4)), ("crescent", (0.55, 0.09, -1.0)), ("E", (0.58, -0.10, 2.0))],
               Box((0.665, 0.0, 0.03), (0.04, 0.04, 0.06), 0.5)),
    "round": ([("Y", (0.42, 0.08, 0.3)), ("crescent", (0.52, -0.10, 2.5)), ("triangle", (0.60, 0.08, 1.0))],
              Box((0.62, -0.02, 0.03), (0.04, 0.04, 0.06), 0.2)),
    "long": ([("L", (0.48, -0.25, 1.0)), ("irregular", (0.47, 0.0, 0.0)), ("E", (0.46, 0.25, -0.5))],
             Box((0.40, 0.13, 0.03), (0.04, 0.04, 0.06), 0.0)),
    "triangle": ([("L", (0.42, -0.08, 0.4)), ("circle", (0.42, 0.10, 0.0)), ("Y", (0.56, 0.0, 1.0))],
                 Box((0.36, 0.01, 0.03), (0.04, 0.04, 0.06), 0.3)),
}


def scene_cloud(name: str, seed: int) -> np.ndarray:
    """A ~311k-point cloud of one bundled table with its objects and clutter."""
    table = load_scene(name).table
    objects, box = SCENES[name]
    center = table.polygon.centroid
    camera = Camera((center.x - 0.15, center.y, table.height + 0.8), (center.x, center.y, table.height), 60.0, 640, 512)
    return render_scene(table, place_objects(objects), clutter=[box], camera=camera, noise_at_1m=0.002, seed=seed).points


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=5, help="perceive calls per scene")
    parser.add_argument("--out", type=Path, default=Path(__file__).resolve().parents[1] / "docs" / "benchmarks" / "perception.md")
    args = parser.parse_args()

    clouds = {name: scene_cloud(name, seed) for seed, name in enumerate(SCENES)}
    from slideplan.perception.tabletop import perceive  # imported here so the first call pays for scikit-learn and SciPy

    start = time.perf_counter()
    perceive(clouds["square"])
    first_call = time.perf_counter() - start
    times, rows = [], []
    for name, cloud in clouds.items():
        for repeat in range(args.repeats):
            start = time.perf_counter()
            perception = perceive(cloud, seed=repeat)
            times.append(time.perf_counter() - start)
        rows.append(f"| {name} | {len(cloud)} | {len(perception.objects)} | {len(perception.obstacles)} |")
    median, p90 = np.percentile(times, [50, 90])
    write_report([
        "# Perception benchmark",
        "",
        f"`python benchmarks/perceive_bench.py --repeats {args.repeats}`: "
        f"{len(times)} calls of `slideplan.perceive` on MuJoCo-rendered scene clouds (640 x 512 depth images, "
        "depth noise 2 mm at 1 m, 5 % dropouts).",
        "",
        f"**median {median:.3f} s, p90 {p90:.3f} s** per cloud; the first call of a process "
        f"took {first_call:.2f} s (it imports scikit-learn and SciPy).",
        "",
        "| table | points | thin objects found | clutter boxes found |",
        "|---|---|---|---|",
        *rows,
    ], args.out)


if __name__ == "__main__":
    main()
