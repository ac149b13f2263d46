"""Small rigid-transform helpers (numpy only): quaternions, roll-pitch-yaw, 4x4 poses.

Plan files store poses as ``[x, y, z, qx, qy, qz, qw]`` rows (scalar-last quaternions,
``qw >= 0``); these functions convert between that form and 4x4 homogeneous matrices.
"""

from __future__ import annotations

import math

import numpy as np


def quaternion_from_matrix(rotation) -> np.ndarray:
    """Convert a rotation matrix to a unit quaternion.

    Args:
        rotation: (3, 3) rotation matrix (a 4x4 pose is accepted; its rotation block is used).

    Returns:
        (4,) array ``[qx, qy, qz, qw]`` with ``qw >= 0`` (each rotation has one such form,
        up to the sign ambiguity at ``qw = 0``).
    """
    r = np.asarray(rotation, dtype=float)[:3, :3]
    trace = r[0, 0] + r[1, 1] + r[2, 2]
    # Shepperd's method: divide by the largest of the four candidate terms, which keeps
    # the result accurate for every rotation (the trace alone fails near 180 degrees).
    if trace > max(r[0, 0], r[1, 1], r[2, 2]):
        s = 2.0 * math.sqrt(1.0 + trace)
        q = [(r[2, 1] - r[1, 2]) / s, (r[0, 2] - r[2, 0]) / s, (r[1, 0] - r[0, 1]) / s, 0.25 * s]
    elif r[0, 0] >= r[1, 1] and r[0, 0] >= r[2, 2]:
        s = 2.0 * math.sqrt(1.0 + r[0, 0] - r[1, 1] - r[2, 2])
        q = [0.25 * s, (r[0, 1] + r[1, 0]) / s, (r[0, 2] + r[2, 0]) / s, (r[2, 1] - r[1, 2]) / s]
    elif r[1, 1] >= r[2, 2]:
        s = 2.0 * math.sqrt(1.0 + r[1, 1] - r[0, 0] - r[2, 2])
        q = [(r[0, 1] + r[1, 0]) / s, 0.25 * s, (r[1, 2] + r[2, 1]) / s, (r[0, 2] - r[2, 0]) / s]
    else:
        s = 2.0 * math.sqrt(1.0 + r[2, 2] - r[0, 0] - r[1, 1])
        q = [(r[0, 2] + r[2, 0]) / s, (r[1, 2] + r[2, 1]) / s, 0.25 * s, (r[1, 0] - r[0, 1]) / s]
    quaternion = np.array(q) / np.linalg.norm(q)
    return -quaternion if quaternion[3] < 0 else quaternion


def quaternion_wxyz(rotation) -> np.ndarray:
    """:func:`quaternion_from_matrix` scalar first, ``[qw, qx, qy, qz]`` (MuJoCo's and viser's order)."""
    x, y, z, w = quaternion_from_matrix(rotation)
    return np.array([w, x, y, z])


