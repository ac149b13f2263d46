"""Top-down pictures of plans (matplotlib, no display needed).

Figures are built with :class:`matplotlib.figure.Figure` directly rather than pyplot, so
drawing never touches the global backend or leaks figures in long experiment runs.
"""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np
import shapely
from matplotlib.figure import Figure
from matplotlib.patches import Polygon as PolygonPatch

from .._files import replacing
from ..world.geometry import SupportSurface
from ..world.scenes import obstacle_footprint
from ..transforms import move_planar, row_to_pose
from ..world.geometry import overhang
from ..transforms import planar_motion

SLIDE_SPACING_M = 0.03  # the object is drawn every this much fingertip travel

if TYPE_CHECKING:
    from ..plan.result import PlanResult

_TABLE_STYLE = {"facecolor": "0.9", "edgecolor": "0.35", "linewidth": 1.2, "label": "table"}


def _new_axes():
    figure = Figure(figsize=(9, 6), layout="constrained")
    axes = figure.add_subplot()
    axes.set_aspect("equal")
    axes.set_xlabel("x (m)")
    axes.set_ylabel("y (m)")
    axes.grid(True, linewidth=0.3)
    return figure, axes


def _draw_table(axes, vertices: np.ndarray) -> None:
    axes.add_patch(PolygonPatch(vertices, closed=True, **_TABLE_STYLE))


def _draw_obstacles(axes, entries) -> None:
    """Obstacles' footprints (plan JSON entries), in brown."""
    for index, entry in enumerate(entries):
        footprint, _ = obstacle_footprint(entry)
        axes.add_patch(PolygonPatch(np.asarray(footprint.exterior.coords), color="tab:brown", alpha=0.6,
                                    label="obstacles" if index == 0 else None))


def save_figure(figure: Figure, path: str | Path) -> Path:
    """Save as SVG if the suffix is ``.svg``, else PNG (the suffix ``.png`` is added if missing)."""
    path = Path(path)
    if path.suffix.lower() not in (".png", ".svg"):
        path = path.with_name(path.name + ".png")
    path.parent.mkdir(parents=True, exist_ok=True)
    with replacing(path) as temporary:
        figure.savefig(temporary, dpi=150)
    return path


def slide_motions(result: PlanResult, spacing_m: float = SLIDE_SPACING_M) -> list[tuple[int, tuple[float, float, float]]]:
    """The object's planar motion from its start (Eq. 2 on SE(2)) at the waypoints where the fingertip
    has travelled each further ``spacing_m``, start and goal excluded: ``[(waypoint, (x, y, yaw))]``."""
    tips = np.asarray(result.fingertip_poses, dtype=float)
    if len(tips) < 3:
        return []
    travel = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(tips[:, :3], axis=0), axis=1))])
    marks = np.arange(spacing_m, travel[-1] - 0.5 * spacing_m, spacing_m)
    first = row_to_pose(tips[0])
    waypoints = sorted(set(int(index) for index in np.searchsorted(travel, marks)) - {0, len(tips) - 1})
    return [(index, planar_motion(first, row_to_pose(tips[index]))) for index in waypoints]


