"""Perception accuracy against depth noise, and the picture of docs/perception.md.

For each noise level, renders random scenes with MuJoCo (one of the four bundled tables,
three objects without rotational symmetry at random non-touching poses, a box of clutter;
320 x 240 depth images, 5 % dropouts), perceives them and measures against the ground truth:
table height error, outline Hausdorff distance, and per object the centroid and yaw error
of the known outline registered to the perceived points (slideplan.perception.registration.register_outline)
and the thickness error. Prints a Markdown table (median and worst case per level) under a line naming
the build, the CPU and the date, and draws
docs/figures/perception.png (scene cloud, what was found, a plan from it).

    python benchmarks/perceive_accuracy.py [--scenes 8] [--figure docs/figures/perception.png]
"""

from __future__ import annotations

import argparse
import math
from pathlib import Path

import numpy as np
import shapely
from matplotlib.figure import Figure
from matplotlib.patches import Polygon as PolygonPatch

from plan_bench import provenance_line  # benchmarks/ is the script's directory, hence on sys.path
from slideplan import InputError, PlannerConfig, load_scene, plan
from slideplan.world.objects import ThinObject, load_outline, place_outline, sample_pose_on_table
from slideplan.perception.tabletop import perceive
from slideplan.perception.registration import register_outline
from slideplan.sim.rendering import Box, PlacedObject, render_scene


NOISE_AT_1M = (0.0, 0.001, 0.002, 0.004, 0.006)  # m; the table is ~0.76 m from the camera: 0.58 x these
TABLES = ("square", "round", "triangle", "long")
OBJECTS = ("L", "E", "Y", "crescent", "irregular")
GAP_M = 0.015  # objects and clutter at least this far apart (touching objects make one cluster)
CLUTTER_SIZE = (0.04, 0.04, 0.06)


def random_scene(rng: np.random.Generator):
    """A table, three placed objects and a box, none touching, all on the table."""
    table = load_scene(TABLES[rng.integers(len(TABLES))]).table
    while True:
        placed = []
        for name in rng.choice(OBJECTS, size=3, replace=False):
            outline, thickness, label = load_outline(str(name))
            pose = sample_pose_on_table(outline, table, rng, margin=0.01)
            placed.append(PlacedObject(label, pose, thickness, place_outline(outline, pose)))
        box_pose = sample_pose_on_table(shapely.box(-0.02, -0.02, 0.02, 0.02), table, rng, margin=0.01)
        footprints = [item.outline for item in placed] + [place_outline(shapely.box(-0.02, -0.02, 0.02, 0.02), box_pose)]
        if all(first.distance(second) > GAP_M for index, first in enumerate(footprints) for second in footprints[index + 1:]):
            box = Box((box_pose[0], box_pose[1], table.height + 0.5 * CLUTTER_SIZE[2]), CLUTTER_SIZE, box_pose[2])
            return table, placed, box


def errors(truth, perception) -> dict[str, list[float]]:
    """Errors of one perceived scene against its truth; a missed object counts in 'missed'."""
    result = {
        "height": [abs(perception.table.height - truth.table.height)],
        "outline": [perception.table.polygon.hausdorff_distance(truth.table.polygon)],
        "centroid": [], "yaw": [], "thickness": [], "missed": [0.0],
    }
    for placed in truth.objects:
        center = np.array(placed.outline.centroid.coords[0])
        found = min(perception.objects, key=lambda item: np.linalg.norm(item.centroid_xy - center), default=None)
        if found is None or np.linalg.norm(found.centroid_xy - center) > 0.02:
            result["missed"][0] += 1
            continue
        (x, y, yaw), _ = register_outline(found.points, load_outline(placed.name)[0])
        result["centroid"].append(math.hypot(x - placed.pose[0], y - placed.pose[1]))
        result["yaw"].append(abs(math.degrees(math.remainder(yaw - placed.pose[2], 2 * math.pi))))
        result["thickness"].append(abs(found.thickness - placed.thickness))
    result["missed"][0] += max(0, len(perception.objects) - len(truth.objects))  # spurious ones count too
    return result


def study(scenes: int) -> str:
    """The Markdown table of errors per noise level."""
    lines = [
        "| depth noise at 1 m (at the table) | table height | outline (Hausdorff) | centroid | yaw | thickness | objects missed or extra | errors raised |",
        "|---|---|---|---|---|---|---|---|",
    ]
    for level, noise in enumerate(NOISE_AT_1M):
        rng = np.random.default_rng(level)
        collected = {key: [] for key in ("height", "outline", "centroid", "yaw", "thickness", "missed")}
        raised = 0
        for index in range(scenes):
            table, placed, box = random_scene(rng)
            truth = render_scene(table, placed, clutter=[box], noise_at_1m=noise, seed=index)
            try:
                found = errors(truth, perceive(truth.points))
            except InputError:
                raised += 1
                continue
            for key, values in found.items():
                collected[key] += values

        def cell(key, scale, unit, digits):
            values = np.asarray(collected[key]) * scale
            return f"{np.median(values):.{digits}f} / {values.max():.{digits}f} {unit}" if len(values) else "n/a"

        lines.append(
            f"| {1000 * noise:.0f} mm ({580 * noise:.1f} mm) | {cell('height', 1000, 'mm', 2)} | {cell('outline', 1000, 'mm', 1)} | "
            f"{cell('centroid', 1000, 'mm', 1)} | {cell('yaw', 1, 'deg', 2)} | {cell('thickness', 1000, 'mm', 2)} | "
            f"{int(sum(collected['missed']))} of {3 * scenes} | {raised} of {scenes} |"
        )
    return "\n".join(lines)


