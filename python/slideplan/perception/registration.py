"""A known outline registered to a perceived object's points: where the object the camera saw lies, as
the closed loop starts from it (:class:`slideplan.sim.closed_loop.Start`) and benchmarks/perceive_accuracy.py
measures it. Needs the ``perception`` extra (SciPy)."""

from __future__ import annotations

import math

import numpy as np
from shapely.geometry import Polygon

from ..world.objects import ThinObject
from ..transforms import rotation_2d


def register_outline(points_xy, outline: Polygon, *, resolution: float = 0.002) -> tuple[tuple[float, float, float], float]:
    """The pose of a known outline that fits a perceived object's points best.

    Minimises the symmetric chamfer distance between the points and a sample of the posed
    outline: over all yaws in 2 deg steps with the outline's origin (its area centroid, as in
    ``data/objects``) at the points' centroid, then over (x, y, yaw) together (Nelder-Mead).

    Args:
        points_xy: (N, 2) or (N, 3) the perceived object's points (e.g. ``PerceivedObject.points``).
        outline: the outline in the object frame (origin at its area centroid).
        resolution: sample spacing of the outline (m).

    Returns:
        ((x, y, yaw), rms chamfer distance in m at that pose).
    """
    from scipy.optimize import minimize  # the perception extra's SciPy
    from scipy.spatial import cKDTree

    points_xy = np.asarray(points_xy, dtype=float)[:, :2]
    centroid = points_xy.mean(axis=0)
    sample_xy = ThinObject.from_outline(outline, thickness=1.0, table_height=0.0, pose=(0, 0, 0), resolution=resolution).points[:, :2]
    # Distances are rigid-invariant: the points are brought into the outline's frame instead of the sample
    # being posed and a tree built for it at every evaluation (both trees are built once).
    perceived_tree, sample_tree = cKDTree(points_xy), cKDTree(sample_xy)

    def cost(pose) -> float:
        x, y, yaw = pose
        rotation = rotation_2d(yaw)
        to_points = perceived_tree.query(sample_xy @ rotation.T + (x, y))[0]
        to_outline = sample_tree.query((points_xy - (x, y)) @ rotation)[0]
        return float(np.mean(to_points**2) + np.mean(to_outline**2))

    coarse = [(*centroid, yaw) for yaw in np.radians(np.arange(-180.0, 180.0, 2.0))]
    start = coarse[int(np.argmin([cost(pose) for pose in coarse]))]
    # Simplex steps: a few mm and about a degree, the size of the coarse search's errors.
    simplex = np.array([start, start + np.array([0.003, 0, 0]), start + np.array([0, 0.003, 0]), start + np.array([0, 0, 0.03])])
    best = minimize(cost, start, method="Nelder-Mead", options={"initial_simplex": simplex, "xatol": 1e-5, "fatol": 1e-12})
    x, y, yaw = best.x
    return (float(x), float(y), math.atan2(math.sin(yaw), math.cos(yaw))), math.sqrt(0.5 * best.fun)


def seen_target(objects: list, *, near=None, index: int = 0, outline: Polygon | None = None):
    """The object a plan is made for among those perceived, and where its known outline lies: one path for the
    simulated loop and the ROS node.

    Args:
        objects: the perceived thin objects (``Perception.objects``, largest first).
        near: (x, y) where the object is expected: the nearest one is the target (the others are clutter);
            None: ``objects[index]``.
        index: the target, largest first, when ``near`` is None.
        outline: the object's known outline (object frame): registered to the target's points; None: the
            plan is made for the points themselves (an object the catalogue does not hold).

    Returns:
        (the perceived object, its outline's pose (x, y, yaw) or None without ``outline``).
    """
    if near is not None:
        target = min(objects, key=lambda seen: float(np.hypot(*(np.asarray(seen.centroid_xy) - np.asarray(near)[:2]))))
    else:
        target = objects[index]
    return target, None if outline is None else register_outline(target.points, outline)[0]