def draw_plan(result: PlanResult, path: str | Path, label: str = "") -> Path:
    """Draw a plan from above: table, obstacles, object at start, along the slide (faded, every
    :data:`SLIDE_SPACING_M` of fingertip travel) and at its final pose, fingertip path, grasp.

    The final object points that overhang the table are highlighted, the grasp pose is an
    arrow along its approach axis (z of the grasp frame), and the title gives the status,
    the planning time and the overhang. A plan that is not solved shows the table and the
    object at its start only.

    Args:
        result: the plan.
        path: output file, ``.png`` or ``.svg``.
        label: a first title line naming what was planned (e.g. ``"crescent on square"``); none if empty.

    Returns:
        The path written.

    Raises:
        OSError: the file cannot be written.
    """
    figure, axes = _new_axes()
    vertices = np.asarray(result.table["polygon"], dtype=float)
    _draw_table(axes, vertices)
    _draw_obstacles(axes, result.obstacles)
    start_xy = np.asarray(result.object["points"])[:, :2]
    axes.scatter(start_xy[:, 0], start_xy[:, 1], s=2, color="0.65", label="object at start")
    title = f"{result.planner}: {result.status} in {result.planning_time_s:.2f} s"
    if len(result.trajectory):
        table = SupportSurface.from_vertices(vertices, result.table["height"])
        # The cloud's outline (its points grown by their mean spacing: an L stays an L), moved along the slide.
        cloud = shapely.MultiPoint(start_xy)
        spacing = float(np.sqrt(cloud.convex_hull.area / len(start_xy)))
        outline = cloud.buffer(spacing).buffer(-0.5 * spacing)
        rings = [np.asarray(part.exterior.coords) for part in getattr(outline, "geoms", [outline])]
        for number, (_, motion) in enumerate(slide_motions(result)):
            for ring_number, ring in enumerate(rings):
                along = move_planar(ring, motion)
                first = number == 0 and ring_number == 0
                axes.plot(along[:, 0], along[:, 1], color="tab:blue", linewidth=0.8, alpha=0.35,
                          label=f"object every {100 * SLIDE_SPACING_M:.0f} cm of the slide" if first else None)
        final_xy = result.moved_object_xy()
        _, outside, _ = overhang(table, final_xy)
        axes.scatter(final_xy[~outside, 0], final_xy[~outside, 1], s=2, color="tab:blue", label="object at goal")
        axes.scatter(final_xy[outside, 0], final_xy[outside, 1], s=3, color="tab:red", label="overhang")
        tips = np.asarray(result.fingertip_poses)[:, :2]
        axes.plot(tips[:, 0], tips[:, 1], color="black", linewidth=1.5, label="fingertip path")
        axes.plot(*tips[0], marker="o", color="tab:green", markersize=8, linestyle="none", label="fingertip start")
        axes.plot(*tips[-1], marker="X", color="tab:purple", markersize=9, linestyle="none", label="fingertip goal")
        if len(result.grasp["pose"]):
            grasp = row_to_pose(result.grasp["pose"])
            approach = grasp[:2, 2]  # z of the grasp frame, seen from above
            if np.linalg.norm(approach) > 1e-6:
                tail = grasp[:2, 3] - 0.06 * approach / np.linalg.norm(approach)
                axes.annotate(
                    "",
                    xy=grasp[:2, 3],
                    xytext=tail,
                    arrowprops={"arrowstyle": "-|>", "color": "tab:orange", "linewidth": 2},
                )
                axes.update_datalim([tail])  # annotations do not widen the view: the arrow ran into the title
            axes.plot(*grasp[:2, 3], marker="s", color="tab:orange", linestyle="none", label="grasp (approach arrow)")
        title += f", overhang {100 * result.overhang_m:.1f} cm"
    axes.set_title(f"{label}\n{title}" if label else title)
    axes.autoscale_view()
    axes.legend(loc="upper left", bbox_to_anchor=(1.02, 1.0), fontsize="small")
    return save_figure(figure, path)



def draw_scene_check(scene, check, path: str | Path) -> Path:
    """Draw what ``slideplan check-scene`` found, from above: the table, where the fingertip reaches its
    top (the lattice points, reached or not), each edge's 1 cm stretches by what they admit (a side grasp
    with a clear pre-grasp, a grasp whose approach is blocked, none), and the robot's base.

    Args:
        scene: the checked scene.
        check: :class:`slideplan.checks.scene.SceneCheck`.
        path: a .png or .svg file.
    """
    figure, axes = _new_axes()
    _draw_table(axes, np.asarray(scene.table.vertices, dtype=float))
    _draw_obstacles(axes, [obstacle.to_dict() for obstacle in scene.obstacles])
    points, reached = check.reach_points, check.reached
    axes.scatter(points[reached, 0], points[reached, 1], marker="o", color="tab:green", label="fingertip reaches")
    axes.scatter(points[~reached, 0], points[~reached, 1], marker="x", color="tab:red", label="fingertip does not reach")
    styles = {"clear": ("tab:green", "side grasp, pre-grasp clear"), "blocked": ("tab:orange", "side grasp, blocked"),
              "none": ("0.6", "no side grasp")}
    for status, (color, label) in styles.items():
        at = np.array([(x, y) for x, y, kind in check.stretches if kind == status]).reshape(-1, 2)
        if len(at):
            axes.scatter(at[:, 0], at[:, 1], marker="s", s=12, color=color, label=label)
    base = np.asarray(scene.base_pose, dtype=float)[:2]
    axes.plot(*base, marker="^", color="black", markersize=9, linestyle="none", label="robot base")
    axes.set_title(f"check-scene: {Path(scene.source).name if scene.source else 'scene'} "
                   f"({'can plan' if check.ok else 'cannot plan'})")
    axes.autoscale_view()
    axes.legend(loc="upper left", bbox_to_anchor=(1.02, 1.0), fontsize="small")
    return save_figure(figure, path)
