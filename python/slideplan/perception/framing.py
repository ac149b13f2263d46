"""Framing: where a camera looking from a given direction must stand to keep a set of points in view.

The 3D view and the execution videos both frame what a user needs to check (the table, the object
at its start and final poses, the hand's path and the grasp) rather than a fixed spot.
"""

from __future__ import annotations

import math

import numpy as np


def view_direction(heading: float, elevation: float) -> np.ndarray:
    """Unit vector from the looked-at point towards the camera.

    Args:
        heading: angle of the camera's horizontal offset from +x (rad).
        elevation: angle above the horizontal (rad).
    """
    return np.array([math.cos(heading) * math.cos(elevation), math.sin(heading) * math.cos(elevation), math.sin(elevation)])


def frame_points(points, direction, fov_y: float, aspect: float, margin: float = 1.1) -> tuple[np.ndarray, np.ndarray]:
    """Where a pinhole camera looking along ``-direction`` stands so that every point is in view.

    The camera looks at the centre of the points' bounding box and backs off along ``direction``
    until each point lies inside the frustum (narrowed by ``margin``) both horizontally and vertically.

    Args:
        points: (N, 3) world points to keep in view.
        direction: from the looked-at point towards the camera (need not be unit; not vertical).
        fov_y: vertical field of view (rad).
        aspect: width / height of the image.
        margin: > 1 leaves a border around the points.

    Returns:
        ``(look_at, position)``, each (3,).
    """
    points = np.asarray(points, dtype=float).reshape(-1, 3)
    back = np.asarray(direction, dtype=float) / np.linalg.norm(direction)
    right = np.cross(back, (0.0, 0.0, 1.0))  # world z stays up in the image
    right /= np.linalg.norm(right)
    up = np.cross(right, back)
    tan_y = math.tan(fov_y / 2) / margin
    tan_x = tan_y * aspect

    def distance_from(look_at: np.ndarray) -> float:
        # A point at depth D - offset.back is in view when |offset.right| <= depth tan_x and |offset.up| <= depth tan_y.
        offsets = points - look_at
        return max(float((offsets @ back + np.maximum(np.abs(offsets @ right) / tan_x, np.abs(offsets @ up) / tan_y)).max()), 1e-3)

    look_at = (points.min(axis=0) + points.max(axis=0)) / 2
    for _ in range(3):  # re-aim at the middle of what the image shows: near points look larger
        distance = distance_from(look_at)
        offsets = points - look_at
        depth = distance - offsets @ back
        across, along = (offsets @ right) / depth, (offsets @ up) / depth
        look_at = look_at + distance * ((across.max() + across.min()) / 2 * right + (along.max() + along.min()) / 2 * up)
    return look_at, look_at + distance_from(look_at) * back
