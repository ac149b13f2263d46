"""Where the depth camera really is, found from what it sees of the robot itself: the arm's kinematics
put the hand and the fingertip where they are, so the robot as the camera is believed to see it (rendered
from the believed pose) and the robot as it does see it differ by the camera's mounting error. Their
points, both read through the believed camera, are registered by trimmed point-to-plane ICP (Chen &
Medioni 1992: the robot's faces are mostly flat, where point-to-point ICP slides slowly); the transform
that carries the seen points onto the expected ones carries the believed camera to where it is
(:class:`CameraFix`).

No physics here: the expected view comes from whoever can render the robot (in simulation,
:meth:`slideplan.sim.episode.Episode.robot_view`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from .camera import Camera, back_project, pixel_points

ABOVE_TABLE_M = 0.02  # robot points this far above the table: not the table, nor a thin object under the finger
SEARCH_PX = 12  # seen pixels this far from the expected robot's may be the robot (about 2 cm at 0.75 m)
ITERATIONS = 40  # ICP steps
TRIM = 3.0  # a pair further apart than this many times the median pair distance is left out ...
TRIM_FLOOR_M = 0.004  # ... but never one nearer than this
MIN_POINTS = 500  # fewer robot points than this on either side is no evidence of where the camera is


@dataclass(frozen=True)
class CameraFix:
    """A camera pose error found from the robot.

    Attributes:
        transform: (4, 4) world-to-world: a point read through the believed camera, moved by it, is where
            the point is. The camera is where ``transform`` carries the believed camera
            (:meth:`corrected`).
        points: seen robot points registered.
        rmse_m: their root mean square distance to the expected robot's surface after the fit.
    """

    transform: np.ndarray
    points: int
    rmse_m: float

    def corrected(self, camera: Camera) -> Camera:
        """The believed ``camera`` moved to where the fix puts it."""
        return Camera.from_optical_pose(self.transform @ camera.optical_pose(), width=camera.width,
                                        height=camera.height, fovy_deg=camera.fovy_deg)

    def plane(self, plane) -> tuple[float, float, float]:
        """A plane ``z = a x + b y + c`` read through the believed camera, as the corrected camera reads it."""
        a, b, c = (float(value) for value in plane)
        corners = np.array([[0.0, 0.0], [1.0, 0.0], [0.0, 1.0]])
        points = np.column_stack([corners, corners @ (a, b) + c]) @ self.transform[:3, :3].T + self.transform[:3, 3]
        solved = np.linalg.solve(np.column_stack([points[:, :2], np.ones(3)]), points[:, 2])
        return float(solved[0]), float(solved[1]), float(solved[2])


def pose_offset(camera: Camera, other: Camera) -> dict[str, float]:
    """Where ``other`` lies from ``camera``, as the hard setting draws a mounting error
    (:func:`slideplan.sim.conditions.camera_as_mounted`): its optical centre moved by ``dx_m, dy_m, dz_m``
    and its frame turned by ``rx_deg, ry_deg, rz_deg`` (extrinsic x-y-z Euler angles about the world axes)."""
    from scipy.spatial.transform import Rotation

    first, second = camera.optical_pose(), other.optical_pose()
    moved = second[:3, 3] - first[:3, 3]
    turn = Rotation.from_matrix(second[:3, :3] @ first[:3, :3].T).as_euler("xyz", degrees=True)
    return {**{f"d{axis}_m": float(value) for axis, value in zip("xyz", moved)},
            **{f"r{axis}_deg": float(value) for axis, value in zip("xyz", turn)}}


def calibrate(seen: np.ndarray, expected: np.ndarray, camera: Camera, table_height: float) -> CameraFix | None:
    """The believed ``camera``'s pose error, from one frame with the robot in view.

    Args:
        seen: (height, width) depth frame of the camera (m, NaN for no return).
        expected: the robot alone as the camera would see it from where it is believed to be, NaN elsewhere.
        camera: where the camera is believed to be (the frames are read through it).
        table_height: z of the table top (m): the points near it are the table and the object, not the robot.

    Returns:
        The fix, or None when either image shows fewer than ``MIN_POINTS`` points of the robot.
    """
    from scipy.ndimage import binary_dilation
    from scipy.spatial import cKDTree

    near = binary_dilation(np.isfinite(expected), iterations=SEARCH_PX)
    observed = pixel_points(np.where(near, seen, np.nan), camera).reshape(-1, 3)
    observed = observed[np.isfinite(observed).all(axis=1)]
    observed = observed[observed[:, 2] > table_height + ABOVE_TABLE_M]
    model, normals = _surface(pixel_points(expected, camera))
    robot = model[:, 2] > table_height + ABOVE_TABLE_M
    model, normals = model[robot], normals[robot]
    if min(len(observed), len(model)) < MIN_POINTS:
        return None
    tree = cKDTree(model)

    def pairs(transform: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The seen points moved by ``transform`` and their nearest model points, the far pairs trimmed."""
        moved = observed @ transform[:3, :3].T + transform[:3, 3]
        distance, index = tree.query(moved)
        kept = distance <= max(TRIM * float(np.median(distance)), TRIM_FLOOR_M)
        return moved[kept], index[kept]

    transform = np.eye(4)
    for _ in range(ITERATIONS):
        moved, index = pairs(transform)
        transform = _step(moved, model[index], normals[index]) @ transform
    moved, index = pairs(transform)
    along = np.einsum("ij,ij->i", moved - model[index], normals[index])
    return CameraFix(transform, len(moved), math.sqrt(float(np.mean(along ** 2))))


def _surface(grid: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The points of an organized cloud ((rows, columns, 3), NaN for none) that have all four neighbours,
    and their unit normals (from the neighbours' differences)."""
    across = grid[1:-1, 2:] - grid[1:-1, :-2]
    down = grid[2:, 1:-1] - grid[:-2, 1:-1]
    normals = np.cross(across, down).reshape(-1, 3)
    points = grid[1:-1, 1:-1].reshape(-1, 3)
    with np.errstate(invalid="ignore"):
        normals = normals / np.linalg.norm(normals, axis=1, keepdims=True)
    valid = np.isfinite(points).all(axis=1) & np.isfinite(normals).all(axis=1)
    return points[valid], normals[valid]


def _step(source: np.ndarray, target: np.ndarray, normals: np.ndarray) -> np.ndarray:
    """One point-to-plane ICP step (Chen & Medioni 1992, linearized in the rotation): the rigid (4, 4)
    transform that best moves ``source`` onto the planes through ``target`` with ``normals`` (paired rows)."""
    from scipy.spatial.transform import Rotation

    rows = np.hstack([np.cross(source, normals), normals])
    residual = np.einsum("ij,ij->i", target - source, normals)
    solution = np.linalg.lstsq(rows, residual, rcond=None)[0]
    transform = np.eye(4)
    transform[:3, :3] = Rotation.from_rotvec(solution[:3]).as_matrix()
    transform[:3, 3] = solution[3:]
    return transform
