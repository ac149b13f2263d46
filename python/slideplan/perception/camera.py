"""A pinhole depth camera: where it stands and looks, which pixel sees which world point, and a depth
image back-projected into a world-frame cloud. The real camera of the ROS node and the simulated one of
:mod:`slideplan.sim.rendering` alike; the tracker (:mod:`slideplan.perception.tracking`) fits in its pixels."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class Camera:
    """A pinhole depth camera looking at a point from above.

    Attributes:
        position: (x, y, z) of the optical centre (m).
        target: the point on the optical axis it looks at (m).
        fovy_deg: vertical field of view (deg).
        width, height: image size (pixels).
        up: the world direction that points up in the image (any roll about the optical axis), or
            None: world z, or world x for a camera looking straight down.
    """

    position: tuple[float, float, float]
    target: tuple[float, float, float]
    fovy_deg: float = 45.0
    width: int = 320
    height: int = 240
    up: tuple[float, float, float] | None = None

    @classmethod
    def from_optical_pose(cls, pose, *, width: int, height: int, fovy_deg: float) -> Camera:
        """The camera whose optical frame (x right, y down, z forward: the frame a depth camera's
        organized cloud is in) has this world pose.

        Args:
            pose: (4, 4) world pose of the optical frame.
            width, height: image size (pixels).
            fovy_deg: vertical field of view (deg).
        """
        pose = np.asarray(pose, dtype=float)
        position = pose[:3, 3]
        return cls(tuple(position), tuple(position + pose[:3, 2]), fovy_deg, width, height, tuple(-pose[:3, 1]))

    def optical_pose(self) -> np.ndarray:
        """(4, 4) world pose of the optical frame (x right, y down, z forward)."""
        right, up, back = self.axes().T
        pose = np.eye(4)
        pose[:3, :3] = np.column_stack([right, -up, -back])
        pose[:3, 3] = self.position
        return pose

    @property
    def focal_px(self) -> float:
        """Focal length in pixels (square pixels)."""
        return 0.5 * self.height / math.tan(math.radians(self.fovy_deg) / 2)

    def pixels(self, points) -> np.ndarray:
        """Where world points appear in the image: (N, 2) (row, column), fractional, pixel centres at
        +0.5 (the inverse of :func:`pixel_points`)."""
        local = (np.asarray(points, dtype=float) - np.asarray(self.position)) @ self.axes()
        depth = -local[:, 2]
        return np.column_stack([0.5 * self.height - local[:, 1] / depth * self.focal_px,
                                0.5 * self.width + local[:, 0] / depth * self.focal_px]) - 0.5

    def axes(self) -> np.ndarray:
        """Camera frame axes as the columns of a 3x3 matrix: image right, image up, backwards.

        MuJoCo's convention: the camera looks along its -z axis.
        """
        forward = np.subtract(self.target, self.position)
        forward = forward / np.linalg.norm(forward)
        if self.up is not None:
            up_hint = np.asarray(self.up, dtype=float)
        else:
            up_hint = np.array([1.0, 0.0, 0.0]) if abs(forward[2]) > 0.999 else np.array([0.0, 0.0, 1.0])
        right = np.cross(forward, up_hint)
        right /= np.linalg.norm(right)
        up = np.cross(right, forward)
        return np.column_stack([right, up, -forward])


def back_project(depth: np.ndarray, camera: Camera) -> np.ndarray:
    """Turn a depth image into a world-frame cloud through the pinhole intrinsics.

    Args:
        depth: (height, width) distances along the optical axis (m); NaN or <= 0 for no return.
        camera: the camera that took it.

    Returns:
        (N, 3) points, one per valid pixel, row by row.
    """
    return pixel_points(depth, camera)[np.isfinite(depth) & (depth > 0)]


def pixel_points(depth: np.ndarray, camera: Camera, corner: tuple[int, int] = (0, 0)) -> np.ndarray:
    """The world point each pixel of a depth image (or of a window of it) sees, in the image's layout.

    Args:
        depth: (rows, columns) distances along the optical axis (m): the camera's whole image, or a
            window of it whose top-left pixel is ``corner``.
        camera: the camera that took it.
        corner: (row, column) of the window's first pixel in the camera's image.

    Returns:
        (rows, columns, 3) array; NaN where the depth is NaN.
    """
    rows, cols = depth.shape
    focal = camera.focal_px
    v, u = np.mgrid[corner[0]:corner[0] + rows, corner[1]:corner[1] + cols]
    # Camera frame: x right, y up, looking along -z; pixel centres at +0.5.
    camera_points = np.stack([(u + 0.5 - 0.5 * camera.width) / focal * depth,
                              -(v + 0.5 - 0.5 * camera.height) / focal * depth, -depth], axis=-1)
    with np.errstate(invalid="ignore"):  # NaN depths stay NaN
        return camera_points @ camera.axes().T + np.asarray(camera.position)