def figure(path: Path) -> None:
    """Three panels: the scene cloud, what perceive found (truth dashed), and a plan for object 0."""
    table, placed, box = load_scene("square").table, [], Box((0.665, 0.0, 0.03), CLUTTER_SIZE, 0.5)
    for name, pose in (("L", (0.42, -0.08, 0.4)), ("crescent", (0.55, 0.09, -1.0)), ("E", (0.58, -0.10, 2.0))):
        outline, thickness, _ = load_outline(name)
        placed.append(PlacedObject(name, pose, thickness, place_outline(outline, pose)))
    truth = render_scene(table, placed, clutter=[box], noise_at_1m=0.002, seed=1)
    perception = perceive(truth.points)
    target = perception.objects[0]
    obj = ThinObject.from_points(target.points, table_height=perception.table.height, name="object 0")
    result = plan(perception.scene(), obj, PlannerConfig(seed=0, time_limit_s=30))

    fig = Figure(figsize=(15, 5), layout="constrained")
    panels = fig.subplots(1, 3)
    points = truth.points[::2]  # every other point: the picture looks the same, the file is half the size
    # Colour scale from just below the table to above the objects: floor dark, clutter saturated.
    scatter = panels[0].scatter(points[:, 0], points[:, 1], c=points[:, 2], s=0.2, cmap="viridis", vmin=-0.003, vmax=0.008)
    fig.colorbar(scatter, ax=panels[0], label="z (m), clipped", shrink=0.8)
    panels[0].set_title(f"rendered scene cloud ({len(truth.points)} points)")
    for axes in panels[1:]:
        axes.add_patch(PolygonPatch(perception.table.vertices, closed=True, facecolor="0.92", edgecolor="0.3", label="perceived table"))
    panels[1].plot(*np.vstack([table.vertices, table.vertices[:1]]).T, "k--", linewidth=0.8, label="true outlines")
    for item in placed:
        panels[1].plot(*np.asarray(item.outline.exterior.coords).T, "k--", linewidth=0.8)
    for index, found in enumerate(perception.objects):
        panels[1].scatter(*found.points[:, :2].T, s=0.5, label=f"object {index}: {1000 * found.thickness:.1f} mm")
    for obstacle in perception.obstacles:
        corners = shapely.affinity.rotate(shapely.box(*(-0.5 * obstacle.size[:2]), *(0.5 * obstacle.size[:2])), obstacle.yaw, use_radians=True)
        corners = shapely.affinity.translate(corners, *obstacle.center[:2])
        panels[1].add_patch(PolygonPatch(np.asarray(corners.exterior.coords), closed=True, facecolor="tab:red", alpha=0.5,
                                         label=f"clutter box, {100 * obstacle.size[2]:.1f} cm tall"))
    panels[1].set_title("perceived: table, thin objects, clutter")
    panels[2].scatter(*target.points[:, :2].T, s=0.5, color="0.6", label="object 0 at start")
    if result.solved:
        panels[2].scatter(*result.moved_object_xy().T, s=0.5, color="tab:blue", label="object 0 at goal")
        panels[2].plot(*result.fingertip_poses[:, :2].T, "k-", linewidth=1, label="fingertip path")
    panels[2].set_title(f"plan for object 0: {result.status}, overhang {100 * result.overhang_m:.1f} cm")
    limits = [((0.0, 1.1), (-0.5, 0.5)), ((0.27, 0.73), (-0.23, 0.23)), ((0.27, 0.73), (-0.23, 0.23))]
    for axes, (x_limits, y_limits) in zip(panels, limits):
        axes.set_aspect("equal")
        axes.set_xlabel("x (m)")
        axes.set_ylabel("y (m)")
        axes.set_xlim(*x_limits)
        axes.set_ylim(*y_limits)
    for axes in panels[1:]:
        axes.legend(loc="lower left", fontsize=7, markerscale=8)
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=100)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--scenes", type=int, default=8, help="random scenes per noise level")
    parser.add_argument("--figure", type=Path, default=Path(__file__).resolve().parents[1] / "docs" / "figures" / "perception.png")
    args = parser.parse_args()
    figure(args.figure)
    print(provenance_line() + "\n\n" + study(args.scenes))


if __name__ == "__main__":
    main()