def matrix_from_quaternion(quaternion) -> np.ndarray:
    """Convert a quaternion to a rotation matrix.

    Args:
        quaternion: ``[qx, qy, qz, qw]``, any non-zero norm (it is normalised).

    Returns:
        (3, 3) rotation matrix.

    Raises:
        ValueError: a zero or non-finite quaternion.
    """
    q = np.asarray(quaternion, dtype=float)
    norm = np.linalg.norm(q)
    if not np.isfinite(norm) or norm == 0.0:
        raise ValueError(f"not a rotation quaternion: {q.tolist()}")
    x, y, z, w = q / norm
    return np.array(
        [
            [1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
            [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
            [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)],
        ]
    )


def pose_to_row(pose) -> np.ndarray:
    """Convert a 4x4 pose to the plan-file form.

    Args:
        pose: (4, 4) homogeneous matrix.

    Returns:
        (7,) array ``[x, y, z, qx, qy, qz, qw]``.
    """
    pose = np.asarray(pose, dtype=float)
    return np.concatenate([pose[:3, 3], quaternion_from_matrix(pose)])


def row_to_pose(row) -> np.ndarray:
    """Convert a plan-file pose ``[x, y, z, qx, qy, qz, qw]`` to a 4x4 matrix.

    Args:
        row: 7 numbers.

    Returns:
        (4, 4) homogeneous matrix.

    Raises:
        ValueError: not 7 numbers, or a zero quaternion.
    """
    row = np.asarray(row, dtype=float)
    if row.shape != (7,):
        raise ValueError(f"expected [x, y, z, qx, qy, qz, qw], got shape {row.shape}")
    return homogeneous(matrix_from_quaternion(row[3:]), row[:3])


def homogeneous(rotation, translation) -> np.ndarray:
    """Assemble a 4x4 pose.

    Args:
        rotation: (3, 3) rotation matrix.
        translation: (3,) translation.

    Returns:
        (4, 4) homogeneous matrix.
    """
    pose = np.eye(4)
    pose[:3, :3] = rotation
    pose[:3, 3] = translation
    return pose


def rotation_from_rpy(roll: float, pitch: float, yaw: float) -> np.ndarray:
    """Rotation of URDF's ``rpy`` convention: ``Rz(yaw) @ Ry(pitch) @ Rx(roll)``.

    Args:
        roll, pitch, yaw: angles (rad) about the fixed x, y and z axes, applied in that order.

    Returns:
        (3, 3) rotation matrix.
    """
    cr, sr = math.cos(roll), math.sin(roll)
    cp, sp = math.cos(pitch), math.sin(pitch)
    cy, sy = math.cos(yaw), math.sin(yaw)
    return np.array(
        [
            [cy * cp, cy * sp * sr - sy * cr, cy * sp * cr + sy * sr],
            [sy * cp, sy * sp * sr + cy * cr, sy * sp * cr - cy * sr],
            [-sp, cp * sr, cp * cr],
        ]
    )


def rotation_angle_between(first, second) -> float:
    """Angle (rad, in [0, pi]) of the rotation taking ``first`` to ``second`` (3x3 or 4x4 inputs)."""
    relative = np.asarray(first, dtype=float)[:3, :3].T @ np.asarray(second, dtype=float)[:3, :3]
    return math.acos(min(1.0, max(-1.0, 0.5 * (np.trace(relative) - 1.0))))


def rotation_vector(rotation) -> np.ndarray:
    """The rotation as axis times angle (rad, angle in [0, pi]), from its unit quaternion."""
    quaternion = quaternion_from_matrix(rotation)
    sine = float(np.linalg.norm(quaternion[:3]))
    return quaternion[:3] * (2.0 * math.atan2(sine, quaternion[3]) / sine) if sine > 1e-12 else 2.0 * quaternion[:3]


def wrap_angle(angle: float) -> float:
    """Map an angle to [-pi, pi)."""
    return (angle + math.pi) % (2.0 * math.pi) - math.pi


def yawed_pose(center, yaw: float) -> np.ndarray:
    """4x4 pose at ``center`` rotated by ``yaw`` about the world z axis (how boxes are placed)."""
    return homogeneous(rotation_from_rpy(0.0, 0.0, yaw), center)


def rotation_2d(yaw: float) -> np.ndarray:
    """The (2, 2) rotation ``R(yaw)`` of the plane."""
    cos_yaw, sin_yaw = math.cos(yaw), math.sin(yaw)
    return np.array([[cos_yaw, -sin_yaw], [sin_yaw, cos_yaw]])


def move_planar(xy, motion) -> np.ndarray:
    """Apply a planar motion (Eq. 2) to points: ``R(yaw) p + (x, y)``.

    Args:
        xy: (N, 2) points, or one (2,) point.
        motion: (x, y, yaw).

    Returns:
        The moved points, in the shape of ``xy``.
    """
    x, y, yaw = (float(value) for value in motion)
    return np.asarray(xy, dtype=float) @ rotation_2d(yaw).T + (x, y)


def compose_planar(first, then) -> tuple[float, float, float]:
    """The planar motion ``then`` after ``first`` (both Eq. 2's ``(x, y, yaw)``): ``move_planar(p, result)
    == move_planar(move_planar(p, first), then)``."""
    x, y = move_planar(np.asarray(first[:2], dtype=float), then)
    return float(x), float(y), float(first[2]) + float(then[2])


def contact_angles(pose: np.ndarray) -> tuple[float, float, float]:
    """Yaw, pitch and roll of a fingertip pose relative to the horizontal surface (docs/design.md 3).

    Args:
        pose: (4, 4) or (3, 3) pose of the contact frame ``F``.

    Returns:
        ``(yaw, pitch, roll)``: yaw = atan2(X_F.y, X_F.x), pitch = asin(-Z_F.z),
        roll = asin(X_F.z) (rad).
    """
    rotation = np.asarray(pose)[:3, :3]
    x_axis, z_axis = rotation[:, 0], rotation[:, 2]
    return (
        math.atan2(x_axis[1], x_axis[0]),
        math.asin(max(-1.0, min(1.0, -z_axis[2]))),
        math.asin(max(-1.0, min(1.0, x_axis[2]))),
    )


def planar_motion(first_pose: np.ndarray, last_pose: np.ndarray) -> tuple[float, float, float]:
    """Eq. 2 restricted to SE(2): the planar motion taking one contact frame to another.

    Args:
        first_pose, last_pose: (4, 4) fingertip poses.

    Returns:
        ``(x, y, yaw)`` such that ``R(yaw) p + (x, y)`` maps the first frame's xy (and its
        X_F heading) onto the last one's.
    """
    yaw = wrap_angle(contact_angles(last_pose)[0] - contact_angles(first_pose)[0])
    x, y = last_pose[:2, 3] - rotation_2d(yaw) @ first_pose[:2, 3]
    return float(x), float(y), yaw
