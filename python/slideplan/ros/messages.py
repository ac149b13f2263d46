"""Numpy to and from the standard ROS 2 messages the nodes exchange: organized depth clouds
(``sensor_msgs/PointCloud2``), joint trajectories (``trajectory_msgs/JointTrajectory``), poses and the
plan's markers (``visualization_msgs/MarkerArray``)."""

from __future__ import annotations

import numpy as np
from builtin_interfaces.msg import Duration
from geometry_msgs.msg import Point, Pose, PoseStamped, Quaternion
from sensor_msgs.msg import PointCloud2, PointField
from std_msgs.msg import ColorRGBA, Header
from trajectory_msgs.msg import JointTrajectory, JointTrajectoryPoint
from visualization_msgs.msg import Marker, MarkerArray

from ..errors import InputError
from ..transforms import matrix_from_quaternion, quaternion_from_matrix

WORLD_FRAME = "world"
_FLOAT32 = PointField.FLOAT32


def cloud_message(points: np.ndarray, header: Header) -> PointCloud2:
    """An organized cloud: ``points`` (height, width, 3) in the header's frame, NaN where a pixel has
    no return (``is_dense`` false), fields x, y, z as float32."""
    height, width, _ = points.shape
    fields = [PointField(name=name, offset=4 * index, datatype=_FLOAT32, count=1) for index, name in enumerate("xyz")]
    data = np.ascontiguousarray(points, dtype=np.float32)
    return PointCloud2(header=header, height=height, width=width, fields=fields, is_bigendian=False, point_step=12,
                       row_step=12 * width, data=data.tobytes(), is_dense=False)


def cloud_points(message: PointCloud2) -> np.ndarray:
    """The xyz of a cloud as (height, width, 3) float64, NaN kept (an unorganized cloud is height 1).

    Raises:
        InputError: no float32 x, y and z fields, a field beyond the point, rows shorter than their
            points, or a data length that does not match the layout (field ``/camera/points``).
    """
    offsets = {field.name: field for field in message.fields}
    missing = [name for name in "xyz" if name not in offsets or offsets[name].datatype != _FLOAT32]
    if missing:
        raise InputError(f"expected float32 fields x, y, z; missing or not float32: {', '.join(missing)}",
                         field="/camera/points")
    for name in "xyz":
        if offsets[name].offset + 4 > message.point_step:
            raise InputError(f"field {name} at offset {offsets[name].offset} does not fit in the point_step of "
                             f"{message.point_step} bytes", field="/camera/points")
    count = message.height * message.width
    if message.row_step < message.width * message.point_step:
        raise InputError(f"row_step {message.row_step} is less than width {message.width} x point_step "
                         f"{message.point_step}", field="/camera/points")
    if len(message.data) < (message.height - 1) * message.row_step + message.width * message.point_step:
        raise InputError(f"{len(message.data)} bytes do not hold {message.height} x {message.width} points of "
                         f"{message.point_step} bytes", field="/camera/points")
    order = ">" if message.is_bigendian else "<"
    layout = np.dtype({"names": list("xyz"), "formats": [order + "f4"] * 3,
                       "offsets": [offsets[name].offset for name in "xyz"], "itemsize": message.point_step})
    raw = np.frombuffer(message.data, dtype=np.uint8)
    if message.row_step != message.width * message.point_step:  # padded rows: drop the padding (one copy)
        raw = raw[:message.height * message.row_step].reshape(message.height, message.row_step)[:, :message.width * message.point_step]
    structured = np.ascontiguousarray(raw).reshape(-1)[:count * message.point_step].view(layout)
    return np.stack([structured[name] for name in "xyz"], axis=-1).astype(float).reshape(message.height, message.width, 3)


def duration(seconds: float) -> Duration:
    """A ``builtin_interfaces/Duration``."""
    whole = int(np.floor(seconds))
    return Duration(sec=whole, nanosec=int(round((seconds - whole) * 1e9)) % 1_000_000_000)


def seconds(value: Duration) -> float:
    """A Duration in seconds."""
    return value.sec + 1e-9 * value.nanosec


def trajectory_message(joint_names: list[str], path: np.ndarray, times: np.ndarray, header: Header,
                       velocities: np.ndarray | None = None) -> JointTrajectory:
    """A JointTrajectory of ``path`` (M, dof) at ``times`` (M,) s from the start, with velocities (M, dof)
    when given (a rest-to-rest timing's)."""
    points = []
    for index, (config, at) in enumerate(zip(np.asarray(path, dtype=float), np.asarray(times, dtype=float))):
        point = JointTrajectoryPoint(positions=config.tolist(), time_from_start=duration(float(at)))
        if velocities is not None:
            point.velocities = np.asarray(velocities[index], dtype=float).tolist()
        points.append(point)
    return JointTrajectory(header=header, joint_names=list(joint_names), points=points)


def trajectory_arrays(message: JointTrajectory, joint_names: list[str]) -> tuple[np.ndarray, np.ndarray]:
    """The path (M, dof) in ``joint_names`` order and times (M,) of a JointTrajectory.

    Raises:
        InputError: joints missing or unknown, points without one position per joint, or times
            that decrease (field ``joint_trajectory``).
    """
    names = list(message.joint_names)
    unknown, missing = sorted(set(names) - set(joint_names)), [name for name in joint_names if name not in names]
    if unknown or missing:
        raise InputError(f"joint names do not match the arm: unknown {unknown}, missing {missing}", field="joint_trajectory")
    if not message.points:
        raise InputError("no points", field="joint_trajectory")
    order = [names.index(name) for name in joint_names]
    path = []
    for index, point in enumerate(message.points):
        if len(point.positions) != len(names):
            raise InputError(f"point {index} has {len(point.positions)} positions for {len(names)} joints",
                             field="joint_trajectory")
        path.append(np.asarray(point.positions, dtype=float)[order])
    times = np.array([seconds(point.time_from_start) for point in message.points])
    if not np.all(np.isfinite(path)) or np.any(np.diff(times) < 0):
        raise InputError("positions must be finite and times non-decreasing", field="joint_trajectory")
    return np.array(path), times


def pose_message(pose: np.ndarray, header: Header) -> PoseStamped:
    """A PoseStamped of a (4, 4) pose."""
    x, y, z, w = _xyzw(pose[:3, :3])
    return PoseStamped(header=header, pose=Pose(position=Point(x=float(pose[0, 3]), y=float(pose[1, 3]), z=float(pose[2, 3])),
                                                orientation=Quaternion(x=x, y=y, z=z, w=w)))


def pose_matrix(message: PoseStamped) -> np.ndarray:
    """The (4, 4) pose of a PoseStamped."""
    position, orientation = message.pose.position, message.pose.orientation
    pose = np.eye(4)
    pose[:3, :3] = matrix_from_quaternion([orientation.x, orientation.y, orientation.z, orientation.w])
    pose[:3, 3] = (position.x, position.y, position.z)
    return pose


def _xyzw(rotation: np.ndarray) -> tuple[float, float, float, float]:
    x, y, z, w = (float(value) for value in quaternion_from_matrix(rotation))
    return x, y, z, w


def _points(xyz) -> list[Point]:
    return [Point(x=float(x), y=float(y), z=float(z)) for x, y, z in np.asarray(xyz, dtype=float)]


def _marker(header: Header, marker_id: int, namespace: str, kind: int, rgba, scale: tuple[float, float, float],
            points=None, pose: np.ndarray | None = None) -> Marker:
    marker = Marker(header=header, ns=namespace, id=marker_id, type=kind, action=Marker.ADD,
                    color=ColorRGBA(r=rgba[0], g=rgba[1], b=rgba[2], a=rgba[3]))
    marker.scale.x, marker.scale.y, marker.scale.z = scale
    marker.pose.orientation.w = 1.0
    if pose is not None:
        marker.pose = pose_message(pose, header).pose
    if points is not None:
        marker.points = _points(points)
    return marker


def plan_markers(result, header: Header) -> MarkerArray:
    """The plan in RViz: the table outline, the object now and at its planned final pose (outlines of
    their clouds' hulls, on the object's top), the fingertip path (a LINE_STRIP) and the grasp frame
    (x, y, z arrows, red, green, blue)."""
    import shapely

    markers = []
    height = float(result.table["height"])
    polygon = np.asarray(result.table["polygon"], dtype=float)
    ring = np.vstack([polygon, polygon[:1]])
    markers.append(_marker(header, 0, "table", Marker.LINE_STRIP, (0.55, 0.45, 0.35, 1.0), (0.005, 0, 0),
                           np.column_stack([ring, np.full(len(ring), height)])))
    top = height + float(result.object["thickness"])
    for marker_id, (namespace, xy, rgba) in enumerate(
            (("object_now", np.asarray(result.object["points"])[:, :2], (0.2, 0.5, 0.8, 1.0)),
             ("object_planned", result.moved_object_xy(), (0.2, 0.8, 0.3, 1.0))), start=1):
        hull = np.asarray(shapely.MultiPoint(xy).convex_hull.exterior.coords)
        markers.append(_marker(header, marker_id, namespace, Marker.LINE_STRIP, rgba, (0.004, 0, 0),
                               np.column_stack([hull, np.full(len(hull), top)])))
    tips = np.asarray(result.fingertip_poses)[:, :3]
    markers.append(_marker(header, 3, "fingertip_path", Marker.LINE_STRIP, (0.9, 0.3, 0.2, 1.0), (0.003, 0, 0), tips))
    if result.solved:
        from ..transforms import row_to_pose

        grasp = row_to_pose(result.grasp["pose"])
        for axis, rgba in enumerate(((1.0, 0, 0, 1.0), (0, 1.0, 0, 1.0), (0, 0, 1.0, 1.0))):
            start = grasp[:3, 3]
            markers.append(_marker(header, 4 + axis, "grasp_frame", Marker.ARROW, rgba, (0.005, 0.01, 0.01),
                                   np.vstack([start, start + 0.06 * grasp[:3, axis]])))
    return MarkerArray(markers=markers)
